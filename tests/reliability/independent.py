"""Independent deviation measurement for the fuzz tests (no cq_fairing evaluation code).

Curves and surfaces are evaluated with ``scipy.interpolate.BSpline`` (rational ones in
homogeneous coordinates), and the distance from a point to a geometry is found by a
nearest dense sample followed by a vectorised golden-section search (curves) or by
alternating golden-section searches in u and v (surfaces).  The product uses its own
basis functions and Newton foot points, so agreement is a real cross-check.

Every distance returned is the distance to an actual point of the geometry (the best of
the local search and of the same-parameter point when ``params`` is given), so it can
only over-estimate the true point-to-geometry distance: a check ``distance <= tol`` is
on the safe side even where a local search ends in a local minimum (folded nets).
"""

import numpy as np
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

GOLDEN = 0.5 * (np.sqrt(5.0) - 1.0)


def curve_points(poles, knots, degree, weights, u):
    """Points of a (rational) B-spline curve at ``u`` with scipy's BSpline."""
    poles = np.asarray(poles, dtype=float)
    if weights is None:
        return BSpline(knots, poles, degree, extrapolate=False)(u)
    h = BSpline(knots, np.hstack([poles * weights[:, None], weights[:, None]]), degree,
                extrapolate=False)(u)
    return h[:, :-1] / h[:, -1:]


def surface_points(poles, u_knots, v_knots, degrees, weights, u, v):
    """Points of a (rational) tensor-product surface at the pairs ``(u[i], v[i])``."""
    pu, pv = degrees
    net = np.asarray(poles, dtype=float)
    if weights is not None:
        net = np.concatenate([net * weights[..., None], weights[..., None]], axis=2)
    ku, kv, d = net.shape
    along_u = BSpline(u_knots, net.reshape(ku, kv * d), pu, extrapolate=False)(u)
    along_u = along_u.reshape(len(u), kv, d)
    bv = BSpline.design_matrix(np.clip(v, v_knots[pv], v_knots[-pv - 1]), v_knots, pv)
    out = np.einsum("ij,ijd->id", bv.toarray(), along_u)
    return out if weights is None else out[:, :-1] / out[:, -1:]


def _golden(f, lo, hi, iterations=48):
    """Vectorised golden-section minimisation of ``f`` on the intervals [lo, hi]."""
    a, b = lo.copy(), hi.copy()
    c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    for _ in range(iterations):
        left = fc < fd
        b = np.where(left, d, b)
        a = np.where(left, a, c)
        c_new = b - GOLDEN * (b - a)
        d_new = a + GOLDEN * (b - a)
        c, d = np.where(left, c_new, d), np.where(left, c, d_new)
        fc, fd = np.where(left, f(c), fd), np.where(left, fc, f(d))
    x = 0.5 * (a + b)
    return x, f(x)


def _pruned(search, points, evaluate, params, threshold):
    """Same-parameter distances; the search runs only where they exceed ``threshold``."""
    if params is None:
        return search(points)
    args = params if isinstance(params, tuple) else (params,)
    near = np.linalg.norm(evaluate(*args) - points, axis=1)
    far = near > threshold
    if far.any():
        near[far] = np.minimum(near[far], search(points[far]))
    return near


def distance_to_curve(points, evaluate, domain, params=None, threshold=0.0, dense=4000):
    """Distance from each point to the curve ``evaluate(t)`` on ``domain`` (upper bound).

    ``params`` (optional): a parameter per point whose curve point is also a candidate;
    the search then runs only where that candidate is farther than ``threshold``.
    """
    return _pruned(lambda pts: _curve_search(pts, evaluate, domain, dense), points,
                   evaluate, params, threshold)


def _curve_search(points, evaluate, domain, dense):
    t = np.linspace(*domain, dense)
    tree = cKDTree(evaluate(t))
    _, j = tree.query(points)
    lo, hi = t[np.maximum(j - 1, 0)], t[np.minimum(j + 1, dense - 1)]
    _, sq = _golden(lambda s: np.sum((evaluate(s) - points) ** 2, axis=1), lo, hi)
    return np.sqrt(sq)


def distance_to_surface(points, evaluate, domain, params=None, threshold=0.0, dense=120,
                        rounds=6):
    """Distance from each point to the surface ``evaluate(u, v)`` on ``domain`` (upper bound).

    ``params`` (optional): ``(u, v)`` per point whose surface point is also a candidate;
    the search then runs only where that candidate is farther than ``threshold``.
    """
    return _pruned(lambda pts: _surface_search(pts, evaluate, domain, dense, rounds), points,
                   evaluate, params, threshold)


def _surface_search(points, evaluate, domain, dense, rounds):
    (u0, u1), (v0, v1) = domain
    gu, gv = np.meshgrid(np.linspace(u0, u1, dense), np.linspace(v0, v1, dense), indexing="ij")
    tree = cKDTree(evaluate(gu.ravel(), gv.ravel()))
    _, j = tree.query(points)
    u, v = gu.ravel()[j], gv.ravel()[j]
    hu, hv = (u1 - u0) / (dense - 1), (v1 - v0) / (dense - 1)
    for _ in range(rounds):
        u, _ = _golden(lambda s: np.sum((evaluate(s, v) - points) ** 2, axis=1),
                       np.maximum(u - hu, u0), np.minimum(u + hu, u1))
        v, sq = _golden(lambda s: np.sum((evaluate(u, s) - points) ** 2, axis=1),
                        np.maximum(v - hv, v0), np.minimum(v + hv, v1))
    return np.sqrt(sq)
