"""Noise level and the "faithful" objective (cq_fairing.core.fidelity, adaptive objective):
the noise estimate against the noise actually injected, the discrepancy count against a dense
least-squares reference, the faithful result against the noise-free truth."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline

import cq_fairing as cf
from cq_fairing.core import examples
from cq_fairing.core.adaptive import (
    equidistributed_space,
    fair_curve_adaptive,
    fair_surface_adaptive,
)
from cq_fairing.core.decomposition import refinement_matrix
from cq_fairing.core.fidelity import DISCREPANCY
from cq_fairing.core.measures import deviation
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.core.surface_fit import _SurfaceFit
from cq_fairing.errors import InvalidInputError

from .naive import dense_coarse, random_clamped_knots


@pytest.fixture(scope="module")
def seed():
    return examples.seed_curve()


@pytest.fixture(scope="module")
def faithful_p7(seed):
    return fair_curve_adaptive(seed.curve, 0.02, target_degree=7, objective="faithful")


@pytest.mark.parametrize("sigma", [0.0005, 0.002, 0.01])
def test_noise_level_matches_the_injected_noise(sigma):
    """The noise across the curve: the injected noise minus its component along the
    noise-free curve's tangent (finite differences of the clean points)."""
    s = examples.seed_curve(noise=sigma)
    tangent = np.gradient(s.clean_points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    noise = s.points - s.clean_points
    across = noise - np.sum(noise * tangent, axis=1, keepdims=True) * tangent
    injected = np.sqrt(np.mean(np.sum(across ** 2, axis=1)))
    estimate = dict(fair_curve_adaptive(s.curve, 0.05, objective="faithful").table)["noise"]
    assert abs(estimate / injected - 1.0) < 0.05


def _dense_variance(source, n, degree):
    """Residual variance across the curve at the source's Greville points of the
    projection onto the family's n-span space, with dense Gram matrices and scipy's
    BSpline."""
    b = source.space.breakpoints
    target = equidistributed_space(b, 1.0 / np.diff(b), n, degree)
    coarse = dense_coarse(source.knots, source.degree, target.knots, degree, source.poles)
    xi = source.space.greville
    spline = BSpline(source.knots, source.poles, source.degree)
    r = BSpline(target.knots, coarse, degree)(xi) - spline(xi)
    tangent = spline.derivative()(xi)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    r -= np.sum(r * tangent, axis=1, keepdims=True) * tangent
    return np.sum(r * r) / (xi.size - target.dimension)


def test_faithful_count_is_the_smallest_within_the_noise(seed, faithful_p7):
    sigma = dict(faithful_p7.table)["noise"]
    n = faithful_p7.n
    limit = (1.0 + DISCREPANCY) ** 2 * sigma ** 2
    assert _dense_variance(seed.curve, n, 7) <= limit
    assert _dense_variance(seed.curve, n - 1, 7) > limit


def test_faithful_curve_meets_tol_and_lands_near_the_truth(seed, faithful_p7):
    assert deviation(seed.curve, faithful_p7.curve, per_span=16).max <= 0.02
    sigma = dict(faithful_p7.table)["noise"]
    to_truth = deviation(seed.truth, faithful_p7.curve, per_span=4)
    assert to_truth.rms < 0.5 * sigma            # the noise is removed, not followed
    compact = fair_curve_adaptive(seed.curve, 0.02, target_degree=7, polish=False)
    assert deviation(seed.truth, compact.curve, per_span=4).rms > 2 * to_truth.rms


def test_faithful_surface_removes_the_noise_within_tol():
    b = examples.blade_surface((40, 50), noise=0.01, span=50.0, chord=15.0)
    result = fair_surface_adaptive(b.surface, 0.05, objective="faithful")
    sigma = dict(result.table)["noise"]
    assert deviation(b.surface, result.surface, per_span=4).max <= 0.05
    assert deviation(b.truth, result.surface, per_span=2).rms < 0.5 * sigma
    assert result.poles.shape[0] * result.poles.shape[1] < 0.05 * b.surface.poles[..., 0].size


def test_the_faithful_surface_search_projects_onto_small_nets_only(monkeypatch):
    """The diagonal count is bracketed by doubling from a small net: apart from the
    noise-level target (a third of the source per direction), no projection is larger than
    the answer's count doubled in both directions (a bisection from the top would start
    with half the source)."""
    b = examples.blade_surface((40, 50), noise=0.01, span=50.0, chord=15.0)
    sizes, project = [], _SurfaceFit.project

    def counting(self, tu, tv, *args, **kwargs):
        sizes.append(tu.n_spans * tv.n_spans)
        return project(self, tu, tv, *args, **kwargs)

    monkeypatch.setattr(_SurfaceFit, "project", counting)
    result = fair_surface_adaptive(b.surface, 0.05, target_degree=5, objective="faithful")
    answer = result.surface.u_space.n_spans * result.surface.v_space.n_spans
    third = int(np.ceil(b.surface.u_space.n_spans / 3)) * int(np.ceil(b.surface.v_space.n_spans / 3))
    assert sizes[0] == third and dict(result.table)["lambda"] == 0.0
    assert max(sizes[1:]) <= 4 * answer < third


def test_tolerance_below_the_noise_falls_back_to_the_compact_search():
    """At 0.015 mm the noise-level net (what a loose tolerance gets) is out of tolerance,
    so the compact search adds poles until the tolerance holds."""
    b = examples.blade_surface((16, 20), noise=0.01, span=50.0, chord=15.0)
    at_noise = fair_surface_adaptive(b.surface, 0.15, objective="faithful", polish=False)
    assert deviation(b.surface, at_noise.surface, per_span=6).max > 0.015
    result = fair_surface_adaptive(b.surface, 0.015, objective="faithful", polish=False)
    assert deviation(b.surface, result.surface, per_span=6).max <= 0.015
    assert result.poles[..., 0].size > at_noise.poles[..., 0].size


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), inner=st.integers(4, 40))
def test_a_noise_free_polynomial_reduces_to_one_span(seed, inner):
    """A cubic Bezier curve written on a finer knot vector is reproduced exactly by one span."""
    rng = np.random.default_rng(seed)
    bezier = rng.normal(size=(4, 3)) * 10.0
    fine = SplineSpace(3, random_clamped_knots(rng, inner + 4, 3))
    poles = refinement_matrix(SplineSpace.quasi_uniform(1, 3), fine) @ bezier
    curve = cf.make_curve(poles, knots=fine.knots, degree=3)
    result = fair_curve_adaptive(curve, 1e-6, objective="faithful")
    assert result.n == 1
    assert np.abs(result.poles - bezier).max() < 1e-8 * np.abs(bezier).max()


def test_unknown_objective_is_refused(seed):
    with pytest.raises(InvalidInputError, match="objective must be one of"):
        fair_curve_adaptive(seed.curve, 0.02, objective="smooth")


def test_public_fair_curve_offers_the_faithful_adaptive_method(seed, faithful_p7):
    c = seed.curve
    result = cf.fair_curve(c.poles, tol=0.02, knots=c.knots, degree=c.degree,
                           method="adaptive", objective="faithful", target_degree=7)
    assert result.schedule == "adaptive"
    assert np.array_equal(result.poles, faithful_p7.poles)
    assert np.array_equal(result.knots, faithful_p7.knots)


def test_public_fair_surface_offers_the_adaptive_method():
    b = examples.blade_surface((16, 20), noise=0.0, span=50.0, chord=15.0)
    s = b.surface
    result = cf.fair_surface(s.poles, tol=0.05, u_knots=s.u_knots, v_knots=s.v_knots,
                             method="adaptive", objective="faithful")
    assert result.schedule == "adaptive"
    assert deviation(s, result.surface, per_span=6).max <= 0.05


@pytest.mark.parametrize("kwargs, message", [
    (dict(n=20, method="adaptive"), "needs tol"),
    (dict(tol=0.02, objective="faithful"), "applies to method='adaptive' only"),
    (dict(tol=0.02, method="energy", objective="faithful"), "applies to method='adaptive'"),
    (dict(tol=0.02, method="adaptive", objective="fewest"), "objective must be one of"),
])
def test_adaptive_arguments_are_checked(seed, kwargs, message):
    with pytest.raises(InvalidInputError, match=message):
        cf.fair_curve(seed.curve.poles, **kwargs)
