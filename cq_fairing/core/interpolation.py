r"""Data points to control points (patent CN103984810, step 1).

A cubic interpolant through ``N`` points with knots at the parameters and natural end
conditions (:math:`C''=0` at both ends) has ``N + 2`` control points, as in the seed's
1300 points -> 1302 control points.  With uniform parameters its knots are
quasi-uniform (:math:`m = N - 1` spans), so it lies in the seeds' :math:`V_m`.
Grids of points are interpolated along rows, then along columns (tensor product), with
parameters averaged over the rows (The NURBS Book, section 9.2.5).
"""

import warnings

import numpy as np
from scipy.interpolate import make_interp_spline

from ..errors import InvalidInputError
from .geometry import BSplineCurve, BSplineSurface, as_poles

__all__ = ["interpolate_points", "interpolate_grid", "parameters", "read_xyz"]

PARAMETRIZATIONS = ("uniform", "chord", "centripetal")


def parameters(points, method="uniform"):
    r"""Parameters in [0, 1] for points along a curve.

    ``uniform``: :math:`u_i = i/(N-1)`; ``chord``: proportional to the cumulative chord
    length; ``centripetal``: to the cumulative square root of chord lengths.

    Parameters
    ----------
    points : ndarray, shape (N, d)
    method : {"uniform", "chord", "centripetal"}

    Returns
    -------
    ndarray, shape (N,)
    """
    if method not in PARAMETRIZATIONS:
        raise InvalidInputError(
            f"parametrization must be one of {PARAMETRIZATIONS}, got {method!r}."
        )
    n = points.shape[0]
    if method == "uniform":
        return np.linspace(0.0, 1.0, n)
    steps = np.linalg.norm(np.diff(points, axis=0), axis=-1)
    if steps.ndim > 1:
        steps = steps.mean(axis=tuple(range(1, steps.ndim)))
    if method == "centripetal":
        steps = np.sqrt(steps)
    if np.any(steps <= 0):
        first = int(np.argmax(steps <= 0))
        raise InvalidInputError(
            f"points {first} and {first + 1} coincide; chord-length parameters need "
            "distinct consecutive points. Remove duplicates or use parametrization='uniform'."
        )
    u = np.concatenate([[0.0], np.cumsum(steps)])
    return u / u[-1]


def _interpolate_axis(values, u):
    """Natural cubic interpolation along axis 0; returns (knots, coefficients)."""
    spline = make_interp_spline(u, values, k=3, bc_type="natural", axis=0)
    return spline.t, spline.c


def interpolate_points(points, parametrization="uniform"):
    """Cubic curve through the points (natural ends): ``N`` points give ``N + 2`` poles.

    Parameters
    ----------
    points : array_like, shape (N, d), N >= 2
    parametrization : {"uniform", "chord", "centripetal"}

    Returns
    -------
    BSplineCurve
        Degree 3, clamped knots at the parameters.

    Raises
    ------
    InvalidInputError
        Fewer than 2 points, NaN/inf, wrong shape, coincident points with chord
        parameters.
    """
    P = as_poles(points, "points", 2)
    if P.shape[0] < 2:
        raise InvalidInputError(
            f"interpolation needs at least 2 points, got {P.shape[0]}; pass more points."
        )
    if P.shape[0] < 4:
        P = _densify(P)
    u = parameters(P, parametrization)
    knots, poles = _interpolate_axis(P, u)
    return BSplineCurve(poles, knots, 3)


def _densify(points):
    """Insert midpoints until a cubic interpolant is defined (at least 4 points)."""
    while points.shape[0] < 4:
        mids = 0.5 * (points[:-1] + points[1:])
        out = np.empty((points.shape[0] + mids.shape[0], points.shape[1]))
        out[0::2], out[1::2] = points, mids
        points = out
    return points


def interpolate_grid(points, parametrization="uniform"):
    """Bicubic surface through a grid of points: (N_u, N_v) points give (N_u+2, N_v+2) poles.

    Parameters
    ----------
    points : array_like, shape (N_u, N_v, d), N_u, N_v >= 4
    parametrization : {"uniform", "chord", "centripetal"}

    Returns
    -------
    BSplineSurface
    """
    P = as_poles(points, "points", 3)
    if min(P.shape[:2]) < 4:
        raise InvalidInputError(
            f"grid interpolation needs at least 4 x 4 points, got {P.shape[0]} x {P.shape[1]}."
        )
    u = parameters(P, parametrization)
    v = parameters(np.swapaxes(P, 0, 1), parametrization)
    u_knots, rows = _interpolate_axis(P, u)
    v_knots, net = _interpolate_axis(np.swapaxes(rows, 0, 1), v)
    return BSplineSurface(np.swapaxes(net, 0, 1), u_knots, v_knots, 3, 3)


def read_xyz(path):
    """Read ``x y z`` points, one per line (blank lines and ``#`` comments skipped).

    Returns
    -------
    ndarray, shape (N, 3)

    Raises
    ------
    InvalidInputError
        Missing file, unreadable numbers, wrong column count, or fewer than 2 points.
    """
    try:
        with warnings.catch_warnings():   # loadtxt warns on an empty file: said below
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(path, dtype=float, comments="#", ndmin=2)
    except FileNotFoundError as exc:
        raise InvalidInputError(f"point file {path} does not exist.") from exc
    except IsADirectoryError as exc:
        raise InvalidInputError(f"point file {path} is a folder, not a file.") from exc
    except ValueError as exc:
        raise InvalidInputError(
            f"point file {path} is not 'x y z' numbers per line ({exc})."
        ) from exc
    if data.size == 0:
        raise InvalidInputError(f"point file {path} holds no points.")
    if data.shape[1] != 3:
        raise InvalidInputError(
            f"point file {path} must have 3 columns (x y z), found {data.shape[1]}."
        )
    if data.shape[0] < 2:
        raise InvalidInputError(f"point file {path} holds 1 point; a curve or a surface "
                                "needs at least 2 x y z points.")
    return as_poles(data, f"points in {path}", 2)
