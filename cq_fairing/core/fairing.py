r"""Public fairing of curves and tensor-product surfaces: :func:`fair_curve`, :func:`fair_surface`.

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

from dataclasses import dataclass, field
from functools import cached_property
from typing import NamedTuple

import numpy as np

from ..errors import InvalidInputError, InvalidTargetError, NumericalError, UnsupportedGeometryError
from .decomposition import decomposition
from .geometry import BSplineCurve, BSplineSurface, make_curve, make_surface, split_pair
from .robustness import LocalFrame
from .schedule import plan_spaces
from .spaces import SplineSpace

__all__ = ["fair_curve", "fair_surface", "FairResult", "SurfaceFairResult",
           "SurfaceDetails", "target_space", "project_curve", "project_surface",
           "checked_plan", "resolved_plan", "largest_resolved_scale", "check_search_options"]


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


def _step(source, target):
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
        return _uncentred(_cartesian(coefficients, self.source.is_rational)[0], self.centre)

    def replace(self, **changes):
        """A copy with some fields changed (used by accuracy control)."""
        from dataclasses import replace

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
        return _uncentred(_cartesian(net, self.source.is_rational)[0], self.centre)

    def replace(self, **changes):
        from dataclasses import replace

        return replace(self, **changes)


# -- helpers ----------------------------------------------------------------------------
def _coefficients(geometry):
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
        return _coefficients(geometry)
    moved = geometry.poles - centre
    if not geometry.is_rational:
        return moved
    w = geometry.weights[..., None]
    return np.concatenate([moved * w, w], axis=-1)


def _uncentred(poles, centre):
    """Cartesian poles translated back by :math:`+c`."""
    return poles if centre is None else poles + centre


def _cartesian(coefficients, rational):
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


def _default_target_degree(source_degree):
    return min(3, source_degree)


def target_space(source, n, degree=None):
    """The quasi-uniform target ``V_n`` on the source's domain, validated.

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
    return SplineSpace.quasi_uniform(int(n), degree, source.domain)


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


def project_curve(curve, target, schedule="auto"):
    """Fair ``curve`` into ``target`` space (trusted inputs). Returns :class:`FairResult`.

    The poles are centred on their bounding box before fairing (module notes).
    """
    spaces = checked_plan(curve.space, target, schedule)
    centre = _centre(curve)
    coefficients = _centred_coefficients(curve, centre)
    steps = [_step(a, b) for a, b in zip(spaces[:-1], spaces[1:])]
    for step in steps:
        coefficients = step.coarse(coefficients)
    poles, weights = _cartesian(coefficients, curve.is_rational)
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
    steps = [(_step(plan_u[i], plan_u[i + 1]), _step(plan_v[i], plan_v[i + 1]))
             for i in range(levels)]
    for step_u, step_v in steps:
        net = _along_v(step_v.coarse, step_u.coarse(net))
    poles, weights = _cartesian(net, surface.is_rational)
    faired = BSplineSurface(_uncentred(poles, centre), target_u.knots, target_v.knots,
                            target_u.degree, target_v.degree, weights)
    scales = tuple((a.n_spans, b.n_spans) for a, b in zip(plan_u, plan_v))
    return SurfaceFairResult(surface, faired, scales, (target_u.n_spans, target_v.n_spans),
                             schedule, tuple(steps), centre=centre)


# -- public entry points -------------------------------------------------------------------
def fair_curve(poles, n=None, *, tol=None, knots=None, degree=None, weights=None,
               target_degree=None, schedule="auto", strategy="guaranteed", order=6,
               deviation="geometric", method="wavelet", objective="compact"):
    r"""Fair a B-spline curve by multiresolution (ARWFA / DWFA) projection.

    The faired curve is the L2-best approximation of the source in the quasi-uniform
    space :math:`V_n` (``n`` spans, ``n + target_degree`` poles):

    .. math:: C_n = \langle\Phi_n|\Phi_n\rangle^{-1} \langle\Phi_n|\Phi_S\rangle\, C_S

    (Ji et al. 2014, eq. 5-7); the wavelet details (eq. 8-10) are kept so that
    :meth:`FairResult.reconstruct` returns the source exactly (eq. 14).

    Parameters
    ----------
    poles : array_like, shape (k, d)
        Source control points (``d`` = 2 or 3; any 1..4 accepted).
    n : int, optional
        Target scale (knot spans).  Give ``n`` or ``tol``.
    tol : float, optional
        Largest allowed deviation (model units, e.g. mm) between source and faired
        curve; the fewest poles within it are searched (see
        :mod:`cq_fairing.core.accuracy`).
    knots : array_like, shape (k + degree + 1,), optional
        Clamped source knots; default quasi-uniform on [0, 1].
    degree : int, optional
        Source degree, default 3.
    weights : array_like, shape (k,), optional
        Positive weights of a rational source; fairing works on :math:`(w P, w)`.
    target_degree : int, optional
        Degree of the faired curve; default ``min(degree, 3)``.
    schedule : {"auto", "direct", "hybrid"}
        Spaces visited, see :mod:`cq_fairing.core.schedule`.
    strategy, order, deviation
        Accuracy-control settings of the tolerance search (with ``tol``, see
        :func:`~cq_fairing.core.accuracy.fair_curve_to_tolerance`); refused with ``n``.
    method : {"wavelet", "adaptive", "energy"}
        ``"adaptive"``: the exact L2 projection onto a target whose knots follow the
        error (:mod:`cq_fairing.core.adaptive`), usually fewer poles than the
        quasi-uniform ``V_n`` at the same ``tol``; one direct decomposition step, so
        ``details``/``reconstruct`` still work.  ``"energy"``: Eck-Hadenfeld local
        energy fairing (:mod:`cq_fairing.core.energy`, derivative ``l = 3``, ``l = 2``
        for quadratics; degree >= 2) that keeps the poles and moves none farther than
        ``tol``.  Both need ``tol`` and no ``n``.
    objective : {"compact", "faithful", "fair"}
        ``method="adaptive"`` only.  ``"compact"``: the fewest poles within ``tol``, the
        rest of the budget spent on fairness.  ``"faithful"``: stop where the residual
        is down to the source's estimated noise (:mod:`cq_fairing.core.fidelity`), or
        later if ``tol`` needs it: the noise removed, the shape kept.  ``"fair"``: the
        fairest of the compact answer and a few slightly larger targets, each polished
        (:func:`~cq_fairing.core.adaptive.fair_curve_adaptive`).

    Returns
    -------
    FairResult

    Raises
    ------
    InvalidInputError
        Bad poles, knots, weights or arguments; a tolerance-search option (``strategy``,
        ``order``, ``deviation``) other than its default given with ``n`` instead of ``tol``.
    InvalidTargetError
        ``n`` out of range.
    InvalidToleranceError, ToleranceNotMetError
        With ``tol``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2 * np.pi, 120)
    >>> poles = np.c_[np.cos(t), np.sin(t), 0.01 * np.sin(40 * t)]
    >>> result = fair_curve(poles, 27)
    >>> result.poles.shape
    (30, 3)
    >>> bool(np.allclose(result.reconstruct(), poles, atol=1e-10))
    True
    """
    curve = make_curve(poles, knots, degree, weights)
    method = _tolerance_method(method, objective, n, tol)
    check_search_options(n, tol, (("strategy", strategy, "guaranteed"), ("order", order, 6),
                                  ("deviation", deviation, "geometric")))
    if method == "energy":
        from .energy import fair_curve_energy

        if curve.degree < 2:
            raise UnsupportedGeometryError(
                "energy fairing needs degree >= 2 (the second derivatives of a degree-1 "
                "curve vanish between its poles); use method='wavelet'.")
        return fair_curve_energy(curve, tol, l=min(3, curve.degree))
    if method == "adaptive":
        from .adaptive import fair_curve_adaptive

        return fair_curve_adaptive(curve, tol, target_degree=target_degree,
                                   objective=objective)
    if (n is None) == (tol is None):
        raise InvalidInputError(
            "give exactly one of n (target scale) and tol (tolerance); "
            f"got n={n!r}, tol={tol!r}."
        )
    if tol is not None:
        from .accuracy import fair_curve_to_tolerance

        return fair_curve_to_tolerance(curve, tol, target_degree=target_degree,
                                       schedule=schedule, strategy=strategy,
                                       order=order, deviation=deviation)
    return project_curve(curve, target_space(curve.space, n, target_degree), schedule)


def fair_surface(poles, n=None, *, tol=None, u_knots=None, v_knots=None, degree=None,
                 weights=None, target_degree=None, schedule="auto",
                 strategy="guaranteed", deviation="geometric", method="wavelet",
                 objective="compact", borders="auto", window=None):
    r"""Fair a tensor-product B-spline surface (ARWFA along u and v).

    .. math:: C_n = A_u\, C\, A_v^T, \qquad
              A = \langle\Phi_n|\Phi_n\rangle^{-1}\langle\Phi_n|\Phi_S\rangle

    with the detail nets :math:`B_u C A_v^T` (u), :math:`A_u C B_v^T` (v) and
    :math:`B_u C B_v^T` (uv).

    Parameters
    ----------
    poles : array_like, shape (k_u, k_v, d)
    n : (int or None, int or None), optional
        Target scales (spans) in u and v; ``None`` in a direction keeps it unchanged
        (fairing in one direction only).  Give ``n`` or ``tol``.
    tol : float, optional
        Largest allowed deviation; the (n_u, n_v) with the fewest poles in total is
        searched.
    u_knots, v_knots : array_like, optional
        Clamped knot vectors; default quasi-uniform.
    degree : int or (int, int), optional
        Source degrees, default 3.
    weights : array_like, shape (k_u, k_v), optional
    target_degree : int or (int, int), optional
        Default ``min(source degree, 3)`` per direction.
    schedule : {"auto", "direct", "hybrid"}
    strategy, deviation
        Accuracy-control settings of the tolerance search (with ``tol``, see
        :func:`~cq_fairing.core.accuracy.fair_surface_to_tolerance`); refused with ``n``.
    method : {"wavelet", "adaptive", "energy"}
        ``"adaptive"``: exact projection onto u and v targets whose knots follow the
        error (:mod:`cq_fairing.core.adaptive`; polynomial surfaces).  ``"energy"``:
        local thin-plate energy fairing within ``tol`` that keeps the net size
        (:mod:`cq_fairing.core.energy`).  Both need ``tol`` and no ``n``.
    objective : {"compact", "faithful", "fair"}
        ``method="adaptive"`` only, as for :func:`fair_curve`.
    borders : {"auto", "free", "pinned"}
        ``method="adaptive"`` only: the target's border rows, see
        :func:`~cq_fairing.core.adaptive.fair_surface_adaptive` (``"free"`` is the plain
        L2 projection, exact reconstruction and often the faster search; ``"pinned"``
        keeps the corners; ``"auto"`` pins them only when the net gets smaller).
    window : (u0, u1, v0, v1), optional
        With ``tol``: measure the deviation only in this parameter box (a trimmed face's
        UV box), both ways; default the whole domain
        (:func:`~cq_fairing.core.accuracy.fair_surface_to_tolerance`; for
        ``method="adaptive"`` the ``window`` of
        :func:`~cq_fairing.core.adaptive.fair_surface_adaptive`).  Refused with ``n`` and
        with ``method="energy"``.

    Returns
    -------
    SurfaceFairResult

    Raises
    ------
    InvalidInputError
        Bad poles, knots, weights or arguments; ``strategy``, ``deviation`` or ``window``
        other than its default given with ``n`` instead of ``tol``.
    InvalidTargetError, InvalidToleranceError, ToleranceNotMetError
    """
    surface = make_surface(poles, u_knots, v_knots, degree, weights)
    method = _tolerance_method(method, objective, n, tol, borders, window)
    check_search_options(n, tol, (("strategy", strategy, "guaranteed"),
                                  ("deviation", deviation, "geometric"), ("window", window, None)))
    if method == "energy":
        from .energy import fair_surface_energy

        return fair_surface_energy(surface, tol)
    if method == "adaptive":
        from .adaptive import fair_surface_adaptive

        return fair_surface_adaptive(surface, tol,
                                     target_degree=split_pair(target_degree, "target_degree"),
                                     objective=objective, borders=borders, window=window)
    if (n is None) == (tol is None):
        raise InvalidInputError(
            "give exactly one of n ((n_u, n_v) target scales) and tol (tolerance); "
            f"got n={n!r}, tol={tol!r}."
        )
    tdu, tdv = split_pair(target_degree, "target_degree")
    if tol is not None:
        from .accuracy import fair_surface_to_tolerance

        return fair_surface_to_tolerance(surface, tol, target_degree=(tdu, tdv),
                                         schedule=schedule, strategy=strategy,
                                         deviation=deviation, window=window)
    nu, nv = split_pair(n, "n")
    target_u = _direction_target(surface.u_space, nu, tdu)
    target_v = _direction_target(surface.v_space, nv, tdv)
    return project_surface(surface, target_u, target_v, schedule)


METHODS = ("wavelet", "adaptive", "energy")


def _tolerance_method(method, objective, n, tol, borders="auto", window=None):
    """Validate ``method`` (and ``objective``, ``borders``, which belong to the adaptive
    method, and ``window``, which belongs to the tolerance searches); the tolerance-only
    methods need ``tol``, no ``n``."""
    if method not in METHODS:
        raise InvalidInputError(f"method must be one of {METHODS}, got {method!r}.")
    for name, value, default in (("objective", objective, "compact"), ("borders", borders, "auto")):
        if method != "adaptive" and value != default:
            raise InvalidInputError(
                f"{name}={value!r} applies to method='adaptive' only, got method={method!r}; "
                f"add method='adaptive' or drop {name}.")
    if method == "energy" and window is not None:
        raise InvalidInputError(
            f"window applies to the tolerance searches of method='wavelet' and 'adaptive', "
            f"got window={window!r} with method='energy', which moves every pole within "
            "tol; drop window or use another method.")
    if method != "wavelet" and (n is not None or tol is None):
        what = ("keeps the control points" if method == "energy"
                else "chooses the target itself")
        raise InvalidInputError(
            f"method={method!r} {what} and needs tol (the largest allowed deviation) and "
            f"no n; got n={n!r}, tol={tol!r}.")
    return method


def check_search_options(n, tol, options):
    """Refuse tolerance-search options given with an explicit target scale.

    The options of the tolerance search (``tol=...``) choose how the target is searched;
    with ``n`` (and no ``tol``) nothing is searched, so a non-default value would be
    ignored silently.  Called once at each public boundary (:func:`fair_curve`,
    :func:`fair_surface`, :func:`cq_fairing.occ.fair_face`).

    Parameters
    ----------
    n, tol : object
        The call's target scale and tolerance (``None`` when not given).
    options : iterable of (str, object, object)
        ``(name, value, default)`` of each tolerance-search option of the call.

    Raises
    ------
    InvalidInputError
        If ``n`` is given without ``tol`` and some option is not at its default.
    """
    given = [(name, value) for name, value, default in options if _differs(value, default)]
    if not given or n is None or tol is not None:
        return
    names = _listed([name for name, _ in given])
    values = ", ".join(f"{name}={value!r}" for name, value in given)
    verb = "applies" if len(given) == 1 else "apply"
    raise InvalidInputError(
        f"{names} {verb} to the tolerance search (tol=...), which does not run with an "
        f"explicit target scale n: got {values} with n={n!r}; drop {names} or give tol "
        "instead of n.")


def _listed(words):
    """``"a"``, ``"a and b"``, ``"a, b and c"``."""
    return " and ".join(filter(None, (", ".join(words[:-1]), words[-1])))


def _differs(value, default):
    """True when an option's value is not its default (``None``: any value given)."""
    if default is None:
        return value is not None
    return not (np.ndim(value) == 0 and value == default)


def _direction_target(space, n, degree):
    """Target space of one direction; ``None`` keeps the source space."""
    if n is None:
        return space
    return target_space(space, n, degree)
