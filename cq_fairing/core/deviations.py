r"""Deviation between an original and a faired curve or surface.

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
"""

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .closest_points import closest_points_curve, closest_points_surface
from .evaluation import (
    _check_domains,
    _unwrap,
    curve_derivatives,
    sample_parameters,
    surface_derivatives,
)
from .probes import CurveProbe, SurfaceProbe, _check_method, _window_start


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
