"""fair_shape fairs faces that meet along whole borders together: real models, measured by
the joins' own projection (cq_fairing.occ.adjacency) and by OCCT's checks."""

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepCheck import BRepCheck_Analyzer

from cq_fairing.errors import InvalidInputError
from cq_fairing.occ.shapes import fair_shape
from tests.occ.helpers import brep_round_trip, edges_of, tolerances, vertex_reaches, vertices_of


@pytest.fixture(scope="module")
def fuselage(real):
    return real("fuselage.brep")


@pytest.fixture(scope="module")
def fuselage_runs(fuselage):
    return {joins: fair_shape(fuselage, tol=2.5, joins=joins) for joins in ("smooth", "free")}


def test_fuselage_joins_stay_closed_creases_stay_creases(fuselage_runs):
    result = fuselage_runs["smooth"]
    rows = result.joins.rows()
    assert result.valid and result.n_faired >= 4
    held = [r for r in rows if r["held"]]
    assert len(held) >= 10
    assert max(r["gap"] for r in held) <= 1e-9 * 2500.0       # model size about 2500
    creases = [r for r in rows if r["kind"] == "crease"]
    assert len(creases) == 2
    assert all(abs(r["angle"] - r["source_angle"]) < 1.0 for r in creases)
    assert all(r.max_deviation <= 2.5 for r in result.faces if r.faired)


def test_fuselage_edge_and_vertex_tolerances_are_not_raised(fuselage, fuselage_runs):
    """The faired fuselage's faces meet where the source's do: no edge or vertex needs,
    or gets, a larger tolerance than the source's (the copy indexes its edges and
    vertices as the source)."""
    shape = fuselage_runs["smooth"].shape
    source, faired = tolerances(edges_of(fuselage)), tolerances(edges_of(shape))
    assert fuselage_runs["smooth"].n_faired >= 4 and faired.shape == source.shape
    assert np.all(faired <= source)
    assert np.all(tolerances(vertices_of(shape)) <= tolerances(vertices_of(fuselage)))


def test_fuselage_smooth_joins_turn_less_than_faired_alone(fuselage_runs):
    """Held joins stay closed and turn at most 0.05 deg beyond the source; faired alone
    the faces turn more (their pinned target borders keep the shared borders where both
    faces' targets agree along them, not the tangent planes across)."""
    joint = fuselage_runs["smooth"].joins.summary()
    alone = fuselage_runs["free"].joins.summary()
    assert joint["max_gap_opened"] < 1e-6
    assert joint["max_angle_excess"] <= 0.05 < alone["max_angle_excess"]


def test_faces_whose_joins_turn_near_a_vertex_get_finer_targets(fuselage_runs):
    """The fuselage's faired faces meet faces kept at their coarsest; on their own
    targets the joins turn by 0.107 deg, and their spans are halved once."""
    faired = [r for r in fuselage_runs["smooth"].faces if r.faired]
    alone = {r.index: r for r in fuselage_runs["free"].faces if r.faired}
    assert faired and all(r.index in alone for r in faired)
    assert sum(np.prod(r.poles_after) for r in faired) > \
        sum(np.prod(alone[r.index].poles_after) for r in faired)


def test_free_joins_keep_faces_alone(fuselage_runs):
    assert fuselage_runs["free"].joins.closed_edges == set()


@pytest.fixture(scope="module")
def testtoler_joint(real):
    return fair_shape(real("testtoler.brep"), tol=0.01)


def test_testtoler_joins_stay_as_closed_and_smooth_as_the_source(real, testtoler_joint):
    """Every join, held pole for pole or pinned to the source, opens by at most 1e-7 of
    the model size (12682) and turns at most 0.05 deg beyond the source; faired alone,
    the faces open their joins by 0.005 or more (above 1e-7 x size: 0.0013)."""
    joint = testtoler_joint
    alone = fair_shape(real("testtoler.brep"), tol=0.01, joins="free")
    s, f = joint.joins.summary(), alone.joins.summary()
    assert joint.valid and s["held"] >= 70 and joint.n_faired > alone.n_faired
    assert s["max_gap_opened"] <= 1e-7 * 12682.0 < 2e-3 < f["max_gap_opened"]
    assert s["max_angle_excess"] <= 0.05
    assert all(r.max_deviation <= 0.01 for r in joint.faces if r.faired)


def test_testtoler_keeps_the_source_tolerances_and_moves_its_corners(real, testtoler_joint,
                                                                    tmp_path):
    """The faired faces move their corners by up to 0.007 (the source's vertex
    tolerances are 1e-7 to 1e-4); the joins stay closed, so the edges at a corner end
    together again and the vertex moves to the middle of their ends.  No edge or vertex
    tolerance rises, each vertex covers every curve end at it (OCCT's evaluation), and
    the shape reads back valid from a BREP text file.  The edges of tolerance 4.44 at
    coordinates of 2.2e4 keep theirs: OCCT's estimate of their need rose by 2.5e-12,
    below the spacing of doubles there (3.6e-12)."""
    source, faired = real("testtoler.brep"), testtoler_joint.shape
    assert testtoler_joint.joins.summary()["max_gap_opened"] <= 1e-7 * 12682.0
    assert np.all(tolerances(edges_of(faired)) <= tolerances(edges_of(source)))
    corners = tolerances(vertices_of(faired))
    assert np.all(corners <= tolerances(vertices_of(source)))
    assert np.all(vertex_reaches(faired) <= corners)
    moves = [BRep_Tool.Pnt_s(a).Distance(BRep_Tool.Pnt_s(b))
             for a, b in zip(vertices_of(source), vertices_of(faired))]
    assert max(moves) > 1e-3
    back = brep_round_trip(faired, tmp_path / "faired.brep")
    assert BRepCheck_Analyzer(back).IsValid()
    assert np.all(vertex_reaches(back) <= tolerances(vertices_of(back)))


def test_a_join_parametrized_differently_on_each_side_keeps_the_source_gap(real):
    """testtoler's faces 41 and 45 run along their join with different parametrizations
    (at equal normalised parameters their borders are 389 apart), so no pole-for-pole
    join exists: each side is held at its source's border and tangent plane instead."""
    shell = real("testtoler.brep")
    runs = {j: fair_shape(shell, tol=0.01, joins=j, faces=[40, 44]) for j in ("smooth", "free")}
    rows = {j: [r for r in run.joins.rows() if r["faces"] == (41, 45)][0]
            for j, run in runs.items()}
    assert all(r.faired for r in runs["smooth"].faces if r.index in (40, 44))
    assert rows["smooth"]["held"] and not rows["free"]["held"]
    assert rows["smooth"]["gap"] <= rows["smooth"]["source_gap"] + 1e-9 * 12682.0
    assert rows["smooth"]["angle_excess"] <= 1e-3
    assert rows["free"]["gap"] > 10 * rows["free"]["source_gap"]


def test_rational_faces_are_joined_in_homogeneous_coordinates(real):
    """Impeller faces 191 and 192 are rational and meet along whole sides: their smooth
    join is faired once and shared (source gap 0.001, angle 0.065 deg)."""
    impeller = real("impeller.igs")
    runs = {j: fair_shape(impeller, tol=0.05, joins=j, faces=[190, 191]) for j in ("smooth", "free")}
    rows = {j: [r for r in run.joins.rows() if r["faces"] == (191, 192)][0]
            for j, run in runs.items()}
    faired = [r for r in runs["smooth"].faces if r.index in (190, 191)]
    assert all(r.faired and r.surface.is_rational and r.max_deviation <= 0.05 for r in faired)
    assert rows["smooth"]["held"] and rows["smooth"]["gap"] < 1e-6
    assert rows["smooth"]["angle"] < 1e-4
    assert rows["free"]["gap"] > 1e-3 and rows["free"]["angle"] > 0.1


def test_faces_whose_joins_run_across_them_are_kept_with_their_reason(real):
    """linkrods' faired faces all meet an analytic or trimmed neighbour along an edge that
    runs across their surfaces, where no fairing holds the join: the default keeps them
    (its joins stay as the source has them); joins="free" fairs them alone."""
    shape = real("linkrods.step")
    joint, alone = (fair_shape(shape, tol=0.01, joins=j) for j in ("smooth", "free"))
    assert alone.n_faired >= 18 and alone.joins.summary()["max_gap_opened"] > 1e-3
    kept = [r for r in joint.faces if r.status == "unchanged" and "run across" in r.message]
    assert len(kept) >= 18 and joint.valid
    assert joint.joins.summary()["max_gap_opened"] <= 1e-9


@pytest.mark.parametrize("kwargs, match", [
    (dict(joins="sealed"), "joins must be one of"),
    (dict(angle_tol=0.0), "angle_tol"),
    (dict(angle_tol=True), "angle_tol"),
])
def test_bad_join_options_are_refused(fuselage, kwargs, match):
    with pytest.raises(InvalidInputError, match=match):
        fair_shape(fuselage, tol=2.5, **kwargs)


def test_faces_touching_at_a_point_are_faired_alone_and_the_contact_is_reported():
    """The diagonal patches of the noisy 2 x 2 example grid meet at one corner only."""
    from cq_fairing.core.examples import patch_grid
    from tests.occ.helpers import compound
    from tests.occ.test_grids import _occ_face

    patches = patch_grid().patches
    shape = compound(_occ_face(patches[0]), _occ_face(patches[3]))
    result = fair_shape(shape, tol=0.01)
    summary = result.joins.summary()
    assert summary["joins"] == 0 and summary["point_contacts"] == 1
    assert result.joins.line() == "joins: none; 1 point contacts (not joined)"
    assert result.n_faired == 2 and result.valid
    assert all(r.max_deviation <= 0.01 for r in result.faces)


def test_an_edge_of_three_faces_is_reported_and_its_faces_kept_whole():
    """Three planes on one edge (a non-manifold join): nothing is joined, every face is
    still there, and the summary names the edge."""
    from tests.occ.helpers import compound, three_faces_on_one_edge

    faces, _ = three_faces_on_one_edge()
    result = fair_shape(compound(*faces), tol=0.01, convert=True)
    assert len(result.faces) == 3 and result.valid
    assert result.joins.summary()["non_manifold"] == 1
    assert result.joins.line() == "joins: none; 1 non-manifold edges (not joined)"


def test_faces_that_share_one_surface_are_faired_as_one():
    """The IEA blade's two main faces are halves of one surface (identical poles), trimmed
    along an inner iso-line: faired once for both, their smooth join stays where it was."""
    from pathlib import Path

    from cq_fairing.occ.convert import face_to_surface
    from cq_fairing.occ.io import read_shape

    blade = read_shape(Path(__file__).resolve().parents[2] / "examples/data/IEA_15MW_CFD.stp")
    result = fair_shape(blade, tol=0.001)
    smooth = [r for r in result.joins.rows() if r["kind"] == "smooth"]
    assert len(smooth) == 1 and smooth[0]["held"]
    assert smooth[0]["gap"] <= 1e-9 and smooth[0]["angle_excess"] <= 0.05
    first, second = (face_to_surface(result.faces[i].face)[0] for i in (1, 2))
    assert np.array_equal(first.poles, second.poles)
    assert first.shape[1] < 204 and all(r.max_deviation <= 0.001 for r in result.faces
                                        if r.faired)


def _grid_beside_a_plane():
    """The noise-free 2 x 2 patch grid (cq_fairing.core.examples.patch_grid) sewn with a
    planar strip along patch 0's side x = 0: the block is no whole part of the model, so
    its faces are projected jointly (not merged), patch 0's side on the plane pinned."""
    from OCP.BRepBuilderAPI import (
        BRepBuilderAPI_MakeFace,
        BRepBuilderAPI_MakePolygon,
        BRepBuilderAPI_Sewing,
    )
    from OCP.gp import gp_Pnt

    from cq_fairing.core.examples import patch_grid
    from cq_fairing.occ.builders import surface_to_natural_face

    grid = patch_grid(noise=0.0)
    sewing = BRepBuilderAPI_Sewing(1e-5)
    for patch in grid.patches:
        sewing.Add(surface_to_natural_face(patch))
    strip = BRepBuilderAPI_MakePolygon(gp_Pnt(0, 0, 0), gp_Pnt(0, 1, 0), gp_Pnt(-1, 1, 0),
                                       gp_Pnt(-1, 0, 0), True)
    sewing.Add(BRepBuilderAPI_MakeFace(strip.Wire(), True).Face())
    sewing.Perform()
    return grid, sewing.SewedShape()


def _faired_patches(result, grid):
    """The faired B-spline surfaces in the grid's patch order (matched by their centres)."""
    from cq_fairing.occ.convert import face_to_surface

    surfaces = [face_to_surface(r.face)[0] for r in result.faces
                if r.faired and r.face is not None]
    centre = [s.evaluate_grid([0.5], [0.5])[0, 0] for s in surfaces]
    return [surfaces[int(np.argmin([np.linalg.norm(c - p.evaluate_grid([0.5], [0.5])[0, 0])
                                    for c in centre]))] for p in grid.patches]


def test_curvature_joins_hold_the_normal_curvature_across():
    """joins="curvature": across the joins whose source is curvature-continuous (the
    noise-free grid's four), the faired faces have one normal curvature, as well as one
    tangent plane; with "smooth" the curvature jumps.  Next to the vertex where patch 0's
    pinned side meets a join, the G2 rows stop short (one join keeps a small jump)."""
    from cq_fairing.core.joins import cross_curvatures, holds_curvature, join_angles

    grid, shell = _grid_beside_a_plane()
    assert all(holds_curvature(grid.patches, j) for j in grid.joins)
    t = np.linspace(0.0, 1.0, 101)
    jumps = {}
    for joins in ("smooth", "curvature"):
        result = fair_shape(shell, tol=0.002, joins=joins)
        assert result.n_faired == 4 and result.valid
        assert all(r.max_deviation <= 0.002 for r in result.faces if r.faired)
        surfaces = _faired_patches(result, grid)
        assert max(join_angles(surfaces, j, t).max() for j in grid.joins) < 1e-4
        jumps[joins] = sorted(np.nanmax(np.abs(np.subtract(*cross_curvatures(surfaces, j, t))))
                              for j in grid.joins)
        if joins == "curvature":
            assert result.joins.summary()["curved"] == 4
            assert "G2 across 4" in result.joins.line()
    assert jumps["smooth"][-1] > 0.2
    assert jumps["curvature"][:3] == pytest.approx([0, 0, 0], abs=1e-6)
    assert jumps["curvature"][-1] < 0.1 * jumps["smooth"][-1]
