"""Peers on the same work: compactness, fidelity, fairness and speed at one tolerance.

Run:  python benchmarks/bench_peers.py [--quick] [--repeat 3] [--out benchmarks/results/peers.md]

Cases (same inputs and tolerance for every method):

* ``seed curve``: eq. 15 of Ji et al. 2014, 1300 noisy points (sigma 0.002 mm), tol 0.02 mm,
  noise-free truth (``cq_fairing.core.examples.seed_curve``).
* ``blade 50x80`` / ``blade 400x400``: noisy blade-like surface on a 50 mm span
  (``blade_surface(span=50, chord=15, noise=0.01)``), tol 0.02 and 0.05 mm, truth kept.
* real faces from ``tests/data`` and ``examples/data`` (IEA 15 MW blade, terrain, an
  impeller blade and a rational impeller fillet, testtoler strips) with ``tol = rel *
  bounding-box diagonal``: the point fitters get the
  face sampled on a grid, our methods fair the face's net (``face_to_surface``).

Per method: control points, max two-sided closest-point deviation from the input geometry
(the interpolant of the points / the face's surface; ``ok`` if within tol), RMS and max
distance to the truth, geometric fairness (``int (dk/ds)^2 ds`` along the curve or summed
over 2 x 21 iso-lines, ``int k^2 ds`` / ``int k1^2 + k2^2 dA``, curvature range, curvature
extrema), median wall time of up to ``--repeat`` runs (one when a run takes over 2 s) including each method's own search for the
setting that meets tol, and the tracemalloc peak (Python-side allocations only: memory
that OCCT and FITPACK allocate in C/C++ is not seen).
"""

import argparse
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from peers.fitters import METHODS, Case  # noqa: E402
from peers.measure import curve_fairness, surface_fairness, to_truth, two_sided  # noqa: E402

from cq_fairing.core import examples  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"  # bundled models, sources and licences in SOURCES.md there

# point fitters that are too slow for big inputs are skipped above these point counts
LIMITS = {"geomdl approximate": 2000, "OCCT variational": 6000, "ours energy (EH)": 6000}
# rows that differ from another row on surfaces only (curves have no border rows)
SURFACE_ONLY = {"ours wavelet adaptive free"}


def seed_case():
    s = examples.seed_curve()
    u = np.linspace(0.0, 1.0, len(s.points))
    return Case("seed curve (1300 pts)", "curve", s.points, (u,), s.curve, 0.02, s.truth)


def blade_case(shape, tol):
    b = examples.blade_surface(shape, noise=0.01, span=50.0, chord=15.0)
    u = np.linspace(0.0, 1.0, shape[0])
    v = np.linspace(0.0, 1.0, shape[1])
    return Case(f"blade {shape[0]}x{shape[1]}", "surface", b.points, (u, v), b.surface, tol,
                b.truth)


def face_case(label, path, index, rel, grid=None):
    from cq_fairing.occ import face_to_surface, read_shape
    from cq_fairing.occ.convert import indexed_faces

    face = indexed_faces(read_shape(path))[index]
    surface, _ = face_to_surface(face)
    ku, kv = surface.poles.shape[:2]
    nu, nv = grid or (int(np.clip(2 * ku, 30, 200)), int(np.clip(2 * kv, 30, 200)))
    (ulo, uhi), (vlo, vhi) = surface.domain
    u, v = np.linspace(ulo, uhi, nu), np.linspace(vlo, vhi, nv)
    pts = surface.evaluate_grid(u, v)
    diag = float(np.linalg.norm(pts.reshape(-1, 3).max(0) - pts.reshape(-1, 3).min(0)))
    tol = rel * diag
    return Case(f"{label} ({ku}x{kv} net, {nu}x{nv} pts)", "surface", pts, (u, v), surface,
                tol)


def cases(quick, big):
    out = [seed_case(), blade_case((50, 80), 0.02), blade_case((50, 80), 0.05)]
    if quick:
        return out
    iea = REPO / "examples" / "data" / "IEA_15MW_CFD.stp"
    out += [face_case("IEA blade main face", iea, *_longest(iea), 1e-4),
            face_case("impeller blade face", DATA / "impeller.igs", *_impeller_blade(), 1e-4),
            face_case("impeller fillet", DATA / "impeller.igs", *_impeller_fillet(), 1e-4),
            face_case("testtoler strip", DATA / "testtoler.brep", *_longest(DATA / "testtoler.brep"), 1e-4)]
    if big:
        out += [blade_case((400, 400), 0.05),
                face_case("terrain", DATA / "terrain.brep", 0, 2e-3, grid=(160, 160))]
    return out


def _impeller_blade():
    """First 17x13 bicubic non-rational impeller face (a blade)."""
    from cq_fairing.occ import face_to_surface, read_shape
    from cq_fairing.occ.convert import indexed_faces

    for i, face in enumerate(indexed_faces(read_shape(DATA / "impeller.igs"))):
        try:
            s, _ = face_to_surface(face)
        except Exception:  # noqa: BLE001 - non-B-spline faces are skipped by design
            continue
        if s.poles.shape[:2] == (17, 13) and not s.is_rational:
            return (i,)
    raise LookupError("no 17x13 blade face in impeller.igs")


def _impeller_fillet():
    """First 50 x 3 rational impeller face of degree 3 x 2: a fillet whose section is a
    circular arc (one rational quadratic span), its u knots strongly graded."""
    from cq_fairing.occ import face_to_surface, read_shape
    from cq_fairing.occ.convert import indexed_faces

    for i, face in enumerate(indexed_faces(read_shape(DATA / "impeller.igs"))):
        try:
            s, _ = face_to_surface(face)
        except Exception:  # noqa: BLE001 - non-B-spline faces are skipped by design
            continue
        if s.poles.shape[:2] == (50, 3) and s.is_rational:
            return (i,)
    raise LookupError("no 50x3 rational fillet in impeller.igs")


def _longest(path):
    """Index of the face with the most poles (a degree-5 strip of testtoler)."""
    from cq_fairing.occ import face_to_surface, read_shape
    from cq_fairing.occ.convert import indexed_faces

    sizes = [np.prod(face_to_surface(f)[0].poles.shape[:2]) for f in indexed_faces(read_shape(path))]
    return (int(np.argmax(sizes)),)


def run(method, case, repeat):
    """Result, median wall time of untraced runs (more than one only while a run takes
    under 2 s) and the tracemalloc peak of one extra traced run (``None`` when a run
    takes over 20 s: tracing would double a long benchmark)."""
    times, result = [], None
    while len(times) < repeat:
        start = time.perf_counter()
        result = METHODS[method](case)
        times.append(time.perf_counter() - start)
        if times[-1] > 2.0:
            break
    peak = None
    if times[0] < 20.0:
        tracemalloc.start()
        METHODS[method](case)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
    return result, statistics.median(times), peak


def measure(case, geometry):
    samples = 20000 if case.kind == "curve" else 250_000
    dev = two_sided(case.source, geometry, case.kind, samples)
    truth = to_truth(case.truth, geometry, case.kind, samples) if case.truth is not None else None
    fair = curve_fairness(geometry) if case.kind == "curve" else surface_fairness(geometry)
    return dev, truth, fair


def n_poles(g):
    return g.poles.shape[0] if g.poles.ndim == 2 else g.poles.shape[0] * g.poles.shape[1]


def shape(g):
    if g.poles.ndim == 2:
        return f"{g.poles.shape[0]} (p{g.degree})"
    return f"{g.poles.shape[0]}x{g.poles.shape[1]} (p{g.u_degree}x{g.v_degree})"


def _fairness(case, geometry):
    """The fairness columns of one geometry in words (the input line's reference values:
    a fit with fewer extrema than the noise-free truth has smoothed shape away)."""
    f = curve_fairness(geometry) if case.kind == "curve" else surface_fairness(geometry)
    return (f"fairness int(dk/ds)^2 {f['dk2']:.3g}, bending {f['bending']:.3g}, curvature "
            f"{f['kmin']:.3g}..{f['kmax']:.3g}, extrema {f['extrema']}")


HEADER = ("| method | poles | setting | max dev | ok | truth RMS | truth max | int(dk/ds)^2 | "
          "bending | curvature range | extrema | time s | peak MB |")


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="seed curve and blade 50x80 only")
    parser.add_argument("--big", action="store_true",
                        help="also the 400x400 blade and the terrain (slow: minutes per method)")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path)
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--cases", nargs="*", help="only cases whose name starts with one of these")
    args = parser.parse_args()
    lines = [f"Command: `python benchmarks/bench_peers.py {' '.join(sys.argv[1:])}`", ""]

    def emit(text):
        print(text, flush=True)
        lines.append(text)
        if args.out:
            args.out.parent.mkdir(parents=True, exist_ok=True)
            args.out.write_text("\n".join(lines) + "\n")

    for case in cases(args.quick, args.big):
        if args.cases and not any(case.name.startswith(c) for c in args.cases):
            continue
        n_pts = case.points.reshape(-1, 3).shape[0]
        emit(f"\n### {case.name}, tol {case.tol:.4g}\n")
        truth = "" if case.truth is None else f"; noise-free truth {_fairness(case, case.truth)}"
        emit(f"Input: {n_pts} points; source net {shape(case.source)}; source "
             f"{_fairness(case, case.source)}{truth}.\n")
        emit(HEADER)
        emit("|" + "---|" * 13)
        for method in args.methods:
            if case.kind == "curve" and method in SURFACE_ONLY:
                continue
            if n_pts > LIMITS.get(method, 10 ** 9):
                emit(f"| {method} | skipped: more than {LIMITS[method]} points (too slow) "
                     "| | | | | | | | | | | |")
                continue
            repeat = args.repeat if n_pts <= 6000 else 1
            try:
                (geometry, setting), seconds, peak = run(method, case, repeat)
            except Exception as exc:  # noqa: BLE001 - a peer's failure is a result to report
                message = " ".join(str(exc).split())[:100]
                emit(f"| {method} | failed: {type(exc).__name__}: {message} "
                     "| | | | | | | | | | | |")
                continue
            dev, truth, fair = measure(case, geometry)
            t_rms, t_max = ("-", "-") if truth is None else (f"{truth[0]:.4f}", f"{truth[1]:.4f}")
            emit(f"| {method} | {n_poles(geometry)} = {shape(geometry)} | {setting} | "
                 f"{dev:.4g} | {'yes' if dev <= case.tol else 'NO'} | {t_rms} | {t_max} | "
                 f"{fair['dk2']:.3g} | {fair['bending']:.3g} | "
                 f"{fair['kmin']:.3g}..{fair['kmax']:.3g} | {fair['extrema']} | "
                 f"{seconds:.3f} | {'-' if peak is None else f'{peak / 2 ** 20:.1f}'} |")


if __name__ == "__main__":
    main()
