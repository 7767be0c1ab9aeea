r"""The curves' default method ``"auto"``: the adaptive fit chosen per curve,
:func:`fair_curve_auto`.

No one fit is best for every curve.  On a noisy scan the ``"faithful"`` fit
(:mod:`cq_fairing.core.fidelity`) stops where the residual reaches the noise and keeps
the noise-free shape, while the compact fit bends the shape by up to the whole
tolerance.  On a clean curve the faithful fit follows the shape far below the tolerance
with many poles, and the compact fit is the answer.  A smooth shape needs fewer poles at
a higher degree, a curve with a corner fewer at degree 3.  So the candidates are fitted
and one is chosen by the rule stated with the options (:mod:`cq_fairing.core.options`,
"The curves' default"): the compact fit at the default degree sets a pole budget; a
noise-limited faithful fit within it wins, the one with the fewest poles; else the
compact fit with the fewest poles over the degrees.

The fits share their stages (:class:`~cq_fairing.core.adaptive_curve.CurveSearch`), and
a stage runs only where its result can change the choice.  Each candidate has a lower
bound on its poles from its cheap part: the faithful fit's first target (its count
from residual variances only, which stops once the count is past the budget), the
compact fit's searched space (the polish keeps the poles, the final check only adds).
The candidates are finished in increasing order of that bound until the next bound
exceeds the fewest poles found.  Where a faithful fit may start within the poles of the
budget's searched space and that space passes the final check, the budget is those
poles, and the budget's fit is polished only if it is chosen.  The choice is that of
fitting every candidate in full, to the bit.
"""

from functools import partial

import numpy as np

from ..errors import ToleranceNotMetError
from .accuracy import check_tolerance, fair_curve_to_tolerance
from .adaptive_curve import CurveSearch
from .fairness import curvature_derivative_energy
from .options import checked_target_degree

__all__ = ["RAISED_DEGREES", "fair_curve_auto", "candidate_degrees"]

#: Degrees tried beside the default one for a polynomial source of degree >= 3.
RAISED_DEGREES = (5, 7)


def candidate_degrees(curve, target_degree=None):
    """The target degrees ``"auto"`` fits at, the default one first.

    Parameters
    ----------
    curve : BSplineCurve
        The source.
    target_degree : int, optional
        An explicit degree: the only one.

    Returns
    -------
    tuple of int
        ``(target_degree,)``; else ``(min(3, p),)`` for a rational source or one of
        degree ``p`` 1 or 2 (their weights and low degree are exact geometry: conics,
        polygons), ``(3,) + RAISED_DEGREES`` for a polynomial source of degree >= 3.
    """
    degree = checked_target_degree(target_degree, curve.degree)
    if target_degree is not None or curve.is_rational or curve.degree < 3:
        return (degree,)
    return (degree,) + RAISED_DEGREES


def fair_curve_auto(curve, tol, *, target_degree=None):
    """Fair ``curve`` within ``tol`` by the fit the rule of this module chooses.

    Parameters
    ----------
    curve : BSplineCurve
        Validated source curve.
    tol : float
        Largest allowed deviation (true closest-point distance, both ways).
    target_degree : int, optional
        Fit at this degree only; default: the candidates of :func:`candidate_degrees`.

    Returns
    -------
    FairResult
        The chosen fit, with ``choice`` the explicit options of
        :func:`~cq_fairing.core.fairing.fair_curve` that give the same curve:
        ``{"method": "adaptive", "objective": "faithful" or "compact", "target_degree":
        p}``, or ``{"method": "wavelet"}`` (with ``"target_degree"`` if one was given).

    Raises
    ------
    InvalidToleranceError
        ``tol`` not positive and finite.
    ToleranceNotMetError
        Neither an adaptive fit nor the wavelet search meets ``tol`` (the wavelet
        search's refusal).
    """
    tol = check_tolerance(tol)
    degrees = candidate_degrees(curve, target_degree)
    searches = [CurveSearch(curve, tol, p) for p in degrees]
    try:
        most = _budget(searches)
    except ToleranceNotMetError:
        wavelet = fair_curve_to_tolerance(curve, tol, target_degree=target_degree)
        given = {} if target_degree is None else {"target_degree": degrees[0]}
        return wavelet.replace(choice={"method": "wavelet", **given})
    quiet = _fewest([(_faithful_poles(search, most), partial(_quiet, search, most))
                     for search in searches])
    if quiet is not None:
        return _chosen(quiet, "faithful")
    return _chosen(_fewest([(_compact_poles(search), partial(_compact, search))
                            for search in searches]), "compact")


def _budget(searches):
    """The pole budget ``B``: the poles of the compact fit at the first degree.

    Its search ends on a space of ``D`` poles; the polish keeps them and the final
    check only adds poles, and none when the unpolished fit passes it (the check backs
    the polish off down to that fit).  So where that fit passes and a faithful fit may
    start within ``D`` poles, ``B = D`` without the polish; else the fit is finished.

    Raises
    ------
    ToleranceNotMetError
        The compact fit at the first degree does not meet tol.
    """
    budget = searches[0]
    space, faired, _, _ = budget.compact()
    fewest_quiet = min(_faithful_poles(search, space.dimension) for search in searches)
    if fewest_quiet <= space.dimension and budget.holds(faired):
        return space.dimension
    return _compact_fit(budget).curve.n_poles


def _faithful_poles(search, ceiling):
    """Poles of the faithful fit's first target (a lower bound of its poles), or
    infinity where they are found to exceed ``ceiling`` (its count search stops there)."""
    count = search.faithful_count(ceiling)[0]
    return np.inf if count is None else search.family(count).dimension


def _quiet(search, most):
    """The noise-limited faithful fit within ``most`` poles, else ``None`` (also where
    its final check fails up to the source's span count: it does not meet tol)."""
    try:
        fit = search.noise_limited(most)
    except ToleranceNotMetError:
        return None
    return fit if fit is not None and fit.curve.n_poles <= most else None


def _compact_poles(search):
    """Poles of the compact search's space, a lower bound of the compact fit's poles;
    infinite where no adaptive target meets tol."""
    try:
        return search.compact()[0].dimension
    except ToleranceNotMetError:
        return np.inf


def _compact(search):
    """The compact adaptive fit of ``search``, or ``None`` where none meets ``tol``."""
    try:
        return _compact_fit(search)
    except ToleranceNotMetError:
        return None


def _compact_fit(search):
    """The compact adaptive fit of ``search``, computed once."""
    return search.once("compact fit", lambda: search.adaptive("compact"))


def _fewest(candidates):
    """The fit with the fewest poles (ties: the least curvature-derivative energy, then
    the first), or ``None``.

    ``candidates`` are pairs ``(lower, make)`` in the rule's order: ``make()`` returns a
    fit with at least ``lower`` poles, or ``None`` (always where ``lower`` is infinite).
    They are made in increasing order of ``lower``, and only while ``lower`` does not
    exceed the fewest poles made so far: a candidate beyond it can neither win nor tie.
    """
    made, fewest = {}, np.inf
    for i in sorted(range(len(candidates)), key=lambda i: candidates[i][0]):
        lower, make = candidates[i]
        if lower == np.inf or lower > fewest:
            break
        fit = make()
        if fit is not None:
            made[i] = fit
            fewest = min(fewest, fit.curve.n_poles)
    if not made:
        return None
    return min((made[i] for i in sorted(made)),
               key=lambda fit: (fit.curve.n_poles, curvature_derivative_energy(fit.curve)))


def _chosen(best, objective):
    """``best`` with its ``choice`` filled."""
    return best.replace(choice={"method": "adaptive", "objective": objective,
                                "target_degree": best.curve.degree})
