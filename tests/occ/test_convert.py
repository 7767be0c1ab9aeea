"""Control nets out of OCP faces and back: checked against OCCT's own evaluation."""

from collections import Counter

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_Copy,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_NurbsConvert,
)
from OCP.BRepCheck import BRepCheck_Analyzer
from OCP.BRepLib import BRepLib
from OCP.BRepTools import BRepTools
from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
from OCP.TopoDS import TopoDS

from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.errors import InvalidInputError, UnsupportedGeometryError
from cq_fairing.occ import face_to_surface, list_faces, surface_to_face
from cq_fairing.occ.convert import (
    COORDINATE_MARGIN,
    TEXT_MARGIN,
    Tolerances,
    finish_edges,
    indexed_faces,
    replace_surface,
    settle_tolerances,
    to_geom_surface,
)
from tests.occ.helpers import (
    area,
    brep_round_trip,
    edges_of,
    faces_of,
    occ_points,
    tolerances,
    uv_box_grid,
    vertex_reaches,
    vertices_of,
)

MODELS = ["terrain.brep", "IEA_15MW_CFD.stp", "impeller.igs", "testtoler.brep",
          "ring_nurbs.brep", "linkrods.step"]


@pytest.mark.parametrize("name", MODELS)
def test_net_evaluates_like_occt_on_every_bspline_face(real, name):
    """Core evaluation of the extracted net == BRepAdaptor_Surface, 1e-9 relative."""
    shape = real(name)
    checked = 0
    for face, info in zip(faces_of(shape), list_faces(shape)):
        if not info.is_bspline:
            continue
        surface, _ = face_to_surface(face)
        u, v = uv_box_grid(face)
        expected = occ_points(face, u, v)
        scale = max(np.abs(expected).max(), 1.0)
        np.testing.assert_allclose(surface.evaluate_grid(u, v), expected, rtol=0,
                                   atol=1e-9 * scale)
        checked += 1
    assert checked == sum(i.is_bspline for i in list_faces(shape)) > 0


@pytest.mark.parametrize("name", ["linkrods.step", "IEA_15MW_CFD.stp", "ring_nurbs.brep",
                                  "testtoler.brep"])
def test_surface_to_face_round_trip_keeps_trim_and_geometry(real, name):
    shape = real(name)
    for face, info in zip(faces_of(shape), list_faces(shape)):
        if not info.is_bspline:
            continue
        surface, _ = face_to_surface(face)
        rebuilt = surface_to_face(surface, face)
        assert BRepCheck_Analyzer(rebuilt).IsValid()
        np.testing.assert_allclose(BRepTools.UVBounds_s(rebuilt), BRepTools.UVBounds_s(face),
                                   atol=1e-9)
        assert area(rebuilt) == pytest.approx(area(face), rel=1e-7)
        u, v = uv_box_grid(face)
        np.testing.assert_allclose(occ_points(rebuilt, u, v), occ_points(face, u, v),
                                   atol=1e-9 * max(1.0, np.abs(occ_points(face, u, v)).max()))


def test_rebuilt_edges_span_exactly_their_range(real):
    """The terrain face on a cubic net of 217 x 282 equal spans over its domain
    ([82100, 89825] x [80300, 88300], spans of 28.37 that no binary fraction holds):
    OCCT's rebuilt boundary curves would end up to 2e-9 short of their edges' ranges,
    which BRepCheck rejects (InvalidRange above 1e-9).  They span the ranges exactly, the
    face is valid and evaluates like the net."""
    from OCP.BRep import BRep_Tool

    from cq_fairing import BSplineSurface

    face, = faces_of(real("terrain.brep"))
    source, _ = face_to_surface(face)

    def clamped(lo, hi, spans):
        return np.r_[[lo] * 3, np.linspace(lo, hi, spans + 1), [hi] * 3]

    u_knots, v_knots = clamped(*source.domain[0], 217), clamped(*source.domain[1], 282)
    greville = [np.convolve(k[1:-1], np.ones(3) / 3, "valid") for k in (u_knots, v_knots)]
    surface = BSplineSurface(source.evaluate_grid(*greville), u_knots, v_knots, 3, 3)
    rebuilt = surface_to_face(surface, face)
    assert BRepCheck_Analyzer(rebuilt).IsValid()
    for edge in edges_of(rebuilt):
        curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
        assert (curve.FirstParameter(), curve.LastParameter()) == BRep_Tool.Range_s(edge)
    u, v = uv_box_grid(rebuilt)
    np.testing.assert_allclose(occ_points(rebuilt, u, v), surface.evaluate_grid(u, v),
                               rtol=0, atol=1e-9 * np.abs(surface.poles).max())


def test_inventory_matches_sources_md(real):
    infos = list_faces(real("linkrods.step"))
    assert Counter(i.surface_type for i in infos) == {"Torus": 9, "Cylinder": 4, "Plane": 6,
                                                      "BSpline": 18}
    bspline = [i for i in infos if i.is_bspline]
    assert sum(i.rational for i in bspline) == 16
    assert all(i.trimmed and i.in_solid for i in bspline)
    assert Counter((i.u_degree, i.v_degree) for i in bspline) == {(6, 10): 6, (6, 8): 6,
                                                                 (6, 3): 4, (3, 1): 2}
    iea = list_faces(real("IEA_15MW_CFD.stp"))
    assert sorted((i.n_poles_u, i.n_poles_v, i.u_degree, i.v_degree) for i in iea)[-1] == \
        (17, 204, 3, 8)
    assert sum(i.trimmed for i in iea) == 2 and not any(i.in_solid for i in iea)
    ring, = list_faces(real("ring_nurbs.brep"))
    assert ring.u_periodic and ring.v_periodic and not ring.trimmed
    imp = list_faces(real("impeller.igs"))
    assert Counter(i.surface_type for i in imp) == {"BSpline": 247, "Revolution": 30}
    assert sum(i.rational for i in imp) == 212
    shell = list_faces(real("testtoler.brep"))
    assert len(shell) == 56 and not any(i.trimmed or i.rational for i in shell)


def test_periodic_face_is_unperiodized_and_stays_closed(real):
    face, = faces_of(real("ring_nurbs.brep"))
    surface, info = face_to_surface(face)
    assert info.unperiodized == ("u", "v")
    assert surface.poles.shape == (16, 51, 3)
    assert surface.u_knots[0] == surface.u_knots[5] and surface.u_knots[-1] == surface.u_knots[-6]
    np.testing.assert_allclose(surface.poles[0], surface.poles[-1], atol=1e-12)
    np.testing.assert_allclose(surface.poles[:, 0], surface.poles[:, -1], atol=1e-12)


def test_errors_for_wrong_inputs(real):
    plane = next(f for f, i in zip(faces_of(real("linkrods.step")), list_faces(real("linkrods.step")))
                 if i.surface_type == "Plane")
    with pytest.raises(UnsupportedGeometryError, match="convert"):
        face_to_surface(plane)
    with pytest.raises(InvalidInputError, match="face"):
        face_to_surface(real("ring_nurbs.brep"))
    with pytest.raises(InvalidInputError):
        face_to_surface("not a face")
    face = faces_of(real("IEA_15MW_CFD.stp"))[1]
    surface, _ = face_to_surface(face)
    from cq_fairing import BSplineSurface

    shrunk = BSplineSurface(surface.poles, surface.u_knots / 2, surface.v_knots / 2,
                            surface.u_degree, surface.v_degree)
    with pytest.raises(InvalidInputError, match="domain"):
        surface_to_face(shrunk, face)


def test_located_face_round_trip():
    """A face moved by a TopLoc_Location: net in global coordinates, rebuilt in place."""
    import cadquery as cq

    solid = cq.Workplane().sphere(2.0).val().transformShape(cq.Matrix()).moved(
        cq.Location(cq.Vector(10, -3, 4)))
    from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert

    nurbs = BRepBuilderAPI_NurbsConvert(solid.wrapped, True).Shape()
    face = faces_of(nurbs)[0]
    surface, _ = face_to_surface(face)
    u, v = uv_box_grid(face)
    np.testing.assert_allclose(surface.evaluate_grid(u, v), occ_points(face, u, v), atol=1e-9)
    rebuilt = surface_to_face(surface, face)
    np.testing.assert_allclose(occ_points(rebuilt, u, v), occ_points(face, u, v), atol=1e-9)


def test_settled_tolerances_pad_each_edge_once_and_cover_every_curve_end(real, tmp_path):
    """A fuselage face moved 1e-5 off its edges' 3-D curves: the edges and their
    vertices need larger tolerances.  Settled with every edge listed twice (a vertex is
    shared by two edges of the face anyway), each edge tolerance is OCCT's own
    (``BRepLib::UpdateTolerances`` on an identical copy) plus one margin at most; each
    vertex covers every curve end at it (OCCT's evaluation) with no more than OCCT's
    tolerance plus one margin, and the shape reads back valid from a BREP text file."""
    source = real("fuselage.brep")
    surface, _ = face_to_surface(indexed_faces(source)[0])
    moved = BSplineSurface(surface.poles + 1e-5, surface.u_knots, surface.v_knots,
                           surface.u_degree, surface.v_degree)

    def moved_copy():
        copy = BRepBuilderAPI_Copy(source, True, False).Shape()
        before = Tolerances(copy)
        edges = replace_surface(indexed_faces(copy)[0], to_geom_surface(moved))
        finish_edges(edges)
        return copy, edges, before

    exact, _, _ = moved_copy()
    BRepLib.UpdateTolerances_s(exact, False)
    settled, edges, before = moved_copy()
    settle_tolerances(settled, edges + edges, before)
    size = np.abs(surface.poles).max() * 1.01
    raw, padded = tolerances(edges_of(exact)), tolerances(edges_of(settled))
    assert (padded > tolerances(edges_of(source))).sum() == 3   # the face's edges rose
    assert np.all(padded >= raw)
    assert np.all(padded - raw <= TEXT_MARGIN * raw + COORDINATE_MARGIN * size)
    corners = tolerances(vertices_of(settled))
    assert (corners > tolerances(vertices_of(source))).sum() == 3
    assert np.all(vertex_reaches(settled) <= corners)
    occt = tolerances(vertices_of(exact))
    assert np.all(corners <= occt + TEXT_MARGIN * occt + COORDINATE_MARGIN * size)
    assert BRepCheck_Analyzer(brep_round_trip(settled, tmp_path / "settled.brep")).IsValid()


def test_a_face_moved_whole_takes_its_vertices_along():
    """A free face's surface translated by (1e-4, -2e-4, 3e-4): its edges, rebuilt on the
    new surface, end at the moved corners, so each vertex moves with them (the centre of
    the curve ends, to round-off) and keeps its tolerance; at its old point it would
    need 3.7e-4."""
    face = BRepBuilderAPI_MakeFace(gp_Pln(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)),
                                   -1.0, 2.0, -0.5, 1.5).Face()
    face = TopoDS.Face_s(BRepBuilderAPI_NurbsConvert(face, True).Shape())
    surface, _ = face_to_surface(face)
    shift = np.array([1e-4, -2e-4, 3e-4])
    moved = BSplineSurface(surface.poles + shift, surface.u_knots, surface.v_knots,
                           surface.u_degree, surface.v_degree)
    rebuilt = surface_to_face(moved, face)
    old, new = vertices_of(face), vertices_of(rebuilt)
    np.testing.assert_allclose([_xyz(BRep_Tool.Pnt_s(v)) for v in new],
                               [_xyz(BRep_Tool.Pnt_s(v)) + shift for v in old], atol=1e-12)
    np.testing.assert_array_equal(tolerances(new), tolerances(old))
    assert np.all(vertex_reaches(rebuilt) <= 1e-12)
    assert BRepCheck_Analyzer(rebuilt).IsValid()


def _xyz(point):
    return np.array([point.X(), point.Y(), point.Z()])
