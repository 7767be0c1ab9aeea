"""fair_shape on real shells and solids: valid, closed, connected, within tolerance."""

import numpy as np
import pytest
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.TopAbs import TopAbs_SHELL, TopAbs_SOLID
from OCP.TopExp import TopExp_Explorer

from cq_fairing.errors import InvalidInputError
from cq_fairing.occ import (
    face_to_surface,
    fair_face,
    fair_shape,
    list_faces,
    read_shape,
    write_shape,
)
from cq_fairing.occ.convert import indexed_faces
from tests.occ.helpers import area, compound, faces_of, volume


def count(shape, kind):
    ex, n = TopExp_Explorer(shape, kind), 0
    while ex.More():
        n += 1
        ex.Next()
    return n


@pytest.fixture(scope="module")
def linkrods_result(real):
    """linkrods faired face by face: with its joins held (the default) every B-spline face
    is kept, its joins running across it (tests/occ/test_joint.py)."""
    calls = []
    result = fair_shape(real("linkrods.step"), tol=5e-3, joins="free",
                        progress=lambda done, total, rep: calls.append((done, total)))
    return result, calls


def test_linkrods_stays_a_valid_closed_solid(real, linkrods_result):
    result, calls = linkrods_result
    source = real("linkrods.step")
    assert result.valid and BRepCheck_Analyzer(result.shape).IsValid()
    assert result.shape.ShapeType() == source.ShapeType()
    assert count(result.shape, TopAbs_SOLID) == count(source, TopAbs_SOLID) == 1
    assert result.free_edges_before == result.free_edges_after == 0
    assert volume(result.shape) == pytest.approx(volume(source), rel=5e-3)
    assert result.max_gap <= 5e-3
    assert calls[-1] == (37, 37) and len(calls) == 37


def test_linkrods_every_bspline_face_is_faired_or_explained(real, linkrods_result):
    result, _ = linkrods_result
    infos = list_faces(real("linkrods.step"))
    statuses = {r.status for r in result.faces}
    assert statuses <= {"faired", "unchanged", "skipped-not-bspline", "failed"}
    for report, info in zip(result.faces, infos):
        if not info.is_bspline:
            assert report.status == "skipped-not-bspline"
        elif report.faired:
            assert report.max_deviation <= 5e-3
        else:
            assert report.message
    assert sum(r.faired for r in result.faces) >= 12


def test_linkrods_step_written_and_read_back(tmp_path, linkrods_result):
    result, _ = linkrods_result
    out = tmp_path / "linkrods_faired.step"
    write_shape(result.shape, out)
    back = read_shape(out)
    assert len(faces_of(back)) == len(faces_of(result.shape)) == 37
    # the STEP reader recomputes pcurves from the 3-D edge curves, which sit within the
    # edge tolerance (<= the gap) of the faired surfaces: trims move by that much
    assert volume(back) == pytest.approx(volume(result.shape), rel=1e-3)
    assert area(back) == pytest.approx(area(result.shape), rel=1e-3)
    # every faired face of the written model lies on the read-back model
    for report in result.faces:
        if report.faired:
            dist = BRepExtrema_DistShapeShape(report.face, back)
            assert dist.IsDone() and dist.Value() < 1e-6


def test_testtoler_shell_stays_one_connected_shell(real):
    source = real("testtoler.brep")
    tol = 5.0
    result = fair_shape(source, tol=tol, density=60)  # default density is 2k+1 (slower)
    assert result.valid
    assert count(result.shape, TopAbs_SHELL) == count(source, TopAbs_SHELL) == 1
    assert result.free_edges_after == result.free_edges_before
    assert result.max_gap <= tol
    faired = [r for r in result.faces if r.faired]
    assert len(faired) >= 8
    assert all(r.max_deviation <= tol for r in faired)
    assert sum(np.prod(r.poles_after) for r in faired) < 0.5 * sum(
        np.prod(r.poles_before) for r in faired)


def test_ring_through_fair_shape_stays_closed(real):
    result = fair_shape(real("ring_nurbs.brep"), tol=0.1)
    assert result.valid and result.faces[0].faired
    assert result.free_edges_after == 0
    assert result.max_gap < 1e-9  # the seam is closed


def test_face_selection_and_errors(real):
    source = real("IEA_15MW_CFD.stp")
    alone = fair_shape(source, tol=0.01, faces=[1], joins="free")
    assert [r.status for r in alone.faces] == ["skipped-not-selected", "faired",
                                               "skipped-not-selected"]
    assert alone.valid
    # face 2 is half of a surface whose other half (face 3) is not selected: fairing it
    # would open their join, so by default it is kept, and says so
    held = fair_shape(source, tol=0.01, faces=[1])
    assert [r.status for r in held.faces] == ["skipped-not-selected", "unchanged",
                                              "skipped-not-selected"]
    assert "[3] run across its surface" in held.faces[1].message
    with pytest.raises(InvalidInputError, match="out of range"):
        fair_shape(source, faces=[3])
    with pytest.raises(InvalidInputError):
        fair_shape(source, progress="yes")
    with pytest.raises(InvalidInputError):
        fair_shape("not a shape")


def test_impeller_subset_keeps_a_validcompound(real):
    """Every ninth impeller face (31 faces; the full 277-face run takes ~3 min)."""
    source = real("impeller.igs")
    chosen = list(range(0, 277, 9))
    result = fair_shape(source, tol=0.05, faces=chosen, joins="free")
    assert result.valid
    assert result.free_edges_after == result.free_edges_before
    for report in result.faces:
        if report.faired:
            assert report.max_deviation <= 0.05
    assert sum(r.faired for r in result.faces) >= 10
    held = fair_shape(source, tol=0.05, faces=chosen)   # joins held: fewer faces faired,
    assert held.valid and held.joins.summary()["max_gap_opened"] <= 1e-9 * 300.0
    kept = [r for r in held.faces if r.status == "unchanged" and r.index in chosen]
    assert all(r.message for r in kept)
    assert sum("run across its surface" in r.message for r in kept) >= 5


# -- worker processes: jobs and a per-face time limit (G2) ---------------------------------
def _wiggly(seed, nu=16, nv=14):
    from tests.reliability.test_occ_inputs import bspline_surface, face_of

    return face_of(bspline_surface(nu, nv, wiggle=0.01, seed=seed))


def test_two_jobs_give_the_same_result_as_one(real):
    """Four faces (a rational trimmed face of linkrods among them) faired serially and in
    two worker processes: the same statuses, bit-identical nets, the same gaps."""
    from cq_fairing.occ.convert import indexed_faces

    rational = indexed_faces(real("linkrods.step"))[9]
    shape = compound(_wiggly(0), rational, _wiggly(1), _wiggly(2))
    serial = fair_shape(shape, tol=5e-3)
    calls = []
    parallel = fair_shape(shape, tol=5e-3, jobs=2,
                          progress=lambda done, total, rep: calls.append((done, total)))
    assert sum(r.faired for r in serial.faces) >= 3
    assert [r.status for r in parallel.faces] == [r.status for r in serial.faces]
    for one, two in zip(serial.faces, parallel.faces):
        assert one.message == two.message and one.poles_after == two.poles_after
        if one.faired:
            assert np.array_equal(one.surface.poles, two.surface.poles)
            assert one.max_deviation == two.max_deviation
            assert BRepCheck_Analyzer(two.face).IsValid()
    assert parallel.max_gap == serial.max_gap and parallel.valid == serial.valid
    assert sorted(calls) == [(k, 4) for k in range(1, 5)]


def test_a_face_over_the_time_limit_is_kept_and_its_worker_killed(real):
    """The 312 x 323 terrain face takes far longer than 3 s; next to it two small faces
    finish.  The terrain face is reported failed and kept, its worker is gone."""
    import multiprocessing
    import time

    from cq_fairing.occ.convert import indexed_faces

    terrain = indexed_faces(real("terrain.brep"))[0]
    shape = compound(_wiggly(0), terrain, _wiggly(1))
    start = time.perf_counter()
    result = fair_shape(shape, tol=2.0, jobs=2, face_timeout=3.0)
    assert time.perf_counter() - start < 60
    first, slow, last = result.faces
    assert first.status == last.status == "faired"
    assert slow.status == "failed"
    assert slow.message == "time limit 3 s exceeded; kept the original"
    assert slow.original.IsSame(terrain) and slow.face.IsSame(terrain)
    assert result.valid and result.n_faired == 2
    assert multiprocessing.active_children() == []


def test_a_face_whose_worker_dies_twice_is_kept_and_reported(real):
    """The terrain face (far longer than 5 s) in a worker process: the worker is killed
    5 s after it started, the face runs again in a fresh one, which is killed too.  The
    face is reported failed and kept, the shape stays valid, no worker is left."""
    import multiprocessing
    import threading
    import time

    from cq_fairing.occ.convert import indexed_faces

    terrain = indexed_faces(real("terrain.brep"))[0]
    shape = compound(terrain, _wiggly(0))
    killed = []

    def kill_twice():
        while len(killed) < 2:
            workers = [p for p in multiprocessing.active_children() if p.pid not in killed]
            if workers:
                time.sleep(5.0)
                workers[0].kill()
                killed.append(workers[0].pid)
            time.sleep(0.05)

    killer = threading.Thread(target=kill_twice, daemon=True)
    killer.start()
    result = fair_shape(shape, tol=2.0, jobs=2, faces=[0])
    killer.join(timeout=60)
    slow = result.faces[0]
    assert len(killed) == 2
    assert slow.status == "failed"
    assert slow.message == "the worker process fairing this face died 2 times; kept the original"
    assert slow.face.IsSame(terrain) and result.valid
    assert multiprocessing.active_children() == []


@pytest.mark.parametrize("options", [dict(jobs=0), dict(jobs=1.5), dict(jobs=True),
                                     dict(face_timeout=0), dict(face_timeout=float("nan")),
                                     dict(face_timeout="10")])
def test_bad_jobs_and_time_limits_are_refused(options):
    with pytest.raises(InvalidInputError, match="jobs|face_timeout"):
        fair_shape(_wiggly(0), **options)


def test_an_engine_without_run_and_close_is_refused():
    with pytest.raises(InvalidInputError, match="engine must have run"):
        fair_shape(_wiggly(0), engine=object())


def test_faired_shell_survives_a_brep_text_round_trip(real, tmp_path):
    """testtoler face 55 (index 54) faired alone: a shared vertex's tolerance is raised to exactly
    its distance from a curve end (1.8685231246390617), which BREP's 15 digits would
    round below that distance; the settled tolerances carry a margin, so the written
    file reads back valid (``write_shape`` checks it with ``BRepCheck``)."""
    result = fair_shape(real("testtoler.brep"), tol=12.68, faces=[54])  # default tol; 0-based
    assert result.valid and result.faces[54].faired
    path = tmp_path / "faired.brep"
    write_shape(result.shape, path)
    back = read_shape(path)
    assert BRepCheck_Analyzer(back).IsValid()
    assert len(indexed_faces(back)) == 56


@pytest.fixture(scope="module")
def mirrored_strips(real):
    """testtoler faces 35 and 36 (126 x 4 poles, degree 5 x 3, mirror images of each
    other) faired adaptively at 0.01 as a shell, each face alone (``joins="free"``: the
    pcurve projection and the congruence reuse below belong to face-by-face fairing)."""
    return fair_shape(real("testtoler.brep"), tol=0.01, method="adaptive", faces=[35, 36],
                      joins="free")


def test_adaptive_strips_keep_their_shared_edge(mirrored_strips):
    """Two neighbouring testtoler strips faired adaptively at 0.01: their own knots
    slide the surfaces along the original, and with their old pcurves the shared edge
    opened 0.28 (0.57 at half the tolerance), so both were restored.  Their shared edges
    now get pcurves projected from the 3-D curve: both stay faired with fewer poles, the
    edge within tol, the shell valid."""
    result = mirrored_strips
    for index in (35, 36):
        report = result.faces[index]
        assert report.status == "faired", report.message
        assert report.surface.poles.shape[0] * report.surface.poles.shape[1] < 126 * 4
        assert report.max_deviation <= report.tolerance
    assert result.max_gap <= 0.01
    assert result.valid


def test_a_mirror_image_gets_the_mirrored_result_of_fairing_it(real, mirrored_strips):
    """Face 36 is face 35 mirrored (same knots, poles under a reflection, same trim):
    it is not faired again but gets face 35's result mirrored, which is what fairing it
    alone gives: the same net to 1e-9 of its size, the same samples' distances, and
    normals and signed distances on its own side."""
    report = mirrored_strips.faces[36]
    assert report.message == "the mirror image of face 36 (its result, computed once)"
    assert report.seconds == 0.0
    alone = fair_face(indexed_faces(real("testtoler.brep"))[36], tol=report.tolerance,
                      method="adaptive")
    size = np.ptp(alone.surface.poles.reshape(-1, 3), axis=0).max()
    np.testing.assert_allclose(report.surface.poles, alone.surface.poles, atol=1e-9 * size)
    assert report.max_deviation == pytest.approx(alone.max_deviation, rel=1e-9)
    for key in ("points", "normals"):
        np.testing.assert_allclose(report.deviation[key], alone.deviation[key],
                                   atol=1e-9 * size)
    np.testing.assert_allclose(report.deviation["signed"], alone.deviation["signed"],
                               atol=1e-9 * size)


def test_a_source_gap_is_not_charged_to_fairing(real):
    """testtoler faces 44 and 48 meet along an edge of tolerance 11.7 whose pcurves lie
    16.8 apart at the same parameter in the source itself.  A rule on the whole gap
    restored both; only what fairing opens beyond the source's gap counts."""
    result = fair_shape(real("testtoler.brep"), tol=0.01, method="adaptive", faces=[44, 48],
                        joins="free")
    assert [result.faces[i].status for i in (44, 48)] == ["faired", "faired"]
    assert result.max_gap <= 0.01
    assert max(result.gaps.values()) <= 0.01
    assert result.valid


def _with_loose_edge(shape, faces, offset):
    """A copy of ``shape`` whose edge between ``faces`` has its 3-D curve moved by
    ``offset`` across the second face, in its tangent plane at the edge's middle, and
    the tolerance to cover it: a loose edge as a careless exporter writes one."""
    from OCP.BRep import BRep_Builder, BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
    from OCP.BRepLib import BRepLib
    from OCP.GeomLProp import GeomLProp_SLProps
    from OCP.gp import gp_Vec
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    copy = BRepBuilderAPI_Copy(shape, True, False).Shape()
    targets = indexed_faces(copy)
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(copy, TopAbs_EDGE, TopAbs_FACE, emap)

    def users(i):
        return {next(k for k, f in enumerate(targets) if f.IsSame(face))
                for face in emap.FindFromIndex(i)}

    edge = next(TopoDS.Edge_s(emap.FindKey(i)) for i in range(1, emap.Extent() + 1)
                if users(i) == set(faces))
    curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
    first, last = BRep_Tool.Range_s(edge)
    middle = 0.5 * (first + last)
    uv = BRep_Tool.CurveOnSurface_s(edge, targets[faces[1]], 0.0, 0.0).Value(middle)
    normal = GeomLProp_SLProps(BRep_Tool.Surface_s(targets[faces[1]]), uv.X(), uv.Y(), 1,
                               1e-9).Normal()
    across = gp_Vec(normal).Crossed(curve.DN(middle, 1)).Normalized() * offset
    builder = BRep_Builder()
    builder.UpdateEdge(edge, curve.Translated(across), 1.2 * abs(offset))
    builder.Range(edge, first, last)
    BRepLib.UpdateTolerances_s(copy, False)
    return copy


def test_a_gap_that_halving_the_tolerance_does_not_shrink_is_closed_at_once(real):
    """testtoler face 40 with its edge to face 35 loosened: the 3-D curve 0.05 off both
    faces (tolerance 0.06).  The adaptive face follows that curve, so the edge opens
    0.05 whatever the tolerance.  The face is kept after the first halving (the
    message names tol 0.005), not fitted twice more down to tol/8."""
    shape = _with_loose_edge(real("testtoler.brep"), (35, 40), -0.05)
    assert BRepCheck_Analyzer(shape).IsValid()
    result = fair_shape(shape, tol=0.01, method="adaptive", faces=[40], joins="free")
    report = result.faces[40]
    assert report.status == "unchanged"
    assert report.message.endswith("along a shared edge even at tol=0.005")
    assert result.max_gap <= 0.01


def test_faces_that_share_a_held_join_search_quasi_uniform_targets(real):
    """The IEA blade's three faces share their spanwise borders (spans graded 74 to 1).
    With their joins held they search quasi-uniform targets, whose knots they share
    along the joins (graded ones would differ face by face and the joins would take
    the union of both); faired alone (``joins="free"``) the two main faces get graded
    targets and fewer poles."""
    from cq_fairing.core.plans import graded_space

    shape = real("IEA_15MW_CFD.stp")
    held = fair_shape(shape)
    alone = fair_shape(shape, joins="free")
    assert [f.status for f in held.faces] == ["unchanged", "faired", "faired"]
    assert all("graded" not in f.message for f in held.faces)
    for index in (1, 2):
        source = face_to_surface(alone.faces[index].original)[0]
        faired = alone.faces[index].surface
        assert "graded like the source's knot spans" in alone.faces[index].message
        np.testing.assert_array_equal(
            faired.u_space.breakpoints,
            graded_space(source.u_space, faired.u_space.n_spans, 3).breakpoints)
        assert np.prod(faired.shape) < np.prod(held.faces[index].surface.shape)
        assert alone.faces[index].max_deviation <= alone.tolerance


def test_faces_of_a_model_of_several_keep_to_uniform_and_span_graded_targets():
    """The noisy 50 x 80 blade with free borders: faired on its own, targets graded by
    the error win (19 x 21 poles, fewer than quasi-uniform ones); as one of two faces of
    a model, faired alone (``joins="free"``), its grading ``"auto"`` is ``"spans"``
    (an error-graded net slides along its surface while its shared edges keep their
    p-curves): the net of ``fair_face(grading="spans")``, without the note."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    from OCP.gp import gp_Trsf, gp_Vec

    from cq_fairing.core.geometry import make_surface
    from cq_fairing.occ.builders import surface_to_natural_face
    from tests.freecad.face_references import NOISY, noisy_blade_net

    noisy, _, u_knots, v_knots = noisy_blade_net(*NOISY[0])
    face = surface_to_natural_face(make_surface(noisy, u_knots, v_knots, (3, 3)))
    tol = NOISY[1]
    alone = fair_face(face, tol=tol, borders="free", details=False)
    spans = fair_face(face, tol=tol, borders="free", grading="spans", details=False)
    assert "graded by the error" in alone.message and "graded by the error" not in spans.message
    assert np.prod(alone.poles_after) < np.prod(spans.poles_after)
    moved = gp_Trsf()
    moved.SetTranslation(gp_Vec(500.0, 0.0, 0.0))
    other = BRepBuilderAPI_Transform(face, moved, True).Shape()
    model = fair_shape(compound(face, other), tol=tol, borders="free", joins="free",
                       details=False)
    for report in model.faces:
        assert report.faired and "graded by the error" not in report.message
        np.testing.assert_allclose(report.surface.poles[..., 1:], spans.surface.poles[..., 1:],
                                   rtol=0, atol=1e-9)
