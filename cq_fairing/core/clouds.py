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

import operator

import numpy as np
from scipy.interpolate import griddata

from ..errors import InvalidInputError
from .geometry import as_poles

__all__ = ["classify_points", "resample_height_field"]

JUMP = 4.0


def classify_points(points):
    """What the sequence ``points`` is.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        At least 2 finite points.

    Returns
    -------
    (str, tuple or None)
        ``("curve", None)`` for one run without jumps, ``("grid", (rows, columns))`` for
        rows of ``columns`` points (at least 4 x 4) each started by a jump, else
        ``("scattered", None)``.

    Raises
    ------
    InvalidInputError
        For points that are not an (N, 3) array of finite numbers with N >= 2.
    """
    points = _as_points(points, 2, "telling a curve, a grid and a cloud apart")
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
    points : array_like, shape (N, 3)
        At least 3 finite points not on one line.
    shape : (int, int)
        Grid size, each an integer of at least 2.

    Returns
    -------
    grid : ndarray, shape (n_u, n_v, 3)
    extrapolated : int
        Grid cells outside the convex hull (given the nearest point's height).

    Raises
    ------
    InvalidInputError
        For a grid size that is not a pair of integers of at least 2, or points that are
        not an (N, 3) array of finite numbers with N >= 3, or span no plane.
    """
    n_u, n_v = _grid_shape(shape)
    points = _as_points(points, 3, "a height field")
    centre = points.mean(axis=0)
    _, spread, axes = np.linalg.svd(points - centre, full_matrices=False)
    if spread.size < 2 or spread[1] <= 1e-12 * max(spread[0], 1e-300):
        raise InvalidInputError(
            f"the {points.shape[0]} points lie on a line (or in one point): they span no "
            "plane to resample a height field over.")
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


def _as_points(points, minimum, purpose):
    """``points`` as a float (N, 3) array of finite numbers with N >= ``minimum``."""
    array = as_poles(points, "points")
    if array.shape[1] != 3:
        raise InvalidInputError(
            f"points must have 3 coordinates (x y z) each, got {array.shape[1]}; pass an "
            "(N, 3) array.")
    if array.shape[0] < minimum:
        raise InvalidInputError(
            f"{purpose} needs at least {minimum} points, got {array.shape[0]}; pass more "
            "points.")
    return array


def _grid_shape(shape):
    """``shape`` as two ints of at least 2 (bools, fractions and other lengths refused)."""
    try:
        values = tuple(shape)
        exact = len(values) == 2 and not any(isinstance(k, (bool, np.bool_)) for k in values)
        n_u, n_v = (operator.index(k) for k in values) if exact else (0, 0)
    except TypeError:
        n_u = n_v = 0
    if min(n_u, n_v) < 2:
        raise InvalidInputError(
            f"a resampling grid is a pair of integers of at least 2 (points per "
            f"direction), got {shape!r}; pass e.g. (40, 40).")
    return n_u, n_v
