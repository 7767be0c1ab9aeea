"""Parametrisation-free measures for the peer benchmark (dense closest point, fairness).

Peers return geometry in their own parametrisations, so every distance here is a true
closest-point distance found by a KD-tree on dense samples and refined by the core's
Newton projection (``closest_points_curve`` / ``closest_points_surface``).  Fairness
figures are geometric (arc length, area), so they do not depend on parametrisation.
"""

import numpy as np
from scipy.spatial import cKDTree

from cq_fairing.core.measures import (
    closest_points_curve,
    closest_points_surface,
    count_extrema,
    curve_curvature,
    curve_derivatives,
    surface_curvatures,
    surface_derivatives,
)


def curve_samples(curve, count):
    lo, hi = curve.domain
    u = np.unique(np.concatenate([np.linspace(lo, hi, count), curve.space.breakpoints]))
    return u, curve_derivatives(curve, u, 0)[0]


def points_to_curve(curve, points, density=None):
    """Closest-point distance of each point to ``curve``, shape (q,)."""
    count = density or max(20 * curve.n_poles, 4 * len(points), 4000)
    u, pts = curve_samples(curve, count)
    _, near = cKDTree(pts).query(points)
    return closest_points_curve(curve, points, u[near])[1]


def surface_grid(surface, shape):
    (ulo, uhi), (vlo, vhi) = surface.domain
    u = np.linspace(ulo, uhi, shape[0])
    v = np.linspace(vlo, vhi, shape[1])
    return u, v, surface.evaluate_grid(u, v)


def points_to_surface(surface, points, density=None, starts=None):
    """Closest-point distance of each point (q, 3) to ``surface``, shape (q,).

    Newton from the nearest of a dense grid of samples and, when ``starts = (u, v)`` is
    given (the parameters the points were sampled at on the other surface), from there
    too; the smaller distance wins (both are distances to actual surface points).  The
    second start matters where a thin part folds back (a blade tip): the nearest sample
    can lie on the far side and lead to a local minimum there.
    """
    ku, kv = surface.poles.shape[:2]
    nu = density or int(np.clip(6 * ku, 150, 900))
    nv = density or int(np.clip(6 * kv, 150, 900))
    u, v, grid = surface_grid(surface, (nu, nv))
    _, near = cKDTree(grid.reshape(-1, 3)).query(points)
    i, j = np.unravel_index(near, (nu, nv))
    d = closest_points_surface(surface, points, u[i], v[j])[2]
    if starts is not None:
        d = np.minimum(d, closest_points_surface(surface, points, *starts)[2])
    return d


def two_sided(source, result, kind, samples):
    """Max of both directed closest-point distances between ``source`` and ``result``."""
    if kind == "curve":
        _, a = curve_samples(source, samples)
        _, b = curve_samples(result, samples)
        return max(points_to_curve(result, a).max(), points_to_curve(source, b).max())
    n = int(np.sqrt(samples))
    u, v, a = surface_grid(source, (n, n))
    b = surface_grid(result, (n, n))[2].reshape(-1, 3)
    uu, vv = (x.ravel() for x in np.meshgrid(u, v, indexing="ij"))
    return max(points_to_surface(result, a.reshape(-1, 3),
                                 starts=_mapped((uu, vv), source, result)).max(),
               points_to_surface(source, b, starts=_mapped((uu, vv), source, source)).max())


def _mapped(uv, source, target):
    """Parameters ``uv`` of ``source`` mapped affinely onto ``target``'s domain."""
    return tuple(t0 + (x - s0) * (t1 - t0) / (s1 - s0)
                 for x, (s0, s1), (t0, t1) in zip(uv, source.domain, target.domain))


def to_truth(truth, result, kind, samples):
    """(rms, max) closest-point distance from result samples to the noise-free truth."""
    if kind == "curve":
        d = points_to_curve(truth, curve_samples(result, samples)[1])
    else:
        n = int(np.sqrt(samples))
        d = points_to_surface(truth, surface_grid(result, (n, n))[2].reshape(-1, 3))
    return float(np.sqrt(np.mean(d ** 2))), float(d.max())


def _line_fairness(points, kappa):
    """(int (dk/ds)^2 ds, int k^2 ds, extrema) along one densely sampled line."""
    ds = np.linalg.norm(np.diff(points, axis=0), axis=1)
    ds = np.maximum(ds, 1e-300)
    dk = np.diff(kappa) / ds
    mid = 0.5 * (kappa[1:] + kappa[:-1])
    return float(np.sum(dk ** 2 * ds)), float(np.sum(mid ** 2 * ds)), count_extrema(kappa, 1e-4)


def curve_fairness(curve, samples=20000):
    """Geometric fairness: int (dk/ds)^2 ds, int k^2 ds, curvature range, curvature extrema."""
    lo, hi = curve.domain
    u = np.linspace(lo, hi, samples)
    kappa, _ = curve_curvature(curve, u)
    pts = curve_derivatives(curve, u, 0)[0]
    jerk, bend, extrema = _line_fairness(pts, kappa)
    return {"dk2": jerk, "bending": bend, "kmin": float(kappa.min()),
            "kmax": float(kappa.max()), "extrema": int(extrema)}


def surface_fairness(surface, lines=21, per_line=600, grid=160):
    """Iso-line fairness (21 lines per direction at fixed domain fractions) and area terms.

    ``dk2``: sum over iso-lines of int (dk/ds)^2 ds (k the iso-curve's curvature);
    ``bending``: int (k1^2 + k2^2) dA on a grid; ``kmin``/``kmax``: principal curvature
    range; ``extrema``: curvature extrema summed over the iso-lines.
    """
    (ulo, uhi), (vlo, vhi) = surface.domain
    fu = np.linspace(ulo, uhi, lines)
    fv = np.linspace(vlo, vhi, lines)
    tu = np.linspace(ulo, uhi, per_line)
    tv = np.linspace(vlo, vhi, per_line)
    jerk = extrema = 0.0
    for fixed, moving, along_u in ((fv, tu, True), (fu, tv, False)):
        for c in fixed:
            uu, vv = (moving, np.full_like(moving, c)) if along_u else (np.full_like(moving, c), moving)
            s = surface_derivatives(surface, uu, vv, 2)
            d1 = s[(1, 0)] if along_u else s[(0, 1)]
            d2 = s[(2, 0)] if along_u else s[(0, 2)]
            speed = np.maximum(np.linalg.norm(d1, axis=1), 1e-300)
            kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / speed ** 3
            j, _, e = _line_fairness(s[(0, 0)], kappa)
            jerk += j
            extrema += e
    gu = np.linspace(ulo, uhi, grid)
    gv = np.linspace(vlo, vhi, grid)
    uu, vv = np.meshgrid(gu, gv, indexing="ij")
    c = surface_curvatures(surface, uu.ravel(), vv.ravel())
    s = surface_derivatives(surface, uu.ravel(), vv.ravel(), 1)
    area = np.linalg.norm(np.cross(s[(1, 0)], s[(0, 1)]), axis=1)
    w = np.full(uu.size, (gu[1] - gu[0]) * (gv[1] - gv[0]))
    bend = float(np.sum((c["k1"] ** 2 + c["k2"] ** 2) * area * w))
    k = np.concatenate([c["k1"], c["k2"]])
    return {"dk2": float(jerk), "bending": bend, "kmin": float(k.min()),
            "kmax": float(k.max()), "extrema": int(extrema)}
