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

from dataclasses import dataclass
from functools import cache
from math import factorial

import numpy as np

from .spaces import basis_functions, find_spans, require_in_domain

__all__ = ["SpanTaylor", "TaylorSurface"]


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
    """

    space: object
    breaks: np.ndarray
    centres: np.ndarray
    halves: np.ndarray
    first: np.ndarray
    coefficients: np.ndarray

    @classmethod
    def of(cls, space):
        """Build the Taylor form of ``space`` from its derivatives at the span centres."""
        p = space.degree
        b = space.breakpoints
        centres, halves = 0.5 * (b[:-1] + b[1:]), 0.5 * np.diff(b)
        spans = find_spans(space, centres)
        derivatives = basis_functions(space, centres, spans, p)   # (p + 1, m, p + 1)
        k = np.arange(p + 1)
        scale = halves[:, None] ** k / np.array([factorial(j) for j in k], dtype=float)
        coefficients = derivatives.transpose(1, 2, 0) * scale[:, None, :]
        return cls(space, b, centres, halves, spans - p, coefficients)

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
        a = np.searchsorted(self.breaks[1:-1], x, side="right")   # interior breaks: no clip
        return a, (x - self.centres[a]) / self.halves[a]

    def powers(self, a, r, order):
        r"""Derivatives with respect to ``x`` of the monomials :math:`r^k`, orders 0..order.

        Returns
        -------
        ndarray, shape (q, order + 1, p + 1)
            Entry ``[:, d, k]`` holds :math:`\frac{k!}{(k-d)!} r^{k-d} / h_a^d` (zero for
            ``k < d``).
        """
        exponents, falling = _falling_table(self.space.degree, order)
        p = self.space.degree
        plain = np.empty((p + 1, r.size))
        plain[0] = 1.0
        for k in range(1, p + 1):   # a row at a time: a twentieth of an accumulate's time
            np.multiply(plain[k - 1], r, out=plain[k])
        if order == 0:
            return plain.T[:, None, :]
        # the powers of 1 / h per span, gathered: one power per span instead of per point
        inverse = ((1.0 / self.halves)[:, None] ** np.arange(order + 1))[a]
        values = plain[exponents]                      # (order + 1, p + 1, q)
        values *= falling[:, :, None]
        values *= inverse.T[:, None, :]
        return values.transpose(2, 0, 1)


@cache
def _falling_table(degree, order):
    """Exponents ``max(k - d, 0)`` and falling factorials ``k! / (k - d)!`` (zero for
    ``k < d``), shape (order + 1, degree + 1): the ``d``-th derivative of ``r^k`` is
    ``falling[d, k] * r ** exponents[d, k]``."""
    k = np.arange(degree + 1)
    d = np.arange(order + 1)[:, None]
    falling = np.array([[factorial(j) // factorial(j - e) if j >= e else 0 for j in k]
                        for e in range(order + 1)], dtype=float)
    return np.maximum(k - d, 0), falling


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

        Two batched matrix products per call, whatever the order: with
        :math:`V_{q,j,l} = \partial_v^j s^l` and :math:`U_{q,i,k} = \partial_u^i r^k`,
        :math:`\partial_u^i \partial_v^j S = \sum_k U_{q,i,k} \sum_l V_{q,j,l}
        A_{a_q,b_q,k,l}` (a Newton step evaluates a few hundred points, and there the
        number of numpy calls, not the arithmetic, sets the time).
        """
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
        rows = np.matmul(weights, local.reshape(q, n, k * dim))               # (q, j, k D)
        rows = rows.reshape(q, order + 1, k, dim).transpose(0, 2, 1, 3)
        table = np.matmul(pu, rows.reshape(q, k, (order + 1) * dim))          # (q, i, j D)
        table = table.reshape(q, order + 1, order + 1, dim)
        return {(i, j): table[:, i, j]
                for i in range(order + 1) for j in range(order + 1 - i)}
