r"""Eck-Hadenfeld local energy fairing of B-spline curves and surfaces.

Curves (Eck and Hadenfeld, eq. 14-21).  The energy of the ``l``-th derivative,
:math:`E_l = \int |C^{(l)}|^2 dt = \sum_{i,j} G_{ij}\, d_i\cdot d_j` with
:math:`G = \langle\Phi^{(l)}|\Phi^{(l)}\rangle` (exact Gram matrix of derivatives), is a
quadratic function of one control point :math:`d_r` with Hessian :math:`2 G_{rr} I`; its
minimiser is the affine combination

.. math:: \tilde d_r = \sum_{i\ne r} \gamma_i d_i, \qquad
          \gamma_i = -\frac{\int_a^b N_i^{(l)} N_r^{(l)}\,dt}{\int_a^b (N_r^{(l)})^2\,dt}
          = -\frac{G_{ir}}{G_{rr}}     \qquad (17\text{-}20)

and :math:`\sum_{i\ne r}\gamma_i = 1` (eq. 21) because :math:`\sum_i N_i^{(l)} \equiv 0`.
The level sets of :math:`E_l(d_r)` are spheres around :math:`\tilde d_r`, so the best
position within the distance tolerance :math:`\delta` of the *original* point
:math:`d_r^0` is :math:`d_r^0 + (\tilde d_r - d_r^0)\min(1, \delta/|\tilde d_r - d_r^0|)`.
Each step moves the control point whose move lowers the energy most,

.. math:: \Delta E_r = G_{rr}\,(|d_r - \tilde d_r|^2 - |x_r - \tilde d_r|^2),

until the largest reduction is below ``rtol`` times the energy (or ``max_steps``).
Points more than the degree apart share no span and do not interact, so every point
whose reduction is the largest within that distance is moved in the same round:
exactly the greedy steps, taken in parallel where they are independent.
Because every control point stays within :math:`\delta` of its original and the
B-splines are a non-negative partition of unity,
:math:`|C(t) - C^0(t)| \le \max_i |d_i - d_i^0| \le \delta`: the faired curve is within
the tolerance everywhere (same-parameter, hence also true distance).  The number of
control points and the knots are kept; the end points are fixed.

Surfaces: the same step for the thin-plate energy
:math:`\iint |S_{uu}|^2 + 2|S_{uv}|^2 + |S_{vv}|^2`, whose matrix is
:math:`K = G^{(2)}_u\otimes G^{(0)}_v + 2\,G^{(1)}_u\otimes G^{(1)}_v + G^{(0)}_u\otimes G^{(2)}_v`.
Control points more than the bandwidth apart do not interact, so the net is updated in
colour classes ``(i mod (p_u+1), j mod (p_v+1))``, each class all at once (every point of
a class moves exactly to its constrained local minimiser), sweep after sweep; the
boundary ring of the net is fixed.

References
----------
M. Eck, J. Hadenfeld, *Local energy fairing of B-spline curves*, Computing Suppl. 10
(1995), eq. 14-22.
"""

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidInputError, UnsupportedGeometryError
from .accuracy import check_tolerance
from .gram import gram_matrix
from .probes import CurveProbe, SurfaceProbe
from .results import FairResult, SurfaceFairResult

__all__ = ["energy_weights", "energy_matrix", "fair_curve_energy", "fair_surface_energy"]


def _check_l(l, degree):
    if isinstance(l, bool) or not isinstance(l, (int, np.integer)) or l not in (2, 3):
        raise InvalidInputError(f"energy derivative order l must be 2 or 3, got {l!r}.")
    if l > degree:
        raise InvalidInputError(
            f"the energy of derivative l={l} vanishes for degree {degree}; use l <= degree."
        )


def energy_weights(space, r, l=2):
    r"""The weights :math:`\gamma_i` of eq. 18 for control point ``r`` (exact).

    Parameters
    ----------
    space : SplineSpace
    r : int
        Control point index.
    l : {2, 3}

    Returns
    -------
    indices : ndarray of int
        The neighbours :math:`i \ne r` with :math:`i_0 \le i \le i_1` (eq. 20).
    gamma : ndarray
        Their weights; they sum to 1 (eq. 21).
    """
    _check_l(l, space.degree)
    g = gram_matrix(space, nu=l).tocsc()
    col = g[:, r].toarray().ravel()
    k = space.degree + 1
    lo, hi = max(0, r - k + 1), min(r + k - 1, space.dimension - 1)
    idx = np.array([i for i in range(lo, hi + 1) if i != r])
    return idx, -col[idx] / col[r]


def energy_matrix(space, l=2):
    r""":math:`G = \langle\Phi^{(l)}|\Phi^{(l)}\rangle`, sparse (the curve energy is :math:`\sum_d c_d^T G c_d`)."""
    return gram_matrix(space, nu=l).tocsr()


def _constrained(target, origin, tol):
    """Point nearest ``target`` within the ball of radius ``tol`` around ``origin``."""
    step = target - origin
    length = np.linalg.norm(step, axis=-1, keepdims=True)
    scale = np.minimum(1.0, tol / np.maximum(length, 1e-300))
    return origin + step * scale


def fair_curve_energy(curve, tol, *, l=3, rtol=1e-6, max_steps=None, fixed=1):
    """Eck-Hadenfeld local energy fairing of a polynomial B-spline curve within ``tol``.

    Parameters
    ----------
    curve : BSplineCurve
        Polynomial (non-rational) source.
    tol : float
        Largest distance any control point (hence any curve point) may move, ``> 0``.
    l : {2, 3}
        Derivative whose energy is minimised.
    rtol : float
        Stop when the best single-point reduction is below ``rtol`` times the energy.
    max_steps : int, optional
        Default ``50 * number of poles``.
    fixed : int
        Control points kept at each end (1 keeps the end points).

    Returns
    -------
    FairResult
        Same poles count and knots; ``details`` empty, ``n`` the source spans,
        ``max_deviation`` the measured true deviation, ``evaluations`` the steps taken.

    Raises
    ------
    InvalidToleranceError, UnsupportedGeometryError (rational curves), InvalidInputError
    """
    tol = check_tolerance(tol)
    if curve.is_rational:
        raise UnsupportedGeometryError(
            "energy fairing needs a polynomial (non-rational) curve; use method='wavelet' "
            "or 'adaptive' for rational curves."
        )
    _check_l(l, curve.degree)
    g = energy_matrix(curve.space, l).tocsc()
    origin = np.array(curve.poles, dtype=float)
    poles = origin.copy()
    k = poles.shape[0]
    diag = g.diagonal()
    movable = np.zeros(k, dtype=bool)
    movable[fixed:k - fixed] = True
    movable &= diag > 0
    grad = g @ poles
    energy = float(np.sum(poles * grad))

    def gain(idx):
        tilde = poles[idx] - grad[idx] / diag[idx, None]
        x = _constrained(tilde, origin[idx], tol)
        now = np.sum((poles[idx] - tilde) ** 2, axis=-1)
        after = np.sum((x - tilde) ** 2, axis=-1)
        return diag[idx] * (now - after), x

    idx_all = np.flatnonzero(movable)
    band = curve.degree
    max_steps = 50 * k if max_steps is None else max_steps
    steps = 0
    while steps < max_steps and idx_all.size:
        reduction = np.full(k, -np.inf)
        reduction[idx_all] = gain(idx_all)[0]
        chosen = _independent_maxima(reduction, band, rtol * max(energy, 1e-300))
        if chosen.size == 0:
            break
        chosen = chosen[: max_steps - steps]
        delta_e, x = gain(chosen)
        delta = x - poles[chosen]
        poles[chosen] = x
        grad += g[:, chosen] @ delta
        energy -= float(delta_e.sum())
        steps += chosen.size
    faired = type(curve)(poles, curve.knots, curve.degree, None)
    deviation = CurveProbe(curve).max_deviation(faired)[0]
    n = curve.space.n_spans
    return FairResult(source=curve, curve=faired, scales=(n,), n=n, schedule="energy",
                      steps=(), max_deviation=deviation, evaluations=steps)


def _independent_maxima(reduction, band, threshold):
    """Indices whose reduction exceeds ``threshold`` and every other within ``band``.

    Points more than ``band`` apart have no common span, so moving all of them at
    once equals moving them one after the other: each is the greedy choice of its
    neighbourhood (ties keep the lower index).
    """
    k = reduction.size
    padded = np.concatenate([np.full(band, -np.inf), reduction, np.full(band, -np.inf)])
    windows = np.lib.stride_tricks.sliding_window_view(padded, 2 * band + 1)
    best = windows.max(axis=1)
    chosen = np.flatnonzero((reduction >= best) & (reduction > threshold))
    if chosen.size > 1:
        keep = np.concatenate([[True], np.diff(chosen) > band])
        chosen = chosen[keep]
    return chosen[chosen < k]


def surface_energy_matrix(surface):
    r"""Thin-plate matrix :math:`K` (sparse, (k_u k_v)^2), row-major net index ``i k_v + j``."""
    us, vs = surface.u_space, surface.v_space
    terms = [(2, 0, 1.0), (1, 1, 2.0), (0, 2, 1.0)]
    return sum(w * sp.kron(gram_matrix(us, nu=a), gram_matrix(vs, nu=b))
               for a, b, w in terms).tocsr()


def fair_surface_energy(surface, tol, *, rtol=1e-6, max_sweeps=200):
    """Local thin-plate energy fairing of a polynomial surface within ``tol``.

    Parameters
    ----------
    surface : BSplineSurface
    tol : float
        Largest distance any control point (hence any surface point) may move.
    rtol : float
        Stop when a sweep lowers the energy by less than ``rtol`` times the energy.
    max_sweeps : int

    Returns
    -------
    SurfaceFairResult
        Same net size and knots, ``details`` empty, ``n`` the source spans.
    """
    tol = check_tolerance(tol)
    if surface.is_rational:
        raise UnsupportedGeometryError(
            "energy fairing needs a polynomial (non-rational) surface; use method='wavelet' "
            "or 'adaptive', which fair rational surfaces in homogeneous coordinates."
        )
    if min(surface.u_degree, surface.v_degree) < 2:
        raise UnsupportedGeometryError(
            f"thin-plate energy fairing needs degree >= 2 in u and v, this surface is "
            f"{surface.u_degree} x {surface.v_degree} (its second derivatives vanish along a "
            "degree-1 direction); use method='wavelet'.")
    ku, kv, d = surface.poles.shape
    K = surface_energy_matrix(surface)
    diag = K.diagonal()
    origin = surface.poles.reshape(ku * kv, d).astype(float)
    poles = origin.copy()
    ii, jj = np.divmod(np.arange(ku * kv), kv)
    interior = (ii > 0) & (ii < ku - 1) & (jj > 0) & (jj < kv - 1) & (diag > 0)
    cu, cv = surface.u_degree + 1, surface.v_degree + 1
    classes = [np.flatnonzero(interior & (ii % cu == a) & (jj % cv == b))
               for a in range(cu) for b in range(cv)]
    energy = float(np.sum(poles * (K @ poles)))
    sweeps = 0
    for sweeps in range(1, max_sweeps + 1):  # noqa: B007 (the count is reported after the loop)
        before = energy
        for idx in classes:
            if idx.size == 0:
                continue
            grad = K[idx] @ poles
            tilde = poles[idx] - grad / diag[idx, None]
            poles[idx] = _constrained(tilde, origin[idx], tol)
        energy = float(np.sum(poles * (K @ poles)))
        if before - energy <= rtol * max(energy, 1e-300):
            break
    faired = type(surface)(poles.reshape(ku, kv, d), surface.u_knots, surface.v_knots,
                           surface.u_degree, surface.v_degree, None)
    deviation = SurfaceProbe(surface, hold_grid=False).max_deviation(faired)[0]
    n = (surface.u_space.n_spans, surface.v_space.n_spans)
    return SurfaceFairResult(source=surface, surface=faired, scales=(n,), n=n,
                             schedule="energy", steps=(), max_deviation=deviation,
                             evaluations=sweeps)
