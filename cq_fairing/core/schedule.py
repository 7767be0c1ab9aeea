r"""Which spaces a fairing passes through: direct ARWFA, DWFA chains, the hybrid schedule.

* ``"direct"``: one ARWFA step from the source to :math:`V_n`; the result is the
  L2-best approximation in :math:`V_n`.
* ``"hybrid"`` (Ji et al. 2014, section 3; patent CN103984810 steps 2-3): ARWFA from
  the source to the largest dyadic scale :math:`2^J \le m`, DWFA halvings
  :math:`2^J \to 2^{J-1} \to \dots \to 2^i`, the smallest dyadic scale with
  :math:`2^i \ge n`, then a last ARWFA step to :math:`n`.  The dyadic spaces are nested,
  so the middle steps compose exactly; the last step projects the :math:`V_{2^i}`
  curve, not the source, so the result differs from ``"direct"`` when :math:`V_n`
  is not inside :math:`V_{2^i}`.
* ``"auto"``: the patent's rule.  When the source is quasi-uniform with a dyadic
  scale :math:`m = 2^j` and :math:`n = 2^i`, the DWFA chain (exactly the direct result);
  otherwise ``"direct"``, which is exact and, with banded algebra, as fast.
"""

import numpy as np

from ..errors import InvalidInputError
from .spaces import SplineSpace

__all__ = ["SCHEDULES", "plan_spaces"]

SCHEDULES = ("auto", "direct", "hybrid")


def _is_power_of_two(value):
    return value >= 1 and (value & (value - 1)) == 0


def _dyadic_chain(start_exp, stop_exp, degree, domain):
    return [SplineSpace.quasi_uniform(2 ** e, degree, domain)
            for e in range(start_exp, stop_exp - 1, -1)]


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
        raise InvalidInputError(
            f"schedule must be one of {SCHEDULES}, got {schedule!r}."
        )
    if source.same_as(target) or schedule == "direct":
        return [source] if source.same_as(target) else [source, target]
    n = target.n_spans
    p, domain = target.degree, target.domain
    uniform_pair = (target.is_quasi_uniform and source.is_quasi_uniform
                    and source.degree == p)
    m = source.n_spans
    if schedule == "auto":
        if uniform_pair and _is_power_of_two(m) and _is_power_of_two(n) and n < m:
            exps = range(int(np.log2(m)) - 1, int(np.log2(n)) - 1, -1)
            return [source] + [SplineSpace.quasi_uniform(2 ** e, p, domain) for e in exps]
        return [source, target]
    # hybrid
    if not target.is_quasi_uniform:
        return [source, target]
    top = int(np.floor(np.log2(max(m, 1))))
    bottom = int(np.ceil(np.log2(n)))
    if top < bottom:
        return [source, target]
    chain = _dyadic_chain(top, bottom, p, domain)
    if uniform_pair and chain[0].same_as(source):
        chain = chain[1:]
    spaces = [source] + chain
    if not spaces[-1].same_as(target):
        spaces.append(target)
    return spaces
