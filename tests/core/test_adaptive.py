"""Adaptive target spaces (cq_fairing.core.adaptive): tolerance by true distance, fewer poles
than the uniform search, exact reconstruction, valid knots, errors."""

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

import cq_fairing as cf
from cq_fairing.core import examples
from cq_fairing.core.adaptive_counts import (
    _bisect_count,
    _doubling,
    _gallop_down,
    _interpolated_count,
)
from cq_fairing.core.adaptive_curve import CurveSearch, fair_curve_adaptive
from cq_fairing.core.adaptive_knots import _source_density, equidistributed_space
from cq_fairing.core.adaptive_surface import fair_surface_adaptive
from cq_fairing.core.energy import fair_surface_energy
from cq_fairing.core.gram import gram_matrix
from cq_fairing.core.measures import deviation
from cq_fairing.core.polish import (
    _constrained_stages,
    largest_penalty,
    net_lengths,
    variation_energy_matrix,
)
from cq_fairing.core.surface_fit import _SurfaceFit
from cq_fairing.core.target_projections import _net_solve
from cq_fairing.errors import InvalidInputError, InvalidToleranceError, ToleranceNotMetError
from tests.reliability.independent import distance_to_surface, surface_points

from .naive import trapezoid


@pytest.fixture(scope="module")
def seed():
    return examples.seed_curve()


@pytest.fixture(scope="module")
def blade():
    """The blade-like surface (30x30 grid, 50 mm span) with a local bump near one edge:
    a feature that a uniform target must resolve everywhere."""
    b = examples.blade_surface((30, 30), noise=0.0, span=50.0, chord=15.0)
    u = np.linspace(0.0, 1.0, 30)[:, None]
    v = np.linspace(0.0, 1.0, 30)[None, :]
    pts = b.clean_points.copy()
    pts[..., 1] += 1.5 * np.exp(-((u - 0.3) / 0.05) ** 2 - ((v - 0.6) / 0.1) ** 2)
    return cf.interpolate_grid(pts)


@pytest.fixture(scope="module")
def seed_result(seed):
    return fair_curve_adaptive(seed.curve, 0.02)


def test_seed_curve_meets_tol_by_true_distance(seed, seed_result):
    assert deviation(seed.curve, seed_result.curve, per_span=16).max <= 0.02


def test_seed_curve_needs_fewer_poles_than_uniform(seed, seed_result):
    uniform = cf.fair_curve(seed.curve.poles, tol=0.02, method="wavelet")
    assert seed_result.poles.shape[0] < uniform.poles.shape[0]


def test_seed_curve_closer_to_truth_than_tol(seed, seed_result):
    assert deviation(seed.truth, seed_result.curve).max < 0.02


def test_unpolished_curve_reconstructs_source_exactly(seed):
    result = fair_curve_adaptive(seed.curve, 0.05, polish=False)
    assert np.allclose(result.reconstruct(), seed.curve.poles, atol=1e-9)


@pytest.mark.parametrize("tol", [0.005, 0.02])
def test_a_verdict_trial_decides_as_a_full_one(seed, tol):
    """A count checked for its verdict only (refuted by the distance floor, or measured
    one way where that exceeds tol) passes or fails as the full measure does, and a
    passing one has the full measure's values, which the reduction goes on from."""
    fit = CurveSearch(seed.curve, tol, 3).fit
    density = _source_density(seed.curve.space)
    for n in (4, 16, 64, 66, 68, 69, 72, 128, 600, 660, 700):
        space = equidistributed_space(*density, n, 3)
        full, quick = fit.trial(space), fit.trial(space, verdict=True)
        assert (quick[2] <= fit.tol) == (full[2] <= fit.tol), n
        if full[2] <= fit.tol:
            np.testing.assert_array_equal(quick[1], full[1])


def test_curve_knots_are_valid_and_clamped(seed_result):
    space = cf.SplineSpace.from_knots(seed_result.knots, seed_result.degree)
    assert space.dimension == seed_result.poles.shape[0]
    assert np.all(np.diff(space.breakpoints) > 0)


def test_equidistributed_space_equal_mass_per_span():
    breaks = np.array([0.0, 0.2, 0.5, 1.0])
    density = np.array([5.0, 1.0, 2.0])
    space = equidistributed_space(breaks, density, 6, 3)
    b = space.breakpoints
    x = np.linspace(0.0, 1.0, 200001)
    rho = density[np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, 2)]
    masses = [trapezoid(rho[(x >= lo) & (x <= hi)], x[(x >= lo) & (x <= hi)])
              for lo, hi in zip(b[:-1], b[1:])]
    assert np.allclose(masses, np.mean(masses), rtol=2e-3)
    assert space.knots[:4].tolist() == [0.0] * 4 and space.knots[-4:].tolist() == [1.0] * 4


def test_uniform_density_gives_quasi_uniform_space():
    space = equidistributed_space(np.linspace(0, 2, 5), np.ones(4), 7, 3)
    assert space.same_as(cf.SplineSpace.quasi_uniform(7, 3, (0.0, 2.0)))


def test_blade_meets_tol_with_fewer_poles_than_uniform(blade, blade_auto):
    result = blade_auto
    uniform = cf.fair_surface(blade.poles, tol=0.02)
    assert deviation(blade, result.surface).max <= 0.02
    assert np.prod(result.poles.shape[:2]) < np.prod(uniform.poles.shape[:2])


def test_unpolished_surface_with_free_borders_reconstructs_source(blade):
    result = fair_surface_adaptive(blade, 0.05, polish=False, borders="free")
    assert np.allclose(result.reconstruct(), blade.poles, atol=1e-8)
    assert deviation(blade, result.surface).max <= 0.05


@pytest.fixture(scope="module")
def blade_auto(blade):
    return fair_surface_adaptive(blade, 0.02)


def test_auto_borders_are_pinned_only_when_the_net_shrinks(blade, blade_auto):
    """On the bump fixture the free-border search ends at 15 x 12; going on with pinned
    borders reaches 15 x 11, so ``"auto"`` keeps them, with the corners exact."""
    free = fair_surface_adaptive(blade, 0.02, borders="free", polish=False)
    assert dict(free.table)["borders"] == "free"
    assert dict(blade_auto.table)["borders"] == "pinned"
    assert blade_auto.poles[:, :, 0].size < free.poles[:, :, 0].size
    assert deviation(blade, blade_auto.surface).max <= 0.02
    for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert np.array_equal(blade_auto.poles[i, j], blade.poles[i, j])


def test_fair_surface_passes_borders_to_the_adaptive_method(blade, blade_auto):
    """The public entry point reaches the same free-border net as the module's own
    function, one pole row more than ``"auto"``; other methods refuse the option."""
    knots = dict(u_knots=blade.u_space.knots, v_knots=blade.v_space.knots,
                 degree=(blade.u_degree, blade.v_degree))
    free = cf.fair_surface(blade.poles, tol=0.02, method="adaptive", borders="free", **knots)
    direct = fair_surface_adaptive(blade, 0.02, borders="free")
    assert dict(free.table)["borders"] == "free"
    np.testing.assert_array_equal(free.poles, direct.poles)
    assert free.poles[:, :, 0].size > blade_auto.poles[:, :, 0].size
    with pytest.raises(InvalidInputError, match="method='adaptive' only"):
        cf.fair_surface(blade.poles, tol=0.02, borders="free", **knots)


def test_pinned_borders_keep_the_corners_within_tol(blade):
    result = fair_surface_adaptive(blade, 0.05, borders="pinned")
    assert dict(result.table)["borders"] == "pinned"
    assert deviation(blade, result.surface).max <= 0.05
    for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert np.array_equal(result.poles[i, j], blade.poles[i, j])


def _least_squares_with_fixed_ends(design, weights, values, ends):
    """min sum_q w_q |design_q x - values_q|^2 over x[1:-1], with x[0], x[-1] = ends."""
    root = np.sqrt(weights)[:, None]
    rest = values - design[:, [0, -1]] @ ends
    inner = np.linalg.lstsq(root * design[:, 1:-1], root * rest, rcond=None)[0]
    return np.concatenate([ends[:1], inner, ends[1:]])


def _gauss(breaks, nodes=8):
    """Gauss-Legendre nodes and weights, ``nodes`` per cell of ``breaks``."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    h = np.diff(breaks)[:, None]
    return ((0.5 * (breaks[1:, None] + breaks[:-1, None]) + 0.5 * h * x).ravel(),
            (0.5 * h * w).ravel())


def _dense_pinned_projection(source, tu, tv):
    """Border curves fitted with their ends kept, then the interior with the border held,
    by weighted least squares at Gauss points (scipy design matrices, numpy lstsq)."""
    def basis(space, x):
        return BSpline.design_matrix(x, space.knots, space.degree).toarray()

    (xu, wu), (xv, wv) = (_gauss(np.union1d(a.breakpoints, b.breakpoints))
                          for a, b in ((source.u_space, tu), (source.v_space, tv)))
    tu_x, tv_x = basis(tu, xu), basis(tv, xv)
    su_x, sv_x = basis(source.u_space, xu), basis(source.v_space, xv)
    p = source.poles
    net = np.zeros((tu.dimension, tv.dimension, 3))
    for j in (0, -1):   # border curves v = v0, v1: the clamped net's border columns
        net[:, j] = _least_squares_with_fixed_ends(tu_x, wu, su_x @ p[:, j], p[[0, -1], j])
    for i in (0, -1):
        net[i, :] = _least_squares_with_fixed_ends(tv_x, wv, sv_x @ p[i], p[i, [0, -1]])
    if min(net.shape[:2]) <= 2:
        return net
    values = np.einsum("qa,abk,rb->qrk", su_x, p, sv_x).reshape(-1, 3)
    design = np.kron(tu_x, tv_x)
    inside = np.zeros(net.shape[:2], dtype=bool)
    inside[1:-1, 1:-1] = True
    inside = inside.ravel()
    root = np.sqrt(np.kron(wu, wv))[:, None]
    rest = values - design[:, ~inside] @ net.reshape(-1, 3)[~inside]
    net.reshape(-1, 3)[inside] = np.linalg.lstsq(root * design[:, inside], root * rest,
                                                 rcond=None)[0]
    return net


def _pinned(source, tu, tv):
    return _SurfaceFit(source, 1.0, (tu.degree, tv.degree), 2, 10_000, "pinned").project(tu, tv)


def test_pinned_projection_matches_a_dense_constrained_least_squares():
    """An independent computation of the same minimisers on a hand-picked case."""
    rng = np.random.default_rng(11)
    source = cf.make_surface(rng.normal(size=(9, 8, 3)), degree=(3, 2),
                             u_knots=np.r_[[0.0] * 4, 0.1, 0.3, 0.35, 0.6, 0.8, [1.0] * 4],
                             v_knots=np.r_[[0.0] * 3, 0.2, 0.25, 0.5, 0.7, 0.9, [1.0] * 3])
    tu = cf.SplineSpace.from_knots(np.r_[[0.0] * 4, 0.27, 0.55, [1.0] * 4], 3)
    tv = cf.SplineSpace.from_knots(np.r_[[0.0] * 3, 0.4, 0.65, [1.0] * 3], 2)
    net = _dense_pinned_projection(source, tu, tv)
    assert np.allclose(_pinned(source, tu, tv), net, rtol=0, atol=1e-10 * np.abs(net).max())


def _random_space(rng, degree, spans):
    """Clamped space on [0, 1] with ``spans`` spans no shorter than a third of the mean."""
    gaps = rng.uniform(1.0, 3.0, spans)
    inner = np.cumsum(gaps)[:-1] / gaps.sum()
    return cf.SplineSpace.from_knots(np.r_[[0.0] * (degree + 1), inner,
                                           [1.0] * (degree + 1)], degree)


@given(seed=st.integers(0, 2 ** 31), degrees=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       source_spans=st.tuples(st.integers(1, 7), st.integers(1, 7)),
       target_degrees=st.tuples(st.integers(1, 4), st.integers(1, 4)),
       fractions=st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0)))
def test_pinned_projection_properties(seed, degrees, source_spans, target_degrees, fractions):
    """For random sources and targets: the dense least-squares minimisers, the corners
    kept exactly, and the source itself back when the target is the source's space."""
    rng = np.random.default_rng(seed)
    su, sv = (_random_space(rng, p, n) for p, n in zip(degrees, source_spans))
    source = cf.make_surface(rng.normal(size=(su.dimension, sv.dimension, 3)),
                             u_knots=su.knots, v_knots=sv.knots, degree=degrees)
    tu, tv = (_random_space(rng, p, max(1, round(f * n)))
              for p, f, n in zip(target_degrees, fractions, source_spans))
    ours = _pinned(source, tu, tv)
    reference = _dense_pinned_projection(source, tu, tv)
    scale = np.abs(source.poles).max()
    assert np.allclose(ours, reference, rtol=0, atol=1e-8 * scale)
    for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert np.array_equal(ours[i, j], source.poles[i, j])
    assert np.allclose(_pinned(source, su, sv), source.poles, rtol=0, atol=1e-10 * scale)


def test_unknown_borders_are_refused(blade):
    with pytest.raises(InvalidInputError, match="borders must be one of"):
        fair_surface_adaptive(blade, 0.05, borders="clamped")


def _variation_energy_by_quadrature(surface, lengths, nodes=12):
    """int int sum_a C(3,a) |d^3 S / ds^a dt^(3-a)|^2 ds dt with s = L_u u, t = L_v v, by
    scipy's BSpline derivatives (v rows first, then u) and Gauss-Legendre per knot cell."""
    (u, wu), (v, wv) = (_gauss(np.unique(knots), nodes)
                        for knots in (surface.u_knots, surface.v_knots))
    weight = np.outer(wu, wv)
    lu, lv = lengths
    total = 0.0
    for a, binom in ((3, 1), (2, 3), (1, 3), (0, 1)):
        rows = BSpline(surface.v_knots, np.swapaxes(surface.poles, 0, 1),
                       surface.v_degree).derivative(3 - a)(v)          # (len v, k_u, 3)
        d = BSpline(surface.u_knots, np.swapaxes(rows, 0, 1),
                    surface.u_degree).derivative(a)(u)                 # (len u, len v, 3)
        d = d / (lu ** a * lv ** (3 - a))
        total += binom * np.sum(np.sum(d * d, axis=2) * weight) * lu * lv
    return total


def test_variation_energy_matches_quadrature_of_third_derivatives():
    rng = np.random.default_rng(3)
    surface = cf.make_surface(rng.normal(size=(7, 6, 3)), degree=(4, 3))
    surface = cf.make_surface(surface.poles, degree=(4, 3),
                              u_knots=np.r_[[0.0] * 5, 0.2, 0.7, [1.0] * 5],
                              v_knots=np.r_[[0.0] * 4, 0.4, 0.5, [1.0] * 4])
    lengths = (40.0, 7.5)
    e = variation_energy_matrix(surface.u_space, surface.v_space, lengths)
    c = surface.poles.reshape(-1, 3)
    ours = float(np.sum(c * (e @ c)))
    assert ours == pytest.approx(_variation_energy_by_quadrature(surface, lengths), rel=1e-9)


def test_net_lengths_of_a_flat_grid():
    u, v = np.meshgrid(np.linspace(0, 30, 7), np.linspace(0, 4, 5), indexing="ij")
    poles = np.stack([u, v, np.zeros_like(u)], axis=-1)
    assert net_lengths(poles) == pytest.approx((30.0, 4.0))


def test_surface_polish_lowers_the_variation_energy_within_tol(blade):
    plain = fair_surface_adaptive(blade, 0.05, polish=False)
    polished = fair_surface_adaptive(blade, 0.05)
    assert dict(polished.table)["lambda"] > 0.0
    assert deviation(blade, polished.surface).max <= 0.05
    surface = polished.surface
    e = variation_energy_matrix(surface.u_space, surface.v_space, net_lengths(blade.poles))

    def energy(s):
        c = s.poles.reshape(-1, 3)
        return float(np.sum(c * (e @ c)))

    assert plain.surface.poles.shape == surface.poles.shape
    assert energy(surface) < energy(plain.surface)  # Tikhonov: E decreases with lambda


def test_starts_on_one_net_are_reduced_once(monkeypatch):
    """A strip with 3 spans across: both axis starts keep u at the source and land on one
    net, which is reduced once; every distinct start is reduced."""
    import cq_fairing.core.adaptive_surface as adaptive

    rng = np.random.default_rng(3)
    u, v = np.linspace(0, 1, 4)[:, None], np.linspace(0, 1, 40)[None, :]
    points = np.stack([np.broadcast_to(10 * u, (4, 40)), np.broadcast_to(50 * v, (4, 40)),
                       3 * np.sin(6 * v) + 0.5 * u + 0.01 * rng.normal(size=(4, 40))], axis=-1)
    strip = cf.interpolate_grid(points)
    starts, reduced = [], []

    def recorded(function, log, net):
        def wrapper(*args, **kwargs):
            result = function(*args, **kwargs)
            log.append(net(args, result))
            return result
        return wrapper

    for name in ("_diagonal_start", "_axis_start"):
        monkeypatch.setattr(adaptive, name, recorded(getattr(adaptive, name), starts,
                                                     lambda args, result: result[0]))
    monkeypatch.setattr(adaptive, "_reduce_surface", recorded(
        adaptive._reduce_surface, reduced, lambda args, result: args[1]))
    result = fair_surface_adaptive(strip, 0.05, borders="free")

    def keys(nets):
        return [(net[0].key, net[1].key) for net in nets]

    assert len(starts) == 3 and len(set(keys(starts))) == 2
    assert sorted(keys(reduced)) == sorted(set(keys(starts)))
    assert deviation(strip, result.surface).max <= 0.05


@pytest.mark.parametrize("tol", [0.05, 0.2, 0.5])
def test_a_reduction_from_far_above_strides_down_in_half_the_trials(blade, tol, monkeypatch):
    """From the source's own 29 x 29 spans, far below tol, the reduction strides down in
    at most 60 % of the trials of the one-span walk (``GALLOP_BELOW = 0``), to a net
    within tol and at most 5 % larger (measured: 21-24 against 48-54 trials, nets of 110
    against 108 poles at 0.2, smaller at 0.05 and 0.5)."""
    import cq_fairing.core.adaptive_surface as adaptive

    def reduced():
        fit = _SurfaceFit(blade, tol, (3, 3), 4, 100_000)
        full = [equidistributed_space(*_source_density(s), s.n_spans, 3)
                for s in (blade.u_space, blade.v_space)]
        top = fit.trial(*full)
        start = fit.evaluations
        spaces, result = adaptive._reduce_surface(fit, full, top, tol)
        assert result[2] <= tol
        return spaces[0].dimension * spaces[1].dimension, fit.evaluations - start

    poles, trials = reduced()
    monkeypatch.setattr(adaptive, "GALLOP_BELOW", 0.0)
    walk_poles, walk_trials = reduced()
    assert trials <= 0.6 * walk_trials
    assert poles <= 1.05 * walk_poles


@given(top=st.integers(1, 400), data=st.data())
def test_count_searches_find_the_smallest_passing_count(top, data):
    """Bisecting from 0 and galloping down from ``top`` agree with a linear scan on any
    monotone check; galloping asks at most 3 counts when the answer lies within 2 of the
    top (bisecting from 0 asks about log2(top))."""
    answer = data.draw(st.integers(1, top))
    asked = {"bisect": [], "gallop": []}

    def check(name):
        def passes(n):
            asked[name].append(n)
            return n >= answer
        return passes

    assert _bisect_count(0, top, check("bisect")) == answer
    assert _gallop_down(top, check("gallop")) == answer
    assert all(1 <= n < top for n in asked["gallop"])
    if top - answer <= 2:
        assert len(asked["gallop"]) <= 3
        if top >= 8:
            assert len(asked["gallop"]) <= len(asked["bisect"])


@given(top=st.integers(2, 400), seed=st.integers(0, 2 ** 31), data=st.data())
def test_interpolated_count_agrees_with_a_scan_on_any_falling_value(top, seed, data):
    """Any non-increasing positive value (random drops, plateaus where half of them are
    zero): the smallest count within the limit, as a linear scan finds it, asking only
    counts inside the bracket or its ends."""
    rng = np.random.default_rng(seed)
    drops = rng.exponential(size=top) * (rng.random(top) < 0.5)
    values = 1e-3 + np.cumsum(drops[::-1])[::-1]      # values[n - 1], non-increasing in n
    limit = data.draw(st.floats(values[-1], 2.0 * values[0]))
    expected = 1 + int(np.argmax(values <= limit))
    fails = data.draw(st.integers(0, expected - 1))
    asked = set()

    def value(n):
        asked.add(n)
        return values[n - 1]

    assert _interpolated_count(fails, top, value, limit) == expected
    assert all(max(fails, 1) <= n <= top for n in asked)


@pytest.mark.parametrize("power", [2.0, 4.0, 8.0])
def test_interpolated_count_closes_a_power_law_bracket_in_two_values(power):
    """On an exact power law the log-log chord lands on the answer, and its neighbour
    closes the bracket: 2 new values where bisection needs 5-6."""
    asked = set()

    def value(n):
        asked.add(n)
        return 3e3 * n ** -power

    for answer in (70, 99, 128):
        limit = value(answer)
        asked.clear()
        assert _interpolated_count(67, 129, value, limit) == answer
        assert len(asked - {67, 129}) == 2
        asked.clear()
        assert _bisect_count(67, 129, lambda n: value(n) <= limit) == answer
        assert len(asked) >= 5


def test_interpolated_count_is_cheaper_than_bisection_on_simulated_residuals():
    r"""Residual variances of noisy data, :math:`s^2 (1 - n/N) + c\,n^{-p}`, bracketed by
    doubling from 4 spans as the faithful search does: the same counts as bisection in at
    most 80 % of its evaluations on average (3.3 against 5.1 when measured)."""
    rng = np.random.default_rng(1)
    counts = {"interpolated": [], "bisect": []}
    for _ in range(200):
        c, p = 10 ** rng.uniform(0, 4), rng.uniform(1.5, 8)
        s2, big_n = 10 ** rng.uniform(-3, 0), rng.uniform(400, 4000)
        values = s2 * (1 - np.arange(1, 401) / big_n) + c * np.arange(1, 401) ** -p
        limit = 1.21 * values[400 // 3 - 1]
        fails, passes = _doubling(lambda n: values[n - 1] <= limit, 400)
        if passes is None or passes - fails < 16:
            continue
        found = {}
        for name, search in (("interpolated", lambda ask: _interpolated_count(
                                  fails, passes, ask, limit)),
                             ("bisect", lambda ask: _bisect_count(
                                  fails, passes, lambda n: ask(n) <= limit))):
            asked = set()
            found[name] = search(lambda n: asked.add(n) or values[n - 1])
            counts[name].append(len(asked - {fails, passes}))
        assert found["interpolated"] == found["bisect"]
    assert len(counts["bisect"]) >= 50
    assert np.mean(counts["interpolated"]) <= 0.8 * np.mean(counts["bisect"])


def test_bad_tolerance_is_refused(seed):
    with pytest.raises(InvalidToleranceError):
        fair_curve_adaptive(seed.curve, -1.0)


def test_unreachable_tolerance_raises(seed):
    with pytest.raises(ToleranceNotMetError):
        fair_curve_adaptive(seed.curve, 1e-9, target_degree=1)


def test_a_refusal_names_the_wavelet_targets_for_a_source_with_multiple_knots():
    """A bicubic source with a crease and a cubic with a corner (a triple knot: C0 at
    0.5) are out of reach of every adaptive target (simple knots on the breakpoints): the
    refusal says so and names the uniform targets, which reach the source's own space.  A source with simple
    knots refused at an unreachable tol gets no such hint."""
    u = np.linspace(0.0, 1.0, 7)
    poles = np.stack(np.meshgrid(u, np.linspace(0.0, 1.0, 4), indexing="ij"), axis=-1)
    height = np.abs(u - 0.5)[:, None] * np.ones((1, 4))
    creased = cf.make_surface(np.concatenate([poles, height[..., None]], axis=-1),
                              u_knots=[0, 0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1, 1])
    with pytest.raises(ToleranceNotMetError) as refused:
        fair_surface_adaptive(creased, 1e-4)
    assert "method 'wavelet'" in str(refused.value)
    assert "7 x 4 poles sit on 2 x 1 spans (multiple knots)" in str(refused.value)
    corner = cf.make_curve(np.stack([u, np.abs(u - 0.5)], axis=1),
                           [0, 0, 0, 0, 0.5, 0.5, 0.5, 1, 1, 1, 1], 3)
    with pytest.raises(ToleranceNotMetError) as refused:
        fair_curve_adaptive(corner, 1e-4)
    assert "its 7 poles sit on 2 spans (multiple knots)" in str(refused.value)
    smooth = cf.make_surface(np.random.default_rng(2).normal(size=(9, 8, 3)), degree=(5, 5))
    with pytest.raises(ToleranceNotMetError) as refused:
        fair_surface_adaptive(smooth, 1e-9)
    assert "wavelet" not in str(refused.value)


def test_constant_weights_give_the_polynomial_net():
    """Homogeneous coordinates with one weight w everywhere are w times the poles: the
    projections, the search and the answer are the polynomial ones (the polish, which
    rational sources skip, is off for both)."""
    poles = np.random.default_rng(1).normal(size=(12, 10, 3))
    polynomial = fair_surface_adaptive(cf.make_surface(poles), 0.3, polish=False)
    rational = fair_surface_adaptive(cf.make_surface(poles, weights=np.full((12, 10), 2.0)),
                                     0.3, polish=False)
    assert rational.surface.is_rational and np.allclose(rational.surface.weights, 2.0)
    assert rational.surface.shape == polynomial.surface.shape
    np.testing.assert_allclose(rational.surface.u_knots, polynomial.surface.u_knots)
    np.testing.assert_allclose(rational.surface.poles, polynomial.surface.poles, atol=1e-12)
    assert rational.max_deviation == pytest.approx(polynomial.max_deviation, rel=1e-9)


def _fillet(sections=40, angle=0.5 * np.pi, seed=3):
    """A swept fillet: along u a wavy spine with noisy radii (cubic, ``sections`` pole
    rows), across v a circular arc of ``angle`` as one rational quadratic span (poles
    c + r e_0, c + r / cos(angle / 2) e_mid, c + r e_1, weights 1, cos(angle / 2), 1).
    Every row has the same weights and the arc's directions, so every section of the
    surface is an exact circular arc in a plane x = const."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 60.0, sections)
    centre = np.stack([x, 2.0 * np.sin(x / 15.0), 0.5 * np.cos(x / 9.0)], axis=1)
    radius = 4.0 + 0.5 * np.sin(x / 20.0) + rng.normal(scale=0.01, size=sections)
    half = 0.5 * angle
    directions = np.array([[0.0, 1.0, 0.0],
                           [0.0, np.cos(half) / np.cos(half), np.sin(half) / np.cos(half)],
                           [0.0, np.cos(angle), np.sin(angle)]])
    poles = centre[:, None, :] + radius[:, None, None] * directions[None, :, :]
    weights = np.tile([1.0, np.cos(half), 1.0], (sections, 1))
    return cf.make_surface(poles, degree=(3, 2), weights=weights)


def _independent_two_sided(a, b, n=60):
    """Two-sided distance of two surfaces on one domain at n x n samples each, measured
    with the reliability suite's independent evaluation and search (scipy's BSpline, a
    KD-tree start, golden-section refinement): an upper bound at those samples."""
    def on(s):
        return lambda u, v: surface_points(s.poles, s.u_knots, s.v_knots,
                                           (s.u_degree, s.v_degree), s.weights, u, v)

    u, v = (g.ravel() for g in np.meshgrid(np.linspace(0.0, 1.0, n), np.linspace(0.0, 1.0, n),
                                           indexing="ij"))
    there = distance_to_surface(on(a)(u, v), on(b), b.domain, (u, v))
    back = distance_to_surface(on(b)(u, v), on(a), a.domain, (u, v))
    return float(max(there.max(), back.max()))


def test_rational_fillet_keeps_its_circular_sections():
    """The projection acts on (w P, w): along the arc the target is the source's own
    rational quadratic span, so the answer keeps three poles there and every section is
    still an exact circular arc, while the sweep is reduced within tol."""
    fillet, tol = _fillet(), 0.05
    result = fair_surface_adaptive(fillet, tol)
    faired = result.surface
    assert faired.is_rational and np.all(faired.weights > 0)
    assert faired.shape[1] == 3 and faired.v_degree == 2
    assert faired.shape[0] < fillet.shape[0] / 3
    assert result.max_deviation <= tol
    assert _independent_two_sided(fillet, faired) <= tol
    for u in np.linspace(0.0, 1.0, 7):
        arc = faired.evaluate_grid(np.array([u]), np.linspace(0.0, 1.0, 9))[0]
        assert np.ptp(arc[:, 0]) <= 1e-9                      # in a plane x = const
        a, b, c = arc[0, 1:], arc[4, 1:], arc[-1, 1:]         # circle through 3 points
        centre = _circumcentre(a, b, c)
        radii = np.linalg.norm(arc[:, 1:] - centre, axis=1)
        assert np.ptp(radii) <= 1e-9 * radii.mean()


def _circumcentre(a, b, c):
    """Centre of the circle through three points of the plane."""
    d = 2.0 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    sq = [p @ p for p in (a, b, c)]
    return np.array([sq[0] * (b[1] - c[1]) + sq[1] * (c[1] - a[1]) + sq[2] * (a[1] - b[1]),
                     sq[0] * (c[0] - b[0]) + sq[1] * (a[0] - c[0]) + sq[2] * (b[0] - a[0])]) / d


def test_a_coarse_search_grid_never_loosens_the_final_check(blade):
    """A tiny sample budget makes the search grid coarse (one sample per span); the final
    check still samples as densely as ``deviation`` (8 per merged span), so the reported
    maximum is the public measure's and within tol (before the fix: checked at 2 per span
    and returned above tol)."""
    result = fair_surface_adaptive(blade, 0.02, max_samples=1000)
    measured = deviation(blade, result.surface).max
    assert measured <= 0.02
    assert result.max_deviation == pytest.approx(measured, rel=1e-9)


def test_a_search_too_coarse_to_converge_is_refused_not_returned(blade):
    """With one sample per span the search keeps accepting nets that the dense check
    rejects; after each search the product grows such a net by a span, tightens the
    search if that fails too, and either returns a net that ``deviation`` confirms or
    says so instead of returning one.  Which tolerances end where follows the search's
    path: at degree 3, 0.045-0.06 end with a confirmed net; at degree 2, 0.05 is refused
    (the refusal is still the denser check's, not a deviation below tol) and 0.03 ends
    with a confirmed net: the tightened search's top, on the source's breakpoints, fails
    at degree 2 and doubles its spans (before that, 0.03 was refused too)."""
    outcomes = {}
    for degree, tol in ((3, 0.045), (3, 0.05), (3, 0.06), (2, 0.03), (2, 0.05)):
        try:
            result = fair_surface_adaptive(blade, tol, target_degree=degree, max_samples=1000)
        except ToleranceNotMetError as error:
            assert "denser check" in str(error)
            assert error.best_deviation > tol
            outcomes[degree, tol] = "refused"
        else:
            assert deviation(blade, result.surface).max <= tol
            outcomes[degree, tol] = "returned"
    assert outcomes == {(3, 0.045): "returned", (3, 0.05): "returned", (3, 0.06): "returned",
                        (2, 0.03): "returned", (2, 0.05): "refused"}


@pytest.mark.parametrize("borders", ["free", "pinned"])
def test_unit_span_weights_give_the_plain_penalised_projection(blade, borders):
    """The span-weighted path (band assembly, banded Cholesky) with every weight 1 is the
    Kronecker path of the plain polish, free and pinned."""
    tu = cf.SplineSpace.quasi_uniform(7, 3)
    tv = cf.SplineSpace.quasi_uniform(5, 3)
    fit = _SurfaceFit(blade, 0.05, (3, 3), 4, 100_000, borders)
    ones = np.ones(fit.span_shape)
    for lam in (0.0, 0.3):
        plain = fit.project(tu, tv, lam)
        assert np.allclose(fit.project(tu, tv, lam, ones), plain, rtol=0,
                           atol=1e-9 * np.abs(plain).max())


@pytest.mark.parametrize("shape", [(6, 9), (9, 6)])
def test_net_solve_matches_a_sparse_lu(shape):
    """Banded Cholesky in either numbering against scipy's sparse LU, and the LU
    fall-back on an indefinite matrix."""
    rng = np.random.default_rng(3)
    tu, tv = (cf.SplineSpace.quasi_uniform(k - 3, 3) for k in shape)
    mass = sp.kron(gram_matrix(tu), gram_matrix(tv)).tocsr()
    matrix = mass + 0.01 * variation_energy_matrix(tu, tv, (1.0, 1.0))
    rhs = rng.normal(size=(shape[0] * shape[1], 3))
    reference = spla.spsolve(matrix.tocsc(), rhs)
    assert np.allclose(_net_solve(matrix, rhs, shape), reference, rtol=1e-9, atol=1e-9)
    indefinite = matrix - 2.0 * mass.diagonal().max() * sp.eye(matrix.shape[0])
    reference = spla.spsolve(indefinite.tocsc(), rhs)
    assert np.allclose(_net_solve(indefinite, rhs, shape), reference, rtol=1e-9, atol=1e-9)


def test_constrained_stages_lower_the_energy_within_tol(blade):
    """Each stage of the constrained polish stays within tol by the public measure, has
    a lower curvature-variation energy than the one before, the first lower than the
    single-lambda polish's, and weighs some patches more than others."""
    spaces = [fair_surface_adaptive(blade, 0.05, polish=False, borders="free").surface]
    spaces = (spaces[0].u_space, spaces[0].v_space)
    fit = _SurfaceFit(blade, 0.99 * 0.05, (3, 3), 8, 400_000)
    (faired, _, _), lam = largest_penalty(lambda x: fit.trial(*spaces, x), fit.tol,
                                          fit.trial(*spaces), steps=8)
    stages = _constrained_stages(fit, spaces, faired, lam)
    e = variation_energy_matrix(*spaces, net_lengths(blade.poles))

    def energy(s):
        c = s.poles.reshape(-1, 3)
        return float(np.sum(c * (e @ c)))

    assert len(stages) >= 1
    energies = [energy(faired)] + [energy(s) for s, _, _ in stages]
    assert all(b < a for a, b in zip(energies, energies[1:])), energies
    for staged, stage_lam, weights in stages:
        assert stage_lam > lam
        assert deviation(blade, staged).max <= 0.05
        assert weights.min() >= 1.0 and weights.max() > 1.0


def test_the_public_result_reports_its_span_weights(blade):
    result = fair_surface_adaptive(blade, 0.05, borders="free")
    assert dict(result.table)["span weight"] > 1.0
    assert deviation(blade, result.surface).max <= 0.05


def test_below_the_noise_the_constrained_stages_come_closer_to_the_truth():
    """At a tolerance below the noise (sigma 0.01, tol 0.02) every fit must follow part
    of the noise; spending the tolerance where the single-lambda polish left it brings
    the net closer to the noise-free truth than that polish and than energy fairing of
    the whole source net (the benchmark's blade goal, on a smaller blade)."""
    blade = examples.blade_surface((30, 40), noise=0.01, span=50.0, chord=15.0)
    plain = fair_surface_adaptive(blade.surface, 0.02, polish=False, borders="free").surface
    spaces = (plain.u_space, plain.v_space)
    fit = _SurfaceFit(blade.surface, 0.99 * 0.02, (3, 3), 8, 400_000)
    (single, _, _), lam = largest_penalty(lambda x: fit.trial(*spaces, x), fit.tol,
                                          fit.trial(*spaces), steps=8)
    staged = _constrained_stages(fit, spaces, single, lam)[-1][0]
    energy = fair_surface_energy(blade.surface, 0.02).surface
    to_truth = {name: deviation(blade.truth, s).rms
                for name, s in (("single", single), ("staged", staged), ("energy", energy))}
    assert deviation(blade.surface, staged).max <= 0.02
    assert to_truth["staged"] < 0.9 * to_truth["single"], to_truth
    assert to_truth["staged"] < to_truth["energy"], to_truth


def _curve_jerk_by_quadrature(curve, nodes=12):
    """int |C'''(t)|^2 dt by scipy's BSpline derivative and Gauss-Legendre per knot cell."""
    t, w = _gauss(np.unique(curve.knots), nodes)
    d = BSpline(curve.knots, curve.poles, curve.degree).derivative(3)(t)
    return float(np.sum(np.sum(d * d, axis=1) * w))


def test_fair_objective_on_a_curve_is_no_rougher_than_compact(seed, seed_result):
    """``objective="fair"`` keeps the least int |C'''|^2 of the compact answer and the
    compact space with one or two more spans, each polished and checked: within tol by
    the true distance, at most two poles more, and on the seed curve a grown space wins
    (energy by an independent quadrature)."""
    fair = fair_curve_adaptive(seed.curve, 0.02, objective="fair")
    assert deviation(seed.curve, fair.curve, per_span=16).max <= 0.02
    assert seed_result.poles.shape[0] < fair.poles.shape[0] <= seed_result.poles.shape[0] + 2
    assert _curve_jerk_by_quadrature(fair.curve) < _curve_jerk_by_quadrature(seed_result.curve)


def test_fair_objective_on_a_surface_is_no_rougher_than_compact(blade):
    """The surface counterpart: the compact net and that net with up to two more spans
    per direction, polished; the least curvature-variation energy (independent
    quadrature of the third derivatives) within tol."""
    compact = fair_surface_adaptive(blade, 0.05)
    fair = fair_surface_adaptive(blade, 0.05, objective="fair")
    assert deviation(blade, fair.surface).max <= 0.05
    lengths = net_lengths(blade.poles)
    assert (_variation_energy_by_quadrature(fair.surface, lengths)
            <= _variation_energy_by_quadrature(compact.surface, lengths) * (1 + 1e-9))
    (cu, cv), (fu, fv) = compact.poles.shape[:2], fair.poles.shape[:2]
    assert cu <= fu <= cu + 2 and cv <= fv <= cv + 2


def test_fair_objective_is_offered_and_unknown_ones_are_refused(seed):
    with pytest.raises(InvalidInputError, match="'fair'"):
        fair_curve_adaptive(seed.curve, 0.02, objective="fairest")


def _blade_fit(blade, tol=0.05):
    return _SurfaceFit(blade, tol, (3, 3), 4, 100_000)


def _blade_spaces(blade, n_u, n_v):
    return [equidistributed_space(*_source_density(s), n, 3)
            for s, n in ((blade.u_space, n_u), (blade.v_space, n_v))]


@pytest.mark.parametrize("counts", [(4, 4), (6, 5), (8, 12), (20, 20)])
def test_a_screened_trial_gives_the_trials_verdict(blade, counts):
    """On nets from far above tol to below it: where the coarse screen refuses a
    candidate, the full trial refuses it too and the screen's distance exceeds tol (a
    true distance of a sample the full grid also holds); where it does not, the screened
    trial is the full trial, value for value."""
    spaces = _blade_spaces(blade, *counts)
    full = _blade_fit(blade).trial(*spaces)
    faired, values, e = _blade_fit(blade).screened_trial(*spaces)
    assert np.array_equal(faired.poles, full[0].poles)
    if values is None:
        assert 0.05 < e <= full[2] * (1 + 1e-9)
    else:
        assert np.array_equal(values, full[1]) and e == full[2]


def test_a_screened_failure_leaves_the_search_grid_alone(blade):
    """A candidate the screen refuses is not measured on the search grid: the search
    probe keeps the feet of the last full trial, and the next full trial gives the same
    values as if the refused candidate had never been tried."""
    fit, twin = _blade_fit(blade), _blade_fit(blade)
    passing, failing = _blade_spaces(blade, 20, 20), _blade_spaces(blade, 4, 4)
    fit.trial(*passing), twin.trial(*passing)
    feet = {key: value.copy() for key, value in fit.probe._feet.items()}
    assert fit.screened_trial(*failing)[1] is None
    assert fit.probe._feet.keys() == feet.keys()
    assert all(np.array_equal(fit.probe._feet[key], feet[key]) for key in feet)
    after = _blade_spaces(blade, 12, 12)
    assert np.array_equal(fit.trial(*after)[1], twin.trial(*after)[1])


def test_a_refused_candidate_is_refused_again_without_a_measurement(blade, monkeypatch):
    """Asking the screen for a refused candidate again returns the same refusal and
    measures nothing: no new deviation measurement, no new Newton run."""
    fit = _blade_fit(blade)
    failing = _blade_spaces(blade, 4, 4)
    first = fit.screened_trial(*failing)
    assert first[1] is None
    evaluations = fit.evaluations

    def no_measurement(*args, **kwargs):
        raise AssertionError("a refused candidate was measured again")

    monkeypatch.setattr(fit, "_coarse_excess", no_measurement)
    again = fit.screened_trial(*_blade_spaces(blade, 4, 4))
    assert again[2] == first[2] and again[1] is None and fit.evaluations == evaluations
    fit.pinned = True   # the same spaces with other borders are another candidate
    with pytest.raises(AssertionError, match="measured again"):
        fit.screened_trial(*failing)


def test_fair_objective_leaves_pinned_borders_only_for_half_the_energy(blade, monkeypatch):
    """At 0.02 the bump fixture's compact net has pinned borders.  The fair objective
    keeps them (``FAIR_SWITCH = 0``), takes the free-border net's fairest growth
    (``FAIR_SWITCH = inf``), or by default the free one only if its curvature-variation
    energy (independent quadrature) is below half the pinned one's; every answer within
    tol."""
    import cq_fairing.core.adaptive_surface as adaptive

    lengths = net_lengths(blade.poles)

    def fair(switch):
        monkeypatch.setattr(adaptive, "FAIR_SWITCH", switch)
        result = fair_surface_adaptive(blade, 0.02, objective="fair")
        assert deviation(blade, result.surface).max <= 0.02
        return (dict(result.table)["borders"],
                _variation_energy_by_quadrature(result.surface, lengths), result.poles)

    kept, switched, default = fair(0.0), fair(np.inf), fair(0.5)
    assert kept[0] == "pinned" and switched[0] == "free"
    expected = switched if switched[1] < 0.5 * kept[1] else kept
    assert default[0] == expected[0] and np.array_equal(default[2], expected[2])


def test_a_curve_refused_by_the_denser_check_grows_until_it_passes():
    """A degree-1 target on a noisy circle: at tol 0.04 and 0.05 the compact net passed
    the search samples but not the denser final check, and the fit was refused (while
    0.03 and 0.06 passed).  It now grows by a span until the check passes: every
    tolerance gets a fit, within tol by an independent dense measure, and the pole
    count never grows as tol does."""
    t = np.linspace(0, 2 * np.pi, 60)
    rng = np.random.default_rng(0)
    poles = np.c_[np.cos(t), np.sin(t), 0.01 * rng.standard_normal(60)]
    source = cf.make_curve(poles)
    counts = []
    for tol in (0.03, 0.04, 0.05, 0.06):
        result = cf.fair_curve(poles, tol=tol, target_degree=1, method="adaptive")
        x = np.linspace(0.0, 1.0, 40_001)   # dense points: never below the true distance
        a, b = source.evaluate(x), result.curve.evaluate(x)
        two_sided = max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max())
        assert two_sided <= tol
        counts.append(result.curve.n_poles)
    assert counts == sorted(counts, reverse=True)
    assert counts[2] < cf.fair_curve(poles, tol=0.05, target_degree=1,
                                     method="wavelet").curve.n_poles


def test_a_higher_target_degree_may_use_more_spans_than_the_source():
    """A random bicubic net on 4 x 4 spans faired at degree 5 within 0.003: simple
    quintic knots on its breakpoints are smoother than its C2 joins and deviate by more,
    so the top doubles its spans (before: refused); within tol by the independent
    measure."""
    u = np.linspace(0.0, 1.0, 7)
    grid = np.stack(np.meshgrid(u, u, indexing="ij"), axis=-1)
    height = 0.3 * np.random.default_rng(7).normal(size=(7, 7))
    cubic = cf.make_surface(np.dstack([10 * grid, height[..., None]]))
    result = fair_surface_adaptive(cubic, 0.003, target_degree=5)
    faired = result.surface
    assert (faired.u_degree, faired.v_degree) == (5, 5)
    assert max(faired.u_space.n_spans, faired.v_space.n_spans) > 4
    assert _independent_two_sided(cubic, faired) <= 0.003


def test_a_lower_target_degree_may_use_more_spans_than_the_source():
    """A quintic Bezier patch (one span each way) faired at the default cubic degree:
    one cubic span cannot hold it within 0.01, so the family's top doubles its spans
    where the degree was lowered (before: refused, 'simple knots on the source's
    breakpoints'); the answer is within tol by the independent measure."""
    u = np.linspace(0.0, 1.0, 6)
    grid = np.stack(np.meshgrid(u, u, indexing="ij"), axis=-1)
    height = np.sin(5 * grid[..., 0]) * np.cos(4 * grid[..., 1])
    quintic = cf.make_surface(np.dstack([10 * grid, height[..., None]]), degree=(5, 5))
    result = fair_surface_adaptive(quintic, 0.01)
    faired = result.surface
    assert (faired.u_degree, faired.v_degree) == (3, 3)
    assert faired.u_space.n_spans + faired.v_space.n_spans > 2
    assert result.max_deviation <= 0.01
    assert _independent_two_sided(quintic, faired) <= 0.01
    with pytest.raises(ToleranceNotMetError, match=r"the finest, simple knots on 4 x 4 spans"):
        fair_surface_adaptive(quintic, 1e-6)
