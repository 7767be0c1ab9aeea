r"""Synthetic test geometry with known noise-free truth.

* :func:`seed_curve`: the space curve of Ji et al. (2014), eq. 15,

  .. math:: x = (R + a\sin bt)\cos t,\quad y = (R + a\sin bt)\sin t,\quad z = a\cos bt,
            \qquad t\in[0, 2\pi],

  a toroidal helix (tube radius ``a``, ``b`` turns around a core circle of radius ``R``)
  sampled at 1300 points, optionally with seeded Gaussian measurement noise, and
  interpolated to 1302 control points as in the seed.  The defaults
  ``R = 65, a = 3.5, b = 13`` mm and noise ``sigma = 0.002`` mm were chosen so that the
  dyadic fairing errors follow the seed's Table 1 (about 0.005 mm at ``n = 1024``,
  0.007 at 128, 0.024 at 64 - so the 0.02 mm tolerance is crossed between the dyadic
  scales 6 and 7 as in the seed - 1.0 at 32 and 4.0 at 16); the truth's curvature lies
  in 0.091-0.098 /mm, inside the seed's 0.080-0.108 /mm.
* :func:`blade_surface`: a noisy blade-like (twisted, cambered) bicubic net with its
  noise-free truth.
* :func:`patch_grid`: four noisy bicubic patches of one smooth surface in a 2 x 2 grid,
  one parametrized backwards and one transposed, with their border joins.
* :func:`patch_network`: three noisy bicubic patches of one span each (already at their
  coarsest) in an L, sharing their borders pole for pole, with their border joins.
"""

from typing import NamedTuple

import numpy as np

from .geometry import BSplineCurve, BSplineSurface
from .interpolation import interpolate_grid, interpolate_points
from .joins import BorderJoin
from .patch_grid import insert_knot
from .spaces import SplineSpace

__all__ = ["SeedCurve", "seed_curve", "seed_curve_points", "BladeSurface", "blade_surface",
           "PatchGrid", "patch_grid", "patch_network"]


class SeedCurve(NamedTuple):
    """The eq. 15 test curve: noisy source, noise-free truth and the data points.

    Attributes
    ----------
    curve : BSplineCurve
        Interpolant of the noisy points (``points + 2`` poles).
    truth : BSplineCurve
        Interpolant of the noise-free points (same parameters and knots).
    points, clean_points : ndarray, shape (N, 3)
    """

    curve: BSplineCurve
    truth: BSplineCurve
    points: np.ndarray
    clean_points: np.ndarray


def seed_curve_points(n_points=1300, R=65.0, a=3.5, b=13):
    """Noise-free points of eq. 15 at ``t = 2 pi i / (n_points - 1)``, shape (n_points, 3)."""
    t = np.linspace(0.0, 2.0 * np.pi, n_points)
    rho = R + a * np.sin(b * t)
    return np.column_stack([rho * np.cos(t), rho * np.sin(t), a * np.cos(b * t)])


def seed_curve(n_points=1300, R=65.0, a=3.5, b=13, noise=0.002, seed=2014):
    """The seed's eq. 15 curve with seeded Gaussian noise (standard deviation ``noise`` mm).

    Returns
    -------
    SeedCurve
    """
    clean = seed_curve_points(n_points, R, a, b)
    noisy = clean + np.random.default_rng(seed).normal(0.0, noise, clean.shape)
    return SeedCurve(interpolate_points(noisy), interpolate_points(clean), noisy, clean)


class BladeSurface(NamedTuple):
    """A noisy blade-like surface and its truth (both interpolate grids on the same parameters)."""

    surface: BSplineSurface
    truth: BSplineSurface
    points: np.ndarray
    clean_points: np.ndarray


def blade_surface(shape=(50, 80), noise=0.02, seed=7, span=100.0, chord=30.0):
    r"""Twisted, cambered blade-like surface sampled on a grid, plus noise.

    Span direction ``u`` (length ``span``), chord direction ``v`` (length ``chord``);
    the section at height :math:`z = \text{span}\,u` is the cambered arc
    :math:`y = c\,(0.12 + 0.04\sin 3\pi u)\,\sin(\pi v)\,(1 + 0.5 v)`,
    :math:`x = c\,(v - 1/2)` with chord :math:`c = \text{chord}\,(1 - 0.3u)`, rotated by
    a twist of :math:`1.2\,u` rad and leaned by :math:`x \mathrel{+}= 2\sin(2\pi u)`.

    Parameters
    ----------
    shape : (int, int)
        Grid points ``(N_u, N_v)``; the nets have ``(N_u + 2, N_v + 2)`` poles.
    noise : float
        Standard deviation of the Gaussian noise added to every point (mm).

    Returns
    -------
    BladeSurface
    """
    u = np.linspace(0.0, 1.0, shape[0])[:, None]
    v = np.linspace(0.0, 1.0, shape[1])[None, :]
    c = chord * (1.0 - 0.3 * u)
    x0 = c * (v - 0.5)
    y0 = c * (0.12 + 0.04 * np.sin(3 * np.pi * u)) * np.sin(np.pi * v) * (1 + 0.5 * v)
    twist = 1.2 * u
    x = x0 * np.cos(twist) - y0 * np.sin(twist) + 2.0 * np.sin(2 * np.pi * u)
    y = x0 * np.sin(twist) + y0 * np.cos(twist)
    z = span * u + 0.0 * v
    clean = np.stack([x, y, z], axis=2)
    noisy = clean + np.random.default_rng(seed).normal(0.0, noise, clean.shape)
    return BladeSurface(interpolate_grid(noisy), interpolate_grid(clean), noisy, clean)


class PatchGrid(NamedTuple):
    """Patches of one surface and the joins between them (:func:`patch_grid`,
    :func:`patch_network`)."""

    patches: list
    joins: list


def _grid_truth(x, y):
    return np.stack([x, y, 0.3 * np.sin(2 * x) * np.cos(1.5 * y) + 0.1 * x * y], -1)


def patch_grid(noise=0.003, seed=1, poles=12):
    r"""Four patches of :math:`z = 0.3 \sin 2x \cos 1.5y + 0.1 xy` on
    :math:`[0, 2]^2`, a 2 x 2 grid of unit squares, each a bicubic least-squares fit of
    ``poles`` x ``poles`` on 60 x 60 samples with Gaussian ``noise`` on its interior poles
    (so the borders still meet, to about 1e-7, and the joins turn by several degrees).

    Patch 1 (x in [1, 2]) runs backwards in u, patch 3 (the corner square) has u along y:
    the joins tie sides of every kind, one of them reversed.

    Returns
    -------
    PatchGrid
        ``patches`` (four BSplineSurface on [0, 1]^2) and their four ``BorderJoin``.
    """
    space = SplineSpace.quasi_uniform(poles - 3, 3)
    s = np.linspace(0.0, 1.0, 60)
    fit = np.linalg.pinv(space.collocation(s).toarray())
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(s, s, indexing="ij")
    patches = []
    for x, y in ((u, v), (2 - u, v), (u, 1 + v), (1 + v, 1 + u)):
        net = np.einsum("ia,abd,jb->ijd", fit, _grid_truth(x, y), fit)
        net[1:-1, 1:-1] += rng.normal(0.0, noise, net[1:-1, 1:-1].shape)
        patches.append(BSplineSurface(net, space.knots, space.knots, 3, 3))
    joins = [BorderJoin(0, "u1", 1, "u1"), BorderJoin(0, "v1", 2, "v0"),
             BorderJoin(2, "u1", 3, "v0"), BorderJoin(1, "v1", 3, "u0", reversed=True)]
    return PatchGrid(patches, joins)


def patch_network(noise=0.003, seed=2):
    r"""Three bicubic patches of one span each, the unit squares at :math:`(0, 0)`,
    :math:`(1, 0)` and :math:`(0, 1)` of :math:`z = 0.3 \sin 2x \cos 1.5y + 0.1 xy` on
    :math:`[0, 2]^2`: an L.

    The surface is the bicubic least-squares fit with two uniform spans per direction on
    40 x 40 samples (C2 at :math:`x = 1` and :math:`y = 1`), cut into its four Bezier
    patches by inserting those knots to multiplicity 3 (:func:`~cq_fairing.core.patch_grid.insert_knot`),
    with Gaussian ``noise`` on the z of every pole of that 7 x 7 net: the patches share
    their borders pole for pole and the joins turn by a few degrees.  Each patch is
    already at its coarsest (4 x 4 poles), so a face-by-face search has nothing to remove,
    and the L is no rectangle of patches to merge into one surface.

    Returns
    -------
    PatchGrid
        ``patches`` (three BSplineSurface on [0, 1]^2) and their two ``BorderJoin``.
    """
    knots = SplineSpace.quasi_uniform(2, 3).knots
    knots = 2.0 * knots / knots[-1]
    s = np.linspace(0.0, 2.0, 40)
    fit = np.linalg.pinv(SplineSpace.from_knots(knots, 3).collocation(s).toarray())
    net = np.einsum("ia,abd,jb->ijd", fit, _grid_truth(*np.meshgrid(s, s, indexing="ij")),
                    fit)
    for axis in (0, 1):
        _, split = insert_knot(knots, 3, np.moveaxis(net, axis, 0), 1.0, 2)
        net = np.moveaxis(split, 0, axis)
    net[..., 2] += np.random.default_rng(seed).normal(0.0, noise, net.shape[:2])
    bezier = np.array([0.0] * 4 + [1.0] * 4)
    patches = [BSplineSurface(net[a:a + 4, b:b + 4].copy(), bezier, bezier, 3, 3)
               for a, b in ((0, 0), (3, 0), (0, 3))]
    return PatchGrid(patches, [BorderJoin(0, "u1", 1, "u0"), BorderJoin(0, "v1", 2, "v0")])
