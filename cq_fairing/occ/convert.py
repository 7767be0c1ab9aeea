r"""Control nets out of OCP faces and back in: :func:`face_to_surface`, :func:`surface_to_face`.

OCCT stores a B-spline surface as distinct knots with multiplicities, 1-based arrays,
and possibly periodic (unclamped) knot vectors; the core wants full clamped knot vectors
and 0-based arrays.  All of that translation lives here.

A periodic direction is *unperiodized*: ``Geom_BSplineSurface.SetUNotPeriodic`` gives an
unclamped representation of the same geometry, and ``Segment`` over the domain clamps it
(end multiplicity ``degree + 1``).  The surface is unchanged, so
:math:`S_{core}(u, v) = S_{occ}(u, v)` on the whole domain.
"""

from dataclasses import dataclass

import numpy as np
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepBuilderAPI import BRepBuilderAPI_Copy
from OCP.BRepLib import BRepLib
from OCP.BRepTools import BRepTools
from OCP.Geom import Geom_BSplineCurve, Geom_BSplineSurface
from OCP.GeomAbs import GeomAbs_SurfaceType
from OCP.gp import gp_Pnt
from OCP.ShapeBuild import ShapeBuild_Edge
from OCP.ShapeFix import ShapeFix_ShapeTolerance
from OCP.TColgp import TColgp_Array2OfPnt
from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal, TColStd_Array2OfReal
from OCP.TopAbs import (
    TopAbs_EDGE,
    TopAbs_FACE,
    TopAbs_FORWARD,
    TopAbs_SHELL,
    TopAbs_SOLID,
    TopAbs_VERTEX,
    TopAbs_WIRE,
)
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS, TopoDS_Shape
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape

from ..core.geometry import BSplineSurface, make_surface
from ..errors import InvalidInputError, UnsupportedGeometryError
from .pcurves import projected_pcurve
from .vertices import covering_point, curve_ends, members, move_vertex, reach, vertex_point

__all__ = ["FaceInfo", "list_faces", "face_info", "face_to_surface", "surface_to_face",
           "to_geom_surface", "indexed_faces", "as_face", "as_shape", "is_occt_error"]

_TYPE_NAMES = {
    GeomAbs_SurfaceType.GeomAbs_Plane: "Plane",
    GeomAbs_SurfaceType.GeomAbs_Cylinder: "Cylinder",
    GeomAbs_SurfaceType.GeomAbs_Cone: "Cone",
    GeomAbs_SurfaceType.GeomAbs_Sphere: "Sphere",
    GeomAbs_SurfaceType.GeomAbs_Torus: "Torus",
    GeomAbs_SurfaceType.GeomAbs_BezierSurface: "Bezier",
    GeomAbs_SurfaceType.GeomAbs_BSplineSurface: "BSpline",
    GeomAbs_SurfaceType.GeomAbs_SurfaceOfRevolution: "Revolution",
    GeomAbs_SurfaceType.GeomAbs_SurfaceOfExtrusion: "Extrusion",
    GeomAbs_SurfaceType.GeomAbs_OffsetSurface: "Offset",
    GeomAbs_SurfaceType.GeomAbs_OtherSurface: "Other",
}


@dataclass(frozen=True)
class FaceInfo:
    """What a face is made of (one row of ``cq-fairing inspect``).

    Attributes
    ----------
    index : int
        0-based position in :func:`indexed_faces` (``TopExp::MapShapes`` order); the same
        index selects the face in :func:`~cq_fairing.occ.fair_shape`.
    surface_type : str
        ``'BSpline'``, ``'Plane'``, ``'Cylinder'``, ... (``BRepAdaptor_Surface::GetType``).
    u_degree, v_degree, n_poles_u, n_poles_v : int or None
        Of the OCCT surface as stored (``None`` unless B-spline or Bezier).
    rational : bool
    u_periodic, v_periodic : bool
        As stored in the file (before any unperiodizing).
    trimmed : bool
        More than one wire, a UV box smaller than the surface domain, or an edge whose
        pcurve leaves the border of the parameter rectangle.
    in_solid : bool
        The face belongs to a ``TopoDS_Solid`` or to a closed shell.
    unperiodized : tuple of str
        Directions (``'u'``, ``'v'``) made non-periodic by :func:`face_to_surface`.
    """

    index: int
    surface_type: str
    u_degree: int = None
    v_degree: int = None
    n_poles_u: int = None
    n_poles_v: int = None
    rational: bool = False
    u_periodic: bool = False
    v_periodic: bool = False
    trimmed: bool = False
    in_solid: bool = False
    unperiodized: tuple = ()

    @property
    def is_bspline(self):
        return self.surface_type == "BSpline"


# -- shapes and faces --------------------------------------------------------------------
def as_shape(shape, name="shape"):
    """The ``TopoDS_Shape`` behind ``shape`` (accepts cadquery objects via ``.wrapped``)."""
    shape = getattr(shape, "wrapped", shape)
    if not isinstance(shape, TopoDS_Shape) or shape.IsNull():
        raise InvalidInputError(
            f"{name} must be a non-null OCP TopoDS_Shape (or a cadquery Shape), got "
            f"{type(shape).__name__}."
        )
    return shape


def as_face(face, name="face"):
    """The ``TopoDS_Face`` behind ``face``; raises InvalidInputError for anything else."""
    shape = as_shape(face, name)
    if shape.ShapeType() != TopAbs_FACE:
        raise InvalidInputError(
            f"{name} must be a face, got a {shape.ShapeType().name[7:].lower()}; "
            "pass one face or use fair_shape for whole shapes."
        )
    return TopoDS.Face_s(shape)


def indexed_faces(shape):
    """The distinct faces of ``shape`` in ``TopExp::MapShapes`` order (0-based list)."""
    fmap = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(as_shape(shape), TopAbs_FACE, fmap)
    return [TopoDS.Face_s(fmap.FindKey(i)) for i in range(1, fmap.Extent() + 1)]


def _faces_in_solids(shape):
    """Set of face hash keys (TShape identity) that lie in a solid or a closed shell."""
    found = TopTools_IndexedMapOfShape()
    for kind in (TopAbs_SOLID, TopAbs_SHELL):
        ex = TopExp_Explorer(shape, kind)
        while ex.More():
            sub = ex.Current()
            if kind == TopAbs_SOLID or BRep_Tool.IsClosed_s(sub):
                TopExp.MapShapes_s(sub, TopAbs_FACE, found)
            ex.Next()
    return found


def list_faces(shape):
    """One :class:`FaceInfo` per distinct face of ``shape`` (index = position).

    Parameters
    ----------
    shape : TopoDS_Shape or cadquery.Shape
    """
    shape = as_shape(shape)
    solid_faces = _faces_in_solids(shape)
    return [face_info(face, i, solid_faces.Contains(face))
            for i, face in enumerate(indexed_faces(shape))]


def face_info(face, index=0, in_solid=False):
    """:class:`FaceInfo` of one face (see :func:`list_faces`)."""
    face = as_face(face)
    kind = _TYPE_NAMES.get(BRepAdaptor_Surface(face, False).GetType(), "Other")
    fields = dict(index=index, surface_type=kind, trimmed=_is_trimmed(face), in_solid=in_solid)
    if kind in ("BSpline", "Bezier"):
        surf = BRep_Tool.Surface_s(face)
        fields.update(u_degree=surf.UDegree(), v_degree=surf.VDegree(),
                      n_poles_u=surf.NbUPoles(), n_poles_v=surf.NbVPoles(),
                      rational=bool(surf.IsURational() or surf.IsVRational()),
                      u_periodic=bool(surf.IsUPeriodic()), v_periodic=bool(surf.IsVPeriodic()))
    return FaceInfo(**fields)


def _is_trimmed(face):
    """The SOURCES.md definition: several wires, a smaller UV box, or off-border pcurves."""
    n_wires = 0
    ex = TopExp_Explorer(face, TopAbs_WIRE)
    while ex.More():
        n_wires += 1
        ex.Next()
    if n_wires != 1:
        return True
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    s0, s1, t0, t1 = BRep_Tool.Surface_s(face).Bounds()
    span = max(s1 - s0, t1 - t0) if np.isfinite(s1 - s0) and np.isfinite(t1 - t0) else 1.0
    eps = 1e-7 * span
    if any(np.isfinite(b) and abs(a - b) > eps for a, b in ((u0, s0), (u1, s1), (v0, t0), (v1, t1))):
        return True
    ex = TopExp_Explorer(face, TopAbs_EDGE)
    while ex.More():
        edge = TopoDS.Edge_s(ex.Current())
        curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
        if curve is None:        # no UV curve: the edge cannot be shown to be a border
            return True
        a, b = BRep_Tool.Range_s(edge, face)
        for t in np.linspace(a, b, 5):
            p = curve.Value(float(t))
            on_u = min(abs(p.X() - u0), abs(p.X() - u1)) <= eps
            on_v = min(abs(p.Y() - v0), abs(p.Y() - v1)) <= eps
            if not (on_u or on_v):
                return True
        ex.Next()
    return False


# -- OCCT surface -> core ----------------------------------------------------------------
def _full_knots(surf, direction):
    if direction == "u":
        knots = [surf.UKnot(i) for i in range(1, surf.NbUKnots() + 1)]
        mults = [surf.UMultiplicity(i) for i in range(1, surf.NbUKnots() + 1)]
    else:
        knots = [surf.VKnot(i) for i in range(1, surf.NbVKnots() + 1)]
        mults = [surf.VMultiplicity(i) for i in range(1, surf.NbVKnots() + 1)]
    return np.repeat(np.asarray(knots, dtype=float), mults)


def _net(surf):
    """Poles (ku, kv, 3) and weights (ku, kv) or None of a Geom_BSplineSurface."""
    ku, kv = surf.NbUPoles(), surf.NbVPoles()
    poles = surf.Poles()
    net = np.empty((ku, kv, 3))
    for i in range(1, ku + 1):
        for j in range(1, kv + 1):
            p = poles.Value(i, j)
            net[i - 1, j - 1] = (p.X(), p.Y(), p.Z())
    weights = None
    if surf.IsURational() or surf.IsVRational():
        w = surf.Weights()
        weights = np.array([[w.Value(i, j) for j in range(1, kv + 1)] for i in range(1, ku + 1)])
    return net, weights


def clamped_bspline(face):
    """A clamped, non-periodic ``Geom_BSplineSurface`` copy of the face's surface
    (periodic and unclamped knot vectors converted exactly).

    Returns
    -------
    surf : Geom_BSplineSurface
        In the face's global coordinates (location applied).
    unperiodized : tuple of str
    """
    surf = BRep_Tool.Surface_s(face)
    if not isinstance(surf, Geom_BSplineSurface):
        kind = type(surf).__name__
        raise UnsupportedGeometryError(
            f"the face's surface is a {kind}, not a B-spline; convert it first "
            "(fair_face(..., convert=True) uses BRepBuilderAPI_NurbsConvert)."
        )
    surf = surf.Copy()
    done = []
    if surf.IsUPeriodic():
        surf.SetUNotPeriodic()
        done.append("u")
    if surf.IsVPeriodic():
        surf.SetVNotPeriodic()
        done.append("v")
    if done or not _is_clamped(surf):
        u0, u1, v0, v1 = surf.Bounds()
        surf.Segment(u0, u1, v0, v1)
    return surf, tuple(done)


def _is_clamped(surf):
    """True when both knot vectors of a non-periodic ``Geom_BSplineSurface`` start and end
    with multiplicity degree + 1.

    OCCT also keeps unclamped ("uniform") knot vectors, whose domain starts at the flat knot
    of index degree + 1 and whose border is not on the outer poles; ``Segment`` to the
    domain inserts the end knots to full multiplicity, an exact change of basis."""
    ends = ((surf.UMultiplicity(1), surf.UMultiplicity(surf.NbUKnots()), surf.UDegree()),
            (surf.VMultiplicity(1), surf.VMultiplicity(surf.NbVKnots()), surf.VDegree()))
    return all(first == last == degree + 1 for first, last, degree in ends)


def is_occt_error(exc):
    """True for an exception raised by OCCT.

    OCP binds ``Standard_Failure`` and each of its kinds (``Standard_DomainError``,
    ``StdFail_NotDone``, ...) as separate Python classes that do not inherit from one
    another, so they are recognised by their module (``OCP.*``).
    """
    return type(exc).__module__.split(".")[0] == "OCP"


def face_to_surface(face):
    """The face's B-spline surface as a core :class:`~cq_fairing.BSplineSurface`.

    Parameters
    ----------
    face : TopoDS_Face or cadquery.Face

    Returns
    -------
    surface : BSplineSurface
        ``poles`` (k_u, k_v, 3) in global coordinates, full clamped knot vectors
        (multiplicities expanded), ``weights`` (k_u, k_v) or ``None``.  Periodic
        directions are unperiodized (same geometry, clamped knots).
    info : FaceInfo
        ``info.unperiodized`` names the directions that were periodic.

    Raises
    ------
    UnsupportedGeometryError
        The face is not a B-spline face.
    """
    face = as_face(face)
    surf, done = clamped_bspline(face)
    net, weights = _net(surf)
    surface = make_surface(net, _full_knots(surf, "u"), _full_knots(surf, "v"),
                           (surf.UDegree(), surf.VDegree()), weights)
    info = face_info(face)
    from dataclasses import replace

    return surface, replace(info, unperiodized=done)


# -- core -> OCCT --------------------------------------------------------------------------
def _distinct(knots):
    values, counts = np.unique(np.asarray(knots, dtype=float), return_counts=True)
    arr_k = TColStd_Array1OfReal(1, values.size)
    arr_m = TColStd_Array1OfInteger(1, values.size)
    for i, (value, count) in enumerate(zip(values, counts), start=1):
        arr_k.SetValue(i, float(value))
        arr_m.SetValue(i, int(count))
    return arr_k, arr_m


def to_geom_surface(surface):
    """A ``Geom_BSplineSurface`` from a core :class:`~cq_fairing.BSplineSurface` (3-D poles)."""
    if not isinstance(surface, BSplineSurface) or surface.poles.shape[2] != 3:
        raise InvalidInputError(
            "surface must be a cq_fairing.BSplineSurface with 3-D poles, got "
            f"{type(surface).__name__}."
        )
    ku, kv, _ = surface.poles.shape
    poles = TColgp_Array2OfPnt(1, ku, 1, kv)
    for i in range(ku):
        for j in range(kv):
            x, y, z = surface.poles[i, j]
            poles.SetValue(i + 1, j + 1, gp_Pnt(float(x), float(y), float(z)))
    uk, um = _distinct(surface.u_knots)
    vk, vm = _distinct(surface.v_knots)
    if surface.weights is None:
        return Geom_BSplineSurface(poles, uk, vk, um, vm, surface.u_degree, surface.v_degree,
                                   False, False)
    weights = TColStd_Array2OfReal(1, ku, 1, kv)
    for i in range(ku):
        for j in range(kv):
            weights.SetValue(i + 1, j + 1, float(surface.weights[i, j]))
    return Geom_BSplineSurface(poles, weights, uk, vk, um, vm, surface.u_degree,
                               surface.v_degree, False, False)


def _edge_pcurves(face):
    """``[(edge, c2d_forward, c2d_reversed_or_None, first, last)]`` for the face's edges."""
    out, seen = [], TopTools_IndexedMapOfShape()
    ex = TopExp_Explorer(face, TopAbs_EDGE)
    while ex.More():
        edge = TopoDS.Edge_s(ex.Current())
        if not seen.Contains(edge):
            seen.Add(edge)
            fwd = TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD))
            c1 = BRep_Tool.CurveOnSurface_s(fwd, face, 0.0, 0.0)
            a, b = BRep_Tool.Range_s(fwd, face)
            c2 = None
            if BRep_Tool.IsClosed_s(edge, face):
                c2 = BRep_Tool.CurveOnSurface_s(TopoDS.Edge_s(fwd.Reversed()), face, 0.0, 0.0)
            out.append((fwd, c1, c2, a, b))
        ex.Next()
    return out


def replace_surface(face, geom_surface, reproject=None):
    """Put ``geom_surface`` under ``face`` in place, keeping every edge and its pcurves.

    The pcurves are UV curves, so on a surface with the same parameter domain they
    describe the same trim.  Old pcurve records (keyed by the old surface) are removed,
    the edges are marked not same-parameter so that :func:`finish_edges` recomputes
    their tolerances.

    An edge for which ``reproject(edge)`` is true (one shared with another face) and
    that is not a seam gets :func:`~cq_fairing.occ.pcurves.projected_pcurve` instead,
    same-parameter with its 3-D curve, so it stays where the neighbour has it even
    where the new surface's parametrization slid along the old one.

    Returns
    -------
    list of TopoDS_Edge
        The edges of the face (forward).
    """
    loc = TopLoc_Location()
    old_surface = BRep_Tool.Surface_s(face, loc)
    pcurves = _edge_pcurves(face)
    builder = BRep_Builder()
    tol = BRep_Tool.Tolerance_s(face)
    builder.UpdateFace(face, geom_surface, TopLoc_Location(), tol)
    remover = ShapeBuild_Edge()
    for edge, c1, c2, a, b in pcurves:
        remover.RemovePCurve(edge, old_surface, loc)
        if c2 is None and reproject is not None and reproject(edge):
            c1 = projected_pcurve(edge, c1, a, b, geom_surface) or c1
        if c2 is None:
            builder.UpdateEdge(edge, c1, face, BRep_Tool.Tolerance_s(edge))
        else:
            builder.UpdateEdge(edge, c1, c2, face, BRep_Tool.Tolerance_s(edge))
        builder.Range(edge, face, a, b)
        builder.SameParameter(edge, False)
    return [edge for edge, *_ in pcurves]


def finish_edges(edges, tolerance=1e-7, rebuild_3d=False):
    """Recompute same-parameter data and tolerances of ``edges`` after a surface change.

    With ``rebuild_3d`` the 3-D curves are rebuilt from the pcurves on the new surface
    (right for a free face: its edges then lie exactly on it), on the edge's range
    (:func:`_knots_on_range`).
    """
    for edge in edges:
        if rebuild_3d and not BRep_Tool.Degenerated_s(edge):
            ShapeBuild_Edge().RemoveCurve3d(edge)
            BRepLib.BuildCurve3d_s(edge, tolerance)
            _knots_on_range(edge)
        BRepLib.SameParameter_s(edge, tolerance)


def _knots_on_range(edge):
    r"""Map the knots of ``edge``'s rebuilt 3-D B-spline curve affinely onto the edge's
    range :math:`[a, b]`, the end knots exactly.

    ``BRepLib::BuildCurve3d`` approximates the pcurve on the surface over :math:`[a, b]`,
    but its knots come out shifted by a rounding per knot span that adds up along the
    curve: on a faired terrain face (knots of the surface's 283 distinct v values, range
    [80300, 88300]) the last knot was 88299.99999999796, 2e-9 short of :math:`b` and
    beyond the 1e-9 (``Precision::PConfusion``) by which ``BRepCheck`` reports the edge
    ``InvalidRange``.  The map moves each knot by at most that drift.
    """
    a, b = BRep_Tool.Range_s(edge)
    curve = BRep_Tool.Curve_s(edge, TopLoc_Location(), 0.0, 0.0)
    if not isinstance(curve, Geom_BSplineCurve) or curve.IsPeriodic():
        return
    knots = np.array([curve.Knot(i) for i in range(1, curve.NbKnots() + 1)])
    if (knots[0], knots[-1]) == (a, b):
        return
    mapped = a + (knots - knots[0]) * ((b - a) / (knots[-1] - knots[0]))
    mapped[0], mapped[-1] = a, b
    array = TColStd_Array1OfReal(1, mapped.size)
    for i, value in enumerate(mapped, start=1):
        array.SetValue(i, float(value))
    curve.SetKnots(array)


# relative and model-size margins on the tolerances of rebuilt edges and their vertices
TEXT_MARGIN = 1e-9
COORDINATE_MARGIN = 1e-12


class Tolerances:
    """The tolerance every edge and vertex of a shape has now, looked up by sub-shape
    (:meth:`of`; 0 for one the shape did not have): what :func:`settle_tolerances`
    keeps where the changed geometry needs no more."""

    def __init__(self, shape):
        self._map = TopTools_IndexedMapOfShape()
        TopExp.MapShapes_s(shape, TopAbs_EDGE, self._map)
        TopExp.MapShapes_s(shape, TopAbs_VERTEX, self._map)
        self._values = [_tolerance(self._map.FindKey(i)) for i in range(1, self._map.Extent() + 1)]

    def of(self, shape):
        index = self._map.FindIndex(shape)
        return self._values[index - 1] if index else 0.0


def _tolerance(shape):
    if shape.ShapeType() == TopAbs_VERTEX:
        return BRep_Tool.Tolerance_s(TopoDS.Vertex_s(shape))
    return BRep_Tool.Tolerance_s(TopoDS.Edge_s(shape))


def settle_tolerances(shape, edges, before):
    r"""Make the tolerances of ``shape`` consistent after ``edges`` changed, with a margin
    where they grew, and move the vertices of ``edges`` to the middle of their curve ends.

    ``BRepLib::UpdateTolerances`` raises every edge tolerance to its faces' and every
    vertex tolerance to the diagonal of the box around its point and the curve ends it
    must cover.  Where a faired face moved its corners, the edges meeting there end
    together again but away from the vertex's point: such a vertex moves to the centre
    of the ends' smallest enclosing ball (:mod:`~cq_fairing.occ.vertices`) where that
    needs a smaller tolerance than its own point.  A vertex's need is the largest
    distance from its point to those ends (``BRepCheck_Vertex`` measures the same), and
    at least the tolerance of each edge at it (OCCT's rule: a vertex is no tighter than
    its edges).  OCCT's box diagonal is no less than that need, so the vertices settled
    are those whose tolerance it raised.

    A BREP file stores tolerances and coordinates with 15 significant digits, so an
    exact tolerance can read back a hair below that distance (testtoler face 55:
    1.8685231246390617 written as 1.86852312463906) and the read shape fails
    ``BRepCheck``.  Each touched edge and each vertex whose need rose above the
    tolerance it had (``before``, a :class:`Tolerances` taken before the change)
    therefore gets :math:`t \leftarrow t (1 + 10^{-9}) + 10^{-12} M`, with :math:`M` the
    largest coordinate magnitude of its vertices: more than the rounding of 15 digits,
    far below any modelling tolerance.  One still within its former tolerance keeps it
    unchanged, and a vertex then stays where it is: the faired shape's tolerances are
    not raised where the geometry does not need it.  An edge's need is OCCT's estimate
    (``BRepLib::SameParameter``), a distance between points of coordinates up to
    :math:`M`; one above the former tolerance by less than the spacing of doubles at
    :math:`M` (testtoler's edges of tolerance 4.44 at coordinates of 2.2e4: 2.5e-12,
    below the spacing 3.6e-12) is that estimate's round-off and keeps the former
    tolerance too.  Each edge and vertex is settled once, however many touched edges
    share it.
    """
    BRepLib.UpdateTolerances_s(shape, False)
    settled = TopTools_IndexedMapOfShape()
    for edge in edges:
        if not settled.Contains(edge):
            settled.Add(edge)
            ends = (TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge))
            _settle_edge(edge, before.of(edge), max(np.abs(vertex_point(v)).max() for v in ends))
    users = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, users)
    for i in range(1, users.Extent() + 1):
        vertex = TopoDS.Vertex_s(users.FindKey(i))
        former = before.of(vertex)
        if BRep_Tool.Tolerance_s(vertex) > former:   # OCCT's need covers the vertex's own
            _settle_vertex(vertex, members(users.FindFromIndex(i)), former)


def _settle_edge(edge, former, size):
    """The former tolerance where OCCT's need is within it or its round-off, else that
    need padded (:func:`settle_tolerances`)."""
    need = BRep_Tool.Tolerance_s(edge)
    if need > former:
        _set_tolerance(edge, former if need - former < np.spacing(size) else
                       _padded(need, size))


def _settle_vertex(vertex, edges, former):
    """Keep ``vertex`` and its former tolerance where its need allows, else move it
    where the need is least and give it that need, padded (:func:`settle_tolerances`)."""
    floor = max(BRep_Tool.Tolerance_s(TopoDS.Edge_s(edge)) for edge in edges)
    point, ends = vertex_point(vertex), curve_ends(vertex, edges)
    if ends is None:       # not only curve ends: OCCT's need, padded where it rose
        distance = BRep_Tool.Tolerance_s(vertex)
    else:
        distance = reach(point, ends)
        if distance > max(floor, former):   # the point, not an edge, sets a new need
            point, distance = covering_point(point, ends)
            move_vertex(vertex, point)
    _set_tolerance(vertex, former if max(distance, floor) <= former else
                   max(_padded(distance, np.abs(point).max()), floor))


def _set_tolerance(item, tolerance):
    """Give an edge or vertex exactly ``tolerance``, lower than it has or not
    (``BRep_Builder::UpdateEdge``/``UpdateVertex`` only raise it)."""
    ShapeFix_ShapeTolerance().SetTolerance(item, tolerance, item.ShapeType())


def _padded(tolerance, size):
    return tolerance * (1.0 + TEXT_MARGIN) + COORDINATE_MARGIN * size


def surface_to_face(surface, original_face):
    """A new face on ``surface`` with the trim (wires, UV pcurves) of ``original_face``.

    Parameters
    ----------
    surface : BSplineSurface
        Core surface on the same UV domain as the original face's surface (fairing keeps
        the domain), in global coordinates.
    original_face : TopoDS_Face or cadquery.Face
        Not modified: a copy is made.

    Returns
    -------
    TopoDS_Face
        Same wires and pcurves; the edges' 3-D curves are rebuilt from the pcurves on the
        new surface, so the edges lie on it; an untrimmed face keeps its natural bounds.

    Raises
    ------
    InvalidInputError
        ``surface`` does not cover the face's UV box.
    """
    original_face = as_face(original_face, "original_face")
    _check_domain(surface, original_face)
    copy = TopoDS.Face_s(BRepBuilderAPI_Copy(original_face, True, False).Shape())
    before = Tolerances(copy)
    edges = replace_surface(copy, to_geom_surface(surface))
    finish_edges(edges, rebuild_3d=True)
    settle_tolerances(copy, edges, before)
    return copy


def _check_domain(surface, face):
    (a, b), (c, d) = surface.domain
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    eps = 1e-7 * max(b - a, d - c, 1.0)
    if u0 < a - eps or u1 > b + eps or v0 < c - eps or v1 > d + eps:
        raise InvalidInputError(
            f"surface domain u[{a}, {b}] x v[{c}, {d}] does not cover the face's UV box "
            f"u[{u0}, {u1}] x v[{v0}, {v1}]; fair the face's own surface (same domain)."
        )
