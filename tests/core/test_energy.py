"""Eck-Hadenfeld local energy fairing: exact weights, eq. 22, tolerance and energy decrease."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

import cq_fairing as cf
from cq_fairing.core import measures as M
from cq_fairing.core.energy import (
    energy_matrix,
    energy_weights,
    fair_curve_energy,
    surface_energy_matrix,
)
from cq_fairing.core.examples import blade_surface, seed_curve


def lagrange_at_zero(nodes):
    """Weights of p(0) for the polynomial interpolating at ``nodes`` (independent of splines)."""
    nodes = np.asarray(nodes, float)
    return np.array([np.prod(-np.delete(nodes, i)) / np.prod(x - np.delete(nodes, i))
                     for i, x in enumerate(nodes)])


def test_eq22_equidistant_cubic():
    space = cf.SplineSpace.quasi_uniform(30, 3)
    r = 15
    idx, gamma = energy_weights(space, r, l=2)
    full = dict(zip(idx - r, gamma))
    expected = dict(zip([-3, -1, 1, 3], lagrange_at_zero([-3, -1, 1, 3])))
    assert full[-2] == pytest.approx(0, abs=1e-12) and full[2] == pytest.approx(0, abs=1e-12)
    for offset, value in expected.items():
        assert full[offset] == pytest.approx(value, rel=1e-12)   # -1/16, 9/16, 9/16, -1/16
    idx, gamma = energy_weights(space, r, l=3)
    expected = lagrange_at_zero([-3, -2, -1, 1, 2, 3])          # 1/20, -3/10, 3/4, ...
    assert np.allclose(gamma, expected, rtol=1e-12)


@settings(max_examples=30)
@given(spans=st.lists(st.floats(0.05, 1.0), min_size=6, max_size=14), l=st.sampled_from([2, 3]),
       degree=st.sampled_from([3, 4]), pick=st.floats(0, 1))
def test_weights_sum_to_one_and_match_quadrature(spans, l, degree, pick):
    b = np.concatenate([[0], np.cumsum(spans)])
    b /= b[-1]
    knots = np.concatenate([[0] * degree, b, [1] * degree])
    space = cf.SplineSpace.from_knots(knots, degree)
    r = int(pick * (space.dimension - 1))
    idx, gamma = energy_weights(space, r, l)
    assert gamma.sum() == pytest.approx(1.0, abs=1e-10)
    # eq. 18 by dense Gauss quadrature of scipy's B-spline derivatives
    x, w = np.polynomial.legendre.leggauss(8)
    nodes = (0.5 * (b[:-1, None] + b[1:, None]) + 0.5 * (b[1:, None] - b[:-1, None]) * x).ravel()
    weights = (0.5 * (b[1:, None] - b[:-1, None]) * w).ravel()

    def d(i):
        c = np.zeros(space.dimension)
        c[i] = 1
        return BSpline(knots, c, degree).derivative(l)(nodes)

    denom = np.sum(weights * d(r) ** 2)
    for i, g in zip(idx, gamma):
        assert g == pytest.approx(-np.sum(weights * d(i) * d(r)) / denom, abs=1e-9)


def test_local_minimiser_is_a_minimum():
    rng = np.random.default_rng(0)
    curve = cf.make_curve(rng.normal(size=(20, 3)))
    g = energy_matrix(curve.space, 3)
    idx, gamma = energy_weights(curve.space, 9, 3)
    poles = curve.poles.copy()
    poles[9] = gamma @ poles[idx]

    def energy(p):
        return float(np.sum(p * (g @ p)))

    base = energy(poles)
    for _ in range(10):
        moved = poles.copy()
        moved[9] += rng.normal(scale=1e-3, size=3)
        assert energy(moved) > base


@pytest.mark.parametrize("l", [2, 3])
def test_energy_fairing_of_seed_curve(l):
    seed = seed_curve()
    tol = 0.02
    result = cf.fair_curve(seed.curve.poles, knots=seed.curve.knots, tol=tol, method="energy") \
        if l == 3 else fair_curve_energy(seed.curve, tol, l=2)
    assert result.poles.shape == seed.curve.poles.shape and result.details == ()
    assert result.n == seed.curve.space.n_spans
    assert np.abs(result.poles - seed.curve.poles).max() <= tol * (1 + 1e-12)
    u = np.linspace(0, 1, 100_001)
    assert np.linalg.norm(result.curve.evaluate(u) - seed.curve.evaluate(u), axis=1).max() <= tol
    g = energy_matrix(seed.curve.space, l)
    assert np.sum(result.poles * (g @ result.poles)) < 0.7 * np.sum(seed.curve.poles * (g @ seed.curve.poles))
    summary = M.fairness_summary(result)
    assert summary["curvature_extrema"]["after"] < 0.5 * summary["curvature_extrema"]["before"]


def test_energy_fairing_of_blade_surface():
    blade = blade_surface(shape=(20, 30))
    tol = 0.05
    result = cf.fair_surface(blade.surface.poles, tol=tol, method="energy")
    assert result.poles.shape == blade.surface.poles.shape
    assert np.abs(result.poles - blade.surface.poles).max() <= tol * (1 + 1e-12)
    assert result.max_deviation <= tol
    K = surface_energy_matrix(blade.surface)
    flat0 = blade.surface.poles.reshape(-1, 3)
    flat1 = result.poles.reshape(-1, 3)
    assert np.sum(flat1 * (K @ flat1)) < 0.8 * np.sum(flat0 * (K @ flat0))  # recorded: 0.61
    assert M.bending_energy(result.surface) == pytest.approx(np.sum(flat1 * (K @ flat1)), rel=1e-9)
    assert np.array_equal(result.poles[0], blade.surface.poles[0])   # boundary kept


def test_energy_errors():
    poles = np.random.default_rng(1).normal(size=(12, 3))
    with pytest.raises(cf.InvalidInputError, match="method"):
        cf.fair_curve(poles, tol=0.1, method="spline")
    with pytest.raises(cf.InvalidInputError, match="needs tol"):
        cf.fair_curve(poles, 5, method="energy")
    with pytest.raises(cf.InvalidInputError, match="needs tol"):
        cf.fair_curve(poles, method="energy")
    with pytest.raises(cf.InvalidToleranceError):
        cf.fair_curve(poles, tol=-1, method="energy")
    with pytest.raises(cf.UnsupportedGeometryError):
        cf.fair_curve(poles, tol=0.1, method="energy", weights=np.linspace(1, 2, 12))
    with pytest.raises(cf.InvalidInputError, match="l must be 2 or 3"):
        fair_curve_energy(cf.make_curve(poles), 0.1, l=4)
    with pytest.raises(cf.InvalidInputError):
        fair_curve_energy(cf.make_curve(poles, degree=2), 0.1, l=3)
