r"""Spline pieces in Taylor form, for evaluation at scattered parameters.

On a non-empty knot span :math:`[b_a, b_{a+1}]` with centre :math:`c_a` and half width
:math:`h_a`, each B-spline basis function of degree :math:`p` is one polynomial in the
local parameter :math:`r = (x - c_a) / h_a \in [-1, 1]`:

.. math::

    N_i(x) = \sum_{k=0}^{p} T_{a,i,k}\, r^k, \qquad
    T_{a,i,k} = \frac{N_i^{(k)}(c_a)\, h_a^k}{k!}.

A tensor-product surface with control points :math:`P_{ij}` is then, on the span pair
:math:`(a, b)`,

.. math::

    S(u, v) = \sum_{k} r^k \sum_{j} N_j(v)\, A_{a,k,j}
            = \sum_{k,l} r^k s^l A_{a,b,k,l}, \qquad
    A_{a,k,j} = \sum_{i} T^u_{a,i,k}\, P_{ij}, \qquad
    A_{a,b,k,l} = \sum_j T^v_{b,j,l}\, A_{a,k,j}.

The coefficients are computed once per surface: :math:`A_{a,k,j}` always (one matrix
product per u span), the full :math:`A_{a,b,k,l}` when it is small enough
(:class:`TaylorSurface`: it costs :math:`(p_u+1)(p_v+1)` numbers per span pair, 136 MB
and about a second to build on a 400 x 400 degree-5 net).  Evaluating :math:`S` and its
partial derivatives at :math:`q` scattered points is then a gather and a few
contractions, where the recurrences of The NURBS Book (A2.3) take :math:`O(p^2)` vector
operations per call: the closest-point Newton iterations of a tolerance search evaluate
small batches of points hundreds of times per fit.  The centred local parameters keep the
powers within :math:`[-1, 1]`.

This module imports numpy only.
"""

from dataclasses import dataclass, field
from functools import cache
from math import factorial

import numpy as np

from .spaces import basis_functions, find_spans, require_in_domain

__all__ = ["SpanTaylor", "TaylorSurface"]

CHUNK = 4096          # points evaluated at a time: their temporaries stay in the cache


LOOKUP_BELOW = 2048   # fewer parameters than this are located by a plain binary search


SPAN_FORMS = 128      # Taylor forms of spaces kept (:meth:`SpanTaylor.of`)
_SPAN_FORMS = {}


@dataclass(frozen=True, eq=False)
class SpanTaylor:
    """Taylor coefficients of a space's basis functions on each non-empty span.

    Attributes
    ----------
    space : SplineSpace
    breaks : ndarray, shape (m + 1,)
        Breakpoints (distinct knots).
    centres, halves : ndarray, shape (m,)
        Centre :math:`c_a` and half width :math:`h_a` of each span.
    first : ndarray of int, shape (m,)
        Index of the first basis function that is non-zero on each span.
    coefficients : ndarray, shape (m, p + 1, p + 1)
        :math:`T_{a,i,k}` for the ``p + 1`` basis functions ``first[a] + i``.
    lookup : SpanLookup
        Finds the span of a parameter (:meth:`locate_in_domain`).
    """

    space: object
    breaks: np.ndarray
    centres: np.ndarray
    halves: np.ndarray
    first: np.ndarray
    coefficients: np.ndarray
    lookup: "SpanLookup"
    _inverse_powers: dict = field(default_factory=dict, repr=False)

    @classmethod
    def of(cls, space):
        """The Taylor form of ``space``, built once per degree and knots (at most
        ``SPAN_FORMS`` kept): the candidates of a tolerance search share their spaces."""
        key = space.key
        if key not in _SPAN_FORMS:
            if len(_SPAN_FORMS) >= SPAN_FORMS:
                _SPAN_FORMS.clear()
            _SPAN_FORMS[key] = cls._built(space)
        return _SPAN_FORMS[key]

    @classmethod
    def _built(cls, space):
        """Build the Taylor form of ``space`` from its derivatives at the span centres."""
        p = space.degree
        b = space.breakpoints
        centres, halves = 0.5 * (b[:-1] + b[1:]), 0.5 * np.diff(b)
        spans = find_spans(space, centres)
        derivatives = basis_functions(space, centres, spans, p)   # (p + 1, m, p + 1)
        k = np.arange(p + 1)
        scale = halves[:, None] ** k / np.array([factorial(j) for j in k], dtype=float)
        coefficients = derivatives.transpose(1, 2, 0) * scale[:, None, :]
        return cls(space, b, centres, halves, spans - p, coefficients, SpanLookup(b))

    def locate(self, x):
        """Span index and local parameter ``r`` in [-1, 1] of each ``x`` (right end closed).

        Raises
        ------
        InvalidInputError
            If a parameter lies outside the domain.
        """
        require_in_domain(self.space, x)
        return self.locate_in_domain(x)

    def locate_in_domain(self, x):
        """As :meth:`locate`, for parameters already known to lie in the domain (the
        clamped iterates of a Newton loop): no check."""
        a = self.lookup(x)
        return a, (x - self.centres[a]) / self.halves[a]

    def powers(self, a, r, order):
        r"""Derivatives with respect to ``x`` of the monomials :math:`r^k`, orders 0..order.

        Returns
        -------
        ndarray, shape (q, order + 1, p + 1)
            Entry ``[:, d, k]`` holds :math:`(r^{k-d} \frac{k!}{(k-d)!})\, h_a^{-d}`,
            multiplied in that order (zero for ``k < d``; row 0 is :math:`r^k` itself).
        """
        p = self.space.degree
        values = np.zeros((order + 1, p + 1, r.size))
        plain = values[0]
        plain[0] = 1.0
        for k in range(1, p + 1):   # a row at a time: a twentieth of an accumulate's time
            np.multiply(plain[k - 1], r, out=plain[k])
        if order == 0:
            return plain.T[:, None, :]
        falling = _falling_table(p, order)
        inverse = self._inverse_power_table(order)[a]     # (q, order + 1)
        for d in range(1, min(order, p) + 1):
            terms = values[d, d:]
            np.multiply(plain[:p + 1 - d], falling[d, d:, None], out=terms)
            terms *= inverse[:, d]
        return values.transpose(2, 0, 1)

    def _inverse_power_table(self, order):
        """:math:`h_a^{-d}` for ``d = 0..order``, shape (m, order + 1), made once per order."""
        if order not in self._inverse_powers:
            self._inverse_powers[order] = (1.0 / self.halves)[:, None] ** np.arange(order + 1)
        return self._inverse_powers[order]


class SpanLookup:
    """The span index of parameters among breakpoints ``breaks``, the same as
    ``np.searchsorted(breaks[1:-1], x, side="right")`` (a breakpoint belongs to the span
    on its right, the right end to the last span, NaN to the last span) in about half
    its time on the thousands of scattered parameters of a Newton step.

    The domain is cut into ``per_span`` equal cells per span, each knowing the span at
    its left end.  A parameter takes its cell's span, moved one span right if it lies
    past that span's end; the few still outside their span (a cell holding several
    breakpoints, rounding at a cell's edge, NaN) are searched.  Fewer than
    ``LOOKUP_BELOW`` parameters are searched at once.
    """

    def __init__(self, breaks, per_span=4):
        interior = breaks[1:-1]
        self.interior = interior
        self.cells = per_span * (breaks.size - 1)
        self.start = breaks[0]
        width = breaks[-1] - breaks[0]
        self.scale = self.cells / width
        edges = breaks[0] + np.arange(self.cells) * (width / self.cells)
        self.span_at = np.searchsorted(interior, edges, side="right")
        # span a runs over [low[a], high[a]), open at the domain's ends; the entry past
        # the last span catches a parameter moved beyond it (x = inf), searched then
        self.low = np.concatenate([[-np.inf], interior, [np.inf]])
        self.high = np.concatenate([interior, [np.inf, np.inf]])

    def __call__(self, x):
        if x.size < LOOKUP_BELOW:
            return np.searchsorted(self.interior, x, side="right")
        t = (x - self.start) * self.scale
        np.fmin(t, self.cells - 1, out=t)    # fmin, fmax: NaN goes to a cell too
        np.fmax(t, 0.0, out=t)
        a = self.span_at.take(t.astype(np.intp))
        a += x >= self.high.take(a)
        outside = (x < self.low.take(a)) | ~(x < self.high.take(a))
        if outside.any():
            a[outside] = np.searchsorted(self.interior, x[outside], side="right")
        return a


@cache
def _falling_table(degree, order):
    """Falling factorials ``k! / (k - d)!`` (zero for ``k < d``), shape
    (order + 1, degree + 1): the ``d``-th derivative of ``r^k`` is
    ``falling[d, k] * r ** (k - d)``."""
    return np.array([[factorial(k) // factorial(k - d) if k >= d else 0
                      for k in range(degree + 1)] for d in range(order + 1)], dtype=float)


class TaylorSurface:
    r"""A tensor-product spline in Taylor form on each span pair.

    The coefficients :math:`A_{a,k,j}` (Taylor along u, poles along v) are always kept.
    When the full form :math:`A_{a,b,k,l} = \sum_j T^v_{b,j,l} A_{a,k,j}` has at most
    ``full_limit`` numbers it is kept too, and evaluation skips the v basis: about
    twice as fast for second derivatives, at a build cost that grows with the span pairs.

    Parameters
    ----------
    u_space, v_space : SplineSpace
    coefficients : ndarray, shape (k_u, k_v, D)
        Control points (homogeneous ones for a rational surface).
    full_limit : int
        Largest size of the full form (default 4 million numbers, 32 MB: up to about
        290 x 290 bicubic spans; the 400 x 400 bicubic blade would need 61 MB and half a
        second to build).
    """

    def __init__(self, u_space, v_space, coefficients, full_limit=4_000_000):
        self.u = SpanTaylor.of(u_space)
        self.v = SpanTaylor.of(v_space)
        self.n_v = coefficients.shape[1]
        m_u, p_u = self.u.centres.size, u_space.degree
        iu = self.u.first[:, None] + np.arange(p_u + 1)
        gathered = coefficients[iu].reshape(m_u, p_u + 1, -1)          # (a, i, j D)
        along_u = np.matmul(self.u.coefficients.transpose(0, 2, 1), gathered)
        # both forms are stored with the (k, D) block last and contiguous: the
        # contraction over the v index then runs ten times faster than over (k, l, D)
        along_u = np.ascontiguousarray(
            along_u.reshape(m_u, p_u + 1, self.n_v, -1).transpose(0, 2, 1, 3))  # (a, j, k, D)
        self._along_u = along_u.reshape(m_u * self.n_v, p_u + 1, -1)
        self._by_pair = None
        self._by_dim = coefficients.shape[-1]
        self._chunk = CHUNK
        m_v, p_v, dim = self.v.centres.size, v_space.degree, along_u.shape[-1]
        if m_u * m_v * (p_u + 1) * (p_v + 1) * dim <= full_limit:
            iv = self.v.first[:, None] + np.arange(p_v + 1)
            by_pair = np.einsum("bjl,abjkd->ablkd", self.v.coefficients, along_u[:, iv])
            self._by_pair = by_pair.reshape((-1,) + by_pair.shape[2:])

    @property
    def is_full(self):
        """True when the full per-span-pair form is kept."""
        return self._by_pair is not None

    def derivatives(self, u, v, order):
        """Partial derivatives ``{(i, j): d^(i+j) S / du^i dv^j}`` for ``i + j <= order``.

        Parameters
        ----------
        u, v : ndarray, shape (q,)
            Parameters inside the domain.
        order : int

        Returns
        -------
        dict of ndarray, each shape (q, D)

        Raises
        ------
        InvalidInputError
            If a parameter lies outside the domain.
        """
        require_in_domain(self.u.space, u)
        require_in_domain(self.v.space, v)
        return self.derivatives_in_domain(u, v, order)

    def derivatives_in_domain(self, u, v, order):
        r"""As :meth:`derivatives`, for parameters known to lie in the domain (no check).

        Two batched matrix products per point, whatever the order: with
        :math:`V_{q,j,l} = \partial_v^j s^l` and :math:`U_{q,i,k} = \partial_u^i r^k`,
        :math:`\partial_u^i \partial_v^j S = \sum_k U_{q,i,k} \sum_l V_{q,j,l}
        A_{a_q,b_q,k,l}` (a Newton step evaluates a few hundred points, and there the
        number of numpy calls, not the arithmetic, sets the time).  Many points are
        evaluated ``CHUNK`` at a time: the gathered coefficients and products of a chunk
        stay in the cache, and each point's value is the same bit for bit (each product
        is one BLAS call per point, with the same operand layout whatever the chunk).
        """
        q = u.size
        if q <= self._chunk:
            table = np.ascontiguousarray(self._table(u, v, order))
        else:
            table = np.empty((q, order + 1, order + 1, self._by_dim))
            edges = list(range(0, q, self._chunk)) + [q]
            if edges[-1] - edges[-2] == 1:   # no point alone: its row of powers would
                del edges[-2]                 # be contiguous, a BLAS path that rounds apart
            for first, last in zip(edges[:-1], edges[1:]):
                table[first:last] = self._table(u[first:last], v[first:last], order)
        return {(i, j): table[:, i, j]
                for i in range(order + 1) for j in range(order + 1 - i)}

    def _table(self, u, v, order):
        r"""The partial derivatives :math:`\partial_u^i \partial_v^j S` for ``i, j <= order``
        at ``q`` points, shape (q, i, j, D) (possibly a non-contiguous view)."""
        a, r = self.u.locate_in_domain(u)
        b, s = self.v.locate_in_domain(v)
        pu, pv = self.u.powers(a, r, order), self.v.powers(b, s, order)
        if self.is_full:
            local = self._by_pair.take(a * self.v.centres.size + b, axis=0)   # (q, l, k, D)
            weights = pv                                                       # (q, j, l)
        else:
            poles = (a * self.n_v + self.v.first[b])[:, None] + np.arange(self.v.space.degree + 1)
            local = self._along_u.take(poles, axis=0)                         # (q, n, k, D)
            taylor_v = self.v.coefficients.take(b, axis=0)                     # (q, n, l)
            weights = np.matmul(pv, taylor_v.transpose(0, 2, 1))              # (q, j, n)
        q, n, k, dim = local.shape
        local = local.reshape(q, n, k * dim)
        if order == 0:
            rows = np.matmul(weights, local)                                   # (q, 1, k D)
            return np.matmul(pu, rows.reshape(q, k, dim))[:, None]
        # the rows transposed, (q, k D, j): k leads, and the second product takes them
        # without a copy (each entry is the same sum of the same products)
        rows = np.matmul(local.transpose(0, 2, 1), weights.transpose(0, 2, 1))
        table = np.matmul(pu, rows.reshape(q, k, dim * (order + 1)))           # (q, i, D j)
        return table.reshape(q, order + 1, dim, order + 1).transpose(0, 1, 3, 2)
