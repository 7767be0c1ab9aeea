"""Exact Gram matrices: dense quadrature, closed forms, symmetry, band structure."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cq_fairing import SplineSpace
from cq_fairing.core.banded import BandedSPD, bandwidth
from cq_fairing.core.gram import gram_matrix, sandwiched

from .naive import dense_gram, random_clamped_knots


@given(deg_a=st.integers(1, 5), deg_b=st.integers(1, 8), ka=st.integers(0, 15),
       kb=st.integers(0, 25), seed=st.integers(0, 2**31 - 1), nu=st.integers(0, 2))
def test_gram_matches_dense_quadrature(deg_a, deg_b, ka, kb, seed, nu):
    rng = np.random.default_rng(seed)
    ta = random_clamped_knots(rng, deg_a + 1 + ka, deg_a)
    tb = random_clamped_knots(rng, deg_b + 1 + kb, deg_b)
    a, b = SplineSpace.from_knots(ta, deg_a), SplineSpace.from_knots(tb, deg_b)
    ours = gram_matrix(a, b, nu).toarray()
    ref = dense_gram(ta, deg_a, tb, deg_b, nu)
    assert np.allclose(ours, ref, rtol=1e-9, atol=1e-11 * np.abs(ref).max())


def test_row_sums_equal_the_integral_of_each_basis_function():
    # sum_j <N_i, N_j> = int N_i = (t_{i+p+1} - t_i) / (p + 1)  (partition of unity)
    rng = np.random.default_rng(3)
    t = random_clamped_knots(rng, 40, 3)
    s = SplineSpace.from_knots(t, 3)
    g = gram_matrix(s).toarray()
    assert np.allclose(g.sum(axis=1), (t[4:4 + 40] - t[:40]) / 4, rtol=1e-13)


def test_hand_computed_entries_of_the_uniform_cubic_gram():
    # interior uniform cubic B-splines on unit spans: <N, N(.-j)> = 151/315, 397/1680, 1/42, 1/5040
    s = SplineSpace.quasi_uniform(20)
    g = gram_matrix(s).toarray() * 20  # spans of length 1/20
    row = g[10, 7:14]
    assert np.allclose(row, [1 / 5040, 1 / 42, 397 / 1680, 151 / 315, 397 / 1680, 1 / 42, 1 / 5040],
                       rtol=1e-12)


def test_gram_is_banded_and_the_banded_solver_is_exact():
    s = SplineSpace.quasi_uniform(500, 3)
    g = gram_matrix(s)
    assert bandwidth(g) == 3
    rhs = np.random.default_rng(0).normal(size=(s.dimension, 4))
    x = BandedSPD(g).solve(rhs)
    assert np.allclose(g @ x, rhs, atol=1e-10)


@settings(max_examples=40, deadline=None)
@given(shape=st.tuples(*[st.integers(1, 9)] * 5), seed=st.integers(0, 2**31 - 1))
def test_sandwiched_is_the_plain_sum_over_both_indices(shape, seed):
    """L C R^T per coordinate against the explicit double sum over a and b."""
    i, a, b, j, d = shape
    rng = np.random.default_rng(seed)
    left, net, right = rng.normal(size=(i, a)), rng.normal(size=(a, b, d)), rng.normal(size=(j, b))
    expected = np.zeros((i, j, d))
    for p in range(a):
        for q in range(b):
            expected += left[:, p, None, None] * right[None, :, q, None] * net[p, q]
    assert np.allclose(sandwiched(left, net, right), expected, rtol=1e-12, atol=1e-12)
