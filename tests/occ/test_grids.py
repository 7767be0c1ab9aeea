"""Patch grids faired as one surface (occ.grids), on a sewn shell of the noisy 2 x 2
grid of ``core.examples.patch_grid``: measured with OCCT's own evaluation and
projection, against the same shell faired face by face, and against the core's merge of
the example called directly (``tests/core/patch_references``, which the FreeCAD
workbench's result is compared with too)."""

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_Sewing
from OCP.Geom import Geom_BSplineSurface, Geom_Line
from OCP.GeomAPI import GeomAPI_IntCS
from OCP.gp import gp_Dir, gp_Pnt
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

from cq_fairing.core.examples import patch_grid
from cq_fairing.occ.convert import face_to_surface
from cq_fairing.occ.shapes import fair_shape
from tests.core.patch_references import grid_pieces, matching

from .helpers import faces_of, global_distance, occ_points, uv_box_grid

TOL = 0.01
ANGLE_TOL = 20.0   # the noisy joins turn by up to 16 deg: smooth ones, for this model


def _occ_face(surface):
    """A face on a core surface, built with OCCT directly."""
    ku, kv = surface.shape
    poles = TColgp_Array2OfPnt(1, ku, 1, kv)
    for i in range(ku):
        for j in range(kv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*map(float, surface.poles[i, j])))
    arrays = []
    for knots in (surface.u_knots, surface.v_knots):
        values, counts = np.unique(knots, return_counts=True)
        k, m = TColStd_Array1OfReal(1, len(values)), TColStd_Array1OfInteger(1, len(values))
        for n, (value, count) in enumerate(zip(values, counts), 1):
            k.SetValue(n, float(value))
            m.SetValue(n, int(count))
        arrays += [k, m]
    geom = Geom_BSplineSurface(poles, arrays[0], arrays[2], arrays[1], arrays[3],
                               surface.u_degree, surface.v_degree)
    return BRepBuilderAPI_MakeFace(geom, 1e-7).Face()


@pytest.fixture(scope="module")
def shell():
    sewing = BRepBuilderAPI_Sewing(1e-5)
    for patch in patch_grid().patches:
        sewing.Add(_occ_face(patch))
    sewing.Perform()
    return sewing.SewedShape()


@pytest.fixture(scope="module")
def runs(shell):
    return {joins: fair_shape(shell, tol=TOL, joins=joins, angle_tol=ANGLE_TOL)
            for joins in ("smooth", "free")}


def test_the_grid_is_found_and_faired_as_one_surface(runs):
    result = runs["smooth"]
    assert [g.shape for g in result.joins.grids] in ([(2, 2)],)
    assert sorted(result.joins.grids[0].faces) == [0, 1, 2, 3]
    assert all(report.faired for report in result.faces) and result.valid
    assert "2 x 2 patch grid" in result.faces[0].message
    assert "1 patch grids (4 faces)" in result.joins.line()


def test_the_pieces_are_the_core_merge_of_the_example_faired_and_cut(shell, runs):
    order = matching([face_to_surface(f)[0].poles for f in faces_of(shell)],
                     patch_grid().patches)
    reference = grid_pieces(TOL)
    for report, k in zip(runs["smooth"].faces, order):
        assert report.surface.shape == reference[k].shape
        assert np.array_equal(report.surface.u_knots, reference[k].u_knots)
        assert np.array_equal(report.surface.v_knots, reference[k].v_knots)
        assert np.abs(report.surface.poles - reference[k].poles).max() <= 1e-9 * 2.0


def test_every_face_stays_within_tolerance_both_ways(shell, runs):
    for original, faired in zip(faces_of(shell), faces_of(runs["smooth"].shape)):
        for a, b in ((original, faired), (faired, original)):
            u, v = uv_box_grid(a, 15, 15)
            points = occ_points(a, u, v).reshape(-1, 3)
            assert global_distance(points, b).max() <= 1.02 * TOL


def test_joins_close_to_round_off_and_turn_less_than_a_hundredth_of_a_degree(runs):
    summary = runs["smooth"].joins.summary()
    assert summary["joins"] == 4 and summary["held"] == 4
    assert summary["max_gap"] <= 1e-9 * 2 * np.sqrt(2)
    assert summary["source_max_smooth_angle"] > 0.5      # the noisy source kinks
    assert summary["max_smooth_angle"] <= 0.01


def test_fairing_as_one_surface_removes_curvature_wiggles_across_the_joins(shell, runs):
    source, merged, alone = (_sign_changes(s) for s in
                             (shell, runs["smooth"].shape, runs["free"].shape))
    print(f"curvature sign changes: source {source}, faired as one {merged}, "
          f"face by face {alone}")
    assert merged < alone < source


def _sign_changes(shape, samples=400):
    """Curvature sign changes of a shell along the lines x = c and y = c that cross the
    joins: second differences of z where vertical lines meet it (OCCT), signs below
    1e-3 of the largest ignored."""
    faces = faces_of(shape)
    count = 0
    t = np.linspace(0.02, 1.98, samples)
    for c in (0.3, 0.65, 1.35, 1.7):
        for xy in (np.stack([np.full_like(t, c), t], 1), np.stack([t, np.full_like(t, c)], 1)):
            z = [_height(faces, x, y) for x, y in xy]
            d2 = np.diff(z, 2)
            signs = np.sign(d2[np.abs(d2) > 1e-3 * np.abs(d2).max()])
            count += int(np.count_nonzero(signs[1:] != signs[:-1]))
    return count


def _height(faces, x, y):
    """z where the vertical line through (x, y) meets the shell (OCCT's intersection)."""
    line = Geom_Line(gp_Pnt(float(x), float(y), -10.0), gp_Dir(0.0, 0.0, 1.0))
    for face in faces:
        hits = GeomAPI_IntCS(line, BRep_Tool.Surface_s(face))
        if hits.NbPoints():
            return hits.Point(1).Z()
    raise AssertionError(f"no face above ({x}, {y})")
