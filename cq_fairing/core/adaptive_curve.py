"""Adaptive fairing of curves: :func:`fair_curve_adaptive` and its target search
(:mod:`cq_fairing.core.adaptive`); :class:`CurveSearch`, its stages on one source,
tolerance and degree, each measured once, among them the ``"faithful"`` fit where the
noise, not the tolerance, sets the size (:meth:`CurveSearch.noise_limited`).

A count of the knot family checked only for its verdict (the doubling and bisection,
the last redistribution round of a count) is measured only as far as the verdict needs
(:meth:`_CurveFit.errors`); every value the results depend on is measured as in full.
"""

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
from .polish import _scaled_energy, largest_penalty
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
        self._system = (None, None)

    def _normal_equations(self, space):
        r"""``{"gram", "rhs", "energy"}`` of ``space``: :math:`G_T`,
        :math:`\langle\Phi_T|\Phi_S\rangle C_S` and the scaled :math:`G^{(3)}`
        (built when first asked for); kept for the last space, which the polish and its
        back-off project onto again and again."""
        key = (space.degree, space.knots.tobytes())
        if self._system[0] != key:
            rhs = gram_matrix(space, self.curve.space) @ self.coefficients
            self._system = (key, {"gram": gram_matrix(space), "rhs": rhs, "energy": None})
        return self._system[1]

    def project(self, space, lam=0.0):
        """Coefficients of the (penalised) projection onto ``space``."""
        system = self._normal_equations(space)
        g = system["gram"]
        if lam > 0.0:
            if system["energy"] is None:
                system["energy"] = _scaled_energy(space, 3)
            g = g + lam * system["energy"]
        return np.asarray(spla.splu(sp.csc_matrix(g)).solve(system["rhs"]))

    def geometry(self, space, coefficients):
        if self.curve.is_rational:
            w = coefficients[:, -1]
            return BSplineCurve(coefficients[:, :-1] / w[:, None], space.knots, space.degree, w)
        return BSplineCurve(coefficients, space.knots, space.degree)

    def errors(self, faired, verdict=False):
        """Per-sample deviation: true distance where the bound exceeds part of tol.

        With ``verdict`` only whether tol holds is asked for: a candidate the probe
        refutes (:meth:`~cq_fairing.core.probes.CurveProbe.refutes`) keeps its bounds,
        and a failing one's true distances may be one-sided.  The verdict is the same,
        and so are the values of a passing candidate; a failing one's are not those of
        a full measure (which the error densities of the reduction need)."""
        self.evaluations += 1
        other, bound = self.probe.bound(faired)
        if verdict and self.probe.refutes(faired, other, bound, self.tol):
            return bound
        return _refined(bound, lambda idx: self.probe.true_distance(
            faired, other, idx, tol=self.tol, verdict=verdict), self.tol)

    def trial(self, space, lam=0.0, verdict=False):
        """``(faired, per-sample deviation, max)``.  A rational candidate with a
        non-positive weight fails (``max = inf``): it may pass through infinity between
        samples.  Its samples then say nothing about where the error is, so they all get
        the same value (twice the tolerance), which keeps the knot density as it is.
        ``verdict``: as for :meth:`errors`."""
        coefficients = self.project(space, lam)
        faired = self.geometry(space, coefficients)
        if self.curve.is_rational and not np.all(coefficients[:, -1] > 0):
            return faired, np.full(self.probe.u.size, 2.0 * self.tol), np.inf
        values = self.errors(faired, verdict)
        return faired, values, float(values.max())


def _reduce(space0, values0, u, tol, degree, trial, rounds=ROUNDS):
    """Lower the span count one at a time with error-driven knots while ``tol`` holds.

    ``trial(space, verdict=...)`` as :meth:`_CurveFit.trial`: the last round of a count
    asks for the verdict only (a failing round's values are needed only for the next
    round's density).  Returns the last passing ``(space, faired, values, max)``.
    """
    best = (space0,) + values0
    while best[0].n_spans > 1:
        space, values = best[0], best[2]
        b = space.breakpoints
        rho = error_density(b, _span_max(b, u, values), tol, degree)
        n = space.n_spans - 1
        found = None
        for round_ in range(rounds):
            cand = equidistributed_space(b, rho, n, degree)
            f, vals, e = trial(cand, verdict=round_ == rounds - 1)
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
    return CurveSearch(curve, tol, checked_target_degree(target_degree, curve.degree),
                       per_span).adaptive(checked_objective(objective), polish)


class CurveSearch:
    """The stages of the adaptive fits of one source curve at one tolerance and degree,
    each measured once and kept: the counts of the knot family checked against ``tol``,
    the compact search (:meth:`compact`), the noise-limited count
    (:meth:`faithful_count`), and the polish and checks that finish a fit
    (:meth:`finished`).  :func:`fair_curve_adaptive` runs them in order (:meth:`adaptive`);
    the curves' default (:mod:`cq_fairing.core.auto_curve`) runs only those that can
    change its choice.

    Parameters
    ----------
    curve : BSplineCurve
        Validated source curve.
    tol : float
        Checked tolerance.
    degree : int
        Checked target degree.
    per_span : int
        Deviation samples per source span.
    """

    def __init__(self, curve, tol, degree, per_span=8):
        self.curve, self.tol, self.degree, self.per_span = curve, tol, degree, per_span
        self.fit = _CurveFit(curve, SAFETY * tol, degree, per_span)
        self.top = curve.space.n_spans
        self.checked = {}
        self._density = _source_density(curve.space)
        self._check_probe = None
        self._kept = {}

    def family(self, n):
        """The knot family's space with ``n`` spans (breakpoints equidistributing the
        source's own density)."""
        return equidistributed_space(*self._density, n, self.degree)

    def passes(self, n):
        """Whether the family's space with ``n`` spans is within tol on the search
        samples; its trial is kept in ``checked[n]``, in full for a passing count and the
        top one, as far as the verdict needs for a failing one
        (:meth:`_CurveFit.errors`)."""
        if n not in self.checked:
            self.checked[n] = self.fit.trial(self.family(n), verdict=n != self.top)
        return self.checked[n][2] <= self.fit.tol

    @property
    def check_probe(self):
        """The probe of the final check: twice the search's samples per span."""
        if self._check_probe is None:
            self._check_probe = CurveProbe(self.curve, per_span=2 * self.per_span)
        return self._check_probe

    def once(self, key, compute):
        """``compute()``, computed on the first call with ``key`` and kept."""
        if key not in self._kept:
            self._kept[key] = compute()
        return self._kept[key]

    def compact(self, start=4):
        """Fewest spans within tol from ``start`` (:func:`_compact_curve`), unpolished:
        ``(space, faired, values, deviation)``.

        Raises
        ------
        ToleranceNotMetError
            Even the source's own breakpoints at the target degree exceed tol.
        """
        return self.once(("compact", start), lambda: _compact_curve(self, start))

    def faithful_count(self, ceiling=np.inf):
        """``(count, sigma)`` of :func:`_faithful_count`; ``(None, sigma)`` where a count
        whose space has more than ``ceiling`` poles is found too noisy: the count is not
        below it, so its space has more poles too (the search stops there)."""
        return self.once(("faithful", ceiling), lambda: _faithful_count(self, ceiling))

    def residual_variance(self, n):
        """Residual variance (:class:`~cq_fairing.core.fidelity.CurveResidual`) of the
        projection onto the family's space with ``n`` spans, computed once."""
        def compute():
            residual = self.once("residual", lambda: CurveResidual(self.curve))
            space = self.family(n)
            return residual.variance(self.fit.geometry(space, self.fit.project(space)))
        return self.once(("variance", n), compute)

    def holds(self, faired):
        """Whether ``faired`` is within tol on the final check's samples: the verdict of
        :func:`_final_curve_check` without its exact maximum."""
        return self.check_probe.max_deviation(faired, self.tol)[0] <= self.tol

    def noise_limited(self, most_poles=np.inf):
        """The ``"faithful"`` fit where the noise sets its size, else ``None``.

        The smallest target of the knot family whose residual is down to the source's
        estimated noise (:mod:`cq_fairing.core.fidelity`) is the answer when it meets
        ``tol`` (checked as by :func:`fair_curve_adaptive`).  When it does not, ``tol``
        needs more poles than the noise does: the tolerance, not the noise, limits the
        fit, and the ``"faithful"`` objective goes on with the compact search; this
        stops there and returns ``None`` (one projection measured, no search), as it
        does, before anything is measured, when that target has more than
        ``most_poles`` poles.

        Returns
        -------
        FairResult or None
            As :func:`fair_curve_adaptive` with ``objective="faithful"`` returns it.

        Raises
        ------
        ToleranceNotMetError
            The target passes the search samples but not the final check, nor do the
            targets grown from it up to the source's span count.
        """
        start, sigma = self.faithful_count()
        if self.family(start).dimension > most_poles or not self.passes(start):
            return None
        return self.finished((self.family(start),) + self.checked[start], 0.0,
                             (("noise", sigma),))

    def adaptive(self, objective="compact", polish=True):
        """:func:`fair_curve_adaptive` on this search (checked ``objective``)."""
        start, table = 4, ()
        if objective == "faithful":
            quiet = self.noise_limited()
            if quiet is not None:
                return quiet
            start, sigma = self.faithful_count()
            table = (("noise", sigma),)
        found, lam = self.polished(self.compact(start), polish)
        fair = objective == "fair" and polish and not self.curve.is_rational and self.degree >= 3
        return self.finished(found, lam, table, fair)

    def polished(self, found, polish=True):
        """``found`` (as :meth:`compact`) with the energy polish of a polynomial target of
        degree >= 3, and its ``lambda``."""
        space, faired, values, e = found
        lam = 0.0
        if polish and not self.curve.is_rational and self.degree >= 3:
            (faired, values, e), lam = largest_penalty(lambda x: self.fit.trial(space, x),
                                                       self.fit.tol, (faired, values, e))
        return (space, faired, values, e), lam

    def finished(self, found, lam, table=(), fair=False):
        """The result of ``found`` (as :meth:`compact`) with penalty ``lam``: checked on
        denser samples (:func:`_checked_curve`), the objective ``"fair"``'s growths with
        ``fair``.

        Raises
        ------
        ToleranceNotMetError
            The final check fails up to the source's span count.
        """
        space, faired, values, _ = found
        space, faired, e, lam = _checked_curve(self, space, faired, values, lam)
        if fair:
            space, faired, e, lam = _fairest_curve(self, (space, faired, e, lam), values)
        step = decomposition(self.curve.space, space)
        return FairResult(self.curve, faired, (self.top, space.n_spans), space.n_spans,
                          "adaptive", (step,), max_deviation=e,
                          evaluations=self.fit.evaluations,
                          table=(("lambda", lam),) + table)


class _TooNoisy(Exception):
    """A count of :func:`_faithful_count` above its ceiling is too noisy."""


def _faithful_count(search, ceiling=np.inf):
    """Smallest count whose residual variance is within the noise level, and that level;
    ``None`` for the count once one whose space has more than ``ceiling`` poles fails
    (the count found is never below a failing one).

    Doubling from a small count stops at the count the noise was measured on (its
    variance is the noise level, so it passes); bisection closes the bracket (a curve's
    residual falls off a cliff onto the noise, where :func:`_interpolated_count`'s
    log-log chord guesses badly: 9 projections against 5 on the seed curve at degree 7)."""
    top = search.top

    def count(fraction):
        return max(1, int(round(fraction * top)))

    sigma = noise_level(lambda fraction: search.residual_variance(count(fraction)),
                        search.curve.size)
    limit = noise_limit(sigma)

    def quiet(n):
        if search.residual_variance(n) <= limit:
            return True
        if search.family(n).dimension > ceiling:
            raise _TooNoisy
        return False

    try:
        fails, n = _doubling(quiet, count(1.0 / NOISE_FRACTION))
        return (top if n is None else _bisect_count(fails, n, quiet)), sigma
    except _TooNoisy:
        return None, sigma


def _compact_curve(search, start):
    """Fewest spans within tol: doubling from ``start``, bisection, error-driven reduction."""
    fit, top = search.fit, search.top
    fails, n = _doubling(search.passes, top, start)
    if n is None:
        worst = search.checked[top][2]
        what = "give a non-positive weight" if np.isinf(worst) else f"deviate by {worst:.4g}"
        raise ToleranceNotMetError(
            f"no adaptive target within tol={search.tol:g}: simple knots on the source's "
            f"breakpoints at degree {fit.degree} {what}; raise the tolerance or keep the "
            f"degree{_multiple_knots_hint(fit.curve.space)}.",
            tolerance=search.tol, best_deviation=worst)
    n = _scan_below(_bisect_count(fails, n, search.passes), search.passes)
    return _reduce(search.family(n), search.checked[n], fit.probe.u, fit.tol, fit.degree,
                   fit.trial)


def _fairest_curve(search, compact, values):
    """Objective ``"fair"``: the ``compact`` answer ``(space, faired, deviation, lambda)``
    or the compact space with ``FAIR_CURVE_GROWTHS`` more spans (knots equidistributing
    the error density of the search-grid deviations ``values``), polished and checked,
    whichever has the least :func:`_curve_energy`."""
    fit = search.fit
    space = compact[0]
    breaks = space.breakpoints
    rho = error_density(breaks, _span_max(breaks, fit.probe.u, values), fit.tol, fit.degree)
    best, best_energy = compact, _curve_energy(space, compact[1])
    for extra in FAIR_CURVE_GROWTHS:
        grown = equidistributed_space(breaks, rho, space.n_spans + extra, fit.degree)
        trial = fit.trial(grown)
        if trial[2] > fit.tol:
            continue
        (faired, _, _), lam = largest_penalty(lambda x, grown=grown: fit.trial(grown, x),
                                              fit.tol, trial)
        try:
            faired, e, lam = _final_curve_check(search, grown, faired, lam)
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


def _checked_curve(search, space, faired, values, lam):
    """The final check of :func:`_final_curve_check`; a space it refuses grows by one
    span at a time (knots equidistributing the search grid's error density ``values``)
    up to the source's span count, as the surface search grows a refused net.  Returns
    ``(space, faired, deviation, lambda)``."""
    fit = search.fit
    while True:
        try:
            return (space,) + _final_curve_check(search, space, faired, lam)
        except ToleranceNotMetError:
            if space.n_spans >= search.top:
                raise
        breaks = space.breakpoints
        rho = error_density(breaks, _span_max(breaks, fit.probe.u, values), fit.tol,
                            fit.degree)
        space = equidistributed_space(breaks, rho, space.n_spans + 1, fit.degree)
        (faired, values, _), lam = fit.trial(space), 0.0


def _final_curve_check(search, space, faired, lam):
    """Check on twice the samples; back the polish off until ``tol`` holds."""
    tol = search.tol
    e = search.check_probe.max_deviation(faired)[0]
    while e > tol and lam > 0.0:
        lam = lam / 10.0 if lam > 1e-8 else 0.0
        faired = search.fit.geometry(space, search.fit.project(space, lam))
        e = search.check_probe.max_deviation(faired)[0]
    if e > tol:
        raise ToleranceNotMetError(
            f"the adaptive target ({space.dimension} poles) passed the search samples but "
            f"deviates by {e:.4g} > tol={tol:g} on the denser check, as do the targets "
            "grown from it up to the source's span count; raise the tolerance or use "
            "method='wavelet'.",
            tolerance=tol, best_deviation=e)
    return faired, e, lam
