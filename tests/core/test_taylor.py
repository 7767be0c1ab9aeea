"""Taylor form of splines against scipy's B-splines and the collocation path."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

import cq_fairing as cf
from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.measures import surface_derivatives
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.core.taylor import LOOKUP_BELOW, SpanTaylor, TaylorSurface
from cq_fairing.errors import InvalidInputError

from .naive import random_clamped_knots
from .test_measures import rational_sphere


def random_knots(rng, k, p, lo=-3.0, hi=4.0, double=False):
    """Clamped knots on [lo, hi] with ``k`` basis functions; optionally one double knot."""
    knots = lo + (hi - lo) * random_clamped_knots(rng, k, p)
    if double and p >= 2 and k - p - 1 >= 2:
        knots[p + 2] = knots[p + 1]
    return knots


def scipy_basis(knots, degree, x, nu):
    """All basis functions' ``nu``-th derivatives at ``x`` (scipy, an independent path).
    Zero above the degree, where scipy 1.10 (Debian's) writes out of bounds."""
    k = knots.size - degree - 1
    if nu > degree:
        return np.zeros((x.size, k))
    return BSpline(knots, np.eye(k), degree)(x, nu=nu)


@settings(max_examples=40, deadline=None)
@given(pu=st.integers(1, 9), pv=st.integers(1, 9), extra_u=st.integers(0, 10),
       extra_v=st.integers(0, 10), double=st.booleans(), seed=st.integers(0, 2**31 - 1))
def test_surface_derivatives_match_scipy_bsplines(pu, pv, extra_u, extra_v, double, seed):
    """Both forms (full per span pair, and Taylor along u with the v basis) agree with
    scipy's basis functions at scattered points, the domain ends and every breakpoint
    (right-continuous there)."""
    rng = np.random.default_rng(seed)
    ku, kv = pu + 1 + extra_u, pv + 1 + extra_v
    tu, tv = random_knots(rng, ku, pu, double=double), random_knots(rng, kv, pv)
    poles = rng.normal(0.0, 30.0, (ku, kv, 3))
    surface = BSplineSurface(poles, tu, tv, pu, pv)
    split = TaylorSurface(surface.u_space, surface.v_space, poles, full_limit=0)
    assert surface.taylor.is_full and not split.is_full
    u = np.r_[rng.uniform(-3, 4, 40), np.unique(tu)]
    v = np.r_[rng.uniform(-3, 4, 40), rng.choice(np.unique(tv), u.size - 40)]
    for ours in (surface_derivatives(surface, u, v, 3), split.derivatives(u, v, 3)):
        for (a, b), value in ours.items():
            expected = np.einsum("qi,qj,ijd->qd", scipy_basis(tu, pu, u, a),
                                 scipy_basis(tv, pv, v, b), poles)
            scale = max(1.0, np.abs(expected).max())
            assert np.abs(value - expected).max() <= 1e-11 * scale, (a, b)


def test_derivatives_above_the_degree_vanish():
    rng = np.random.default_rng(3)
    surface = BSplineSurface(rng.normal(size=(4, 3, 3)), random_knots(rng, 4, 2),
                             random_knots(rng, 3, 1), 2, 1)
    d = surface_derivatives(surface, rng.uniform(-3, 4, 9), rng.uniform(-3, 4, 9), 3)
    assert np.abs(d[(3, 0)]).max() == 0.0 and np.abs(d[(0, 2)]).max() == 0.0
    assert np.abs(d[(2, 0)]).max() > 0.0 and np.abs(d[(1, 1)]).max() > 0.0


def test_rational_sphere_derivatives_match_the_collocation_grid():
    sphere = rational_sphere(3.0)
    u, v = np.linspace(0, 1, 13), np.linspace(0, 1, 17)
    uu, vv = (g.ravel() for g in np.meshgrid(u, v, indexing="ij"))
    ours = surface_derivatives(sphere, uu, vv, 2)
    assert np.allclose(np.linalg.norm(ours[(0, 0)], axis=1), 3.0, atol=1e-12)
    for (a, b), value in ours.items():
        grid = sphere.evaluate_grid(u, v, a, b).reshape(-1, 3)
        assert np.abs(value - grid).max() < 1e-10, (a, b)


def test_span_coefficients_are_the_taylor_coefficients_at_the_centres():
    """T[a, i, k] = N_i^(k)(c_a) h_a^k / k!: the constant terms are the basis values at the
    centres, which sum to one (partition of unity), and r = +-1 gives the span ends."""
    space = SplineSpace.from_knots([0, 0, 0, 0, 0.2, 0.2, 0.7, 1, 1, 1, 1], 3)
    form = SpanTaylor.of(space)
    assert np.allclose(form.breaks, [0, 0.2, 0.7, 1])
    assert np.allclose(form.coefficients[:, :, 0].sum(axis=1), 1.0)
    for a in range(form.centres.size):
        for r, x in ((-1.0, form.breaks[a]), (1.0, form.breaks[a + 1] - 1e-15)):
            values = form.coefficients[a] @ r ** np.arange(4)
            basis = scipy_basis(space.knots, 3, np.array([x]), 0)[0]
            assert np.allclose(values, basis[form.first[a]:form.first[a] + 4], atol=1e-12)


def test_parameters_outside_the_domain_are_refused():
    surface = cf.make_surface(np.zeros((4, 4, 3)))
    with pytest.raises(InvalidInputError, match="domain"):
        surface_derivatives(surface, np.array([0.5, 1.2]), np.array([0.5, 0.5]), 1)


@settings(max_examples=30, deadline=None)
@given(degree=st.integers(1, 9), order=st.integers(0, 4), seed=st.integers(0, 2**31 - 1))
def test_powers_are_the_derivatives_of_the_monomials(degree, order, seed):
    """Entry [:, d, k] is k!/(k-d)! r^(k-d) / h^d, zero for k < d (written out here one
    term at a time)."""
    rng = np.random.default_rng(seed)
    k = degree + 1 + int(rng.integers(0, 5))
    form = SpanTaylor.of(SplineSpace.from_knots(random_knots(rng, k, degree), degree))
    x = rng.uniform(-3, 4, 25)
    a, r = form.locate(x)
    table = form.powers(a, r, order)
    assert table.shape == (25, order + 1, degree + 1)
    for d in range(order + 1):
        for j in range(degree + 1):
            expected = (np.prod(np.arange(j - d + 1, j + 1), dtype=float) * r ** (j - d)
                        / form.halves[a] ** d if j >= d else np.zeros(25))
            assert np.allclose(table[:, d, j], expected, rtol=1e-13, atol=0.0), (d, j)


def test_every_parameter_falls_in_the_span_to_its_right():
    """Breakpoints belong to the span on their right, the right end to the last span;
    the local parameter is -1 at a span's start and +1 at the domain's end."""
    space = SplineSpace.from_knots([0, 0, 0, 0, 0.2, 0.2, 0.7, 1, 1, 1, 1], 3)
    form = SpanTaylor.of(space)
    a, r = form.locate(np.array([0.0, 0.1, 0.2, 0.5, 0.7, 0.99, 1.0]))
    assert a.tolist() == [0, 0, 1, 1, 2, 2, 2]
    assert np.allclose(r[[0, 2, 4, 6]], [-1, -1, -1, 1])


@pytest.mark.parametrize("full_limit", [0, 4_000_000])
def test_evaluation_in_chunks_is_the_same_bit_for_bit(full_limit):
    """Points evaluated a few at a time (a last chunk of one point joins the one before)
    give exactly the values of one batch: a Newton run's results do not depend on how
    many points it iterates."""
    rng = np.random.default_rng(11)
    tu, tv = random_knots(rng, 9, 3), random_knots(rng, 8, 3)
    surface = BSplineSurface(rng.normal(0.0, 30.0, (9, 8, 3)), tu, tv, 3, 3)
    form = TaylorSurface(surface.u_space, surface.v_space, surface.poles, full_limit=full_limit)
    for q in (301, 302, 303):
        u, v = rng.uniform(-3, 4, q), rng.uniform(-3, 4, q)
        for order in (0, 1, 2):
            form._chunk = q
            whole = form.derivatives_in_domain(u, v, order)
            form._chunk = 3
            chunked = form.derivatives_in_domain(u, v, order)
            for key, value in whole.items():
                assert np.array_equal(chunked[key], value), (q, order, key)
                assert chunked[key].strides == value.strides


def test_span_lookup_is_the_binary_search():
    """The cell lookup finds the span ``searchsorted`` finds, on breakpoints, next to
    them, at and beyond the ends, at NaN and infinities, and at scattered parameters."""
    rng = np.random.default_rng(5)
    for degree in (1, 3, 5):
        knots = random_knots(rng, 40, degree)
        knots[degree + 5:degree + 9] = np.linspace(0.1, 0.1001, 4)   # breakpoints close together
        form = SpanTaylor.of(SplineSpace.from_knots(np.sort(knots), degree))
        b = form.breaks
        x = np.concatenate([rng.uniform(-3, 4, LOOKUP_BELOW), b, np.nextafter(b, -np.inf),
                            np.nextafter(b, np.inf), [np.nan, -np.inf, np.inf]])
        rng.shuffle(x)
        assert x.size >= LOOKUP_BELOW
        assert np.array_equal(form.lookup(x), np.searchsorted(b[1:-1], x, side="right"))
