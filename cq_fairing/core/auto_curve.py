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
"""

from ..errors import ToleranceNotMetError
from .accuracy import check_tolerance, fair_curve_to_tolerance
from .adaptive_curve import fair_curve_adaptive, noise_limited_curve
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
    try:
        budget = fair_curve_adaptive(curve, tol, target_degree=degrees[0])
    except ToleranceNotMetError:
        wavelet = fair_curve_to_tolerance(curve, tol, target_degree=target_degree)
        given = {} if target_degree is None else {"target_degree": degrees[0]}
        return wavelet.replace(choice={"method": "wavelet", **given})
    most = budget.curve.n_poles
    quiet = [fit for fit in (noise_limited_curve(curve, tol, target_degree=p, most_poles=most)
                             for p in degrees)
             if fit is not None and fit.curve.n_poles <= most]
    if quiet:
        return _chosen(quiet, "faithful")
    return _chosen([budget] + [fit for fit in (_compact(curve, tol, p) for p in degrees[1:])
                               if fit is not None], "compact")


def _compact(curve, tol, degree):
    """The compact adaptive fit at ``degree``, or ``None`` where none meets ``tol``."""
    try:
        return fair_curve_adaptive(curve, tol, target_degree=degree)
    except ToleranceNotMetError:
        return None


def _chosen(fits, objective):
    """The fit with the fewest poles (ties: the least curvature-derivative energy), its
    ``choice`` filled."""
    best = min(fits, key=lambda fit: (fit.curve.n_poles,
                                      curvature_derivative_energy(fit.curve)))
    return best.replace(choice={"method": "adaptive", "objective": objective,
                                "target_degree": best.curve.degree})
