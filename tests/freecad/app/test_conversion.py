"""Part.BSplineSurface/Curve <-> core conversion, checked against OCCT's own evaluation."""

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import conversion

import fixtures


def _occ_grid(surface, u, v):
    return np.array([[tuple(surface.value(a, b)) for b in v] for a in u])


def _check_same_surface(part_surface, core_surface, count=7, rtol=1e-9):
    (u0, u1), (v0, v1) = core_surface.domain
    u, v = np.linspace(u0, u1, count), np.linspace(v0, v1, count)
    ours = core_surface.evaluate_grid(u, v)
    theirs = _occ_grid(part_surface, u, v)
    scale = np.abs(theirs).max()
    assert np.abs(ours - theirs).max() <= rtol * scale


@pytest.mark.parametrize("index", [0, 1, 2])
def test_blade_faces_evaluate_like_occt(index):
    face = fixtures.blade_shape().Faces[index]
    core = conversion.surface_from_face(face)
    assert core.shape == (face.Surface.NbUPoles, face.Surface.NbVPoles)
    assert core.u_knots.size == core.shape[0] + core.u_degree + 1
    _check_same_surface(face.Surface, core)


def test_round_trip_keeps_poles_and_knots():
    face = fixtures.blade_shape().Faces[1]
    core = conversion.surface_from_face(face)
    back = conversion.part_surface(core)
    assert back.getUKnots() == pytest.approx(face.Surface.getUKnots())
    assert back.getVMultiplicities() == face.Surface.getVMultiplicities()
    assert (back.UDegree, back.VDegree) == (3, 8)
    _check_same_surface(back, core)


def test_periodic_ring_is_converted_not_refused():
    shape = Part.Shape()
    shape.read(str(fixtures.REAL / "ring_nurbs.brep"))
    face = shape.Faces[0]
    assert face.Surface.isUPeriodic() and face.Surface.isVPeriodic()
    core = conversion.surface_from_face(face)
    _check_same_surface(face.Surface, core)
    assert core.u_knots[0] == core.u_knots[core.u_degree]  # clamped


def test_unclamped_uniform_knots_are_clamped_not_refused():
    """shell_patches.brep's patches carry uniform, unclamped knots (-3 .. 4, each once)
    on a non-periodic surface: converted to the same surface on its domain [0, 1]^2,
    clamped (one Bezier patch, 4 x 4 poles)."""
    face = Part.read(str(fixtures.REAL / "shell_patches.brep")).Faces[0]
    surface = face.Surface
    assert not (surface.isUPeriodic() or surface.isVPeriodic())
    assert surface.getUMultiplicities()[0] == 1 and surface.getUKnots()[0] == -3.0
    core = conversion.surface_from_face(face)
    assert core.domain == ((0.0, 1.0), (0.0, 1.0)) and core.shape == (4, 4)
    _check_same_surface(surface, core)


def test_rational_face_keeps_weights():
    shape = Part.read(str(fixtures.REAL / "linkrods.step"))
    face = next(f for f in shape.Faces if isinstance(f.Surface, Part.BSplineSurface)
                and f.Surface.isURational())
    core = conversion.surface_from_face(face)
    assert core.weights is not None and not np.allclose(core.weights, 1.0)
    _check_same_surface(face.Surface, core)


def test_plane_face_is_refused_with_a_clear_message():
    face = Part.makeBox(1, 1, 1).Faces[0]
    with pytest.raises(cf.UnsupportedGeometryError, match="not a B-spline surface"):
        conversion.surface_from_face(face)


def test_curve_round_trip_matches_occt():
    points = [FreeCAD.Vector(x, np.sin(x), 0.1 * np.cos(3 * x)) for x in np.linspace(0, 6, 30)]
    curve = Part.BSplineCurve()
    curve.interpolate(points)
    core = conversion.curve_from_edge(curve.toShape())
    t = np.linspace(*core.domain, 25)
    theirs = np.array([tuple(curve.value(x)) for x in t])
    assert np.abs(core.evaluate(t) - theirs).max() < 1e-10
    back = conversion.part_curve(core)
    assert np.abs(np.array([tuple(back.value(x)) for x in t]) - theirs).max() < 1e-10


def _impeller():
    shape = Part.Shape()
    shape.read(str(fixtures.REAL / "impeller.igs"))
    return shape


# QA's failures: "NULL shape" (1, 26, 28, 155), "command not done" (78, 84, 85, 91) and
# faces that only the shape fixer makes valid (180, 213)
IMPELLER_TRIMS = (1, 26, 28, 78, 84, 85, 91, 155, 180, 213)


def test_impeller_trims_rebuild_on_their_own_surface():
    """IGES trims join their edges within up to 0.15 mm: rebuilt on the unchanged
    surface, each face is valid and keeps its area and the length of its outline."""
    shape = _impeller()
    for number in IMPELLER_TRIMS:
        face = shape.Faces[number - 1]
        rebuilt = conversion.face_on_surface(face.Surface.copy(), face)
        assert rebuilt.isValid(), number
        assert rebuilt.Area == pytest.approx(face.Area, rel=1e-3), number
        outline = sum(e.Length for e in face.Edges)  # the fixer may merge or drop tiny edges
        assert sum(e.Length for e in rebuilt.Edges) == pytest.approx(outline, rel=1e-3), number


def _restriction_area_matches(face):
    """The area measure of a UV-box face: the surface restricted to the face's
    parameter box has the face's area (within 1e-6)."""
    u0, u1, v0, v1 = face.ParameterRange
    area = face.Area
    return abs(face.Surface.toShape(u0, u1, v0, v1).Area - area) <= 1e-6 * area


@pytest.mark.parametrize("name", ["impeller.igs", "testtoler.brep", "linkrods.step",
                                  "shell_patches.brep"])
def test_faces_along_their_box_sides_are_uv_boxes_by_area(name):
    """A face whose p-curves run along the sides of its UV box is recognised without
    OCCT's area integrals; OCCT's classifier puts every point of a grid over such a
    face's box on the face, and the model's other B-spline faces are answered by the
    area measure."""
    faces = [f for f in Part.read(str(fixtures.REAL / name)).Faces
             if isinstance(f.Surface, Part.BSplineSurface) and len(f.Wires) == 1]
    along = [f for f in faces if conversion._along_box_sides(f)]
    for face in along:
        u0, u1, v0, v1 = face.ParameterRange
        assert all(face.isPartOfDomain(u, v) for u in np.linspace(u0, u1, 9)[1:-1]
                   for v in np.linspace(v0, v1, 9)[1:-1])
    for face in faces:
        assert conversion.is_uv_rectangle(face) == (face in along
                                                    or _restriction_area_matches(face))


def test_a_b_spline_pcurve_along_a_side_is_a_box_side():
    """shell_patches Face28 (a collapsed border, one p-curve a B-spline along u = 1 whose
    poles all lie on that side): a UV box, so a faired surface rebuilds it from its box,
    degenerated edge included, where a rebuild from its p-curves gave an invalid face
    (the area measure misses it by 1.5e-6)."""
    face = Part.read(str(fixtures.REAL / "shell_patches.brep")).Faces[27]
    assert any(edge.Degenerated for edge in face.Edges)
    assert any(isinstance(face.curveOnSurface(edge)[0], Part.Geom2d.BSplineCurve2d)
               for edge in face.Edges)
    assert conversion.is_uv_rectangle(face) and not _restriction_area_matches(face)
    rebuilt = conversion.face_on_surface(face.Surface, face)
    assert rebuilt.isValid() and rebuilt.Area == pytest.approx(face.Area, rel=1e-5)


def test_a_face_cut_inside_its_box_is_not_a_uv_box():
    """A triangle and a disc cut out of the fixture's surface in parameter space: their
    p-curves leave the sides of their UV boxes, and they are not UV boxes."""
    surface, _ = fixtures.noisy_blade_surface(20, 30)
    whole = surface.toShape()
    (u0, u1, v0, v1) = whole.ParameterRange
    points = [FreeCAD.Base.Vector2d(u0, v0), FreeCAD.Base.Vector2d(u1, v0),
              FreeCAD.Base.Vector2d(u0, v1)]
    edges = [Part.Geom2d.Line2dSegment(a, b).toShape(surface)
             for a, b in zip(points, points[1:] + points[:1])]
    triangle = Part.Face(surface, Part.Wire(edges))
    disc = Part.Face(surface, Part.Wire(Part.Geom2d.Circle2d(
        FreeCAD.Base.Vector2d(0.5 * (u0 + u1), 0.5 * (v0 + v1)),
        0.25 * min(u1 - u0, v1 - v0)).toShape(surface)))
    for face in (triangle, disc):
        face.validate()
        assert not conversion._along_box_sides(face)
        assert not conversion.is_uv_rectangle(face)
    assert conversion._along_box_sides(whole) and conversion.is_uv_rectangle(whole)


def test_a_face_domain_answers_each_grid_as_occt_and_reads_the_trim_once():
    """:class:`conversion.FaceDomain` of a trimmed linkrods face: OCCT's
    ``isPartOfDomain`` at every sample of two grids, the same answer when a grid is
    asked again (a copy, which the caller may change) and its region the same
    classification; the fixture's whole face is its box, all samples on it, no
    region."""
    face = next(f for f in Part.read(str(fixtures.REAL / "linkrods.step")).Faces
                if isinstance(f.Surface, Part.BSplineSurface)
                and not conversion.is_uv_rectangle(f))
    domain = conversion.FaceDomain(face)
    u0, u1, v0, v1 = face.ParameterRange
    for u, v in ((np.linspace(u0, u1, 17), np.linspace(v0, v1, 13)),
                 (np.linspace(u0, u1, 9), np.linspace(v0, v1, 21))):
        occt = np.array([[face.isPartOfDomain(float(a), float(b)) for b in v] for a in u])
        first = domain.inside(u, v)
        assert np.array_equal(first, occt) and 0 < occt.sum() < occt.size
        first[:] = ~first
        assert np.array_equal(domain.inside(u, v), occt)
        assert np.array_equal(domain.region()(u, v), occt)
    assert not domain.rectangle
    whole = conversion.FaceDomain(fixtures.noisy_blade_surface(20, 30)[0].toShape())
    assert whole.rectangle and whole.region() is None
    assert whole.inside(np.linspace(0, 1, 4), np.linspace(0, 1, 3)).all()
