r"""Deviation and curvature of core surfaces on sample grids (numpy + scipy only).

Deviation of the faired surface :math:`F` from the source :math:`S` at a sample
:math:`p = F(u_i, v_j)` is the signed distance to the closest point of :math:`S`,
approximated by the distance to the tangent plane at the nearest point of a dense
source sample: :math:`d = (p - S(q))\cdot n_S(q)`.  The error of this point-to-plane
estimate is :math:`O(h^2\kappa)` for a source sample spacing :math:`h`; the tests compare it
with FreeCAD's ``Part.Face.distToShape``.

Curvatures follow from the fundamental forms: with :math:`E, F, G` and :math:`L, M, N`,
:math:`K = (LN - M^2)/(EG - F^2)` and :math:`H = (EN - 2FM + GL) / (2(EG - F^2))`.
"""

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["sample_parameters", "parametric_deviation", "signed_deviation", "curvature"]


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


def _unit_normals(surface, u, v):
    n = np.cross(surface.evaluate_grid(u, v, 1, 0), surface.evaluate_grid(u, v, 0, 1))
    length = np.linalg.norm(n, axis=2, keepdims=True)
    return n / np.where(length > 0, length, 1.0)


def signed_deviation(source, faired, uv_range, count=40, oversample=4):
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
    normals = _unit_normals(source, us, vs).reshape(-1, 3)
    _, nearest = cKDTree(dense).query(points.reshape(-1, 3))
    d = np.einsum("ij,ij->i", points.reshape(-1, 3) - dense[nearest], normals[nearest])
    return points, d.reshape(count, count)


def curvature(surface, uv_range, count=40, kind="mean"):
    """Mean or Gaussian curvature on a ``count x count`` grid.

    Returns
    -------
    points : ndarray, shape (count, count, 3)
    values : ndarray, shape (count, count)
    """
    u, v = sample_parameters(uv_range, count)
    su, sv = surface.evaluate_grid(u, v, 1, 0), surface.evaluate_grid(u, v, 0, 1)
    suu = surface.evaluate_grid(u, v, 2, 0)
    suv = surface.evaluate_grid(u, v, 1, 1)
    svv = surface.evaluate_grid(u, v, 0, 2)
    n = np.cross(su, sv)
    n /= np.maximum(np.linalg.norm(n, axis=2, keepdims=True), 1e-300)
    e, f, g = (su * su).sum(2), (su * sv).sum(2), (sv * sv).sum(2)
    l, m, nn = (suu * n).sum(2), (suv * n).sum(2), (svv * n).sum(2)
    det = np.maximum(e * g - f * f, 1e-300)
    if kind == "gaussian":
        values = (l * nn - m * m) / det
    else:
        values = (e * nn - 2 * f * m + g * l) / (2 * det)
    return surface.evaluate_grid(u, v), values
