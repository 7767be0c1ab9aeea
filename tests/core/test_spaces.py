"""Spline spaces: basis evaluation against scipy's BSpline, validation messages."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import BSpline

from cq_fairing import InvalidInputError, SplineSpace
from cq_fairing.core.geometry import BSplineSurface

from .naive import basis_matrix, random_clamped_knots


@given(degree=st.integers(1, 7), extra=st.integers(0, 20), seed=st.integers(0, 2**31 - 1))
def test_evaluation_and_derivatives_match_scipy(degree, extra, seed):
    rng = np.random.default_rng(seed)
    k = degree + 1 + extra
    knots = random_clamped_knots(rng, k, degree)
    space = SplineSpace.from_knots(knots, degree)
    c = rng.normal(size=(k, 3))
    x = np.concatenate([rng.random(40), [0.0, 1.0], knots[degree + 1:-degree - 1]])
    for nu in range(min(degree, 4) + 1):
        ours = space.evaluate(c, x, nu)
        ref = BSpline(knots, c, degree)(x, nu)
        assert np.allclose(ours, ref, rtol=1e-10, atol=1e-9 * np.abs(ref).max()), nu


@given(degree=st.integers(1, 7), extra=st.integers(1, 12), seed=st.integers(0, 2**31 - 1))
def test_derivatives_at_repeated_knots_match_scipy(degree, extra, seed):
    """Interior knots repeated up to ``degree`` times (zero-width spans, where A2.3's
    divisions by knot differences give 0), every derivative up to the degree, between
    the knots and at them."""
    rng = np.random.default_rng(seed)
    distinct = np.sort(rng.uniform(0.05, 0.95, extra))
    inner = np.repeat(distinct, rng.integers(1, degree + 1, extra))
    knots = np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])
    space = SplineSpace.from_knots(knots, degree)
    c = rng.normal(size=(space.dimension, 3))
    x = np.concatenate([rng.random(40), [0.0, 1.0], distinct])
    for nu in range(degree + 1):
        ours = space.evaluate(c, x, nu)
        ref = BSpline(knots, c, degree)(x, nu)
        assert np.allclose(ours, ref, rtol=1e-9, atol=1e-9 * max(np.abs(ref).max(), 1.0)), nu


@given(degrees=st.tuples(st.integers(1, 5), st.integers(1, 5)),
       extra=st.tuples(st.integers(0, 12), st.integers(0, 12)), rational=st.booleans(),
       seed=st.integers(0, 2**31 - 1))
def test_surface_grid_evaluation_matches_dense_scipy_bases(degrees, extra, rational, seed):
    r"""``evaluate_grid`` (sparse collocation products) against :math:`B_u^{(a)} P B_v^{(b)T}`
    with dense scipy bases, every partial up to order 2, and the quotient
    :math:`(B_u W P B_v^T) / (B_u W B_v^T)` for a rational net."""
    rng = np.random.default_rng(seed)
    k = [p + 1 + e for p, e in zip(degrees, extra)]
    knots = [random_clamped_knots(rng, n, p) for n, p in zip(k, degrees)]
    poles = rng.normal(size=(k[0], k[1], 3))
    weights = rng.uniform(0.5, 2.0, size=k) if rational else None
    surface = BSplineSurface(poles, knots[0], knots[1], *degrees, weights=weights)
    u = np.concatenate([rng.random(9), [0.0, 1.0]])
    v = np.concatenate([rng.random(7), [0.0, 1.0]])
    if rational:
        bu, bv = basis_matrix(knots[0], degrees[0], u), basis_matrix(knots[1], degrees[1], v)
        w = bu @ weights @ bv.T
        ref = np.einsum("ui,ijd,vj->uvd", bu, poles * weights[..., None], bv) / w[..., None]
        assert np.allclose(surface.evaluate_grid(u, v), ref, rtol=1e-10, atol=1e-10)
        return
    for a, b in ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)):
        if a > degrees[0] or b > degrees[1]:
            continue
        ref = np.einsum("ui,ijd,vj->uvd", basis_matrix(knots[0], degrees[0], u, a), poles,
                        basis_matrix(knots[1], degrees[1], v, b))
        assert np.allclose(surface.evaluate_grid(u, v, a, b), ref, rtol=1e-9,
                           atol=1e-9 * max(np.abs(ref).max(), 1.0)), (a, b)


@given(degree=st.integers(1, 5), extra=st.integers(0, 12), seed=st.integers(0, 2**31 - 1))
def test_dense_basis_values_are_scipys_basis_and_its_derivatives(degree, extra, seed):
    """``basis_values`` (every basis function and its derivatives up to the order, dense)
    against scipy's BSpline, ends and interior knots included."""
    rng = np.random.default_rng(seed)
    knots = random_clamped_knots(rng, degree + 1 + extra, degree)
    space = SplineSpace.from_knots(knots, degree)
    x = np.concatenate([rng.random(9), [0.0, 1.0], knots[degree + 1:-degree - 1]])
    order = min(degree, 2)
    values = space.basis_values(x, order)
    assert values.shape == (order + 1, x.size, space.dimension)
    for nu in range(order + 1):
        ref = basis_matrix(knots, degree, x, nu)
        assert np.allclose(values[nu], ref, rtol=1e-9, atol=1e-9 * max(np.abs(ref).max(), 1.0))


def test_collocation_rows_are_a_partition_of_unity():
    space = SplineSpace.quasi_uniform(13, 4, (2.0, 5.0))
    x = np.linspace(2.0, 5.0, 101)
    assert np.allclose(space.collocation(x).sum(axis=1), 1.0, atol=1e-14)


def test_quasi_uniform_space_is_the_seeds_v_m():
    space = SplineSpace.quasi_uniform(10)
    assert space.dimension == 13
    assert np.allclose(space.knots, [0, 0, 0, 0, .1, .2, .3, .4, .5, .6, .7, .8, .9, 1, 1, 1, 1])
    assert space.is_quasi_uniform and space.n_spans == 10


@pytest.mark.parametrize("knots, degree, words", [
    ([0, 0, 0, 0, 0.5, 0.4, 1, 1, 1, 1], 3, "non-decreasing"),
    ([0, 0, 0, 0.2, 0.5, 1, 1, 1, 1], 3, "clamped"),
    ([0, 0, 0, 0, 0.5, 0.5, 0.5, 0.5, 1, 1, 1, 1], 3, "repeated 4 times"),
    ([0, 0, 0, 0, np.nan, 1, 1, 1, 1], 3, "NaN"),
    ([0, 0, 1, 1], 3, "at least 8 knots"),
    ([0, 0, 0, 0, 1, 1, 1, 1], 0, "degree must be an integer >= 1"),
])
def test_bad_knots_raise_typed_errors_that_say_what_to_do(knots, degree, words):
    with pytest.raises(InvalidInputError, match=words):
        SplineSpace.from_knots(knots, degree)


def test_parameters_outside_the_domain_are_refused():
    with pytest.raises(InvalidInputError, match="domain"):
        SplineSpace.quasi_uniform(4).evaluate(np.zeros(7), [1.5])
