r"""Which faces of a model meet, along which borders, and how well: :func:`find_joins`.

A *join* is a boundary along which two faces meet.  In a shell or a solid it is an edge
shared by exactly two faces (the edge's ancestors in ``TopExp::MapShapesAndAncestors``).
In a compound of loose faces (an IGES file with no shared edges) it is a pair of free
edges, one per face, that coincide within a distance (see :func:`find_joins`); the
source is not changed: no sewing, only reading.

How well a join closes is measured on the geometry of the two faces.  At ``samples``
parameters :math:`t_k`, uniform on the range of side 0's edge, the point

.. math:: P_k = S_0(c_0(t_k))

of face 0 (its surface :math:`S_0` at its pcurve :math:`c_0`) is projected onto face 1's
surface, seeded with face 1's pcurve at the matching parameter and kept inside face 1's
parameter box, giving :math:`Q_k = S_1(u_k, v_k)`; the gap is
:math:`g_k = |P_k - Q_k|` and the angle :math:`\alpha_k` is the angle between the unit
normals :math:`\pm (S_u \times S_v) / |S_u \times S_v|` of the two faces at :math:`P_k`
and :math:`Q_k`, each taken with its face's orientation (``TopAbs_REVERSED`` turns it).
The same is done with face 1's points projected onto face 0, and each sample keeps the
larger of the two gaps and angles.  The faces of one shell are consistently oriented,
so a tangent join has :math:`\alpha_k \approx 0`; two loose faces may disagree, and
their angle is folded to :math:`\min(\alpha, 180^\circ - \alpha)`.

A join is *smooth* when its largest source angle is below ``angle_tol`` degrees, else a
*crease*.  :func:`measure_joins` measures the same joins on another shape with the same
faces and edges (a faired copy), sample for sample, so that the faired angles and gaps
can be compared with :attr:`Join.source_angles` point by point; :meth:`Adjacency.measure`
measures a copy at the source's scale and keeps the source measure of each join between
faces the copy left as they were.  All joins are measured at once: the points of each
face are evaluated together and every projection is one row of one Gauss-Newton run.
"""

from dataclasses import dataclass, field
from itertools import compress

import numpy as np
from OCP.Bnd import Bnd_Box
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepTools import BRepTools
from OCP.Geom import Geom_BezierSurface, Geom_BSplineSurface
from OCP.GeomAPI import GeomAPI_ProjectPointOnCurve
from OCP.gp import gp_Pnt, gp_Vec
from OCP.ShapeAnalysis import ShapeAnalysis_Surface
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_REVERSED, TopAbs_VERTEX
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape
from scipy.spatial import cKDTree

from ..core.free_edges import COINCIDENCE, EDGE_PROBES, match_free_edges, probe_length
from ..core.joint_projection import Join, JoinSide, locate_side
from ..errors import InvalidInputError
from .convert import as_shape, indexed_faces

__all__ = ["JoinSide", "Join", "JoinMeasure", "Adjacency", "find_joins", "measure_joins"]

SIDES = ("u0", "u1", "v0", "v1")
NEWTON_STEPS = 12         # Gauss-Newton iterations of a projection onto a surface
NEWTON_STOP = 1e-12       # step (relative to the model size) that ends a projection
HALVINGS = 8              # step halvings before a projection is taken as converged
SINGULAR = 1e-4           # |S_u x S_v| / max(|S_u|, |S_v|)^2 below it: no reliable normal
NUDGE = 1e-6              # parameter step (relative to the edge's range) off a pole


# -- results -------------------------------------------------------------------------------
@dataclass(frozen=True)
class JoinMeasure:
    """A join measured on some shape (:func:`measure_joins`).

    Attributes
    ----------
    gap : float
        Largest distance between the two faces along the join.
    angle : float
        Largest angle (degrees) between their normals along the join.
    angles, gaps : numpy.ndarray
        Per sample, in the order of :attr:`Join.source_angles`.
    """

    gap: float
    angle: float
    angles: np.ndarray = field(compare=False, repr=False)
    gaps: np.ndarray = field(default=None, compare=False, repr=False)


@dataclass
class Adjacency:
    """The joins of a shape and what does not join (:func:`find_joins`).

    Attributes
    ----------
    joins : list of Join
    non_manifold : list of int
        Edge indices used by three or more faces (no join is made of them).
    point_contacts : list of tuple of int
        Face pairs ``(i, j)``, ``i < j``, that touch at a vertex only: they share a
        vertex (or, for loose faces, have vertices within the coincidence distance) but
        no edge and no join.
    free_edges : int
        Non-degenerate edges used by one face that are in no join (for a shell: the free
        edges, as :func:`~cq_fairing.occ.shapes.free_edge_count` counts them).
    angle_tol : float
        The smooth/crease threshold used, degrees.
    coincidence : float
        The distance within which loose boundaries were matched.
    measures : list of JoinMeasure
        Each join measured in the source, with its gap per sample.
    samples : int
        Points measured per join.
    size : float
        The source's bounding-box diagonal, the scale of the measure: a projection stops
        at a step of :data:`NEWTON_STOP` times it.
    """

    joins: list
    non_manifold: list = field(default_factory=list)
    point_contacts: list = field(default_factory=list)
    free_edges: int = 0
    angle_tol: float = 1.0
    coincidence: float = 0.0
    measures: list = field(default_factory=list)
    samples: int = 24
    size: float = 1.0

    def joins_of(self, face):
        """The joins with ``face`` (0-based index) on either side.

        Raises
        ------
        InvalidInputError
            ``face`` is not an integer.
        """
        if isinstance(face, bool) or not isinstance(face, (int, np.integer)):
            raise InvalidInputError(
                f"face must be a 0-based face index (int), got {face!r}; e.g. joins_of(3).")
        return [join for join in self.joins if face in join.faces]

    def measure(self, shape, unchanged=()):
        """The joins measured on ``shape``, a copy of the source, at the source's scale
        (:attr:`size`), ``samples`` points each (:func:`measure_joins`).

        ``shape``, the result and the errors are those of :func:`measure_joins`;
        ``unchanged`` (iterable of int) names faces of ``shape`` that are the source's
        own: the same surfaces, and where they meet one another the same edges,
        p-curves and ranges (faces left as they were in a ``BRepBuilderAPI_Copy``, which
        copies the geometry exactly).  A join between two of them keeps its source
        measure (:attr:`measures`): measuring it again would repeat the same computation
        on the same numbers.  ``unchanged`` holding something else than face indices
        raises :class:`~cq_fairing.errors.InvalidInputError`.
        """
        shape = as_shape(shape)
        unchanged = _face_indices(unchanged)
        model = _Model(shape, self.size)
        for join in self.joins:
            _check_fits(model, join)
        again = [not set(join.faces) <= unchanged for join in self.joins]
        fresh = iter(_measures(model, list(compress(self.joins, again)), self.samples))
        return [next(fresh) if measured else self.measures[k]
                for k, measured in enumerate(again)]

    def summary(self):
        """Counts and extremes as a dict: ``joins``, ``smooth``, ``crease``,
        ``max_gap``, ``max_angle``, ``max_smooth_angle``, ``non_manifold``,
        ``point_contacts``, ``free_edges``."""
        smooth = [j for j in self.joins if j.kind == "smooth"]
        return dict(
            joins=len(self.joins), smooth=len(smooth), crease=len(self.joins) - len(smooth),
            max_gap=max((j.source_gap for j in self.joins), default=0.0),
            max_angle=max((j.source_angle for j in self.joins), default=0.0),
            max_smooth_angle=max((j.source_angle for j in smooth), default=0.0),
            non_manifold=len(self.non_manifold), point_contacts=len(self.point_contacts),
            free_edges=self.free_edges)


# -- validation ------------------------------------------------------------------------------
def _is_number(value):
    return not isinstance(value, bool) and isinstance(value, (int, float, np.integer, np.floating))


def _check_options(angle_tol, coincidence, samples):
    if not _is_number(angle_tol) or not 0 < angle_tol < 180:
        raise InvalidInputError(
            f"angle_tol must be an angle in degrees between 0 and 180 (exclusive), got "
            f"{angle_tol!r}; e.g. angle_tol=1.0 for 'smooth below one degree'.")
    if coincidence is not None and (not _is_number(coincidence) or not np.isfinite(coincidence)
                                    or coincidence <= 0):
        raise InvalidInputError(
            f"coincidence must be a positive finite distance in model units or None, got "
            f"{coincidence!r}; leave it None for 1e-4 of the bounding-box diagonal.")
    _check_samples(samples)


def _face_indices(faces):
    """``faces`` as a set of face indices."""
    faces = list(faces)
    if not all(isinstance(f, (int, np.integer)) and not isinstance(f, bool) for f in faces):
        raise InvalidInputError(
            f"unchanged must hold 0-based face indices (int), got {faces!r}; e.g. {{0, 3}}.")
    return {int(f) for f in faces}


def _check_samples(samples):
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 2:
        raise InvalidInputError(
            f"samples must be an integer >= 2 (points measured per join), got {samples!r}; "
            "e.g. samples=24.")


# -- topology ---------------------------------------------------------------------------------
def _edge_map(shape):
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, emap)
    return emap


class _Model:
    """Faces, edges and per-face geometry of one shape, indexed as the results are, and
    its size (by default its bounding-box diagonal).

    The faces using each edge are collected by exploring each face's edges (one entry per
    use, so a seam lists its face twice, as ``MapShapesAndAncestors`` does): reading the
    ancestor lists back from OCCT costs far more per list in Python.
    """

    def __init__(self, shape, size=None):
        self.shape = shape
        self.faces = indexed_faces(shape)
        self.emap = _edge_map(shape)
        self.size = _diagonal(shape) if size is None else size
        self._surfaces = {}
        self._uses = {}
        self.vertices = TopTools_IndexedMapOfShape()
        self.vertex_faces = {}
        for index, face in enumerate(self.faces):
            explorer = TopExp_Explorer(face, TopAbs_EDGE)
            while explorer.More():
                self._uses.setdefault(self.emap.FindIndex(explorer.Current()), []).append(index)
                explorer.Next()
            explorer = TopExp_Explorer(face, TopAbs_VERTEX)
            while explorer.More():
                vertex = self.vertices.Add(explorer.Current())
                self.vertex_faces.setdefault(vertex, set()).add(index)
                explorer.Next()

    def edge(self, index):
        """The FORWARD edge of 1-based index ``index``."""
        return TopoDS.Edge_s(self.emap.FindKey(index).Oriented(TopAbs_FORWARD))

    def owners(self, index):
        """Distinct face indices using edge ``index`` and the number of uses."""
        uses = self._uses.get(index, [])
        return sorted(set(uses)), len(uses)

    def surface(self, face_index):
        """``(Geom_Surface, UV box (u0, u1, v0, v1), orientation sign)`` of a face."""
        if face_index not in self._surfaces:
            face = self.faces[face_index]
            sign = -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0
            self._surfaces[face_index] = (BRep_Tool.Surface_s(face),
                                          BRepTools.UVBounds_s(face), sign)
        return self._surfaces[face_index]

    def evaluate(self, faces, uv):
        """Points, :math:`S_u`, :math:`S_v` of the faces ``faces`` (n,) at ``uv`` (n, 2)
        (:func:`_evaluate`, face by face): an array (n, 3, 3), ``[:, 0]`` the points."""
        out = np.empty((len(uv), 3, 3))
        order = np.argsort(faces, kind="stable")
        for rows in np.split(order, np.flatnonzero(np.diff(faces[order])) + 1):
            if rows.size:
                out[rows] = _evaluate(self.surface(int(faces[rows[0]]))[0], uv[rows])
        return out


def _diagonal(shape):
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, True)
    if box.IsVoid():
        return 1.0
    x0, y0, z0, x1, y1, z1 = box.Get()
    return float(np.linalg.norm([x1 - x0, y1 - y0, z1 - z0])) or 1.0


def _pcurve(model, edge, face_index):
    """``(Geom2d_Curve or None, first, last)`` of a FORWARD edge on a face."""
    face = model.faces[face_index]
    curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
    first, last = BRep_Tool.Range_s(edge, face)
    return curve, first, last


def _uv(model, edge, face_index, params):
    """UV points (n, 2) of the edge on the face at edge parameters ``params``.

    From the pcurve; an edge without one (rare) gets its 3-D points projected
    (``ShapeAnalysis_Surface::ValueOfUV``).
    """
    curve, _, _ = _pcurve(model, edge, face_index)
    if curve is not None:
        return np.array([curve.Value(float(t)).Coord() for t in params])
    surface = model.surface(face_index)[0]
    analysis, adaptor = ShapeAnalysis_Surface(surface), BRepAdaptor_Curve(edge)
    tol = 1e-9 * model.size
    return np.array([analysis.ValueOfUV(adaptor.Value(float(t)), tol).Coord() for t in params])


def _join_side(model, face_index, edge_index):
    """The :class:`JoinSide` of a face's edge: which border of the parameter rectangle
    (:func:`~cq_fairing.core.joint_projection.locate_side`)."""
    edge = model.edge(edge_index)
    surface = model.surface(face_index)[0]
    curve, first, last = _pcurve(model, edge, face_index)
    if curve is None or not isinstance(surface, (Geom_BSplineSurface, Geom_BezierSurface)):
        return JoinSide(face_index, edge_index)
    uv = np.array([curve.Value(float(t)).Coord() for t in np.linspace(first, last, 7)])
    return locate_side(face_index, edge_index, uv, surface.Bounds(),
                       lambda u, v: surface.Value(u, v).Coord(),
                       BRep_Tool.Tolerance_s(edge), model.size)


# -- measurement ---------------------------------------------------------------------------
def _evaluate(surface, uv):
    """Points, :math:`S_u`, :math:`S_v` of an OCCT ``surface`` at ``uv`` (n, 2), by its
    ``D1`` one point at a time: an array (n, 3, 3), ``[:, 0]`` the points."""
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    d1, point, along_u, along_v = surface.D1, p.Coord, du.Coord, dv.Coord
    values = []
    add = values.extend   # one flat list: converting tuples of tuples costs more
    for u, v in uv.tolist():
        d1(u, v, p, du, dv)
        add(point())
        add(along_u())
        add(along_v())
    return np.array(values, dtype=float).reshape(len(uv), 3, 3)


def _normals(su, sv, sign):
    r"""Unit normals :math:`\pm S_u \times S_v / |S_u \times S_v|` (``sign`` a number or
    one per row, shape (n, 1)) and a mask of the singular points (a degenerated edge's
    pole), where the normal is undefined:
    :math:`|S_u \times S_v| \le 10^{-4} \max(|S_u|, |S_v|)^2` (one derivative vanishes
    or both are parallel)."""
    n = np.cross(su, sv)
    length = np.linalg.norm(n, axis=1)
    scale = np.maximum(np.einsum("ij,ij->i", su, su), np.einsum("ij,ij->i", sv, sv))
    singular = length <= SINGULAR * np.maximum(scale, 1e-300)
    length[singular] = 1.0
    return sign * n / length[:, None], singular


def _off_poles(model, track, normals, singular):
    r"""Fill in the ``normals`` of a ``track`` where they are ``singular``: the edge
    parameter moved by the track's ``inward`` step (ten times further each time, up to
    four times).  At a pole the normal depends on the direction of approach, and along
    the join it is the one both faces share."""
    sign = model.surface(track.face)[2]
    params, inward = track.params, track.inward
    for _ in range(4):
        if not singular.any():
            break
        params = np.where(singular, params + inward, params)
        inward = 10.0 * inward
        uv = _uv(model, track.edge, track.face, params[singular])
        values = model.evaluate(np.full(len(uv), track.face), uv)
        normals[singular], singular[singular] = _normals(values[:, 1], values[:, 2], sign)


def _project(evaluate, lo, hi, targets, uv, points, su, sv, stop):
    r"""Closest points to ``targets`` of surfaces inside parameter boxes, from seeds ``uv``.

    Each row ``k`` is projected onto its own surface, ``evaluate(rows, uv)`` (the
    values of :meth:`_Model.evaluate` of those rows' surfaces at ``uv``), inside its box
    ``lo[k] <= (u, v) <= hi[k]``.  Gauss-Newton on :math:`\min |S(u, v) - X|^2`: the
    step solves :math:`J^T J \, \delta = J^T (X - S)` with :math:`J = [S_u \; S_v]`; a
    parameter that would leave the box is held at the border and the other one solved
    alone, and a step that would move away from :math:`X` is halved (up to
    :data:`HALVINGS` times; near a singular corner the full step can jump far across
    the surface).  A row stops when its step moves its point by at most ``stop``.
    ``points``, ``su``, ``sv`` are the surfaces' values at the seeds.

    Returns
    -------
    uv, points, su, sv : numpy.ndarray
        At the projections.
    """
    uv, points, su, sv = uv.copy(), points.copy(), su.copy(), sv.copy()
    uv = np.clip(uv, lo, hi)
    active = np.ones(len(uv), bool)
    for _ in range(NEWTON_STEPS):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        r = targets[idx] - points[idx]
        a, b, c = (np.einsum("ij,ij->i", x, y) for x, y in
                   ((su[idx], su[idx]), (su[idx], sv[idx]), (sv[idx], sv[idx])))
        g1, g2 = np.einsum("ij,ij->i", su[idx], r), np.einsum("ij,ij->i", sv[idx], r)
        det = a * c - b * b
        ok = det > 1e-14 * np.maximum(a * c, 1e-300)
        step = np.zeros((idx.size, 2))
        step[ok, 0] = (c[ok] * g1[ok] - b[ok] * g2[ok]) / det[ok]
        step[ok, 1] = (a[ok] * g2[ok] - b[ok] * g1[ok]) / det[ok]
        alone = ~ok   # singular: each direction alone
        step[alone, 0] = np.where(a[alone] > 0, g1[alone] / np.maximum(a[alone], 1e-300), 0.0)
        step[alone, 1] = np.where(c[alone] > 0, g2[alone] / np.maximum(c[alone], 1e-300), 0.0)
        trial = uv[idx] + step
        out = (trial < lo[idx]) | (trial > hi[idx])
        only_u = out[:, 1] & ~out[:, 0]   # v held: u alone
        only_v = out[:, 0] & ~out[:, 1]
        step[only_u, 0] = np.where(a[only_u] > 0, g1[only_u] / np.maximum(a[only_u], 1e-300), 0)
        step[only_v, 1] = np.where(c[only_v] > 0, g2[only_v] / np.maximum(c[only_v], 1e-300), 0)
        pending, moved = np.arange(idx.size), np.zeros(idx.size)
        for _ in range(HALVINGS):   # backtrack: a step must not move away from the target
            sel = idx[pending]
            new = np.clip(uv[sel] + step[pending], lo[sel], hi[sel])
            values = evaluate(sel, new)
            p, du, dv = values[:, 0], values[:, 1], values[:, 2]
            better = (np.linalg.norm(targets[sel] - p, axis=1)
                      <= np.linalg.norm(targets[sel] - points[sel], axis=1))
            moved[pending[better]] = np.linalg.norm(p[better] - points[sel[better]], axis=1)
            good = sel[better]
            uv[good], points[good] = new[better], p[better]
            su[good], sv[good] = du[better], dv[better]
            pending = pending[~better]
            if pending.size == 0:
                break
            step[pending] *= 0.5
        active[idx[moved <= stop]] = False   # converged, or no step helps (a border minimum)
    return uv, points, su, sv


def _angles(n0, n1, folded):
    """Angles (degrees) between unit normals, folded to at most 90 where ``folded``
    (a number or one per row)."""
    cos = np.clip(np.einsum("ij,ij->i", n0, n1), -1.0, 1.0)
    angles = np.degrees(np.arccos(cos))
    return np.where(folded, np.minimum(angles, 180.0 - angles), angles)


@dataclass(frozen=True)
class _Track:
    """One side of a join sampled along its edge: the face, its FORWARD edge, the edge
    parameters of the samples and the step that moves each off a pole into the edge
    (:func:`_off_poles`)."""

    face: int
    edge: object
    params: np.ndarray
    inward: np.ndarray


def _tracks(model, join, samples):
    """The two :class:`_Track` of ``join``: side 0 at ``samples`` parameters uniform on
    its edge's range, side 1 at the same fractions of its own (from the other end when
    the edges are ``opposed``)."""
    s = np.linspace(0.0, 1.0, samples)
    towards_middle = np.where(s < 0.5, 1.0, -1.0)
    tracks = []
    for side, turned in zip(join.sides, (False, join.opposed)):
        edge = model.edge(side.edge)
        _, first, last = _pcurve(model, edge, side.face)
        params = (last - s * (last - first)) if turned else (first + s * (last - first))
        inward = NUDGE * (last - first) * towards_middle * (-1.0 if turned else 1.0)
        tracks.append(_Track(side.face, edge, params, inward))
    return tracks


def _measure(model, joins, samples):
    """Per-sample gaps and angles (each (len(joins), samples)) of ``joins`` on ``model``
    (see the module doc).

    All joins at once: the samples of side 0 of every join, then of side 1, are the rows;
    each row's partner is the same sample on the join's other side.  Each face's points
    are evaluated together (:meth:`_Model.evaluate`) and every row's point is projected
    onto its partner's face, from the partner's point, in one Gauss-Newton run
    (:func:`_project`).
    """
    pairs = [_tracks(model, join, samples) for join in joins]
    tracks = [pair[0] for pair in pairs] + [pair[1] for pair in pairs]
    if not tracks:
        return np.empty((0, samples)), np.empty((0, samples))
    n = len(joins) * samples
    partner = np.roll(np.arange(2 * n), n)
    faces = np.repeat([track.face for track in tracks], samples)
    _, boxes, signs = zip(*(model.surface(track.face) for track in tracks))
    boxes = np.repeat(boxes, samples, axis=0)[partner]
    signs = np.repeat(signs, samples)[:, None]
    uv = np.concatenate([_uv(model, track.edge, track.face, track.params) for track in tracks])
    values = model.evaluate(faces, uv)
    at = values[partner]
    _, q, qu, qv = _project(lambda rows, x: model.evaluate(faces[partner[rows]], x),
                            boxes[:, [0, 2]], boxes[:, [1, 3]], values[:, 0], uv[partner],
                            at[:, 0], at[:, 1], at[:, 2], NEWTON_STOP * model.size)
    own = _edge_normals(model, tracks, values, signs, samples)
    other, on_pole = _normals(qu, qv, signs[partner])
    other[on_pole] = own[partner][on_pole]   # a projection onto a pole
    folded = np.tile(np.repeat([not join.shared for join in joins], samples), 2)
    gaps = np.linalg.norm(values[:, 0] - q, axis=1)
    angles = _angles(own, other, folded)
    return (np.maximum(gaps[:n], gaps[n:]).reshape(-1, samples),
            np.maximum(angles[:n], angles[n:]).reshape(-1, samples))


def _edge_normals(model, tracks, values, signs, samples):
    """Unit normals along ``tracks`` from their ``values`` (:meth:`_Model.evaluate` at
    their samples) and orientation ``signs`` (one per row), moved off the poles
    (:func:`_off_poles`)."""
    normals, singular = _normals(values[:, 1], values[:, 2], signs)
    for k in np.unique(np.flatnonzero(singular) // samples):
        rows = slice(k * samples, (k + 1) * samples)
        _off_poles(model, tracks[k], normals[rows], singular[rows])
    return normals


def measure_joins(shape, joins, *, samples=24):
    """Measure ``joins`` on ``shape``: gaps and normal angles along each join.

    Parameters
    ----------
    shape : TopoDS_Shape or cadquery.Shape
        The source or a shape with the same faces and edges in the same order (a faired
        copy made by :func:`~cq_fairing.occ.fair_shape`).
    joins : iterable of Join
        From :func:`find_joins` on the source.
    samples : int, optional
        Points per join; use the value given to :func:`find_joins` to compare the
        angles sample by sample with :attr:`Join.source_angles`.

    Returns
    -------
    list of JoinMeasure
        One per join, in order.

    Raises
    ------
    InvalidInputError
        Bad ``samples``, something else than a :class:`Join`, or a join whose face or
        edge indices do not fit ``shape`` (not the same faces and edges).
    """
    shape = as_shape(shape)
    _check_samples(samples)
    model = _Model(shape)
    joins = list(joins)
    for join in joins:
        _check_fits(model, join)
    return _measures(model, joins, samples)


def _measures(model, joins, samples):
    """:class:`JoinMeasure` of each of ``joins`` on ``model`` (:func:`_measure`)."""
    return [JoinMeasure(float(gaps.max()), float(angles.max()), angles, gaps)
            for gaps, angles in zip(*_measure(model, joins, samples))]


def _check_fits(model, join):
    if not isinstance(join, Join):
        raise InvalidInputError(
            f"joins must hold Join objects from find_joins, got {type(join).__name__}.")
    for side in join.sides:
        fits = (0 <= side.face < len(model.faces) and 1 <= side.edge <= model.emap.Extent()
                and side.face in model.owners(side.edge)[0])
        if not fits:
            raise InvalidInputError(
                f"the join side (face {side.face}, edge {side.edge}) is not a face and one of "
                f"its edges in this shape ({len(model.faces)} faces, {model.emap.Extent()} "
                "edges); measure the source or a copy with the same faces and edges.")


# -- finding joins ------------------------------------------------------------------------------
def find_joins(shape, *, angle_tol=1.0, coincidence=None, samples=24):
    """The joins of ``shape``: which faces meet, along which borders, and how well.

    Parameters
    ----------
    shape : TopoDS_Shape or cadquery.Shape
        A shell, a solid, or a compound (of loose faces, shells, solids).  Not changed.
    angle_tol : float, optional
        Degrees: a join whose largest source normal angle is below it is ``"smooth"``,
        otherwise a ``"crease"``.
    coincidence : float, optional
        Distance within which two free edges of different faces are one boundary (loose
        faces, e.g. an IGES compound).  Default 1e-4 of the bounding-box diagonal; for
        each pair it is raised to the larger of the two edges' tolerances.
    samples : int, optional
        Points measured along each join (uniform in side 0's edge parameter).

    Returns
    -------
    Adjacency

    Notes
    -----
    *Shared edges.*  An edge used by exactly two faces is a join; one used by three or
    more is non-manifold (listed, not a join); a seam (listed twice for one face) and a
    degenerated edge are neither.

    *Loose boundaries.*  Free edges (used by one face) are matched geometrically, as
    sewing would pair them but without changing anything: two edges of different faces
    whose start and end points coincide (in the same or in reverse order) within the
    coincidence distance (at most :data:`~cq_fairing.core.free_edges.EDGE_SHARE` of the
    shorter edge's length, or the edges' tolerance), and whose
    :data:`~cq_fairing.core.free_edges.EDGE_PROBES` samples lie within it of each
    other (at the same fractions of the parameter range, or else by projection onto the
    other edge's 3-D curve), form a join with ``shared=False``.  Each edge is matched
    once, the closest candidate first.  Partial overlaps (one long edge against two
    short ones, a T-junction of loose faces) are not matched in this version: those
    edges stay free, and the faces may then be listed in
    :attr:`Adjacency.point_contacts`.  Two free edges of one face (an unsewn seam) are
    not a join.

    Raises
    ------
    InvalidInputError
        Bad ``shape``, ``angle_tol``, ``coincidence`` or ``samples``.
    """
    shape = as_shape(shape)
    _check_options(angle_tol, coincidence, samples)
    model = _Model(shape)
    if coincidence is None:
        coincidence = COINCIDENCE * model.size
    pairs, non_manifold, free = [], [], []
    for index in range(1, model.emap.Extent() + 1):
        if BRep_Tool.Degenerated_s(model.edge(index)):
            continue
        owners, uses = model.owners(index)
        if len(owners) >= 3:
            non_manifold.append(index)
        elif len(owners) == 2:
            pairs.append(((owners[0], index), (owners[1], index), True, False))
        elif uses == 1:
            free.append(index)
    matched = _match_free_edges(model, free, coincidence)
    pairs += [((fa, ea), (fb, eb), False, opposed) for (fa, ea), (fb, eb), opposed in matched]
    drafts = [Join((_join_side(model, *first), _join_side(model, *second)), "smooth", 0.0, 0.0,
                   None, shared, opposed) for first, second, shared, opposed in pairs]
    measures = _measures(model, drafts, samples)
    joins = [_source_join(draft, measure, angle_tol) for draft, measure in zip(drafts, measures)]
    used = {edge for (_, ea), (_, eb), _ in matched for edge in (ea, eb)}
    return Adjacency(joins, non_manifold, _point_contacts(model, joins, coincidence),
                     len(free) - len(used), float(angle_tol), float(coincidence), measures,
                     int(samples), model.size)


def _source_join(draft, measure, angle_tol):
    """``draft`` (a :class:`Join` with its sides) with its source ``measure`` and kind."""
    kind = "smooth" if measure.angle < angle_tol else "crease"
    return Join(draft.sides, kind, measure.gap, measure.angle, measure.angles, draft.shared,
                draft.opposed)


class _FreeEdge:
    """A free edge's probes: EDGE_PROBES points at uniform fractions of its range."""

    def __init__(self, model, index):
        self.index = index
        self.edge = model.edge(index)
        self.face = model.owners(index)[0][0]
        adaptor = BRepAdaptor_Curve(self.edge)
        first, last = adaptor.FirstParameter(), adaptor.LastParameter()
        self.points = np.array([adaptor.Value(float(t)).Coord()
                                for t in np.linspace(first, last, EDGE_PROBES)])
        self.tolerance = BRep_Tool.Tolerance_s(self.edge)
        self.length = probe_length(self.points)

    def distance_along(self, other):
        """Largest distance from this edge's probes to ``other``'s 3-D curve (inf when
        ``other`` has no 3-D curve or a probe does not project)."""
        curve = BRep_Tool.Curve_s(other.edge, 0.0, 0.0)
        first, last = BRep_Tool.Range_s(other.edge)
        if curve is None:
            return np.inf
        worst = 0.0
        for p in self.points[1:-1]:
            projector = GeomAPI_ProjectPointOnCurve(gp_Pnt(*p), curve, first, last)
            if projector.NbPoints() == 0:
                return np.inf
            worst = max(worst, projector.LowerDistance())
        return worst


def _match_free_edges(model, free, coincidence):
    """Pairs ``((face, edge), (face, edge), opposed)`` of coincident free edges
    (:func:`~cq_fairing.core.free_edges.match_free_edges`, the probes' distance to the
    other edge's curve by :meth:`_FreeEdge.distance_along`)."""
    if len(free) < 2:
        return []
    edges = [_FreeEdge(model, index) for index in free]
    matched = match_free_edges([e.face for e in edges], [e.points for e in edges],
                               [e.tolerance for e in edges], [e.length for e in edges],
                               coincidence,
                               lambda i, j: edges[i].distance_along(edges[j]))
    return [((edges[i].face, edges[i].index), (edges[j].face, edges[j].index), opposed)
            for i, j, opposed in matched]


def _point_contacts(model, joins, coincidence):
    """Face pairs that share a vertex (or have coincident vertices) and nothing else."""
    count = model.vertices.Extent()
    if count == 0:
        return []
    groups = list(range(count))

    def root(i):
        while groups[i] != i:
            groups[i] = groups[groups[i]]
            i = groups[i]
        return i

    vertices = [TopoDS.Vertex_s(model.vertices.FindKey(i)) for i in range(1, count + 1)]
    points = np.array([BRep_Tool.Pnt_s(v).Coord() for v in vertices])
    tolerances = np.array([BRep_Tool.Tolerance_s(v) for v in vertices])
    radius = max(coincidence, float(tolerances.max()))
    for i, j in cKDTree(points).query_pairs(radius):
        if np.linalg.norm(points[i] - points[j]) <= max(coincidence, tolerances[i], tolerances[j]):
            groups[root(i)] = root(j)
    faces_at = {}
    for i in range(count):
        faces_at.setdefault(root(i), set()).update(model.vertex_faces[i + 1])
    linked = {tuple(sorted(j.faces)) for j in joins}
    for index in range(1, model.emap.Extent() + 1):
        owners = model.owners(index)[0]
        linked.update((a, b) for a in owners for b in owners if a < b)
    contacts = set()
    for faces in faces_at.values():
        ordered = sorted(faces)
        contacts.update((a, b) for n, a in enumerate(ordered) for b in ordered[n + 1:]
                        if (a, b) not in linked)
    return sorted(contacts)
