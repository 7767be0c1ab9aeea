r"""Deviation and fairness measures between an original and a faired curve or surface.

Deviation
---------
Both geometries are sampled at the same dense parameters: ``per_span`` (default 8)
equally spaced parameters in every knot span of the finer space, the ends and all
breakpoints included (:func:`sample_parameters`).  Two distances are offered:

* ``"parametric"``: the same-parameter distance :math:`|A(u) - B(u)|`.  It costs one
  evaluation and is an *upper bound* of the true distance from :math:`A(u)` to the
  geometry :math:`B` (and from :math:`B(u)` to :math:`A`).
* ``"geometric"``: the true (closest-point) distance, in both directions, whose
  maximum is the two-sided Hausdorff estimate

  .. math:: h(A, B) = \max\Bigl(\max_{u} d(A(u), B),\; \max_{u} d(B(u), A)\Bigr).

  The foot point on a curve :math:`C` solves :math:`C'(t)\cdot(C(t) - P) = 0` by Newton's
  method (vectorised over all points, clamped to the domain) started at the nearest
  sample; on a surface the 2x2 Newton system of
  :math:`(S_u\cdot(S-P),\ S_v\cdot(S-P)) = 0` is used, started at the nearest sample
  in a window of :math:`\pm 2` samples around the same parameter (both surfaces share
  their parametrisation).  Every distance returned is the distance to an actual point
  of the geometry, so it can only over-estimate the exact point-to-geometry distance,
  never under-estimate it: tolerance checks stay on the safe side.

Maxima use the cheap bound to skip work: the true distance is computed only at samples
whose same-parameter distance exceeds the running maximum (or the tolerance), in
decreasing order of the bound.

Fairness
--------
Curvature :math:`\kappa = |C'\times C''|/|C'|^3` and torsion
:math:`\tau = (C'\times C'')\cdot C'''/|C'\times C''|^2` along curves; principal, mean
and Gaussian curvature of surfaces from the fundamental forms; the bending energies

.. math::  E_C = \int |C''(t)|^2\,dt, \qquad
           E_S = \iint |S_{uu}|^2 + 2|S_{uv}|^2 + |S_{vv}|^2 \,du\,dv

computed exactly from Gram matrices of derivatives (:func:`~cq_fairing.core.gram.gram_matrix`
with ``nu = 2``, tensor products for surfaces; polynomial geometry); the number of
curvature extrema and of inflections (wiggle count) and
:math:`\int (d\kappa/ds)^2\,ds` along curves.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from ..errors import InvalidInputError
from .geometry import BSplineCurve, BSplineSurface, extent, grid_product
from .gram import gram_matrix, quadrature_rule
from .spaces import basis_functions, find_spans, require_in_domain

__all__ = [
    "Deviation", "DeviationMap", "sample_parameters", "extent", "curve_derivatives",
    "surface_derivatives", "closest_points_curve", "closest_points_surface",
    "closest_points_surface_restarted",
    "CurveProbe", "SurfaceProbe", "deviation", "deviation_map",
    "curve_curvature", "curvature_derivative_energy", "surface_curvatures",
    "bending_energy", "count_extrema", "count_sign_changes", "curve_wiggles",
    "surface_wiggles", "fairness_summary",
]

DEVIATIONS = ("geometric", "parametric")
STEP_FLOOR = 1e-10   # a Newton step moving the foot point less than this x size: converged
HALVINGS = 12        # a Newton step that increases the distance is halved up to this often
BLOCK_SAMPLES = 65_536  # grid samples per block of rows when a probe does not hold its grid
COLLOCATIONS = 128     # collocation matrices a probe keeps (per target space and axis)


# -- samples and evaluation ---------------------------------------------------------------
def within_box(u, v, bounds):
    """Sample axes ``u``, ``v`` restricted to ``bounds`` ``((u0, u1), (v0, v1))``, whose
    ends become samples; unchanged for ``bounds=None``."""
    if bounds is None:
        return u, v
    return tuple(np.unique(np.concatenate([[low], x[(x > low) & (x < high)], [high]]))
                 for x, (low, high) in zip((u, v), bounds))


def sample_parameters(*spaces, per_span=8):
    """Dense parameters: ``per_span`` per span of the merged breakpoints, ends included.

    Parameters
    ----------
    *spaces : SplineSpace
        One or more spaces on the same domain; their breakpoints are merged, so the
        samples are at least ``per_span`` per span of the finer space.
    per_span : int, optional
        Samples per span (``>= 1``); every breakpoint is a sample.

    Returns
    -------
    ndarray, shape (spans * per_span + 1,)
    """
    if isinstance(per_span, bool) or not isinstance(per_span, (int, np.integer)) or per_span < 1:
        raise InvalidInputError(f"per_span must be an integer >= 1, got {per_span!r}.")
    b = np.unique(np.concatenate([s.breakpoints for s in spaces]))
    frac = np.arange(per_span) / per_span
    inner = (b[:-1, None] + (b[1:] - b[:-1])[:, None] * frac[None, :]).ravel()
    return np.append(inner, b[-1])


def curve_derivatives(curve, u, order):
    """Points and derivatives ``[C, C', ..., C^(order)]`` at ``u`` (rational allowed).

    Returns
    -------
    list of ndarray, each shape (len(u), d)
    """
    u = np.asarray(u, dtype=float).ravel()
    space = curve.space
    coeffs = curve.homogeneous() if curve.is_rational else curve.poles
    spans = find_spans(space, u)
    basis = basis_functions(space, u, spans, order)
    idx = spans[:, None] - space.degree + np.arange(space.degree + 1)[None, :]
    local = coeffs[idx]
    h = [np.einsum("qj,qjd->qd", basis[k], local) for k in range(order + 1)]
    if not curve.is_rational:
        return h
    return _rational_curve(h)


def _rational_curve(h):
    """Quotient rule for ``x = X / w`` (The NURBS Book, eq. 4.8) on homogeneous derivatives."""
    from math import comb

    w = [hk[:, -1:] for hk in h]
    out = []
    for k in range(len(h)):
        val = h[k][:, :-1].copy()
        for i in range(1, k + 1):
            val -= comb(k, i) * w[i] * out[k - i]
        out.append(val / w[0])
    return out


def surface_derivatives(surface, u, v, order):
    """Partial derivatives ``{(a, b): S_{u^a v^b}}`` with ``a + b <= order`` at points (u_i, v_i).

    Evaluated from the surface's Taylor form (:attr:`BSplineSurface.taylor`), the
    quotient rule applied for a rational surface.

    Returns
    -------
    dict of ndarray, each shape (len(u), d)
    """
    u = np.asarray(u, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    require_in_domain(surface.u_space, u)
    require_in_domain(surface.v_space, v)
    return _derivatives_in_domain(surface, u, v, order)


def _derivatives_in_domain(surface, u, v, order):
    """:func:`surface_derivatives` at 1-d float parameters known to lie in the domain (the
    clamped iterates of :func:`closest_points_surface`): no check."""
    from math import comb

    h = surface.taylor.derivatives_in_domain(u, v, order)
    if not surface.is_rational:
        return h
    w = {key: val[:, -1:] for key, val in h.items()}
    out = {}
    for a, b in h:
        val = h[(a, b)][:, :-1].copy()
        for i in range(a + 1):
            for j in range(b + 1):
                if i or j:
                    val -= comb(a, i) * comb(b, j) * w[(i, j)] * out[(a - i, b - j)]
        out[(a, b)] = val / w[(0, 0)]
    return out


# -- closest points ---------------------------------------------------------------------------
def closest_points_curve(curve, points, u0, iterations=30, stop_below=None):
    r"""Foot points on ``curve`` of ``points`` by damped, clamped Newton iterations.

    Solves :math:`f(t) = C'(t)\cdot(C(t) - P) = 0` with
    :math:`f' = |C'|^2 + C''\cdot(C - P)` (a gradient step when :math:`f' \le 0`),
    clamping ``t`` to the domain and halving a step until the distance decreases, so
    the distance never grows from the start.  A point has converged once its step would
    move the foot point by less than ``STEP_FLOOR`` times the curve's size (the distance
    is then exact to far below any tolerance; iterating on costs only halvings).

    Parameters
    ----------
    curve : BSplineCurve
    points : ndarray, shape (q, d)
    u0 : ndarray, shape (q,)
        Start parameters (e.g. the nearest sample).
    stop_below : float, optional
        Stop iterating a point once its distance is at most this (a tolerance check
        needs no more: the distance to an actual curve point bounds the true one).

    Returns
    -------
    t : ndarray, shape (q,)
    distance : ndarray, shape (q,)
        ``|C(t) - P|``, never below the exact distance to the curve.
    """
    points = np.asarray(points, dtype=float)
    lo, hi = curve.domain
    t = np.clip(np.asarray(u0, dtype=float).copy(), lo, hi)
    dist = _distance(curve_derivatives(curve, t, 0)[0], points)
    active = np.arange(t.size)
    size = curve.size
    for _ in range(iterations):
        active = _above(active, dist, stop_below)
        if active.size == 0:
            break
        c, c1, c2 = curve_derivatives(curve, t[active], 2)
        r = c - points[active]
        f = np.einsum("qd,qd->q", c1, r)
        speed2 = np.maximum(np.einsum("qd,qd->q", c1, c1), 1e-300)
        fp = speed2 + np.einsum("qd,qd->q", c2, r)
        step = -f / np.where(fp > 1e-12 * speed2, fp, speed2)
        step = np.where(((t[active] <= lo) & (step < 0)) | ((t[active] >= hi) & (step > 0)), 0.0, step)
        big = (np.abs(step) > 1e-13 * (hi - lo)) & (np.abs(step) * np.sqrt(speed2) > STEP_FLOOR * size)
        active, step = active[big], step[big]
        if active.size == 0:
            break

        def trial(idx, s):
            new = np.clip(t[idx] + s, lo, hi)
            return new, _distance(curve_derivatives(curve, new, 0)[0], points[idx])

        new, d_new = _damped(trial, active, step, dist)
        moved = (d_new < dist[active]) & (np.abs(new - t[active]) > 1e-13 * (hi - lo))
        t[active[moved]], dist[active[moved]] = new[moved], d_new[moved]
        active = active[moved]
    return t, dist


def _distance(a, b):
    """Euclidean distance along the last axis (an einsum: 4x faster than ``np.linalg.norm``
    on the million-sample grids of a tolerance check)."""
    d = a - b
    return np.sqrt(np.einsum("...k,...k->...", d, d))


def _above(active, dist, stop_below):
    """The ``active`` points whose distance still exceeds ``stop_below`` (all if ``None``)."""
    return active if stop_below is None else active[dist[active] > stop_below]


def _closest_from_starts(curve, points, sample_u, tree, same_u, starts=3, tol=None):
    """Smallest Newton distance from the same parameter and the ``starts`` nearest samples.

    Three starts, not two: the two nearest samples of a wavy faired curve can lie on one
    lobe, and Newton from both ends in the same local minimum (a seed-like curve of 53
    poles projected onto 23: 0.0518 against the true 0.0476).

    With ``tol`` the other starts are tried only where the first distance exceeds it,
    and every Newton iteration stops once below it.
    """
    best = closest_points_curve(curve, points, same_u, stop_below=tol)[1]
    todo = np.flatnonzero(best > tol) if tol is not None else np.arange(best.size)
    if todo.size == 0:
        return best
    _, near = tree.query(points[todo], k=min(starts, sample_u.size))
    near = near.reshape(todo.size, -1)
    for column in near.T:
        best[todo] = np.minimum(best[todo], closest_points_curve(
            curve, points[todo], sample_u[column], stop_below=tol)[1])
    return best


def _damped(trial, active, step, dist, halvings=HALVINGS):
    """Halve steps until the distance does not grow; returns the last trial per point.

    Only the points whose distance grew pay for a halving.  A Newton step can overshoot
    by far more than 2^5: on a fillet whose u domain is 6e-4 long (``|S_u|`` about 2e3,
    ``|S_v|`` about 2), the first step from a point 0.08 off was twice the u domain, and
    the point stopped there, 30 times its true distance (0.0024) away."""
    new, d_new = trial(active, step)
    for _ in range(halvings):
        worse = d_new > dist[active]
        if not worse.any():
            break
        step = np.where(worse.reshape((-1,) + (1,) * (step.ndim - 1)), 0.5 * step, step)
        sel = np.flatnonzero(worse)
        n2, d2 = trial(active[sel], step[sel])
        new[sel], d_new[sel] = n2, d2
    return new, d_new


def closest_points_surface(surface, points, u0, v0, iterations=30, stop_below=None,
                           bounds=None):
    r"""Foot points on ``surface`` by damped, clamped 2x2 Newton iterations.

    Solves :math:`g = (S_u\cdot r,\ S_v\cdot r) = 0`, :math:`r = S(u, v) - P`, with the
    Hessian :math:`H = J^T J + [S_{uu}\cdot r,\ S_{uv}\cdot r;\ S_{uv}\cdot r,\ S_{vv}\cdot r]`
    (Gauss-Newton :math:`J^T J` when :math:`H` is not positive definite), clamping to the
    domain and halving steps until the distance decreases.  With ``stop_below`` a point
    stops once its distance is at most that value; it has converged once its step would
    move the foot point by less than ``STEP_FLOOR`` times the surface's size (as
    :func:`closest_points_curve`).  ``bounds`` ``((u0, u1), (v0, v1))`` inside the
    domain restricts the foot points to that parameter box (a face's UV box); default
    the whole domain.

    Returns
    -------
    u, v, distance : ndarray, shape (q,)
        ``distance`` is that of an actual surface point: never below the exact one.
    """
    points = np.asarray(points, dtype=float)
    (ulo, uhi), (vlo, vhi) = surface.domain if bounds is None else bounds
    uv = np.stack([np.clip(np.asarray(u0, dtype=float), ulo, uhi),
                   np.clip(np.asarray(v0, dtype=float), vlo, vhi)], axis=1)
    dist = _distance(_derivatives_in_domain(surface, uv[:, 0], uv[:, 1], 0)[(0, 0)], points)
    active = np.arange(dist.size)
    scale = max(uhi - ulo, vhi - vlo)
    size = surface.size
    for _ in range(iterations):
        active = _above(active, dist, stop_below)
        if active.size == 0:
            break
        s = _derivatives_in_domain(surface, uv[active, 0], uv[active, 1], 2)
        step, moves = _newton_step(s, s[(0, 0)] - points[active], uv[active],
                                   ((ulo, uhi), (vlo, vhi)))
        big = (np.abs(step).sum(axis=1) > 1e-13 * scale) & (moves > (STEP_FLOOR * size) ** 2)
        active, step = active[big], step[big]
        if active.size == 0:
            break

        def trial(idx, st):
            new = uv[idx] + st
            new[:, 0] = np.clip(new[:, 0], ulo, uhi)
            new[:, 1] = np.clip(new[:, 1], vlo, vhi)
            pts = _derivatives_in_domain(surface, new[:, 0], new[:, 1], 0)[(0, 0)]
            return new, _distance(pts, points[idx])

        new, d_new = _damped(trial, active, step, dist)
        moved = (d_new < dist[active]) & (np.abs(new - uv[active]).sum(axis=1) > 1e-13 * scale)
        uv[active[moved]], dist[active[moved]] = new[moved], d_new[moved]
        active = active[moved]
    return uv[:, 0], uv[:, 1], dist


def closest_points_surface_restarted(surface, points, u0, v0, per_span=4, max_samples=257,
                                     starts=2):
    r"""Foot points by :func:`closest_points_surface` from ``(u0, v0)``, restarted from
    the nearest coarse samples of the surface that lie elsewhere.

    The coarse samples are ``per_span`` per knot span and direction (one per span where
    that would exceed ``max_samples`` per direction; ends and breakpoints included), held
    in a ``cKDTree``.  Each of a point's ``starts`` nearest samples that is nearer than
    its foot point, or lies more than two samples away from it in parameters, is a new
    Newton start, and the nearest result is kept: Newton from the same parameter can
    stop at an extremum that is not the nearest (the IEA blade's airfoil face has points
    nearer to the other side of its closed trailing edge, where the samples at both ends
    of v coincide).  No distance returned exceeds the nearest coarse sample's, and each
    is that of an actual surface point: never below the exact one.

    Returns
    -------
    u, v, distance : ndarray, shape (q,)
    """
    points = np.asarray(points, dtype=float)
    u, v, dist = closest_points_surface(surface, points, u0, v0)
    axes = []
    for space in (surface.u_space, surface.v_space):
        x = sample_parameters(space, per_span=per_span)
        axes.append(x if x.size <= max_samples else sample_parameters(space, per_span=1))
    grid = surface.evaluate_grid(*axes).reshape(-1, points.shape[1])
    near, index = cKDTree(grid).query(points, k=min(starts, grid.shape[0]))
    for column in range(near.shape[1] if near.ndim == 2 else 1):
        d0, k = (near[:, column], index[:, column]) if near.ndim == 2 else (near, index)
        i, j = np.unravel_index(k, (axes[0].size, axes[1].size))
        elsewhere = ((np.abs(np.searchsorted(axes[0], u) - i) > 2)
                     | (np.abs(np.searchsorted(axes[1], v) - j) > 2))
        again = np.flatnonzero((d0 < dist) | elsewhere)
        if again.size == 0:
            continue
        u2, v2, d2 = closest_points_surface(surface, points[again], axes[0][i[again]],
                                            axes[1][j[again]])
        better = d2 < dist[again]
        take = again[better]
        u[take], v[take], dist[take] = u2[better], v2[better], d2[better]
    return u, v, dist


def _newton_step(s, r, uv, bounds):
    """Newton step of :func:`closest_points_surface` at derivatives ``s`` and residuals
    ``r`` (Gauss-Newton where the Hessian is not positive definite), held at the borders
    (:func:`_border_step`), and the squared length of the foot point's move, computed
    from the step capped at a thousand domain widths (a collapsed surface, S_u = 0, has
    steps whose squares would overflow; any such step counts as a move)."""
    su, sv = s[(1, 0)], s[(0, 1)]
    g1, g2 = np.einsum("qd,qd->q", su, r), np.einsum("qd,qd->q", sv, r)
    a = np.einsum("qd,qd->q", su, su)
    b = np.einsum("qd,qd->q", su, sv)
    c = np.einsum("qd,qd->q", sv, sv)
    ha = a + np.einsum("qd,qd->q", s[(2, 0)], r)
    hb = b + np.einsum("qd,qd->q", s[(1, 1)], r)
    hc = c + np.einsum("qd,qd->q", s[(0, 2)], r)
    det = ha * hc - hb * hb
    bad = (det <= 1e-12 * (a * c + 1e-300)) | (ha <= 0)
    ha, hb, hc = np.where(bad, a, ha), np.where(bad, b, hb), np.where(bad, c, hc)
    det = ha * hc - hb * hb
    det = np.where(np.abs(det) > 1e-300, det, 1e-300)
    step = np.stack([-(hc * g1 - hb * g2) / det, -(ha * g2 - hb * g1) / det], axis=1)
    step = _border_step(step, uv, (g1, g2), (ha, hc), bounds)
    limit = 1e3 * max(high - low for low, high in bounds)
    s0, s1 = np.clip(step[:, 0], -limit, limit), np.clip(step[:, 1], -limit, limit)
    moves = a * s0 ** 2 + 2 * b * s0 * s1 + c * s1 ** 2
    return step, moves


def _border_step(step, uv, gradient, curvature, bounds):
    r"""The Newton ``step`` of foot points ``uv`` with the domain's borders as constraints.

    A parameter on a border whose 2-D step leaves the domain is held there, and the
    other one takes the 1-D Newton step :math:`-g_i / h_{ii}` along that border.  At a
    corner the 2-D step can point out of both borders while the minimum lies along one
    of them (the coupling :math:`h_{uv}` turns the step): each 1-D step that points
    inward is then a candidate, and the one with the larger predicted decrease
    :math:`g_i^2 / h_{ii}` is taken (IEA blade face 2: the corner at 0.2951, the border
    minimum 0.0246 along it at 0.2937).
    """
    (g1, g2), (ha, hc) = gradient, curvature
    (ulo, uhi), (vlo, vhi) = bounds
    low, high = np.array([ulo, vlo]), np.array([uhi, vhi])
    leaves = ((uv <= low) & (step < 0)) | ((uv >= high) & (step > 0))
    if not leaves.any():
        return step
    lu, lv = leaves[:, 0], leaves[:, 1]
    along_u = -g1 / np.maximum(ha, 1e-300)
    along_v = -g2 / np.maximum(hc, 1e-300)
    out = np.stack([np.where(lu, 0.0, np.where(lv, along_u, step[:, 0])),
                    np.where(lv, 0.0, np.where(lu, along_v, step[:, 1]))], axis=1)
    corner = np.flatnonzero(lu & lv)
    if corner.size:
        out[corner] = _corner_step(uv[corner], along_u[corner], along_v[corner],
                                   g1[corner], g2[corner], bounds)
    return out


def _corner_step(uv, along_u, along_v, g1, g2, bounds):
    """Steps at corners where the 2-D step leaves both borders: the inward 1-D step with
    the larger predicted decrease :math:`g_i^2 / h_{ii} = -g_i s_i`, else none."""
    inward_u = ~_leaves(uv[:, 0], along_u, bounds[0])
    inward_v = ~_leaves(uv[:, 1], along_v, bounds[1])
    take_u = inward_u & (~inward_v | (-g1 * along_u >= -g2 * along_v))
    take_v = inward_v & ~take_u
    return np.stack([np.where(take_u, along_u, 0.0), np.where(take_v, along_v, 0.0)], axis=1)


def _leaves(x, step, bounds):
    """True where a parameter on a border of ``bounds`` would step out of it."""
    low, high = bounds
    return ((x <= low) & (step < 0)) | ((x >= high) & (step > 0))


# -- results ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Deviation:
    """Summary of the deviation between two geometries at dense samples.

    Attributes
    ----------
    max, mean, rms : float
        Over the samples of the source (``mean``/``rms``) and both directions (``max``).
    location : tuple of float
        Parameter ``(u,)`` or ``(u, v)`` of the sample where the maximum occurs.
    point : ndarray, shape (d,)
        The geometry point at ``location`` from which the maximum distance is measured.
    method : {"geometric", "parametric"}
    n_samples : int
    """

    max: float
    mean: float
    rms: float
    location: tuple
    point: np.ndarray
    method: str
    n_samples: int


@dataclass(frozen=True)
class DeviationMap:
    r"""Per-sample deviation of a faired geometry from its source, ready for viewers.

    Attributes
    ----------
    parameters : tuple of ndarray
        ``(u,)`` for curves, ``(u, v)`` for surfaces (the sample grid axes).
    points : ndarray, shape (N, d) or (Nu, Nv, d)
        Source points at the samples.
    values : ndarray, shape (N,) or (Nu, Nv)
        Distance from each source point to the faired geometry (``method``).
    signed : ndarray, same shape as ``values``
        ``values`` with the sign of :math:`(F - S)\cdot n`, ``n`` the source's unit
        normal (surfaces) or principal normal (curves; 0 where the curvature vanishes).
    method : {"geometric", "parametric"}
    """

    parameters: tuple
    points: np.ndarray
    values: np.ndarray
    signed: np.ndarray
    method: str

    @property
    def max(self):
        return float(self.values.max())

    @property
    def mean(self):
        return float(self.values.mean())

    @property
    def rms(self):
        return float(np.sqrt(np.mean(self.values ** 2)))


# -- probes: cached source samples, fast maxima --------------------------------------------------
class CurveProbe:
    """Dense samples of a source curve, reused to measure many faired candidates.

    Parameters
    ----------
    source : BSplineCurve
    per_span : int
        Samples per span of the merged breakpoints of the source and each candidate.
    method : {"geometric", "parametric"}
    u : ndarray, optional
        Explicit, fixed sample parameters (overrides ``per_span``).
    """

    def __init__(self, source, per_span=8, method="geometric", u=None):
        _check_method(method)
        self.source = source
        self.method = method
        self.per_span = per_span
        self._fixed = u is not None
        self._set_samples(sample_parameters(source.space, per_span=per_span) if u is None else u)

    def _set_samples(self, u):
        self.u = u
        self.points = curve_derivatives(self.source, u, 0)[0]
        self._tree = None

    def _adapt(self, faired):
        """Use ``per_span`` samples per span of the merged breakpoints of both curves."""
        if self._fixed:
            return
        u = sample_parameters(self.source.space, faired.space, per_span=self.per_span)
        if u.size != self.u.size or not np.array_equal(u, self.u):
            self._set_samples(u)

    @property
    def tree(self):
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree

    def bound(self, faired):
        """Faired points and the same-parameter distance at every sample."""
        other = curve_derivatives(faired, self.u, 0)[0]
        return other, _distance(other, self.points)

    def true_distance(self, faired, other, idx, tol=None):
        """Two-sided true distance at samples ``idx`` (max of both directions).

        With ``tol``, extra Newton starts are only tried where the first exceeds ``tol``,
        and values ``<= tol`` are upper bounds (the iterations stop there).
        """
        if idx.size == 0:
            return np.zeros(0)
        d_fs = _closest_from_starts(faired, self.points[idx], self.u, cKDTree(other),
                                    self.u[idx], tol=tol)
        d_sf = _closest_from_starts(self.source, other[idx], self.u, self.tree, self.u[idx],
                                    tol=tol)
        return np.maximum(d_fs, d_sf)

    def max_deviation(self, faired, tol=None):
        """Largest deviation (dense samples); with ``tol`` stop once it is exceeded.

        Returns
        -------
        value : float
            The maximum; with ``tol`` and a miss, a value ``> tol`` that is a lower bound.
        index : int
            Sample index where it occurs.
        """
        self._adapt(faired)
        other, bound = self.bound(faired)
        bound = _FlatBound(bound)
        if self.method == "parametric":
            return bound.argmax()
        return _pruned_max(bound, lambda idx, below: self.true_distance(faired, other, idx, below),
                           tol)


def box_region(box):
    """The ``region`` of a parameter box ``(u0, u1, v0, v1)``: the samples inside it,
    its borders included."""
    u0, u1, v0, v1 = box
    return lambda u, v: np.outer((u >= u0) & (u <= u1), (v >= v0) & (v <= v1))


def _region_mask(region, u, v):
    """``region(u, v)`` checked: a boolean array of shape (len(u), len(v))."""
    mask = np.asarray(region(u, v))
    if mask.shape != (u.size, v.size) or mask.dtype != bool:
        raise InvalidInputError(
            f"region(u, v) must return a boolean array of shape ({u.size}, {v.size}) "
            f"(one flag per sample), got {mask.dtype} of shape {mask.shape}; fix the "
            "region callable.")
    return mask


class SurfaceProbe:
    """Dense grid samples of a source surface, reused to measure many candidates.

    Parameters
    ----------
    source : BSplineSurface
    per_span : int
    method : {"geometric", "parametric"}
    uv : (ndarray, ndarray), optional
        Explicit grid axes (override ``per_span``).
    keep_feet : bool
        Keep each sample's last foot parameters, the Newton starts of the next candidate
        (a search that measures many nearby candidates on the same grid).
    bounds : ((u0, u1), (v0, v1)), optional
        Parameter box of both geometries that the foot points stay in (a face's UV box,
        with ``uv`` sampled inside it); default the source's whole domain.
    region : callable, optional
        ``region(u, v) -> bool array (len(u), len(v))``: the samples whose deviation
        counts (a trimmed face's domain); the others count as 0, so a candidate is
        measured, and its error spread, only where the face is.  Default: everywhere.
    hold_grid : bool
        Keep the source's grid points and each candidate's in full (the adaptive search's
        probe, capped at 400k samples, whose path depends on the rounding of those
        grids).  Without, a measurement walks the grid in blocks of rows and evaluates
        points only where the exact distance is needed (:class:`_LazyGrid`): a check of
        a million-sample grid then holds a few MB instead of about 90, and the uniform
        search on the 400 x 400 blade (10 million samples per check) peaks at 214 MB
        instead of 1151 MB.
    """

    def __init__(self, source, per_span=8, method="geometric", uv=None, keep_feet=False,
                 hold_grid=True, bounds=None, region=None):
        _check_method(method)
        self.source = source
        self.bounds = bounds
        self.region = region
        self.method = method
        self.per_span = per_span
        self.keep_feet = keep_feet
        self.hold_grid = hold_grid
        self._prior = None
        self._fixed = uv is not None
        if uv is None:
            uv = within_box(sample_parameters(source.u_space, per_span=per_span),
                            sample_parameters(source.v_space, per_span=per_span), bounds)
        self._set_samples(*uv)

    def _set_samples(self, u, v):
        self.u, self.v = u, v
        self.points = (self.source.evaluate_grid(u, v) if self.hold_grid
                       else _LazyGrid(self.source, u, v))
        self._half_step = (0.5 * np.gradient(u), 0.5 * np.gradient(v))
        self._outside = None if self.region is None else ~_region_mask(self.region, u, v)
        self._feet = {}
        self._source_blocks = None
        self._collocations = {}

    def _keep(self, key, i, j, u, v):
        """Remember the feet ``(u, v)`` of samples ``(i, j)`` on the ``"source"`` or on
        the ``"faired"`` geometry (``keep_feet`` only; the grid's own parameters elsewhere)."""
        if not self.keep_feet:
            return
        if key not in self._feet:
            self._feet[key] = np.stack(np.meshgrid(self.u, self.v, indexing="ij"), axis=-1)
        self._feet[key][i, j] = np.stack([u, v], axis=-1)

    def _last_feet(self, key, i, j):
        """Foot parameters last found at samples ``(i, j)``: this probe's own, else those
        of an adopted probe (:meth:`adopt_feet`) interpolated bilinearly; ``None`` if
        neither.  Successive candidates of a search differ little, so their feet are
        Newton starts that converge at once even where a candidate slides along the
        source (its same-parameter point is far from the foot)."""
        if key in self._feet:
            return self._feet[key][i, j, 0], self._feet[key][i, j, 1]
        prior = self._prior
        if prior is not None and key in prior._feet:
            return _bilinear(prior.u, prior.v, prior._feet[key], self.u[i], self.v[j])
        return None

    def _adapt(self, faired):
        """Use ``per_span`` samples per span of the merged breakpoints, per direction."""
        if self._fixed:
            return
        u, v = within_box(
            sample_parameters(self.source.u_space, faired.u_space, per_span=self.per_span),
            sample_parameters(self.source.v_space, faired.v_space, per_span=self.per_span),
            self.bounds)
        if (u.size, v.size) != (self.u.size, self.v.size) or not (
                np.array_equal(u, self.u) and np.array_equal(v, self.v)):
            self._set_samples(u, v)

    def adopt_feet(self, other):
        """Start from the feet that ``other`` (a probe of the same source on another grid)
        found last, interpolated bilinearly at each sample when it is measured: a dense
        check after a search on a coarser grid."""
        self._prior = other

    def bound(self, faired):
        """Faired points on the grid (a :class:`_LazyGrid` without ``hold_grid``) and the
        same-parameter distance at every sample, shape (len(u), len(v)); 0 outside the
        ``region``, whose samples are then never measured further."""
        if not self.hold_grid:
            blocks = self._bound_blocks(faired)
            return _LazyGrid(faired, self.u, self.v), np.concatenate(
                [blocks.block(b) for b in range(blocks.n_blocks)])
        other = self._grid_of(faired)
        bound = _distance(other, self.points)
        if self._outside is not None:
            bound[self._outside] = 0.0
        return other, bound

    def _grid_of(self, faired):
        """``faired.evaluate_grid(u, v)``, the same values, with the collocation matrices
        kept per space (at most ``COLLOCATIONS``): the adaptive search measures about
        three candidates per distinct target space."""
        if faired.is_rational:
            return faired.evaluate_grid(self.u, self.v)
        return grid_product(self._collocation(0, faired.u_space),
                            self._collocation(1, faired.v_space), faired.poles)

    def _collocation(self, axis, space):
        """Collocation matrix of ``space`` at this grid's ``axis`` parameters, kept."""
        key = (axis, space.key)
        if key not in self._collocations:
            if len(self._collocations) >= COLLOCATIONS:
                self._collocations.clear()
            self._collocations[key] = space.collocation((self.u, self.v)[axis])
        return self._collocations[key]

    def _bound_blocks(self, faired):
        """:class:`_BoundBlocks` of ``faired`` on this grid, about ``BLOCK_SAMPLES`` per
        block."""
        step = max(1, BLOCK_SAMPLES // self.v.size)
        if self._source_blocks is None or self._source_blocks.step != step:
            self._source_blocks = self.source.grid_blocks(self.u, self.v, step)
        return _BoundBlocks(self._source_blocks, faired.grid_blocks(self.u, self.v, step),
                            self._outside)

    def true_distance(self, faired, other, flat_idx, window=2, tol=None, verdict=False):
        """Two-sided true distance at flat grid indices ``flat_idx``.

        With ``tol``, the second Newton start is only tried where the first exceeds
        ``tol``, and values ``<= tol`` are upper bounds (the iterations stop there).
        With ``verdict`` (and ``tol``) the distance from the faired points back to the
        source is only measured where the source's distance to the faired surface is
        within ``tol``: a value above ``tol`` is then one direction's, enough to refuse
        the candidate.
        """
        if flat_idx.size == 0:
            return np.zeros(0)
        if self._outside is not None and self._outside.ravel()[flat_idx].any():
            return self._inside_only(faired, other, flat_idx, window, tol, verdict)
        shape = self.points.shape[:2]
        i, j = np.unravel_index(flat_idx, shape)
        d_fs = self._one_way(faired, self.points, other, i, j, window, tol)
        if not verdict:
            return np.maximum(d_fs, self._one_way(self.source, other, self.points, i, j,
                                                  window, tol))
        back = d_fs <= tol
        if back.any():
            d_fs[back] = np.maximum(d_fs[back], self._one_way(
                self.source, other, self.points, i[back], j[back], window, tol))
        return d_fs

    def _inside_only(self, faired, other, flat_idx, window, tol, verdict):
        """:meth:`true_distance` with 0 at the samples outside the ``region``, which count
        as 0 everywhere (a maximum that asks for the largest bound of every row, as
        ``_pruned_max`` does on a grid of at most 64 rows, asks for rows wholly outside
        too)."""
        inside = ~self._outside.ravel()[flat_idx]
        distance = np.zeros(flat_idx.size)
        distance[inside] = self.true_distance(faired, other, flat_idx[inside], window, tol,
                                              verdict)
        return distance

    def _one_way(self, target, here, there, i, j, window, tol=None):
        """Distance from ``here[i, j]`` to ``target`` (sampled as ``there`` on the grid).

        A sample whose same-parameter distance is within ``tol`` needs no search.  Newton
        starts from the same parameter, or from the last foot (:meth:`_last_feet`) where
        that lies more than half a sample spacing away (the candidate slides along the
        source); where the result stays above ``tol`` it starts again from the nearest
        ``there`` sample within ``window`` (with ``tol`` and ``window`` 0, it does not).
        """
        key = "source" if target is self.source else "faired"
        p = here[i, j]
        u0, v0 = self.u[i], self.v[j]
        last = self._last_feet(key, i, j)
        if last is not None:
            lu, lv = last
            slid = (np.abs(lu - u0) > self._half_step[0][i]) | \
                (np.abs(lv - v0) > self._half_step[1][j])
            u0, v0 = np.where(slid, lu, u0), np.where(slid, lv, v0)
        if tol is None:
            u0, v0, d = self._from_both_starts(target, here, there, p, i, j, u0, v0, window)
            self._keep(key, i, j, u0, v0)
            return d
        d = _distance(there[i, j], p)
        todo = np.flatnonzero(d > tol)
        if todo.size:
            u0[todo], v0[todo], d[todo] = closest_points_surface(
                target, p[todo], u0[todo], v0[todo], stop_below=tol, bounds=self.bounds)
            todo = todo[d[todo] > tol]
        if todo.size and window:
            wu, wv = _window_start(here, there, i[todo], j[todo], self.u, self.v, window)
            fu, fv, fd = closest_points_surface(target, p[todo], wu, wv, stop_below=tol,
                                                bounds=self.bounds)
            better = fd < d[todo]
            k = todo[better]
            u0[k], v0[k], d[k] = fu[better], fv[better], fd[better]
        self._keep(key, i, j, u0, v0)
        return d

    def _from_both_starts(self, target, here, there, p, i, j, u0, v0, window):
        """Feet and distances of ``p`` on ``target`` from both starts (``(u0, v0)`` and the
        nearest ``there`` sample within ``window``), the smaller distance kept (the first
        start's on ties).  One Newton run over both sets of starts: each point iterates
        on its own, so the values are those of two runs (to rounding: the vector kernels
        may round a point's last bit differently in another batch), in half the vector
        operations' calls (which is what a few hundred points cost)."""
        wu, wv = _window_start(here, there, i, j, self.u, self.v, window)
        n = p.shape[0]
        fu, fv, fd = closest_points_surface(target, np.concatenate([p, p]),
                                            np.concatenate([u0, wu]), np.concatenate([v0, wv]),
                                            bounds=self.bounds)
        pick = np.where(fd[n:] < fd[:n], np.arange(n, 2 * n), np.arange(n))
        return fu[pick], fv[pick], fd[pick]

    def max_deviation(self, faired, tol=None, stride=4):
        """As :meth:`CurveProbe.max_deviation`; the index is flat over the grid.

        With ``tol``, every ``stride``-th sample per direction is checked first: a miss
        there is a miss of the dense grid (same samples), found at 1/stride^2 the cost.
        """
        if tol is not None and stride > 1 and min(self.points.shape[:2]) > 4 * stride:
            self._adapt(faired)
            sub = SurfaceProbe(self.source, method=self.method,
                               uv=(self.u[::stride], self.v[::stride]), region=self.region)
            value, k = sub.max_deviation(faired, tol, stride=1)
            if value > tol:
                i, j = np.unravel_index(k, sub.points.shape[:2])
                return value, int(np.ravel_multi_index((i * stride, j * stride),
                                                       self.points.shape[:2]))
        self._adapt(faired)
        if self.hold_grid:
            other, bound = self.bound(faired)
            bound = _FlatBound(bound.ravel())
        else:
            other = _LazyGrid(faired, self.u, self.v)
            bound = _RowBound(self._bound_blocks(faired), self.v.size,
                              None if self.method == "parametric" else tol)
        if self.method == "parametric":
            return bound.argmax()
        return _pruned_max(bound, lambda idx, below: self.true_distance(faired, other, idx,
                                                                         tol=below), tol)


class _LazyGrid:
    """The points of ``surface`` on the grid ``u x v``, evaluated only where indexed:
    ``grid[i, j]`` with index arrays gives shape (len(i), d).  A tolerance check needs
    the exact distance at a few hundred of a million samples (and their neighbours)."""

    def __init__(self, surface, u, v):
        self.surface, self.u, self.v = surface, u, v
        self.shape = (u.size, v.size, surface.poles.shape[-1])

    def __getitem__(self, index):
        i, j = index
        return _derivatives_in_domain(self.surface, self.u[i], self.v[j], 0)[(0, 0)]


class _FlatBound:
    """The same-parameter bound of every sample, held in full (flat sample index)."""

    def __init__(self, values):
        self.values = values
        self.size = values.size

    def argmax(self):
        """``(largest bound, its flat index)``, the first one on ties."""
        k = int(np.argmax(self.values))
        return float(self.values[k]), k

    def leaders(self, k):
        """Flat indices of ``k`` samples of large bound: here the ``k`` largest (any
        ``k`` of them on ties)."""
        return np.argpartition(self.values, -k)[-k:]

    def above(self, threshold):
        """``(flat indices, bounds)`` of the samples whose bound exceeds ``threshold``,
        indices ascending."""
        idx = np.flatnonzero(self.values > threshold)
        return idx, self.values[idx]


class _BoundBlocks:
    """The same-parameter distance of a faired surface from its source on a grid, a block
    of rows at a time (two :class:`~cq_fairing.core.geometry.GridBlocks` with the same
    grid and ``step``)."""

    def __init__(self, source, faired, outside=None):
        self._source, self._faired, self._outside = source, faired, outside
        self.step, self.n_blocks, self.n_u = source.step, source.n_blocks, source.n_u
        self.rows_of = source.rows_of

    def block(self, b):
        """Shape (rows of block ``b``, n_v); 0 at the samples ``outside`` the region."""
        distance = _distance(self._faired.block(b), self._source.block(b))
        if self._outside is not None:
            distance[self._outside[self.rows_of(b)]] = 0.0
        return distance


class _RowBound:
    """The same-parameter bound on a grid, held as each row's maximum only.

    One pass over the blocks of rows keeps the maximum of each row and where it sits,
    and with ``tol`` the samples above ``tol`` (those a tolerance check can ask for).
    Any other samples asked for are recomputed with their whole blocks, which give the
    same values bit for bit (:class:`~cq_fairing.core.geometry.GridBlocks`).  A final
    check then holds no grid-sized array and runs no partition over one (85 MB and
    10.7 million samples on the terrain; the 400 x 400 blade's uniform search peaks at
    147 MB instead of 225 MB).

    Parameters
    ----------
    blocks : _BoundBlocks
    n_v : int
        Samples per row.
    tol : float or None
    """

    def __init__(self, blocks, n_v, tol):
        self._blocks, self._n_v, self._tol = blocks, n_v, tol
        n_u = blocks.n_u
        self.size = n_u * n_v
        self.row_max, self._row_arg = np.empty(n_u), np.empty(n_u, dtype=np.intp)
        kept = []
        for b in range(blocks.n_blocks):
            rows = blocks.rows_of(b)
            block = blocks.block(b)
            self._row_arg[rows] = np.argmax(block, axis=1)
            self.row_max[rows] = block[np.arange(block.shape[0]), self._row_arg[rows]]
            if tol is not None:
                kept.append(self._flat_above(np.arange(rows.start, rows.stop), block, tol))
        if tol is not None:
            self._kept = tuple(np.concatenate(part) for part in zip(*kept))

    def _flat_above(self, index, block, threshold):
        i, j = np.nonzero(block > threshold)
        return index[i] * self._n_v + j, block[i, j]

    def argmax(self):
        i = int(np.argmax(self.row_max))
        return float(self.row_max[i]), i * self._n_v + int(self._row_arg[i])

    def leaders(self, k):
        """Flat indices of the largest bound of each of the ``k`` rows of largest maximum
        (all rows if fewer): the largest bound is among them, and no row is recomputed."""
        rows = np.argpartition(self.row_max, -min(k, self.row_max.size))[-k:]
        return rows * self._n_v + self._row_arg[rows]

    def above(self, threshold):
        if self._tol is not None and threshold >= self._tol:
            idx, values = self._kept
            keep = values > threshold
            return idx[keep], values[keep]
        return self._recomputed(np.flatnonzero(self.row_max > threshold), threshold)

    def _recomputed(self, rows, threshold):
        """``(flat indices, bounds)`` above ``threshold`` on ``rows`` (ascending), each
        recomputed with its block."""
        parts = []
        for b in np.unique(rows // self._blocks.step):
            start = self._blocks.rows_of(b).start
            picked = rows[rows // self._blocks.step == b]
            parts.append(self._flat_above(picked, self._blocks.block(b)[picked - start],
                                          threshold))
        if not parts:
            return np.zeros(0, dtype=np.intp), np.zeros(0)
        return tuple(np.concatenate(part) for part in zip(*parts))


def _pruned_max(bound, exact, tol):
    """Max of the true distance over all samples, computing it only where ``bound`` can win.

    ``bound`` (:class:`_FlatBound` or :class:`_RowBound`) is ``>= exact`` sample-wise.
    ``exact(idx, below)`` returns the true distance at samples ``idx`` where it exceeds
    ``below`` and an upper bound ``<= below`` elsewhere (its Newton iterations stop
    there); ``below=None`` asks for every value exactly.  Candidates (bound above the
    tolerance, or above the largest true distance at 64 samples of large bound,
    ``bound.leaders(64)``) are processed in
    decreasing order of the bound, in doubling batches, each with ``below`` the running
    maximum (a sample that cannot beat it needs no exact value), until the next bound
    cannot beat the running maximum.  Without ``tol`` the exact maximum is returned.
    With ``tol`` the search also stops as soon as the maximum exceeds ``tol`` (the value
    returned is then an exact sample distance ``> tol``, a lower bound of the maximum)
    or once no remaining bound exceeds ``tol`` (the value returned is then an upper
    bound ``<= tol``).
    """
    best, best_i = -1.0, bound.argmax()[1]
    if tol is not None:
        candidates, values = bound.above(tol)
        if candidates.size == 0:
            return bound.argmax()
    else:
        top = bound.leaders(min(64, bound.size))
        d = exact(top, None)
        k = int(np.argmax(d))
        best, best_i = float(d[k]), int(top[k])
        candidates, values = bound.above(best)
        keep = ~np.isin(candidates, top)
        candidates, values = candidates[keep], values[keep]
    by_bound = np.argsort(values)[::-1]
    order, values = candidates[by_bound], values[by_bound]
    start, batch = 0, 256
    while start < order.size:
        next_bound = float(values[start])
        if next_bound <= best:
            break
        if tol is not None and next_bound <= tol:
            return max(best, next_bound), best_i
        idx = order[start:start + batch]
        d = exact(idx, best if tol is None else max(best, tol))
        k = int(np.argmax(d))
        if d[k] > best:
            best, best_i = float(d[k]), int(idx[k])
        if tol is not None and best > tol:
            return best, best_i
        start += batch
        batch *= 2
    if tol is not None and best <= tol:
        rest = float(values[start]) if start < order.size else tol
        return max(best, min(rest, tol)), best_i
    return best, best_i


def _check_method(method):
    if method not in DEVIATIONS:
        raise InvalidInputError(
            f"deviation must be one of {DEVIATIONS}, got {method!r}."
        )
# -- public deviation ----------------------------------------------------------------------------
def _unwrap(source, faired):
    """Accept (source, faired) geometries or a fair result as ``source``."""
    if faired is None and hasattr(source, "source"):
        faired = source.curve if hasattr(source, "curve") else source.surface
        source = source.source
    if isinstance(source, BSplineCurve) and isinstance(faired, BSplineCurve):
        return source, faired, "curve"
    if isinstance(source, BSplineSurface) and isinstance(faired, BSplineSurface):
        return source, faired, "surface"
    raise InvalidInputError(
        "expected two BSplineCurve or two BSplineSurface objects (or one fair result), "
        f"got {type(source).__name__} and {type(faired).__name__}."
    )


def _check_domains(a, b):
    da = np.ravel(a.domain) if hasattr(a, "u_space") else np.array(a.domain)
    db = np.ravel(b.domain) if hasattr(b, "u_space") else np.array(b.domain)
    if np.abs(da - db).max() > 1e-12 * max(1.0, np.abs(da).max()):
        raise InvalidInputError(
            f"both geometries must share the parameter domain, got {tuple(da)} and {tuple(db)}."
        )


def deviation(source, faired=None, *, method="geometric", per_span=8):
    """Max, mean and RMS deviation of ``faired`` from ``source`` at dense samples.

    Parameters
    ----------
    source : BSplineCurve or BSplineSurface, or a FairResult / SurfaceFairResult
    faired : same kind as ``source`` (omit when ``source`` is a fair result)
    method : {"geometric", "parametric"}
        True (closest-point, two-sided) or same-parameter distance.
    per_span : int
        Samples per span of the merged breakpoints of both geometries.

    Returns
    -------
    Deviation
        ``max`` is the two-sided maximum (Hausdorff estimate for ``"geometric"``);
        ``mean`` and ``rms`` are over the distances from the source samples.
    """
    _check_method(method)
    source, faired, kind = _unwrap(source, faired)
    _check_domains(source, faired)
    dmap = deviation_map(source, faired, method=method, per_span=per_span)
    if kind == "curve":
        probe = CurveProbe(source, method=method, u=dmap.parameters[0])
        value, i = probe.max_deviation(faired)
        location = (float(probe.u[i]),)
        point = probe.points[i]
    else:
        probe = SurfaceProbe(source, method=method, uv=dmap.parameters)
        value, k = probe.max_deviation(faired)
        i, j = np.unravel_index(k, dmap.values.shape)
        location = (float(probe.u[i]), float(probe.v[j]))
        point = probe.points[i, j]
    value = max(value, dmap.max)
    return Deviation(value, dmap.mean, dmap.rms, location, np.array(point), method,
                     int(dmap.values.size))


def deviation_map(source, faired=None, *, method="geometric", per_span=8):
    """Per-sample distance from the source to the faired geometry (:class:`DeviationMap`).

    The sign is that of :math:`(F - S)\\cdot n` with ``n`` the unit normal of the source
    surface (principal normal of a curve).  See :func:`deviation` for the arguments.
    """
    _check_method(method)
    source, faired, kind = _unwrap(source, faired)
    _check_domains(source, faired)
    if kind == "curve":
        u = sample_parameters(source.space, faired.space, per_span=per_span)
        c = curve_derivatives(source, u, 2)
        other = curve_derivatives(faired, u, 0)[0]
        foot = other
        if method == "geometric":
            t, best = closest_points_curve(faired, c[0], u)
            _, near = cKDTree(other).query(c[0], k=min(3, u.size))
            for column in near.reshape(u.size, -1).T:
                t2, d2 = closest_points_curve(faired, c[0], u[column])
                t, best = np.where(d2 < best, t2, t), np.minimum(d2, best)
            foot = curve_derivatives(faired, t, 0)[0]
        normal = _principal_normal(c[1], c[2])
        values = np.linalg.norm(foot - c[0], axis=1)
        signed = values * np.sign(np.einsum("qd,qd->q", foot - c[0], normal))
        return DeviationMap((u,), c[0], values, signed, method)
    u = sample_parameters(source.u_space, faired.u_space, per_span=per_span)
    v = sample_parameters(source.v_space, faired.v_space, per_span=per_span)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    s = surface_derivatives(source, uu.ravel(), vv.ravel(), 1)
    pts = s[(0, 0)]
    foot = faired.evaluate_grid(u, v).reshape(-1, pts.shape[1])
    if method == "geometric":
        here = pts.reshape(u.size, v.size, -1)
        there = foot.reshape(u.size, v.size, -1)
        i, j = np.unravel_index(np.arange(pts.shape[0]), (u.size, v.size))
        fu, fv = _window_start(here, there, i, j, u, v)
        fu, fv, _ = closest_points_surface(faired, pts, fu, fv)
        foot = surface_derivatives(faired, fu, fv, 0)[(0, 0)]
    normal = _unit_normal(s[(1, 0)], s[(0, 1)])
    values = np.linalg.norm(foot - pts, axis=1)
    signed = values * np.sign(np.einsum("qd,qd->q", foot - pts, normal)) if normal is not None \
        else values.copy()
    shape = (u.size, v.size)
    return DeviationMap((u, v), pts.reshape(shape + (-1,)), values.reshape(shape),
                        signed.reshape(shape), method)


def _bilinear(x, y, values, xq, yq):
    """Bilinear interpolation of a grid ``values`` (n_x, n_y, 2) sampled at increasing
    ``x``, ``y``, at the points ``(xq, yq)`` (clamped to the grid): two arrays (q,)."""
    (a, wa), (b, wb) = _cell(x, xq), _cell(y, yq)
    wa, wb = wa[:, None], wb[:, None]
    out = ((1 - wa) * ((1 - wb) * values[a, b] + wb * values[a, b + 1])
           + wa * ((1 - wb) * values[a + 1, b] + wb * values[a + 1, b + 1]))
    return out[:, 0], out[:, 1]


def _cell(x, xq):
    """Index ``k`` of the cell ``[x_k, x_k+1]`` holding each ``xq`` and its weight there."""
    xq = np.clip(xq, x[0], x[-1])
    k = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
    return k, (xq - x[k]) / (x[k + 1] - x[k])


def _window_start(here, there, i, j, u, v, window=2):
    """Parameters of the nearest ``there`` sample within +-window of each (i, j) (the
    first of equals in row-major window order), all neighbours read in one indexing."""
    nu, nv = here.shape[:2]
    offsets = np.arange(-window, window + 1)
    ii = np.clip(i[:, None, None] + offsets[None, :, None], 0, nu - 1)
    jj = np.clip(j[:, None, None] + offsets[None, None, :], 0, nv - 1)
    ii, jj = (x.reshape(i.size, -1) for x in np.broadcast_arrays(ii, jj))
    near = there[ii.ravel(), jj.ravel()].reshape(ii.shape + (-1,))
    k = np.argmin(np.linalg.norm(near - here[i, j][:, None, :], axis=2), axis=1)
    rows = np.arange(i.size)
    return u[ii[rows, k]], v[jj[rows, k]]


def _principal_normal(d1, d2):
    """Unit principal normal (0 where the curvature vanishes); 2-D uses the left normal."""
    if d1.shape[1] == 2:
        n = np.stack([-d1[:, 1], d1[:, 0]], axis=1)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        return n
    t = d1 / np.maximum(np.linalg.norm(d1, axis=1, keepdims=True), 1e-300)
    n = d2 - np.einsum("qd,qd->q", d2, t)[:, None] * t
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    return np.where(norm > 1e-12 * np.maximum(np.linalg.norm(d2, axis=1, keepdims=True), 1e-300),
                    n / np.maximum(norm, 1e-300), 0.0)


def _unit_normal(su, sv):
    if su.shape[1] != 3:
        return None
    n = np.cross(su, sv)
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


# -- fairness -----------------------------------------------------------------------------------
def _as3(x):
    return x if x.shape[1] == 3 else np.hstack([x, np.zeros((x.shape[0], 3 - x.shape[1]))])


def curve_curvature(curve, u):
    r"""Curvature :math:`\kappa` and torsion :math:`\tau` at parameters ``u``.

    .. math:: \kappa = \frac{|C'\times C''|}{|C'|^3}, \qquad
              \tau = \frac{(C'\times C'')\cdot C'''}{|C'\times C''|^2}

    (``tau`` is 0 where ``kappa`` vanishes and for planar curves).

    Returns
    -------
    kappa, tau : ndarray, shape (len(u),)
    """
    d = curve_derivatives(curve, u, 3)
    d1, d2, d3 = (_as3(x) for x in d[1:4])
    cross = np.cross(d1, d2)
    cn2 = np.einsum("qd,qd->q", cross, cross)
    speed = np.linalg.norm(d1, axis=1)
    kappa = np.sqrt(cn2) / np.maximum(speed, 1e-300) ** 3
    small = cn2 <= 1e-24 * np.maximum(speed, 1e-300) ** 6
    tau = np.where(small, 0.0, np.einsum("qd,qd->q", cross, d3) / np.where(small, 1.0, cn2))
    return kappa, tau


def _curvature_rate(curve, u):
    r""":math:`d\kappa/dt` and the speed :math:`|C'|` at ``u``."""
    d = curve_derivatives(curve, u, 3)
    d1, d2, d3 = (_as3(x) for x in d[1:4])
    cross = np.cross(d1, d2)
    cn = np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
    speed = np.maximum(np.linalg.norm(d1, axis=1), 1e-300)
    dcross = np.cross(d1, d3)
    rate = (np.einsum("qd,qd->q", cross, dcross) / (cn * speed ** 3)
            - 3.0 * cn * np.einsum("qd,qd->q", d1, d2) / speed ** 5)
    return rate, speed


def curvature_derivative_energy(curve, points_per_span=8):
    r""":math:`\int (d\kappa/ds)^2\, ds = \int (d\kappa/dt)^2 / |C'|\, dt`.

    Gauss-Legendre with ``points_per_span`` nodes per knot span (the integrand is
    rational, so this is a quadrature, accurate to the rounding for smooth spans).
    """
    nodes, weights = quadrature_rule(curve.space.breakpoints, points_per_span)
    rate, speed = _curvature_rate(curve, nodes)
    return float(np.sum(weights * rate ** 2 / speed))


def surface_curvatures(surface, u, v):
    r"""Principal, mean and Gaussian curvature at points ``(u_i, v_i)``.

    With :math:`E, F, G` and :math:`L, M, N` the first and second fundamental forms,
    :math:`K = (LN - M^2)/(EG - F^2)`, :math:`H = (EN - 2FM + GL)/(2(EG - F^2))`,
    :math:`\kappa_{1,2} = H \pm \sqrt{H^2 - K}` (sign of the normal
    :math:`S_u\times S_v`).

    Returns
    -------
    dict with ``k1``, ``k2``, ``mean``, ``gaussian`` : ndarray, shape (len(u),)
    """
    s = surface_derivatives(surface, u, v, 2)
    su, sv = _as3(s[(1, 0)]), _as3(s[(0, 1)])
    n = np.cross(su, sv)
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    E, F, G = (np.einsum("qd,qd->q", a, b) for a, b in ((su, su), (su, sv), (sv, sv)))
    L, M, N = (np.einsum("qd,qd->q", _as3(s[key]), n) for key in ((2, 0), (1, 1), (0, 2)))
    det = np.maximum(E * G - F * F, 1e-300)
    K = (L * N - M * M) / det
    H = (E * N - 2 * F * M + G * L) / (2 * det)
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    return {"k1": H + root, "k2": H - root, "mean": H, "gaussian": K}


def bending_energy(geometry):
    r"""Exact bending energy of a polynomial curve or surface (Gram matrices of derivatives).

    Curve: :math:`\int|C''|^2 = \sum_d c_d^T G^{(2)} c_d`.  Surface:
    :math:`\sum_d \operatorname{tr}(P_d^T G^{(2)}_u P_d G^{(0)}_v) +
    2\operatorname{tr}(P_d^T G^{(1)}_u P_d G^{(1)}_v) +
    \operatorname{tr}(P_d^T G^{(0)}_u P_d G^{(2)}_v)` with :math:`G^{(\nu)}` the Gram
    matrices of :math:`\nu`-th derivatives.  Rational geometry is integrated by
    Gauss-Legendre quadrature instead (8 nodes per span and direction).
    """
    if isinstance(geometry, BSplineCurve):
        if geometry.is_rational:
            nodes, w = quadrature_rule(geometry.space.breakpoints, 8)
            d2 = curve_derivatives(geometry, nodes, 2)[2]
            return float(np.sum(w * np.einsum("qd,qd->q", d2, d2)))
        g = gram_matrix(geometry.space, nu=2)
        P = geometry.poles
        return float(np.sum(P * (g @ P)))
    if isinstance(geometry, BSplineSurface):
        if geometry.is_rational:
            return _rational_surface_energy(geometry)
        P = geometry.poles
        total = 0.0
        for a, b, w in ((2, 0, 1.0), (1, 1, 2.0), (0, 2, 1.0)):
            gu = gram_matrix(geometry.u_space, nu=a)
            gv = gram_matrix(geometry.v_space, nu=b)
            for d in range(P.shape[2]):
                X = P[:, :, d]
                total += w * float(np.sum(X * (gu @ (gv @ X.T).T)))
        return total
    raise InvalidInputError(f"expected a BSplineCurve or BSplineSurface, got {type(geometry).__name__}.")


def _rational_surface_energy(surface):
    nu_, wu = quadrature_rule(surface.u_space.breakpoints, 8)
    nv_, wv = quadrature_rule(surface.v_space.breakpoints, 8)
    uu, vv = np.meshgrid(nu_, nv_, indexing="ij")
    s = surface_derivatives(surface, uu.ravel(), vv.ravel(), 2)
    dens = sum(c * np.einsum("qd,qd->q", s[k], s[k]) for k, c in (((2, 0), 1), ((1, 1), 2), ((0, 2), 1)))
    return float(np.sum(dens.reshape(uu.shape) * wu[:, None] * wv[None, :]))


def count_sign_changes(values, threshold=0.0):
    """Number of sign changes along the last axis, ignoring ``|values| <= threshold``.

    Returns an int for 1-D input and the sum over rows otherwise.
    """
    x = np.atleast_2d(np.asarray(values, dtype=float))
    total = 0
    for row in x:
        s = np.sign(row[np.abs(row) > threshold])
        total += int(np.count_nonzero(s[1:] != s[:-1]))
    return total


def count_extrema(values, rel_threshold=1e-6):
    """Number of interior local extrema along the last axis (summed over rows).

    Steps smaller than ``rel_threshold`` times the row's range are ignored (rounding
    noise on flat stretches).
    """
    x = np.atleast_2d(np.asarray(values, dtype=float))
    total = 0
    for row in x:
        span = float(row.max() - row.min())
        total += count_sign_changes(np.diff(row), rel_threshold * span)
    return total


def curve_wiggles(curve, per_span=8, reference=None):
    r"""Curvature extrema and inflections of a curve at dense samples.

    Inflections count sign changes of :math:`(C'\times C'')\cdot b`, ``b`` the mean
    binormal (the signed curvature for planar curves).  Samples are ``per_span`` per
    span of ``reference`` (default the curve itself; pass the source to compare a
    faired curve on the same samples).

    Returns
    -------
    dict with ``curvature_extrema`` and ``inflections`` (int)
    """
    u = sample_parameters((reference or curve).space, per_span=per_span)
    kappa, _ = curve_curvature(curve, u)
    d = curve_derivatives(curve, u, 2)
    cross = np.cross(_as3(d[1]), _as3(d[2]))
    b = cross.sum(axis=0)
    b = b / max(np.linalg.norm(b), 1e-300)
    signed = cross @ b
    scale = np.abs(signed).max() if signed.size else 0.0
    return {"curvature_extrema": count_extrema(kappa),
            "inflections": count_sign_changes(signed, 1e-9 * scale)}


def surface_wiggles(surface, per_span=4, reference=None):
    r"""Curvature extrema and normal-curvature sign changes along iso-parameter lines.

    Iso-lines sit at the breakpoints of ``reference`` (default the surface itself;
    pass the source to compare a faired surface on the same lines); along each the
    curvature of the iso-curve and the sign of its normal curvature
    :math:`S_{ww}\cdot n` are sampled ``per_span`` times per span of ``reference``.

    Returns
    -------
    dict with ``curvature_extrema`` and ``inflections`` (int, summed over all iso-lines)
    """
    ref = reference or surface
    u = sample_parameters(ref.u_space, per_span=per_span)
    v = sample_parameters(ref.v_space, per_span=per_span)
    u_lines, v_lines = ref.u_space.breakpoints, ref.v_space.breakpoints
    extrema = inflections = 0
    for fixed, moving, along in ((u_lines, v, "v"), (v_lines, u, "u")):
        if along == "v":
            uu, vv = np.meshgrid(fixed, moving, indexing="ij")
            k1, k2 = (0, 1), (0, 2)
        else:
            vv, uu = np.meshgrid(fixed, moving, indexing="ij")
            k1, k2 = (1, 0), (2, 0)
        s = surface_derivatives(surface, uu.ravel(), vv.ravel(), 2)
        d1, d2 = _as3(s[k1]), _as3(s[k2])
        n = np.cross(_as3(s[(1, 0)]), _as3(s[(0, 1)]))
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        speed = np.maximum(np.linalg.norm(d1, axis=1), 1e-300)
        kappa = (np.linalg.norm(np.cross(d1, d2), axis=1) / speed ** 3).reshape(uu.shape)
        normal_k = (np.einsum("qd,qd->q", d2, n) / speed ** 2).reshape(uu.shape)
        extrema += count_extrema(kappa)
        inflections += count_sign_changes(normal_k, 1e-9 * np.abs(normal_k).max())
    return {"curvature_extrema": int(extrema), "inflections": int(inflections)}


def _curve_fairness(curve, reference):
    u = sample_parameters(reference.space, per_span=8)
    kappa, tau = curve_curvature(curve, u)
    out = {"bending_energy": bending_energy(curve),
           "curvature_min": float(kappa.min()), "curvature_max": float(kappa.max()),
           "torsion_max_abs": float(np.abs(tau).max()),
           "curvature_derivative_energy": curvature_derivative_energy(curve)}
    out.update(curve_wiggles(curve, reference=reference))
    return out


def _surface_fairness(surface, reference):
    u = sample_parameters(reference.u_space, per_span=4)
    v = sample_parameters(reference.v_space, per_span=4)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    c = surface_curvatures(surface, uu.ravel(), vv.ravel())
    out = {"bending_energy": bending_energy(surface),
           "gaussian_min": float(c["gaussian"].min()), "gaussian_max": float(c["gaussian"].max()),
           "mean_abs_max": float(np.abs(c["mean"]).max()),
           "principal_abs_max": float(max(np.abs(c["k1"]).max(), np.abs(c["k2"]).max()))}
    out.update(surface_wiggles(surface, reference=reference))
    return out


def fairness_summary(source, faired=None):
    """Fairness figures before and after: ``{name: {"before": x, "after": y}}``.

    Curves: bending energy, curvature min/max, largest torsion, curvature-derivative
    energy, curvature extrema and inflections.  Surfaces: bending energy, Gaussian
    curvature range, largest mean and principal curvature, iso-line wiggles.
    Both are sampled at the same parameters (those of the source), so the counts
    compare like with like.
    """
    source, faired, kind = _unwrap(source, faired)
    measure = _curve_fairness if kind == "curve" else _surface_fairness
    before, after = measure(source, source), measure(faired, source)
    return {key: {"before": before[key], "after": after[key]} for key in before}
