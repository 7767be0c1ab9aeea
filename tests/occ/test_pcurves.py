"""Pcurves (cq_fairing.occ.pcurves): evaluated many parameters at a time, and projected
from an edge's 3-D curve, checked by OCCT's own evaluation of the curves and the new
surface."""

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

from cq_fairing.occ import fair_face
from cq_fairing.occ.convert import indexed_faces, to_geom_surface
from cq_fairing.occ.pcurves import pcurve_points, projected_pcurve


@pytest.fixture(scope="module")
def strip(real):
    """testtoler face 40 faired adaptively at 0.01 (76 x 5 poles from 126 x 4), and its
    edge to face 35 (tolerance 1e-7: the 3-D curve lies on both faces)."""
    shape = real("testtoler.brep")
    faces = indexed_faces(shape)
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, emap)
    edge = next(TopoDS.Edge_s(emap.FindKey(i)) for i in range(1, emap.Extent() + 1)
                if {next(k for k, f in enumerate(faces) if f.IsSame(g))
                    for g in emap.FindFromIndex(i)} == {35, 40})
    report = fair_face(faces[40], tol=0.01, method="adaptive")
    assert report.status == "faired"
    return TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD)), faces[40], report


def _track_distances(edge, pcurve, surface, first, last, count=401):
    """``|C(t) - S(c(t))|`` at ``count`` parameters, the 3-D curve by OCCT."""
    curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
    out = []
    for t in np.linspace(first, last, count):
        uv = pcurve.Value(float(t))
        out.append(curve.Value(float(t)).Distance(surface.Value(uv.X(), uv.Y())))
    return np.array(out)


@pytest.fixture(scope="module")
def projection(strip):
    """``(edge, old pcurve, new pcurve, new surface, first, last, face report)``."""
    edge, face, report = strip
    surface = to_geom_surface(report.surface)
    old = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
    first, last = BRep_Tool.Range_s(edge, face)
    new = projected_pcurve(edge, old, first, last, surface)
    return edge, old, new, surface, first, last, report


def test_projected_pcurve_follows_the_3d_curve_where_the_old_one_slid(projection):
    edge, old, new, surface, first, last, report = projection
    kept = _track_distances(edge, old, surface, first, last)
    projected = _track_distances(edge, new, surface, first, last)
    # the old pcurve on the new surface slides along it, far beyond the face's tolerance
    assert kept.max() > 5 * report.tolerance
    # the projection stays within the face's two-sided deviation of the curve, at 401
    # parameters between and on the 8-per-span samples it interpolates
    assert projected.max() <= report.max_deviation
    assert projected[0] < 1e-9 and projected[-1] < 1e-9


def test_projected_pcurve_keeps_the_edge_range(projection):
    edge, old, new, surface, first, last, _ = projection
    assert (new.FirstParameter(), new.LastParameter()) == pytest.approx((first, last))
    # a range that is not the 3-D curve's: no projection, the caller keeps the old one
    assert projected_pcurve(edge, old, first, 0.5 * (first + last), surface) is None


def test_an_edge_without_a_3d_curve_keeps_its_pcurve(projection):
    """Nothing to project: ``None``, and ``replace_surface`` keeps the old pcurve."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
    from OCP.ShapeBuild import ShapeBuild_Edge

    edge, old, _, surface, first, last, _ = projection
    bare = TopoDS.Edge_s(BRepBuilderAPI_Copy(edge, True, False).Shape())
    ShapeBuild_Edge().RemoveCurve3d(bare)
    assert BRep_Tool.Curve_s(bare, 0.0, 0.0) is None
    assert projected_pcurve(bare, old, first, last, surface) is None


@pytest.mark.parametrize("name", ["linkrods.step", "impeller.igs", "testtoler.brep"])
def test_pcurve_points_are_occts_values(real, name):
    """Every p-curve of every face of the model (B-spline curves, lines and trimmed
    curves), evaluated by ``pcurve_points`` at 17 parameters over its edge's range:
    OCCT's ``Geom2d_Curve::Value`` at each, to round-off of the face's parameter box
    (a B-spline's parameters clamped into its domain, which an edge's range may pass by
    round-off: linkrods has one 1e-9 beyond)."""
    from OCP.BRepTools import BRepTools
    from OCP.TopExp import TopExp_Explorer

    kinds = set()
    for face in indexed_faces(real(name)):
        u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
        scale = max(abs(u0), abs(u1), abs(v0), abs(v1), u1 - u0, v1 - v0)
        edges = TopExp_Explorer(face, TopAbs_EDGE)
        while edges.More():
            edge = TopoDS.Edge_s(edges.Current())
            curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            edges.Next()
            if curve is None:
                continue
            kinds.add(type(curve).__name__)
            first, last = BRep_Tool.Range_s(edge, face)
            t = np.linspace(first, last, 17)
            basis = curve.BasisCurve() if hasattr(curve, "BasisCurve") else curve
            at = (np.clip(t, basis.FirstParameter(), basis.LastParameter())
                  if type(basis).__name__ == "Geom2d_BSplineCurve" else t)
            expected = np.array([curve.Value(float(s)).Coord() for s in at])
            np.testing.assert_allclose(pcurve_points(curve)(t), expected, rtol=0,
                                       atol=1e-12 * scale)
    assert "Geom2d_BSplineCurve" in kinds or "Geom2d_Line" in kinds
