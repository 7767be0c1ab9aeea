"""Targets graded like the source's spans (:func:`cq_fairing.core.plans.graded_space`)
against their definition: the source's breakpoints at equal steps of their index."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cq_fairing.core.plans import graded_space, has_graded_spans, target_space
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
    if m % n == 0:               # nested: the target's knots are the source's own
        assert np.all(np.isin(t, b))


@given(st.integers(2, 40), st.data())
def test_on_equal_spans_the_graded_target_is_the_quasi_uniform_one(m, data):
    source = SplineSpace.quasi_uniform(m, 3, (0.0, 2.5))
    n = data.draw(st.integers(1, m))
    assert not has_graded_spans(source)
    assert graded_space(source, n, 3) is target_space(source, n, 3)


def test_graded_spans_are_told_from_equal_ones():
    assert has_graded_spans(_space([1.0, 1.0, 3.0]))
    assert not has_graded_spans(_space([0.5] * 7))
