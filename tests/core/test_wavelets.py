"""Null-space wavelets: the seed's m=10, n=5 example, rank, compact support, E Q = 0."""

import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from cq_fairing import NumericalError, SplineSpace
from cq_fairing.core.decomposition import Decomposition
from cq_fairing.core.gram import gram_matrix
from cq_fairing.core.wavelets import wavelet_matrix

from .naive import random_clamped_knots


def _pair(m, n, degree=3):
    """E and the wavelets the product uses (compact unless n > 0.4 m, non-nested)."""
    source, target = SplineSpace.quasi_uniform(m, degree), SplineSpace.quasi_uniform(n, degree)
    d = Decomposition(source, target)
    return d.E, d.Q.toarray()


def test_seed_example_m10_n5():
    """Ji et al. (null space paper): E is 8 x 13, five wavelets, columns scaled to max 1."""
    E, Q = _pair(10, 5)
    assert E.shape == (8, 13)
    assert Q.shape == (13, 5)
    assert np.allclose(Q.max(axis=0), 1.0)
    assert np.abs(E @ Q).max() < 1e-14 * np.abs(E).max() * 13
    assert np.linalg.matrix_rank(Q) == 5
    # every wavelet lies inside one of the seed's 9-column windows (columns i..i+8, 1-based)
    for i in range(5):
        support = np.flatnonzero(np.abs(Q[:, i]) > 0)
        assert support.min() >= i and support.max() <= i + 8
    # inner wavelet symmetric, the others mirror images in pairs; end wavelets asymmetric
    mirrored = Q[::-1, ::-1]
    assert np.allclose(Q, mirrored, atol=1e-12)
    middle = Q[:, 2]
    assert np.allclose(middle, middle[::-1], atol=1e-12)
    end = Q[:, 0][np.abs(Q[:, 0]) > 0]
    assert not np.allclose(end, end[::-1], atol=1e-3)


@given(m=st.integers(2, 160), data=st.data())
def test_rank_is_m_minus_n_and_wavelets_are_in_the_null_space(m, data):
    n = data.draw(st.integers(1, m - 1))
    E, Q = _pair(m, n)
    assert Q.shape == (m + 3, m - n)
    assert np.linalg.matrix_rank(Q, tol=1e-9) == m - n
    assert np.abs(E @ Q).max() <= 1e-9 * np.abs(E).max()


@given(degree=st.integers(1, 6), extra=st.integers(4, 60), seed=st.integers(0, 2**31 - 1),
       data=st.data())
def test_general_sources_any_degree_and_knots(degree, extra, seed, data):
    rng = np.random.default_rng(seed)
    k = degree + 1 + extra
    source = SplineSpace.from_knots(random_clamped_knots(rng, k, degree), degree)
    n = data.draw(st.integers(1, max(1, (k - 3) // 3)))
    target = SplineSpace.quasi_uniform(n, 3)
    E = gram_matrix(target, source)
    try:
        Q = wavelet_matrix(E).toarray()
    except NumericalError:
        dense_rank = np.linalg.matrix_rank(E.toarray(), tol=1e-10 * np.abs(E).max())
        assume(False) if dense_rank < target.dimension else pytest.fail("refused a full-rank E")
        return
    assert np.linalg.matrix_rank(Q, tol=1e-9) == k - target.dimension
    assert np.abs(E @ Q).max() <= 1e-9 * np.abs(E).max()


@given(m=st.integers(3, 160), data=st.data())
def test_compact_path_has_full_rank_up_to_the_ratio_limit(m, data):
    n = data.draw(st.integers(1, max(1, int(0.4 * m))))
    source, target = SplineSpace.quasi_uniform(m), SplineSpace.quasi_uniform(n)
    E = gram_matrix(target, source)
    Q = wavelet_matrix(E, compact=True).toarray()
    assert np.linalg.matrix_rank(Q, tol=1e-9) == m - n
    assert np.abs(E @ Q).max() <= 1e-9 * np.abs(E).max()


def test_wavelets_are_compactly_supported_for_coarse_targets():
    _, Q = _pair(1299, 78)
    widths = [np.ptp(np.flatnonzero(Q[:, i])) + 1 for i in range(Q.shape[1])]
    assert max(widths) <= 12  # columns, independent of m


def test_rank_deficient_pairs_are_refused_with_a_clear_error():
    # six uniform hats cannot be resolved by a source with one long span on [0.37, 1]
    source = SplineSpace.from_knots([0, 0, 0.07, 0.16, 0.17, 0.36, 0.37, 1, 1], 1)
    target = SplineSpace.quasi_uniform(5, 1)
    assert np.linalg.matrix_rank(gram_matrix(target, source).toarray()) == 5 < 6
    with pytest.raises(NumericalError, match="not resolved"):
        wavelet_matrix(gram_matrix(target, source))


@pytest.mark.parametrize("m, n", [(1000, 997), (2000, 1990), (300, 290), (200, 150)])
def test_near_m_wavelets_are_exact_and_full_rank(m, n):
    """n close to m: global null vectors from banded projections (no dense SVD of E).

    Checked against a dense reference: the columns span the null space of E (rank
    m - n of Q, and of [Q | N] with N from a dense SVD), E Q = 0 to rounding, and the
    decomposition reconstructs to rounding.  Its speed is measured by
    ``benchmarks/bench_core.py`` (``near_m_rows``).
    """
    import scipy.linalg as la

    import cq_fairing as cf

    poles = np.random.default_rng(m).normal(size=(m + 3, 3))
    result = cf.fair_curve(poles, n)
    E, Q = _pair(m, n)
    assert np.abs(E @ Q).max() <= 1e-12 * np.abs(E).max()
    assert np.linalg.matrix_rank(Q) == m - n
    if m <= 1000:
        null = la.null_space(E.toarray())
        assert np.linalg.matrix_rank(np.hstack([Q, null]), tol=1e-8) == m - n
    assert np.abs(result.reconstruct() - poles).max() <= 1e-12 * np.abs(poles).max()
