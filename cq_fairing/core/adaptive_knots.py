r"""Knot families of the adaptive targets: breakpoints that equidistribute an error density.

A target with ``N`` spans has breakpoints :math:`b_j` with
:math:`\int_{b_j}^{b_{j+1}}\rho = \frac1N\int\rho` for a piecewise-constant density
:math:`\rho`; the density of a span whose error :math:`e_j` exceeds
:math:`\theta\,\mathrm{tol}` grows as :math:`(e_j/\theta\,\mathrm{tol})^{1/(p+1)}/h_j`
(:mod:`cq_fairing.core.adaptive`, notes 1 and 3).
"""


import numpy as np

from .spaces import SplineSpace

THETA = 0.9          # redistribution aims at THETA * tol


SAFETY = 0.99       # the search works to SAFETY * tol (room for excess between samples)


ROUNDS = 4           # redistribution rounds per count


FLOOR = 0.25         # density floor, fraction of the mean density


# -- knot families ----------------------------------------------------------------------------
def equidistributed_space(breaks, density, n, degree):
    r"""Clamped space with ``n`` spans whose breakpoints equidistribute ``density``.

    Parameters
    ----------
    breaks : ndarray, shape (s + 1,)
        Breakpoints on which ``density`` is piecewise constant.
    density : ndarray, shape (s,)
        Positive density per span.
    n : int
        Spans of the new space (``>= 1``).
    degree : int

    Returns
    -------
    SplineSpace
        Knots ``b_0 (degree+1 times), b_1, ..., b_{n-1}, b_n (degree+1 times)`` with
        :math:`\int_{b_i}^{b_{i+1}}\rho = \frac1n\int\rho`.
    """
    mass = np.concatenate([[0.0], np.cumsum(density * np.diff(breaks))])
    new = np.interp(np.linspace(0.0, mass[-1], int(n) + 1), mass, breaks)
    new[0], new[-1] = breaks[0], breaks[-1]
    new = _separate(new)
    knots = np.concatenate([np.full(degree, new[0]), new, np.full(degree, new[-1])])
    return SplineSpace(int(degree), knots)


def _separate(b, min_fraction=1e-3):
    """Keep breakpoints strictly increasing (no span below ``min_fraction`` of the mean)."""
    gap = min_fraction * (b[-1] - b[0]) / (b.size - 1)
    h = np.maximum(np.diff(b), gap)
    out = b[0] + np.concatenate([[0.0], np.cumsum(h)]) * (b[-1] - b[0]) / h.sum()
    out[-1] = b[-1]
    return out


def error_density(breaks, span_error, tol, degree):
    r"""Density :math:`\rho_j = h_j^{-1}(e_j/\theta\,\mathrm{tol})^{1/(p+1)}`, smoothed and floored.

    Parameters
    ----------
    breaks : ndarray, shape (s + 1,)
    span_error : ndarray, shape (s,)
        Largest deviation measured in each span.
    tol : float
    degree : int

    Returns
    -------
    ndarray, shape (s,)
    """
    h = np.diff(breaks)
    ratio = np.maximum(span_error, 1e-6 * tol) / (THETA * tol)
    rho = ratio ** (1.0 / (degree + 1)) / h
    for _ in range(2):
        padded = np.concatenate([rho[:1], rho, rho[-1:]])
        rho = np.maximum(rho, 0.25 * padded[:-2] + 0.5 * padded[1:-1] + 0.25 * padded[2:])
    mean = np.sum(rho * h) / np.sum(h)
    return np.maximum(rho, FLOOR * mean)


def _source_density(space):
    b = space.breakpoints
    return b, 1.0 / np.diff(b)


def _refined(bound, exact, tol, batch=256):
    """Per-sample deviation: the same-parameter ``bound``, replaced by the true distance
    ``exact(idx)`` where the bound exceeds ``tol``, largest first, until one true
    distance exceeds ``tol`` (the candidate fails; later samples keep their bound).
    """
    values = np.array(bound, dtype=float)
    order = np.flatnonzero(values > tol)
    order = order[np.argsort(values[order])[::-1]]
    start = 0
    while start < order.size:
        idx = order[start:start + batch]
        values[idx] = exact(idx)
        if values[idx].max() > tol:
            break
        start, batch = start + batch, 2 * batch
    return values


def _span_max(breaks, u, values):
    """Largest ``values`` per span of ``breaks`` (samples at parameters ``u``)."""
    idx = np.clip(np.searchsorted(breaks, u, side="right") - 1, 0, breaks.size - 2)
    out = np.zeros(breaks.size - 1)
    np.maximum.at(out, idx, values)
    return out


def _multiple_knots_hint(*spaces):
    """Advice for a source whose ``spaces`` have multiple interior knots, so that its own
    space has more poles than any adaptive target (simple knots on its breakpoints);
    else ``""``."""
    if all(s.dimension - s.degree == s.n_spans for s in spaces):
        return ""
    poles = " x ".join(str(s.dimension) for s in spaces)
    spans = " x ".join(str(s.n_spans) for s in spaces)
    return (f" or use method 'wavelet', whose uniform targets reach the source's own "
            f"space: its {poles} poles sit on {spans} spans (multiple knots)")
