r"""The tolerance search of one face, for every backend: the fewest poles whose faired
net the backend's own two-sided check keeps within ``tol``.

A face is a B-spline surface :math:`S` seen through its trim.  A backend (the OCP layer's
:func:`cq_fairing.occ.fair_face`, the FreeCAD workbench) hands :func:`search_face` its
pieces, and the search is the same whichever it is:

* ``grid`` ``(u, v, inside)``: sample parameters over the face's UV box and the mask of
  those on the face, :func:`sample_counts` per direction by default; the candidates are
  measured there (:class:`~cq_fairing.core.scale_search.SurfaceSampler`);
* ``finish``: applied to every candidate before it is measured (:func:`face_finisher`:
  closed seams tied, collapsed borders kept, optionally the source's border rows);
* ``check(faired) -> float``: the backend's two-sided distance between the face and the
  finished candidate put under the face's trim, the judge of every candidate; and
  optionally ``exceeds(faired, tol) -> bool``, a cheap test that is true only where the
  check's value is certain to exceed ``tol`` (a lower bound above it);
* for the core's searches, ``window``, the face's UV box inside the surface's domain
  (:func:`uv_window`), and for the adaptive method ``region(u, v)``, the mask of grid
  samples on the face.

The attempts (:func:`face_attempts`) run in order and the first whose candidate passes
``check`` wins.  With the wavelet method and ``search="local"`` (the default of every
face) they are: the bisection of :func:`~cq_fairing.core.scale_search.search_scales` on
the face's samples with the distance to the faired tangent planes (a first-order
estimate of the true distance), the core's two-sided uniform search
(:func:`~cq_fairing.core.fairing.fair_surface` with ``search="guaranteed"``), then the
bisection with the parametric distance :math:`|S_f(u, v) - S(u, v)|`, an upper bound of
the true distance.  On a source whose spans are graded each bisection runs twice, on
quasi-uniform targets and on targets graded like the source's spans
(:func:`~cq_fairing.core.plans.graded_space`), and the fewer poles win (the outcome's
notes say when the graded ones did): quasi-uniform targets cannot follow a grading that
the shape has (the IEA blade's spanwise stations, 74 to 1: 17 x 9 poles against 11 x 9
graded), and graded ones waste spans on a grading it does not have (a testtoler strip's
refined end: 19 x 4 against 10 x 4).  Each bisection runs with free borders (the plain
projection) and with borders pinned to the source's border curves; with
``grading="auto"`` the pinned ones also on targets refined towards the borders
(:func:`~cq_fairing.core.plans.end_graded_space`), where a pinned projection's error
gathers (the noisy 50 x 80 blade at 0.05: 11 x 11 poles against 12 x 15 quasi-uniform
ones).  They aim at ``MARGIN * tol`` (room for excursions between samples); the last one
aims at ``tol`` itself.  A core step rule (``"linear"``,
``"guaranteed"``, ``"polyfit"``) replaces the first two by the core's search with that
rule (and its ``measure``).  The adaptive method lets the core choose non-uniform
targets at ``tol``, then at ``MARGIN * tol``; the energy method likewise keeps the net
and moves its poles.

Where a candidate of the local search's attempts keeps more than
``ERROR_GRADED_SHARE`` of the source's poles (and more than ``ERROR_GRADED_POLES``),
uniform and span-graded targets follow the shape poorly, and with ``grading="auto"``
the adaptive method's targets, whose knots the error places, are tried before it
(:func:`_error_graded`, once per search): fewer poles that pass the check win, and the
notes say so.  Their borders are free unless ``borders="pinned"``: pinned ones let the
net slide along the surface, and on the terrain at 1e-3 of its diagonal they keep 2 %
fewer poles (118 x 101 against 120 x 101) at 5.5 times the bending energy; the free
ones have a quarter of the 220 x 285 quasi-uniform net's.

The winner of a bisection or of the core's uniform search is then **polished** (with
``objective`` ``"auto"``, the default, or ``"fair"``; ``"compact"`` keeps the plain
projection): the penalised projection onto the same target spaces, with the same
borders, :math:`(G_T + \lambda K_T)\, C = \langle\Phi_T|\Phi_S\rangle C_S`
(:meth:`~cq_fairing.core.target_projections.TargetProjections.project`, :math:`K_T` the
curvature-variation energy scaled to weigh like :math:`G_T` at :math:`\lambda = 1`),
with the largest :math:`\lambda = 10^x` that the winner's own measure keeps within
``tol`` (a bisection on :math:`x` over ``POLISH_EXPONENTS``,
:func:`~cq_fairing.core.polish.largest_penalty`), or, where that net fails ``check``,
within ``MARGIN * tol``; it replaces the winner if it passes ``check``.  The tolerance
the projection leaves unused goes into fairness at the same poles: on the IEA blade's
main face at 1e-3 of its size the 11 x 9 net's thin-plate bending energy drops from
106.8 to 99.7, below the 17 x 9 plain net's 101.4.

A face is kept ``'unchanged'`` when its net is already at its coarsest (degree + 1 poles
per direction), when the chosen target is the source's own spaces, or when an adaptive
target needs as many poles as the source.  A rational face whose homogeneous projection
gets a non-positive weight is searched again on its non-rational least-squares
approximation in the same spaces (:func:`non_rational`), and the outcome's notes say so.
This module imports numpy and scipy only (and the core).
"""

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..errors import InvalidInputError, NumericalError, ToleranceNotMetError
from .adaptive_surface import fair_surface_adaptive
from .closest_points import closest_points_surface_restarted
from .fairing import fair_surface
from .geometry import BSplineSurface, closed_axes, collapse_rows, collapsed_rows
from .gram import sandwiched
from .options import DEFAULTS
from .plans import direction_target, has_graded_spans
from .polish import largest_penalty
from .projection import project_surface
from .results import SurfaceFairResult
from .scale_search import SurfaceSampler, _operator, max_scales, search_scales, target_degrees
from .spaces import SplineSpace
from .target_projections import TargetProjections

__all__ = ["search_face", "FaceOutcome", "face_attempts", "face_finisher", "sample_counts",
           "uv_window", "non_rational", "AdaptiveTarget", "CoreSearch", "MARGIN",
           "ERROR_GRADED_NOTE", "POLISH_NOTE"]

#: Share of ``tol`` the searches aim at (room for excursions between samples).
MARGIN = 0.9
#: Note of a face whose winning target has its borders pinned to the source's.
PINNED_NOTE = ("target borders pinned to the source's border curves: fewer poles than "
               "free ones")
#: Notes of a bisection's winner whose targets are graded (``"source"``, ``"ends"``).
GRADING_NOTES = {"source": "targets graded like the source's knot spans: fewer poles than "
                           "quasi-uniform ones",
                 "ends": "targets refined towards the pinned borders: fewer poles than "
                         "quasi-uniform ones"}
#: Samples per direction for ``k`` poles: ``clip(2 k + 1, *SAMPLE_RANGE)``.
SAMPLE_RANGE = (20, 400)
#: A bisection winner keeping more than this share of the source's poles, and more than
#: ``ERROR_GRADED_POLES`` poles, has the adaptive method's error-graded targets tried.
ERROR_GRADED_SHARE = 0.25
ERROR_GRADED_POLES = 100
#: Exponents ``x`` of the penalties :math:`\lambda = 10^x` the polish bisects over, and
#: its halvings of that range.
POLISH_EXPONENTS = (-6.0, 1.0)
POLISH_STEPS = 6
#: Shares of ``tol`` the polish aims at in turn, until its net passes the check.
POLISH_AIMS = (1.0, MARGIN)
#: Objectives that polish a bisection's winner.
POLISHING = ("auto", "fair")
#: Note of a polished winner (the penalty follows).
POLISH_NOTE = ("polished: the largest curvature-variation penalty within tol at the same "
               "poles, lambda")
#: Note of a face whose winning target has knots graded by the error.
ERROR_GRADED_NOTE = ("targets graded by the error (the adaptive method's knots): fewer "
                     "poles than quasi-uniform ones")


class AdaptiveTarget(NamedTuple):
    """Attempt that lets the core's adaptive search choose the target."""

    objective: str
    borders: str


class CoreSearch(NamedTuple):
    """Attempt that runs the core's uniform tolerance search with ``rule`` (one of
    :data:`~cq_fairing.core.options.SEARCHES`) bounding the distance ``measure`` (one of
    :data:`~cq_fairing.core.options.MEASURES`)."""

    rule: str
    measure: str = DEFAULTS["measure"]


class FaceOutcome(NamedTuple):
    """What :func:`search_face` made of a face.

    Attributes
    ----------
    status : str
        ``'faired'`` or ``'unchanged'``.
    message : str
        Why the face is unchanged (``""`` when faired).
    surface : BSplineSurface
        The faired, finished surface (the one ``check`` passed); the source when
        unchanged.
    result : SurfaceFairResult or None
        The core result of the winning attempt, its surface the finished one (``None``
        when unchanged, or with ``details=False`` after the local search).
    deviation : float or None
        ``check``'s value of ``surface`` (``0.0`` when unchanged).
    notes : tuple of str
        What the search did beyond the plain case (a non-rational approximation).
    """

    status: str
    message: str
    surface: BSplineSurface
    result: SurfaceFairResult = None
    deviation: float = None
    notes: tuple = ()


def sample_counts(surface):
    """Default samples per direction of a face's grid: ``clip(2 k + 1, 20, 400)`` for
    ``k`` poles in that direction."""
    return tuple(int(np.clip(2 * k + 1, *SAMPLE_RANGE)) for k in surface.shape)


def uv_window(box, surface):
    """The face's UV box ``(u0, u1, v0, v1)`` inside ``surface``'s domain, as the core's
    ``window``; ``None`` where that is the whole domain or empty."""
    u0, u1, v0, v1 = box
    (a, b), (c, d) = surface.domain
    clipped = (max(u0, a), min(u1, b), max(v0, c), min(v1, d))
    if clipped[0] >= clipped[1] or clipped[2] >= clipped[3] or clipped == (a, b, c, d):
        return None
    return clipped


def face_attempts(tol, search="local", method="wavelet", objective=DEFAULTS["objective"],
                  borders="auto", measure=DEFAULTS["measure"]):
    """The ``(criterion, goal)`` attempts of :func:`search_face`, in order.

    With ``tol=None`` (an explicit target scale): one attempt.  ``method="adaptive"``:
    an :class:`AdaptiveTarget` at ``tol``, then at ``MARGIN * tol``;
    ``method="energy"`` likewise with the criterion ``"energy"``.  Otherwise the
    requested search (``"local"``: the bisection with the normal-distance estimate
    ``"normal"``, then the core's ``CoreSearch("guaranteed")`` with its default
    measure; a core step rule: the core's search with it and ``measure`` alone, the one
    search ``measure`` applies to), then the bisection with the parametric
    distance ``"parametric"``, an upper bound of the true distance; they aim at
    ``MARGIN * tol``, the last one at ``tol``.  The normal distance looks from the
    original's samples only; where the faired face reaches beyond the original (the
    checks measure both ways), the core's two-sided search still finds a coarse net,
    where the parametric distance of a face with strongly graded knots keeps nearly all
    poles (an impeller fillet: 20 x 3 poles against 48 x 3).
    """
    if tol is None:
        return [(None, None)]
    if method != "wavelet":
        target = AdaptiveTarget(objective, borders) if method == "adaptive" else "energy"
        return [(target, tol), (target, MARGIN * tol)]
    first = (["normal", CoreSearch("guaranteed")] if search == "local"
             else [CoreSearch(search, measure)])
    return [(criterion, MARGIN * tol) for criterion in first + ["parametric"]] + \
        [("parametric", tol)]


def search_face(surface, tol, grid, finish, check, *, n=None, target_degree=None,
                attempts=None, exceeds=None, region=None, window=None, details=True,
                judge="the backend", grading="auto", borders="auto", objective="auto"):
    """Fair a face's ``surface`` within ``tol`` (or onto ``n``), each candidate judged by
    the backend's ``check`` (module notes).

    Parameters
    ----------
    surface : BSplineSurface
        The face's net (periodic directions unperiodized).
    tol : float or None
        Largest two-sided distance ``check`` may report; ``None`` with ``n``.
    grid : (ndarray, ndarray, ndarray of bool)
        ``(u, v, inside)`` of the face's samples.
    finish : callable
        ``finish(faired) -> BSplineSurface`` for every candidate (:func:`face_finisher`).
    check : callable
        ``check(faired) -> float``: the two-sided distance of the finished candidate.
    n : (int or None, int or None) or int, optional
        Explicit target scales; then the only attempt, accepted whatever ``check`` says.
    target_degree : int or (int, int), optional
        Default ``min(3, source degree)`` per direction.
    attempts : list, optional
        :func:`face_attempts` (default: those of the local search at ``tol``).
    exceeds : callable, optional
        ``exceeds(faired, tol) -> bool``, true only where ``check(faired) > tol`` for
        certain; such a candidate fails without ``check``, which measures it only if
        every attempt fails (for the error's best deviation).
    region : callable, optional
        ``region(u, v)``: mask of grid samples on the face, for the adaptive method
        (``None``: all of them).
    window : (float, float, float, float), optional
        The face's UV box for the core's searches (:func:`uv_window`).
    details : bool
        Compute the wavelet details of a local search's winner with the core.
    judge : str
        Who owns ``check``, for the error message: ``"OCCT"`` says "by OCCT's measure".
    grading : {"auto", "spans", "uniform"}
        The bisections' targets (:func:`_bisected`): with ``"spans"`` also targets graded
        like the source's spans where they are graded; with ``"auto"`` those, with pinned
        borders targets refined towards them, and, in the local search at ``tol``,
        targets graded by the error (the adaptive method's compact fit, with free borders
        unless ``borders="pinned"``) in place of a candidate that keeps many poles
        (:func:`_error_graded`).
    borders : {"auto", "free", "pinned"}
        The border rows of the bisections' targets (:func:`_bisected`) and of explicit
        scales ``n``: the plain projection (``"free"``), pinned to the source's border
        curves (``"pinned"``), or both, the fewer poles winning (``"auto"``; with ``n``
        the plain projection).  The adaptive method takes its own ``borders`` from
        ``attempts``.
    objective : {"auto", "compact", "fair"}
        ``"auto"`` and ``"fair"`` polish the winner of a bisection or of the core's
        uniform search (module notes); ``"compact"`` keeps the plain projection.  The
        adaptive method takes its own ``objective`` from ``attempts``.

    Returns
    -------
    FaceOutcome

    Raises
    ------
    ToleranceNotMetError
        No attempt keeps the face within ``tol``.
    InvalidInputError
        ``n`` is not an int or a pair.
    """
    attempts = attempts or face_attempts(tol)
    degree = target_degrees(surface, target_degree)
    scales = max_scales(surface, degree)
    if scales == (None, None) and n is None:
        return _unchanged(surface, "the net is already at its coarsest (degree + 1 poles "
                          "per direction); nothing to fair")
    if None in scales:  # the core's uniform search coarsens both directions or none
        attempts = [a for a in attempts if not isinstance(a[0], CoreSearch)]
    sampler = SurfaceSampler(grid, surface)
    graded = grading != "uniform" and any(has_graded_spans(s)
                                          for s in (surface.u_space, surface.v_space))
    gradings = ("uniform", "source") if graded else ("uniform",)
    sides = {"auto": ("free",) if n is not None else ("free", "pinned"),
             "free": ("free",), "pinned": ("pinned",)}[borders]
    ends = ("ends",) if grading == "auto" else ()
    families = tuple((g, b) for b in sides
                     for g in gradings + (ends if b == "pinned" else ()))
    local = any(criterion == "normal" for criterion, _ in attempts)
    error_graded = AdaptiveTarget("compact", "pinned" if borders == "pinned" else "free") \
        if grading == "auto" and n is None and local else None
    pieces = _Pieces(tol, n, degree, sampler, finish, check, exceeds, region, window,
                     details, judge, families, {}, error_graded, objective in POLISHING)
    try:
        return _verified(surface, pieces, attempts)
    except NumericalError:
        note = ("fairing in homogeneous coordinates gave non-positive weights; faired a "
                "non-rational least-squares approximation instead")
        outcome = _verified(non_rational(surface), pieces, attempts)
        return outcome._replace(notes=(note,) + outcome.notes)


class _Pieces(NamedTuple):
    """What every attempt of :func:`search_face` shares."""

    tol: float
    n: object
    degree: tuple
    sampler: SurfaceSampler
    finish: object
    check: object
    exceeds: object
    region: object
    window: tuple
    details: bool
    judge: str
    families: tuple
    projections: dict
    error_graded: object = None
    polish: bool = False

    def pinned_projection(self, source):
        """The pinned-border :class:`~cq_fairing.core.target_projections.TargetProjections`
        of ``source``, kept for the attempts that follow (their operators are shared)."""
        kept = self.projections.get(id(source))
        if kept is None or kept[0] is not source:
            kept = self.projections[id(source)] = (source, TargetProjections(source, "pinned"))
        return kept[1]


def _verified(source, pieces, attempts):
    """The first candidate of the attempts that passes ``pieces.check`` (module notes)."""
    tol = pieces.tol
    measured, refusals, prefiltered = [], [], []
    error_graded = pieces.error_graded
    for criterion, goal in attempts:
        try:
            candidates = _candidates(source, goal, criterion, pieces)
        except ToleranceNotMetError as exc:
            measured.append(exc.best_deviation)
            refusals.append((goal, str(exc)))
            continue
        for candidate in candidates:
            target, faired = candidate.target, candidate.faired
            if error_graded is not None and _keeps_many(source, faired):
                outcome = _error_graded(source, pieces, error_graded, faired)
                if outcome is not None:
                    return outcome
                error_graded = None
            if target is not None and _is_identity(source, target, pieces.degree):
                return _unchanged(source, "the finest admissible target is the source "
                                  "space itself; nothing to fair")
            if isinstance(criterion, AdaptiveTarget) and _keeps_every_pole(source, faired):
                return _unchanged(source, "the adaptive target needs as many poles as the "
                                  "source; nothing to reduce")
            if tol is not None and pieces.exceeds is not None and pieces.exceeds(faired, tol):
                prefiltered.append(faired)
                continue
            deviation = pieces.check(faired)
            if tol is None or deviation <= tol:
                return _won(source, candidate, criterion, deviation, pieces)
            measured.append(deviation)
    measured += [pieces.check(faired) for faired in prefiltered]
    known = [d for d in measured if d is not None]
    best = min(known) if known else float("inf")
    where = f"by {pieces.judge}'s measure"
    if len(refusals) == len(attempts):   # no candidate reached the check
        if isinstance(attempts[0][0], AdaptiveTarget):   # the core's reason, at tol itself
            raise ToleranceNotMetError(max(refusals, key=lambda r: r[0])[1], tolerance=tol,
                                       best_deviation=best)
        where = f"by the search's estimate (no candidate reached {pieces.judge}'s check)"
    raise ToleranceNotMetError(
        f"no target keeps this face within tol={tol:g} {where}, best found {best:.4g}; "
        "raise the tolerance or leave the face as is.", tolerance=tol, best_deviation=best)


def _won(source, candidate, criterion, deviation, pieces):
    """The outcome of a ``candidate`` that passed the check with ``deviation``: polished
    (:func:`_polished`) where ``pieces.polish`` asks for it and the polish passes too."""
    faired, result, notes = candidate.faired, candidate.result, candidate.notes
    if pieces.polish and pieces.tol is not None and _polishable(criterion):
        polished = _polished(source, candidate, criterion, pieces)
        if polished is not None:
            faired, deviation, lam = polished
            notes += (f"{POLISH_NOTE} {lam:.3g}",)
    if pieces.details and result is None:
        result = _core_fair(source, candidate.target, pieces.degree)
    if result is not None:
        result = result.replace(surface=faired)
    return FaceOutcome("faired", "", faired, result, deviation, notes)


def _polishable(criterion):
    """Whether the winner of ``criterion``'s attempt is a projection onto target spaces
    (a bisection's or the core's uniform search's)."""
    return criterion in ("normal", "parametric") or isinstance(criterion, CoreSearch)


def _polished(source, candidate, criterion, pieces):
    """``(faired, deviation, lambda)`` of the polished ``candidate`` (module notes): the
    largest penalty that keeps the criterion's measure within ``tol``, or, where that
    net fails the check, within ``MARGIN * tol`` (``POLISH_AIMS``); ``None`` where no
    penalty in range passes.  The bisections' winners are measured by their own
    criterion's distance, the core search's by the tangent-plane one, on the face's
    samples and the centres of their cells (:func:`_centres_sampler`), where a face's
    check also looks, and by the closest-point distance of the face's rim samples
    (:func:`_rim`)."""
    samplers = (pieces.sampler,) + _centres_sampler(pieces.sampler, source)
    kind = "parametric" if criterion == "parametric" else "normal"
    rim = _rim(pieces.sampler)

    def measure(faired):
        estimate = max(getattr(sampler, kind)(faired) for sampler in samplers)
        return max(estimate, closest_points_surface_restarted(faired, *rim)[2].max())

    spaces = _target_spaces(source, candidate.target, pieces.degree)
    pinned = candidate.family is not None and candidate.family[1] == "pinned"
    projections = pieces.pinned_projection(source) if pinned else TargetProjections(source)

    def trial(lam):
        try:
            faired = pieces.finish(projections.projected(*spaces, lam))
        except NumericalError:   # a rational projection with a weight <= 0
            return None, None, np.inf
        return faired, None, measure(faired)

    for aim in POLISH_AIMS:
        (faired, _, _), lam = largest_penalty(trial, aim * pieces.tol, (None, None, np.inf),
                                              *POLISH_EXPONENTS, POLISH_STEPS)
        if faired is None:
            return None
        if pieces.exceeds is not None and pieces.exceeds(faired, pieces.tol):
            continue
        deviation = pieces.check(faired)
        if deviation <= pieces.tol:
            return faired, deviation, lam
    return None


def _rim(sampler):
    """``(points, u, v)`` of the face's samples with a neighbour off the face or on the
    grid's border (the face's rim, where a net that shrinks along its surface leaves
    the source's points behind, unseen by the tangent-plane estimate)."""
    inside = np.asarray(sampler.inside, bool)
    padded = np.pad(inside, 1)
    interior = inside & padded[:-2, 1:-1] & padded[2:, 1:-1] & padded[1:-1, :-2] & \
        padded[1:-1, 2:]
    rim = (inside & ~interior)[inside]
    uu, vv = np.meshgrid(sampler.u, sampler.v, indexing="ij")
    return sampler.reference[rim], uu[inside][rim], vv[inside][rim]


def _centres_sampler(sampler, source):
    """``(SurfaceSampler,)`` on the centres of the cells of ``sampler``'s grid whose four
    corners lie on the face (a face's check samples those too), or ``()`` where none
    does."""
    u, v, inside = sampler.grid
    inside = np.asarray(inside, bool)
    cells = inside[1:, 1:] & inside[:-1, 1:] & inside[1:, :-1] & inside[:-1, :-1]
    if not cells.any():
        return ()
    return (SurfaceSampler((0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1]), cells), source),)


def _keeps_many(source, faired):
    """Whether ``faired`` keeps more than ``ERROR_GRADED_SHARE`` of the source's poles
    and more than ``ERROR_GRADED_POLES``."""
    return _poles(faired) > max(ERROR_GRADED_SHARE * _poles(source), ERROR_GRADED_POLES)


def _error_graded(source, pieces, target, rival):
    """The adaptive method's candidate (``target``, an :class:`AdaptiveTarget`) in
    place of a uniform or source-graded ``rival`` that keeps many poles
    (:func:`_keeps_many`): such targets follow the shape poorly where its detail is
    uneven (a terrain: 220 x 285 of 312 x 323 poles, against 120 x 101 with knots
    where the error is).  The adaptive fit at ``tol``, then at ``MARGIN * tol``; its
    candidate wins if it has fewer poles than ``rival`` and passes the check; ``None``
    otherwise (the attempts go on)."""
    poles = _poles(rival)
    for goal in (pieces.tol, MARGIN * pieces.tol):
        try:
            (candidate,) = _candidates(source, goal, target, pieces)
        except ToleranceNotMetError:
            return None
        faired = candidate.faired
        if _poles(faired) >= poles:
            return None
        if pieces.exceeds is not None and pieces.exceeds(faired, pieces.tol):
            continue
        deviation = pieces.check(faired)
        if deviation <= pieces.tol:
            return FaceOutcome("faired", "", faired, candidate.result.replace(surface=faired),
                               deviation, (ERROR_GRADED_NOTE,))
    return None


def _unchanged(surface, message):
    return FaceOutcome("unchanged", message, surface, None, 0.0)


def _keeps_every_pole(source, faired):
    """True when an adaptive result has at least the source's pole count: it only moved
    knots, so the face is kept, as the uniform search keeps a face whose only admissible
    target is the source's own space."""
    return _poles(faired) >= _poles(source)


def _is_identity(source, target, degree):
    """True when the target (scales, or the adaptive method's spaces) gives back the
    source's own spaces."""
    for space, n, deg in zip((source.u_space, source.v_space), target, degree):
        if n is None:
            continue
        chosen = n if isinstance(n, SplineSpace) else direction_target(space, int(n), deg)
        if not chosen.same_as(space):
            return False
    return True


def _candidates(source, tol, criterion, pieces):
    """The attempt's :class:`_Candidate` list, fewest poles first.

    For the adaptive method (``criterion`` an :class:`AdaptiveTarget`) the target is the
    pair of non-uniform spaces the core chose, measured only on the face
    (``pieces.region`` and ``pieces.window``, whose bounds are sample lines); the core's
    uniform search (a :class:`CoreSearch`) measures in ``pieces.window``; energy fairing
    (``criterion`` ``"energy"``) keeps the source's spaces and has no target (``None``);
    the bisections give one candidate per target family (:func:`_bisected`).
    """
    finish, degree = pieces.finish, pieces.degree
    if criterion == "energy":
        result = fair_surface(source.poles, tol=tol, u_knots=source.u_knots,
                              v_knots=source.v_knots,
                              degree=(source.u_degree, source.v_degree),
                              weights=source.weights, method="energy")
        return [_Candidate(None, finish(result.surface), result)]
    if isinstance(criterion, AdaptiveTarget):
        result = fair_surface_adaptive(source, tol, target_degree=degree,
                                       objective=criterion.objective,
                                       borders=criterion.borders, region=pieces.region,
                                       window=pieces.window)
        spaces = (result.surface.u_space, result.surface.v_space)
        return [_Candidate(spaces, finish(result.surface), result)]
    if isinstance(criterion, CoreSearch):
        result = fair_surface(source.poles, tol=tol, u_knots=source.u_knots,
                              v_knots=source.v_knots,
                              degree=(source.u_degree, source.v_degree),
                              weights=source.weights, target_degree=degree,
                              search=criterion.rule, measure=criterion.measure,
                              window=pieces.window)
        return [_Candidate(result.n, finish(result.surface), result)]
    if pieces.n is not None:
        return [_explicit(source, pieces)]
    return _bisected(source, tol, criterion, pieces)


class _Candidate(NamedTuple):
    """One candidate of an attempt: its target (scales or spaces, ``None`` for energy
    fairing), the finished surface, the core result if computed, its notes, and the
    bisection's target family ``(grading, borders)``."""

    target: object
    faired: BSplineSurface
    result: SurfaceFairResult = None
    notes: tuple = ()
    family: tuple = None


def _explicit(source, pieces):
    """The candidate of explicit scales ``pieces.n``: the projection onto them, with the
    borders pinned when ``pieces.families`` has pinned ones only."""
    n = pieces.n
    pair = (n, n) if np.ndim(n) == 0 else tuple(n)
    if len(pair) != 2:
        raise InvalidInputError(f"n must be an int or a pair (n_u, n_v), got {n!r}.")
    result = _core_fair(source, pair, pieces.degree)
    if all(borders == "pinned" for _, borders in pieces.families):
        spaces = [None if t is None else direction_target(s, t, p) for t, s, p in
                  zip(pair, (source.u_space, source.v_space), pieces.degree)]
        surface = pieces.pinned_projection(source).projected(*spaces)
        return _Candidate(pair, pieces.finish(surface), result, (PINNED_NOTE,))
    return _Candidate(pair, pieces.finish(result.surface), result)


def _bisected(source, tol, criterion, pieces):
    """One :class:`_Candidate` per target family of ``pieces.families`` that meets
    ``tol``, fewest poles first (on a tie in the families' order): the bisection
    (:func:`~cq_fairing.core.scale_search.search_scales`) with the ``criterion``'s
    measure on quasi-uniform targets and, for a source whose spans are graded (a blade's
    spanwise stations, a strip's refined end), on targets graded like them
    (:func:`~cq_fairing.core.plans.graded_space`); each with free borders (the plain L2
    projection) and with borders pinned to the source's border curves
    (:class:`~cq_fairing.core.target_projections.TargetProjections`), the pinned ones
    also on targets refined towards the borders
    (:func:`~cq_fairing.core.plans.end_graded_space`), whose bisection measures only
    candidates with fewer poles than the quasi-uniform pinned family's winner
    (:func:`_to_beat`: the others cannot win).  A candidate two
    families share is measured once.  A pinned family whose rational projection gives
    a non-positive weight is left out (the free ones keep the core's rule: the caller
    searches a non-rational approximation).

    Raises
    ------
    ToleranceNotMetError
        No family's targets meet ``tol`` (the first one's refusal).
    """
    measure = pieces.sampler.normal if criterion == "normal" else pieces.sampler.parametric
    found, refusals, measured = [], [], {"free": {}, "pinned": {}}
    for grading, borders in pieces.families:
        projection = (pieces.pinned_projection(source).projected if borders == "pinned"
                      else None)
        try:
            searched = search_scales(source, tol, pieces.degree, measure, pieces.finish,
                                     projection=projection, grading=grading,
                                     measured=measured[borders],
                                     fewer_than=_to_beat(found, grading, borders))
        except ToleranceNotMetError as exc:
            refusals.append(exc)
            continue
        except NumericalError:
            if borders == "free":
                raise
            continue
        if searched is not None:
            target, faired = searched[:2]
            found.append(_Candidate(target, faired, None,
                                    _family_notes(target, grading, borders),
                                    (grading, borders)))
    if not found:
        raise refusals[0]
    return sorted(found, key=lambda c: _poles(c.faired))


def _to_beat(found, grading, borders):
    """Poles the border-refined family (``grading="ends"``) must beat: its quasi-uniform
    sibling's winner (the same borders), whose spans it only redistributes; ``None``
    for the other families."""
    if grading != "ends":
        return None
    return next((_poles(c.faired) for c in found if c.family == ("uniform", borders)),
                None)


def _poles(surface):
    return surface.shape[0] * surface.shape[1]


def _family_notes(target, grading, borders):
    """The notes of a bisection's winner whose targets are not the plain
    quasi-uniform, free-border ones."""
    graded = any(isinstance(t, SplineSpace) and not t.is_quasi_uniform for t in target)
    notes = (GRADING_NOTES[grading],) if graded else ()
    if borders == "pinned":
        notes += (PINNED_NOTE,)
    return notes


def _core_fair(source, target, degree):
    """The core's :class:`SurfaceFairResult` (with details) for the chosen target: spaces
    (``None`` keeps a direction) or scales."""
    return project_surface(source, *_target_spaces(source, target, degree))


def _target_spaces(source, target, degree):
    """The target's pair of spaces: its spaces, or the quasi-uniform spaces of its scales
    (``None`` keeps the source's space in that direction)."""
    return [t if isinstance(t, SplineSpace) else direction_target(space, t, p)
            for t, space, p in zip(target, (source.u_space, source.v_space), degree)]


def face_finisher(surface, periodic=(), fixed_border=False):
    r"""Post-processing of every candidate: keep the source's closed and collapsed borders.

    * a **periodic** direction (``"u"`` or ``"v"`` in ``periodic``: the source was
      unperiodized), or one whose first and last pole rows coincide in the source (a
      closed seam), gets its first and last rows tied to their mean, so the seam edge
      stays shared;
    * a **collapsed** border row (all its poles at one point :math:`c`, the pole of a
      sphere: a degenerated edge) is set back to :math:`c` in the faired net
      (:func:`~cq_fairing.core.geometry.collapse_rows`), so the degenerated edge and its
      vertex stay exact.

    Rows count as coincident or collapsed within ``COINCIDENT`` (1e-9) of the net's extent
    (:func:`~cq_fairing.core.geometry.closed_axes`).  ``fixed_border`` first restores all
    the source's border rows (:func:`_fix_border`).
    """
    closed = closed_axes(surface)
    tied = [axis for axis in (0, 1) if "uv"[axis] in periodic or closed[axis]]
    collapsed = collapsed_rows(surface)

    def finish(faired):
        if fixed_border:
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
    """``faired`` re-expressed in the source spaces (L2 projection, exact when the spaces
    are nested) with the source's border rows."""
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
    net = faired.homogeneous() if source.is_rational else faired.poles
    au = _operator(faired.u_space, source.u_space)
    av = _operator(faired.v_space, source.v_space)
    net = np.tensordot(au, net, axes=(1, 0))
    return np.matmul(av, net)


def non_rational(surface):
    """Least-squares non-rational surface in the same spline spaces as ``surface``, fitted
    to its points on a ``(3 k_u + 1) x (3 k_v + 1)`` grid."""
    u = np.linspace(*surface.u_space.domain, 3 * surface.shape[0] + 1)
    v = np.linspace(*surface.v_space.domain, 3 * surface.shape[1] + 1)
    points = surface.evaluate_grid(u, v)
    mu = surface.u_space.collocation(u).toarray()
    mv = surface.v_space.collocation(v).toarray()
    pu, pv = np.linalg.pinv(mu), np.linalg.pinv(mv)
    poles = sandwiched(pu, points, pv)
    return BSplineSurface(poles, surface.u_knots, surface.v_knots, surface.u_degree,
                          surface.v_degree)
