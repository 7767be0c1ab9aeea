r"""Public fairing of curves and tensor-product surfaces: :func:`fair_curve`, :func:`fair_surface`.

The two entry points validate their input once (:func:`~cq_fairing.core.geometry.make_curve`,
:mod:`cq_fairing.core.options`) and hand the geometry to one method:

* ``"wavelet"`` with ``n``: the projection onto the quasi-uniform :math:`V_n`
  (:mod:`cq_fairing.core.projection`, Ji et al. 2014, eq. 5-14);
* ``"wavelet"`` with ``tol``: the fewest poles within the tolerance
  (:mod:`cq_fairing.core.accuracy`);
* ``"adaptive"``: targets whose knots follow the error (:mod:`cq_fairing.core.adaptive`);
* ``"energy"``: Eck-Hadenfeld energy fairing (:mod:`cq_fairing.core.energy`);
* ``"auto"`` (curves, the default): the adaptive fit chosen per curve
  (:mod:`cq_fairing.core.auto_curve`), with ``n`` the wavelet projection.

Each returns a :class:`~cq_fairing.core.results.FairResult` or
:class:`~cq_fairing.core.results.SurfaceFairResult`.
"""

from typing import Literal

from numpy.typing import ArrayLike

from ..errors import InvalidInputError, UnsupportedGeometryError
from .accuracy import fair_curve_to_tolerance, fair_surface_to_tolerance
from .adaptive_curve import fair_curve_adaptive
from .adaptive_surface import fair_surface_adaptive
from .auto_curve import fair_curve_auto
from .energy import fair_curve_energy, fair_surface_energy
from .geometry import make_curve, make_surface, split_pair
from .options import (
    CURVE_METHODS,
    MEASURES,
    SEARCHES,
    check_applies,
    check_order,
    check_search_options,
    checked_choice,
    curve_method,
    renamed_keywords,
    tolerance_method,
)
from .plans import direction_target, target_space
from .projection import project_curve, project_surface
from .results import FairResult, SurfaceDetails, SurfaceFairResult

Method = Literal["wavelet", "adaptive", "energy"]
CurveMethod = Literal["auto", "wavelet", "adaptive", "energy"]
Objective = Literal["auto", "compact", "faithful", "fair"]
Borders = Literal["auto", "free", "pinned"]
Schedule = Literal["auto", "direct", "hybrid"]
Search = Literal["guaranteed", "linear", "polyfit"]
Measure = Literal["geometric", "parametric"]
IntPair = int | tuple[int, int]

__all__ = ["fair_curve", "fair_surface", "FairResult", "SurfaceFairResult", "SurfaceDetails"]


# -- public entry points -------------------------------------------------------------------
def fair_curve(poles: ArrayLike, n: int | None = None, *, tol: float | None = None,
               knots: ArrayLike | None = None, degree: int | None = None,
               weights: ArrayLike | None = None, target_degree: int | None = None,
               schedule: Schedule = "auto", search: Search = "guaranteed", order: int = 6,
               measure: Measure = "geometric", method: CurveMethod = "auto",
               objective: Objective = "auto", **renamed: object) -> FairResult:
    r"""Fair a B-spline curve by multiresolution (ARWFA / DWFA) projection.

    With ``tol`` (the default ``method="auto"``) the fit is chosen per curve among the
    adaptive ones and reported as ``choice`` (see ``method``).  With ``n`` the faired
    curve is the L2-best approximation of the source in the quasi-uniform space
    :math:`V_n` (``n`` spans, ``n + target_degree`` poles):

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
        curve (true closest-point distance, both ways).
    knots : array_like, shape (k + degree + 1,), optional
        Clamped source knots; default quasi-uniform on [0, 1].
    degree : int, optional
        Source degree, default 3.
    weights : array_like, shape (k,), optional
        Positive weights of a rational source; fairing works on :math:`(w P, w)`.
    target_degree : int, optional
        Degree of the faired curve; default ``min(degree, 3)`` (``"auto"``: chosen, see
        there).  Refused with ``method="energy"``, which keeps the degree.
    schedule : {"auto", "direct", "hybrid"}
        Spaces visited, see :mod:`cq_fairing.core.schedule`; ``method="wavelet"`` only
        (and the default method with ``n``, which is the wavelet projection).
    search : {"guaranteed", "linear", "polyfit"}
        Step rule of the wavelet tolerance search (with ``tol``, see
        :func:`~cq_fairing.core.accuracy.fair_curve_to_tolerance`).
    order : int
        Degree (2 .. 6) of the least-squares fit of ``search="polyfit"``; only with it.
    measure : {"geometric", "parametric"}
        The distance the tolerance search bounds: closest-point or same-parameter.
        ``search``, ``order`` and ``measure`` belong to the tolerance search of
        ``method="wavelet"``: refused with ``n`` and with the other methods.
    **renamed
        Old spellings, accepted for one release with a ``DeprecationWarning``:
        ``strategy`` (now ``search``), ``deviation`` (now ``measure``); see
        :mod:`cq_fairing.core.options`.
    method : {"auto", "wavelet", "adaptive", "energy"}
        ``"auto"`` (default): with ``tol``, the adaptive fit chosen per curve by the rule
        of :mod:`cq_fairing.core.options` (:mod:`cq_fairing.core.auto_curve`): the
        ``"faithful"`` fit, at the degree 3, 5 or 7 that needs the fewest poles, where
        the noise sets its size and it needs no more poles than the compact fit at
        degree 3; else the compact fit with the fewest poles over those degrees; the
        result's ``choice`` names the options that give the same curve.  With ``n``: the
        wavelet projection.  ``"wavelet"``: the projection onto :math:`V_n`, with
        ``tol`` the fewest poles of a uniform target within it (the seed's ARWFA search,
        :mod:`cq_fairing.core.accuracy`).
        ``"adaptive"``: the exact L2 projection onto a target whose knots follow the
        error (:mod:`cq_fairing.core.adaptive`), usually fewer poles than the
        quasi-uniform ``V_n`` at the same ``tol``; one direct decomposition step, so
        ``details``/``reconstruct`` still work.  ``"energy"``: Eck-Hadenfeld local
        energy fairing (:mod:`cq_fairing.core.energy`, derivative ``l = 3``, ``l = 2``
        for quadratics; degree >= 2) that keeps the poles and moves none farther than
        ``tol``.  Both need ``tol`` and no ``n``.
    objective : {"auto", "compact", "faithful", "fair"}
        ``method="adaptive"`` only.  ``"compact"`` (``"auto"``): the fewest poles within ``tol``, the
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
        Bad poles, knots, weights or arguments; an option the chosen method does not use
        (:data:`~cq_fairing.core.options.APPLIES`), or a tolerance-search option
        (``search``, ``order``, ``measure``) other than its default given with ``n``
        instead of ``tol``.
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
    method = curve_method(method, n, tol)
    search, measure = _checked_search(
        **renamed_keywords("fair_curve", renamed, method, search=search, measure=measure))
    curve = make_curve(poles, knots, degree, weights)
    method = tolerance_method(method, objective, n, tol, methods=CURVE_METHODS)
    check_applies(method, (("target_degree", target_degree), ("schedule", schedule),
                           ("search", search), ("order", order), ("measure", measure)),
                  methods=CURVE_METHODS)
    check_search_options(n, tol, (("search", search, "guaranteed"), ("order", order, 6),
                                  ("measure", measure, "geometric")))
    check_order(order, search)
    if method == "auto":

        return fair_curve_auto(curve, tol, target_degree=target_degree)
    if method == "energy":

        if curve.degree < 2:
            raise UnsupportedGeometryError(
                "energy fairing needs degree >= 2 (the second derivatives of a degree-1 "
                "curve vanish between its poles); use method='wavelet'.")
        return fair_curve_energy(curve, tol, l=min(3, curve.degree))
    if method == "adaptive":

        return fair_curve_adaptive(curve, tol, target_degree=target_degree,
                                   objective=objective)
    if (n is None) == (tol is None):
        raise InvalidInputError(
            "give exactly one of n (target scale) and tol (tolerance); "
            f"got n={n!r}, tol={tol!r}."
        )
    if tol is not None:

        return fair_curve_to_tolerance(curve, tol, target_degree=target_degree,
                                       schedule=schedule, strategy=search,
                                       order=order, deviation=measure)
    return project_curve(curve, target_space(curve.space, n, target_degree), schedule)


def fair_surface(poles: ArrayLike, n: tuple[int | None, int | None] | None = None, *,
                 tol: float | None = None, u_knots: ArrayLike | None = None,
                 v_knots: ArrayLike | None = None, degree: IntPair | None = None,
                 weights: ArrayLike | None = None, target_degree: IntPair | None = None,
                 schedule: Schedule = "auto", search: Search = "guaranteed",
                 measure: Measure = "geometric", method: Method = "wavelet",
                 objective: Objective = "auto", borders: Borders = "auto",
                 window: tuple[float, float, float, float] | None = None,
                 **renamed: object) -> SurfaceFairResult:
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
        Default ``min(source degree, 3)`` per direction; refused with ``method="energy"``.
    schedule : {"auto", "direct", "hybrid"}
        ``method="wavelet"`` only.
    search, measure
        The tolerance search's step rule and distance, as for :func:`fair_curve` (see
        :func:`~cq_fairing.core.accuracy.fair_surface_to_tolerance`); refused with ``n``
        and with the other methods.
    method : {"wavelet", "adaptive", "energy"}
        ``"adaptive"``: exact projection onto u and v targets whose knots follow the
        error (:mod:`cq_fairing.core.adaptive`; polynomial surfaces).  ``"energy"``:
        local thin-plate energy fairing within ``tol`` that keeps the net size
        (:mod:`cq_fairing.core.energy`).  Both need ``tol`` and no ``n``.
    objective : {"auto", "compact", "faithful", "fair"}
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
    **renamed
        Old spellings ``strategy`` and ``deviation``, as for :func:`fair_curve`.

    Returns
    -------
    SurfaceFairResult

    Raises
    ------
    InvalidInputError
        Bad poles, knots, weights or arguments; an option the chosen method does not use;
        ``search``, ``measure`` or ``window`` other than its default given with ``n``
        instead of ``tol``.
    InvalidTargetError, InvalidToleranceError, ToleranceNotMetError
    """
    search, measure = _checked_search(
        **renamed_keywords("fair_surface", renamed, method, search=search, measure=measure))
    surface = make_surface(poles, u_knots, v_knots, degree, weights)
    method = tolerance_method(method, objective, n, tol, borders, window)
    check_applies(method, (("target_degree", target_degree), ("schedule", schedule),
                           ("search", search), ("measure", measure)))
    check_search_options(n, tol, (("search", search, "guaranteed"),
                                  ("measure", measure, "geometric"), ("window", window, None)))
    if method == "energy":

        return fair_surface_energy(surface, tol)
    if method == "adaptive":

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

        return fair_surface_to_tolerance(surface, tol, target_degree=(tdu, tdv),
                                         schedule=schedule, strategy=search,
                                         deviation=measure, window=window)
    nu, nv = split_pair(n, "n")
    target_u = direction_target(surface.u_space, nu, tdu)
    target_v = direction_target(surface.v_space, nv, tdv)
    return project_surface(surface, target_u, target_v, schedule)




def _checked_search(search, measure):
    """``search`` and ``measure``, refused unless one of their values."""
    return checked_choice("search", search, SEARCHES), checked_choice("measure", measure, MEASURES)
