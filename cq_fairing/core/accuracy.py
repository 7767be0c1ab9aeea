r"""Accuracy control: the fewest control points whose faired result stays within a tolerance.

Fairing to scale :math:`n` (``n`` knot spans, ``n + p`` poles) gives a deviation
:math:`e(n)` from the source, measured at dense samples (:mod:`cq_fairing.core.measures`,
true geometric distance by default).  Accuracy control solves the inverse problem
:math:`\min\{n : e(n) \le \varepsilon\}` (Ji et al. 2014, section 4).  :math:`e` is
*not* monotone in :math:`n` in general (the spaces :math:`V_n` are not nested), so a
search can only certify what it has measured.  Three strategies:

``"linear"`` (Ji et al. 2014, eq. 16-19, Table 2)
    Dyadic descent :math:`n = 2^j` until :math:`e > \varepsilon`, then the linear
    hypothesis on :math:`y = \lg e` versus :math:`x = j = \log_2 n`:
    :math:`j = \frac{x_2 - x_1}{b - a}\lg\varepsilon + \frac{b x_1 - a x_2}{b - a}`,
    :math:`n = \operatorname{round}(2^j)`, replacing the bracket end on the same side of
    :math:`\varepsilon`, until the passing and failing scales are adjacent.
``"polyfit"`` (eq. 20-40, Table 3)
    Least-squares polynomial of degree ``order`` (2..6) through the dyadic table
    :math:`(j, \lg e(2^j))`, solved for :math:`\lg\varepsilon` inside the dyadic bracket,
    :math:`n = \lceil 2^j \rceil`.  The prediction is then measured; if it misses the
    tolerance, linear-hypothesis iterations continue from the bracket, so the answer is
    always within tolerance (but not necessarily the fewest poles).
``"guaranteed"`` (default)
    Dyadic bracket (the smallest passing dyadic scale :math:`2^{j+1}` and the failing
    :math:`2^j`), bisection to a passing :math:`n^*` with :math:`n^* - 1` failing, then a
    downward scan that accepts any smaller passing scale until :data:`SCAN_WINDOW`
    consecutive scales below the current answer fail.  What is guaranteed, precisely:

    1. the result is measured, and its deviation at the dense samples is ``<= tol``;
    2. it has no more poles than the smallest passing dyadic scale (the best one-scale
       DWFA answer);

    The search measures at ``per_span = 8`` samples per span of the source (the finer
    space); the answer is re-measured at :data:`STRICT_PER_SPAN` samples per span of the
    merged breakpoints of source and answer (curves; 8 for surfaces, what
    :func:`~cq_fairing.core.measures.deviation` reports by default) and, if that misses,
    the search is repeated with the answer marked as failing.
    3. the :data:`SCAN_WINDOW` scales just below it were measured and all exceed ``tol``.

    It is the exact minimum whenever :math:`e` exceeds ``tol`` for every scale more than
    :data:`SCAN_WINDOW` below the first crossing (checked against exhaustive search in the
    tests); nothing cheaper than measuring every smaller scale can promise more.

Surfaces minimise the total pole count :math:`(n_u + p_u)(n_v + p_v)`.  ``"guaranteed"``
finds :math:`u_{lo}` (the fewest u-spans with v untouched) and :math:`v_{lo}`, takes a
first answer by bisection on the segment from :math:`(u_{lo}, v_{lo})` to the largest net,
then walks :math:`n_u = u_{lo}, u_{lo}+1, \dots` (in steps of :math:`\lfloor (n_{u,\max} -
u_{lo})/32 \rfloor` first, then by one around the best): for each it tests the largest
:math:`n_v` that would beat the best total so far and, if that passes, bisects down to the
smallest passing :math:`n_v` (assuming :math:`e` grows as :math:`n_v` shrinks at fixed
:math:`n_u`); the walk stops when even :math:`n_v = 1` could not improve (not
:math:`v_{lo}`: between non-nested spaces a smaller :math:`n_u` can pass where the
source's :math:`n_u` fails).  For the same reason it also walks the :math:`n_u` below
:math:`u_{lo}` at which fewer v-spans than the source's could beat the best, and the
walk is repeated while the best improves (a smaller best admits fewer v-spans at each
:math:`n_u`: a net found later can make an :math:`n_u` tried earlier pass).  The answer
is measured within ``tol`` and scanned like the curve case in both directions.  A closed
direction (end rows that coincide) counts scales below
:func:`~cq_fairing.core.geometry.fewest_spans` as inadmissible, so the coarsest answer
still closes as a valid face.  ``"linear"`` and ``"polyfit"`` apply the seed's
methods along the equal-ratio diagonal :math:`(n_u, n_v) \approx s\,(n_{u,\max},
n_{v,\max})`.

Only coarse projections :math:`C_n = G_{nn}^{-1}E\,C_S` are computed during the search
(operators cached per pair of spaces); the wavelet details are computed once, for the
answer.
"""

from typing import NamedTuple

import numpy as np

from ..errors import InvalidInputError, InvalidToleranceError, ToleranceNotMetError
from .decomposition import decomposition
from .evaluation import sample_parameters, within_box
from .geometry import BSplineCurve, BSplineSurface, fewest_spans
from .options import SEARCHES, checked_choice, checked_order
from .plans import largest_resolved_scale, resolved_plan
from .probes import CurveProbe, SurfaceProbe
from .projection import project_curve, project_surface
from .results import cartesian_poles, homogeneous_coefficients
from .spaces import SplineSpace

__all__ = ["fair_curve_to_tolerance", "fair_surface_to_tolerance", "ScaleError",
           "STRATEGIES", "SCAN_WINDOW", "check_tolerance", "dyadic_table"]

STRATEGIES = SEARCHES  # the step rules of the search (``search`` of fair_curve/fair_surface)
SCAN_WINDOW = 4
"""Consecutive failing scales below the answer that the guaranteed search measures."""
STRICT_PER_SPAN = 16
r"""Samples per merged span of the strict check of a curve answer.  Eight per span missed a
peak of a wild degree-2 net by 1.7 % between samples (0.1778 reported, 0.1809 at 16 per
span; found by ``tests/reliability/test_fuzz.py``); sixteen quarter the second-order
excess :math:`\tfrac18 h^2 \max|d''|` at a small cost: only answers are checked."""


class ScaleError(NamedTuple):
    """One measured scale of an accuracy-control search (a row of ``result.table``).

    Attributes
    ----------
    n : int or (int, int)
        Knot spans (curves) or ``(n_u, n_v)`` (surfaces).
    poles : int
        Control points of the faired geometry (total for surfaces).
    scale : float
        Dyadic scale :math:`\\log_2 n` (curves) or of the diagonal index (surfaces).
    deviation : float
        Maximum deviation at the dense samples when ``exact``; otherwise (the
        guaranteed search only decides pass/fail) a value ``> tol`` that is a lower
        bound of the maximum, or a value ``<= tol`` that is an upper bound.
    step : int
        Order in which the scale was measured (0 first).
    exact : bool
    """

    n: object
    poles: int
    scale: float
    deviation: float
    step: int
    exact: bool = True


# -- validation ----------------------------------------------------------------------------------
def check_tolerance(tol):
    """Return ``tol`` as a float; raise :class:`InvalidToleranceError` unless positive and finite."""
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.integer, np.floating)):
        raise InvalidToleranceError(
            f"tol must be a positive number (a length in model units, e.g. 0.02 mm), got {tol!r}."
        )
    value = float(tol)
    if not np.isfinite(value) or value <= 0:
        raise InvalidToleranceError(
            f"tol must be a positive finite length (e.g. 0.02 mm), got {value!r}; "
            "pass the largest deviation you accept between original and faired geometry."
        )
    return value


def _check_options(strategy, order):
    checked_choice("strategy", strategy, STRATEGIES)
    checked_order(order)


def _check_degree(value, source_degree, name):
    if value is None:
        return min(3, source_degree)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidInputError(f"{name} must be an integer >= 1, got {value!r}.")
    return int(value)


# -- measured error functions ------------------------------------------------------------------
class _Chain:
    """Coarse coefficients of one direction per target scale, cached along the schedule.

    Admissible scales are those the source resolves
    (:func:`~cq_fairing.core.plans.resolved_plan`); ``n_max`` is the largest of them.
    """

    def __init__(self, space, degree, schedule):
        self.space, self.degree, self.schedule = space, degree, schedule
        self.n_max = largest_resolved_scale(space, degree, schedule, space.dimension - degree)
        self._cache = {}

    def target(self, n):
        return SplineSpace.quasi_uniform(int(n), self.degree, self.space.domain)

    def coarse(self, coefficients, n, key=None):
        """Coefficients in ``V_n`` along axis 0 (intermediate spaces cached under ``key``).

        ``None`` when the source does not resolve ``V_n`` (an inadmissible scale).
        """
        spaces = resolved_plan(self.space, self.target(n), self.schedule)
        if spaces is None:
            return None
        c = coefficients
        for i, (src, dst) in enumerate(zip(spaces[:-1], spaces[1:])):
            cache_key = (key, dst.key, i)
            if cache_key not in self._cache:
                if len(self._cache) > 256:
                    self._cache.clear()
                self._cache[cache_key] = c if src.same_as(dst) else decomposition(src, dst).coarse(c)
            c = self._cache[cache_key]
        return c


class _Measured:
    """An error function ``e(n)`` with a cache, an evaluation counter and a log.

    ``measure(n, tol)`` returns the exact maximum for ``tol=None``; with ``tol`` (set
    by :meth:`decide_only`) a pass/fail-deciding bound (see :class:`ScaleError`).
    """

    def __init__(self, measure, poles, scale, strict=None):
        self._measure, self._poles, self._scale = measure, poles, scale
        self._strict = measure if strict is None else strict
        self.values = {}
        self.tol = None
        self.evaluations = 0

    def decide_only(self, tol):
        """Measure only as far as needed to decide ``e(n) <= tol`` (faster)."""
        self.tol = tol
        return self

    def __call__(self, n):
        if n not in self.values:
            self.evaluations += 1
            self.values[n] = (float(self._measure(n, self.tol)), len(self.values),
                              self.tol is None)
        return self.values[n][0]

    def exact(self, n):
        """The exact maximum at ``n`` (re-measured if only a bound is known)."""
        if n not in self.values or not self.values[n][2]:
            self.evaluations += 1
            step = self.values[n][1] if n in self.values else len(self.values)
            self.values[n] = (float(self._strict(n)), step, True)
        return self.values[n][0]

    def table(self):
        rows = [ScaleError(n, self._poles(n), self._scale(n), v, step, ex)
                for n, (v, step, ex) in self.values.items()]
        return tuple(sorted(rows, key=lambda r: r.step))


def _curve_error(curve, degree, schedule, deviation):
    chain = _Chain(curve.space, degree, schedule)
    probe = CurveProbe(curve, method=deviation, u=sample_parameters(curve.space))
    strict = CurveProbe(curve, method=deviation, per_span=STRICT_PER_SPAN)
    coefficients = homogeneous_coefficients(curve)

    def geometry(n):
        coarse = chain.coarse(coefficients, n)
        if coarse is None:
            return None
        poles, weights = cartesian_poles(coarse, curve.is_rational)
        return BSplineCurve(poles, chain.target(n).knots, degree, weights)

    def measure(n, tol):
        return _deviation(probe, geometry(n), tol)

    err = _Measured(measure, lambda n: n + degree, lambda n: float(np.log2(n)),
                    lambda n: _deviation(strict, geometry(n)))
    return err, chain.n_max


def _deviation(probe, faired, tol=None):
    """``probe``'s maximum deviation of ``faired``; ``inf`` for an inadmissible scale (None:
    not resolved by the source, or below :func:`~cq_fairing.core.geometry.fewest_spans`)."""
    return float("inf") if faired is None else probe.max_deviation(faired, tol)[0]


# -- one-dimensional searches ---------------------------------------------------------------------
def _dyadic_bracket(err, n_max, tol, extra_points=0):
    """Descend ``2^j`` from the largest power below ``n_max``; return (fail, pass, table).

    ``fail`` is 0 when even ``n = 1`` passes.  With ``extra_points`` the descent goes on
    past the first failure until that many dyadic points are measured in total.
    """
    j = int(np.floor(np.log2(n_max)))
    fail, passing, points = 0, n_max, []
    while j >= 0:
        n = 2 ** j
        e = err(n)
        points.append((j, e))
        if fail == 0:
            if e <= tol:
                passing = n
            else:
                fail = n
        if fail and len(points) >= extra_points:
            break
        j -= 1
    return fail, passing, points


def _require(err, n_max, tol, what):
    if err(n_max) > tol:
        e = err.exact(n_max)
        best = min(v[0] for v in err.values.values() if v[2])
        raise ToleranceNotMetError(
            f"no target within tol={tol:g}: even the largest admissible target ({what}) "
            f"deviates by {e:.4g}; raise the tolerance or fair to the source's own degree "
            "and knots.", tolerance=tol, best_deviation=best,
        )


def _guaranteed(err, n_max, tol, window=SCAN_WINDOW):
    """Bracket, bisect, then scan ``window`` failing scales below the answer."""
    _require(err, n_max, tol, f"n={n_max}")
    fail, passing, _ = _dyadic_bracket(err, n_max, tol)
    while passing - fail > 1:
        mid = (passing + fail) // 2
        if err(mid) <= tol:
            passing = mid
        else:
            fail = mid
    n, misses = passing - 1, 0
    while n >= 1 and misses < window:
        if err(n) <= tol:
            passing, misses = n, 0
        else:
            misses += 1
        n -= 1
    return passing


def _lg(e):
    return float(np.log10(max(e, 1e-300)))


def _linear_iterations(err, tol, fail, passing, max_iter=64):
    """Eq. 16-19: replace the bracket end on the same side, until the ends are adjacent."""
    target = _lg(tol)
    for _ in range(max_iter):
        if passing - fail <= 1 or fail == 0:
            break
        x1, a = np.log2(passing), _lg(err(passing))
        x2, b = np.log2(fail), _lg(err(fail))
        if np.isfinite(b) and b != a:                 # b = inf at an inadmissible scale
            j = (x2 - x1) / (b - a) * target + (b * x1 - a * x2) / (b - a)
        else:
            j = 0.5 * (x1 + x2)
        n = int(np.clip(np.round(2.0 ** j), fail + 1, passing - 1))
        if err(n) <= tol:
            passing = n
        else:
            fail = n
    return passing


def _linear(err, n_max, tol):
    _require(err, n_max, tol, f"n={n_max}")
    fail, passing, _ = _dyadic_bracket(err, n_max, tol)
    return _linear_iterations(err, tol, fail, passing)


def polyfit_scale(points, tol, order, bracket):
    """Root of the least-squares polynomial ``lg e(j)`` at ``lg tol`` (eq. 20-40).

    Parameters
    ----------
    points : sequence of (j, e)
        Dyadic table.
    order : int
        Polynomial degree 2..6.
    bracket : (float, float)
        ``(j_fail, j_pass)``; the largest real root inside is returned, ``None`` if none.
    """
    points = [p for p in points if np.isfinite(p[1])]      # inadmissible scales: inf
    if len(points) < 2:
        return None
    x = np.array([p[0] for p in points], dtype=float)
    y = np.array([_lg(p[1]) for p in points])
    coef = np.polyfit(x, y, min(order, x.size - 1))
    coef[-1] -= _lg(tol)
    roots = np.roots(coef)
    lo, hi = bracket
    real = roots[np.abs(roots.imag) < 1e-9].real
    inside = real[(real >= lo - 1e-9) & (real <= hi + 1e-9)]
    return float(inside.max()) if inside.size else None


def _polyfit(err, n_max, tol, order):
    _require(err, n_max, tol, f"n={n_max}")
    fail, passing, points = _dyadic_bracket(err, n_max, tol, extra_points=max(7, order + 1))
    if fail == 0:
        return passing
    j = polyfit_scale(points, tol, order, (np.log2(fail), np.log2(passing)))
    if j is not None:
        n = int(np.clip(np.ceil(2.0 ** j - 1e-9), fail + 1, passing))
        if err(n) <= tol:
            return n
        fail = n
    return _linear_iterations(err, tol, fail, passing)


def _search_1d(err, n_max, tol, strategy, order):
    if strategy == "guaranteed":
        err.decide_only(tol)
        return _guaranteed(err, n_max, tol)
    if strategy == "linear":
        return _linear(err, n_max, tol)
    return _polyfit(err, n_max, tol, order)


def _verified(search, err, tol, attempts=8):
    """Run ``search`` until its answer passes the strict check (merged-breakpoint samples).

    The search measures at the source's samples (a subset of the strict ones, so a miss
    there is a strict miss); a strict miss is recorded and the search repeated.
    """
    for _ in range(attempts):
        n = search()
        if err.exact(n) <= tol:
            return n
    raise ToleranceNotMetError(
        f"accuracy control did not converge to a verified answer within tol={tol:g}; "
        "raise the tolerance slightly.", tolerance=tol,
        best_deviation=min(v[0] for v in err.values.values() if v[2]))


def dyadic_table(curve, j_min=0, *, target_degree=None, schedule="hybrid", deviation="geometric"):
    """Max deviation at every dyadic scale ``2^j``, ``j_min <= j <= log2(n_max)`` (Table 1).

    Returns
    -------
    list of (j, n, deviation), finest first.
    """
    degree = _check_degree(target_degree, curve.degree, "target_degree")
    err, n_max = _curve_error(curve, degree, schedule, deviation)
    top = int(np.floor(np.log2(n_max)))
    return [(j, 2 ** j, err(2 ** j)) for j in range(top, j_min - 1, -1)]


# -- public entry points --------------------------------------------------------------------------
def fair_curve_to_tolerance(curve, tol, *, target_degree=None, schedule="auto",
                            strategy="guaranteed", order=6, deviation="geometric"):
    r"""Fair ``curve`` with the fewest poles whose deviation stays within ``tol``.

    Parameters
    ----------
    curve : BSplineCurve
        Validated source curve.
    tol : float
        Largest allowed deviation (model units), ``> 0``.
    target_degree : int, optional
        Default ``min(3, curve.degree)``.
    schedule : {"auto", "direct", "hybrid"}
    strategy : {"guaranteed", "linear", "polyfit"}
        See the module documentation.
    order : int
        Polynomial degree for ``"polyfit"`` (2..6).
    deviation : {"geometric", "parametric"}
        Distance used for the tolerance (true two-sided, or same-parameter).

    Returns
    -------
    FairResult
        With ``max_deviation``, ``evaluations`` (deviation measurements) and ``table``
        (:class:`ScaleError` rows in measurement order).

    Raises
    ------
    InvalidToleranceError
        ``tol`` not a positive finite number.
    ToleranceNotMetError
        Even the largest admissible target exceeds ``tol``.
    """
    tol = check_tolerance(tol)
    _check_options(strategy, order)
    degree = _check_degree(target_degree, curve.degree, "target_degree")
    err, n_max = _curve_error(curve, degree, schedule, deviation)
    if n_max < 1:
        raise InvalidInputError(
            f"a degree-{degree} target needs more than {curve.n_poles} source poles.")
    n = _verified(lambda: _search_1d(err, n_max, tol, strategy, order), err, tol)
    target = SplineSpace.quasi_uniform(n, degree, curve.domain)
    result = project_curve(curve, target, schedule)
    deviation_value = err.exact(n)
    return result.replace(max_deviation=deviation_value, evaluations=err.evaluations,
                          table=err.table())


def _surface_error(surface, degrees, schedule, deviation, window=None):
    chain_u = _Chain(surface.u_space, degrees[0], schedule)
    chain_v = _Chain(surface.v_space, degrees[1], schedule)
    bounds = None if window is None else (window[:2], window[2:])
    probe = SurfaceProbe(surface, method=deviation, hold_grid=False, bounds=bounds,
                         uv=within_box(sample_parameters(surface.u_space),
                                       sample_parameters(surface.v_space), bounds))
    strict = SurfaceProbe(surface, method=deviation, hold_grid=False, bounds=bounds)
    net = homogeneous_coefficients(surface)
    lowest = [min(n, chain.n_max) for n, chain in zip(fewest_spans(surface), (chain_u, chain_v))]

    def geometry(nu, nv):
        if nu < lowest[0] or nv < lowest[1]:   # a closed direction cannot close on so few
            return None
        upper = chain_u.coarse(net, nu, key="u")
        if upper is None:
            return None
        coarse = chain_v.coarse(np.swapaxes(upper, 0, 1), nv, key=("v", nu))
        if coarse is None:
            return None
        poles, weights = cartesian_poles(np.swapaxes(coarse, 0, 1), surface.is_rational)
        return BSplineSurface(poles, chain_u.target(nu).knots, chain_v.target(nv).knots,
                              degrees[0], degrees[1], weights)

    def measure(n, tol):
        return _deviation(probe, geometry(*n), tol)

    err = _Measured(measure, lambda n: (n[0] + degrees[0]) * (n[1] + degrees[1]),
                    lambda n: float(np.log2(max(n))),
                    lambda n: _deviation(strict, geometry(*n)))
    return err, chain_u, chain_v


def check_window(window, surface):
    """``window`` as four floats ``(u0, u1, v0, v1)`` with ``u0 < u1``, ``v0 < v1`` inside
    the domain (to rounding), or ``None``."""
    if window is None:
        return None
    (a, b), (c, d) = surface.domain
    try:
        u0, u1, v0, v1 = (float(x) for x in window)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(
            f"window must be four numbers (u0, u1, v0, v1), got {window!r}.") from exc
    eps = 1e-9 * max(b - a, d - c)
    if not (a - eps <= u0 < u1 <= b + eps and c - eps <= v0 < v1 <= d + eps):
        raise InvalidInputError(
            f"window must be a parameter box inside the domain u[{a:g}, {b:g}] x "
            f"v[{c:g}, {d:g}] with u0 < u1 and v0 < v1, got {window!r}.")
    return max(u0, a), min(u1, b), max(v0, c), min(v1, d)


def _min_along(err, fixed, tol, lo_fail, hi_pass, axis):
    """Smallest passing index along ``axis`` between a failing and a passing one."""
    def at(k):
        return err((k, fixed) if axis == 0 else (fixed, k))
    while hi_pass - lo_fail > 1:
        mid = (hi_pass + lo_fail) // 2
        if at(mid) <= tol:
            hi_pass = mid
        else:
            lo_fail = mid
    return hi_pass


def _guaranteed_surface(err, U, V, pu, pv, tol, window=SCAN_WINDOW):
    _require(err, (U, V), tol, f"n=({U}, {V})")
    u_err = _Projected(err, lambda k: (k, V))
    v_err = _Projected(err, lambda k: (U, k))
    u_lo = _guaranteed(u_err, U, tol, window)
    v_lo = _guaranteed(v_err, V, tol, window)
    best = _diagonal_start(err, (u_lo, v_lo), (U, V), tol)
    step = max(1, (U - u_lo) // 32)
    while True:   # again while the best improves: each n_u then admits fewer v-spans
        found = _walk(err, range(u_lo, U + 1, step), best, V, pu, pv, tol)
        below = _below(found, u_lo, V, pu, pv)
        found = _walk(err, range(below, u_lo), found, V, pu, pv, tol)
        if step > 1:
            near = range(max(below, found[0] - step + 1), min(U, found[0] + step - 1) + 1)
            found = _walk(err, near, found, V, pu, pv, tol)
        if found == best:
            return _scan_surface(err, best, tol, window)
        best = found


def _below(best, u_lo, V, pu, pv):
    """The smallest ``n_u`` below ``u_lo`` worth walking: those at which a net with
    fewer v-spans than the source's could beat ``best``.  ``u_lo`` is the fewest u-spans
    passing with v at the source; between non-nested spaces a smaller ``n_u`` can pass
    with fewer v-spans although it fails with all of them (a 7 x 9 net: ``(1, 6)``
    misses tol, ``(1, 5)`` passes, 32 poles against the 35 of ``(2, 4)``).  Below the
    returned ``n_u`` only ``n_v >= V`` could beat ``best``: those nets are the u-line
    that fixed ``u_lo``."""
    total = (best[0] + pu) * (best[1] + pv)
    return max(1, min(u_lo, -(-total // (V + pv)) - pu))


def _walk(err, nus, best, V, pu, pv, tol):
    """For increasing ``n_u``, the smallest passing ``n_v`` that beats ``best`` (if any).

    The fewest v-spans with u at the source would be a lower bound of ``n_v`` if the
    deviation grew monotonically as ``n_u`` shrinks; between non-nested spaces it
    need not (a 9 x 8 net: ``(6, 2)`` misses tol by 0.2 % while ``(4, 2)`` passes), so
    the walk goes on while any ``n_v >= 1`` could still beat ``best``.
    """
    for nu in nus:
        total = (best[0] + pu) * (best[1] + pv)
        cap = min(total // (nu + pu) - pv, V)
        if (cap + pv) * (nu + pu) >= total:
            cap -= 1
        if cap < 1:
            break
        if err((nu, cap)) <= tol:
            best = (nu, _min_along(err, nu, tol, 0, cap, axis=1))
    return best


def _diagonal_start(err, low, high, tol):
    """Smallest passing net on the segment from ``low`` to ``high`` (bisection)."""
    steps = max(high[0] - low[0], high[1] - low[1])
    if steps == 0:
        return high

    def point(k):
        return tuple(int(round(a + k * (b - a) / steps)) for a, b in zip(low, high))

    fail, passing = -1, steps
    while passing - fail > 1:
        mid = (passing + fail) // 2
        if err(point(mid)) <= tol:
            passing = mid
        else:
            fail = mid
    return point(passing)


def _scan_surface(err, best, tol, window):
    """Accept any passing net with one direction reduced, up to ``window`` misses."""
    improved = True
    while improved:
        improved = False
        for axis in (0, 1):
            misses, k = 0, best[axis] - 1
            while k >= 1 and misses < window:
                cand = (k, best[1]) if axis == 0 else (best[0], k)
                if err(cand) <= tol:
                    best, misses, improved = cand, 0, True
                else:
                    misses += 1
                k -= 1
    return best


class _Projected:
    """A one-dimensional view ``k -> err(map(k))`` sharing the parent's cache."""

    def __init__(self, err, mapping):
        self.err, self.mapping = err, mapping

    def __call__(self, k):
        return self.err(self.mapping(k))

    def exact(self, k):
        return self.err.exact(self.mapping(k))

    @property
    def values(self):
        return self.err.values


def fair_surface_to_tolerance(surface, tol, *, target_degree=(None, None), schedule="auto",
                              strategy="guaranteed", order=6, deviation="geometric",
                              window=None):
    r"""Fair ``surface`` with the fewest poles in total whose deviation stays within ``tol``.

    Parameters
    ----------
    surface : BSplineSurface
    tol : float
    target_degree : (int or None, int or None)
    schedule : {"auto", "direct", "hybrid"}
    strategy : {"guaranteed", "linear", "polyfit"}
        ``"guaranteed"`` minimises :math:`(n_u + p_u)(n_v + p_v)`; the seed strategies
        search the equal-ratio diagonal (see the module documentation).
    order : int
    deviation : {"geometric", "parametric"}
    window : (u0, u1, v0, v1), optional
        Parameter box inside the domain (a trimmed face's UV box) where the deviation is
        measured, two-sided: samples of either surface in the box, foot points on the
        other surface in the box.  Default the whole domain.

    Returns
    -------
    SurfaceFairResult
        With ``max_deviation`` (over ``window``), ``evaluations`` and ``table``.

    Raises
    ------
    InvalidToleranceError, ToleranceNotMetError, InvalidInputError (``window``)
    """
    tol = check_tolerance(tol)
    _check_options(strategy, order)
    window = check_window(window, surface)
    tdu, tdv = (None, None) if target_degree is None else target_degree
    pu = _check_degree(tdu, surface.u_degree, "target_degree (u)")
    pv = _check_degree(tdv, surface.v_degree, "target_degree (v)")
    err, chain_u, chain_v = _surface_error(surface, (pu, pv), schedule, deviation, window)
    U, V = chain_u.n_max, chain_v.n_max
    if U < 1 or V < 1:
        raise InvalidInputError("the surface has too few poles for the target degrees.")
    top = max(U, V)

    def diagonal(k):
        return (max(1, int(round(k * U / top))), max(1, int(round(k * V / top))))

    def search():
        if strategy == "guaranteed":
            return _guaranteed_surface(err.decide_only(tol), U, V, pu, pv, tol)
        return diagonal(_search_1d(_Projected(err, diagonal), top, tol, strategy, order))

    n = _verified(search, err, tol)
    result = project_surface(surface, chain_u.target(n[0]), chain_v.target(n[1]), schedule)
    deviation_value = err.exact(n)
    return result.replace(max_deviation=deviation_value, evaluations=err.evaluations,
                          table=err.table())
