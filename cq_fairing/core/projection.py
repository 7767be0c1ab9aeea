r"""Projection of curves and tensor-product surfaces onto a target space: the wavelet fairing.

Fairing from the source space :math:`S` to the target :math:`V_n` keeps the L2-best
approximation :math:`C_n = G_{nn}^{-1}\langle\Phi_n|\Phi_S\rangle C_S` and returns the
wavelet details, so the source is recovered exactly (Ji et al. 2014, eq. 5-14).
Surfaces apply the curve operators along u and then v (tensor product), which yields
the coarse net and the three detail nets u, v and uv (Ji et al., null-space paper,
Fig. 10).  Rational input is faired in homogeneous coordinates :math:`(w x, w)`.

Coordinates are centred first: the poles are translated by the centre :math:`c` of
their bounding box (:class:`~cq_fairing.core.robustness.LocalFrame`; homogeneous
:math:`(w (x - c), w)` for rational input), faired and translated back.  This is exact
in exact arithmetic because the rows of the projection sum to one, and in floating point
it keeps a part's accuracy relative to its own size rather than to its distance from
the origin.  Details are stored in the centred coordinates (for polynomial input they
do not depend on the translation at all, since wavelets are orthogonal to constants).
"""

from .geometry import BSplineCurve, BSplineSurface
from .plans import checked_plan
from .results import (
    FairResult,
    SurfaceFairResult,
    _along_v,
    _centre,
    _centred_coefficients,
    _uncentred,
    cartesian_poles,
    projection_step,
)

__all__ = ["project_curve", "project_surface"]


def project_curve(curve, target, schedule="auto"):
    """Fair ``curve`` into ``target`` space (trusted inputs). Returns :class:`FairResult`.

    The poles are centred on their bounding box before fairing (module notes).
    """
    spaces = checked_plan(curve.space, target, schedule)
    centre = _centre(curve)
    coefficients = _centred_coefficients(curve, centre)
    steps = [projection_step(a, b) for a, b in zip(spaces[:-1], spaces[1:])]
    for step in steps:
        coefficients = step.coarse(coefficients)
    poles, weights = cartesian_poles(coefficients, curve.is_rational)
    faired = BSplineCurve(_uncentred(poles, centre), target.knots, target.degree, weights)
    return FairResult(curve, faired, tuple(s.n_spans for s in spaces),
                      target.n_spans, schedule, tuple(steps), centre=centre)


def project_surface(surface, target_u, target_v, schedule="auto"):
    """Fair ``surface`` into ``target_u x target_v`` (trusted). Returns :class:`SurfaceFairResult`.

    The poles are centred on their bounding box before fairing (module notes).
    """
    plan_u = checked_plan(surface.u_space, target_u, schedule)
    plan_v = checked_plan(surface.v_space, target_v, schedule)
    levels = max(len(plan_u), len(plan_v)) - 1
    plan_u += [plan_u[-1]] * (levels + 1 - len(plan_u))
    plan_v += [plan_v[-1]] * (levels + 1 - len(plan_v))
    centre = _centre(surface)
    net = _centred_coefficients(surface, centre)
    steps = [(projection_step(plan_u[i], plan_u[i + 1]), projection_step(plan_v[i], plan_v[i + 1]))
             for i in range(levels)]
    for step_u, step_v in steps:
        net = _along_v(step_v.coarse, step_u.coarse(net))
    poles, weights = cartesian_poles(net, surface.is_rational)
    faired = BSplineSurface(_uncentred(poles, centre), target_u.knots, target_v.knots,
                            target_u.degree, target_v.degree, weights)
    scales = tuple((a.n_spans, b.n_spans) for a, b in zip(plan_u, plan_v))
    return SurfaceFairResult(surface, faired, scales, (target_u.n_spans, target_v.n_spans),
                             schedule, tuple(steps), centre=centre)
