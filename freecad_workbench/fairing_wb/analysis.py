r"""Deviation and curvature of core surfaces on sample grids (numpy + scipy only).

Deviation of the faired surface :math:`F` from the source :math:`S` at a sample
:math:`p = F(u_i, v_j)` is the signed distance to the closest point of :math:`S`:
the foot point :math:`(u^*, v^*) = \arg\min |S(u, v) - p|^2` is found by the core's
damped Newton iterations (``cq_fairing.core.measures.closest_points_surface``: they
slide along the border of the face's parameter box where the minimum lies on it),
started at the nearest point of a dense source sample; then
:math:`|d| = |p - S(u^*, v^*)|` with the sign of :math:`(p - S)\cdot n_S`.  The tests
compare it with FreeCAD's ``Part.Face.distToShape``.

Curvatures are the core's (:func:`cq_fairing.core.fairness.grid_curvatures`).
"""

import numpy as np
from scipy.spatial import cKDTree

from cq_fairing.core.closest_points import (
    RestartSamples,
    closest_points_surface,
    closest_points_surface_restarted,
    nearer_starts,
)
from cq_fairing.core.evaluation import surface_derivatives
from cq_fairing.core.fairness import grid_curvatures
from cq_fairing.core.probes import ROUNDING, BoundWalk

__all__ = ["sample_parameters", "parametric_deviation", "signed_deviation",
           "two_sided_deviation", "SampledDeviation", "curvature", "points_and_normals",
           "foot_points"]


def sample_parameters(uv_range, count):
    """``count`` equally spaced parameters per direction over ``(u0, u1, v0, v1)``."""
    u0, u1, v0, v1 = uv_range
    return np.linspace(u0, u1, count), np.linspace(v0, v1, count)


def parametric_deviation(source, faired, uv_range, count=40):
    r"""Max of :math:`|S(u, v) - F(u, v)|` on a ``count x count`` grid.

    An upper bound of the geometric (closest-point) deviation at those samples, cheap
    enough for the task panel's live figures.
    """
    u, v = sample_parameters(uv_range, count)
    diff = source.evaluate_grid(u, v) - faired.evaluate_grid(u, v)
    return float(np.sqrt((diff ** 2).sum(axis=2)).max())


def foot_points(surface, points, u, v, uv_range):
    """Closest points on ``surface`` inside ``uv_range`` from start parameters ``u, v``,
    and the unit normals there."""
    u0, u1, v0, v1 = uv_range
    u, v, _ = closest_points_surface(surface, points, u, v, bounds=((u0, u1), (v0, v1)))
    return points_and_normals(surface, u, v)


def points_and_normals(surface, u, v):
    r"""Points and unit normals :math:`S_u \times S_v / |S_u \times S_v|` of ``surface``
    at scattered parameters ``(u_q, v_q)``, each (q, 3) (a zero normal where
    :math:`S_u \times S_v = 0`)."""
    d = surface_derivatives(surface, u, v, 1)
    s, n = d[(0, 0)], np.cross(d[(1, 0)], d[(0, 1)])
    n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
    return s, n


def signed_deviation(source, faired, uv_range, count=40, oversample=2):
    """Signed closest-point distances from faired samples to the source surface.

    Parameters
    ----------
    source, faired : cq_fairing.BSplineSurface
    uv_range : (u0, u1, v0, v1)
    count : int
        Samples per direction on the faired surface.
    oversample : int
        Density of the source sample relative to ``count``.

    Returns
    -------
    points : ndarray, shape (count, count, 3)
        Faired sample points.
    distance : ndarray, shape (count, count)
        Signed along the source normal.
    """
    u, v = sample_parameters(uv_range, count)
    points = faired.evaluate_grid(u, v)
    us, vs = sample_parameters(uv_range, count * oversample)
    dense = source.evaluate_grid(us, vs).reshape(-1, 3)
    flat = points.reshape(-1, 3)
    _, nearest = cKDTree(dense).query(flat)
    iu, iv = np.divmod(nearest, vs.size)
    foot, normals = foot_points(source, flat, us[iu], vs[iv], uv_range)
    offset = flat - foot
    # |p - foot| is the distance even where the foot point sits on the face's border
    # (there p - foot is not along the normal); the normal only gives the sign.
    d = np.copysign(np.linalg.norm(offset, axis=1), np.einsum("ij,ij->i", offset, normals))
    return points, d.reshape(count, count)


def two_sided_deviation(source, faired, uv_range, count=40):
    r"""Deviation both ways on a ``count x count`` parameter grid.

    At each :math:`(u_i, v_j)` the larger in magnitude of :math:`d_{F \to S}`, the
    faired sample's signed distance to the source (:func:`signed_deviation`), and
    :math:`-d_{S \to F}`, the source sample's signed distance to the faired surface
    with its sign turned to the same sense (faired minus source).  One way alone misses
    a faired face that stops short of its source's border: every faired sample lies on
    the source, while the source's border is far from the faired face.

    Returns
    -------
    points : ndarray, shape (count, count, 3)
        Faired sample points (where the values are drawn).
    distance : ndarray, shape (count, count)
    """
    points, there = signed_deviation(source, faired, uv_range, count)
    _, back = signed_deviation(faired, source, uv_range, count)
    return points, np.where(np.abs(there) >= np.abs(back), there, -back)


class SampledDeviation:
    r"""Two-sided distance between a source surface :math:`S` and candidates :math:`F`
    that share its parametrisation, at fixed samples :math:`(u_i, v_i)` of a face.

    At each sample the larger of the distance from :math:`S(u_i, v_i)` to :math:`F` and
    from :math:`F(u_i, v_i)` to :math:`S`, each by the core's batched Newton projection
    started at :math:`(u_i, v_i)` and restarted from coarse samples of the surface
    (:func:`~cq_fairing.core.closest_points.closest_points_surface_restarted`): the
    distance to an actual point of the surface, never below the true one.  This is the
    batched measure :func:`cq_fairing.occ.sample_face_deviation` starts from before OCCT
    measures its largest values again.

    Parameters
    ----------
    source : cq_fairing.BSplineSurface
    grids : sequence of (ndarray, ndarray, ndarray of bool)
        ``(u, v, inside)``: grid parameters inside the surface's domain and the mask of
        the samples taken (those on the face).
    """

    def __init__(self, source, grids):
        self.source, self.grids = source, list(grids)
        uv = np.concatenate([np.stack(np.meshgrid(u, v, indexing="ij"), axis=-1)[inside]
                             for u, v, inside in self.grids])
        self.u, self.v = uv[:, 0], uv[:, 1]
        self.points = self._on_grids(source)
        self._source_samples = None
        self._last = None

    def _on_grids(self, surface):
        """``surface``'s points at the samples, (q, 3), evaluated grid by grid."""
        return np.concatenate([surface.evaluate_grid(u, v)[inside]
                               for u, v, inside in self.grids])

    def _restarts(self):
        """The source's :class:`~cq_fairing.core.closest_points.RestartSamples`, made once."""
        if self._source_samples is None:
            self._source_samples = RestartSamples(self.source)
        return self._source_samples

    def _candidate(self, faired):
        """The :class:`_Walk` of ``faired``'s samples, kept for the last candidate
        (:meth:`exceeds` then :meth:`__call__` go on with the same one), seeded with the
        foot points the last candidate's walk found."""
        if self._last is None or self._last.faired is not faired:
            self._last = _Walk(self, faired, None if self._last is None else self._last.feet)
        return self._last

    def distances(self, faired, index=slice(None)):
        """The two-sided distance at the samples ``index`` (all by default), each sample
        measured on its own from its start parameters (its value is the same in any
        batch); the foot points are kept as the next candidate's seeds."""
        walk = self._candidate(faired)
        there, back = walk.starts
        *feet_there, d_there = closest_points_surface_restarted(
            faired, self.points[index], *there[index].T, samples=walk.restarts)
        *feet_back, d_back = closest_points_surface_restarted(
            self.source, walk.points[index], *back[index].T, samples=self._restarts())
        walk.feet[0][index], walk.feet[1][index] = np.column_stack(feet_there), \
            np.column_stack(feet_back)
        return np.maximum(d_there, d_back)

    def __call__(self, faired):
        r"""The largest two-sided distance of ``faired`` over the samples
        (``distances(faired).max()``), measured only where it can be the largest.

        Both distances at a sample are at most its bound, the distance at its Newton
        starts (:class:`_Walk`; each run never moves away), so the samples are measured
        in decreasing order of it, in doubling batches from
        :data:`~cq_fairing.core.probes.FIRST_BATCH`, until
        the next one's is below the largest distance found by more than ``ROUNDING`` of
        the source's extent (the parametric distance and the Newton runs evaluate the
        surfaces by different routes, equal to rounding).  No sample passed over can
        exceed that maximum, and each sample's value is that of the full measurement, so
        the maximum is the full one."""
        walk = self._candidate(faired)
        walk.measure_above(lambda: walk.best)
        return walk.best

    def exceeds(self, faired, tol):
        r"""Whether :meth:`__call__` of ``faired`` exceeds ``tol``, measuring only what
        decides it: only a sample whose bound (:class:`_Walk`) exceeds ``tol`` can
        exceed it either way, so those are measured in the order of :meth:`__call__`,
        which goes on from them,
        and the first value above ``tol`` answers ``True`` (a lower bound of the full
        maximum)."""
        walk = self._candidate(faired)
        walk.measure_above(lambda: tol if walk.best <= tol else np.inf)
        return walk.best > tol


class _Walk:
    """One candidate's samples in decreasing order of an upper bound of their two-sided
    distance, measured in doubling batches (:class:`~cq_fairing.core.probes.BoundWalk`),
    with the largest distance measured so far.

    Each way's Newton run at a sample starts at the sample's parameters or, where its
    point is nearer, at ``seeds`` (the feet the last candidate's runs found:
    :func:`~cq_fairing.core.closest_points.nearer_starts`); the bound is the larger of
    the two ways' distances at their starts (both the parametric distance without
    seeds)."""

    def __init__(self, check, faired, seeds=None):
        self.check, self.faired = check, faired
        self.points = check._on_grids(faired)
        uv = np.column_stack([check.u, check.v])
        parametric = np.linalg.norm(self.points - check.points, axis=1)
        if seeds is None:
            self.starts, bound = (uv, uv), parametric
        else:
            (there, bound_there), (back, bound_back) = (
                nearer_starts(faired, check.points, uv, seeds[0], parametric),
                nearer_starts(check.source, self.points, uv, seeds[1], parametric))
            self.starts, bound = (there, back), np.maximum(bound_there, bound_back)
        self.feet = tuple(np.array(s, dtype=float) for s in self.starts)
        self.walk = BoundWalk(bound)
        self.restarts = RestartSamples(faired)
        self.slack = ROUNDING * check.source.size
        self.best = 0.0

    def measure_above(self, level):
        """Measure the next batches while the next sample's bound is above ``level()``
        less the rounding slack."""
        while self.walk.next_bound > level() - self.slack:
            index = self.walk.take(level() - self.slack)
            self.best = max(self.best, float(self.check.distances(self.faired, index).max()))


def curvature(surface, uv_range, count=40, kind="mean"):
    """Mean or Gaussian curvature on a ``count x count`` grid.

    The core's formula (:func:`cq_fairing.core.fairness.grid_curvatures`), so the map
    shows the values the fairness measures use.

    Returns
    -------
    points : ndarray, shape (count, count, 3)
    values : ndarray, shape (count, count)
        NaN where the surface is singular (a collapsed border).
    """
    c = grid_curvatures(surface, *sample_parameters(uv_range, count))
    return c["points"], c["gaussian" if kind == "gaussian" else "mean"]
