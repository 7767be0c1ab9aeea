"""Joins held against faces faired alone, in the same run.

1. The synthetic 2 x 2 grid of ``cq_fairing.core.examples.patch_grid`` (noisy patches of
   one surface) faired onto quasi-uniform bicubic targets by ``fair_patches``: alone,
   G0, G1 and G2; and merged into one surface on as many poles per patch, cut back into its
   patches (what ``fair_shape`` does with a grid that forms a whole model); and faired
   as a network by energy on the sources' own spaces (``fair_network``, what
   ``fair_shape`` does with faces at their coarsest); gap and normal angle at 101
   samples per join, deviation as the largest distance to the source at equal
   parameters (41 x 41 per patch), curvature sign changes along 16 lines across joins.
2. Whole models faired with joins held (``joins="smooth"``, the default) against each
   face alone (``joins="free"``): time, faces faired, poles, every join's gap and
   normal angle measured by projection both ways (``ShapeFairResult.joins``), the edges
   and vertices whose tolerance rose above the source's, and the
   curvature sign changes along curves across the smooth joins, source and faired
   (:func:`crossing_sign_changes`).

   Each model is faired once untimed both ways, then ``--rounds`` times in alternation
   (held, then free): the time is the median of its rounds, and the ratio of the two
   medians is what the issue's "at most 2x face by face" compares (machines are noisy;
   both ways share each round's conditions).

    python benchmarks/bench_joins.py [--rounds 3]   # grid; fuselage 2.5, testtoler 0.01,
                                                    # shell_patches 0.083 (its default),
                                                    # linkrods 0.01, impeller 0.2 (its default)
    python benchmarks/bench_joins.py --models testtoler   # those models only, no grid
"""

import argparse
import statistics
import time
from pathlib import Path

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedMapOfShape

from cq_fairing.core.examples import patch_grid
from cq_fairing.core.joins import JointPatch, fair_patches
from cq_fairing.core.network import fair_network
from cq_fairing.core.patch_grid import merge_grid, split_grid
from cq_fairing.core.patch_layout import find_grids
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.occ import read_shape
from cq_fairing.occ.builders import surface_to_natural_face
from cq_fairing.occ.convert import face_to_surface, indexed_faces
from cq_fairing.occ.shapes import fair_shape

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
FLAT = 1e-9   # second differences below this x the model's largest are round-off
CASES = (("fuselage.brep", 2.5), ("testtoler.brep", 0.01), ("shell_patches.brep", 0.083),
         ("linkrods.step", 0.01), ("impeller.igs", 0.2))


def model_rows(name, tol, rounds):
    """The held and the free row of one model, each timed as the median of ``rounds``
    runs in alternation after one untimed run each, and the ratio of the medians."""
    shape = read_shape(DATA / name)
    times = {joins: [] for joins in ("smooth", "free")}
    results = {joins: fair_shape(shape, tol=tol, joins=joins) for joins in times}
    for _ in range(rounds):
        for joins in times:
            start = time.perf_counter()
            results[joins] = fair_shape(shape, tol=tol, joins=joins)
            times[joins].append(time.perf_counter() - start)
    medians = {joins: statistics.median(t) for joins, t in times.items()}
    rows = [row(name, tol, joins, shape, results[joins], medians[joins]) for joins in times]
    return rows, medians["smooth"] / medians["free"]


def row(name, tol, joins, shape, result, seconds):
    """One table row of ``result``, ``fair_shape(shape, tol=tol, joins=joins)``."""
    s = result.joins.summary()
    poles = sum(r.poles_after[0] * r.poles_after[1] for r in result.faces if r.poles_after)
    worst = max(((r.max_deviation or 0.0) for r in result.faces if r.faired), default=0.0)
    crossing = result.joins.adjacency.joins
    return (f"| {name} | {tol:g} | {joins} | {seconds:.2f} | {result.n_faired} | {poles} | "
            f"{s['held']}/{s['joins']} | {s['max_gap_opened']:.2g} | "
            f"{s['max_angle_excess']:.3f} | {worst / tol:.2f} | {result.valid} | "
            f"{raised_tolerances(shape, result.shape)} | "
            f"{crossing_sign_changes(shape, crossing)} -> "
            f"{crossing_sign_changes(result.shape, crossing)} |")


def raised_tolerances(source, faired):
    """``"e / v (largest rise)"``: how many edges and vertices of ``faired`` have a larger
    tolerance than the same sub-shape of ``source`` (the faired shape is a copy: its
    edges and vertices come in the same order)."""
    counts, largest = [], 0.0
    for kind, tolerance in ((TopAbs_EDGE, lambda x: BRep_Tool.Tolerance_s(TopoDS.Edge_s(x))),
                            (TopAbs_VERTEX,
                             lambda x: BRep_Tool.Tolerance_s(TopoDS.Vertex_s(x)))):
        before, after = (_tolerances(shape, kind, tolerance) for shape in (source, faired))
        rise = after - before
        counts.append(int(np.count_nonzero(rise > 0)))
        largest = max(largest, float(rise.max(initial=0.0)))
    return f"{counts[0]} / {counts[1]}" + (f" ({largest:.2g})" if largest > 0 else "")


def _tolerances(shape, kind, tolerance):
    found = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, kind, found)
    return np.array([tolerance(found.FindKey(i)) for i in range(1, found.Extent() + 1)])


def crossing_sign_changes(shape, joins, samples=41):
    """Normal-curvature sign changes along curves that cross the smooth joins between two
    B-spline faces (:func:`crossing_curves`): second differences below 1e-3 of the
    largest on their curve ignored, and below :data:`FLAT` times the largest over all
    the curves (a flat curve's round-off)."""
    curves = crossing_curves(shape, joins, samples)
    if not curves:
        return 0
    floor = FLAT * max(np.abs(d2).max() for d2 in curves)
    return sum(sign_changes_along(d2, floor) for d2 in curves)


def crossing_curves(shape, joins, samples=41):
    """Per smooth join between two B-spline faces' whole sides, at a quarter, half and
    three quarters along it: the iso-line of each face across it, from its far side to
    the join and on into the other face; the second differences of its points projected
    on the surfaces' normals."""
    faces = indexed_faces(shape)
    curves = []
    for join in joins:
        if join.kind != "smooth" or any(s.side is None or not s.full for s in join.sides):
            continue
        a, b = join.sides
        for t in (0.25, 0.5, 0.75):
            first = _across(face_to_surface(faces[a.face])[0], a, t, samples)
            second = _across(face_to_surface(faces[b.face])[0], b, t, samples)
            points = np.concatenate([first[0], second[0][::-1][1:]])
            normals = np.concatenate([first[1], second[1][::-1][1:]])
            curves.append(np.einsum("ij,ij->i", np.diff(points, 2, axis=0), normals[1:-1]))
    return curves


def sign_changes_along(d2, floor):
    """Sign changes of ``d2`` where it is above 1e-3 of its largest and above ``floor``."""
    signs = np.sign(d2[np.abs(d2) > max(1e-3 * np.nanmax(np.abs(d2)), floor)])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def _across(surface, side, t, samples):
    """Points and unit normals (signs aligned with the first) along the iso-line across
    ``side`` at the fraction ``t`` of its edge, from the far side to the border."""
    (u0, u1), (v0, v1) = surface.domain
    along = side.along[0] + t * (side.along[1] - side.along[0])
    across = np.linspace(0.0, 1.0, samples)
    if side.side[0] == "u":
        u = (u1 + (u0 - u1) * across) if side.side[1] == "0" else (u0 + (u1 - u0) * across)
        grid = [(u, [along])]
    else:
        v = (v1 + (v0 - v1) * across) if side.side[1] == "0" else (v0 + (v1 - v0) * across)
        grid = [([along], v)]
    point, du, dv = (surface.evaluate_grid(*grid[0], nu, nv).reshape(samples, 3)
                     for nu, nv in ((0, 0), (1, 0), (0, 1)))
    normal = np.cross(du, dv)
    with np.errstate(invalid="ignore"):   # a collapsed border has no normal: NaN, skipped
        normal /= np.linalg.norm(normal, axis=1)[:, None]
    return point, normal * np.sign(normal @ normal[0])[:, None]


def _border(surface, side, t):
    """Points and unit normals along a side at normalised parameters ``t``."""
    (u0, u1), (v0, v1) = surface.domain
    if side[0] == "u":
        u, v = [u0 if side[1] == "0" else u1], v0 + (v1 - v0) * t
    else:
        u, v = u0 + (u1 - u0) * t, [v0 if side[1] == "0" else v1]
    point, du, dv = (surface.evaluate_grid(u, v, nu, nv).reshape(len(t), 3)
                     for nu, nv in ((0, 0), (1, 0), (0, 1)))
    normal = np.cross(du, dv)
    return point, normal / np.linalg.norm(normal, axis=1)[:, None]


def grid_row(label, surfaces, grid):
    t = np.linspace(0.0, 1.0, 101)
    gap = angle = 0.0
    for join in grid.joins:
        pa, na = _border(surfaces[join.a], join.side_a, t)
        pb, nb = _border(surfaces[join.b], join.side_b, 1 - t if join.reversed else t)
        gap = max(gap, np.linalg.norm(pa - pb, axis=1).max())
        cos = np.clip(np.abs(np.sum(na * nb, axis=1)), 0.0, 1.0)
        angle = max(angle, np.degrees(np.arccos(cos)).max())
    g = np.linspace(0.0, 1.0, 41)
    deviation = max(np.linalg.norm(s.evaluate_grid(g, g) - p.evaluate_grid(g, g), axis=2).max()
                    for s, p in zip(surfaces, grid.patches))
    return (f"| {label} | {gap:.2g} | {angle:.3f} | {deviation:.4f} | "
            f"{sign_changes(surfaces)} |")


def sign_changes(surfaces, samples=201):
    """Curvature sign changes along 16 iso-parameter lines that cross the joins: second
    differences of z (the grid is a height field), below 1e-3 of the largest ignored.
    Each line runs through two patches (patch 3 has u along y)."""
    t = np.linspace(0.0, 1.0, samples)
    count = 0
    for c in (0.2, 0.45, 0.7, 0.9):
        s0, s1, s2, s3 = surfaces
        lines = (
            (s0.evaluate_grid(t, [c])[:, 0], s1.evaluate_grid(t[::-1], [c])[:, 0]),
            (s2.evaluate_grid(t, [c])[:, 0], s3.evaluate_grid([c], t)[0]),
            (s0.evaluate_grid([c], t)[0], s2.evaluate_grid([c], t)[0]),
            (s1.evaluate_grid([1 - c], t)[0], s3.evaluate_grid(t, [c])[:, 0]))
        for first, second in lines:
            d2 = np.diff(np.concatenate([first, second[1:]])[:, 2], 2)
            signs = np.sign(d2[np.abs(d2) > 1e-3 * np.abs(d2).max()])
            count += int(np.count_nonzero(signs[1:] != signs[:-1]))
    return count


def synthetic():
    grid = patch_grid()
    print("| grid, targets | max gap | max normal angle (deg) | deviation | "
          "curvature sign changes |")
    print("|---|---|---|---|---|")
    print(grid_row("source (12 x 12 each)", grid.patches, grid))
    for n in (4, 6):
        target = SplineSpace.quasi_uniform(n, 3)
        patches = [JointPatch(p, (target, target)) for p in grid.patches]
        alone = [fair_patches([p], []).surfaces[0] for p in patches]
        print(grid_row(f"{n + 3} x {n + 3}, alone", alone, grid))
        for continuity in ("G0", "G1", "G2"):
            result = fair_patches(patches, grid.joins, continuity=continuity)
            print(grid_row(f"{n + 3} x {n + 3}, {continuity}", result.surfaces, grid))
        print(grid_row(f"{2 * n + 3} x {2 * n + 3} merged, cut into 4", _merged(grid, 2 * n),
                       grid))
    for tol in (0.005, 0.01):
        network = fair_network(grid.patches, grid.joins, tol)
        print(grid_row(f"12 x 12, network by energy, tol {tol:g}", network.surfaces, grid))
    for tol in (0.005, 0.01):
        faired = _fair_shell(grid, tol)
        print(grid_row(f"fair_shape (default) on the sewn shell, tol {tol:g}: "
                       f"{' / '.join(f'{s.shape[0]} x {s.shape[1]}' for s in faired)}",
                       faired, grid))


def _fair_shell(grid, tol):
    """The grid as an OCCT shell (its faces sewn) faired by ``fair_shape`` with the
    defaults (its joins turn by up to 16 deg in the source: smooth below 20); the faired
    surfaces in patch order."""
    sewing = BRepBuilderAPI_Sewing(1e-5)
    for patch in grid.patches:
        sewing.Add(surface_to_natural_face(patch))
    sewing.Perform()
    shell = sewing.SewedShape()
    order = [int(np.argmin([np.abs(face_to_surface(f)[0].poles - p.poles).max()
                            if face_to_surface(f)[0].shape == p.shape else np.inf
                            for f in indexed_faces(shell)])) for p in grid.patches]
    faired = indexed_faces(fair_shape(shell, tol=tol, angle_tol=20.0).shape)
    return [face_to_surface(faired[k])[0] for k in order]


def _merged(grid, n):
    """The grid merged into one surface, projected onto n x n spans with its patch
    borders pinned, cut back into its patches in their own orientations."""
    block = find_grids(grid.patches, grid.joins)[0]
    merged = merge_grid([[c.to_grid(grid.patches[c.patch]) for c in column]
                         for column in block.cells], tol=1e-6)
    (u0, u1), (v0, v1) = merged.surface.domain
    pieces = split_grid(merged, merged.pinned_projection(
        SplineSpace.quasi_uniform(n, 3, (u0, u1)), SplineSpace.quasi_uniform(n, 3, (v0, v1))))
    out = [None] * len(grid.patches)
    for i, column in enumerate(block.cells):
        for j, cell in enumerate(column):
            out[cell.patch] = cell.from_grid(pieces[i][j])
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3,
                        help="timed runs per model and way, in alternation (default 3)")
    parser.add_argument("--models", nargs="*", default=None,
                        help="words of the model file names to run, without the grid "
                             "(default: the grid and every model)")
    args = parser.parse_args()
    if args.models is None:
        synthetic()
        print()
    print("| model | tol | joins | s | faces faired | poles | joins held | largest gap "
          "opened | largest smooth-join angle excess (deg) | worst deviation / tol | valid | "
          "edge / vertex tolerances raised (largest rise) | "
          "curvature sign changes across smooth joins, source -> faired |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    ratios = []
    for name, tol in CASES:
        if args.models is not None and not any(word in name for word in args.models):
            continue
        rows, ratio = model_rows(name, tol, args.rounds)
        print("\n".join(rows), flush=True)
        ratios.append(f"{name} {ratio:.2f}x")
    print(f"\ntime held / face by face (medians of {args.rounds} rounds): "
          + ", ".join(ratios))


if __name__ == "__main__":
    main()
