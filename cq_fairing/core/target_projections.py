r"""Exact projections of one source surface onto pairs of target spaces, with the
target's border rows free or pinned to the source's border curves.

For a source :math:`S` with coefficients :math:`P` (homogeneous :math:`(wP, w)` when
rational) and targets :math:`T_u, T_v`, the **free** projection is the L2-best net
(the core's ARWFA projection, Ji et al. 2014 eq. 5-7),

.. math:: C = G_u^{-1} E_u\, P\, E_v^T G_v^{-T},
          \qquad G = \langle\Phi_T|\Phi_T\rangle,\; E = \langle\Phi_T|\Phi_S\rangle .

With **pinned** borders the four border rows come first, each the L2 projection of
the source's border curve (a border row of the clamped source net) onto its target
space with its two end points kept, so the corners are the source's and each edge
depends on its own curve only; the interior rows are then the projection with those
border rows held, :math:`A_{II} x_I = r_I - A_{IB} x_B`.  A free projection moves
a face's boundary along the surface where the source's parametric speed changes within
a span of the target (a net whose poles are evenly spaced on clamped uniform knots:
its border moves by a fraction of a span, 50 times the tolerance on the noisy 50 x 80
blade), which the two-sided distance sees; pinned borders stay on the source's border
curves.  Optionally a curvature-variation penalty :math:`\lambda K` and per-span
weights of the distance to the source (:mod:`cq_fairing.core.weighted`) enter the
system (the adaptive method's polish).

Per-space operators (Gram matrices and their factors, the source's moments) are kept
while a search revisits a space.  This module imports numpy and scipy only (and the
core).
"""

from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import solveh_banded

from .banded import BandedSPD, kron_solve
from .geometry import BSplineSurface
from .gram import gram_matrix
from .polish import _scaled_energy, net_lengths, variation_energy_matrix
from .results import cartesian_poles
from .weighted import SpanWeightedProjection

__all__ = ["TargetProjections", "factored_gram", "cross_gram"]

#: Interior blocks up to this size are inverted densely (:class:`_InteriorFactor`).
DENSE_INVERSE = 200


class TargetProjections:
    """Projections of ``surface`` onto target space pairs (module notes).

    Parameters
    ----------
    surface : BSplineSurface
        The source, clamped in both directions.
    borders : {"free", "pinned"}
        The target's border rows; :attr:`pinned` may be switched between projections.
    """

    def __init__(self, surface, borders="free"):
        self.surface = surface
        self.rational = surface.is_rational
        # what the projections act on: the poles, or (w P, w) for a rational source
        self.coefficients = surface.homogeneous() if self.rational else surface.poles
        self.pinned = borders == "pinned"
        self._cache = {}

    @cached_property
    def lengths(self):
        """The source net's mean polygon lengths (:func:`~cq_fairing.core.polish.net_lengths`)."""
        return net_lengths(self.surface.poles)

    def projected(self, tu, tv, lam=0.0):
        """The projected surface on ``tu x tv``; ``None`` keeps the source's space in that
        direction; ``lam`` the curvature-variation penalty of :meth:`project`.

        Raises
        ------
        NumericalError
            A rational source's projection has a weight ``<= 0``
            (:func:`~cq_fairing.core.results.cartesian_poles`).
        """
        tu = self.surface.u_space if tu is None else tu
        tv = self.surface.v_space if tv is None else tv
        poles, weights = cartesian_poles(self.project(tu, tv, lam), self.rational)
        return BSplineSurface(poles, tu.knots, tv.knots, tu.degree, tv.degree, weights)

    def _cached(self, key, build):
        """Operators that depend on the source's coefficients, kept while the searches
        revisit a space (at most 64)."""
        if key not in self._cache:
            if len(self._cache) >= 64:
                self._cache.clear()
            self._cache[key] = build()
        return self._cache[key]

    def _half(self, space_u):
        """``<Phi_Tu|Phi_Su> P``, shape (k_tu, k_v, d)."""
        def build():
            p = self.coefficients
            b = cross_gram(space_u, self.surface.u_space)
            return (b @ p.reshape(p.shape[0], -1)).reshape((-1,) + p.shape[1:])
        return self._cached(("half", space_u.key), build)

    def _inner(self, space):
        """:func:`_held_ends` of a target's Gram matrix, kept per space."""
        return _shared(("inner", space.key), lambda: _held_ends(factored_gram(space)[0]))

    def _moments(self, tu, tv):
        r""":math:`\langle\Phi_{T_u}|\Phi_{S_u}\rangle P \langle\Phi_{T_v}|\Phi_{S_v}\rangle^T`,
        shape (k_tu, k_tv, d)."""
        half = self._half(tu)
        bv = cross_gram(tv, self.surface.v_space)
        return np.swapaxes((bv @ np.swapaxes(half, 0, 1).reshape(half.shape[1], -1))
                           .reshape(tv.dimension, half.shape[0], -1), 0, 1)

    def _weighted(self, tu, tv):
        """:class:`~cq_fairing.core.weighted.SpanWeightedProjection` onto ``tu x tv`` (the
        polish's stages: polynomial sources only)."""
        return self._cached(("weighted", tu.key, tv.key),
                            lambda: SpanWeightedProjection(self.surface, tu, tv))

    def _mass(self, tu, tv, weights):
        r""":math:`G_u\otimes G_v`, or its span-weighted sum."""
        if weights is None:
            return sp.kron(factored_gram(tu)[0], factored_gram(tv)[0]).tocsr()
        return self._weighted(tu, tv).matrix(weights)

    def project(self, tu, tv, lam=0.0, weights=None, edge_lam=None):
        """Net of the (penalised) projection onto ``tu x tv``, shape (k_tu, k_tv, d);
        with pinned borders the border rows are fixed first (:meth:`_border`, with
        ``edge_lam``, default ``lam``).  ``weights`` (one per source span pair) weigh the
        distance to the source per patch (:mod:`cq_fairing.core.weighted`)."""
        rhs = (self._moments(tu, tv) if weights is None else
               self._weighted(tu, tv).moments(weights))
        if self.pinned:
            net = self._border(tu, tv, lam if edge_lam is None else edge_lam)
            interior = self._interior(tu, tv, rhs, net, lam, weights)
            if interior is not None:
                net[1:-1, 1:-1] = interior
            return net
        if lam <= 0.0 and weights is None:
            return kron_solve(factored_gram(tu)[1], factored_gram(tv)[1], rhs)
        a = self._mass(tu, tv, weights) + lam * self._energy(tu, tv)
        shape = (tu.dimension, tv.dimension)
        return _net_solve(a, rhs.reshape(shape[0] * shape[1], -1), shape).reshape(rhs.shape)

    def _energy(self, tu, tv):
        r""":func:`variation_energy_matrix` scaled to weigh like :math:`G_u\otimes G_v`
        (trace against trace) at ``lam = 1``, kept per target pair."""
        def build():
            k = variation_energy_matrix(tu, tv, self.lengths)
            mass = factored_gram(tu)[0].diagonal().sum() * factored_gram(tv)[0].diagonal().sum()
            return k * (mass / max(k.diagonal().sum(), 1e-300))
        return self._cached(("energy", tu.key, tv.key), build)

    def _border(self, tu, tv, lam):
        r"""Net with its four border rows set, interior zero.

        Each border row is the L2 projection of the source's border curve (a border row
        of the clamped source net) onto the target space with its two end points kept:
        :math:`G_{II} x_I = (\langle\Phi_T|\Phi_S\rangle c)_I - G_{IE} c_E`, so the
        four corners are the source's and each edge depends on its own border curve only.
        With ``lam > 0`` the edge's matrix gains the curves' polish term
        :math:`\lambda G^{(3)}` (scaled as in :func:`_scaled_energy`).
        """
        p = self.coefficients
        net = np.zeros((tu.dimension, tv.dimension, p.shape[-1]))
        half = self._half(tu)
        along_u = self._edge_factors(tu, lam)
        for j in (0, -1):
            net[:, j] = _held_solve(along_u, half[:, j], p[[0, -1], j])
        bv = cross_gram(tv, self.surface.v_space)
        along_v = self._edge_factors(tv, lam)
        for i in (0, -1):
            net[i, :] = _held_solve(along_v, bv @ p[i], p[i, [0, -1]])
        return net

    def _edge_factors(self, space, lam):
        """:func:`_held_ends` of a border row's matrix on ``space``, shared by its two
        edges: the Gram matrix (kept per space), plus ``lam`` times the curves' scaled
        :math:`G^{(3)}` (kept per space) when ``lam > 0``; ``None`` when ``space`` has
        only its two end functions."""
        if space.dimension <= 2:
            return None
        if lam <= 0.0:
            return self._inner(space)
        energy = self._cached(("edge energy", space.key), lambda: _scaled_energy(space, 3))
        return _held_ends(factored_gram(space)[0] + lam * energy)

    def _interior(self, tu, tv, rhs, border, lam, weights=None):
        r"""Interior net of the (penalised, weighted) projection with the border rows held:
        :math:`A_{II} x_I = r_I - A_{IB}\, x_B` for :math:`A = G_u\otimes G_v\ (+\lambda K)`
        or its span-weighted sum; without penalty and weights
        :math:`A_{II} = G_{u,II}\otimes G_{v,II}` is solved per direction.
        ``None`` when a direction has no interior row."""
        ku, kv, d = border.shape
        if ku <= 2 or kv <= 2:
            return None
        if lam <= 0.0 and weights is None:
            (gu, _), (gv, _) = factored_gram(tu), factored_gram(tv)
            along_u = (gu @ border.reshape(ku, -1)).reshape(ku, kv, d)
            held = np.swapaxes((gv @ np.swapaxes(along_u, 0, 1).reshape(kv, -1))
                               .reshape(kv, ku, d), 0, 1)
            return kron_solve(self._inner(tu)[0], self._inner(tv)[0],
                                 (rhs - held)[1:-1, 1:-1])
        a = (self._mass(tu, tv, weights) + lam * self._energy(tu, tv)).tocsr()
        inside = np.zeros((ku, kv), dtype=bool)
        inside[1:-1, 1:-1] = True
        i, b = np.flatnonzero(inside), np.flatnonzero(~inside)
        flat = border.reshape(ku * kv, d)
        r = rhs.reshape(ku * kv, d)[i] - a[i][:, b] @ flat[b]
        return _net_solve(a[i][:, i], r, (ku - 2, kv - 2)).reshape(ku - 2, kv - 2, d)

    def geometry(self, spaces, net):
        """The surface of a projected ``net`` on ``spaces``: rational (``net`` holds
        :math:`(w P, w)`) for a rational source."""
        tu, tv = spaces
        if not self.rational:
            return BSplineSurface(net, tu.knots, tv.knots, tu.degree, tv.degree)
        w = net[..., -1]
        return BSplineSurface(net[..., :-1] / w[..., None], tu.knots, tv.knots, tu.degree,
                              tv.degree, w)


_SHARED = {}


def _shared(key, build):
    """Operators that depend on spaces only (Gram matrices, their factors, the cross
    Gram matrices of a target and a source space), shared by the projections of every
    source while a search, or the next search of the same spaces, revisits them (at most
    256, as the plain projection's operators in :mod:`cq_fairing.core.scale_search`)."""
    if key not in _SHARED:
        if len(_SHARED) >= 256:
            _SHARED.clear()
        _SHARED[key] = build()
    return _SHARED[key]


def factored_gram(space):
    """Gram matrix of ``space`` and its banded Cholesky factor
    (:class:`~cq_fairing.core.banded.BandedSPD`), shared while searches revisit it."""
    def build():
        g = gram_matrix(space)
        return g, BandedSPD(g)
    return _shared(("gram", space.key), build)


def cross_gram(target, source):
    """``<Phi_T|Phi_S>`` of a target and a source space (sparse), shared while searches
    revisit the pair."""
    return _shared(("cross", target.key, source.key), lambda: gram_matrix(target, source))


def _held_solve(factors, moments, ends):
    """Coefficients with the two ``ends`` kept, ``moments`` = <Phi_T|Phi_S> c: the
    interior solved with ``factors`` (:func:`_held_ends`; ``None``: ends only)."""
    x = np.empty((moments.shape[0],) + ends.shape[1:])
    x[0], x[-1] = ends
    if factors is not None:
        factor, columns = factors
        x[1:-1] = factor.solve(moments[1:-1] - columns @ ends)
    return x


def _held_ends(matrix):
    """Factor of a symmetric positive definite banded matrix's interior block (itself
    positive definite) and its first and last columns there: what a solve with the two
    end coefficients held needs (:class:`_InteriorFactor`)."""
    m = sp.csr_matrix(matrix)
    return _InteriorFactor(m[1:-1, 1:-1]), m[1:-1][:, [0, m.shape[0] - 1]].toarray()


class _InteriorFactor:
    """Solves with an interior block: its dense inverse up to :data:`DENSE_INVERSE`
    rows, a banded Cholesky factor (:class:`~cq_fairing.core.banded.BandedSPD`) above.
    The solves of a net take hundreds of right-hand sides at once (a net's other
    direction times its coordinates), where a sparse LU solves one column at a time
    (a 10 x 10 block against 600 columns: 11 ms; the dense inverse 0.004 ms).  The
    blocks are those of B-spline Gram matrices, whose condition is bounded by the
    degree and the ratio of the spans' lengths, so the inverse loses no more digits
    than a factor's solve."""

    def __init__(self, block):
        self.size = block.shape[0]
        self._inverse = (np.linalg.inv(block.toarray()) if self.size <= DENSE_INVERSE
                         else None)
        self._factor = None if self._inverse is not None else BandedSPD(block)

    def solve(self, rhs):
        """``block^{-1} rhs`` for ``rhs`` of shape (k, ...)."""
        if self._factor is not None:
            return self._factor.solve(rhs)
        flat = rhs.reshape(self.size, int(np.prod(rhs.shape[1:], dtype=int)))
        return (self._inverse @ flat).reshape(rhs.shape)


def _net_solve(matrix, rhs, shape):
    r"""Solve :math:`A x = r` for a symmetric positive definite matrix on the unknowns of
    a net of ``shape`` (k_u, k_v) (row-major), by banded Cholesky with the shorter
    direction numbered first: a tensor operator of degree ``p`` then has half-bandwidth
    about :math:`p \min(k_u, k_v)`, and the factor costs
    :math:`O(k_u k_v\, p^2 \min(k_u, k_v)^2)` without fill-in outside the band (a
    sparse LU of the same 3360-pole degree-7 system took 15 times as long).
    Falls back to a sparse LU if the factorisation breaks down."""
    ku, kv = shape
    order = np.arange(ku * kv).reshape(ku, kv)
    order = (order.T if kv > ku else order).ravel()
    m = sp.csr_matrix(matrix)[order][:, order].tocoo()
    lower = m.row >= m.col
    offsets = m.row[lower] - m.col[lower]
    bands = np.zeros((int(offsets.max(initial=0)) + 1, ku * kv))
    bands[offsets, m.col[lower]] = m.data[lower]
    x = np.empty_like(rhs, dtype=float)
    try:
        x[order] = solveh_banded(bands, rhs[order], lower=True)
    except np.linalg.LinAlgError:
        x = spla.splu(sp.csc_matrix(matrix)).solve(rhs)
    return x
