r"""The energy polish of an adaptive fit: the largest penalty within the tolerance.

The penalised projection :math:`(G_T + \lambda\, G^{(l)}_T)\, C = \langle\Phi_T|\Phi_S\rangle C_S`
with the largest :math:`\lambda` whose deviation stays within ``tol``; for surfaces the
constrained stages that grow :math:`\lambda` further while the patches nearest the
tolerance are weighted more (:mod:`cq_fairing.core.adaptive`, note 4).
"""


import numpy as np
import scipy.sparse as sp

from .gram import gram_matrix

GROWTH = 8.0         # the constrained polish multiplies lambda by this per stage


STAGES = 4           # at most this many stages


REWEIGHTS = 12       # reweighting rounds per stage


WEIGHT_AIM = 0.97    # patches above this fraction of tol get more weight ...


WEIGHT_POWER = 4     # ... by (deviation / (WEIGHT_AIM tol))^WEIGHT_POWER


MIN_GAIN = 0.8       # a stage must bring the energy below this fraction of the last


def _scaled_energy(space, l):
    r""":math:`G^{(l)}` scaled so that :math:`\lambda = 1` weighs it like :math:`G^{(0)}`."""
    e = gram_matrix(space, nu=l)
    g = gram_matrix(space)
    return e * (g.diagonal().sum() / max(e.diagonal().sum(), 1e-300))


def largest_penalty(trial_lam, tol, start, lo=-8.0, hi=3.0, steps=10):
    """Largest ``lambda = 10^x`` whose polished result stays within ``tol``: ``10^hi`` if
    it does, else a bisection on ``x`` in ``[lo, hi]`` (``steps`` halvings); ``(start,
    0.0)`` when not even ``10^lo`` does.

    ``trial_lam(lam) -> (faired, values, deviation)``; returns ``(trial, lam)``.
    """
    best, best_lam = start, 0.0
    f, v, e = trial_lam(10.0 ** hi)
    if e <= tol:
        return (f, v, e), 10.0 ** hi
    f, v, e = trial_lam(10.0 ** lo)
    if e > tol:
        return best, best_lam
    best, best_lam = (f, v, e), 10.0 ** lo
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        f, v, e = trial_lam(10.0 ** mid)
        if e <= tol:
            best, best_lam, lo = (f, v, e), 10.0 ** mid, mid
        else:
            hi = mid
    return best, best_lam


def net_lengths(poles):
    r"""Mean polygon lengths :math:`(L_u, L_v)` of a net's rows along u and along v.

    Parameters
    ----------
    poles : ndarray, shape (k_u, k_v, d)

    Returns
    -------
    (float, float)
        Positive (a degenerate direction gets a billionth of the other's length); ``(1,
        1)`` for a net below ``1e-50`` in both directions (all poles coincident, or a
        model so small that the energy's fifth powers of its lengths would underflow:
        any net is then within every admissible tolerance).
    """
    lu = float(np.mean(np.linalg.norm(np.diff(poles, axis=0), axis=-1).sum(axis=0)))
    lv = float(np.mean(np.linalg.norm(np.diff(poles, axis=1), axis=-1).sum(axis=1)))
    if max(lu, lv) < 1e-50:
        return 1.0, 1.0
    floor = 1e-9 * max(lu, lv)
    return max(lu, floor), max(lv, floor)


def variation_energy_matrix(space_u, space_v, lengths):
    r"""Curvature-variation energy of a tensor net in the net's physical scale.

    With :math:`s = L_u u`, :math:`t = L_v v` (the net's lengths, :func:`net_lengths`),

    .. math:: E = \iint S_{sss}^2 + 3 S_{sst}^2 + 3 S_{stt}^2 + S_{ttt}^2 \,ds\,dt
        = \sum_{a + b = 3} \binom{3}{a} \frac{c^T (G^{(a)}_u \otimes G^{(b)}_v) c}
          {L_u^{2a - 1} L_v^{2b - 1}},

    the tensor counterpart of the curves' :math:`G^{(3)}` (Eck and Hadenfeld, ``l = 3``):
    it penalises the change of curvature along every direction, which is what the
    thin-plate (second-order) energy leaves alone.

    Returns
    -------
    scipy.sparse.csr_matrix, shape (k_u k_v, k_u k_v)
        Row-major net index ``i k_v + j``.
    """
    lu, lv = lengths
    return sum(w * sp.kron(gram_matrix(space_u, nu=a), gram_matrix(space_v, nu=3 - a))
               / (lu ** (2 * a - 1) * lv ** (5 - 2 * a))
               for a, w in ((3, 1.0), (2, 3.0), (1, 3.0), (0, 1.0))).tocsr()


def _constrained_stages(fit, spaces, faired, lam):
    r"""Spend the tolerance where the single-``lambda`` polish left it unused.

    The polish stops at the largest :math:`\lambda` whose deviation stays within tol,
    which is set by the few patches that reach tol first; everywhere else some budget is
    left.  Each stage here multiplies :math:`\lambda` by ``GROWTH`` and weighs the
    distance to the source per source patch (:mod:`cq_fairing.core.weighted`),

    .. math:: \min_C \sum_{\sigma\tau} w_{\sigma\tau}\,\|S - S_{src}\|^2_{\sigma\times\tau}
        + \lambda\, E(S),

    raising :math:`w` by :math:`(e_{\sigma\tau} / (a\,tol))^q` (``a = WEIGHT_AIM``,
    ``q = WEIGHT_POWER``) on the patches whose largest search-grid deviation
    :math:`e_{\sigma\tau}` exceeds ``a tol``,
    until the trial is within tol (iteratively reweighted least squares; the weights
    carry over to the next stage).  The stages approach
    :math:`\min E(S)` subject to the deviation limit at the samples.  They stop when a
    stage needs more than ``REWEIGHTS`` rounds, when a round's largest deviation exceeds
    the stage's first (the reweighting diverges: on the testtoler strip it went from 6.7
    to 19.8 tol in the second round and 228 tol in the twelfth, with weights up to
    1e47; on the blade it may rise by 1 % in one round and still converge), or when a
    stage lowers the energy :math:`c^T K c` by less than ``1 - MIN_GAIN``.  Border rows
    (pinned) keep the single ``lam``.

    Returns
    -------
    list of (BSplineSurface, float, ndarray)
        ``(faired, lambda, weights)`` per accepted stage, each lower in energy than the
        one before; empty when ``lam`` is 0 (no budget left to spend).
    """
    if lam <= 0.0:
        return []
    energy_matrix = fit._energy(*spaces)

    def energy(surface):
        c = surface.poles.reshape(-1, surface.poles.shape[-1])
        return float(np.einsum("id,id->", c, energy_matrix @ c))

    stages, best = [], energy(faired)
    weights = np.ones(fit.span_shape)
    for stage in range(1, STAGES + 1):
        stage_lam = lam * GROWTH ** stage
        first = None
        for _ in range(REWEIGHTS):
            staged, values, e = fit.trial(*spaces, stage_lam, weights, edge_lam=lam)
            first = e if first is None else first
            if e <= fit.tol or e > first:
                break
            excess = fit.span_max(values) / (WEIGHT_AIM * fit.tol)
            weights = weights * np.maximum(excess, 1.0) ** WEIGHT_POWER
        if e > fit.tol:
            break
        value = energy(staged)
        if value < best:
            stages.append((staged, stage_lam, weights.copy()))
        if value > MIN_GAIN * best:
            break
        best = value
    return stages
