"""Span-weighted projections against a dense quadrature on a fine grid (naive bases)."""

import numpy as np
import scipy.sparse as sp
from hypothesis import given
from hypothesis import strategies as st

from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.gram import gram_matrix, quadrature_rule
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.core.weighted import SpanWeightedProjection

from .naive import basis_matrix, random_clamped_knots


def _knots(rng, k, degree, double):
    """Random clamped knots; with ``double`` one interior knot is repeated (a source with
    a kink, like the impeller face's double knot)."""
    knots = random_clamped_knots(rng, k, degree)
    inner = knots[degree + 1:-degree - 1]
    if double and inner.size >= 2 and degree >= 2:
        knots = np.sort(np.concatenate([knots[:degree + 1], inner[:-1], inner[:1],
                                        knots[-degree - 1:]]))
    return knots


def _patch_quadrature(source_knots, target_knots, points=12):
    """Nodes, weights and source span of each node: 12 Gauss points on every interval of
    the merged knots (exact far beyond the degrees used here)."""
    breaks = np.union1d(source_knots, target_knots)
    x, w = quadrature_rule(breaks, points)
    inner = np.unique(source_knots)
    return x, w, np.searchsorted(inner, x, side="right") - 1


@given(source_degrees=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       target_degrees=st.tuples(st.integers(1, 6), st.integers(1, 6)),
       extra=st.tuples(st.integers(0, 8), st.integers(0, 8), st.integers(0, 6), st.integers(0, 6)),
       double=st.booleans(), seed=st.integers(0, 2**31 - 1))
def test_weighted_normal_equations_match_a_dense_quadrature(source_degrees, target_degrees,
                                                            extra, double, seed):
    r""":math:`\sum w_{\sigma\tau} G_u^\sigma\otimes G_v^\tau` and the moments, against
    :math:`\sum_q \omega_q\, b(q) b(q)^T` on a fine tensor quadrature whose weights carry
    the weight of the source patch each node lies in (dense bases from the textbook
    recursion), for random knots, degrees and weights."""
    rng = np.random.default_rng(seed)
    ks = [p + 1 + e for p, e in zip(source_degrees, extra[:2])]
    kt = [p + 1 + e for p, e in zip(target_degrees, extra[2:])]
    sk = [_knots(rng, k, p, double) for k, p in zip(ks, source_degrees)]
    tk = [random_clamped_knots(rng, k, p) for k, p in zip(kt, target_degrees)]
    ks = [t.size - p - 1 for t, p in zip(sk, source_degrees)]
    poles = rng.normal(size=(ks[0], ks[1], 3))
    source = BSplineSurface(poles, sk[0], sk[1], *source_degrees)
    targets = [SplineSpace.from_knots(t, p) for t, p in zip(tk, target_degrees)]
    projection = SpanWeightedProjection(source, *targets)
    weights = rng.uniform(0.1, 10.0, size=projection.shape)

    (xu, wu, su), (xv, wv, sv) = (_patch_quadrature(s, t) for s, t in zip(sk, tk))
    omega = np.outer(wu, wv) * weights[su][:, sv]
    bu, bv = (basis_matrix(t, p, x) for t, p, x in zip(tk, target_degrees, (xu, xv)))
    values = np.einsum("ua,abd,vb->uvd", basis_matrix(sk[0], source_degrees[0], xu), poles,
                       basis_matrix(sk[1], source_degrees[1], xv))
    matrix = np.einsum("ui,uk,uv,vj,vl->ijkl", bu, bu, omega, bv, bv)
    moments = np.einsum("ui,uv,vj,uvd->ijd", bu, omega, bv, values)

    for direction in (projection.u, projection.v):   # every cross integral in its window
        span, function = np.nonzero(np.abs(direction.cross).sum(axis=2))
        offset = function - direction.start[span]
        assert offset.min() >= 0 and offset.max() < direction.width <= direction.k

    n = kt[0] * kt[1]
    assert np.allclose(projection.matrix(weights).toarray(), matrix.reshape(n, n),
                       rtol=1e-10, atol=1e-12 * np.abs(matrix).max())
    assert np.allclose(projection.moments(weights), moments, rtol=1e-10,
                       atol=1e-12 * np.abs(moments).max())


def test_unit_weights_give_the_exact_projection():
    """At w = 1 the matrix is the Kronecker product of the Gram matrices and the moments
    are the cross Gram matrices applied to the net: the plain projection."""
    rng = np.random.default_rng(7)
    su, sv = SplineSpace.quasi_uniform(9, 3), SplineSpace.quasi_uniform(13, 3)
    tu, tv = SplineSpace.quasi_uniform(4, 5), SplineSpace.quasi_uniform(6, 4)
    poles = rng.normal(size=(su.dimension, sv.dimension, 3))
    source = BSplineSurface(poles, su.knots, sv.knots, 3, 3)
    projection = SpanWeightedProjection(source, tu, tv)
    ones = np.ones(projection.shape)
    kron = sp.kron(gram_matrix(tu), gram_matrix(tv)).toarray()
    assert np.allclose(projection.matrix(ones).toarray(), kron, rtol=1e-12, atol=1e-15)
    cross = np.einsum("ia,abd,jb->ijd", gram_matrix(tu, su).toarray(), poles,
                      gram_matrix(tv, sv).toarray())
    assert np.allclose(projection.moments(ones), cross, rtol=1e-12, atol=1e-14)
