r"""Which spaces a fairing passes through: ladder (default), direct ARWFA, seed hybrid.

* ``"auto"`` (the *ladder*): one ARWFA step from the source to :math:`V_{n 2^J}`, the
  largest space of that form with at most a third of the source's spans, then DWFA halvings
  :math:`V_{n 2^J} \supset V_{n 2^{J-1}} \supset \dots \supset V_n`.  The dyadic spaces
  anchored at ``n`` are nested, and for nested subspaces the composition of orthogonal
  projections is the projection onto the smallest, so the faired curve is *exactly* the
  direct L2-best approximation in :math:`V_n`.  Every step reduces the scale by a factor
  between 2 and 6, which keeps the compact wavelets well conditioned and their column
  windows short: with one direct step the
  condition number of :math:`\langle\Psi|\Psi\rangle` grows roughly like
  :math:`(m/n)^8` (reconstruction error 2e-11 at 1299 -> 78, 6e-6 at 300 -> 1, and
  no positive definite factor at 1299 -> 1), and for non-nested ratios above about
  0.4 the shortest windows stop being numerically dependent, so wavelets need long
  windows.  When the source is ``V_m`` with ``m = 2^j`` and ``n = 2^i`` this is the
  patent's pure DWFA chain.
* ``"direct"``: one ARWFA step, source to :math:`V_n` (the seeds' ARWFA).  Same
  coarse result; well conditioned for ratios up to about 16.
* ``"hybrid"`` (Ji et al. 2014, section 3; patent CN103984810 steps 2-3): ARWFA from
  the source to the largest power of two :math:`2^J \le m`, DWFA halvings down to the
  smallest :math:`2^i \ge n`, then a last ARWFA step to :math:`n`.  The last step
  projects the :math:`V_{2^i}` curve rather than the source, so the result differs
  from the L2-best one unless :math:`V_n \subset V_{2^i}`.
"""

import numpy as np

from ..errors import InvalidInputError
from .options import SCHEDULES
from .spaces import SplineSpace

__all__ = ["SCHEDULES", "plan_spaces"]


def plan_spaces(source, target, schedule="auto"):
    """The spaces visited from ``source`` to ``target`` (both included).

    Parameters
    ----------
    source, target : SplineSpace
    schedule : {"auto", "direct", "hybrid"}

    Returns
    -------
    list of SplineSpace
        ``[source, ..., target]``; consecutive spaces are one decomposition step.
    """
    if schedule not in SCHEDULES:
        raise InvalidInputError(f"schedule must be one of {SCHEDULES}, got {schedule!r}.")
    if source.same_as(target):
        return [source]
    if schedule == "direct" or not target.is_quasi_uniform:
        return [source, target]
    if schedule == "auto":
        return [source] + _ladder(source, target)
    return [source] + _seed_hybrid(source, target)


MAX_FIRST_STEP_RATIO = 1.0 / 3.0


def _ladder(source, target):
    """``[V_{n 2^J}, ..., V_{2n}, V_n]``; the top level has at most a third of the source's spans.

    A source that is itself on the ladder (``V_m`` with ``m = n 2^j``) continues with
    exact halvings.
    """
    source_spans = source.dimension - source.degree
    on_ladder = _is_on_ladder(source, target)
    levels = [target]
    while True:
        above = SplineSpace.quasi_uniform(2 * levels[-1].n_spans, target.degree, target.domain)
        if above.same_as(source) or above.n_spans >= source_spans:
            break  # the source itself, or one that equals it up to rounding of its knots
        if not on_ladder and above.n_spans > MAX_FIRST_STEP_RATIO * source_spans:
            break
        levels.append(above)
    return levels[::-1]


def _is_on_ladder(source, target):
    """True when the source is ``V_{n 2^j}`` of the target's degree (pure DWFA halvings)."""
    if not source.is_quasi_uniform or source.degree != target.degree:
        return False
    ratio = source.n_spans / target.n_spans
    return ratio == int(ratio) and int(ratio) & (int(ratio) - 1) == 0


def _seed_hybrid(source, target):
    """The seed's schedule: to 2^J <= m, halvings to 2^i >= n, ARWFA to n."""
    p, domain = target.degree, target.domain
    m, n = source.n_spans, target.n_spans
    top, bottom = int(np.floor(np.log2(m))), int(np.ceil(np.log2(n)))
    if top < bottom:
        return [target]
    chain = [SplineSpace.quasi_uniform(2 ** e, p, domain) for e in range(top, bottom - 1, -1)]
    chain = [space for space in chain if not space.same_as(source)]
    if not chain or not chain[-1].same_as(target):
        chain.append(target)
    return chain
