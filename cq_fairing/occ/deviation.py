r"""How far a faired face moved, measured both ways, with OCCT as the final judge.

For UV samples :math:`(u_i, v_i)` inside the original face (``BRepTopAdaptor_FClass2d``),
the original points are :math:`p_i = S_0(u_i, v_i)` and the *true* distance is
:math:`d_i = \min_{(s,t)} |S_1(s, t) - p_i|` to the faired surface :math:`S_1`.  The way
back is measured the same way: the faired points :math:`q_i = S_1(u_i, v_i)` (the faired
face keeps the original's trim and parameter domain) and their distances
:math:`b_i = \min_{(s,t)} |S_0(s, t) - q_i|` to the original surface.  The way there
alone misses a faired face that reaches beyond the original: an impeller fillet faired
onto one cubic span in u was 0.0082 from every original sample but 0.070 away at its
own samples (tol 0.01).  The *parametric* distance :math:`|S_1(u_i, v_i) - p_i|` is an
upper bound of :math:`d_i` (fairing keeps the parameter domain).

**Batched, then judged by OCCT.**  On B-spline faces (``projection="local"``) the
samples are measured in batches by the core's vectorized Newton iteration
(:func:`~cq_fairing.core.closest_points.closest_points_surface_restarted`: started at the
sample's own parameters, where both surfaces share their parametrization, and again
from the nearest of a coarse sampling where that is nearer): each value is the
distance to an actual point of the surface, so it bounds the true distance from above
and is never above the parametric distance.  OCCT then measures again, from the largest
value down (:func:`_judge`), every sample whose batched value is at least
``JUDGED_FRACTION`` of the largest OCCT value: the sample's point evaluated by
``BRepAdaptor_Surface``, the batched foot point evaluated by OCCT and OCCT's Newton
projection (``Extrema_GenLocateExtPS``) started there; the largest are measured once
more with the global projection and the border curves (:func:`_refine_largest`).  The
maximum is therefore an OCCT measurement, and every sample left to the batched value is
below ``JUDGED_FRACTION`` of it.  The samples are taken in decreasing order of their
parametric distance, and those whose parametric distance is below that share of the
maximum, which neither way can bring to it, are measured only when the per-sample
field is read (:class:`FaceDeviation`).  Where OCCT's points differ from the core's (a
face the core reads differently), every sample is measured by OCCT, as for other faces.

**OCCT at every sample** (non-B-spline faces, ``projection="global"``): the point and
normal from ``BRepAdaptor_Surface`` and the distance from ``Extrema_GenLocateExtPS``
started at the sample's parameters, capped by the parametric distance (with
``"global"`` also ``GeomAPI_ProjectPointOnSurf`` over the whole surface).  OCCT's
projection finds orthogonal extrema only, so near a border, where the nearest point of
the bounded patch may be a border point, it can return a farther extremum; :math:`d_i`
is therefore the smallest of the two and, where Newton finds no projection, of the
nearest points of the four border curves; the largest :math:`d_i` are measured again
with the global projection and the border curves.

Every :math:`d_i` is the distance to a point of :math:`S_1`, never below the true one.
The signed distance takes the sign of :math:`(q_i - p_i)\cdot n_0(u_i, v_i)` with
:math:`q_i` the projected point and :math:`n_0` the original face's outward normal (face
orientation applied).
"""

import math
from collections.abc import Mapping

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Surface
from OCP.BRepLProp import BRepLProp_SLProps
from OCP.BRepTools import BRepTools
from OCP.Extrema import Extrema_GenLocateExtPS
from OCP.GeomAdaptor import GeomAdaptor_Surface
from OCP.GeomAPI import GeomAPI_ProjectPointOnCurve, GeomAPI_ProjectPointOnSurf
from OCP.gp import gp_Pnt
from OCP.TopAbs import TopAbs_REVERSED

from ..core.closest_points import RestartSamples, closest_points_surface_restarted, nearer_starts
from ..core.evaluation import surface_derivatives
from ..core.probes import ROUNDING, BoundWalk
from ..errors import InvalidInputError, UnsupportedGeometryError
from .convert import as_face, face_info, face_to_surface
from .trims import face_region

__all__ = ["sample_face_deviation", "face_uv_grid", "DEFAULT_DENSITY"]

DEFAULT_DENSITY = 40
JUDGED_FRACTION = 0.9   # OCCT measures again every sample at least this share of the maximum
JUDGED_BLOCK = 64       # samples OCCT measures again per step of the walk down from the largest
SAME_GEOMETRY = 1e-9    # the core's and OCCT's points agree within this share of the size


def _density(density):
    pair = (density, density) if np.ndim(density) == 0 else tuple(density)
    if len(pair) != 2 or any(isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 2
                             for d in pair):
        raise InvalidInputError(
            f"density must be an integer >= 2 or a pair of them (samples per direction), "
            f"got {density!r}."
        )
    return int(pair[0]), int(pair[1])


def face_uv_grid(face, density=DEFAULT_DENSITY, classify=True):
    """A UV grid over the face's UV box and the mask of samples inside the trim.

    Parameters
    ----------
    face : TopoDS_Face
    density : int or (int, int)
        Samples per direction.
    classify : bool, optional
        ``False`` for a face known to be untrimmed: every sample is inside.

    Returns
    -------
    u : ndarray, shape (n_u,)
    v : ndarray, shape (n_v,)
    inside : ndarray of bool, shape (n_u, n_v)
        ``True`` where ``BRepTopAdaptor_FClass2d`` classifies the point IN or ON the face
        (:func:`~cq_fairing.occ.trims.face_region`: the same answers, asked of OCCT only
        near the trim).
    """
    nu, nv = _density(density)
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    s0, s1, t0, t1 = BRep_Tool.Surface_s(face).Bounds()
    u = np.clip(np.linspace(u0, u1, nu), s0, s1)
    v = np.clip(np.linspace(v0, v1, nv), t0, t1)
    if not classify:
        return u, v, np.ones((nu, nv), dtype=bool)
    return u, v, face_region(face)(u, v)


PROJECTIONS = ("local", "global")


def sample_face_deviation(original_face, faired_face, density=DEFAULT_DENSITY,
                          projection="local", surfaces=None):
    """Distances from the original face to the faired one on dense UV samples.

    Parameters
    ----------
    original_face, faired_face : TopoDS_Face or cadquery.Face
        The faired face must share the original's UV domain (as fairing guarantees).
    density : int or (int, int), optional
        Samples per direction over the original face's UV box; samples outside the trim
        are dropped.  An untrimmed face (``face_info(face).trimmed`` false: one wire on
        the borders of its surface) keeps every sample, as the fairing of a face does,
        without asking OCCT's classifier about each (6 ms on 40 x 40 samples).
    projection : {"local", "global"}, optional
        ``"local"``: on B-spline faces, the core's batched Newton projection started at
        each sample's own parameters, OCCT measuring again every sample near the maximum
        (module notes); on other faces OCCT's Newton projection
        (``Extrema_GenLocateExtPS``) at every sample, about 10 us a point.
        ``"global"``: OCCT at every sample, also ``GeomAPI_ProjectPointOnSurf`` over the
        whole surface (about 1 ms a point), capped by the local result.  Either way the
        largest distances are then measured again by OCCT with
        ``GeomAPI_ProjectPointOnSurf`` and the border curves, down to the first that
        stays the largest (:func:`_refine_largest`).  Every distance returned is the
        length to an actual point of the faired surface, so it is never below the true
        distance: a tolerance verified with ``"local"`` holds.
    surfaces : (BSplineSurface, BSplineSurface), optional
        The core surfaces of both faces if already at hand (the faired one as built into
        ``faired_face``; OCCT's judge checks that they agree with the faces); read from
        the faces by default.

    Returns
    -------
    FaceDeviation
        A mapping: ``uv`` (N, 2), ``points`` (N, 3) on the original, ``faired_points`` (N, 3) at the
        same parameters on the faired face, ``normals`` (N, 3) of the original,
        ``distance`` (N,) true distance of the original points to the faired surface,
        ``distance_back`` (N,) of the faired points to the original surface,
        ``parametric`` (N,), ``signed`` (N,) (``distance`` with the side of the
        original's normal); the summaries ``max`` (two-sided: the largest of
        ``distance`` and ``distance_back``, measured by OCCT), ``mean``, ``rms`` (of
        ``distance``) and ``max_parametric``.
    """
    original_face = as_face(original_face, "original_face")
    faired_face = as_face(faired_face, "faired_face")
    if projection not in PROJECTIONS:
        raise InvalidInputError(
            f"projection must be one of {PROJECTIONS}, got {projection!r}."
        )
    grid = face_uv_grid(original_face, density, classify=face_info(original_face).trimmed)
    return deviation_on_grid(original_face, faired_face, grid, projection, surfaces=surfaces)


def reference_samples(face, *grids, surface=None):
    """``(uv, points, normals)`` of ``face`` on one or more :func:`face_uv_grid` grids.

    ``surface``: the face's core surface if already read (``face_to_surface``).
    """
    uv = np.concatenate([np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)[inside]
                         for u, v, inside in grids])
    if uv.size == 0:
        raise InvalidInputError("no UV sample falls inside the face; raise the density.")
    surface = surface or _core_surface(face)
    if surface is None:
        points, normals = _points_and_normals(face, uv)
    else:
        points, normals = _core_points_and_normals(surface, face, uv)
    return uv, points, normals


def deviation_on_grid(original_face, faired_face, grid, projection="local", reference=None,
                      surfaces=None):
    """:func:`sample_face_deviation` on a precomputed :func:`face_uv_grid` (trusted).

    ``reference`` may hold :func:`reference_samples` of the original on that grid, and
    ``surfaces`` the core surfaces of both faces if already at hand (the faired one as
    built into ``faired_face``); OCCT's judge checks that they agree with the faces.
    """
    if projection == "local" and surfaces is None:
        surfaces = _core_surface(original_face), _core_surface(faired_face)
    uv, points, normals = reference or reference_samples(
        original_face, grid, surface=surfaces[0] if surfaces else None)
    if projection == "local" and None not in surfaces:
        return BatchedCheck(original_face, faired_face, surfaces, (uv, points, normals)).deviation()
    return _occt_deviation(original_face, faired_face, uv, points, normals,
                           projection == "global")


def _occt_deviation(original_face, faired_face, uv, points, normals, use_global):
    """The :class:`FaceDeviation` of OCCT's measure at every sample (:func:`_by_occt`)."""
    faired_points, parametric, there, back = _by_occt(original_face, faired_face, uv, points,
                                                      use_global)
    known = _known(uv, points, faired_points, normals, parametric)
    known["max"] = float(max(there[0].max(), back[0].max()))
    return FaceDeviation(known, lambda: _field(points, normals, there, back))


FIELD = ("distance", "distance_back", "signed", "mean", "rms")
KEYS = ("uv", "points", "faired_points", "normals", "parametric", "max", "max_parametric") \
    + FIELD


class FaceDeviation(Mapping):
    """The samples and figures of a deviation check, the keys of
    :func:`sample_face_deviation`'s result.

    The maximum is measured at once; the per-sample field (``distance``,
    ``distance_back``, ``signed``, ``mean``, ``rms``: a map's values, a report's
    figures) is completed on first read, where the batched check left samples that
    cannot reach the maximum unmeasured (:class:`BatchedCheck`).  Pickled as a plain
    dict, field included.
    """

    def __init__(self, known, complete):
        self._values, self._complete = known, complete

    def __getitem__(self, key):
        if key in FIELD and self._complete is not None:
            self._values.update(self._complete())
            self._complete = None
        return self._values[key]

    def __iter__(self):
        return iter(KEYS)

    def __len__(self):
        return len(KEYS)

    def __reduce__(self):
        return dict, (dict(self),)


def _known(uv, points, faired_points, normals, parametric):
    """The entries of a :class:`FaceDeviation` known before any closest point."""
    return {"uv": uv, "points": points, "faired_points": faired_points, "normals": normals,
            "parametric": parametric, "max_parametric": float(parametric.max())}


def _field(points, normals, there, back):
    """The per-sample entries of a :class:`FaceDeviation` from both ways'
    ``(distance, nearest points)``."""
    (distance, projected), (back_distance, _) = there, back
    sign = np.sign(np.einsum("ij,ij->i", projected - points, normals))
    return {"distance": distance, "distance_back": back_distance, "signed": sign * distance,
            "mean": float(distance.mean()), "rms": float(np.sqrt(np.mean(distance ** 2)))}


class _NotTheSameGeometry(Exception):
    """OCCT's point of a face differs from the core's reading of it: measure with OCCT."""


def _core_surface(face):
    """The core's :class:`~cq_fairing.core.geometry.BSplineSurface` of a B-spline face
    (:func:`~cq_fairing.occ.convert.face_to_surface`), ``None`` for other faces."""
    try:
        return face_to_surface(face)[0]
    except UnsupportedGeometryError:
        return None


def _in_domain(surface, uv):
    (u0, u1), (v0, v1) = surface.domain
    return np.clip(uv[:, 0], u0, u1), np.clip(uv[:, 1], v0, v1)


def _core_points(surface, uv):
    return surface_derivatives(surface, *_in_domain(surface, uv), 0)[(0, 0)]


def _core_points_and_normals(surface, face, uv):
    """Points and unit normals (face orientation applied; zero where ``S_u x S_v``
    vanishes) of the core's ``surface`` at ``uv``, all at once."""
    d = surface_derivatives(surface, *_in_domain(surface, uv), 1)
    normals = np.cross(d[(1, 0)], d[(0, 1)])
    length = np.linalg.norm(normals, axis=1)
    defined = length > 1e-12 * max(1.0, float(length.max(initial=0.0)))
    flip = -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0
    normals[defined] *= flip / length[defined, None]
    normals[~defined] = 0.0
    return d[(0, 0)], normals


class BatchedCheck:
    r"""The check of one faired face against its original on fixed samples, by the
    core's batched projection both ways, measured only where the maximum can be, OCCT
    judging the samples near it.

    Each way's batched distance at a sample is at most the parametric distance
    :math:`|S_1(u_i, v_i) - p_i|` (its Newton run starts at the sample's parameters and
    only takes steps that bring it nearer), so the samples are measured in decreasing
    order of it (:class:`~cq_fairing.core.probes.BoundWalk`) down to ``JUDGED_FRACTION``
    of the largest batched value, OCCT's judge (:func:`_judge`) runs on them, and the
    walk goes on down to that share of the judged maximum (judged again) where that is
    lower.  No sample passed over can reach the maximum, nor be within
    ``JUDGED_FRACTION`` of it: the maximum is the one of measuring every sample.  The
    samples passed over are measured by the batched projection when the field is first
    read.  Where OCCT's points differ from the core's, every sample is measured by OCCT
    (:func:`_by_occt`).

    With ``seeds``, the foot points of another faired surface on the same samples
    (:meth:`seeds` of its check: a polished net after its unpolished one), each way's
    Newton run at a sample starts from the seed where the seed's point is nearer
    (:func:`~cq_fairing.core.closest_points.nearer_starts`), and the walk's bound is that
    nearer distance: a net that slides along its source keeps its samples' feet where
    they were, far nearer than the same parameters.

    Parameters
    ----------
    original_face, faired_face : TopoDS_Face
    surfaces : (BSplineSurface, BSplineSurface)
        The core surfaces of both faces (the faired one as built into ``faired_face``).
    reference : (ndarray, ndarray, ndarray)
        :func:`reference_samples` of the original.
    seeds : (ndarray, ndarray), optional
        ``(feet on the faired surface, feet on the original)``, each (q, 2).
    """

    def __init__(self, original_face, faired_face, surfaces, reference, seeds=None):
        original, faired = surfaces
        self.faces, self.reference = (original_face, faired_face), reference
        uv, points, _ = reference
        self.faired_points = _core_points(faired, uv)
        self.parametric = np.linalg.norm(self.faired_points - points, axis=1)
        there, back = (None, None) if seeds is None else seeds
        self.ways = (_Way(faired_face, faired, original_face, points, uv, self.parametric,
                          there),
                     _Way(original_face, original, faired_face, self.faired_points, uv,
                          self.parametric, back))
        self.slack = ROUNDING * max(original.size, faired.size)
        self.walk = BoundWalk(np.maximum(*(way.bound for way in self.ways)))
        self.level, self.judged = 0.0, None
        self.pending = 0.0   # largest batched value of the samples taken since judged

    def exceeds(self, tol):
        """Whether the check's maximum exceeds ``tol``, measuring only what decides it.

        The walk measures the samples whose bound (the distance at their Newton starts)
        exceeds ``tol``, in batches; OCCT judges the samples measured whenever a batched value exceeds
        ``tol``, and the first judged maximum above ``tol`` answers ``True`` (the judged
        maximum of samples measured is a lower bound of the full one).  ``False`` once
        every sample that could exceed ``tol`` is measured and none does: the maximum
        :meth:`deviation` gives is then within ``tol``, and it goes on from these
        samples.  Where OCCT's points differ from the core's the answer is ``False``
        and :meth:`deviation` measures every sample by OCCT."""
        try:
            while True:
                if self.judged is not None and self.judged > tol:
                    return True
                if self.pending > tol and self._judge() > tol:
                    return True
                if self.walk.next_bound <= tol - self.slack:
                    return False
                self._take(tol - self.slack)
        except _NotTheSameGeometry:
            return False

    def deviation(self):
        """The :class:`FaceDeviation` of the faired face."""
        uv, points, normals = self.reference
        try:
            while self.judged is None or self._below_next():
                while self._below_next():
                    self._take(JUDGED_FRACTION * self.level - self.slack)
                self._judge()
        except _NotTheSameGeometry:
            points, normals = _points_and_normals(self.faces[0], uv)
            return _occt_deviation(*self.faces, uv, points, normals, False)
        known = _known(uv, points, self.faired_points, normals, self.parametric)
        known["max"] = self.judged

        def field():
            rest = self.walk.rest()
            return _field(points, normals, *(way.completed(rest) for way in self.ways))

        return FaceDeviation(known, field)

    def seeds(self):
        """``(feet on the faired surface, feet on the original)`` at every sample, (q, 2)
        each: the foot points found where measured, the start parameters elsewhere; the
        ``seeds`` of the check of a nearby surface."""
        return tuple(way.feet.copy() for way in self.ways)

    def _below_next(self):
        """Whether the next sample's bound reaches ``JUDGED_FRACTION`` of the level (the
        largest batched value, then the judged maximum)."""
        return self.walk.next_bound > JUDGED_FRACTION * self.level - self.slack

    def _take(self, floor=-np.inf):
        """Measure the walk's next batch both ways (its samples whose bound is above
        ``floor``); before any judging the level follows the largest batched value."""
        index = self.walk.take(floor)
        batched = max(float(way.measure(index).max()) for way in self.ways)
        self.pending = max(self.pending, batched)
        if self.judged is None:
            self.level = max(self.level, batched)

    def _judge(self):
        """OCCT's judge on every sample measured; the judged maximum becomes the level."""
        taken = self.walk.taken()
        self.level = self.judged = max(way.judge(taken) for way in self.ways)
        self.pending = 0.0
        return self.judged


class _Way:
    """One way of the batched check: the distances of ``points`` (``source_face``'s points
    at ``uv``) to ``target_face``'s surface (the core's ``target``), measured a batch of
    samples at a time, each Newton run from ``uv`` or, where its point is nearer, from
    ``seeds``; :attr:`bound` is the distance at the start (``parametric`` at ``uv``)."""

    def __init__(self, target_face, target, source_face, points, uv, parametric, seeds=None):
        self.target_face, self.target, self.source_face = target_face, target, source_face
        self.points, self.uv = points, uv
        if seeds is None:
            self.starts, self.bound = uv, parametric
        else:
            self.starts, self.bound = nearer_starts(target, points, uv, seeds, parametric)
        self.distance = np.zeros(len(points))
        self.feet = np.array(self.starts, dtype=float)
        self.projected = np.zeros_like(points)
        self._restarts = None
        self._judged = None

    def measure(self, index):
        """The batched distances at samples ``index``, kept with their foot points
        (:func:`~cq_fairing.core.closest_points.closest_points_surface_restarted`)."""
        if self._restarts is None:
            self._restarts = RestartSamples(self.target)
        starts = self.starts[index]
        s, t, distance = closest_points_surface_restarted(
            self.target, self.points[index], starts[:, 0], starts[:, 1],
            samples=self._restarts)
        self.distance[index], self.feet[index] = distance, np.column_stack([s, t])
        self.projected[index] = _core_points(self.target, self.feet[index])
        return distance

    def judge(self, index):
        """OCCT's judge (:func:`_judge`) on the measured samples ``index``; their maximum."""
        distance, projected = self.distance[index], self.projected[index]
        _judge(self.target_face, self.source_face, self.uv[index], self.feet[index],
               self.points[index], distance, projected, self.target.size)
        self._judged = index, distance, projected
        return float(distance.max())

    def completed(self, rest):
        """``(distance, nearest points)`` at every sample: the judged values where judged,
        the batched ones elsewhere, ``rest`` (the samples not measured yet) measured."""
        if rest.size:
            self.measure(rest)
        distance, projected = self.distance.copy(), self.projected.copy()
        index, judged, nearest = self._judged
        distance[index], projected[index] = judged, nearest
        return distance, projected


def _by_occt(original_face, faired_face, uv, points, use_global):
    """Both ways by OCCT at every sample: ``(faired_points, parametric, (distance,
    nearest points), (distance back, nearest points back))``."""
    faired_points, _ = _points_and_normals(faired_face, uv, normals=False)
    parametric = np.linalg.norm(faired_points - points, axis=1)
    there = _distances_to(faired_face, points, uv, faired_points, parametric, use_global)
    back = _distances_to(original_face, faired_points, uv, points, parametric, use_global)
    return faired_points, parametric, there, back


def _judge(target_face, source_face, uv, feet, points, distance, projected, size):
    """OCCT measures again, in place, every sample whose batched ``distance`` is at least
    ``JUDGED_FRACTION`` of the largest OCCT value, walking down from the largest in
    blocks of ``JUDGED_BLOCK``, and measures the largest once more with the global
    projection and the border curves (:func:`_refine_largest`), until the walk's next
    sample is below that share of the maximum.

    Per judged sample: the point ``source_face`` has at ``uv`` (``BRepAdaptor_Surface``),
    the batched foot point evaluated by OCCT, and OCCT's Newton projection
    (``Extrema_GenLocateExtPS``) started at the foot's parameters, the nearer kept.

    Raises
    ------
    _NotTheSameGeometry
        OCCT's source point or its distance to the foot point differs from the core's
        by more than ``SAME_GEOMETRY`` times ``size``.
    """
    surface = BRep_Tool.Surface_s(target_face)
    judge_one = _JudgeOne(GeomAdaptor_Surface(surface), BRepAdaptor_Surface(source_face),
                          SAME_GEOMETRY * max(size, 1e-300))
    borders = _Borders(surface)
    order = np.argsort(distance)[::-1]
    judged = np.zeros(distance.size, dtype=bool)
    walked = 0
    while walked < order.size:
        while walked < order.size and distance[order[walked]] >= JUDGED_FRACTION * \
                distance[judged].max(initial=0.0):
            block = order[walked:walked + JUDGED_BLOCK]
            walked += block.size
            for k, at, foot, point in zip(block.tolist(), uv[block].tolist(),
                                          feet[block].tolist(), points[block].tolist()):
                distance[k], projected[k] = judge_one(at, foot, point, distance[k])
            judged[block] = True
        index = np.flatnonzero(judged)
        d, q = distance[index], projected[index]
        _refine_largest(surface, points[index], d, q, borders)
        distance[index], projected[index] = d, q
        if walked >= order.size or distance[order[walked]] < JUDGED_FRACTION * d.max():
            break


class _JudgeOne:
    """OCCT's distance of one sample (see :func:`_judge`): ``adaptor`` the target
    surface's, ``source`` the source face's, ``agree`` the largest difference from the
    core's points allowed."""

    def __init__(self, adaptor, source, agree):
        self.adaptor, self.source, self.agree = adaptor, source, agree
        self.local = Extrema_GenLocateExtPS(adaptor)

    def __call__(self, uv, foot, point, batched):
        """``(distance, nearest point)`` of the source's point at ``uv`` (the core's
        ``point``, at ``batched`` from the core's ``foot`` parameters)."""
        p = self.source.Value(*uv)
        if math.dist((p.X(), p.Y(), p.Z()), point) > self.agree:
            raise _NotTheSameGeometry
        q = self.adaptor.Value(*foot)
        if abs(p.Distance(q) - batched) > self.agree:
            raise _NotTheSameGeometry
        self.local.Perform(p, *foot)
        if self.local.IsDone() and p.Distance(self.local.Point().Value()) < p.Distance(q):
            q = self.local.Point().Value()
        return p.Distance(q), (q.X(), q.Y(), q.Z())


def _distances_to(face, points, uv, same_parameter, parametric, use_global):
    """Distances of ``points`` (taken at ``uv``) to ``face``'s surface and the nearest
    points found: :func:`_project`, capped by the ``same_parameter`` points of the
    surface at ``parametric`` distance, the largest measured again
    (:func:`_refine_largest`)."""
    surface = BRep_Tool.Surface_s(face)
    borders = _Borders(surface)
    distance, projected = _project(surface, points, uv, use_global, borders)
    closer = parametric < distance
    distance[closer] = parametric[closer]
    projected[closer] = same_parameter[closer]
    _refine_largest(surface, points, distance, projected, borders)
    return distance, projected


def _points_and_normals(face, uv, normals=True):
    """OCCT's points and unit normals (face orientation applied) at ``uv``, one by one."""
    adaptor = BRepAdaptor_Surface(face)
    points = np.empty((len(uv), 3))
    out_normals = np.zeros((len(uv), 3))
    flip = -1.0 if face.Orientation() == TopAbs_REVERSED else 1.0
    props = BRepLProp_SLProps(adaptor, 1, 1e-9) if normals else None
    for k, (a, b) in enumerate(uv):
        p = adaptor.Value(float(a), float(b))
        points[k] = (p.X(), p.Y(), p.Z())
        if props is not None:
            props.SetParameters(float(a), float(b))
            if props.IsNormalDefined():
                n = props.Normal()
                out_normals[k] = (flip * n.X(), flip * n.Y(), flip * n.Z())
    return points, out_normals


def _project(surface, points, uv, use_global, borders):
    """Distances of ``points`` to ``surface`` and the nearest points found.

    ``Extrema_GenLocateExtPS`` (Newton from the sample's parameters) for every point;
    with ``use_global`` also ``GeomAPI_ProjectPointOnSurf``, keeping the nearer point.
    Where Newton fails, the nearest of the same-parameter point and the nearest points of
    the four border curves (:class:`_Borders`) is used: the nearest point of a bounded
    patch that is no orthogonal projection lies on its border (a candidate that slid
    along the source: on a testtoler strip face Newton failed at a sample 5.2 from the
    faired surface, whose same-parameter distance is 15.1).  Every candidate is a point
    of the surface, so the distance is never below the true one.
    """
    adaptor = GeomAdaptor_Surface(surface)
    projector = None
    if use_global:
        s0, s1, t0, t1 = surface.Bounds()
        projector = GeomAPI_ProjectPointOnSurf()
        projector.Init(surface, s0, s1, t0, t1)
    distance = np.empty(len(points))
    projected = np.empty_like(points)
    for k, (x, y, z) in enumerate(points):
        p = gp_Pnt(float(x), float(y), float(z))
        local = Extrema_GenLocateExtPS(adaptor)
        local.Perform(p, float(uv[k, 0]), float(uv[k, 1]))
        if local.IsDone():
            q = local.Point().Value()
        else:
            q = borders.nearer(p, surface.Value(*map(float, uv[k])))
        if projector is not None:
            projector.Perform(p)
            if projector.NbPoints() > 0 and projector.LowerDistance() < p.Distance(q):
                q = projector.NearestPoint()
        distance[k] = p.Distance(q)
        projected[k] = (q.X(), q.Y(), q.Z())
    return distance, projected


def _refine_largest(surface, points, distance, projected, borders=None):
    """Measure the largest ``distance`` values again, in place, until the largest is one
    measured again.

    Newton from a sample's parameters can converge to an extremum that is not the
    nearest point (the terrain's fair fit: 12.81 at a sample 10.06 from the faired
    surface, whose tol is 11.58).  From the largest down, each sample takes the nearer
    of its point, ``GeomAPI_ProjectPointOnSurf``'s nearest extremum and the nearest
    point of the border curves (:class:`_Borders`); the walk stops at the first sample
    not above the largest value measured again, so the maximum is a measured-again
    value.  Usually one sample, 1-40 ms.  ``borders``: the surface's :class:`_Borders`,
    if already built.
    """
    projector, borders = None, borders or _Borders(surface)
    largest = -np.inf
    for k in np.argsort(distance)[::-1]:
        if distance[k] <= largest:
            break
        if projector is None:
            projector = GeomAPI_ProjectPointOnSurf()
            projector.Init(surface, *surface.Bounds())
        p = gp_Pnt(*map(float, points[k]))
        q = gp_Pnt(*map(float, projected[k]))
        projector.Perform(p)
        if projector.NbPoints() > 0 and projector.LowerDistance() < p.Distance(q):
            q = projector.NearestPoint()
        q = borders.nearer(p, q)
        distance[k] = p.Distance(q)
        projected[k] = (q.X(), q.Y(), q.Z())
        largest = max(largest, distance[k])


class _Borders:
    """The four border curves of a bounded surface (iso-curves at its parameter bounds),
    built on first use."""

    def __init__(self, surface):
        self.surface = surface
        self._curves = None

    def nearer(self, p, q):
        """The nearest to ``p`` of ``q`` and of each border curve's orthogonal projections
        and end points (the patch's corners)."""
        if self._curves is None:
            s0, s1, t0, t1 = self.surface.Bounds()
            self._curves = [self.surface.UIso(s0), self.surface.UIso(s1),
                            self.surface.VIso(t0), self.surface.VIso(t1)]
        best, best_distance = q, p.Distance(q)
        for curve in self._curves:
            candidates = [curve.Value(curve.FirstParameter()), curve.Value(curve.LastParameter())]
            projection = GeomAPI_ProjectPointOnCurve(p, curve)
            if projection.NbPoints() > 0:
                candidates.append(projection.NearestPoint())
            for point in candidates:
                if p.Distance(point) < best_distance:
                    best, best_distance = point, p.Distance(point)
        return best
