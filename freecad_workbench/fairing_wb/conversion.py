"""Part.BSplineSurface / Part.BSplineCurve <-> cq_fairing geometry.

FreeCAD stores distinct knots plus multiplicities; the core stores full clamped knot
vectors.  Periodic geometry, and non-periodic geometry with unclamped ("uniform") knots,
is converted to its clamped (non-periodic) equivalent with OCCT's ``setUNotPeriodic``
and ``segment`` (the same shape, more poles) before conversion, so it is handled rather
than refused.  Rational geometry keeps its weights
(all-one weights count as polynomial).  Other surface types (planes, cylinders, ...) raise
:class:`cq_fairing.UnsupportedGeometryError`: fairing applies to freeform B-splines.
"""

import functools

import FreeCAD
import numpy as np
import Part

import cq_fairing as cf

from . import trim

__all__ = ["surface_from_face", "part_surface", "curve_from_edge", "part_curve",
           "face_on_surface", "face_on_edges", "full_knots", "uv_range", "FaceDomain",
           "is_uv_rectangle", "periodic_directions"]


def full_knots(knots, mults):
    """Expand distinct knots and multiplicities into the full knot vector."""
    return np.repeat(np.asarray(knots, dtype=float), np.asarray(mults, dtype=int))


def _distinct(full):
    knots, mults = np.unique(np.round(full, 15), return_counts=True)
    return [float(k) for k in knots], [int(m) for m in mults]


def _weights_or_none(weights):
    w = np.asarray(weights, dtype=float)
    return None if np.allclose(w, 1.0, rtol=0, atol=1e-14) else w


def _clamped_surface(surface):
    """Non-periodic, clamped copy: ``setUNotPeriodic`` may leave unclamped end knots, and
    OCCT also keeps unclamped ("uniform") knot vectors on non-periodic surfaces (whose
    domain starts at the knot of index degree + 1); ``segment`` over the whole domain
    clamps them (same geometry)."""
    surface = surface.copy()
    if surface.isUPeriodic():
        surface.setUNotPeriodic()
    if surface.isVPeriodic():
        surface.setVNotPeriodic()
    if not _is_clamped(surface):
        surface.segment(*surface.bounds())
    return surface


def _is_clamped(surface):
    """True when both knot vectors start and end with multiplicity degree + 1."""
    return all(mults[0] == mults[-1] == degree + 1 for mults, degree in (
        (surface.getUMultiplicities(), surface.UDegree),
        (surface.getVMultiplicities(), surface.VDegree)))


def surface_from_face(face):
    """The face's underlying surface as a :class:`cq_fairing.BSplineSurface`.

    Returns
    -------
    cq_fairing.BSplineSurface
        Poles of shape (k_u, k_v, 3), full knot vectors, weights or ``None``.

    Raises
    ------
    cq_fairing.UnsupportedGeometryError
        If the face is not a B-spline face.
    """
    surface = face.Surface
    if not isinstance(surface, Part.BSplineSurface):
        raise cf.UnsupportedGeometryError(
            f"the face is a {type(surface).__name__}, not a B-spline surface; fairing "
            "applies to freeform (B-spline) faces only. Pick a B-spline face.")
    surface = _clamped_surface(surface)
    poles = np.array([[[p.x, p.y, p.z] for p in row] for row in surface.getPoles()])
    weights = _weights_or_none(surface.getWeights()) if (
        surface.isURational() or surface.isVRational()) else None
    return cf.make_surface(
        poles,
        full_knots(surface.getUKnots(), surface.getUMultiplicities()),
        full_knots(surface.getVKnots(), surface.getVMultiplicities()),
        (surface.UDegree, surface.VDegree), weights)


def uv_range(face, surface):
    """The face's ``(u0, u1, v0, v1)`` clipped to the core surface's domain.

    OCCT's parameter range of a trimmed face may exceed the surface domain by its
    tolerance (1e-10 or so); the core evaluates inside the domain only.
    """
    (a, b), (c, d) = surface.domain
    u0, u1, v0, v1 = face.ParameterRange
    return (min(max(u0, a), b), min(max(u1, a), b), min(max(v0, c), d), min(max(v1, c), d))


def periodic_directions(face):
    """``("u",)``, ``("v",)``, ``("u", "v")`` or ``()``: the periodic directions of the
    face's B-spline surface, which :func:`surface_from_face` unperiodizes."""
    surface = face.Surface
    return tuple(name for name, periodic in (("u", surface.isUPeriodic()),
                                             ("v", surface.isVPeriodic())) if periodic)


class FaceDomain:
    """The part of its surface's parameter plane that ``face`` covers, read from OCCT once
    for all the grids sampled on it: whether it is the face's UV box
    (:attr:`rectangle`), and otherwise its trim (:class:`fairing_wb.trim.Trim`) and the
    mask of each grid asked (a face's searches and checks ask the same grids again)."""

    def __init__(self, face):
        self.face = face
        self._trim = trim.Trim(face)
        self._masks = {}

    @functools.cached_property
    def rectangle(self):
        """:func:`is_uv_rectangle` of the face."""
        return is_uv_rectangle(self.face)

    def inside(self, u, v):
        """``(len(u), len(v))`` booleans: which grid parameters ``(u_i, v_j)`` lie on the
        face (inside its trim or on it, OCCT's ``isPartOfDomain``,
        :func:`fairing_wb.trim.on_face`); all true, without asking OCCT sample by sample,
        for a face trimmed to its UV box (or untrimmed).  A copy: the caller may change
        it."""
        u, v = np.asarray(u, float), np.asarray(v, float)
        if self.rectangle:
            return np.ones((len(u), len(v)), dtype=bool)
        key = (u.tobytes(), v.tobytes())
        if key not in self._masks:
            self._masks[key] = self._trim.on_face(u, v)
        return self._masks[key].copy()

    def region(self):
        """The core's ``region(u, v)`` of the face (:meth:`inside` of any grid), or
        ``None`` for a face trimmed to its UV box (or untrimmed), which its UV box, the
        core's ``window``, bounds."""
        return None if self.rectangle else self.inside


def part_surface(surface):
    """A ``Part.BSplineSurface`` from a :class:`cq_fairing.BSplineSurface` (clamped)."""
    uk, um = _distinct(surface.u_knots)
    vk, vm = _distinct(surface.v_knots)
    poles = [[FreeCAD.Vector(*map(float, p)) for p in row] for row in surface.poles]
    result = Part.BSplineSurface()
    weights = None if surface.weights is None else surface.weights.tolist()
    result.buildFromPolesMultsKnots(poles, um, vm, uk, vk, False, False,
                                    int(surface.u_degree), int(surface.v_degree), weights)
    return result


def curve_from_edge(edge):
    """The edge's curve as a :class:`cq_fairing.BSplineCurve` (periodic -> clamped).

    Raises
    ------
    cq_fairing.UnsupportedGeometryError
        If the edge is not a B-spline edge.
    """
    curve = edge.Curve
    if not isinstance(curve, Part.BSplineCurve):
        raise cf.UnsupportedGeometryError(
            f"the edge is a {type(curve).__name__}, not a B-spline curve; fairing "
            "applies to freeform (B-spline) edges only. Pick a B-spline edge.")
    curve = curve.copy()
    if curve.isPeriodic():
        curve.setNotPeriodic()
        curve.segment(curve.FirstParameter, curve.LastParameter)
    poles = np.array([[p.x, p.y, p.z] for p in curve.getPoles()])
    weights = _weights_or_none(curve.getWeights()) if curve.isRational() else None
    return cf.make_curve(poles, full_knots(curve.getKnots(), curve.getMultiplicities()),
                         curve.Degree, weights)


def part_curve(curve):
    """A ``Part.BSplineCurve`` from a :class:`cq_fairing.BSplineCurve`."""
    knots, mults = _distinct(curve.knots)
    result = Part.BSplineCurve()
    weights = None if curve.weights is None else curve.weights.tolist()
    result.buildFromPolesMultsKnots([FreeCAD.Vector(*map(float, p)) for p in curve.poles],
                                    mults, knots, False, int(curve.degree), weights)
    return result


def is_uv_rectangle(face):
    """True when the face is its surface restricted to ``face.ParameterRange``: one
    wire that runs along the sides of that box (:func:`_along_box_sides`), or else one
    wire and the area of that restriction within 1e-6 of the face's (OCCT integrates
    both areas, 14 ms on a 50 x 80 net, where the sides take 0.1 ms)."""
    if len(face.Wires) != 1:
        return False
    if _along_box_sides(face):
        return True
    u0, u1, v0, v1 = face.ParameterRange
    area = face.Area
    return abs(face.Surface.toShape(u0, u1, v0, v1).Area - area) <= 1e-6 * max(area, 1e-300)


def _along_box_sides(face):
    """True when the p-curve of every edge of ``face`` lies on one side of the face's UV
    box (``face.ParameterRange``, within 1e-9 of the box's size): a straight line whose
    two ends lie there, or a B-spline or Bezier p-curve whose poles all do (the curve
    lies in their convex hull).  A face with one such wire is the whole box."""
    u0, u1, v0, v1 = face.ParameterRange
    near = 1e-9 * max(u1 - u0, v1 - v0)
    sides = (("x", u0), ("x", u1), ("y", v0), ("y", v1))
    for edge in face.Edges:
        points = _pcurve_hull(face, edge)
        if points is None or not any(all(abs(getattr(point, axis) - at) <= near
                                         for point in points) for axis, at in sides):
            return False
    return True


def _pcurve_hull(face, edge):
    """Points whose convex hull holds the p-curve of ``edge`` on ``face``: a line's two
    ends, a B-spline's or Bezier's poles; ``None`` for other curves."""
    found = face.curveOnSurface(edge)
    if not found:
        return None
    curve, first, last = found
    if isinstance(curve, (Part.Geom2d.Line2d, Part.Geom2d.Line2dSegment)):
        return [curve.value(first), curve.value(last)]
    if isinstance(curve, (Part.Geom2d.BSplineCurve2d, Part.Geom2d.BezierCurve2d)):
        return curve.getPoles()
    return None


def _wire_on_surface(face, wire, surface):
    """``wire`` of ``face`` rebuilt on ``surface`` from its p-curves.

    Each new edge gets its source edge's tolerance: files from other systems (IGES) join
    their edges within 1e-4 to 0.2 mm, while an edge made from a p-curve has 1e-7, so
    without it the edges do not connect into a wire ("BRep_API: command not done").
    """
    edges = []
    for edge in wire.OrderedEdges:
        pcurve, first, last = face.curveOnSurface(edge)  # the p-curve on *this* face
        new = pcurve.toShape(surface, first, last)
        new.fixTolerance(_tolerance(edge))
        edges.append(new)
    return Part.Wire(edges)


def _tolerance(shape):
    """The largest tolerance of ``shape`` and its vertices."""
    return max([shape.Tolerance] + [v.Tolerance for v in shape.Vertexes])


def face_on_surface(surface, face, domain=None):
    """A face on the new ``Part`` surface bounded like ``face`` in parameter space.

    Untrimmed faces and faces trimmed to a parameter rectangle (e.g. the two halves of the
    IEA blade) are rebuilt exactly from their UV box.  Other trims are rebuilt from the
    edges' p-curves (unchanged because fairing keeps the parameter domain) with the
    source's edge tolerances; a face that is still not valid is repaired by OCCT's shape
    fixer (wire order and orientation, edges shorter than the tolerance) within the
    source face's largest tolerance.  The result has ``face``'s orientation.
    ``domain``: the :class:`FaceDomain` of ``face`` where already read.

    Raises
    ------
    cq_fairing.UnsupportedGeometryError
        If the trimmed face cannot be rebuilt into a valid face.
    """
    u0, u1, v0, v1 = face.ParameterRange
    if (FaceDomain(face) if domain is None else domain).rectangle:
        return _oriented_like(surface.toShape(u0, u1, v0, v1), face)
    try:
        wires = [_wire_on_surface(face, wire, surface) for wire in face.Wires]
        result = Part.Face(surface, wires[0])
        for inner in wires[1:]:
            result = Part.Face(result, inner)
        if not result.isValid():
            result.fix(1e-7, 1e-7, max(_tolerance(face), 1e-7))
    except Part.OCCError as error:
        raise _not_rebuilt(f"OCCT: {error}") from error
    if result.isNull() or not result.isValid():
        raise _not_rebuilt("the rebuilt face is not valid")
    return _oriented_like(result, face)


def _oriented_like(result, face):
    """``result`` with ``face``'s orientation (its normal turned the same way)."""
    if result.Orientation != face.Orientation:
        result.reverse()
    return result


def face_on_edges(surface, face, tolerance):
    """A face on ``surface`` bounded by ``face``'s own edges (shared, not copied).

    Faces of one shell rebuilt this way keep sharing their edges, vertices and edge splits,
    so they form a shell without sewing.  The edges keep their 3D curves; OCCT's shape
    fixer adds each edge's p-curve on ``surface`` (projection) and raises the edge
    tolerances to the distance between the edge and the new surface, at most
    ``tolerance``.  The result has ``face``'s orientation.
    """
    result = Part.Face(surface, face.OuterWire)
    for inner in face.Wires:
        if not inner.isSame(face.OuterWire):
            result = Part.Face(result, inner)
    result = _oriented_like(result, face)
    if not result.isValid():
        result.fix(1e-7, 1e-7, tolerance)
    return result


def _not_rebuilt(what):
    return cf.UnsupportedGeometryError(
        f"the trimmed face could not be rebuilt on the faired surface ({what}); fair the "
        "untrimmed surface (Part > Convert) or a face trimmed to a UV rectangle.")
