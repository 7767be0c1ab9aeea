"""fair_curve / fair_surface: invariants, tensor-product structure, schedules, errors."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

import cq_fairing as cf
from cq_fairing.core.schedule import plan_spaces
from cq_fairing.core.spaces import SplineSpace

from .naive import dense_coarse

seeds = st.integers(0, 2**31 - 1)


def _noisy_curve(seed, k=120):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, k)
    return np.c_[10 * np.cos(t), 10 * np.sin(t), np.sin(3 * t)] + rng.normal(0, 0.05, (k, 3))


@given(seed=seeds, m=st.integers(8, 200), data=st.data())
def test_curve_reconstruction_is_exact_for_any_scale(seed, m, data):
    n = data.draw(st.integers(1, m - 1))
    poles = np.random.default_rng(seed).normal(size=(m + 3, 3)) * 50
    result = cf.fair_curve(poles, n)
    assert result.poles.shape == (n + 3, 3)
    assert np.abs(result.reconstruct() - poles).max() <= 1e-10 * np.abs(poles).max()


@given(seed=seeds, n=st.integers(1, 40))
def test_every_schedule_of_the_ladder_gives_the_direct_projection(seed, n):
    poles = _noisy_curve(seed)
    ladder = cf.fair_curve(poles, n)
    direct = cf.fair_curve(poles, n, schedule="direct")
    assert np.allclose(ladder.poles, direct.poles, atol=1e-10 * np.abs(poles).max())


@given(seed=seeds)
def test_projection_onto_the_same_space_is_the_identity(seed):
    poles = _noisy_curve(seed, 40)
    assert np.allclose(cf.fair_curve(poles, 37).poles, poles, atol=1e-13)


@given(seed=seeds, n=st.integers(2, 30))
def test_projection_is_idempotent_and_linear(seed, n):
    a, b = _noisy_curve(seed), _noisy_curve(seed + 1)
    once = cf.fair_curve(a, n)
    # projecting the faired curve (expressed in the source space) again changes nothing
    up = once.reconstruct(detail_weight=0.0)
    assert np.allclose(cf.fair_curve(up, n).poles, once.poles, atol=1e-10)
    combo = cf.fair_curve(2.5 * a - 0.7 * b, n).poles
    assert np.allclose(combo, 2.5 * once.poles - 0.7 * cf.fair_curve(b, n).poles, atol=1e-9)


@given(seed=seeds, n=st.integers(2, 40), scale=st.floats(1e-3, 1e3),
       shift=st.lists(st.floats(-1e4, 1e4), min_size=3, max_size=3))
def test_fairing_commutes_with_rotation_translation_and_scaling(seed, n, scale, shift):
    poles = _noisy_curve(seed)
    rot = Rotation.random(random_state=seed % 2**32).as_matrix()
    moved = scale * poles @ rot.T + np.array(shift)
    expected = scale * cf.fair_curve(poles, n).poles @ rot.T + np.array(shift)
    tol = 1e-9 * (np.abs(moved).max() + 1)
    assert np.allclose(cf.fair_curve(moved, n).poles, expected, atol=tol)


def test_seed_nonnested_cases_match_the_dense_reference():
    rng = np.random.default_rng(5)
    for m, n in [(117, 27), (1299, 78)]:
        poles = rng.normal(size=(m + 3, 3))
        ref = dense_coarse(SplineSpace.quasi_uniform(m).knots, 3,
                           SplineSpace.quasi_uniform(n).knots, 3, poles)
        assert np.allclose(cf.fair_curve(poles, n).poles, ref, atol=1e-9)


def test_surface_is_the_tensor_product_of_curve_fairings():
    rng = np.random.default_rng(7)
    net = rng.normal(size=(50, 80, 3))
    result = cf.fair_surface(net, (15, 23))
    assert result.poles.shape == (18, 26, 3)
    rows = np.stack([cf.fair_curve(net[i], 23).poles for i in range(50)])
    expected = np.stack([cf.fair_curve(rows[:, j], 15).poles for j in range(26)], axis=1)
    assert np.allclose(result.poles, expected, atol=1e-10)
    (det,) = result.details
    assert det.u.shape == (32, 26, 3) and det.v.shape == (18, 54, 3) and det.uv.shape == (32, 54, 3)
    assert np.abs(result.reconstruct() - net).max() < 1e-10 * np.abs(net).max()


@given(seed=seeds, ku=st.integers(5, 40), kv=st.integers(5, 40), data=st.data())
def test_surface_reconstruction_any_targets_including_one_direction(seed, ku, kv, data):
    nu = data.draw(st.one_of(st.none(), st.integers(1, ku - 3)))
    nv = data.draw(st.one_of(st.none(), st.integers(1, kv - 3)))
    if nu is None and nv is None:
        nu = 1
    net = np.random.default_rng(seed).normal(size=(ku, kv, 3))
    result = cf.fair_surface(net, (nu, nv))
    assert result.poles.shape == ((nu + 3) if nu else ku, (nv + 3) if nv else kv, 3)
    assert np.abs(result.reconstruct() - net).max() <= 1e-10 * np.abs(net).max()


def test_partial_detail_restores_part_of_the_source():
    poles = _noisy_curve(3)
    result = cf.fair_curve(poles, 20)
    half = result.reconstruct(detail_weight=0.5)
    coarse = result.reconstruct(detail_weight=0.0)
    assert np.allclose(half, 0.5 * (coarse + poles), atol=1e-10)


def test_rational_curves_are_faired_in_homogeneous_coordinates():
    rng = np.random.default_rng(8)
    poles = _noisy_curve(8, 60)
    weights = 1 + 0.05 * rng.random(60)
    result = cf.fair_curve(poles, 20, weights=weights)
    assert result.weights is not None and np.all(result.weights > 0)
    assert np.allclose(result.reconstruct(), poles, atol=1e-10)
    homogeneous = cf.fair_curve(np.c_[poles * weights[:, None], weights], 20).poles
    assert np.allclose(result.poles * result.weights[:, None], homogeneous[:, :3], atol=1e-12)


def test_general_source_knots_and_degree():
    rng = np.random.default_rng(9)
    knots = np.r_[np.zeros(6), np.sort(rng.uniform(0.05, 0.95, 59)), np.ones(6)]
    poles = rng.normal(size=(65, 2))
    result = cf.fair_curve(poles, 12, knots=knots, degree=5)
    assert result.degree == 3 and result.poles.shape == (15, 2)
    assert np.allclose(result.reconstruct(), poles, atol=1e-10)
    ref = dense_coarse(knots, 5, SplineSpace.quasi_uniform(12).knots, 3, poles)
    assert np.allclose(result.poles, ref, atol=1e-9)


def test_plans():
    src = SplineSpace.quasi_uniform(1299)
    tgt = SplineSpace.quasi_uniform(78)
    assert [s.n_spans for s in plan_spaces(src, tgt, "hybrid")] == [1299, 1024, 512, 256, 128, 78]
    assert [s.n_spans for s in plan_spaces(src, tgt, "auto")] == [1299, 312, 156, 78]
    dyadic = SplineSpace.quasi_uniform(1024)
    assert [s.n_spans for s in plan_spaces(dyadic, SplineSpace.quasi_uniform(64), "auto")] == \
        [1024, 512, 256, 128, 64]


def test_ladder_terminates_for_a_target_equal_to_the_source_up_to_rounding():
    """Knots that went through a file differ in the last bit: V_48 -> V_48 is one step.

    (Before the fix the ladder doubled forever from ratio 1 and exhausted memory when
    FreeCAD recomputed a reopened document.)
    """
    knots = SplineSpace.quasi_uniform(48).knots.copy()
    knots[10] = np.nextafter(knots[10], 1.0)
    rounded = SplineSpace.from_knots(knots, 3)
    target = SplineSpace.quasi_uniform(48)
    assert not rounded.same_as(target) and rounded.is_quasi_uniform
    assert [s.n_spans for s in plan_spaces(rounded, target, "auto")] == [48, 48]
    poles = np.random.default_rng(0).normal(size=(51, 3))
    assert np.allclose(cf.fair_curve(poles, 48, knots=knots).poles, poles, atol=1e-9)


def test_hybrid_differs_from_the_l2_best_only_slightly_on_smooth_data():
    t = np.linspace(0, 1, 1300)
    pts = np.c_[np.cos(6 * t), np.sin(6 * t), 0.2 * t]
    curve = cf.interpolate_points(pts)
    direct = cf.fair_curve(curve.poles, 78)
    hybrid = cf.fair_curve(curve.poles, 78, schedule="hybrid")
    gap = np.abs(direct.poles - hybrid.poles).max()
    assert 0 < gap < 1e-4


@pytest.mark.parametrize("kwargs, error, words", [
    (dict(poles=np.zeros((10, 3)), n=8), cf.InvalidTargetError, "between 1 and 7"),
    (dict(poles=np.zeros((10, 3)), n=0), cf.InvalidTargetError, "between 1 and 7"),
    (dict(poles=np.zeros((10, 3)), n=2.5), cf.InvalidTargetError, "integer"),
    (dict(poles=np.full((10, 3), np.nan), n=3), cf.InvalidInputError, "NaN or inf"),
    (dict(poles=np.zeros((10,)), n=3), cf.InvalidInputError, "shape"),
    (dict(poles=np.zeros((3, 3)), n=1), cf.InvalidInputError, "at least 4 poles"),
    (dict(poles=np.zeros((10, 3))), cf.InvalidInputError, "exactly one of n"),
    (dict(poles=np.zeros((10, 3)), n=3, weights=-np.ones(10)), cf.InvalidInputError, "positive"),
    (dict(poles=np.zeros((10, 3)), n=3, schedule="fast"), cf.InvalidInputError, "schedule"),
])
def test_bad_input_raises_typed_errors(kwargs, error, words):
    with pytest.raises(error, match=words):
        cf.fair_curve(**kwargs)


def test_bad_surface_input():
    with pytest.raises(cf.InvalidInputError, match="shape"):
        cf.fair_surface(np.zeros((10, 3)), (2, 2))
    with pytest.raises(cf.InvalidTargetError):
        cf.fair_surface(np.zeros((10, 10, 3)), (2, 8))
