r"""Target-size search for one face: the fewest poles whose faired surface stays within ``tol``.

For a candidate ``(n_u, n_v)`` the faired surface is the L2-best approximation in
:math:`V_{n_u}\otimes V_{n_v}` (the core's ARWFA projection, Ji et al. 2014 eq. 5-7),

.. math:: C_n = G_u^{-1} E_u\, C_S\, E_v^T G_v^{-T},
          \qquad G = \langle\Phi_n|\Phi_n\rangle,\; E = \langle\Phi_n|\Phi_S\rangle,

computed here with the core's exact Gram matrices and no wavelet details (they are
only needed for the final result).  Its deviation is the largest *parametric* distance
:math:`\max_i |S_n(u_i, v_i) - S(u_i, v_i)|` over samples inside the face, an upper bound
of the true distance, so a candidate accepted here is within ``tol``; OCCT's projection
checks the final face again (:mod:`cq_fairing.occ.faces`).

The search is a bisection on a common fraction of the largest scales, then on each
direction alone.  Deviation is not strictly monotone in ``n``, so the result is the
fewest poles *found*, always verified, not a proven minimum.  Along a closed direction
(end rows that coincide) fewer spans than :func:`~cq_fairing.core.geometry.fewest_spans`
count as failing: the coarsest net still closes as a valid face.

This is the local stand-in for ``cq_fairing.fair_surface(tol=...)`` until the core's
accuracy control lands with a surface search.
"""

import math

import numpy as np

from ..core.banded import BandedSPD
from ..core.geometry import BSplineSurface, fewest_spans
from ..core.gram import gram_matrix
from ..core.plans import target_space
from ..core.results import cartesian_poles, homogeneous_coefficients
from ..errors import ToleranceNotMetError

__all__ = ["project", "search_scales", "max_scales"]


_OPERATORS = {}


def _operator(source, target):
    """Dense ``G^{-1} E`` mapping source coefficients to the target (k_t, k_s), cached."""
    if target is None:
        return None
    key = (source.key, target.key)
    if key not in _OPERATORS:
        if len(_OPERATORS) > 256:
            _OPERATORS.clear()
        cross = gram_matrix(target, source).toarray()
        _OPERATORS[key] = BandedSPD(gram_matrix(target)).solve(cross)
    return _OPERATORS[key]


def project(surface, target_u, target_v, along_u=None):
    """The L2-best surface in ``target_u x target_v`` (``None`` keeps a direction).

    Rational surfaces are projected in homogeneous coordinates; a non-positive weight
    in the result raises :class:`~cq_fairing.errors.NumericalError` from the core's rule.
    ``along_u`` may hold the net already projected along u (a search reuses it).
    """
    net = along_u if along_u is not None else project_u(surface, target_u)
    av = _operator(surface.v_space, target_v)
    if av is not None:
        net = np.matmul(av, net)
    poles, weights = cartesian_poles(net, surface.is_rational)
    tu = surface.u_space if target_u is None else target_u
    tv = surface.v_space if target_v is None else target_v
    return BSplineSurface(poles, tu.knots, tv.knots, tu.degree, tv.degree, weights)


def project_u(surface, target_u):
    """Homogeneous (or Cartesian) net projected along u only, shape (k_tu, k_v, d')."""
    net = homogeneous_coefficients(surface)
    au = _operator(surface.u_space, target_u)
    return net if au is None else np.tensordot(au, net, axes=(1, 0))


def max_scales(surface, target_degree):
    """Largest admissible ``n`` per direction (``n + degree`` poles, at most the source's).

    ``None`` for a direction that cannot be reduced (fewer poles than degree + 2).
    """
    out = []
    for space, degree in zip((surface.u_space, surface.v_space), target_degree):
        n = space.dimension - degree
        out.append(n if n >= 1 else None)
    return tuple(out)


def search_scales(surface, tol, target_degree, deviation, finish=None, keep=(True, True),
                  projection=None):
    """Fewest-poles ``(n_u, n_v)`` with ``deviation(faired) <= tol``.

    Parameters
    ----------
    surface : BSplineSurface
    tol : float
    target_degree : (int, int)
    deviation : callable
        ``deviation(faired_surface) -> float`` (parametric, on the face's samples).
    finish : callable, optional
        Applied to each candidate before measuring (periodic seam tying, fixed border).
    keep : (bool, bool), optional
        Whether the search may keep the source's space in u and in v (``None`` in
        ``n``).  A merged patch grid must not keep a direction whose source knots hold
        its former joins.
    projection : callable, optional
        ``projection(target_u, target_v) -> BSplineSurface`` (``None`` keeps a
        direction) in place of the plain L2 projection :func:`project`.

    Returns
    -------
    n : (int or None, int or None)
        ``None`` keeps that direction unchanged.
    faired : BSplineSurface
    dev : float
    evaluations : int

    Raises
    ------
    ToleranceNotMetError
        Even the finest admissible target (per direction, or one direction only) deviates
        more than ``tol``.
    """
    finish = finish or (lambda s: s)
    top = max_scales(surface, target_degree)
    spaces = ({}, {})
    cache = {}

    def space(axis, n):
        if n is None:
            return None
        if n not in spaces[axis]:
            source = surface.u_space if axis == 0 else surface.v_space
            spaces[axis][n] = target_space(source, int(n), target_degree[axis])
        return spaces[axis][n]

    halves = {}

    def projected(n):
        if projection is not None:
            return projection(space(0, n[0]), space(1, n[1]))
        if n[0] not in halves:
            halves[n[0]] = project_u(surface, space(0, n[0]))
        return project(surface, space(0, n[0]), space(1, n[1]), halves[n[0]])

    lowest = [None if m is None else min(low, m)
              for low, m in zip(fewest_spans(surface), top)]

    def run(n):
        if any(k is not None and k < low for k, low in zip(n, lowest)):
            return None, np.inf   # a closed direction cannot close on so few spans
        if n not in cache:
            faired = finish(projected(n))
            cache[n] = (faired, deviation(faired))
        return cache[n]

    patterns = [top, (top[0], None), (None, top[1])]
    patterns = [p for p in dict.fromkeys(patterns) if p != (None, None) and
                all(k or n is not None for k, n in zip(keep, p))]
    feasible = [p for p in patterns if run(p)[1] <= tol]
    if not feasible:
        best = min(run(p)[1] for p in patterns) if patterns else float("inf")
        raise ToleranceNotMetError(
            f"no target size keeps the face within tol={tol:g} (the finest admissible "
            f"target deviates {best:.3g}); raise the tolerance or leave this face as is.",
            tolerance=tol, best_deviation=best,
        )
    best = min((_shrink(p, tol, run) for p in feasible),
               key=lambda n: _poles(n, surface, target_degree))
    faired, dev = run(best)
    return best, faired, dev, len(cache)


def _poles(n, surface, degree):
    ku = surface.u_space.dimension if n[0] is None else n[0] + degree[0]
    kv = surface.v_space.dimension if n[1] is None else n[1] + degree[1]
    return ku * kv


def _shrink(start, tol, run):
    """Bisect a common fraction of ``start``, then each direction alone."""
    def scaled(s):
        return tuple(None if m is None else max(1, math.ceil(s * m)) for m in start)

    lo, hi = 0.0, 1.0
    while True:
        mid = 0.5 * (lo + hi)
        if scaled(mid) in (scaled(lo), scaled(hi)):
            break
        if run(scaled(mid))[1] <= tol:
            hi = mid
        else:
            lo = mid
    best = scaled(hi)
    for axis in (0, 1):
        if best[axis] is None:
            continue
        lo_n, hi_n = 0, best[axis]
        while hi_n - lo_n > 1:
            mid = (lo_n + hi_n) // 2
            cand = tuple(mid if a == axis else best[a] for a in (0, 1))
            if run(cand)[1] <= tol:
                hi_n = mid
            else:
                lo_n = mid
        best = tuple(hi_n if a == axis else best[a] for a in (0, 1))
    return best
