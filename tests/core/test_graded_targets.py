"""Graded targets against their definitions: graded like the source's spans
(:func:`cq_fairing.core.plans.graded_space`: the source's breakpoints at equal steps of
their index) and refined towards both ends (:func:`cq_fairing.core.plans.end_graded_space`:
halfway between equal spans and the Chebyshev-Lobatto points)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cq_fairing.core.plans import end_graded_space, graded_space, has_graded_spans, target_space
from cq_fairing.core.spaces import SplineSpace


def _space(steps, degree=3):
    """The clamped space with simple interior knots spaced by ``steps``."""
    b = np.concatenate([[0.0], np.cumsum(steps)])
    return SplineSpace(degree, np.concatenate([np.zeros(degree), b, np.full(degree, b[-1])]))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.01, 10.0), min_size=2, max_size=30), st.data())
def test_each_target_span_covers_the_same_number_of_source_spans(steps, data):
    source = _space(steps)
    m = source.n_spans
    n = data.draw(st.integers(1, m))
    target = graded_space(source, n, 3)
    b, t = source.breakpoints, target.breakpoints
    assert target.degree == 3 and target.n_spans == n
    assert t[0] == b[0] and t[-1] == b[-1] and np.all(np.diff(t) > 0)
    for i in range(n + 1):       # target breakpoint i sits at source index i m / n
        j, frac = divmod(i * m, n)
        expected = b[j] if frac == 0 else b[j] + (frac / n) * (b[j + 1] - b[j])
        assert abs(t[i] - expected) <= 1e-12 * b[-1]
    if m % n == 0 and has_graded_spans(source):   # nested: the source's own knots
        assert np.all(np.isin(t, b))
    elif m % n == 0:             # equal spans: the quasi-uniform V_n, nested to round-off
        assert np.abs(t[:, None] - b[None, :]).min(axis=1).max() <= 1e-12 * b[-1]


@given(st.integers(2, 40), st.data())
def test_on_equal_spans_the_graded_target_is_the_quasi_uniform_one(m, data):
    source = SplineSpace.quasi_uniform(m, 3, (0.0, 2.5))
    n = data.draw(st.integers(1, m))
    assert not has_graded_spans(source)
    assert graded_space(source, n, 3) is target_space(source, n, 3)


def test_graded_spans_are_told_from_equal_ones():
    assert has_graded_spans(_space([1.0, 1.0, 3.0]))
    assert not has_graded_spans(_space([0.5] * 7))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 60), st.integers(1, 5), st.floats(-50.0, 50.0), st.floats(0.1, 100.0))
def test_end_graded_targets_are_halfway_to_the_chebyshev_lobatto_points(n, degree, a, width):
    """Each breakpoint is the mean of the equally spaced one and the Chebyshev-Lobatto
    point :math:`(1 - \\cos(\\pi i / n)) / 2` (scaled to the domain); the spans are
    symmetric, shorten monotonically towards both ends, and the space is clamped."""
    b = a + width
    space = end_graded_space(n, degree, (a, b))
    t = space.breakpoints
    i = np.arange(n + 1)
    lobatto = a + width * 0.5 * (1.0 - np.cos(np.pi * i / n))
    uniform = a + width * i / n
    assert space.degree == degree and space.n_spans == n
    np.testing.assert_allclose(t, 0.5 * (lobatto + uniform), rtol=0, atol=1e-12 * width)
    assert t[0] == a and t[-1] == b
    steps = np.diff(t)
    np.testing.assert_allclose(steps, steps[::-1], rtol=0, atol=1e-12 * width)
    half = steps[: (n + 1) // 2]
    assert np.all(np.diff(half) >= -1e-12 * width)
    source = SplineSpace.quasi_uniform(n + 2, degree, (a, b))
    assert target_space(source, n, degree, "ends").same_as(
        end_graded_space(n, degree, source.domain))
