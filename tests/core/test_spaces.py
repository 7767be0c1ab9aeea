"""Spline spaces: basis evaluation against scipy's BSpline, validation messages."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import BSpline

from cq_fairing import InvalidInputError, SplineSpace

from .naive import random_clamped_knots


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
