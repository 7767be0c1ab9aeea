"""What fairing returns: :class:`FairResult`, :class:`SurfaceFairResult` and their details.

A result keeps the decomposition steps it went through, so the wavelet details and the
exact reconstruction are computed on demand (:attr:`FairResult.details`,
:meth:`FairResult.reconstruct`).  The helpers below move between Cartesian and homogeneous
coefficients and the centred coordinates the steps work in
(:mod:`cq_fairing.core.projection`).
"""

from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..errors import NumericalError
from .decomposition import decomposition
from .geometry import BSplineCurve, BSplineSurface
from .robustness import LocalFrame

__all__ = ["FairResult", "SurfaceFairResult", "SurfaceDetails", "projection_step",
           "homogeneous_coefficients", "cartesian_poles"]


class SurfaceDetails(NamedTuple):
    """The three detail nets of one surface level (any may have a zero-length axis).

    Attributes
    ----------
    u : ndarray, shape (k_u - r_u, r_v, d')   wavelets in u, scaling functions in v
    v : ndarray, shape (r_u, k_v - r_v, d')   scaling functions in u, wavelets in v
    uv : ndarray, shape (k_u - r_u, k_v - r_v, d')
    """

    u: np.ndarray
    v: np.ndarray
    uv: np.ndarray


class _Identity:
    """A decomposition step that keeps a direction unchanged."""

    def __init__(self, space):
        self.source = self.target = space

    def coarse(self, c):
        return np.asarray(c, dtype=float)

    def detail(self, c):
        c = np.asarray(c)
        return np.zeros((0,) + c.shape[1:])

    def reconstruct(self, coarse, detail):
        return np.asarray(coarse, dtype=float)


def projection_step(source, target):
    return _Identity(source) if source.same_as(target) else decomposition(source, target)


@dataclass(frozen=True, eq=False)
class FairResult:
    """Outcome of :func:`fair_curve`.

    Attributes
    ----------
    source : BSplineCurve
        The input curve.
    curve : BSplineCurve
        The faired curve in :math:`V_n`.
    details : tuple of ndarray
        Detail coefficients per level, finest first; level ``i`` has shape
        ``(k_i - k_{i+1}, d')`` with ``d' = d + 1`` for rational input (homogeneous).
        Computed on first access, so fairing alone never builds wavelets.
    scales : tuple of int
        Knot spans of every space visited, source first, ``n`` last.
    n : int
        The target scale (spans); ``curve`` has ``n + degree`` poles.
    schedule : str
    max_deviation, evaluations, table, fairness
        Filled by accuracy control and the measures (``None`` when not computed).
    centre : ndarray, shape (d,), optional
        Translation :math:`c` of the coordinates the steps work in (``None``: origin).
    choice : dict, optional
        What :func:`fair_curve`'s ``method="auto"`` chose with ``tol``: the explicit
        options that give the same curve, e.g. ``{"method": "adaptive", "objective":
        "faithful", "target_degree": 7}`` (:mod:`cq_fairing.core.auto_curve`); ``None``
        when the method was given (or with ``n``: the wavelet projection).
    """

    source: BSplineCurve
    curve: BSplineCurve
    scales: tuple
    n: int
    schedule: str
    steps: tuple = field(repr=False, default=())
    max_deviation: float = None
    evaluations: int = None
    table: tuple = None
    fairness: dict = None
    centre: np.ndarray = field(repr=False, default=None)
    choice: dict = None

    @cached_property
    def details(self):
        """Detail coefficients per level, finest first (computed on first access)."""
        coefficients = _centred_coefficients(self.source, self.centre)
        details = []
        for step in self.steps:
            details.append(step.detail(coefficients))
            coefficients = step.coarse(coefficients)
        return tuple(details)

    @property
    def poles(self):
        """Faired control points, shape (n + degree, d)."""
        return self.curve.poles

    @property
    def knots(self):
        return self.curve.knots

    @property
    def degree(self):
        return self.curve.degree

    @property
    def weights(self):
        return self.curve.weights

    def reconstruct(self, detail_weight=1.0):
        """Source poles from the faired poles and the details.

        Parameters
        ----------
        detail_weight : float, optional
            1 restores the source exactly when ``curve`` is the plain projection
            (``method="wavelet"``; ``"adaptive"`` with ``polish=False``); 0 gives the
            coarse curve expressed in the source space; values between restore part of
            the detail.  The details are those of the plain projection, so after a
            polished adaptive fit (``table`` ``lambda > 0``) or energy fairing (no
            details: same space) 1 gives the source plus the change the polish or the
            energy fairing made, not the source.

        Returns
        -------
        ndarray, shape (k, d)
        """
        coefficients = _centred_coefficients(self.curve, self.centre)
        for step, detail in zip(reversed(self.steps), reversed(self.details)):
            coefficients = step.reconstruct(coefficients, detail_weight * detail)
        return _uncentred(cartesian_poles(coefficients, self.source.is_rational)[0], self.centre)

    def replace(self, **changes):
        """A copy with some fields changed (used by accuracy control)."""
        return replace(self, **changes)


@dataclass(frozen=True, eq=False)
class SurfaceFairResult:
    """Outcome of :func:`fair_surface`.

    Attributes
    ----------
    source, surface : BSplineSurface
        Input and faired surface (``surface.poles`` has shape (n_u + p_u, n_v + p_v, d)).
    details : tuple of SurfaceDetails
        One per level, finest first.
    scales : tuple of (int, int)
        Spans (u, v) of every level visited, source first.
    n : (int, int)
    centre : ndarray, shape (d,), optional
        Translation :math:`c` of the coordinates the steps work in (``None``: origin).
    """

    source: BSplineSurface
    surface: BSplineSurface
    scales: tuple
    n: tuple
    schedule: str
    steps: tuple = field(repr=False, default=())
    max_deviation: float = None
    evaluations: int = None
    table: tuple = None
    fairness: dict = None
    centre: np.ndarray = field(repr=False, default=None)

    @cached_property
    def details(self):
        """:class:`SurfaceDetails` per level, finest first (computed on first access)."""
        net = _centred_coefficients(self.source, self.centre)
        details = []
        for step_u, step_v in self.steps:
            upper, lower = step_u.coarse(net), step_u.detail(net)
            details.append(SurfaceDetails(
                u=_along_v(step_v.coarse, lower),
                v=_along_v(step_v.detail, upper),
                uv=_along_v(step_v.detail, lower),
            ))
            net = _along_v(step_v.coarse, upper)
        return tuple(details)

    @property
    def poles(self):
        return self.surface.poles

    @property
    def u_knots(self):
        return self.surface.u_knots

    @property
    def v_knots(self):
        return self.surface.v_knots

    @property
    def degree(self):
        """``(u_degree, v_degree)`` of the faired surface."""
        return self.surface.u_degree, self.surface.v_degree

    @property
    def weights(self):
        return self.surface.weights

    def reconstruct(self, detail_weight=1.0):
        """Source net from the faired net and the three detail nets per level.

        ``detail_weight`` as for :meth:`FairResult.reconstruct`: 1 restores the source
        exactly when ``surface`` is the plain projection (``method="wavelet"``;
        ``"adaptive"`` with ``polish=False`` and free borders); after a polished or
        pinned adaptive fit or energy fairing it gives the source plus the change those
        made to the coarse net.

        Returns
        -------
        ndarray, shape (k_u, k_v, d)
        """
        net = _centred_coefficients(self.surface, self.centre)
        for (step_u, step_v), det in zip(reversed(self.steps), reversed(self.details)):
            w = detail_weight
            upper = _along_v(step_v.reconstruct, net, w * det.v)
            lower = _along_v(step_v.reconstruct, w * det.u, w * det.uv)
            net = step_u.reconstruct(upper, lower)
        return _uncentred(cartesian_poles(net, self.source.is_rational)[0], self.centre)

    def replace(self, **changes):
        return replace(self, **changes)


# -- helpers ----------------------------------------------------------------------------
def homogeneous_coefficients(geometry):
    return geometry.homogeneous() if geometry.is_rational else geometry.poles


def _centre(geometry):
    """Bounding-box centre of the poles, shape (d,) (the translation of :class:`LocalFrame`)."""
    return LocalFrame.around(geometry.poles).centre


def _centred_coefficients(geometry, centre):
    r"""Coefficients of the geometry translated by :math:`-c`.

    :math:`P - c` for polynomial geometry, :math:`(w (P - c), w)` for rational; ``centre``
    ``None`` means :math:`c = 0`.
    """
    if centre is None:
        return homogeneous_coefficients(geometry)
    moved = geometry.poles - centre
    if not geometry.is_rational:
        return moved
    w = geometry.weights[..., None]
    return np.concatenate([moved * w, w], axis=-1)


def _uncentred(poles, centre):
    """Cartesian poles translated back by :math:`+c`."""
    return poles if centre is None else poles + centre


def cartesian_poles(coefficients, rational):
    """Split homogeneous coefficients into (poles, weights); weights None if polynomial."""
    if not rational:
        return coefficients, None
    w = coefficients[..., -1]
    if np.any(w <= 0):
        raise NumericalError(
            f"fairing a rational geometry gave non-positive weights (min {w.min():.3g}); "
            "fair a non-rational approximation instead (convert the face first)."
        )
    return coefficients[..., :-1] / w[..., None], w


def _along_v(func, *arrays):
    """Apply a first-axis operator along axis 1 of (a, b, d) arrays."""
    moved = [np.swapaxes(a, 0, 1) for a in arrays]
    return np.swapaxes(func(*moved), 0, 1)
