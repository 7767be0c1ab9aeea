"""One ARWFA/DWFA step against a naive dense implementation, and exact reconstruction."""

import numpy as np
import pytest
import scipy.linalg as la
from hypothesis import given
from hypothesis import strategies as st

from cq_fairing import SplineSpace
from cq_fairing.core.decomposition import Decomposition, is_subspace, refinement_matrix
from cq_fairing.errors import NumericalError

from .naive import basis_matrix, dense_coarse, dense_gram, quasi_uniform_knots, random_clamped_knots


@pytest.mark.parametrize("m, n", [(117, 27), (1299, 78), (117, 7), (10, 5), (64, 16), (256, 128)])
def test_coarse_projection_matches_dense_reference(m, n):
    rng = np.random.default_rng(m * 1000 + n)
    source, target = SplineSpace.quasi_uniform(m), SplineSpace.quasi_uniform(n)
    c = rng.normal(size=(m + 3, 3))
    ours = Decomposition(source, target).coarse(c)
    ref = dense_coarse(source.knots, 3, target.knots, 3, c)
    assert np.allclose(ours, ref, rtol=0, atol=1e-9 * np.abs(ref).max())


@given(degree=st.integers(1, 8), extra=st.integers(6, 80), seed=st.integers(0, 2**31 - 1),
       data=st.data())
def test_general_source_space_matches_dense_reference(degree, extra, seed, data):
    rng = np.random.default_rng(seed)
    k = degree + 1 + extra
    knots = random_clamped_knots(rng, k, degree)
    source = SplineSpace.from_knots(knots, degree)
    n = data.draw(st.integers(1, max(1, k // 4)))
    target = SplineSpace.quasi_uniform(n, 3)
    c = rng.normal(size=(k, 2))
    ours = Decomposition(source, target).coarse(c)
    ref = dense_coarse(knots, degree, target.knots, 3, c)
    assert np.allclose(ours, ref, atol=1e-9 * max(1.0, np.abs(ref).max()))


def test_details_match_the_seed_formula_with_dense_matrices():
    """D_n = <Psi|Psi>^-1 <Psi|Phi_m> C_m with Psi = Phi_m Q (eq. 8-10)."""
    rng = np.random.default_rng(1)
    source, target = SplineSpace.quasi_uniform(117), SplineSpace.quasi_uniform(27)
    d = Decomposition(source, target)
    c = rng.normal(size=(120, 3))
    Q = d.Q.toarray()
    g = dense_gram(source.knots, 3, source.knots, 3)
    ref = la.solve(Q.T @ g @ Q, Q.T @ g @ c)
    assert np.allclose(d.detail(c), ref, atol=1e-9 * np.abs(ref).max())


@given(m=st.integers(4, 400), data=st.data(), seed=st.integers(0, 2**31 - 1))
def test_one_direct_step_reconstructs_exactly_for_moderate_ratios(m, data, seed):
    n = data.draw(st.integers(max(1, m // 16), max(1, m // 3)))
    rng = np.random.default_rng(seed)
    d = Decomposition(SplineSpace.quasi_uniform(m), SplineSpace.quasi_uniform(n))
    c = rng.normal(size=(m + 3, 3)) * 100
    rebuilt = d.reconstruct(d.coarse(c), d.detail(c))
    assert np.abs(rebuilt - c).max() <= 1e-10 * np.abs(c).max()


def test_direct_steps_are_refused_at_extreme_ratios_which_is_why_the_ladder_exists():
    """One step 300 -> 1 (wavelet Gram condition ~1.5e14, ~1e-5 lost) is refused; the
    default ladder stays exact."""
    from cq_fairing import fair_curve

    c = np.random.default_rng(4).normal(size=(303, 3))
    d = Decomposition(SplineSpace.quasi_uniform(300), SplineSpace.quasi_uniform(1))
    with pytest.raises(NumericalError, match="ratio 300.*condition number"):
        d.detail(c)
    ladder = fair_curve(c, 1)
    assert ladder.scales == (300, 64, 32, 16, 8, 4, 2, 1)
    assert np.abs(ladder.reconstruct() - c).max() < 1e-12 * np.abs(c).max() * 100


def test_condition_estimate_matches_the_dense_one_norm_condition():
    d = Decomposition(SplineSpace.quasi_uniform(200), SplineSpace.quasi_uniform(20))
    dense = (d._wavelet_moments @ d.Q).toarray()
    exact = np.linalg.cond(dense, 1)
    assert exact / 3 <= d.wavelet_gram.condition_estimate() <= exact * (1 + 1e-8)


def test_analysis_and_synthesis_are_inverse_matrices():
    """[A; B] [P | Q_r] = I, the seed's eq. (12)-(14)."""
    d = Decomposition(SplineSpace.quasi_uniform(40), SplineSpace.quasi_uniform(17))
    eye_n, eye_w = np.eye(20), np.eye(23)
    P = d.reconstruct(eye_n, np.zeros((23, 20)))
    Qr = d.reconstruct(np.zeros((20, 23)), eye_w)
    A, B = d.coarse(np.eye(43)), d.detail(np.eye(43))
    assert np.allclose(np.vstack([A, B]) @ np.hstack([P, Qr]), np.eye(43), atol=1e-10)


@pytest.mark.parametrize("coarse_n, fine_n, degree", [(8, 16, 3), (5, 10, 3), (4, 12, 2), (7, 21, 5)])
def test_refinement_is_exact_knot_insertion(coarse_n, fine_n, degree):
    coarse = SplineSpace.quasi_uniform(coarse_n, degree)
    fine = SplineSpace.quasi_uniform(fine_n, degree)
    assert is_subspace(coarse, fine) and not is_subspace(fine, coarse)
    R = refinement_matrix(coarse, fine).toarray()
    x = np.linspace(0, 1, 301)
    # Phi_c(x) = Phi_f(x) R, evaluated with scipy's basis functions
    assert np.allclose(basis_matrix(fine.knots, degree, x) @ R,
                       basis_matrix(coarse.knots, degree, x), atol=1e-13)
    # and the dense identity R = G_ff^-1 <Phi_f|Phi_c>
    ref = la.solve(dense_gram(fine.knots, degree, fine.knots, degree),
                   dense_gram(fine.knots, degree, coarse.knots, degree))
    assert np.allclose(R, ref, atol=1e-9)


def test_dyadic_step_upsampling_is_the_same_curve():
    d = Decomposition(SplineSpace.quasi_uniform(64), SplineSpace.quasi_uniform(32))
    assert d.nested
    cn = np.random.default_rng(2).normal(size=(35, 3))
    x = np.linspace(0, 1, 257)
    assert np.allclose(d.source.evaluate(d.upsample(cn), x), d.target.evaluate(cn, x), atol=1e-12)


def test_non_nested_upsampling_is_not_the_same_curve_but_projects_back():
    d = Decomposition(SplineSpace.quasi_uniform(117), SplineSpace.quasi_uniform(27))
    assert not d.nested
    cn = np.random.default_rng(3).normal(size=(30, 2))
    up = d.upsample(cn)
    assert np.allclose(d.coarse(up), cn, atol=1e-10)
    x = np.linspace(0, 1, 500)
    assert np.abs(d.source.evaluate(up, x) - d.target.evaluate(cn, x)).max() > 1e-6


def test_quasi_uniform_knots_helper_agrees():
    assert np.allclose(SplineSpace.quasi_uniform(9).knots, quasi_uniform_knots(9))
