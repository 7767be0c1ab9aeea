"""The curves' default method "auto" (cq_fairing.core.auto_curve): the seed curve's
targets, the rule checked against the candidate fits computed one by one (also where the
default computes only what can change its choice), the reported choice reproducing the
curve, and the cases where it keeps one degree or falls back to the wavelet search."""

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.core import examples
from cq_fairing.core.adaptive_curve import CurveSearch
from cq_fairing.core.auto_curve import RAISED_DEGREES, candidate_degrees
from cq_fairing.core.decomposition import refinement_matrix
from cq_fairing.core.deviations import deviation
from cq_fairing.core.fairness import curvature_derivative_energy, curve_wiggles
from cq_fairing.core.spaces import SplineSpace
from tests.reliability.independent import curve_points, distance_to_curve


def _fair(curve, tol, **options):
    return cf.fair_curve(curve.poles, tol=tol, knots=curve.knots, degree=curve.degree,
                         weights=curve.weights, **options)


def _two_sided(a, b, n=20_001):
    """Largest distance between two curves on [0, 1] from ``n`` points of each to the
    other, by the reliability suite's independent evaluation and search (an upper bound
    at those points)."""
    def on(c):
        return lambda t: curve_points(c.poles, c.knots, c.degree, c.weights, t)

    u = np.linspace(0.0, 1.0, n)
    there = distance_to_curve(on(a)(u), on(b), (0.0, 1.0), u, dense=n)
    back = distance_to_curve(on(b)(u), on(a), (0.0, 1.0), u, dense=n)
    return float(max(there.max(), back.max()))


@pytest.fixture(scope="module")
def seed():
    return examples.seed_curve()


@pytest.fixture(scope="module")
def seed_auto(seed):
    return _fair(seed.curve, 0.02)


def test_the_seed_curve_meets_its_targets_by_default(seed, seed_auto):
    """At most 81 poles, int (dk/ds)^2 at most 0.042, at most 0.0024 from the noise-free
    curve; within tol by an independent dense measure."""
    faired = seed_auto.curve
    assert faired.n_poles <= 81
    assert curvature_derivative_energy(faired) <= 0.042
    assert deviation(seed.truth, faired, per_span=4).max <= 0.0024
    assert _two_sided(seed.curve, faired) <= 0.02


def test_the_seed_default_beats_the_wavelet_and_adaptive_fits(seed, seed_auto):
    """No more poles than method="adaptive", at least as fair as the uniform search
    (int (dk/ds)^2 and inflections, sampled on the source's spans), and closer to the
    noise-free curve than both."""
    uniform = _fair(seed.curve, 0.02, method="wavelet")
    adaptive = _fair(seed.curve, 0.02, method="adaptive")
    faired = seed_auto.curve
    assert faired.n_poles <= adaptive.curve.n_poles
    assert curvature_derivative_energy(faired) <= curvature_derivative_energy(uniform.curve)
    wiggles = curve_wiggles(faired, reference=seed.curve)["inflections"]
    assert wiggles <= curve_wiggles(uniform.curve, reference=seed.curve)["inflections"]
    to_truth = deviation(seed.truth, faired, per_span=4).max
    for other in (uniform, adaptive):
        assert to_truth < deviation(seed.truth, other.curve, per_span=4).max


def test_the_choice_is_reported_and_gives_the_same_curve(seed, seed_auto):
    assert seed_auto.choice == {"method": "adaptive", "objective": "faithful",
                                "target_degree": 7}
    again = _fair(seed.curve, 0.02, **seed_auto.choice)
    assert again.choice is None
    np.testing.assert_array_equal(again.curve.poles, seed_auto.curve.poles)
    np.testing.assert_array_equal(again.curve.knots, seed_auto.curve.knots)


def _candidates(curve, tol, objective):
    """The fits at the degrees 3, 5 and 7, by the explicit adaptive method."""
    return {p: _fair(curve, tol, method="adaptive", objective=objective, target_degree=p)
            for p in (3,) + RAISED_DEGREES}


def test_a_noise_free_curve_gets_the_compact_fit_with_the_fewest_poles():
    """Nine tenths of the eq. 15 curve without noise (open: the independent measure's
    nearest samples are unambiguous): every faithful fit follows the shape far below
    tol with more poles than the compact fit at degree 3 (the budget), so the rule takes
    the compact fit with the fewest poles over the degrees, a raised one: fewer poles
    and a fairer curve than both the uniform search and method="adaptive"."""
    clean = cf.interpolate_points(examples.seed_curve_points(334)[:300])
    result = _fair(clean, 0.02)
    compact = _candidates(clean, 0.02, "compact")
    faithful = _candidates(clean, 0.02, "faithful")
    budget = compact[3].curve.n_poles
    assert min(fit.curve.n_poles for fit in faithful.values()) > budget
    fewest = min(compact, key=lambda p: compact[p].curve.n_poles)
    assert fewest in RAISED_DEGREES
    assert result.choice == {"method": "adaptive", "objective": "compact",
                             "target_degree": fewest}
    np.testing.assert_array_equal(result.curve.poles, compact[fewest].curve.poles)
    uniform = _fair(clean, 0.02, method="wavelet")
    assert result.curve.n_poles < min(budget, uniform.curve.n_poles)
    assert curvature_derivative_energy(result.curve) < min(
        curvature_derivative_energy(compact[3].curve),
        curvature_derivative_energy(uniform.curve))
    assert _two_sided(clean, result.curve) <= 0.02


def test_a_noise_free_polynomial_is_recovered_exactly():
    """A cubic Bezier refined to 40 spans: the residual is rounding, so the faithful
    fit is the one cubic span that reproduces it, as few poles as the compact fit and
    the source's own shape, not a polished one."""
    bezier = np.random.default_rng(5).normal(size=(4, 3)) * 10.0
    fine = SplineSpace.quasi_uniform(40, 3)
    poles = refinement_matrix(SplineSpace.quasi_uniform(1, 3), fine) @ bezier
    result = cf.fair_curve(poles, tol=1e-3)
    assert result.choice == {"method": "adaptive", "objective": "faithful",
                             "target_degree": 3}
    assert np.abs(result.curve.poles - bezier).max() <= 1e-9 * np.abs(bezier).max()


def _by_the_rule(curve, tol):
    """The documented rule applied to every candidate fitted in full, each on its own:
    ``(objective, fit)``."""
    degrees = candidate_degrees(curve)
    compact = {}
    for p in degrees:
        try:
            compact[p] = _fair(curve, tol, method="adaptive", target_degree=p)
        except cf.ToleranceNotMetError:
            compact[p] = None
    budget = compact[degrees[0]].curve.n_poles
    quiet = [CurveSearch(curve, tol, p).noise_limited(budget) for p in degrees]
    quiet = [fit for fit in quiet if fit is not None and fit.curve.n_poles <= budget]
    fits, objective = (quiet, "faithful") if quiet else (
        [fit for fit in compact.values() if fit is not None], "compact")
    return objective, min(fits, key=lambda fit: (fit.curve.n_poles,
                                                 curvature_derivative_energy(fit.curve)))


@pytest.mark.parametrize("case, tol, objective", [
    ("seed 400", 0.01, "faithful"),   # the budget: its searched space, never polished
    ("seed 400", 0.1, "compact"),     # degree 7; the budget finished, degree 5 never
    ("clean 200", 0.02, "compact"),   # degree 7; the budget's fit never finished
    ("ten poles", 0.02, "compact"),   # the budget's own degree
])
def test_fitting_only_what_can_change_the_choice_chooses_as_fitting_everything(case, tol,
                                                                               objective):
    """The default computes a stage only where it can change the choice (lower bounds
    on poles, the budget without its polish); the rule applied to every candidate
    fitted in full, one by one, chooses the same fit, to the bit."""
    curve = {"seed 400": lambda: examples.seed_curve(400).curve,
             "clean 200": lambda: cf.interpolate_points(examples.seed_curve_points(200)),
             "ten poles": lambda: cf.make_curve(np.random.default_rng(10).normal(size=(10, 3))),
             }[case]()
    expected_objective, expected = _by_the_rule(curve, tol)
    result = _fair(curve, tol)
    assert expected_objective == objective
    assert result.choice == {"method": "adaptive", "objective": objective,
                             "target_degree": expected.curve.degree}
    np.testing.assert_array_equal(result.curve.poles, expected.curve.poles)
    np.testing.assert_array_equal(result.curve.knots, expected.curve.knots)
    assert result.max_deviation == expected.max_deviation


def test_rational_low_degree_and_explicit_degrees_keep_one_degree(seed):
    """Weights and degrees 1 and 2 are exact geometry; an explicit target_degree is the
    only degree fitted (and is then reported)."""
    t = np.linspace(0.0, 3.0, 80)
    poles = np.c_[10 * t, np.sin(2 * t), 0.3 * np.cos(5 * t)]
    rational = cf.make_curve(poles, weights=1.0 + 0.3 * np.sin(t))
    quadratic = cf.make_curve(poles, degree=2)
    assert candidate_degrees(rational) == (3,)
    assert candidate_degrees(quadratic) == (2,)
    assert candidate_degrees(seed.curve) == (3, 5, 7)
    assert candidate_degrees(seed.curve, 5) == (5,)
    for curve, degree in ((rational, 3), (quadratic, 2)):
        result = _fair(curve, 0.02)
        assert result.curve.degree == degree == result.choice["target_degree"]
        assert result.max_deviation <= 0.02
    explicit = _fair(seed.curve, 0.02, target_degree=5)   # the faithful fit has more poles
    assert explicit.choice == {"method": "adaptive", "objective": "compact",
                               "target_degree": 5}


def test_where_the_adaptive_fit_is_refused_the_wavelet_search_is_the_answer():
    """A quintic Bezier at degree 3 within 0.05: no adaptive cubic target meets tol (one
    span, the source's, is its family's top), the uniform search's does."""
    quintic = cf.make_curve(np.random.default_rng(1).normal(size=(6, 3)), degree=5)
    with pytest.raises(cf.ToleranceNotMetError):
        _fair(quintic, 0.05, method="adaptive")
    result = _fair(quintic, 0.05)
    assert result.choice == {"method": "wavelet"}
    np.testing.assert_array_equal(result.curve.poles,
                                  _fair(quintic, 0.05, method="wavelet").curve.poles)
    assert _two_sided(quintic, result.curve) <= 0.05


def test_with_a_target_scale_the_default_is_the_wavelet_projection(seed):
    poles = seed.curve.poles
    result = cf.fair_curve(poles, 78)
    assert result.choice is None and result.n == 78
    np.testing.assert_array_equal(result.poles, cf.fair_curve(poles, 78, method="wavelet").poles)


@pytest.mark.parametrize("options, belongs", [
    (dict(search="linear"), "method='wavelet'"),
    (dict(schedule="direct"), "method='wavelet'"),
    (dict(objective="faithful"), "method='adaptive'"),
])
def test_an_option_of_one_method_is_refused_by_the_default(seed, options, belongs):
    (name, value), = options.items()
    with pytest.raises(cf.InvalidInputError) as info:
        cf.fair_curve(seed.curve.poles, tol=0.02, **options)
    message = str(info.value)
    assert message.startswith(f"{name}={value!r} applies to {belongs} only")
    assert "got method='auto', which chooses the adaptive fit per curve" in message
    assert message.endswith(f"add {belongs} or drop {name}.")
