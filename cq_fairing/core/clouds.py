r"""What a file of points is, and a scattered cloud resampled onto a grid.

The order of ``x y z`` points decides what they can be interpolated as:

* one run of points without jumps: a curve (:func:`~cq_fairing.interpolate_points`);
* rows of equal length separated by jumps (a scan-line grid): a surface
  (:func:`~cq_fairing.interpolate_grid`);
* anything else is a scattered cloud (a scan of a face, say), which neither
  interpolation can take as it is: :func:`resample_height_field` puts it onto a grid
  first, as a height field over its best-fit (PCA) plane.

A jump is a step longer than ``JUMP`` times the median step between consecutive points.
"""

import numpy as np
from scipy.interpolate import griddata

from ..errors import InvalidInputError

__all__ = ["classify_points", "resample_height_field"]

JUMP = 4.0


def classify_points(points):
    """What the sequence ``points`` is.

    Parameters
    ----------
    points : ndarray, shape (N, 3)

    Returns
    -------
    (str, tuple or None)
        ``("curve", None)`` for one run without jumps, ``("grid", (rows, columns))`` for
        rows of ``columns`` points (at least 4 x 4) each started by a jump, else
        ``("scattered", None)``.
    """
    steps = np.linalg.norm(np.diff(points, axis=0), axis=1)
    jumps = np.flatnonzero(steps > JUMP * np.median(steps)) + 1
    if jumps.size == 0:
        return "curve", None
    columns = int(jumps[0])
    n = points.shape[0]
    regular = n % columns == 0 and np.array_equal(jumps, np.arange(columns, n, columns))
    if regular and columns >= 4 and n // columns >= 4:
        return "grid", (n // columns, columns)
    return "scattered", None


def resample_height_field(points, shape):
    r"""Resample scattered points onto a ``shape`` grid over their best-fit plane.

    With :math:`c` the centroid and :math:`e_1, e_2, e_3` the right singular vectors of
    the centred points, each point is :math:`(s, t, h)` in that frame; the grid is
    :math:`s \times t` on the points' extents, and :math:`h` there is the linear
    interpolant on the Delaunay triangulation of :math:`(s, t)` (exact for a plane),
    the nearest point's :math:`h` outside their convex hull.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        At least 3 points not on one line.
    shape : (int, int)
        Grid size, each at least 2.

    Returns
    -------
    grid : ndarray, shape (n_u, n_v, 3)
    extrapolated : int
        Grid cells outside the convex hull (given the nearest point's height).

    Raises
    ------
    InvalidInputError
        For a grid size below 2 or points that span no plane.
    """
    n_u, n_v = (int(k) for k in shape)
    if min(n_u, n_v) < 2:
        raise InvalidInputError(f"a resampling grid needs at least 2 x 2 points, got {shape}.")
    centre = points.mean(axis=0)
    _, spread, axes = np.linalg.svd(points - centre, full_matrices=False)
    if spread.size < 2 or spread[1] <= 1e-12 * max(spread[0], 1e-300):
        raise InvalidInputError(
            f"the {points.shape[0]} points lie on a line: they span no plane to resample "
            "a height field over.")
    local = (points - centre) @ axes.T
    s = np.linspace(local[:, 0].min(), local[:, 0].max(), n_u)
    t = np.linspace(local[:, 1].min(), local[:, 1].max(), n_v)
    S, T = np.meshgrid(s, t, indexing="ij")
    H = griddata(local[:, :2], local[:, 2], (S, T), method="linear")
    outside = np.isnan(H)
    if outside.any():
        H[outside] = griddata(local[:, :2], local[:, 2], (S[outside], T[outside]),
                              method="nearest")
    grid = centre + np.stack([S, T, H], axis=2) @ axes
    return grid, int(outside.sum())
