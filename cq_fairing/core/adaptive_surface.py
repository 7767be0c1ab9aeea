"""Adaptive fairing of surfaces: :func:`fair_surface_adaptive` and its search over the
pair of target knot families (:mod:`cq_fairing.core.adaptive`).
"""

from functools import cache

import numpy as np

from ..errors import InvalidInputError, ToleranceNotMetError
from .accuracy import check_tolerance, check_window
from .adaptive_counts import (
    _bisect_count,
    _doubling,
    _gallop_down,
    _interpolated_count,
    _scan_below,
)
from .adaptive_knots import (
    ROUNDS,
    SAFETY,
    _multiple_knots_hint,
    _source_density,
    _span_max,
    equidistributed_space,
    error_density,
)
from .fidelity import NOISE_FRACTION, SurfaceResidual, noise_level, noise_limit
from .options import check_borders, checked_objective, checked_target_degree
from .polish import _constrained_stages, largest_penalty, variation_energy_matrix
from .probes import box_region
from .results import SurfaceFairResult, projection_step
from .surface_fit import _final_check, _SurfaceFit

GALLOP_BELOW = 0.5   # a surface reduction strides on while its deviation stays below this x tol


# objective "fair": spans added to the compact net (per direction for surfaces)
FAIR_GROWTHS = ((1, 0), (0, 1), (1, 1), (2, 1), (1, 2), (2, 2))


FAIR_SWITCH = 0.5    # objective "fair" leaves the compact net's borders for half the energy


TOP_GROWTH = 2       # a failing top at another degree than the source's doubles its spans


def _redistributed(fit, breaks, axis, values, n, tol):
    """The ``n``-span space along ``axis`` whose knots equidistribute the error density of
    the search-grid deviations ``values`` (their largest over the other direction) on
    ``breaks``."""
    marginal = values.max(axis=1 - axis)
    samples = (fit.probe.u, fit.probe.v)[axis]
    rho = error_density(breaks, _span_max(breaks, samples, marginal), tol, fit.degrees[axis])
    return equidistributed_space(breaks, rho, n, fit.degrees[axis])


def _reduce_surface(fit, spaces, result, tol, rounds=ROUNDS):
    """Lower ``N_u`` or ``N_v`` (the larger net first) with error-driven knots while tol
    holds.

    A direction steps down by one span, as long as the last pass came within
    ``GALLOP_BELOW`` of tol; further below, by twice its last stride (one try per stride
    larger than one, halved when it fails).  A start far above the answer then walks down
    in a few dozen trials instead of one per span (the IEA face's diagonal start, 17 x 186
    poles, deviates by 1-6 % of tol all the way down to 17 x 56), while near tol the walk
    is the one-span walk.  At stride one each count gets ``rounds`` redistributions, and a
    direction whose next count fails them all is blocked.
    """
    blocked, strides = [False, False], [1, 1]
    while not all(blocked):
        axis = int(np.argmax([s.dimension if not blocked[i] else -1
                              for i, s in enumerate(spaces)]))
        n_spans = spaces[axis].n_spans
        if n_spans <= 1:
            blocked[axis] = True
            continue
        stride = min(strides[axis], n_spans - 1)
        found = _lowered(fit, spaces, result, axis, n_spans - stride, tol,
                         rounds if stride == 1 else 1)
        if found is not None:
            spaces, result = found
            strides[axis] = 2 * stride if result[2] <= GALLOP_BELOW * tol else 1
        elif stride > 1:
            strides[axis] = stride // 2
        else:
            blocked[axis] = True
    return spaces, result


def _lowered(fit, spaces, result, axis, n, tol, rounds):
    """``(spaces, trial)`` with ``n`` spans along ``axis`` within tol, knots redistributed
    by the last trial's errors up to ``rounds`` times; ``None`` if none passes."""
    b, values = spaces[axis].breakpoints, result[1]
    for round_ in range(rounds):
        cand = _redistributed(fit, b, axis, values, n, tol)
        pair = [cand, spaces[1]] if axis == 0 else [spaces[0], cand]
        last = round_ == rounds - 1   # nothing reads the last round's values if it fails
        trial = fit.screened_trial(*pair) if last else fit.trial(*pair)
        if trial[2] <= tol:
            return pair, trial
        b, values = cand.breakpoints, trial[1]
    return None


def fair_surface_adaptive(surface, tol, *, target_degree=None, objective="compact", polish=True,
                          borders="auto", per_span=8, max_samples=400_000, region=None,
                          window=None, _safety=SAFETY):
    r"""Fair ``surface`` into adaptive (non-uniform) u and v targets within ``tol``.

    ``"compact"``: the knot families start from the source's breakpoint densities.
    Three starts are bisected: along the diagonal :math:`N = \lceil t\, n_S\rceil`, u
    first (v at the source) then v, and v first then u.  From each, each direction is
    lowered one span at a time (by doubling strides while far below tol,
    :func:`_reduce_surface`) with knots redistributed by the marginal error density
    (the largest deviation over the other direction), the larger net direction first;
    the smallest net wins.  See the module documentation.  ``"faithful"``: the diagonal
    and then each direction are lowered for the smallest net whose residual is down to
    the noise level (:mod:`cq_fairing.core.fidelity`); if that net exceeds ``tol`` the
    compact search takes over.

    Parameters
    ----------
    surface : BSplineSurface
        Validated source (``cq_fairing.make_surface``).  A rational one is projected in
        homogeneous coordinates (module notes, 6.): the result is rational, not polished,
        and ``"fair"`` gives the ``"compact"`` answer.
    tol : float
        Largest allowed true (two-sided, closest-point) deviation, ``> 0``.
    target_degree : int or (int, int), optional
        Default ``min(3, source degree)`` per direction.
    objective : {"compact", "faithful", "fair"}
        As for :func:`fair_curve_adaptive`; ``"fair"`` grows the compact net by the
        ``FAIR_GROWTHS`` spans per direction and keeps the net of least
        curvature-variation energy (:func:`_fairest_grown`); with ``borders="auto"``
        and a pinned compact net, the free-border net grown the same way replaces it
        when its energy is below ``FAIR_SWITCH`` (half) of the pinned one's
        (:func:`_fairest_of`).
    polish : bool
        Spend the remaining tolerance on the curvature-variation energy
        (:func:`variation_energy_matrix`, penalised projection, then span-weighted
        stages towards the fairest net within tol, :func:`_constrained_stages`;
        ``"compact"`` only).
    borders : {"auto", "free", "pinned"}
        ``"free"``: the plain (penalised) L2 projection, whose largest deviation often
        sits at a corner.  ``"pinned"``: each border row is the projection of the
        source's border curve with its two end points kept, and the interior is
        projected with the border rows held (exact Gram matrices throughout): the four
        corners stay exactly where they are, and each edge follows its own border
        curve.  ``"auto"``: free borders, then (compact search) the reduction goes on
        with pinned ones, which are kept only if the net gets smaller; the table's
        ``"borders"`` entry says which.
    per_span : int
        Deviation samples per source span (lowered until the grid has at most
        ``max_samples`` points).  The result is checked on a grid twice as dense per
        span of the merged breakpoints, never coarser than the 8 per span of
        :func:`~cq_fairing.core.measures.deviation`; if that finds more than ``tol``,
        the compact net is grown by one span along u or v (knots from its error
        density, the smaller net first) and checked again, and only if neither passes
        is the search repeated with a tighter working tolerance (down to 0.9 ``tol``).
    region : callable, optional
        ``region(u, v) -> bool array (len(u), len(v))``: where the deviation counts,
        e.g. a trimmed face's domain (:class:`~cq_fairing.core.measures.SurfaceProbe`).
        Search, knot placement and the final check then see only those samples: the
        net follows the surface where the face is, not under the trimmed-away part.
        Default: the whole parameter domain.
    window : (u0, u1, v0, v1), optional
        A parameter box (a trimmed face's UV box): the deviation counts inside it only
        (and inside ``region``), and its four bounds are sample lines of every grid, so
        the border of a face trimmed to a box inside the surface's domain is measured
        where the largest errors of a projection sit (a linkrods face on v in [0.122,
        0.878] trimmed at 0.125 and 0.875: 0.0067 measured on the samples inside,
        0.0139 on the trim's border, tol 0.01).

    Returns
    -------
    SurfaceFairResult
        ``max_deviation``, ``evaluations`` and ``table`` ``(("lambda", value),
        ("span weight", largest patch weight, 1 without reweighting), ("borders", "free"
        or "pinned"), ...)`` filled (``("noise", sigma)`` too for
        ``"faithful"``); one direct decomposition step, so ``details``/``reconstruct``
        work (exactly for free borders and ``lambda = 0``, see the module notes).

    Raises
    ------
    InvalidToleranceError, InvalidInputError, ToleranceNotMetError
    """
    tol = check_tolerance(tol)
    faithful = checked_objective(objective) == "faithful"
    check_borders(borders)
    if region is not None and not callable(region):
        raise InvalidInputError(
            f"region must be a callable region(u, v) -> boolean array or None, got "
            f"{type(region).__name__}; pass a function of the two sample vectors.")
    counted, edges = _restriction(region, check_window(window, surface))
    tdu, tdv = target_degree if isinstance(target_degree, (tuple, list)) else (target_degree,) * 2
    degrees = (checked_target_degree(tdu, surface.u_degree), checked_target_degree(tdv, surface.v_degree))
    fit = _SurfaceFit(surface, _safety * tol, degrees, per_span, max_samples,
                      "pinned" if borders == "pinned" else "free", counted, edges)
    dens = [_source_density(s) for s in (surface.u_space, surface.v_space)]
    tops = [surface.u_space.n_spans, surface.v_space.n_spans]

    def family(t):
        return [equidistributed_space(b, r, max(1, int(np.ceil(t * top - 1e-9))), p)
                for (b, r), top, p in zip(dens, tops, degrees)]

    check = _final_check(surface, 2 * per_span, 4 * max_samples, counted, edges)
    table, found = (), None
    if faithful:
        spaces, sigma = _faithful_net(fit, family, dens, tops)
        table = (("noise", sigma),)
        faired = fit.geometry(spaces, fit.project(*spaces))
        e = np.inf if fit.inadmissible(faired) else check(faired)
        found = (spaces, faired, e, 0.0, 1.0) if e <= tol else None
    if found is None:
        candidates = _compact_candidates(fit, family, dens, tops, tol, borders == "auto")
        found = _checked_compact(fit, candidates, polish, tol, check)
        if objective == "fair" and found[2] <= tol and not fit.rational:
            found = _fairest_of(fit, candidates, found, polish, tol, check)
    spaces, faired, e, lam, span_weight = found
    if e > tol and _safety > 0.9:
        try:
            return fair_surface_adaptive(surface, tol, target_degree=target_degree,
                                         objective=objective, polish=polish,
                                         borders=borders, per_span=per_span,
                                         max_samples=max_samples, region=region,
                                         window=window, _safety=_safety * tol / e - 0.005)
        except ToleranceNotMetError:
            pass  # nothing within the tighter working tolerance: this net's refusal says why
    if e > tol:
        raise ToleranceNotMetError(
            f"the adaptive target {spaces[0].dimension}x{spaces[1].dimension} passed the "
            f"search samples but deviates by {e:.4g} > tol={tol:g} on the denser check; "
            "raise the tolerance or use method='wavelet'.", tolerance=tol, best_deviation=e)
    step = (projection_step(surface.u_space, spaces[0]),
            projection_step(surface.v_space, spaces[1]))
    n = (spaces[0].n_spans, spaces[1].n_spans)
    return SurfaceFairResult(surface, faired, (tuple(tops), n), n, "adaptive", (step,),
                             max_deviation=e, evaluations=fit.evaluations,
                             table=(("lambda", lam), ("span weight", span_weight),
                                    ("borders", "pinned" if fit.pinned else "free")) + table)


def _compact_candidates(fit, family, dens, tops, tol, try_pinned):
    """The compact net ``[(pinned, spaces, trial)]``; with ``try_pinned`` a smaller net
    with pinned borders (:func:`_pinned_below`), if there is one, comes first and the
    free-border net second."""
    spaces, result = _compact_net(fit, family, dens, tops, tol)
    candidates = [(fit.pinned, spaces, result)]
    lower = _pinned_below(fit, spaces) if try_pinned else None
    if lower is not None:
        candidates.insert(0, (True,) + lower)
    return candidates


def _checked_compact(fit, candidates, polish, tol, check):
    """The first of the compact ``candidates`` (:func:`_compact_candidates`) that the
    denser ``check`` finds within ``tol`` once polished, the polish backed off until it
    does: ``(spaces, faired, deviation there, lambda, largest span weight)``; else the
    last grown by a span (:func:`_grown_and_checked`).  ``fit.pinned`` ends as the
    answer's."""
    for pinned, spaces, result in candidates:
        fit.pinned = pinned
        found = _polished_and_checked(fit, spaces, result, polish, tol, check)
        if found[2] <= tol:
            return found
    return _grown_and_checked(fit, spaces, result, polish, tol, check) or found


def _fairest_of(fit, candidates, compact, polish, tol, check):
    """Objective ``"fair"`` over both border choices: :func:`_fairest_grown` from the
    ``compact`` answer, replaced by the same from the other compact candidate
    (:func:`_compact_candidates`, polished and checked) when that has less than
    ``FAIR_SWITCH`` times its :func:`_surface_energy`; ``fit.pinned`` ends as the
    answer's.  Pinned borders are chosen for fewer poles and keep the corners; they are
    given up only for a much fairer surface.  On the terrain the pinned degree-3 net
    (5159 poles, polish ``lambda`` 0.098) had 90 times the energy of the free one; on the
    50 x 80 blade at 0.05 the free net had 0.79 times the pinned one's, with more poles
    (88 against 77) and a higher bending energy.
    """
    chosen = fit.pinned
    best = _fairest_grown(fit, compact, polish, tol, check)
    limit = FAIR_SWITCH * _surface_energy(fit, best[0], best[1])
    for pinned, spaces, result in candidates:
        if pinned == chosen:
            continue
        fit.pinned = pinned
        start = _polished_and_checked(fit, spaces, result, polish, tol, check)
        grown = _fairest_grown(fit, start, polish, tol, check) if start[2] <= tol else None
        if grown is not None and _surface_energy(fit, grown[0], grown[1]) < limit:
            return grown
    fit.pinned = chosen
    return best


def _fairest_grown(fit, compact, polish, tol, check):
    r"""Objective ``"fair"``: the ``compact`` answer ``(spaces, faired, deviation, lambda,
    largest span weight)`` or the compact net with ``FAIR_GROWTHS`` more spans along u
    and v (knots from its error density, as :func:`_grown_and_checked`), each polished
    and checked (:func:`_polished_and_checked`), whichever has the least
    :func:`_surface_energy`.  The compact net leaves the polish little tolerance to
    spend (none on the 400 x 400 blade); a few spans more give it some, and the energy
    picks how many (at most 2 more per direction)."""
    spaces = compact[0]
    values = fit.trial(*spaces)[1]  # the compact net's search-grid deviations
    best, best_energy = compact, _surface_energy(fit, spaces, compact[1])
    for growth in FAIR_GROWTHS:
        pair = _grown(fit, spaces, values, growth)
        trial = fit.screened_trial(*pair)
        if trial[2] > fit.tol:
            continue
        found = _polished_and_checked(fit, pair, trial, polish, tol, check)
        if found[2] > tol:
            continue
        energy = _surface_energy(fit, pair, found[1])
        if energy < best_energy:
            best, best_energy = found, energy
    return best


def _surface_energy(fit, spaces, surface):
    r""":math:`c^T K c` with :math:`K` = :func:`variation_energy_matrix` in the source
    net's physical scale, unscaled: comparable between target spaces on one domain."""
    c = surface.poles.reshape(-1, surface.poles.shape[-1])
    k = variation_energy_matrix(*spaces, fit.lengths)
    return float(np.einsum("id,id->", c, k @ c))


def _grown(fit, spaces, values, growth):
    """``spaces`` with ``growth[axis]`` more spans along each axis, knots redistributed by
    the error density of the search-grid deviations ``values`` (:func:`_redistributed`);
    an axis that does not grow keeps its space."""
    return [_redistributed(fit, space.breakpoints, axis, values, space.n_spans + extra,
                           fit.tol) if extra else space
            for axis, (space, extra) in enumerate(zip(spaces, growth))]


def _grown_and_checked(fit, spaces, result, polish, tol, check):
    """A net the denser ``check`` refused, grown by one span along u or along v (knots
    from its error density, the smaller of the two nets first), polished and checked:
    the first that passes (as :func:`_polished_and_checked`), else ``None``.  One span
    more where the error is usually covers the excess between the search's samples, at
    the cost of two trials instead of a new search."""
    grown = [_grown(fit, spaces, result[1], growth) for growth in ((1, 0), (0, 1))]
    for pair in sorted(grown, key=_net_size):
        trial = fit.screened_trial(*pair)
        if trial[2] <= tol:
            found = _polished_and_checked(fit, pair, trial, polish, tol, check)
            if found[2] <= tol:
                return found
    return None


def _polished_and_checked(fit, spaces, result, polish, tol, check):
    """Polish a net within the search's tolerance (one ``lambda``, then the constrained
    stages of :func:`_constrained_stages`, the last first), and return the first that
    ``check`` finds within ``tol``; without one, back the single-``lambda`` polish off
    (``lambda`` down by tens, then zero).  ``(spaces, faired, deviation, lambda, largest
    span weight)``."""
    faired, lam = result[0], 0.0
    if polish and min(fit.degrees) >= 2 and not fit.rational:
        (faired, _, _), lam = largest_penalty(lambda x: fit.screened_trial(*spaces, x),
                                              fit.tol, result, steps=8)
        for staged, stage_lam, weights in reversed(_constrained_stages(fit, spaces, faired, lam)):
            e = check(staged, fit.probe)
            if e <= tol:
                return spaces, staged, e, stage_lam, float(weights.max())
    e = check(faired, fit.probe)
    while e > tol and lam > 0.0:
        lam = lam / 10.0 if lam > 1e-8 else 0.0
        faired = fit.geometry(spaces, fit.project(*spaces, lam))
        e = check(faired, fit.probe)
    return spaces, faired, e, lam, 1.0


def _degree_hint(fit):
    """``" or keep the source's degrees (target_degree=(p_u, p_v))"`` where the target
    degree is below the source's, as the curve search says."""
    source = (fit.surface.u_degree, fit.surface.v_degree)
    if tuple(fit.degrees) == source:
        return ""
    return f" or keep the source's degrees (target_degree={source})"


def _compact_net(fit, family, dens, tops, tol):
    """Smallest net within tol from three starts: ``(spaces, trial)``.  Two starts on the
    same net are reduced once (the IEA face's axis starts both stop at 17 x 31 poles)."""
    full, top_result = _top(fit, family, tops)
    steps = max(tops)
    if top_result[2] > fit.tol:
        spans = " x ".join(str(s.n_spans) for s in full)
        raise ToleranceNotMetError(
            f"no adaptive target within tol={tol:g}: the finest, simple knots on {spans} "
            f"spans following the source's breakpoints at degrees {fit.degrees}, deviates "
            f"by {top_result[2]:.4g}; raise the tolerance{_degree_hint(fit)}"
            f"{_multiple_knots_hint(fit.surface.u_space, fit.surface.v_space)}.",
            tolerance=tol, best_deviation=top_result[2])
    starts = [_diagonal_start(fit, family, steps, top_result),
              _axis_start(fit, full, top_result, dens, tops, fit.degrees, (0, 1)),
              _axis_start(fit, full, top_result, dens, tops, fit.degrees, (1, 0))]
    best, reduced = None, {}
    for spaces, result in starts:
        key = (spaces[0].key, spaces[1].key)
        if key not in reduced:  # the second walk from one net would repeat the first
            reduced[key] = _reduce_surface(fit, spaces, result, fit.tol)
        spaces, result = reduced[key]
        if best is None or _net_size(spaces) < _net_size(best[0]):
            best = (spaces, result)
    return best


def _top(fit, family, tops):
    """The top of the knot family, ``family(1.0)``, and its trial.

    At the source's degree the top is the source's own breakpoints.  Another target
    degree may need more spans than the source has: a lower one holds less on a span
    (impeller faces of degree 5 on 8 x 7 spans: 0.0101 at degree 3 on those breakpoints,
    tol 0.01), a higher one is smoother across the source's joins.  Where the top fails,
    each direction whose target degree is not the source's gets twice its spans, up to
    ``TOP_GROWTH`` doublings.  ``tops`` is changed in place, and ``family`` reads it."""
    source = (fit.surface.u_degree, fit.surface.v_degree)
    other = [axis for axis in (0, 1) if fit.degrees[axis] != source[axis]]
    full = family(1.0)
    result = fit.trial(*full)
    for _ in range(TOP_GROWTH if other else 0):
        if result[2] <= fit.tol:
            break
        for axis in other:
            tops[axis] *= 2
        full = family(1.0)
        result = fit.trial(*full)
    return full, result


def _pinned_below(fit, spaces):
    """Go on lowering the free-border answer ``spaces`` one span at a time with pinned
    borders: ``(spaces, trial)`` if that reaches a smaller net, else ``None``."""
    fit.pinned = True
    try:
        trial = fit.screened_trial(*spaces)
        if trial[2] > fit.tol:
            return None
        lower, reduced = _reduce_surface(fit, list(spaces), trial, fit.tol)
        return (lower, reduced) if _net_size(lower) < _net_size(spaces) else None
    finally:
        fit.pinned = False


def _faithful_net(fit, family, dens, tops):
    """Smallest net whose residual is within the noise level: the diagonal (bracketed by
    doubling from a small net up to the one the noise was measured on, as for curves: the
    large projections a bisection from the top starts with cost more than all the small
    ones; then :func:`_interpolated_count`), then each direction (the larger first)
    lowered with the other held (:func:`_gallop_down`: a balanced net seldom lowers far);
    and the noise level."""
    residual = SurfaceResidual(fit.surface)

    def variance(spaces):
        faired = fit.geometry(spaces, fit.project(*spaces))
        return np.inf if fit.inadmissible(faired) else residual.variance(faired)

    @cache
    def at_fraction(fraction):
        return variance(family(fraction))

    sigma = noise_level(at_fraction, fit.surface.size)
    steps, limit = max(tops), noise_limit(sigma)

    def diagonal(k):
        return at_fraction(k / steps)

    fails, k = _doubling(lambda k: diagonal(k) <= limit, -(-steps // NOISE_FRACTION))
    k = steps if k is None else _interpolated_count(fails, k, diagonal, limit)
    spaces = family(k / steps)
    for axis in np.argsort([-s.dimension for s in spaces]):
        b, rho = dens[axis]

        def with_count(n, axis=axis, b=b, rho=rho, spaces=spaces):
            pair = list(spaces)
            pair[axis] = equidistributed_space(b, rho, n, fit.degrees[axis])
            return pair

        n = _gallop_down(spaces[axis].n_spans, lambda n: variance(with_count(n)) <= limit)
        spaces = with_count(n)
    return spaces, sigma


def _net_size(spaces):
    return spaces[0].dimension * spaces[1].dimension


def _diagonal_start(fit, family, steps, top_result):
    """Smallest ``t = k / steps`` with both directions at ``ceil(t n_S)`` spans passing."""
    cache = {steps: top_result}

    def check(k):
        cache[k] = fit.screened_trial(*family(k / steps))
        return cache[k][2] <= fit.tol

    k = _bisect_count(0, steps, check)
    return family(k / steps), cache[k]


def _axis_start(fit, full, top_result, dens, tops, degrees, order):
    """Bisect the span count of one direction (the other at the source), then the other."""
    spaces, result = list(full), top_result
    for axis in order:
        b, rho = dens[axis]
        cache = {tops[axis]: (list(spaces), result)}

        def check(n, axis=axis, b=b, rho=rho, cache=cache, spaces=spaces):
            pair = list(spaces)
            pair[axis] = equidistributed_space(b, rho, n, degrees[axis])
            trial = fit.screened_trial(*pair)
            cache[n] = (pair, trial)
            return trial[2] <= fit.tol

        n = _scan_below(_bisect_count(0, tops[axis], check), check)
        spaces, result = cache[n]
    return spaces, result


def _restriction(region, box):
    """``(region, edges)`` of a ``region`` and a checked ``window`` box: the samples that
    count (in the region and in the box) and the box's bounds as sample lines."""
    if box is None:
        return region, None
    u0, u1, v0, v1 = box
    inside = box_region(box)
    counted = inside if region is None else (lambda u, v: region(u, v) & inside(u, v))
    return counted, ((u0, u1), (v0, v1))
