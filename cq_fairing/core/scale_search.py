r"""Target-size search for one face: the fewest poles whose faired surface stays within ``tol``.

For a candidate ``(n_u, n_v)`` the faired surface is the L2-best approximation in
:math:`V_{n_u}\otimes V_{n_v}` (the core's ARWFA projection, Ji et al. 2014 eq. 5-7),

.. math:: C_n = G_u^{-1} E_u\, C_S\, E_v^T G_v^{-T},
          \qquad G = \langle\Phi_n|\Phi_n\rangle,\; E = \langle\Phi_n|\Phi_S\rangle,

computed here with the core's exact Gram matrices and no wavelet details (they are
only needed for the final result).  Its deviation is the largest *parametric* distance
:math:`\max_i |S_n(u_i, v_i) - S(u_i, v_i)|` over samples inside the face, an upper bound
of the true distance, so a candidate accepted here is within ``tol``
(:meth:`SurfaceSampler.parametric`); the caller checks the final face again with its
own two-sided measure.

The search is a bisection on a common fraction of the largest scales, then on each
direction alone.  Deviation is not strictly monotone in ``n``, so the result is the
fewest poles *found*, always verified, not a proven minimum.  Along a closed direction
(end rows that coincide) fewer spans than :func:`~cq_fairing.core.geometry.fewest_spans`
count as failing: the coarsest net still closes as a valid face.

The OCP layer's face search (:mod:`cq_fairing.occ.faces`) and the merged patch grids
(:mod:`cq_fairing.core.grid_fairing`) run it, measuring candidates on a
:class:`SurfaceSampler`.  This module imports numpy and scipy only (and the core).
"""

import math

import numpy as np

from ..errors import InvalidInputError, ToleranceNotMetError
from .geometry import BSplineSurface, fewest_spans, one_thread_product
from .plans import target_space
from .results import cartesian_poles, homogeneous_coefficients
from .target_projections import cross_gram, factored_gram

__all__ = ["project", "search_scales", "max_scales", "target_degrees", "SurfaceSampler"]


_OPERATORS = {}


def _operator(source, target):
    """Dense ``G^{-1} E`` mapping source coefficients to the target (k_t, k_s), cached."""
    if target is None:
        return None
    key = (source.key, target.key)
    if key not in _OPERATORS:
        if len(_OPERATORS) > 256:
            _OPERATORS.clear()
        cross = cross_gram(target, source).toarray()
        _OPERATORS[key] = factored_gram(target)[1].solve(cross)
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
    return net if au is None else one_thread_product(au, net)


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
                  projection=None, grading="uniform", measured=None, fewer_than=None):
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
    grading : {"uniform", "source", "ends"}
        The targets' knots (:func:`~cq_fairing.core.plans.target_space`): quasi-uniform,
        graded like the source's spans, or refined towards both ends.
    measured : dict, optional
        ``{(u space key, v space key): (faired, deviation)}`` of candidates measured
        already, shared by searches of one surface with one ``deviation`` and ``finish``
        (the two gradings: a direction whose spans are equal gets the same targets in
        both); filled here.
    fewer_than : int, optional
        Poles of another family's winner, for a family that only matters where it
        beats it: a candidate with at least as many poles is taken as passing without
        being measured, and a winner with as many is none (``None``).  The bisection's
        path then differs from the full one, so it may miss a smaller candidate the full
        search finds; it never costs the other families anything.

    Returns
    -------
    target : (SplineSpace or None, SplineSpace or None)
        The target spaces; ``None`` keeps that direction unchanged.
    faired : BSplineSurface
    dev : float
    evaluations : int

    or ``None`` where no candidate with fewer than ``fewer_than`` poles was found.

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
    measured = {} if measured is None else measured

    def space(axis, n):
        if n is None:
            return None
        if n not in spaces[axis]:
            source = surface.u_space if axis == 0 else surface.v_space
            spaces[axis][n] = target_space(source, int(n), target_degree[axis], grading)
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
        if fewer_than is not None and _poles(n, surface, target_degree) >= fewer_than:
            return None, -np.inf  # cannot win: taken as passing, not measured
        if n not in cache:
            key = tuple(None if s is None else s.key for s in (space(0, n[0]), space(1, n[1])))
            if key not in measured:
                faired = finish(projected(n))
                measured[key] = (faired, deviation(faired))
            cache[n] = measured[key]
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
    if faired is None:
        return None
    return (space(0, best[0]), space(1, best[1])), faired, dev, len(cache)


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


def target_degrees(surface, target_degree):
    """The target's degrees ``(p, q)``: ``target_degree`` (an int or a pair), by default
    ``min(3, source degree)`` per direction."""
    if target_degree is None:
        return min(3, surface.u_degree), min(3, surface.v_degree)
    pair = (target_degree, target_degree) if np.ndim(target_degree) == 0 else tuple(target_degree)
    if len(pair) != 2 or any(isinstance(d, bool) or not isinstance(d, (int, np.integer)) or d < 1
                             for d in pair):
        raise InvalidInputError(
            f"target_degree must be an integer >= 1 or a pair of them, got {target_degree!r}."
        )
    return int(pair[0]), int(pair[1])


class SurfaceSampler:
    r"""Original points on a UV grid of the face (inside the trim), for the search.

    ``grid`` is ``(u, v, inside)``: the grid's parameters and the ``(u.size, v.size)``
    mask of the samples that lie on the face.  The sparse collocation matrices
    (:math:`p + 1` non-zeros per row) are cached per spline space, so a candidate's
    grid :math:`M_u P M_v^T` costs :math:`O((n_u k_v + n_u n_v)(p + 1))` work
    (:func:`_grid_of`), where dense factors cost :math:`O(n_u k_u k_v + n_u n_v k_v)`.
    The measures work on the whole grid laid out coordinate by coordinate, ``(n_v, d,
    n_u)``, so that no product is copied into another layout, and take the largest
    value over the samples on the face.
    """

    def __init__(self, grid, surface):
        self.grid = grid
        self.u, self.v, self.inside = grid
        self._on_face = None if np.all(self.inside) else np.asarray(self.inside).T
        self._cache = {}
        self._reference = self._points(surface)

    @property
    def reference(self):
        """The source's points on the face's samples, (q, 3) in row-major order of
        ``(u, v)``."""
        return self._samples(self._reference)

    def evaluate(self, surface):
        """``surface``'s points on the face's samples, (q, 3) in row-major order of
        ``(u, v)``."""
        return self._samples(self._points(surface))

    def _samples(self, grid):
        """The samples of a ``(n_v, d, n_u)`` grid on the face, (q, d), ``(u, v)``
        row-major."""
        return grid.transpose(2, 0, 1)[self.inside]

    def _matrix(self, space, x, nu=0):
        key = (space.key, x.size, nu)
        if key not in self._cache:
            self._cache[key] = space.collocation(x, nu)
        return self._cache[key]

    def _largest(self, field):
        """The largest value of a ``(n_v, n_u)`` field over the samples on the face."""
        return float((field if self._on_face is None else field[self._on_face]).max())

    def _points(self, surface):
        """``surface``'s points on the whole grid, ``(n_v, 3, n_u)``."""
        net = surface.homogeneous() if surface.is_rational else surface.poles
        mu, mv = self._matrix(surface.u_space, self.u), self._matrix(surface.v_space, self.v)
        grid = _grid_of(mv, _along_u(mu, net))
        return grid[:, :-1] / grid[:, -1:] if surface.is_rational else grid

    def parametric(self, faired):
        """Largest ``|S_f(u, v) - S(u, v)|``: an upper bound of the true distance."""
        offset = self._points(faired) - self._reference
        return math.sqrt(self._largest(_dot(offset, offset)))

    def normal(self, faired):
        """Largest distance to the faired surface's tangent planes at the same parameters.

        A first-order estimate of the true distance, far below the parametric one where
        fairing shifts the surface along itself (bumpy nets); OCCT checks the result.
        At a sample whose normal :math:`S_u \\times S_v` vanishes (below 1e-12 of the
        largest on the face) the estimate is the parametric distance.
        """
        net = faired.homogeneous() if faired.is_rational else faired.poles
        mu, mv = self._matrix(faired.u_space, self.u), self._matrix(faired.v_space, self.v)
        du = self._matrix(faired.u_space, self.u, 1)
        dv = self._matrix(faired.v_space, self.v, 1)
        along_u = _along_u(mu, net)                     # S and S_v share it
        h, hu, hv = (_grid_of(mv, along_u), _grid_of(mv, _along_u(du, net)),
                     _grid_of(dv, along_u))
        if faired.is_rational:  # quotient rule: S = X / w, S_u = (X_u - w_u S) / w
            w = h[:, -1:]
            points = h[:, :-1] / w
            su = (hu[:, :-1] - hu[:, -1:] * points) / w
            sv = (hv[:, :-1] - hv[:, -1:] * points) / w
        else:
            points, su, sv = h, hu, hv
        normal = _cross(su, sv)
        length = np.sqrt(_dot(normal, normal))
        offset = self._reference - points
        ok = length > 1e-12 * max(1.0, self._largest(length))
        along_normal = np.abs(_dot(offset, normal))
        if ok.all():   # a tangent plane at every sample
            return self._largest(along_normal / length)
        dist = np.sqrt(_dot(offset, offset))
        np.divide(along_normal, length, out=dist, where=ok)
        return self._largest(dist)


def _along_u(mu, net):
    """The net (k_u, k_v, d) contracted with the sparse ``mu`` (n_u, k_u) along u, laid
    out ``(k_v, d, n_u)`` for the product along v."""
    flat = mu @ net.reshape(net.shape[0], -1)                    # (n_u, k_v * d)
    return flat.reshape(mu.shape[0], net.shape[1], -1).transpose(1, 2, 0).copy()


def _grid_of(mv, along_u):
    r"""The grid :math:`G_{ab} = \sum_{ij} (M_u)_{ai} P_{ij} (M_v)_{bj}` laid out
    ``(n_v, d, n_u)``, from :func:`_along_u`'s product and the sparse ``mv`` (n_v, k_v)."""
    flat = mv @ along_u.reshape(along_u.shape[0], -1)
    return flat.reshape((mv.shape[0],) + along_u.shape[1:])


def _dot(a, b):
    """The dot products of two ``(n_v, 3, n_u)`` grids, ``(n_v, n_u)``."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _cross(a, b):
    """The cross products of two ``(n_v, 3, n_u)`` grids, ``(n_v, 3, n_u)``."""
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1],
                     a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)
