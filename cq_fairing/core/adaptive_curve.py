"""Adaptive fairing of curves: :func:`fair_curve_adaptive` and its target search
(:mod:`cq_fairing.core.adaptive`); :func:`noise_limited_curve`, its ``"faithful"`` fit
where the noise, not the tolerance, sets the size.
"""

from functools import cache

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import ToleranceNotMetError
from .accuracy import check_tolerance
from .adaptive_counts import _bisect_count, _doubling, _scan_below
from .adaptive_knots import (
    ROUNDS,
    SAFETY,
    _multiple_knots_hint,
    _refined,
    _source_density,
    _span_max,
    equidistributed_space,
    error_density,
)
from .decomposition import decomposition
from .fidelity import NOISE_FRACTION, CurveResidual, noise_level, noise_limit
from .geometry import BSplineCurve
from .gram import gram_matrix
from .options import checked_objective, checked_target_degree
from .polish import _polish, _scaled_energy
from .probes import CurveProbe
from .results import FairResult

FAIR_CURVE_GROWTHS = (1, 2)


# -- curves -------------------------------------------------------------------------------------
class _CurveFit:
    """Exact projections of one source curve onto candidate spaces, with their deviation."""

    def __init__(self, curve, tol, degree, per_span):
        self.curve, self.tol, self.degree = curve, tol, degree
        self.coefficients = curve.homogeneous() if curve.is_rational else curve.poles
        self.probe = CurveProbe(curve, per_span=per_span)
        self.evaluations = 0

    def project(self, space, lam=0.0):
        """Coefficients of the (penalised) projection onto ``space``."""
        g = gram_matrix(space)
        if lam > 0.0:
            g = g + lam * _scaled_energy(space, 3)
        rhs = gram_matrix(space, self.curve.space) @ self.coefficients
        return np.asarray(spla.splu(sp.csc_matrix(g)).solve(rhs))

    def geometry(self, space, coefficients):
        if self.curve.is_rational:
            w = coefficients[:, -1]
            return BSplineCurve(coefficients[:, :-1] / w[:, None], space.knots, space.degree, w)
        return BSplineCurve(coefficients, space.knots, space.degree)

    def errors(self, faired):
        """Per-sample deviation: true distance where the bound exceeds part of tol."""
        self.evaluations += 1
        other, bound = self.probe.bound(faired)
        return _refined(bound, lambda idx: self.probe.true_distance(faired, other, idx,
                                                                     tol=self.tol), self.tol)

    def trial(self, space, lam=0.0):
        """``(faired, per-sample deviation, max)``.  A rational candidate with a
        non-positive weight fails (``max = inf``): it may pass through infinity between
        samples.  Its samples then say nothing about where the error is, so they all get
        the same value (twice the tolerance), which keeps the knot density as it is."""
        coefficients = self.project(space, lam)
        faired = self.geometry(space, coefficients)
        if self.curve.is_rational and not np.all(coefficients[:, -1] > 0):
            return faired, np.full(self.probe.u.size, 2.0 * self.tol), np.inf
        values = self.errors(faired)
        return faired, values, float(values.max())


def _reduce(space0, values0, u, tol, degree, trial, rounds=ROUNDS):
    """Lower the span count one at a time with error-driven knots while ``tol`` holds.

    Returns the last passing ``(space, faired, values, max)``.
    """
    best = (space0,) + values0
    while best[0].n_spans > 1:
        space, values = best[0], best[2]
        b = space.breakpoints
        rho = error_density(b, _span_max(b, u, values), tol, degree)
        n = space.n_spans - 1
        found = None
        for _ in range(rounds):
            cand = equidistributed_space(b, rho, n, degree)
            f, vals, e = trial(cand)
            if e <= tol:
                found = (cand, f, vals, e)
                break
            cb = cand.breakpoints
            b, rho = cb, error_density(cb, _span_max(cb, u, vals), tol, degree)
        if found is None:
            break
        best = found
    return best


def fair_curve_adaptive(curve, tol, *, target_degree=None, objective="compact", polish=True,
                        per_span=8):
    r"""Fair ``curve`` into an adaptive (non-uniform) target within ``tol``.

    See the module documentation for the algorithm (knot family, count bisection,
    error-driven redistribution, energy polish) and :mod:`cq_fairing.core.fidelity`
    for the ``"faithful"`` objective.

    Parameters
    ----------
    curve : BSplineCurve
        Validated source curve (``cq_fairing.make_curve``).
    tol : float
        Largest allowed true (closest-point, two-sided) deviation, model units, ``> 0``.
    target_degree : int, optional
        Default ``min(3, curve.degree)``.
    objective : {"compact", "faithful", "fair"}
        ``"compact"``: the fewest poles within ``tol``, the rest of the budget spent on
        fairness (polish).  ``"faithful"``: the fewest poles whose residual is down to
        the source's noise level (discrepancy principle), or more if ``tol`` needs
        them; no polish (it would add bias).  Removes the noise and keeps the shape.
        ``"fair"``: the compact answer and the compact space with ``FAIR_CURVE_GROWTHS``
        more spans (knots from its error density), each polished and checked; the one of
        least :math:`\int \|C^{(3)}\|^2` wins (polynomial curves of degree >= 3 with
        ``polish``; otherwise as ``"compact"``).  At the fewest poles the polish has
        little tolerance left to spend; one or two spans more give it some.
    polish : bool
        Spend the remaining tolerance on the ``G^{(3)}`` energy (polynomial curves,
        ``"compact"`` only).
    per_span : int
        Deviation samples per source span.

    Returns
    -------
    FairResult
        ``curve`` on the adaptive knots; ``max_deviation`` measured; ``evaluations`` the
        number of projections measured; ``table`` ``(("lambda", value), ("noise", sigma))``
        (``sigma`` the estimated noise level, ``"faithful"`` only);
        ``details``/``reconstruct`` as for the uniform fairing (direct step).

    Raises
    ------
    InvalidToleranceError
        ``tol`` not positive and finite.
    InvalidInputError
        Unknown ``objective`` or bad ``target_degree``.
    ToleranceNotMetError
        Even the source's own space at the target degree exceeds ``tol``.
    """
    tol = check_tolerance(tol)
    return _adaptive_curve(curve, tol, checked_target_degree(target_degree, curve.degree),
                           checked_objective(objective), polish, per_span)


def noise_limited_curve(curve, tol, *, target_degree=None, most_poles=None, per_span=8):
    """The ``"faithful"`` fit of :func:`fair_curve_adaptive` where the noise sets its
    size, else ``None``.

    The smallest target of the knot family whose residual is down to the source's
    estimated noise (:mod:`cq_fairing.core.fidelity`) is the answer when it meets ``tol``
    (checked as by :func:`fair_curve_adaptive`).  When it does not, ``tol`` needs more
    poles than the noise does: the tolerance, not the noise, limits the fit, and the
    ``"faithful"`` objective would go on with the compact search; this function stops
    there and returns ``None`` (one projection measured, no search).

    Parameters
    ----------
    curve, tol, target_degree, per_span
        As for :func:`fair_curve_adaptive`.
    most_poles : int, optional
        ``None`` also, before anything is measured, when the noise needs a target with
        more poles.

    Returns
    -------
    FairResult or None
        As :func:`fair_curve_adaptive` with ``objective="faithful"`` returns it.
    """
    tol = check_tolerance(tol)
    return _adaptive_curve(curve, tol, checked_target_degree(target_degree, curve.degree),
                           "faithful", True, per_span, past_noise=False,
                           most_poles=np.inf if most_poles is None else most_poles)


def _adaptive_curve(curve, tol, degree, objective, polish, per_span, past_noise=True,
                    most_poles=np.inf):
    """:func:`fair_curve_adaptive` on validated arguments; ``past_noise=False``: ``None``
    where a ``"faithful"`` fit would need the compact search or more than ``most_poles``
    poles (:func:`noise_limited_curve`)."""
    faithful = objective == "faithful"
    fair = objective == "fair" and polish and not curve.is_rational and degree >= 3
    fit = _CurveFit(curve, SAFETY * tol, degree, per_span)
    b0, rho0 = _source_density(curve.space)
    top = curve.space.n_spans

    def family(n):
        return equidistributed_space(b0, rho0, n, degree)

    cache = {}

    def check(n):
        cache[n] = fit.trial(family(n))
        return cache[n][2] <= fit.tol

    table = ()
    start = 4
    if faithful:
        start, sigma = _faithful_count(fit, family, top)
        table = (("noise", sigma),)
    if faithful and family(start).dimension <= most_poles and check(start):
        space, (faired, values, e), lam = family(start), cache[start], 0.0
    elif not past_noise:
        return None
    else:
        space, faired, values, e = _compact_curve(fit, family, check, cache, top, start, tol)
        lam = 0.0
        if polish and not curve.is_rational and degree >= 3:
            (faired, values, e), lam = _polish(lambda x: fit.trial(space, x), fit.tol,
                                               (faired, values, e))
    space, faired, e, lam = _checked_curve(curve, fit, space, faired, values, lam, per_span,
                                           tol)
    if fair:
        space, faired, e, lam = _fairest_curve(curve, fit, (space, faired, e, lam), values,
                                               per_span, tol)
    step = decomposition(curve.space, space)
    return FairResult(curve, faired, (top, space.n_spans), space.n_spans, "adaptive",
                      (step,), max_deviation=e, evaluations=fit.evaluations,
                      table=(("lambda", lam),) + table)


def _faithful_count(fit, family, top):
    """Smallest count whose residual variance is within the noise level, and that level.

    Doubling from a small count stops at the count the noise was measured on (its
    variance is the noise level, so it passes); bisection closes the bracket (a curve's
    residual falls off a cliff onto the noise, where :func:`_interpolated_count`'s
    log-log chord guesses badly: 9 projections against 5 on the seed curve at degree 7)."""
    residual = CurveResidual(fit.curve)

    @cache
    def variance(n):
        space = family(n)
        return residual.variance(fit.geometry(space, fit.project(space)))

    def count(fraction):
        return max(1, int(round(fraction * top)))

    sigma = noise_level(lambda fraction: variance(count(fraction)), fit.curve.size)
    limit = noise_limit(sigma)

    def quiet(n):
        return variance(n) <= limit

    fails, n = _doubling(quiet, count(1.0 / NOISE_FRACTION))
    return (top if n is None else _bisect_count(fails, n, quiet)), sigma


def _compact_curve(fit, family, check, cache, top, start, tol):
    """Fewest spans within tol: doubling from ``start``, bisection, error-driven reduction."""
    fails, n = _doubling(check, top, start)
    if n is None:
        what = ("give a non-positive weight" if np.isinf(cache[top][2])
                else f"deviate by {cache[top][2]:.4g}")
        raise ToleranceNotMetError(
            f"no adaptive target within tol={tol:g}: simple knots on the source's "
            f"breakpoints at degree {fit.degree} {what}; raise the tolerance or keep the "
            f"degree{_multiple_knots_hint(fit.curve.space)}.",
            tolerance=tol, best_deviation=cache[top][2])
    n = _scan_below(_bisect_count(fails, n, check), check)
    return _reduce(family(n), cache[n], fit.probe.u, fit.tol, fit.degree, fit.trial)


def _fairest_curve(curve, fit, compact, values, per_span, tol):
    """Objective ``"fair"``: the ``compact`` answer ``(space, faired, deviation, lambda)``
    or the compact space with ``FAIR_CURVE_GROWTHS`` more spans (knots equidistributing
    the error density of the search-grid deviations ``values``), polished and checked,
    whichever has the least :func:`_curve_energy`."""
    space = compact[0]
    breaks = space.breakpoints
    rho = error_density(breaks, _span_max(breaks, fit.probe.u, values), fit.tol, fit.degree)
    best, best_energy = compact, _curve_energy(space, compact[1])
    for extra in FAIR_CURVE_GROWTHS:
        grown = equidistributed_space(breaks, rho, space.n_spans + extra, fit.degree)
        trial = fit.trial(grown)
        if trial[2] > fit.tol:
            continue
        (faired, _, _), lam = _polish(lambda x, grown=grown: fit.trial(grown, x), fit.tol, trial)
        try:
            faired, e, lam = _final_curve_check(curve, fit, grown, faired, lam, per_span, tol)
        except ToleranceNotMetError:
            continue
        energy = _curve_energy(grown, faired)
        if energy < best_energy:
            best, best_energy = (grown, faired, e, lam), energy
    return best


def _curve_energy(space, curve):
    r""":math:`\int \|C^{(3)}(t)\|^2 dt = \mathrm{tr}(c^T G^{(3)} c)` of a polynomial
    curve: unscaled, so comparable between spaces on one domain."""
    return float(np.einsum("id,id->", curve.poles, gram_matrix(space, nu=3) @ curve.poles))


def _checked_curve(curve, fit, space, faired, values, lam, per_span, tol):
    """The final check of :func:`_final_curve_check`; a space it refuses grows by one
    span at a time (knots equidistributing the search grid's error density ``values``)
    up to the source's span count, as the surface search grows a refused net.  Returns
    ``(space, faired, deviation, lambda)``."""
    while True:
        try:
            return (space,) + _final_curve_check(curve, fit, space, faired, lam, per_span, tol)
        except ToleranceNotMetError:
            if space.n_spans >= curve.space.n_spans:
                raise
        breaks = space.breakpoints
        rho = error_density(breaks, _span_max(breaks, fit.probe.u, values), fit.tol,
                            fit.degree)
        space = equidistributed_space(breaks, rho, space.n_spans + 1, fit.degree)
        (faired, values, _), lam = fit.trial(space), 0.0


def _final_curve_check(curve, fit, space, faired, lam, per_span, tol):
    """Check on twice the samples; back the polish off until ``tol`` holds."""
    check_probe = CurveProbe(curve, per_span=2 * per_span)
    e = check_probe.max_deviation(faired)[0]
    while e > tol and lam > 0.0:
        lam = lam / 10.0 if lam > 1e-8 else 0.0
        faired = fit.geometry(space, fit.project(space, lam))
        e = check_probe.max_deviation(faired)[0]
    if e > tol:
        raise ToleranceNotMetError(
            f"the adaptive target ({space.dimension} poles) passed the search samples but "
            f"deviates by {e:.4g} > tol={tol:g} on the denser check, as do the targets "
            "grown from it up to the source's span count; raise the tolerance or use "
            "method='wavelet'.",
            tolerance=tol, best_deviation=e)
    return faired, e, lam
