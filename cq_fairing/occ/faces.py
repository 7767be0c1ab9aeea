r"""Fair one OCP face: :func:`fair_face` and its :class:`FaceFairReport`.

Pipeline: classify the face; convert it to NURBS on request; take its net
(:func:`~cq_fairing.occ.face_to_surface`); choose the target (explicit ``n`` or the
fewest poles within ``tol``, :mod:`cq_fairing.core.scale_search`); fair with the core
(:func:`cq_fairing.fair_surface`), or with ``method="adaptive"`` let the core choose
non-uniform targets within ``tol`` (:mod:`cq_fairing.core.adaptive`); put the faired surface under the face's own trim
(:func:`~cq_fairing.occ.surface_to_face`); measure the deviation with OCCT's projection
(:func:`~cq_fairing.occ.sample_face_deviation`).

Special cases handled, not refused:

* **rational** faces are faired in homogeneous coordinates :math:`(w P, w)`; if a
  weight of the result is not positive, a non-rational least-squares approximation in
  the same spline spaces is faired instead and ``message`` says so.  The adaptive
  method projects :math:`(w P, w)` too and refuses candidates with a weight
  :math:`\le 0` (no polish: :mod:`cq_fairing.core.adaptive`, note 6).  Energy fairing
  keeps the net and fairs polynomial surfaces only: a rational face gets status
  ``'skipped-rational'`` and is left unchanged;
* **periodic** directions are faired on the unperiodized (clamped) net and the first
  and last rows are tied to their mean afterwards, so the surface stays closed (G0 at
  the seam; tangent continuity across the seam is not enforced);
* **trimmed** faces keep their wires and UV pcurves (same parameter domain);
* ``boundary="fixed"`` keeps the border rows of the source net (``"wavelet"`` and
  ``"adaptive"``; the energy method keeps them by itself): the faired surface is
  projected back into the source spaces (L2, exact when the spaces are nested) and its
  border rows are replaced by the source's, so the natural boundary curves do not
  move (the result has as many poles as the source: fairer, not lighter).
"""

import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Literal, NamedTuple

import numpy as np
from OCP.Bnd import Bnd_Box
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
from OCP.TopoDS import TopoDS, TopoDS_Face

from ..core.adaptive_surface import fair_surface_adaptive
from ..core.fairing import fair_surface
from ..core.geometry import BSplineSurface, closed_axes, collapse_rows, collapsed_rows
from ..core.options import check_face_options, renamed_value
from ..core.plans import target_space
from ..core.results import SurfaceFairResult
from ..core.scale_search import SurfaceSampler, max_scales, search_scales, target_degrees
from ..core.spaces import SplineSpace
from ..errors import (
    InvalidInputError,
    NumericalError,
    ToleranceNotMetError,
    UnsupportedGeometryError,
)
from .builders import face_uv_box
from .convert import FaceInfo, as_face, face_info, face_to_surface, surface_to_face
from .deviation import deviation_on_grid, exceeds_on_widest, face_uv_grid, reference_samples
from .trims import face_region

if TYPE_CHECKING:
    import cadquery

__all__ = ["fair_face", "FaceFairReport", "default_tolerance"]

MARGIN = 0.9
STATUSES = ("faired", "unchanged", "skipped-not-bspline", "skipped-rational",
            "skipped-not-selected", "tolerance-not-met", "failed")


@dataclass(eq=False)
class FaceFairReport:
    """What happened to one face.

    Attributes
    ----------
    face : TopoDS_Face
        The faired face, or the original one when it was not faired.
    status : str
        ``'faired'``, ``'unchanged'`` (nothing to reduce), ``'skipped-not-bspline'``,
        ``'skipped-rational'`` (``method="energy"``), ``'skipped-not-selected'``,
        ``'tolerance-not-met'`` or ``'failed'``.
    message : str
        One line for the user (empty when there is nothing to say).
    result : SurfaceFairResult or None
        The core result (faired net, details) when faired.
    info : FaceInfo or None
    poles_before, poles_after : (int, int) or None
        Poles per direction of the source net and of the faired net.
    max_deviation : float or None
        Largest true distance (``GeomAPI_ProjectPointOnSurf``) from samples of the
        original face to the faired surface.
    tolerance : float or None
        The tolerance asked for (``None`` with explicit ``n``).
    seconds : float
        Wall time spent on this face.
    deviation : dict or None
        The full :func:`~cq_fairing.occ.sample_face_deviation` samples.
    original : TopoDS_Face or None
        The input face.
    surface : BSplineSurface or None
        The faired surface under ``face`` (after seam tying / border fixing).
    index : int or None
        Position in the shape (set by ``fair_shape``).
    """

    face: object
    status: str
    message: str = ""
    result: SurfaceFairResult = None
    info: FaceInfo = None
    poles_before: tuple = None
    poles_after: tuple = None
    max_deviation: float = None
    tolerance: float = None
    seconds: float = 0.0
    deviation: dict = field(default=None, repr=False)
    original: object = field(default=None, repr=False)
    surface: object = field(default=None, repr=False)
    index: int = None

    @property
    def faired(self):
        return self.status == "faired"


def default_tolerance(shape):
    """Default tolerance: 1e-3 of the bounding-box diagonal of ``shape`` (model units)."""
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    x0, y0, z0, x1, y1, z1 = box.Get()
    return 1e-3 * float(np.linalg.norm([x1 - x0, y1 - y0, z1 - z0]))


def fair_face(face: "TopoDS_Face | cadquery.Face", *, tol: float | None = None,
              n: tuple[int | None, int | None] | None = None,
              method: Literal["wavelet", "adaptive", "energy"] = "wavelet",
              objective: Literal["compact", "faithful", "fair"] = "compact",
              convert: bool = False, boundary: Literal["free", "fixed"] = "free",
              target_degree: int | tuple[int, int] | None = None,
              density: int | tuple[int, int] | None = None, details: bool = True,
              search: Literal["local", "guaranteed", "linear", "polyfit"] = "local",
              borders: Literal["auto", "free", "pinned"] = "auto") -> FaceFairReport:
    r"""Fair one face and put the result under the face's own trim.

    Parameters
    ----------
    face : TopoDS_Face or cadquery.Face
        Not modified.
    tol : float, optional
        Largest allowed distance (model units) between original and faired face; the
        fewest poles within it are searched.  Default (with ``n`` also ``None``):
        1e-3 of the face's bounding-box diagonal.
    n : (int or None, int or None) or int, optional
        Explicit target scales (knot spans) per direction, passed to
        :func:`cq_fairing.fair_surface`; ``None`` keeps a direction.
    method : {"wavelet", "adaptive", "energy"}
        ``"wavelet"``: multiresolution (ARWFA/DWFA) fairing onto quasi-uniform targets.
        ``"adaptive"``: the same exact L2 projection onto u and v targets whose knots
        follow the error (``cq_fairing.fair_surface(method="adaptive")``), usually
        fewer poles at the same ``tol``.  ``"energy"``: Eck-Hadenfeld local thin-plate
        energy fairing that keeps the net, each pole within ``tol`` of its place
        (``cq_fairing.fair_surface(method="energy")``), so the same-parameter distance,
        and with it the true distance, stays within ``tol``.  ``"adaptive"`` and
        ``"energy"`` need ``tol`` (or the default) and refuse ``n`` and ``search``;
        ``"energy"`` also refuses ``target_degree`` and ``boundary="fixed"``.  The
        options' names, values and defaults: :mod:`cq_fairing.core.options`.
        ``"wavelet"`` and ``"adaptive"`` fair rational faces in homogeneous coordinates
        (``"adaptive"`` without its polish); ``"energy"`` fairs polynomial faces only
        (rational ones: ``'skipped-rational'``).
    objective : {"compact", "faithful", "fair"}
        ``method="adaptive"`` only.  ``"compact"``: the fewest poles within ``tol``;
        ``"faithful"``: stop where the residual reaches the net's estimated noise level
        (more poles, closer to the noise-free shape), within ``tol``; ``"fair"``: the
        fairest of the compact net and that net with up to two more spans per direction,
        pinned borders given up for a free-border net with half the energy or less
        (:func:`cq_fairing.core.adaptive.fair_surface_adaptive`).
    convert : bool, optional
        Convert a non-B-spline face to NURBS (``BRepBuilderAPI_NurbsConvert``, exact)
        instead of skipping it.
    boundary : {"free", "fixed"}
        ``"fixed"`` puts the source's border rows of poles back after the fit (see module
        notes); refused with ``method="energy"``, which keeps the border ring anyway.
    target_degree : int or (int, int), optional
        Default ``min(3, source degree)`` per direction; refused with
        ``method="energy"``, which keeps the degree.
    density : int or (int, int), optional
        UV samples per direction for the deviation check; default
        ``clip(2 k + 1, 20, 400)`` for ``k`` poles in that direction.
    details : bool, optional
        Compute the wavelet details (``report.result``) with the core after the local
        search, which does not; ``False`` skips that step (``result`` is then ``None``)
        and is faster on large nets.  The core's searches and the adaptive and energy
        methods return their core result, details included, at no extra cost.
    search : {"local", "guaranteed", "linear", "polyfit"}
        How the ``method="wavelet"`` target is found with ``tol``.  ``"local"``:
        bisection on the face's own samples (inside the trim) with the distance to the
        faired tangent planes (:mod:`cq_fairing.core.scale_search`); the others:
        ``cq_fairing.fair_surface(tol=..., search=...)``, the core's accuracy control
        with that step rule, measured in the face's UV box.  Either way OCCT's
        projection checks the result; if it fails, the local search runs again with the
        parametric distance, an upper bound of the true distance.  Refused with ``n``
        (no search runs) and with the other methods.  ``"core"`` is the old spelling of
        ``"guaranteed"`` (a ``DeprecationWarning``, for one release).
    borders : {"auto", "free", "pinned"}
        ``method="adaptive"`` only: the border rows of the core's target
        (:func:`cq_fairing.core.adaptive.fair_surface_adaptive`).  ``"auto"`` pins them
        (corners kept, each edge projected on its own) when that gives fewer poles;
        ``"free"`` is the plain projection and often a faster search on faces whose
        pinned net slides along the surface; ``"pinned"`` always pins.  Independent of
        ``boundary``, which restores the source's border rows afterwards.

    Returns
    -------
    FaceFairReport

    Raises
    ------
    InvalidInputError, InvalidToleranceError, InvalidTargetError
        Bad arguments, or an option the chosen method or ``n`` does not use
        (:func:`cq_fairing.core.options.check_face_options`).
    ToleranceNotMetError
        No target keeps the face within ``tol`` (checked with OCCT's projection).
    """
    start = time.perf_counter()
    face = as_face(face)
    search = renamed_value("fair_face", "search", search)
    check_face_options(tol, n, method, boundary, objective, borders, search, target_degree)
    info = face_info(face)
    if not info.is_bspline:
        if not convert:
            return FaceFairReport(face, "skipped-not-bspline", (
                f"{info.surface_type} face left unchanged; pass convert=True to convert "
                "it to NURBS and fair it."), info=info, original=face,
                seconds=time.perf_counter() - start)
        face = TopoDS.Face_s(BRepBuilderAPI_NurbsConvert(face, True).Shape())
    if tol is None and n is None:
        tol = default_tolerance(face)
    criteria = _criteria(tol, search, method, objective, borders)
    try:
        report = _fair_bspline(face, tol, n, boundary, target_degree, density, details, criteria)
    except UnsupportedGeometryError as exc:  # energy: weights, a degree-1 direction
        if method != "energy":
            raise
        report = _not_for_energy(face, info, tol, exc)
    report.original = face
    report.seconds = time.perf_counter() - start
    return report


def _not_for_energy(face, info, tol, refusal):
    """Report of a face the energy method does not fair: rational faces (also those
    ``convert=True`` made rational, a cylinder's) are ``'skipped-rational'``; any other
    refusal of the core (a face with a degree-1 direction) leaves the face
    ``'unchanged'`` with the core's reason."""
    if face_info(face).rational:
        return FaceFairReport(face, "skipped-rational", (
            "rational face left unchanged: method='energy' fairs polynomial surfaces only; "
            "use method='wavelet' or 'adaptive' for it."), info=info, tolerance=tol)
    return FaceFairReport(face, "unchanged", f"face left unchanged: {refusal}", info=info,
                          tolerance=tol)


class AdaptiveTarget(NamedTuple):
    """Criterion of an attempt that lets the core's adaptive search choose the target."""

    objective: str
    borders: str


class CoreSearch(NamedTuple):
    """Criterion of an attempt that runs the core's uniform tolerance search with
    ``rule`` (one of :data:`~cq_fairing.core.options.SEARCHES`)."""

    rule: str


def _criteria(tol, search, method, objective, borders):
    """The ``(criterion, goal)`` attempts of :func:`_fair_verified`, in order.

    With explicit ``n``: one attempt.  ``method="adaptive"``: the core's adaptive search
    (criterion: an :class:`AdaptiveTarget`) at ``tol``, then at ``MARGIN * tol``;
    ``method="energy"`` likewise with the criterion ``"energy"``.
    Otherwise the requested search (``"local"`` with the normal-distance estimate, then
    the core's ``fair_surface(tol=...)``; a core step rule: the core's search with it
    alone, a :class:`CoreSearch`), then the local
    search with the parametric distance, an upper bound of the true distance; they aim
    at ``MARGIN * tol`` (room for excursions between samples), the last one at ``tol``.
    The normal distance looks from the original's samples only; where the faired face
    reaches beyond the original (OCCT's check measures both ways), the core's two-sided
    search still finds a coarse net, where the parametric distance of a face with
    strongly graded knots keeps nearly all poles (an impeller fillet: 20 x 3 poles
    against 48 x 3).
    """
    if tol is None:
        return [(None, None)]
    if method != "wavelet":
        target = AdaptiveTarget(objective, borders) if method == "adaptive" else "energy"
        return [(target, tol), (target, MARGIN * tol)]
    first = ["normal", CoreSearch("guaranteed")] if search == "local" else [CoreSearch(search)]
    return [(criterion, MARGIN * tol) for criterion in first + ["parametric"]] + \
        [("parametric", tol)]


def _fair_bspline(face, tol, n, boundary, target_degree, density, details, criteria):
    surface, info = face_to_surface(face)
    density = density or tuple(int(np.clip(2 * k + 1, 20, 400)) for k in surface.shape)
    degree = target_degrees(surface, target_degree)
    notes = []
    if info.unperiodized:
        notes.append(f"periodic in {'/'.join(info.unperiodized)}: faired the unperiodized "
                     "net with first/last rows tied (closed, G0 at the seam)")
    if boundary == "fixed" and info.trimmed:
        notes.append("boundary='fixed' keeps the surface's border rows; this trimmed face's "
                     "edges lie inside the surface, so they may still move")
    sampler = SurfaceSampler(face_uv_grid(face, density, classify=info.trimmed), surface)
    finish = _finisher(surface, info.unperiodized, boundary)
    scales = max_scales(surface, degree)
    if scales == (None, None) and n is None:
        return _unchanged(face, info, surface, "the net is already at its coarsest "
                          "(degree + 1 poles per direction); nothing to fair", tol)
    if None in scales:  # the core's uniform search coarsens both directions or none
        criteria = [c for c in criteria if not isinstance(c[0], CoreSearch)]
    try:
        return _fair_verified(face, info, surface, surface, tol, n, degree, sampler, finish,
                              details, criteria, notes)
    except NumericalError:
        notes.append("fairing in homogeneous coordinates gave non-positive weights; "
                     "faired a non-rational least-squares approximation instead")
        return _fair_verified(face, info, surface, _non_rational(surface), tol, n, degree,
                              sampler, finish, details, criteria, notes)


def _check_samples(face, grid, trimmed, surface):
    """Search grid plus the centres of its cells: the OCCT check sees between samples."""
    u, v, _ = grid
    cu, cv = 0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1])
    inside = face_region(face)(cu, cv) if trimmed else np.ones((cu.size, cv.size), dtype=bool)
    return reference_samples(face, grid, (cu, cv, inside), surface=surface)


def _fair_verified(face, info, surface, source, tol, n, degree, sampler, finish, details,
                   criteria, notes):
    """Fair, rebuild and check with OCCT; with ``tol`` retry with stricter searches.

    ``criteria`` are the attempts of :func:`_criteria`; the first whose rebuilt face
    passes the check wins.  The OCCT check runs on the search grid plus the centres of
    its cells; a candidate whose samples of largest parametric distance already put a
    lower bound of the check's maximum above ``tol``
    (:func:`~cq_fairing.occ.deviation.exceeds_on_widest`) fails without the full check,
    which then runs only if every attempt fails (for the error's best deviation).
    """
    measured, refusals, prefiltered = [], [], []
    check = None
    region = face_region(face) if info.trimmed else None
    window = _uv_window(face, source) if info.trimmed else None
    for criterion, goal in criteria:
        try:
            target, faired, result = _choose(source, goal, n, degree, sampler, finish,
                                             criterion, region, window)
        except ToleranceNotMetError as exc:
            measured.append(exc.best_deviation)
            refusals.append((goal, str(exc)))
            continue
        if target is not None and _is_identity(source, target, degree):
            return _unchanged(face, info, surface, "the finest admissible target is the "
                              "source space itself; nothing to fair", tol)
        if target is not None and _keeps_every_pole(source, target, faired):
            return _unchanged(face, info, surface, "the adaptive target needs as many poles "
                              "as the source; nothing to reduce", tol)
        new_face = surface_to_face(faired, face)
        check = check or _check_samples(face, sampler.grid, info.trimmed, surface)
        if tol is not None and exceeds_on_widest(face, new_face, (surface, faired), check, tol):
            prefiltered.append((new_face, faired))
            continue
        deviation = deviation_on_grid(face, new_face, None, reference=check,
                                      surfaces=(surface, faired))
        if tol is None or deviation["max"] <= tol:
            if details and result is None:
                result = _core_fair(source, target, degree)
            if result is not None:
                result = result.replace(surface=faired)
            return FaceFairReport(
                new_face, "faired", "; ".join(notes), result=result, info=info,
                poles_before=surface.shape, poles_after=faired.shape,
                max_deviation=deviation["max"], tolerance=tol, deviation=deviation,
                surface=faired)
        measured.append(deviation["max"])
    measured += [deviation_on_grid(face, new_face, None, reference=check,
                                   surfaces=(surface, faired))["max"]
                 for new_face, faired in prefiltered]
    best = min(d for d in measured if d is not None) if any(
        d is not None for d in measured) else float("inf")
    where = "by OCCT's measure"
    if len(refusals) == len(criteria):   # no candidate reached OCCT's check
        if isinstance(criteria[0][0], AdaptiveTarget):   # the core's reason, at tol itself
            raise ToleranceNotMetError(max(refusals, key=lambda r: r[0])[1], tolerance=tol,
                                       best_deviation=best)
        where = "by the search's estimate (no candidate reached OCCT's check)"
    raise ToleranceNotMetError(
        f"no target keeps this face within tol={tol:g} {where}, best found {best:.4g}; "
        "raise the tolerance or leave the face as is.", tolerance=tol, best_deviation=best)


def _keeps_every_pole(source, target, faired):
    """True when an adaptive result (``target`` holds spaces, not scales) has at least the
    source's pole count: it only moved knots, so the face is kept, as the uniform search
    keeps a face whose only admissible target is the source's own space."""
    adaptive = any(isinstance(t, SplineSpace) for t in target)
    return adaptive and faired.shape[0] * faired.shape[1] >= source.shape[0] * source.shape[1]


def _is_identity(source, target, degree):
    """True when the target (scales, or the adaptive method's spaces) gives back the
    source's own spaces."""
    for space, n, deg in zip((source.u_space, source.v_space), target, degree):
        if n is None:
            continue
        chosen = n if isinstance(n, SplineSpace) else target_space(space, int(n), deg)
        if not chosen.same_as(space):
            return False
    return True


def _unchanged(face, info, surface, message, tol):
    return FaceFairReport(face, "unchanged", message, info=info, poles_before=surface.shape,
                          poles_after=surface.shape, max_deviation=0.0, tolerance=tol)


def _choose(source, tol, n, degree, sampler, finish, criterion, region=None, window=None):
    """Target scales, the faired (finished) surface and the core result if computed.

    For the adaptive method (``criterion`` an :class:`AdaptiveTarget`) the target is the
    pair of non-uniform spaces the core chose, measured only on the face (``region``,
    :func:`~cq_fairing.occ.trims.face_region` of a trimmed face, and its UV box
    ``window``, whose bounds are sample lines); the core's uniform search
    (a :class:`CoreSearch`) measures in ``window``; energy fairing (``criterion`` ``"energy"``) keeps the
    source's spaces and has no target (``None``).
    """
    if criterion == "energy":
        result = fair_surface(source.poles, tol=tol, u_knots=source.u_knots,
                              v_knots=source.v_knots,
                              degree=(source.u_degree, source.v_degree),
                              weights=source.weights, method="energy")
        return None, finish(result.surface), result
    if isinstance(criterion, AdaptiveTarget):
        result = fair_surface_adaptive(source, tol, target_degree=degree,
                                       objective=criterion.objective,
                                       borders=criterion.borders, region=region,
                                       window=window)
        spaces = (result.surface.u_space, result.surface.v_space)
        return spaces, finish(result.surface), result
    if isinstance(criterion, CoreSearch):
        result = fair_surface(source.poles, tol=tol, u_knots=source.u_knots,
                              v_knots=source.v_knots,
                              degree=(source.u_degree, source.v_degree),
                              weights=source.weights, target_degree=degree,
                              search=criterion.rule, window=window)
        return result.n, finish(result.surface), result
    if n is not None:
        pair = (n, n) if np.ndim(n) == 0 else tuple(n)
        if len(pair) != 2:
            raise InvalidInputError(f"n must be an int or a pair (n_u, n_v), got {n!r}.")
        result = _core_fair(source, pair, degree)
        return pair, finish(result.surface), result
    measure = sampler.normal if criterion == "normal" else sampler.parametric
    target, faired, _, _ = search_scales(source, tol, degree, measure, finish)
    return target, faired, None


def _uv_window(face, surface):
    """The face's UV box inside the surface's domain as ``(u0, u1, v0, v1)``; ``None`` where
    that is the whole domain or empty."""
    (u0, u1), (v0, v1) = face_uv_box(face)
    (a, b), (c, d) = surface.domain
    box = (max(u0, a), min(u1, b), max(v0, c), min(v1, d))
    if box[0] >= box[1] or box[2] >= box[3] or box == (a, b, c, d):
        return None
    return box


def _core_fair(source, target, degree):
    """The core's :class:`SurfaceFairResult` (with details) for the chosen target."""
    return fair_surface(source.poles, n=target, u_knots=source.u_knots,
                        v_knots=source.v_knots, degree=(source.u_degree, source.v_degree),
                        weights=source.weights, target_degree=degree)


def _finisher(surface, periodic, boundary):
    r"""Post-processing of every candidate: keep the source's closed and collapsed borders.

    * a **periodic** direction, or one whose first and last pole rows coincide in the
      source (a closed, non-periodic seam), gets its first and last rows tied to their
      mean (:func:`_tie_rows`), so the seam edge stays shared;
    * a **collapsed** border row (all its poles at one point :math:`c`, the pole of a
      sphere: a degenerated edge) is set back to :math:`c` in the faired net
      (:func:`~cq_fairing.core.geometry.collapse_rows`), so the degenerated edge and its
      vertex stay exact.

    Rows count as coincident or collapsed within ``COINCIDENT`` (1e-9) of the net's extent
    (:func:`~cq_fairing.core.geometry.closed_axes`).
    ``boundary="fixed"`` first restores all the source's border rows.
    """
    closed = closed_axes(surface)
    tied = [axis for axis in (0, 1) if "uv"[axis] in periodic or closed[axis]]
    collapsed = collapsed_rows(surface)

    def finish(faired):
        if boundary == "fixed":
            faired = _fix_border(surface, faired)
        for axis in tied:
            faired = _tie_rows(faired, axis)
        return collapse_rows(faired, collapsed)
    return finish


def _tie_rows(surface, axis):
    """Make the first and last pole rows along ``axis`` equal (their mean)."""
    hom = surface.homogeneous() if surface.is_rational else surface.poles.copy()
    hom = np.moveaxis(hom, axis, 0).copy()
    mean = 0.5 * (hom[0] + hom[-1])
    hom[0] = hom[-1] = mean
    hom = np.moveaxis(hom, 0, axis)
    if surface.is_rational:
        weights = hom[..., -1]
        return replace(surface, poles=hom[..., :-1] / weights[..., None], weights=weights)
    return replace(surface, poles=hom)


def _fix_border(source, faired):
    """``faired`` re-expressed in the source spaces with the source's border rows."""
    poles = _into(faired, source)
    src = source.homogeneous() if source.is_rational else source.poles
    poles[0], poles[-1], poles[:, 0], poles[:, -1] = src[0], src[-1], src[:, 0], src[:, -1]
    if source.is_rational:
        weights = poles[..., -1]
        if np.any(weights <= 0):
            raise NumericalError("fixing the border gave non-positive weights.")
        return BSplineSurface(poles[..., :-1] / weights[..., None], source.u_knots,
                              source.v_knots, source.u_degree, source.v_degree, weights)
    return BSplineSurface(poles, source.u_knots, source.v_knots, source.u_degree,
                          source.v_degree)


def _into(faired, source):
    """L2 projection of ``faired`` into the source spaces (homogeneous if rational)."""
    from ..core.scale_search import _operator

    net = faired.homogeneous() if source.is_rational else faired.poles
    au = _operator(faired.u_space, source.u_space)
    av = _operator(faired.v_space, source.v_space)
    net = np.tensordot(au, net, axes=(1, 0))
    return np.matmul(av, net)


def _non_rational(surface):
    """Least-squares non-rational surface in the same spline spaces as ``surface``."""
    u = np.linspace(*surface.u_space.domain, 3 * surface.shape[0] + 1)
    v = np.linspace(*surface.v_space.domain, 3 * surface.shape[1] + 1)
    points = surface.evaluate_grid(u, v)
    mu = surface.u_space.collocation(u).toarray()
    mv = surface.v_space.collocation(v).toarray()
    pu, pv = np.linalg.pinv(mu), np.linalg.pinv(mv)
    poles = np.einsum("ia,abd,jb->ijd", pu, points, pv)
    return BSplineSurface(poles, surface.u_knots, surface.v_knots, surface.u_degree,
                          surface.v_degree)

