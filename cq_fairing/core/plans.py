r"""Target spaces and the plans of spaces a projection visits, checked for resolution.

A plan is the list of spaces from the source to the target that a schedule visits
(:mod:`cq_fairing.core.schedule`).  A step is resolved when
:math:`\langle\Phi_n|\Phi_S\rangle` has full row rank, so that the details and the exact
reconstruction exist (:mod:`cq_fairing.core.decomposition`).
"""

import numpy as np

from ..errors import InvalidInputError, InvalidTargetError
from .decomposition import decomposition
from .schedule import plan_spaces
from .spaces import SplineSpace

__all__ = ["target_space", "graded_space", "end_graded_space", "has_graded_spans",
           "direction_target", "resolved_plan", "checked_plan", "largest_resolved_scale"]


def _default_target_degree(source_degree):
    return min(3, source_degree)


def target_space(source, n, degree=None, grading="uniform"):
    """The target ``V_n`` on the source's domain, validated: quasi-uniform, with
    ``grading="source"`` graded like the source's spans (:func:`graded_space`), or with
    ``grading="ends"`` refined towards both ends (:func:`end_graded_space`).

    Raises
    ------
    InvalidTargetError
        If ``n`` is not an integer, below 1, or gives at least as many poles as the
        source has.
    """
    if degree is None:
        degree = _default_target_degree(source.degree)
    elif isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise InvalidInputError(
            f"target_degree must be an integer >= 1, got {degree!r}; e.g. target_degree=3.")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)):
        raise InvalidTargetError(f"target scale n must be an integer, got {n!r}.")
    k = source.dimension
    if n < 1 or n + degree > k:
        raise InvalidTargetError(
            f"target scale n must be between 1 and {k - degree} (n + {degree} poles, at "
            f"most the source's {k}), got n={n}."
        )
    if grading == "source":
        return graded_space(source, int(n), degree)
    if grading == "ends":
        return end_graded_space(int(n), degree, source.domain)
    return SplineSpace.quasi_uniform(int(n), degree, source.domain)


def end_graded_space(n, degree, domain):
    r"""The ``n``-span space of ``degree`` on ``domain`` :math:`[a, b]` whose spans shorten
    towards both ends, halfway between equal spans and the Chebyshev-Lobatto points:

    .. math:: t_i = a + (b - a)\left(\frac{i}{2n} + \frac{1 - \cos(\pi i / n)}{4}\right),
              \qquad i = 0..n,

    so the end spans are about :math:`2 / (2 + \pi) \approx 0.39` times the middle ones
    for large :math:`n`.  It suits a projection whose border rows are pinned to the
    source's border curves: the interior must bend to meet them, so the error gathers
    next to the borders (the noisy 50 x 80 blade at 0.05: 11 x 11 poles against 12 x 15
    quasi-uniform ones).
    """
    x = np.arange(n + 1) / n
    a, b = domain
    t = a + (b - a) * (0.5 * x + 0.25 * (1.0 - np.cos(np.pi * x)))
    t[0], t[-1] = a, b
    return SplineSpace(int(degree), np.concatenate([np.full(degree, a), t,
                                                    np.full(degree, b)]))


def has_graded_spans(space):
    """True when the breakpoints of ``space`` are not equally spaced (to 1e-9)."""
    steps = np.diff(space.breakpoints)
    return bool(steps.max() > steps.min() * (1.0 + 1e-9))


def graded_space(source, n, degree):
    r"""The ``n``-span space of ``degree`` whose breakpoints are the source's at equal
    steps of their index.

    With the source's breakpoints :math:`b_0 < \dots < b_m`, the target's are
    :math:`t_i = b(i m / n)`, :math:`i = 0..n`, where :math:`b(x)` interpolates
    :math:`b_j` linearly in :math:`j`: every target span covers :math:`m / n` source
    spans, so a source whose spans grow along a direction (a blade's spanwise stations)
    gets targets that grow alike.  Where :math:`n` divides :math:`m` the target's knots
    are the source's own (nested spaces); on equally spaced breakpoints it is the
    quasi-uniform :math:`V_n` itself.  It is the adaptive method's starting family
    (:func:`~cq_fairing.core.adaptive_knots.equidistributed_space` of the source's span
    density), computed on the index so that nested knots are the source's to the bit.
    """
    if not has_graded_spans(source):
        return SplineSpace.quasi_uniform(n, degree, source.domain)
    b = source.breakpoints
    t = np.interp(np.arange(n + 1) * ((b.size - 1) / n), np.arange(b.size), b)
    t[0], t[-1] = b[0], b[-1]
    return SplineSpace(int(degree), np.concatenate([np.full(degree, t[0]), t,
                                                    np.full(degree, t[-1])]))


def resolved_plan(source, target, schedule):
    """:func:`plan_spaces`, dropping top ladder levels the source cannot resolve.

    A non-uniform source can be locally coarser than the first uniform level of the
    ladder (its ``<Phi|Phi_S>`` is then rank deficient); the next lower level is tried,
    down to the direct step.

    Returns
    -------
    list of SplineSpace or None
        ``None`` when some step, even the direct one, is not resolved.
    """
    spaces = _reduced_plan(source, target, schedule)
    return None if _unresolved_step(spaces) else spaces


def checked_plan(source, target, schedule):
    """:func:`resolved_plan`, refusing a target the source does not resolve.

    Raises
    ------
    InvalidTargetError
        If ``<Phi_n|Phi_S>`` of a step lacks full row rank (the target is locally finer
        than the source, e.g. at clustered or repeated source knots): no details or
        exact reconstruction exist for it.
    """
    spaces = _reduced_plan(source, target, schedule)
    step = _unresolved_step(spaces)
    if step:
        raise InvalidTargetError(_unresolved_message(source, target, schedule, step))
    return spaces


def _reduced_plan(source, target, schedule):
    spaces = plan_spaces(source, target, schedule)
    while len(spaces) > 2 and not _resolves(spaces[0], spaces[1]):
        spaces = [spaces[0]] + spaces[2:]
    return spaces


def largest_resolved_scale(source, degree, schedule, below):
    """Largest ``n <= below`` whose ``V_n`` (of ``degree``) the source resolves; 0 if none."""
    for n in range(int(below), 0, -1):
        target = SplineSpace.quasi_uniform(n, degree, source.domain)
        if resolved_plan(source, target, schedule) is not None:
            return n
    return 0


def _resolves(source, target):
    return source.same_as(target) or decomposition(source, target).resolves_target


def _unresolved_step(spaces):
    """The first step ``(a, b)`` of a plan whose ``a`` does not resolve ``b``, else None."""
    for a, b in zip(spaces[:-1], spaces[1:]):
        if not _resolves(a, b):
            return a, b
    return None


def _unresolved_message(source, target, schedule, step):
    rank = decomposition(*step).matched_rank
    n = target.n_spans
    best = largest_resolved_scale(source, target.degree, schedule, n - 1)
    advice = (f"choose n <= {best}, the largest below {n} it resolves" if best else
              "no smaller target is resolved either")
    return (f"target n={n} ({target.dimension} poles of degree {target.degree}) is not "
            f"resolved by the source ({source.dimension} poles of degree {source.degree}): "
            f"<Phi|Phi_S> of the step to {step[1].n_spans} spans has rank {rank} < "
            f"{step[1].dimension} because the source's knots "
            "are locally sparser than the target's (clustered or repeated knots), so no "
            f"details or exact reconstruction exist; {advice}, or pass tol= to let accuracy "
            "control choose.")


def direction_target(space, n, degree):
    """Target space of one direction; ``None`` keeps the source space."""
    if n is None:
        return space
    return target_space(space, n, degree)
