r"""Exact Gram (inner-product) matrices between spline spaces.

For two spaces :math:`A` (degree :math:`p_a`) and :math:`B` (degree :math:`p_b`)
on the same domain, the Gram matrix is

.. math::  G^{(\nu)}_{ij} = \int N^{A\,(\nu)}_i(t)\, N^{B\,(\nu)}_j(t)\, dt .

On every interval between consecutive breakpoints of the *merged* knot sets the
integrand is one polynomial of degree :math:`p_a + p_b - 2\nu`, so Gauss-Legendre
quadrature with :math:`\lceil (p_a + p_b - 2\nu + 1)/2 \rceil` nodes per interval
is exact (up to rounding).  Each row has at most
:math:`(p_a + 1)(\text{spans of } B \text{ it meets})` non-zeros, so the matrices are
kept sparse (banded): building and applying them costs :math:`O(k_a + k_b)`.

References
----------
Ji, Xue, Yang, He (2014), eq. (5)-(6): :math:`\langle\Phi_n|\Phi_n\rangle`,
:math:`\langle\Phi_n|\Phi_m\rangle`.
"""

from functools import lru_cache

import numpy as np
import scipy.sparse as sp

from ..errors import InvalidInputError
from .spaces import basis_functions, find_spans

__all__ = ["gram_matrix", "quadrature_rule", "merged_breakpoints", "interval_products",
           "sandwiched"]


def quadrature_rule(breakpoints, points_per_interval):
    """Composite Gauss-Legendre nodes and weights over consecutive breakpoints.

    Parameters
    ----------
    breakpoints : ndarray, shape (s + 1,)
        Increasing interval ends.
    points_per_interval : int

    Returns
    -------
    nodes, weights : ndarray, shape (s * points_per_interval,)
    """
    ref_x, ref_w = _gauss_legendre(points_per_interval)
    a, b = breakpoints[:-1, None], breakpoints[1:, None]
    half = 0.5 * (b - a)
    nodes = (a + b) * 0.5 + half * ref_x[None, :]
    weights = half * ref_w[None, :]
    return nodes.ravel(), weights.ravel()


def sandwiched(left, net, right):
    r""":math:`L\,C\,R^T` for each coordinate of a net: :math:`\sum_{a,b} L_{ia} C_{abd}
    R_{jb}`, shape ``(i, j, d)`` (the moments :math:`E_u C E_v^T` of a tensor-product
    projection, :math:`E = \langle\Phi_n|\Phi_S\rangle`).

    Two matrix products, :math:`O(i\,a\,b\,d + i\,j\,b\,d)`: a three-operand
    ``einsum`` without a contraction order loops over all five indices at once, 12 s
    where this takes 0.02 s (a 312 x 323 net onto 120 x 110).

    Parameters
    ----------
    left : array_like, shape (i, a)
    net : ndarray, shape (a, b, d)
    right : array_like, shape (j, b)
    """
    along_u = np.tensordot(np.asarray(left), net, axes=(1, 0))     # (i, b, d)
    return np.matmul(np.asarray(right), along_u)                    # (i, j, d)


@lru_cache(maxsize=32)
def _gauss_legendre(points):
    """Reference nodes and weights on [-1, 1] (cached: numpy recomputes them each call)."""
    return np.polynomial.legendre.leggauss(points)


def gram_matrix(space_a, space_b=None, nu=0):
    r"""Exact sparse Gram matrix :math:`\langle \Phi_a^{(\nu)} | \Phi_b^{(\nu)} \rangle`.

    Parameters
    ----------
    space_a, space_b : SplineSpace
        Spaces on the same parameter domain; ``space_b`` defaults to ``space_a``.
    nu : int, optional
        Derivative order of both factors (0 for the L2 inner product, 2 for the
        bending-energy matrix).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (k_a, k_b)

    Raises
    ------
    InvalidInputError
        If the domains differ.
    """
    if space_b is None:
        space_b = space_a
    dom_a, dom_b = np.array(space_a.domain), np.array(space_b.domain)
    scale = max(1.0, float(np.abs(dom_a).max()))
    if np.abs(dom_a - dom_b).max() > 1e-12 * scale:
        raise InvalidInputError(
            f"Gram matrices need spaces on one domain, got {tuple(dom_a)} and {tuple(dom_b)}; "
            "reparameterise one of them."
        )
    merged = merged_breakpoints(space_a, space_b)
    rows, cols, products = interval_products(space_a, space_b, merged, nu)
    shape = products.shape
    coo = sp.coo_matrix(
        (products.ravel(),
         (np.broadcast_to(rows[:, :, None], shape).ravel(),
          np.broadcast_to(cols[:, None, :], shape).ravel())),
        shape=(space_a.dimension, space_b.dimension),
    )
    return coo.tocsr()  # sums the contributions of intervals that share basis functions


def merged_breakpoints(space_a, space_b):
    """Breakpoints of both spaces inside ``space_a``'s domain, near-duplicates (closer than
    1e-13 of the domain) dropped, the last one the domain's end exactly."""
    lo, hi = space_a.domain
    merged = np.union1d(space_a.breakpoints, space_b.breakpoints)
    merged = merged[(merged >= lo) & (merged <= hi)]
    merged = merged[np.concatenate([[True], np.diff(merged) > 1e-13 * (hi - lo)])]
    merged[-1] = hi
    return merged


def interval_products(space_a, space_b, merged, nu=0):
    r"""Exact :math:`\int_I \phi_i^{(\nu)} \psi_j^{(\nu)}` over each interval ``I`` of
    ``merged`` (breakpoints of both spaces, :func:`merged_breakpoints`), for the
    :math:`p + 1` functions of each space non-zero there.

    Returns
    -------
    rows : ndarray of int, shape (s, p_a + 1)
    cols : ndarray of int, shape (s, p_b + 1)
        Indices of those functions in ``space_a`` and ``space_b``.
    products : ndarray, shape (s, p_a + 1, p_b + 1)
    """
    degree = max(space_a.degree + space_b.degree - 2 * nu, 0)
    per_interval = degree // 2 + 1
    nodes, weights = quadrature_rule(merged, per_interval)
    rows, values_a = _local_basis(space_a, nodes, nu)
    cols, values_b = (rows, values_a) if space_b is space_a else _local_basis(space_b, nodes, nu)
    # the nodes of one merged interval share their spans in both spaces: sum the products
    # over each interval's nodes first, (s, p_a + 1, n) @ (s, n, p_b + 1)
    s = merged.size - 1
    weighted = (weights[:, None] * values_a).reshape(s, per_interval, -1).transpose(0, 2, 1)
    products = np.matmul(weighted, values_b.reshape(s, per_interval, -1))
    return rows[::per_interval], cols[::per_interval], products


def _local_basis(space, nodes, nu):
    """Indices and values of the ``p + 1`` basis functions non-zero at each node."""
    spans = find_spans(space, nodes)
    values = basis_functions(space, nodes, spans, nu)[nu]
    index = spans[:, None] - space.degree + np.arange(space.degree + 1)[None, :]
    return index, values
