r"""Noise level of a source and the discrepancy principle: how many poles keep the shape.

A tolerance bounds how far the faired geometry may move; it does not say where the
noise ends and the shape begins.  For a source sampled from a noisy scan the exact L2
projection :math:`P_T` onto a target space :math:`T` of dimension :math:`k` leaves, at
the source's :math:`N` Greville points :math:`\xi_i`, the residual across the geometry

.. math:: r_i = \Pi_i\bigl((P_T S)(\xi_i) - S(\xi_i)\bigr),
   \qquad \mathrm{E}\,\|r\|^2 \approx \sigma^2 (N - k) + \|b_T\|^2,

where :math:`\Pi_i` keeps the component along the source's unit normal (surfaces) or
orthogonal to its unit tangent (curves): a difference along the geometry only
reparametrizes it (a net with evenly spaced poles on clamped knots is not evenly
parametrized near its ends, and no coarser space reproduces that exactly).  The residual
is noise of standard deviation :math:`\sigma` per point (across the geometry) plus the
bias :math:`b_T` of the shape that :math:`T` cannot represent.  Hence

* **noise level**: on a target a third of the source's size the bias of a smooth shape
  is negligible, and :math:`\hat\sigma^2 = \|r\|^2 / (N - k)` estimates the noise
  (checked against the noise injected into the seed curve of Ji et al. 2014 at three
  levels, ``tests/core/test_fidelity.py``);
* **discrepancy principle** (Morozov): the smallest target whose residual variance
  :math:`\|r\|^2/(N-k)` is within :math:`(1+\delta)^2\hat\sigma^2` has removed the
  noise and kept the shape: any smaller target adds visible bias, any larger one keeps
  noise.

The residual needs no closest-point computation, so counting this way costs a few
projections and evaluations.
"""

import numpy as np

__all__ = ["DISCREPANCY", "CurveResidual", "SurfaceResidual", "noise_level", "noise_limit"]

DISCREPANCY = 0.10     # delta: residual variance within (1 + delta)^2 of the noise level
NOISE_FRACTION = 3     # the noise is measured on a target 1/NOISE_FRACTION of the source
NOISE_FLOOR = 1e-9     # noise below this fraction of the part's size is rounding


class CurveResidual:
    r"""Residual variance :math:`\|r\|^2 / (N - k)` of candidates at a source curve's
    Greville points (the source's points and unit tangents computed once).

    Parameters
    ----------
    source : BSplineCurve
        The curve being faired, ``N`` poles.
    """

    def __init__(self, source):
        self.xi = source.space.greville
        self.points = source.evaluate(self.xi)
        self.tangent = _unit(source.evaluate(self.xi, 1))

    def variance(self, faired):
        """Sum of the squared residual components orthogonal to the source's tangent,
        over :math:`N - k` (``faired`` has ``k < N`` poles)."""
        r = faired.evaluate(self.xi) - self.points
        r = r - np.einsum("qd,qd->q", r, self.tangent)[:, None] * self.tangent
        return float(np.sum(r * r)) / max(self.xi.size - faired.space.dimension, 1)


class SurfaceResidual:
    r"""Residual variance of candidates on the tensor grid of a source surface's
    Greville points (the source's points and unit normals computed once).

    The residual is taken along the source's unit normal (none where the normal
    vanishes, as at a collapsed border row; the whole residual for nets that are not
    three-dimensional).

    Parameters
    ----------
    source : BSplineSurface
    """

    def __init__(self, source):
        self.xu, self.xv = source.u_space.greville, source.v_space.greville
        self.points = source.evaluate_grid(self.xu, self.xv)
        self.normal = None
        if self.points.shape[-1] == 3:
            self.normal = _unit(np.cross(source.evaluate_grid(self.xu, self.xv, nu=1),
                                         source.evaluate_grid(self.xu, self.xv, nv=1)))

    def variance(self, faired):
        r""":math:`\|r\|^2 / (N_u N_v - k_u k_v)` for a ``faired`` net of ``k_u x k_v`` poles."""
        r = faired.evaluate_grid(self.xu, self.xv) - self.points
        if self.normal is not None:
            r = np.einsum("uvd,uvd->uv", r, self.normal)
        k = faired.u_space.dimension * faired.v_space.dimension
        return float(np.sum(r * r)) / max(self.xu.size * self.xv.size - k, 1)


def _unit(vectors):
    """Unit vectors along the last axis; the zero vector where the length vanishes."""
    length = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return np.divide(vectors, length, out=np.zeros_like(vectors),
                     where=length > 1e-12 * max(float(length.max()), 1e-300))


def noise_level(variance_at, size):
    r"""Estimated noise :math:`\hat\sigma` (3D RMS per point) of a source.

    Parameters
    ----------
    variance_at : callable
        ``variance_at(fraction)`` projects the source onto its own knot family scaled by
        ``fraction`` and returns the residual variance there.
    size : float
        The source's extent (bounding-box diagonal of its poles).

    Returns
    -------
    float
        :math:`\max(\sqrt{\mathrm{variance\_at}(1/3)},\ 10^{-9}\,\mathrm{size})`:
        below a billionth of the part's size the "noise" is rounding, and a
        noise-free source is then reduced to the smallest target that reproduces it.
    """
    return max(float(np.sqrt(variance_at(1.0 / NOISE_FRACTION))), NOISE_FLOOR * size)


def noise_limit(sigma, delta=DISCREPANCY):
    r"""The discrepancy bound: a residual variance within the noise is
    :math:`\le (1+\delta)^2\hat\sigma^2`."""
    return (1.0 + delta) ** 2 * sigma ** 2
