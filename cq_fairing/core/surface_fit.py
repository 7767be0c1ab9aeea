"""One adaptive surface fit: the projections, deviations and final checks of the
candidate nets of :func:`~cq_fairing.core.adaptive_surface.fair_surface_adaptive`
(:mod:`cq_fairing.core.adaptive`, notes 4 and 5).
"""

from functools import cached_property

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.linalg import solveh_banded

from .adaptive_knots import _refined
from .banded import BandedSPD, kron_solve
from .evaluation import sample_parameters
from .geometry import BSplineSurface, fewest_spans
from .gram import gram_matrix
from .polish import _scaled_energy, net_lengths, variation_energy_matrix
from .probes import SurfaceProbe
from .weighted import SpanWeightedProjection

FINAL_MIN_PER_SPAN = 8  # the final surface check never samples coarser than deviation() does


SCREEN_STRIDE = 4    # a verdict-only trial looks at every 4th search sample first ...


SCREEN_SAMPLES = 16  # ... and the true distance at its 16 largest bounds


# -- surfaces -------------------------------------------------------------------------------------
class _SurfaceFit:
    """Exact tensor projections of one source surface, with their deviation on a grid."""

    def __init__(self, surface, tol, degrees, per_span, max_samples, borders="free",
                 region=None, edges=None):
        self.surface, self.tol, self.degrees = surface, tol, degrees
        self.rational = surface.is_rational
        # what the projections act on: the poles, or (w P, w) for a rational source
        self.coefficients = surface.homogeneous() if self.rational else surface.poles
        self.region = region
        self.pinned = borders == "pinned"
        u, v = _grid((surface,), per_span, edges)
        while u.size * v.size > max_samples and per_span > 1:
            per_span -= 1
            u, v = _grid((surface,), per_span, edges)
        self._uv = (u, v)
        self._span_starts = (np.searchsorted(u, surface.u_space.breakpoints[:-1]),
                             np.searchsorted(v, surface.v_space.breakpoints[:-1]))
        self.lengths = net_lengths(surface.poles)
        self.lowest = fewest_spans(surface)
        self.evaluations = 0
        self._cache = {}
        self._refused = {}   # screened_trial's refusals, by candidate

    @cached_property
    def probe(self):
        """The search grid's :class:`~cq_fairing.core.measures.SurfaceProbe`, built on
        first use (a faithful fit that passes never measures on it)."""
        return SurfaceProbe(self.surface, uv=self._uv, keep_feet=True, region=self.region)

    @cached_property
    def coarse_probe(self):
        """Every ``SCREEN_STRIDE``-th search sample per direction, starting Newton from
        the search probe's last feet and keeping none of its own
        (:meth:`screened_trial`)."""
        u, v = self._uv
        probe = SurfaceProbe(self.surface, uv=(u[::SCREEN_STRIDE], v[::SCREEN_STRIDE]),
                             region=self.region)
        probe.adopt_feet(self.probe)
        return probe

    def _cached(self, key, build):
        """Per-space operators, kept while the searches revisit a space (at most 64)."""
        if key not in self._cache:
            if len(self._cache) >= 64:
                self._cache.clear()
            self._cache[key] = build()
        return self._cache[key]

    def _half(self, space_u):
        """``<Phi_Tu|Phi_Su> P``, shape (k_tu, k_v, d)."""
        def build():
            p = self.coefficients
            b = gram_matrix(space_u, self.surface.u_space)
            return (b @ p.reshape(p.shape[0], -1)).reshape((-1,) + p.shape[1:])
        return self._cached(("half", space_u.key), build)

    def _gram(self, space):
        """Gram matrix of a target space and its banded Cholesky factor."""
        def build():
            g = gram_matrix(space)
            return g, BandedSPD(g)
        return self._cached(("gram", space.key), build)

    def _inner(self, space):
        """:func:`_held_ends` of a target's Gram matrix, kept per space."""
        return self._cached(("inner", space.key), lambda: _held_ends(self._gram(space)[0]))

    def _moments(self, tu, tv):
        r""":math:`\langle\Phi_{T_u}|\Phi_{S_u}\rangle P \langle\Phi_{T_v}|\Phi_{S_v}\rangle^T`,
        shape (k_tu, k_tv, d)."""
        half = self._half(tu)
        bv = self._cross_v(tv)
        return np.swapaxes((bv @ np.swapaxes(half, 0, 1).reshape(half.shape[1], -1))
                           .reshape(tv.dimension, half.shape[0], -1), 0, 1)

    def _cross_v(self, tv):
        return self._cached(("cross v", tv.key), lambda: gram_matrix(tv, self.surface.v_space))

    def _weighted(self, tu, tv):
        """:class:`~cq_fairing.core.weighted.SpanWeightedProjection` onto ``tu x tv`` (the
        polish's stages: polynomial sources only)."""
        return self._cached(("weighted", tu.key, tv.key),
                            lambda: SpanWeightedProjection(self.surface, tu, tv))

    def _mass(self, tu, tv, weights):
        r""":math:`G_u\otimes G_v`, or its span-weighted sum."""
        if weights is None:
            return sp.kron(self._gram(tu)[0], self._gram(tv)[0]).tocsr()
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
            return kron_solve(self._gram(tu)[1], self._gram(tv)[1], rhs)
        a = self._mass(tu, tv, weights) + lam * self._energy(tu, tv)
        shape = (tu.dimension, tv.dimension)
        return _net_solve(a, rhs.reshape(shape[0] * shape[1], -1), shape).reshape(rhs.shape)

    def _energy(self, tu, tv):
        r""":func:`variation_energy_matrix` scaled to weigh like :math:`G_u\otimes G_v`
        (trace against trace) at ``lam = 1``, kept per target pair."""
        def build():
            k = variation_energy_matrix(tu, tv, self.lengths)
            mass = self._gram(tu)[0].diagonal().sum() * self._gram(tv)[0].diagonal().sum()
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
        bv = self._cross_v(tv)
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
        return _held_ends(self._gram(space)[0] + lam * energy)

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
            (gu, _), (gv, _) = self._gram(tu), self._gram(tv)
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

    def errors(self, faired):
        """Per-sample deviation grid: true distance where the bound exceeds part of tol."""
        self.evaluations += 1
        other, bound = self.probe.bound(faired)
        flat = _refined(bound.ravel(),
                        lambda idx: self.probe.true_distance(faired, other, idx, tol=self.tol),
                        self.tol)
        return flat.reshape(bound.shape)

    def span_max(self, values):
        """Largest of the search-grid ``values`` in each source span pair (a sample on a
        breakpoint counts for the span to its right), shape (n_su, n_sv)."""
        along_u = np.maximum.reduceat(values, self._span_starts[0], axis=0)
        return np.maximum.reduceat(along_u, self._span_starts[1], axis=1)

    @property
    def span_shape(self):
        return self._span_starts[0].size, self._span_starts[1].size

    def trial(self, tu, tv, lam=0.0, weights=None, edge_lam=None):
        """``(faired, per-sample deviation on the search grid, its max)``."""
        return self._measured(self._faired(tu, tv, lam, weights, edge_lam))

    def _faired(self, tu, tv, lam=0.0, weights=None, edge_lam=None):
        """The candidate surface: :meth:`project` onto ``tu x tv``."""
        return self.geometry((tu, tv), self.project(tu, tv, lam, weights, edge_lam))

    def geometry(self, spaces, net):
        """The surface of a projected ``net`` on ``spaces``: rational (``net`` holds
        :math:`(w P, w)`) for a rational source."""
        tu, tv = spaces
        if not self.rational:
            return BSplineSurface(net, tu.knots, tv.knots, tu.degree, tv.degree)
        w = net[..., -1]
        return BSplineSurface(net[..., :-1] / w[..., None], tu.knots, tv.knots, tu.degree,
                              tv.degree, w)

    def inadmissible(self, faired):
        """True for a candidate that fails whatever its samples say: a rational one with a
        weight ``<= 0`` (it may pass through infinity between samples), or one with fewer
        spans along a closed direction than :func:`~cq_fairing.core.geometry.fewest_spans`
        (it cannot close as a valid face)."""
        spans = (faired.u_space.n_spans, faired.v_space.n_spans)
        return (any(n < low for n, low in zip(spans, self.lowest))
                or self.rational and not np.all(faired.weights > 0))

    def _measured(self, faired):
        if self.inadmissible(faired):
            # its samples say nothing about where the error is: all get twice the
            # tolerance, which keeps the knot density as it is (as for curves)
            self.evaluations += 1
            return faired, np.full((self.probe.u.size, self.probe.v.size), 2 * self.tol), np.inf
        values = self.errors(faired)
        return faired, values, float(values.max())

    def screened_trial(self, tu, tv, lam=0.0):
        """:meth:`trial` for a search that reads only the verdict of a failing candidate
        (the count bisections of the starts, the polish's bisection on lambda).

        The candidate is first measured on the coarse grid (:attr:`coarse_probe`): the
        true distance at its ``SCREEN_SAMPLES`` largest same-parameter bounds above tol.
        If one exceeds tol the candidate fails, and ``(faired, None, e)`` comes back with
        that distance ``e``, a lower bound of its maximum; the search grid is not
        measured and keeps its feet.  Otherwise the full :meth:`trial` follows.  A
        failing trial measured in full costs two to three passing ones on the IEA face
        (its largest bounds all stay above tol, so each runs Newton from both starts to
        convergence); half the trials of its starts fail.

        A refusal changes nothing the next measurement starts from, so it is kept and
        given again when a search asks for the same candidate (a count scan below a
        bisection, the second axis start repeating the first's second direction).
        """
        key = (tu.key, tv.key, lam, self.pinned)
        if key in self._refused:
            return self._refused[key]
        faired = self._faired(tu, tv, lam)
        excess = np.inf if self.inadmissible(faired) else self._coarse_excess(faired)
        if excess is not None:
            self.evaluations += 1
            self._refused[key] = (faired, None, excess)
            return self._refused[key]
        return self._measured(faired)

    def _coarse_excess(self, faired):
        """A true distance above tol among the ``SCREEN_SAMPLES`` largest bounds of the
        coarse grid, or ``None``."""
        probe = self.coarse_probe
        other, bound = probe.bound(faired)
        flat = bound.ravel()
        above = np.flatnonzero(flat > self.tol)
        if above.size == 0:
            return None
        largest = above[np.argsort(flat[above])[::-1][:SCREEN_SAMPLES]]
        exact = probe.true_distance(faired, other, largest, window=0, tol=self.tol,
                                    verdict=True).max()
        return float(exact) if exact > self.tol else None


def _held_solve(factors, moments, ends):
    """Coefficients with the two ``ends`` kept, ``moments`` = <Phi_T|Phi_S> c: the
    interior solved with ``factors`` (:func:`_held_ends`; ``None``: ends only)."""
    x = np.empty((moments.shape[0],) + ends.shape[1:])
    x[0], x[-1] = ends
    if factors is not None:
        lu, columns = factors
        x[1:-1] = lu.solve(moments[1:-1] - columns @ ends)
    return x


def _held_ends(matrix):
    """LU factors of a matrix's interior block and its first and last columns there:
    what a solve with the two end coefficients held needs."""
    m = sp.csr_matrix(matrix)
    return (spla.splu(sp.csc_matrix(m[1:-1, 1:-1])),
            m[1:-1][:, [0, m.shape[0] - 1]].toarray())


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


def _final_check(surface, per_span, max_samples, region=None, edges=None):
    """``check(faired)``: the exact two-sided maximum at ``per_span`` samples per span of
    the merged breakpoints of source and result, halved while the source's grid would
    exceed ``max_samples`` but never below the 8 per span of
    :func:`~cq_fairing.core.measures.deviation`, so a result is never accepted at a coarser
    density than the public measure reports (a 312 x 323 terrain was checked at 3 per span
    and passed at 23.06 where 8 per span find 23.44 > tol 23.11)."""
    spans = surface.u_space.n_spans, surface.v_space.n_spans
    while per_span > FINAL_MIN_PER_SPAN and \
            (spans[0] * per_span + 1) * (spans[1] * per_span + 1) > max_samples:
        per_span //= 2
    per_span = max(per_span, FINAL_MIN_PER_SPAN)

    def check(faired, search=None):
        uv = _grid((surface, faired), per_span, edges)
        probe = SurfaceProbe(surface, uv=uv, hold_grid=False, region=region)
        if search is not None:
            probe.adopt_feet(search)
        return probe.max_deviation(faired)[0]

    return check


def _grid(surfaces, per_span, edges=None):
    """Sample axes: ``per_span`` per span of the merged breakpoints of ``surfaces``, and
    the parameters ``edges`` ``(u values, v values)`` if given."""
    u = sample_parameters(*(s.u_space for s in surfaces), per_span=per_span)
    v = sample_parameters(*(s.v_space for s in surfaces), per_span=per_span)
    if edges is None:
        return u, v
    return np.union1d(u, edges[0]), np.union1d(v, edges[1])
