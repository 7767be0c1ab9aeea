r"""Closest points on curves and surfaces: damped Newton iterations, vectorised over all
points and clamped to the domain (foot points on a border slide along it).

The foot point on a curve :math:`C` solves :math:`C'(t)\cdot(C(t) - P) = 0`; on a surface
the 2x2 system :math:`(S_u\cdot(S-P),\ S_v\cdot(S-P)) = 0`.  Every distance returned is
the distance to an actual point of the geometry, so it can only over-estimate the exact
point-to-geometry distance.
"""


import numpy as np
from scipy.spatial import cKDTree

from .evaluation import _derivatives_in_domain, curve_derivatives, sample_parameters
from .spaces import clamp, find_spans

STEP_FLOOR = 1e-10   # a Newton step moving the foot point less than this x size: converged


HALVINGS = 12        # a Newton step that increases the distance is halved up to this often
BATCHED_TRIALS = 512  # halvings of few points are tried together, this many trials a call


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
    t = clamp(np.asarray(u0, dtype=float), lo, hi)
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
            new = clamp(t[idx] + s, lo, hi)
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

    ``tree()`` returns the ``cKDTree`` of the curve's samples at ``sample_u``, asked for
    only when other starts are tried (building one for the ten thousand samples of a
    seed-like curve costs about as much as a Newton run).  With ``tol`` the other starts
    are tried only where the first distance exceeds it, and every Newton iteration stops
    once below it.
    """
    best = closest_points_curve(curve, points, same_u, stop_below=tol)[1]
    todo = np.flatnonzero(best > tol) if tol is not None else np.arange(best.size)
    if todo.size == 0:
        return best
    _, near = tree().query(points[todo], k=min(starts, sample_u.size))
    near = near.reshape(todo.size, -1)
    for column in near.T:
        best[todo] = np.minimum(best[todo], closest_points_curve(
            curve, points[todo], sample_u[column], stop_below=tol)[1])
    return best


def distance_floor(curve, u, on_curve, points):
    r"""Lower bounds of the distances from ``points`` to a polynomial ``curve``, from its
    points ``on_curve`` at increasing parameters ``u`` that span its domain.

    On :math:`[u_j, u_{j+1}]` the curve moves at most :math:`M_j` per unit parameter,
    :math:`M_j` the largest derivative control point
    :math:`p\,(P_{i+1} - P_i) / (t_{i+p+1} - t_{i+1})` active on the knot spans the
    interval meets (convex hull property of :math:`C'`), so with
    :math:`a_j = \|C(u_j) - P\|`

    .. math:: \min_{t \in [u_j, u_{j+1}]} \|C(t) - P\| \ge
       \tfrac12\,(a_j + a_{j+1} - M_j\,(u_{j+1} - u_j)).

    Parameters
    ----------
    curve : BSplineCurve
        Polynomial (no weights).
    u : ndarray, shape (m,)
        Increasing, ``u[0]`` and ``u[-1]`` the domain's ends.
    on_curve : ndarray, shape (m, d)
        ``curve`` at ``u``.
    points : ndarray, shape (q, d)

    Returns
    -------
    ndarray, shape (q,)
        Bounds ``>= 0``, never above the exact distances (up to rounding).
    """
    spans = find_spans(curve.space, u) - curve.degree
    speed = _span_speeds(curve)
    reach = np.maximum(np.maximum.reduceat(speed, spans[:-1]), speed[spans[1:]]) * np.diff(u)
    a = _distance(on_curve[None, :, :], np.asarray(points, dtype=float)[:, None, :])
    return np.maximum(0.5 * (a[:, :-1] + a[:, 1:] - reach).min(axis=1), 0.0)


def _span_speeds(curve):
    """Largest derivative control point norm active on each knot span of a polynomial
    curve (span ``mu`` of :func:`find_spans` at index ``mu - p``): bounds of ``|C'|``."""
    t, p = curve.knots, curve.degree
    k = curve.poles.shape[0]
    width = t[p + 1:p + k] - t[1:k]
    step = np.linalg.norm(np.diff(curve.poles, axis=0), axis=1)
    speed = p * np.divide(step, width, out=np.zeros_like(step), where=width > 0)
    return np.lib.stride_tricks.sliding_window_view(speed, p).max(axis=1)


def _damped(trial, active, step, dist, halvings=HALVINGS, batched=BATCHED_TRIALS):
    """Halve steps until the distance does not grow; returns the last trial per point.

    Only the points whose distance grew pay for a halving.  A Newton step can overshoot
    by far more than 2^5: on a fillet whose u domain is 6e-4 long (``|S_u|`` about 2e3,
    ``|S_v|`` about 2), the first step from a point 0.08 off was twice the u domain, and
    the point stopped there, 30 times its true distance (0.0024) away.

    The halvings of few points are tried together: the steps :math:`s / 2^k` for as
    many ``k`` as keep a call within ``batched`` trials (all that remain for a
    handful of points, one at a time for thousands), and each point takes its first
    ``k`` that does not grow its distance, or its last.  That is the same as halving
    one ``k`` after another (powers of two scale a step exactly), in a few evaluations
    where the last Newton iterations of a search had a dozen of one or two points
    each."""
    new, d_new = trial(active, step)
    worse = np.flatnonzero(d_new > dist[active])
    done = 0
    while worse.size and done < halvings:
        count = min(halvings - done, max(1, batched // worse.size))
        factors = 0.5 ** np.arange(done + 1, done + count + 1)
        steps = (factors.reshape((count,) + (1,) * step.ndim) * step[worse]).reshape(
            (-1,) + step.shape[1:])
        tried, d_tried = trial(np.tile(active[worse], count), steps)
        tried = tried.reshape((count, worse.size) + tried.shape[1:])
        d_tried = d_tried.reshape(count, worse.size)
        better = d_tried <= dist[active[worse]]
        found = better.any(axis=0)
        first = np.where(found, better.argmax(axis=0), count - 1)
        columns = np.arange(worse.size)
        new[worse], d_new[worse] = tried[first, columns], d_tried[first, columns]
        worse = worse[~found]
        done += count
    return new, d_new


def closest_points_surface(surface, points, u0, v0, iterations=30, stop_below=None,
                           bounds=None, start_distance=None):
    r"""Foot points on ``surface`` by damped, clamped 2x2 Newton iterations.

    Solves :math:`g = (S_u\cdot r,\ S_v\cdot r) = 0`, :math:`r = S(u, v) - P`, with the
    Hessian :math:`H = J^T J + [S_{uu}\cdot r,\ S_{uv}\cdot r;\ S_{uv}\cdot r,\ S_{vv}\cdot r]`
    (Gauss-Newton :math:`J^T J` when :math:`H` is not positive definite), clamping to the
    domain and halving steps until the distance decreases.  With ``stop_below`` a point
    stops once its distance is at most that value; it has converged once its step would
    move the foot point by less than ``STEP_FLOOR`` times the surface's size (as
    :func:`closest_points_curve`).  ``bounds`` ``((u0, u1), (v0, v1))`` inside the
    domain restricts the foot points to that parameter box (a face's UV box); default
    the whole domain.  ``start_distance`` gives the distances at the starts where a
    caller knows them already (a probe's same-parameter distances; NaN where not known,
    which are evaluated): the start's evaluation is then skipped there.

    Returns
    -------
    u, v, distance : ndarray, shape (q,)
        ``distance`` is that of an actual surface point: never below the exact one.
    """
    points = np.asarray(points, dtype=float)
    (ulo, uhi), (vlo, vhi) = surface.domain if bounds is None else bounds
    uv = np.stack([clamp(np.asarray(u0, dtype=float), ulo, uhi),
                   clamp(np.asarray(v0, dtype=float), vlo, vhi)], axis=1)
    dist = _start_distance(surface, points, uv, start_distance)
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
            new[:, 0] = clamp(new[:, 0], ulo, uhi)
            new[:, 1] = clamp(new[:, 1], vlo, vhi)
            pts = _derivatives_in_domain(surface, new[:, 0], new[:, 1], 0)[(0, 0)]
            return new, _distance(pts, points[idx])

        new, d_new = _damped(trial, active, step, dist)
        moved = (d_new < dist[active]) & (np.abs(new - uv[active]).sum(axis=1) > 1e-13 * scale)
        uv[active[moved]], dist[active[moved]] = new[moved], d_new[moved]
        active = active[moved]
    return uv[:, 0], uv[:, 1], dist


def _start_distance(surface, points, uv, known=None):
    """Distances of ``points`` from ``surface`` at parameters ``uv``, evaluated where
    ``known`` (optional) is NaN and taken from it elsewhere."""
    dist = np.full(len(points), np.nan) if known is None else np.array(known, dtype=float)
    todo = np.flatnonzero(np.isnan(dist))
    if todo.size:
        dist[todo] = _distance(
            _derivatives_in_domain(surface, uv[todo, 0], uv[todo, 1], 0)[(0, 0)], points[todo])
    return dist


class RestartSamples:
    r"""The coarse samples :func:`closest_points_surface_restarted` restarts from:
    ``per_span`` per knot span and direction of ``surface`` (one per span where that
    would exceed ``max_samples`` per direction; ends and breakpoints included), their
    points held in a ``cKDTree``.  Made once, they serve every projection onto the same
    surface (building the tree of a 50 x 80 net's 58 000 samples costs about 10 ms).

    Attributes
    ----------
    axes : (ndarray, ndarray)
        The sample parameters per direction.
    tree : scipy.spatial.cKDTree
        The samples' points, flat in row-major ``(u, v)`` order.
    """

    def __init__(self, surface, per_span=4, max_samples=257):
        axes = []
        for space in (surface.u_space, surface.v_space):
            x = sample_parameters(space, per_span=per_span)
            axes.append(x if x.size <= max_samples else sample_parameters(space, per_span=1))
        self.axes = tuple(axes)
        grid = surface.evaluate_grid(*axes)
        self.tree = cKDTree(grid.reshape(-1, grid.shape[-1]))


def closest_points_surface_restarted(surface, points, u0, v0, per_span=4, max_samples=257,
                                     starts=2, samples=None):
    r"""Foot points by :func:`closest_points_surface` from ``(u0, v0)``, restarted from
    the nearest coarse samples of the surface that lie elsewhere.

    The coarse samples are :class:`RestartSamples` of ``surface`` (``per_span`` per knot
    span and direction, at most ``max_samples`` per direction), or ``samples``, made
    for ``surface`` already.  Each of a point's ``starts`` nearest samples that is
    nearer than its foot point, or lies more than two samples away from it in
    parameters, is a new Newton start, and the nearest result is kept: Newton from the
    same parameter can stop at an extremum that is not the nearest (the IEA blade's
    airfoil face has points nearer to the other side of its closed trailing edge, where
    the samples at both ends of v coincide).  No distance returned exceeds the nearest
    coarse sample's, and each is that of an actual surface point: never below the exact
    one.

    Returns
    -------
    u, v, distance : ndarray, shape (q,)
    """
    points = np.asarray(points, dtype=float)
    u, v, dist = closest_points_surface(surface, points, u0, v0)
    if samples is None:
        samples = RestartSamples(surface, per_span, max_samples)
    axes = samples.axes
    near, index = samples.tree.query(points, k=min(starts, samples.tree.n))
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
    s0, s1 = clamp(step[:, 0], -limit, limit), clamp(step[:, 1], -limit, limit)
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


def nearer_starts(surface, points, uv, seeds, at_uv=None):
    r"""Start parameters of closest-point runs on ``surface``: per point, of ``uv`` and
    ``seeds`` (both (q, 2), in the domain) the one whose surface point is nearer, with
    that distance; ``at_uv``: the distances at ``uv`` where already known (evaluated
    otherwise).

    A run of :func:`closest_points_surface_restarted` returns a distance at most that of
    its start (its Newton steps only bring the foot nearer), so the distance returned
    here bounds the run's from above.  The seeds are typically the foot points of a
    nearby surface measured before (a polished net after its unpolished one), where
    :math:`|S(s_i) - p_i|` bounds far more tightly than the same-parameter distance of a
    net that slides along its source.

    Returns
    -------
    starts : ndarray, shape (q, 2)
    bound : ndarray, shape (q,)
    """
    points = np.asarray(points, dtype=float)
    bounds = [np.linalg.norm(_derivatives_in_domain(surface, *_clamped(surface, p), 0)[(0, 0)]
                             - points, axis=1) if known is None else known
              for p, known in ((uv, at_uv), (seeds, None))]
    seeded = bounds[1] < bounds[0]
    return np.where(seeded[:, None], seeds, uv), np.where(seeded, bounds[1], bounds[0])


def _clamped(surface, uv):
    """``(u, v)`` of ``uv`` (q, 2) clamped into ``surface``'s domain."""
    (u0, u1), (v0, v1) = surface.domain
    return clamp(uv[:, 0], u0, u1), clamp(uv[:, 1], v0, v1)
