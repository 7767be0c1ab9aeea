"""Searches for the smallest passing count of spans: doubling, bisection, galloping and
interpolation on a monotone pass/fail verdict (:mod:`cq_fairing.core.adaptive`, note 2).
"""


import numpy as np


def _bisect_count(fails, passes, check):
    """Smallest passing count between a failing and a passing one (assumes monotone)."""
    while passes - fails > 1:
        mid = (passes + fails) // 2
        if check(mid):
            passes = mid
        else:
            fails = mid
    return passes


def _doubling(check, top, start=4):
    """Bracket ``(fails, passes)`` by doubling the count from ``start`` (cheap small spaces
    first); ``passes`` is ``None`` when even ``top`` fails."""
    fails, n = 0, min(start, top)
    while not check(n):
        if n == top:
            return fails, None
        fails, n = n, min(2 * n, top)
    return fails, n


def _gallop_down(passes, check):
    """Smallest passing count below a passing one, bracketed by stepping down 1, 2, 4, ...
    (assumes monotone): the same answer as bisecting from 0, in fewer checks when it lies
    close below ``passes``, as when a direction of a balanced net is lowered alone."""
    step = 1
    while passes - step >= 1:
        if not check(passes - step):
            return _bisect_count(passes - step, passes, check)
        passes, step = passes - step, 2 * step
    return _bisect_count(0, passes, check)


def _interpolated_count(fails, passes, value, limit, patience=3):
    r"""Smallest count in ``(fails, passes]`` whose ``value`` is ``<= limit``, for a value
    that falls as the count grows (a residual variance): the same answer as
    :func:`_bisect_count` when it is monotone, in fewer evaluations when it is smooth.

    The residual of a spline fit falls roughly like a power of the span count, so each
    guess is where the chord through the bracket's ends in
    :math:`(\log n, \log(value / limit))` crosses zero (regula falsi), with the Illinois
    rule: an end kept twice in a row has its weight halved, so the guesses do not creep up
    on the answer from one side.  A bisection follows whenever ``patience`` guesses have
    not halved the bracket (and while no failing count is known), so the worst case stays
    logarithmic.  On simulated residuals (power laws over a noise term, in
    ``tests/core/test_adaptive.py``) the brackets a doubling leaves close in 3.3
    evaluations on average where bisection needs 5.1.

    Parameters
    ----------
    fails, passes : int
        A count whose value exceeds ``limit`` (0: none known) and one whose value does not.
    value : callable
        ``value(n) > 0``; the bracket's ends are asked for again (memoise it).
    limit : float
    patience : int
    """
    weights, last = {"fails": 1.0, "passes": 1.0}, None
    halved_at, guesses = passes - fails, 0
    while passes - fails > 1:
        bisect = fails < 1 or guesses == patience
        n = (fails + passes) // 2 if bisect else _falsi_guess(fails, passes, value, limit,
                                                               weights)
        moved = "passes" if value(n) <= limit else "fails"
        fails, passes = (fails, n) if moved == "passes" else (n, passes)
        kept = "fails" if moved == "passes" else "passes"
        weights[moved] = 1.0
        if last == moved:
            weights[kept] *= 0.5
        last, guesses = moved, 0 if bisect else guesses + 1
        if bisect or 2 * (passes - fails) <= halved_at:
            halved_at, guesses = passes - fails, 0
    return passes


def _falsi_guess(fails, passes, value, limit, weights):
    r"""Count strictly inside ``(fails, passes)`` where the weighted chord through
    :math:`(\log n, \log(value / limit))` at the two ends crosses zero (the midpoint
    when the ends do not fall)."""
    above = weights["fails"] * np.log(value(fails) / limit)
    below = weights["passes"] * np.log(value(passes) / limit)
    t = above / (above - below) if above > below else 0.5
    n = int(round(np.exp(np.log(fails) + t * np.log(passes / fails))))
    return min(max(n, fails + 1), passes - 1)


def _scan_below(n, check, window=3):
    """Lower a bisected count further while fewer than ``window`` counts in a row fail."""
    best, misses = n, 0
    while n > 1 and misses < window:
        n -= 1
        if check(n):
            best, misses = n, 0
        else:
            misses += 1
    return best
