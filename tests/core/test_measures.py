"""Deviation and fairness measures against brute force and closed forms."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.interpolate import BSpline
from scipy.spatial import cKDTree

import cq_fairing as cf
from cq_fairing.core import examples, probes
from cq_fairing.core import measures as M
from cq_fairing.core.adaptive_knots import _source_density, equidistributed_space
from cq_fairing.core.closest_points import (
    HALVINGS,
    _damped,
    _distance,
    distance_floor,
    nearer_starts,
)
from cq_fairing.core.plans import target_space
from cq_fairing.core.probes import _FlatBound, _RowBound, box_region
from cq_fairing.core.projection import project_curve, project_surface
from tests.reliability.independent import curve_points, distance_to_curve

from .naive import random_clamped_knots, trapezoid

S2 = np.sqrt(0.5)


def rational_circle(radius=2.0):
    """Exact NURBS circle (9 poles, degree 2)."""
    square = np.array([[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1], [1, 0]],
                      float)
    weights = np.array([1, S2, 1, S2, 1, S2, 1, S2, 1])
    knots = [0, 0, 0, .25, .25, .5, .5, .75, .75, 1, 1, 1]
    return cf.make_curve(radius * square, knots, 2, weights), square, weights, knots


def rational_sphere(radius=3.0):
    _, square, wc, kc = rational_circle(1.0)
    meridian = np.array([[0, -1], [1, -1], [1, 0], [1, 1], [0, 1]], float)
    wm = np.array([1, S2, 1, S2, 1])
    poles = np.zeros((5, 9, 3))
    poles[..., 0] = meridian[:, None, 0] * square[None, :, 0]
    poles[..., 1] = meridian[:, None, 0] * square[None, :, 1]
    poles[..., 2] = meridian[:, None, 1]
    return cf.make_surface(radius * poles, [0, 0, 0, .5, .5, 1, 1, 1], kc, 2, np.outer(wm, wc))


def rational_cylinder(radius=1.5, height=4.0):
    _, square, wc, kc = rational_circle(1.0)
    poles = np.zeros((2, 9, 3))
    poles[..., :2] = radius * square[None]
    poles[1, :, 2] = height
    return cf.make_surface(poles, [0, 0, 1, 1], kc, (1, 2), np.outer([1, 1], wc))


def noisy_curve(k, amplitude, seed):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 2 * np.pi, k)
    return cf.make_curve(np.c_[np.cos(t), np.sin(t), 0.3 * np.sin(2 * t)] + rng.normal(0, amplitude, (k, 3)))


def brute_hausdorff_curve(a, b, u, dense=200_001):
    """Two-sided max distance from the samples u to dense points of the other curve, and
    how far above the curve's own distance that can lie: a foot point between two dense
    points ``h`` apart is at most ``h / 2`` from one of them, so the point distance
    ``sqrt(d^2 + (h/2)^2)`` exceeds ``d`` by less than ``(h/2)^2 / d``."""
    x = np.linspace(0, 1, dense)
    dense_a, dense_b = a.evaluate(x), b.evaluate(x)
    da = cKDTree(dense_b).query(a.evaluate(u))[0]
    db = cKDTree(dense_a).query(b.evaluate(u))[0]
    value = max(da.max(), db.max())
    gap = max(np.linalg.norm(np.diff(d, axis=0), axis=1).max() for d in (dense_a, dense_b))
    return value, (gap / 2) ** 2 / value


@settings(max_examples=12)
@given(k=st.integers(12, 60), ratio=st.floats(0.1, 0.8), amp=st.floats(1e-3, 5e-2),
       seed=st.integers(0, 1000))
def test_curve_max_deviation_matches_brute_force(k, ratio, amp, seed):
    curve = noisy_curve(k, amp, seed)
    n = max(1, int(ratio * (k - 3)))
    faired = project_curve(curve, target_space(curve.space, n)).curve
    probe = M.CurveProbe(curve)
    value, i = probe.max_deviation(faired)
    brute, slack = brute_hausdorff_curve(curve, faired, probe.u)
    # ours: distance to an actual foot point (>= exact); brute: to 2e5 points per curve
    assert value <= brute + 1e-9
    assert value >= brute - slack - 1e-9
    same = np.linalg.norm(curve.evaluate(probe.u) - faired.evaluate(probe.u), axis=1).max()
    assert M.CurveProbe(curve, method="parametric").max_deviation(faired)[0] == pytest.approx(same)
    assert value <= same + 1e-12
    # the tolerance mode decides the same way
    for tol in (0.5 * value, 2 * value):
        decided, _ = probe.max_deviation(faired, tol)
        assert (decided <= tol) == (value <= tol)


def test_sample_parameters_cover_every_span_and_ends():
    space = cf.SplineSpace.from_knots([0, 0, 0, 0, .1, .5, .55, 1, 1, 1, 1], 3)
    u = M.sample_parameters(space, per_span=8)
    assert u[0] == 0 and u[-1] == 1 and u.size == 4 * 8 + 1
    assert set(space.breakpoints) <= set(u)
    with pytest.raises(cf.InvalidInputError):
        M.sample_parameters(space, per_span=0)


def test_surface_deviation_matches_brute_force():
    rng = np.random.default_rng(3)
    u, v = np.meshgrid(np.linspace(0, 1, 14), np.linspace(0, 1, 11), indexing="ij")
    pts = np.stack([u * 4, v * 3, 0.4 * np.sin(3 * u) * np.cos(2 * v)], axis=2)
    source = cf.make_surface(pts + rng.normal(0, 0.01, pts.shape))
    fair = project_surface(source, target_space(source.u_space, 4), target_space(source.v_space, 3))
    probe = M.SurfaceProbe(source)
    value, _ = probe.max_deviation(fair.surface)
    x = np.linspace(0, 1, 700)
    dense_f = fair.surface.evaluate_grid(x, x).reshape(-1, 3)
    dense_s = source.evaluate_grid(x, x).reshape(-1, 3)
    s_pts = probe.points.reshape(-1, 3)
    f_pts = fair.surface.evaluate_grid(probe.u, probe.v).reshape(-1, 3)
    brute = max(cKDTree(dense_f).query(s_pts)[0].max(), cKDTree(dense_s).query(f_pts)[0].max())
    assert brute - 2e-4 <= value <= brute + 1e-9
    dev = M.deviation(fair)
    assert dev.max == pytest.approx(value, rel=1e-9)
    assert 0 < dev.mean <= dev.rms <= dev.max
    dmap = M.deviation_map(fair)
    assert dmap.values.shape == dmap.signed.shape == (dmap.parameters[0].size, dmap.parameters[1].size)
    assert np.allclose(np.abs(dmap.signed), dmap.values)


@given(seed=st.integers(0, 2**31 - 1), block=st.sampled_from([1, 37, 10_000]))
@settings(max_examples=15, deadline=None)
def test_a_probe_without_its_grid_measures_what_one_holding_it_does(seed, block):
    """``hold_grid=False`` walks the grid in blocks of rows (one row, a few, all at once)
    and evaluates points only where needed: the same two-sided maximum, with and
    without a tolerance, at the same sample."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 9), indexing="ij")
    pts = np.stack([u * 4, v * 3, 0.4 * np.sin(3 * u) * np.cos(2 * v)], axis=2)
    source = cf.make_surface(pts + rng.normal(0, 0.01, pts.shape))
    fair = project_surface(source, target_space(source.u_space, 3), target_space(source.v_space, 2))
    held, lazy = M.SurfaceProbe(source), M.SurfaceProbe(source, hold_grid=False)
    _, bound = held.bound(fair.surface)
    value, at = held.max_deviation(fair.surface)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(probes, "BLOCK_SAMPLES", block)
        assert np.allclose(lazy.bound(fair.surface)[1], bound, rtol=1e-12, atol=1e-15)
        assert lazy.max_deviation(fair.surface) == (pytest.approx(value, rel=1e-10), at)
        assert lazy.max_deviation(fair.surface, 0.9 * value)[0] > 0.9 * value
        assert lazy.max_deviation(fair.surface, 1.1 * value)[0] <= 1.1 * value
        parametric = M.SurfaceProbe(source, method="parametric", hold_grid=False)
        same_k = int(np.argmax(bound))
        assert parametric.max_deviation(fair.surface) == (pytest.approx(bound.max(), rel=1e-12),
                                                          same_k)


@given(seed=st.integers(0, 2**31 - 1), kept=st.sampled_from([1, 3, 128]))
@settings(max_examples=10, deadline=None)
def test_a_probe_keeping_collocations_evaluates_as_the_surface_does(seed, kept):
    """The probe's grid of each candidate (collocation matrices kept per target space,
    the store cleared when full) is ``evaluate_grid``'s bit for bit, for candidates
    asked in any order and again."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, 14), np.linspace(0, 1, 11), indexing="ij")
    pts = np.stack([u * 4, v * 3, 0.4 * np.sin(3 * u) * np.cos(2 * v)], axis=2)
    source = cf.make_surface(pts + rng.normal(0, 0.01, pts.shape))
    candidates = [project_surface(source, target_space(source.u_space, a),
                                  target_space(source.v_space, b)).surface
                  for a, b in rng.integers(2, 5, size=(6, 2))]
    probe = M.SurfaceProbe(source)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(probes, "COLLOCATIONS", kept)
        for c in candidates + candidates[::-1]:
            other, bound = probe.bound(c)
            expected = c.evaluate_grid(probe.u, probe.v)
            assert np.array_equal(other, expected)
            assert np.array_equal(bound, _distance(expected, probe.points))
            assert len(probe._collocations) <= kept


class _ArrayBlocks:
    """An array served a block of ``step`` rows at a time, as ``_BoundBlocks`` serves a
    bound."""

    def __init__(self, values, step):
        self.values, self.step = values, step
        self.n_u = values.shape[0]
        self.n_blocks = -(-self.n_u // step)
        self.asked = 0

    def rows_of(self, b):
        return slice(b * self.step, min((b + 1) * self.step, self.n_u))

    def block(self, b):
        self.asked += 1
        return self.values[self.rows_of(b)]


@given(seed=st.integers(0, 2**31 - 1), size=st.integers(1, 3000), first=st.integers(1, 300),
       levels=st.integers(1, 50))
@settings(max_examples=80, deadline=None)
def test_a_walk_by_bound_finds_the_maximum_and_hands_out_each_sample_once(seed, size, first,
                                                                          levels):
    """Values below their bounds (few levels, so ties are common): walking down the
    bounds until the next one is at most the largest value taken gives the maximum of
    all values; the batches come in decreasing order of bound, double in size, and the
    samples taken and the rest split the samples."""
    rng = np.random.default_rng(seed)
    bound = rng.integers(0, levels + 1, size=size) / levels
    values = bound * rng.uniform(0.5, 1.0, size=size)
    walk = probes.BoundWalk(bound, first)
    best, sizes, last = -np.inf, [], np.inf
    while walk.next_bound > best:
        batch = walk.take()
        assert bound[batch[0]] <= last and np.all(np.diff(bound[batch]) <= 0)
        best, last = max(best, float(values[batch].max())), float(bound[batch[-1]])
        sizes.append(batch.size)
    assert best == values.max()
    assert all(b == first * 2 ** k for k, b in enumerate(sizes[:-1]))
    taken, rest = walk.taken(), walk.rest()
    assert np.array_equal(np.sort(np.r_[taken, rest]), np.arange(size))
    assert rest.size == 0 or bound[rest].max() <= best


@given(seed=st.integers(0, 2**31 - 1), size=st.integers(1, 3000), first=st.integers(1, 300),
       levels=st.integers(1, 50), share=st.floats(0.0, 1.0))
@settings(max_examples=80, deadline=None)
def test_a_walk_cut_at_a_floor_hands_out_exactly_the_samples_above_it(seed, size, first,
                                                                       levels, share):
    """Batches cut at a floor (``take(floor)``) hand out, over the whole walk, exactly
    the samples whose bound is above the floor, in decreasing order of bound, and the
    walk's next bound is then at most the floor."""
    rng = np.random.default_rng(seed)
    bound = rng.integers(0, levels + 1, size=size) / levels
    floor = share * bound.max()
    walk = probes.BoundWalk(bound, first)
    taken = []
    while walk.next_bound > floor:
        batch = walk.take(floor)
        assert np.all(bound[batch] > floor) and np.all(np.diff(bound[batch]) <= 0)
        taken.append(batch)
    taken = np.concatenate(taken) if taken else np.zeros(0, int)
    assert np.array_equal(np.sort(taken), np.flatnonzero(bound > floor))
    assert np.array_equal(walk.taken(), taken) and walk.next_bound <= floor


@given(seed=st.integers(0, 2**31 - 1), shape=st.tuples(st.integers(1, 40), st.integers(1, 30)),
       step=st.integers(1, 50), levels=st.integers(2, 1000))
@settings(max_examples=60, deadline=None)
def test_a_bound_kept_by_rows_answers_as_the_whole_array(seed, shape, step, levels):
    """``_RowBound`` keeps row maxima (and the samples above ``tol``) and recomputes
    blocks on demand: its largest value and its samples above any threshold are those of
    the whole array (values drawn from few levels, so ties are common), and its ``k``
    leaders are the largest of the ``k`` rows of largest maximum, found without a block."""
    rng = np.random.default_rng(seed)
    values = rng.integers(0, levels, size=shape) / levels
    tol = float(rng.choice(values.ravel()))
    flat = _FlatBound(values.ravel())
    for kept in (None, tol):
        blocks = _ArrayBlocks(values, step)
        by_rows = _RowBound(blocks, shape[1], kept)
        assert blocks.asked == blocks.n_blocks
        assert by_rows.argmax() == flat.argmax()
        for threshold in (tol, 0.5 * tol, tol + 0.25, -1.0):
            idx, got = by_rows.above(threshold)
            want_idx, want = flat.above(threshold)
            assert np.array_equal(idx, want_idx) and np.array_equal(got, want)
        k = min(8, shape[0])
        asked = blocks.asked
        leaders = by_rows.leaders(k)
        assert blocks.asked == asked
        assert np.array_equal(np.sort(values.ravel()[leaders]), np.sort(values.max(axis=1))[-k:])
        assert values.max() in values.ravel()[leaders]
        assert np.all(values.ravel()[leaders] == values.max(axis=1)[leaders // shape[1]])


@pytest.mark.parametrize("rational", [False, True])
def test_grid_blocks_are_the_rows_of_the_grid(rational):
    """Blocks of any size hold the grid's rows (to rounding: ``evaluate_grid`` contracts u
    first), and a block asked again comes out the same bit for bit."""
    rng = np.random.default_rng(7)
    knots = [np.r_[[0.0] * 4, np.sort(rng.random(5)), [1.0] * 4],
             np.r_[[0.0] * 3, np.sort(rng.random(60)), [1.0] * 3]]
    poles = rng.normal(size=(9, 63, 3))
    weights = rng.uniform(0.5, 2.0, size=(9, 63)) if rational else None
    surface = cf.BSplineSurface(poles, knots[0], knots[1], 3, 2, weights=weights)
    u, v = np.sort(rng.random(41)), np.sort(rng.random(29))
    grid = surface.evaluate_grid(u, v)
    for step in (1, 5, 41, 100):
        blocks = surface.grid_blocks(u, v, step)
        assert blocks.n_blocks == -(-41 // step)
        whole = np.concatenate([blocks.block(b) for b in range(blocks.n_blocks)])
        assert np.allclose(whole, grid, rtol=1e-12, atol=1e-12)
        last = blocks.n_blocks - 1
        assert np.array_equal(blocks.block(last), whole[blocks.rows_of(last)])


@pytest.mark.parametrize("rational", [False, True])
def test_grid_blocks_built_in_slices_are_the_same_bit_for_bit(rational, monkeypatch):
    """``W_a(v_j)`` built a slice of v at a time (a few samples per slice here, as on a
    3329-sample terrain grid) gives the blocks of one whole product exactly."""
    from cq_fairing.core import geometry

    rng = np.random.default_rng(11)
    knots = [np.r_[[0.0] * 3, np.sort(rng.random(20)), [1.0] * 3],
             np.r_[[0.0] * 4, np.sort(rng.random(30)), [1.0] * 4]]
    weights = rng.uniform(0.5, 2.0, size=(23, 34)) if rational else None
    surface = cf.BSplineSurface(rng.normal(size=(23, 34, 3)), knots[0], knots[1], 2, 3,
                                weights=weights)
    u, v = np.sort(rng.random(37)), np.sort(rng.random(301))
    whole = surface.grid_blocks(u, v, 8)
    monkeypatch.setattr(geometry, "ALONG_V_SLICE", 23 * 4 * 7)   # 7 samples per slice
    sliced = surface.grid_blocks(u, v, 8)
    for b in range(whole.n_blocks):
        assert np.array_equal(sliced.block(b), whole.block(b))


def _reparametrised(surface, phi, degree):
    """Poles of ``S(phi(u), v)`` for a Bezier patch ``S`` and a polynomial ``phi`` of
    degree ``degree / surface.u_degree``: Bernstein collocation, exact for polynomials."""
    x = np.linspace(0.0, 1.0, degree + 1)
    k = np.arange(degree + 1)
    binom = np.array([math.comb(degree, i) for i in k])
    bernstein = binom * x[:, None] ** k * (1 - x[:, None]) ** (degree - k)
    rows = np.stack([BSpline(surface.u_space.knots, surface.poles[:, j], surface.u_degree)(phi(x))
                     for j in range(surface.poles.shape[1])], axis=1)
    poles = np.linalg.solve(bernstein, rows.reshape(degree + 1, -1)).reshape(rows.shape)
    return cf.make_surface(poles, [0.0] * (degree + 1) + [1.0] * (degree + 1),
                           surface.v_space.knots, (degree, surface.v_degree))


def test_surface_probe_follows_a_sliding_candidate_by_its_last_feet():
    """The candidate is the source itself with u -> phi(u) = u + 0.3 u (1 - u): the
    same-parameter distance is large, the true one zero.  The feet the probe keeps on the
    candidate are phi^-1 of the sample parameters (closed form), and a denser probe that
    adopts them measures zero too."""
    j, i = np.meshgrid(np.arange(4.0), np.arange(4.0))
    source = cf.make_surface(np.stack([3 * i, 2 * j, np.sin(i) * np.cos(j)], axis=2))
    candidate = _reparametrised(source, lambda u: u + 0.3 * u * (1 - u), 6)
    probe = M.SurfaceProbe(source, per_span=20, keep_feet=True)
    other, bound = probe.bound(candidate)
    assert bound.max() > 0.3
    everywhere = np.arange(bound.size)
    assert probe.true_distance(candidate, other, everywhere).max() < 1e-9
    inverse = (1.3 - np.sqrt(1.69 - 1.2 * probe.u)) / 0.6
    i, j = np.unravel_index(everywhere, bound.shape)
    feet_u, feet_v = probe._last_feet("faired", i, j)
    assert np.allclose(feet_u, inverse[i], atol=1e-8)
    assert np.allclose(feet_v, probe.v[j], atol=1e-8)
    assert probe.true_distance(candidate, other, everywhere, tol=1e-6).max() < 1e-6
    dense = M.SurfaceProbe(source, per_span=50)
    dense.adopt_feet(probe)
    i, j = np.unravel_index(np.arange(dense.points.shape[0] * dense.points.shape[1]),
                            dense.points.shape[:2])
    feet_u, _ = dense._last_feet("faired", i, j)
    assert np.allclose(feet_u, (1.3 - np.sqrt(1.69 - 1.2 * dense.u[i])) / 0.6, atol=1e-3)
    assert dense.max_deviation(candidate)[0] < 1e-9


def test_signed_deviation_of_offset_plane():
    u, v = np.meshgrid(np.linspace(0, 1, 6), np.linspace(0, 1, 5), indexing="ij")
    plane = np.stack([u, v, 0 * u], axis=2)
    a = cf.make_surface(plane)
    b = cf.make_surface(plane + [0, 0, 0.1])
    c = cf.make_surface(plane - [0, 0, 0.1])
    for other, sign in ((b, 1), (c, -1)):
        dmap = M.deviation_map(a, other)
        assert np.allclose(dmap.values, 0.1) and np.allclose(dmap.signed, sign * 0.1)
        assert M.deviation(a, other).max == pytest.approx(0.1)
    with pytest.raises(cf.InvalidInputError):
        M.deviation(a, rational_circle()[0])


def test_circle_curvature_and_energy_closed_forms():
    circle = rational_circle(2.0)[0]
    u = np.linspace(0, 1, 101)
    kappa, tau = M.curve_curvature(circle, u)
    assert np.allclose(kappa, 0.5, rtol=1e-10) and np.allclose(tau, 0, atol=1e-10)
    assert M.curvature_derivative_energy(circle) == pytest.approx(0, abs=1e-16)
    assert M.curve_wiggles(circle)["inflections"] == 0


def test_helix_curvature_and_torsion():
    r, c = 2.0, 0.5
    t = np.linspace(0, 4 * np.pi, 801)
    helix = cf.interpolate_points(np.c_[r * np.cos(t), r * np.sin(t), c * t])
    u = np.linspace(0.2, 0.8, 200)
    kappa, tau = M.curve_curvature(helix, u)
    assert np.allclose(kappa, r / (r * r + c * c), rtol=1e-4)
    assert np.allclose(tau, c / (r * r + c * c), rtol=1e-3)


def test_sphere_and_cylinder_curvatures():
    sphere = rational_sphere(3.0)
    u, v = np.meshgrid(np.linspace(0.1, 0.9, 9), np.linspace(0, 1, 13), indexing="ij")
    k = M.surface_curvatures(sphere, u.ravel(), v.ravel())
    assert np.allclose(np.abs(k["k1"]), 1 / 3, rtol=1e-9) and np.allclose(np.abs(k["k2"]), 1 / 3, rtol=1e-9)
    assert np.allclose(k["gaussian"], 1 / 9, rtol=1e-9) and np.allclose(np.abs(k["mean"]), 1 / 3, rtol=1e-9)
    cyl = rational_cylinder(1.5)
    k = M.surface_curvatures(cyl, u.ravel(), v.ravel())
    assert np.allclose(k["gaussian"], 0, atol=1e-10)
    assert np.allclose(np.abs(k["mean"]), 1 / 3, rtol=1e-9)
    assert np.allclose(np.sort(np.abs([k["k1"], k["k2"]]), axis=0), [[0] * u.size, [1 / 1.5] * u.size],
                       atol=1e-9)


def _naive_curve_energy(curve):
    spline = BSpline(curve.knots, curve.poles, curve.degree).derivative(2)
    x, w = np.polynomial.legendre.leggauss(10)
    b = curve.space.breakpoints
    total = 0.0
    for a, c in zip(b[:-1], b[1:]):
        t = 0.5 * (a + c) + 0.5 * (c - a) * x
        total += np.sum(0.5 * (c - a) * w * np.sum(spline(t) ** 2, axis=1))
    return total


def test_bending_energy_is_exact():
    curve = noisy_curve(25, 0.02, 1)
    assert M.bending_energy(curve) == pytest.approx(_naive_curve_energy(curve), rel=1e-10)
    circle = rational_circle(1.0)[0]
    # rational: quadrature; arc-length parametrised approx, compare with dense sum
    x = np.linspace(0, 1, 200001)
    d2 = M.curve_derivatives(circle, x, 2)[2]
    assert M.bending_energy(circle) == pytest.approx(trapezoid(np.sum(d2 ** 2, axis=1), x)
                                                     if hasattr(np, "trapz") else
                                                     np.trapezoid(np.sum(d2 ** 2, axis=1), x), rel=1e-6)
    rng = np.random.default_rng(0)
    surface = cf.make_surface(rng.normal(size=(7, 6, 3)))
    x, w = np.polynomial.legendre.leggauss(6)
    total = 0.0
    bu, bv = surface.u_space.breakpoints, surface.v_space.breakpoints
    for a, c in zip(bu[:-1], bu[1:]):
        for e, f in zip(bv[:-1], bv[1:]):
            uu, vv = 0.5 * (a + c) + 0.5 * (c - a) * x, 0.5 * (e + f) + 0.5 * (f - e) * x
            ww = np.outer(0.5 * (c - a) * w, 0.5 * (f - e) * w)
            dens = sum(coef * np.sum(surface.evaluate_grid(uu, vv, a_, b_) ** 2, axis=2)
                       for a_, b_, coef in ((2, 0, 1), (1, 1, 2), (0, 2, 1)))
            total += np.sum(ww * dens)
    assert M.bending_energy(surface) == pytest.approx(total, rel=1e-10)


def test_wiggle_counts_on_a_sine():
    from scipy.interpolate import make_interp_spline

    x = np.linspace(0.5, 4 * np.pi - 0.5, 400)
    ends = ([(2, [0.0, -np.sin(x[0])])], [(2, [0.0, -np.sin(x[-1])])])
    spline = make_interp_spline(x, np.c_[x, np.sin(x)], k=3, bc_type=ends)
    curve = cf.make_curve(spline.c, spline.t, 3)
    w = M.curve_wiggles(curve)
    assert w["inflections"] == 3
    assert w["curvature_extrema"] == 7
    assert M.count_sign_changes([1, -1, 1e-20, -1, 2], threshold=1e-12) == 2
    assert M.count_extrema([0, 1, 0, 1, 2]) == 2


def test_fairness_summary_before_after():
    noisy = noisy_curve(60, 0.01, 2)
    result = cf.fair_curve(noisy.poles, 12)
    summary = M.fairness_summary(result)
    assert summary["bending_energy"]["after"] < summary["bending_energy"]["before"]
    assert summary["curvature_extrema"]["after"] < summary["curvature_extrema"]["before"]
    assert set(summary["inflections"]) == {"before", "after"}


@given(seed=st.integers(0, 2**31 - 1), tol=st.sampled_from([0.005, 0.02, 0.08]))
@settings(max_examples=15, deadline=None)
def test_a_verdict_measures_the_way_back_only_where_the_way_there_is_within_tol(seed, tol):
    """``verdict=True`` gives the two-sided value wherever the source's distance to the
    candidate is within tol, and a value above tol (that one-sided distance) elsewhere:
    the same samples exceed tol as with the full two-sided measure.  Without the second
    Newton start (``window=0``) a value can only be larger."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 9), indexing="ij")
    pts = np.stack([u * 4, v * 3, 0.4 * np.sin(3 * u) * np.cos(2 * v)], axis=2)
    source = cf.make_surface(pts + rng.normal(0, 0.01, pts.shape))
    fair = project_surface(source, target_space(source.u_space, 3), target_space(source.v_space, 2))
    full, quick = M.SurfaceProbe(source), M.SurfaceProbe(source)
    other, bound = full.bound(fair.surface)
    idx = np.flatnonzero(bound.ravel() > tol)
    both = full.true_distance(fair.surface, other, idx, tol=tol)
    either = quick.true_distance(fair.surface, quick.bound(fair.surface)[0], idx, tol=tol,
                                 verdict=True)
    assert np.array_equal(both > tol, either > tol)
    within = either <= tol
    # to rounding: a point's last bit may differ when it is measured in another batch
    assert np.allclose(either[within], both[within], rtol=1e-12, atol=0.0)
    assert np.all(either[~within] <= both[~within] * (1 + 1e-12))
    first_start = M.SurfaceProbe(source)   # window 0: no second Newton start
    once = first_start.true_distance(fair.surface, first_start.bound(fair.surface)[0], idx,
                                     window=0, tol=tol, verdict=True)
    assert np.all(once >= either * (1 - 1e-12))
    assert np.allclose(once[once <= tol], either[once <= tol], rtol=1e-12, atol=0.0)


@settings(max_examples=60, deadline=None)
@given(shear=st.floats(-0.95, 0.95), stretch=st.floats(0.3, 3.0),
       point=st.tuples(st.floats(-1.0, 2.0), st.floats(-1.0, 2.0), st.floats(-1.0, 1.0)),
       corner=st.tuples(st.integers(0, 1), st.integers(0, 1)))
def test_foot_points_slide_along_a_border_from_a_corner(shear, stretch, point, corner):
    """On a sheared planar patch S(u, v) = (u + shear v, stretch v, 0) the squared
    distance is a convex quadratic, so its minimum over the unit box is the one foot
    point: closest-point iterations started at any corner must reach it, also where the
    2-D Newton step points out of both borders at that corner and the minimum lies
    along one of them (the distance is then that of the exact constrained minimum,
    found here by brute force on a fine grid)."""
    x = np.linspace(0.0, 1.0, 4)
    poles = np.array([[(a + shear * b, stretch * b, 0.0) for b in x] for a in x])
    surface = cf.make_surface(poles, degree=1)
    p = np.array([point])
    _, _, dist = M.closest_points_surface(surface, p, [float(corner[0])], [float(corner[1])])
    fine = np.linspace(0.0, 1.0, 801)
    grid = surface.evaluate_grid(fine, fine)
    brute = np.linalg.norm(grid - p[0], axis=2).min()
    assert dist[0] <= brute + 1e-9
    assert dist[0] >= brute - 5e-3  # the grid's own spacing bounds how far below it can be


def test_newton_recovers_from_steps_far_past_a_short_domain():
    """A strip 30 mm long on a u domain 6e-4 long (|S_u| about 5e4, |S_v| about 2), points
    near it started from parameters up to a third of the domain away: a Newton step there
    can overshoot by more than 2^5, and with five halvings one of these 300 foot points
    stopped 5.07 away where the nearest point is 0.032 away (such a measure refused
    correct fits of impeller fillets).  Every one now ends at the nearest point."""
    x = np.linspace(0.0, 30.0, 12)
    row = np.stack([x, 3.0 * np.sin(x / 6.0), 0.2 * x], axis=1)
    poles = np.stack([row, row + [0.0, 0.5, 1.0], row + [0.0, 1.0, 2.0]], axis=1)
    graded = np.geomspace(1.0, 1.0 / 64.0, 9)
    span = 6e-4
    u_knots = np.r_[[0.0] * 4, np.cumsum(graded[:-1]) / graded.sum() * span, [span] * 4]
    strip = cf.make_surface(poles, u_knots=u_knots, degree=(3, 2))
    rng = np.random.default_rng(0)
    u0, v0 = rng.uniform(0.0, span, 300), rng.uniform(0.0, 1.0, 300)
    near_u = np.clip(u0 + rng.normal(scale=span / 4, size=300), 0.0, span)
    points = M.surface_derivatives(strip, near_u, v0, 0)[(0, 0)] + \
        rng.normal(scale=0.05, size=(300, 3))
    dense = strip.evaluate_grid(np.linspace(0.0, span, 4000), np.linspace(0.0, 1.0, 200))
    nearest_sample = cKDTree(dense.reshape(-1, 3)).query(points)[0]
    _, _, found = M.closest_points_surface(strip, points, u0, v0)
    assert np.all(found <= nearest_sample + 1e-9)


def _halved_one_at_a_time(trial, active, step, dist):
    """Naive damping: halve the steps of the points whose distance grew, one halving
    after another, re-trying those points only (the rule :func:`_damped` batches)."""
    new, d_new = trial(active, step)
    for _ in range(HALVINGS):
        worse = d_new > dist[active]
        if not worse.any():
            break
        step = np.where(worse.reshape((-1,) + (1,) * (step.ndim - 1)), 0.5 * step, step)
        sel = np.flatnonzero(worse)
        new[sel], d_new[sel] = trial(active[sel], step[sel])
    return new, d_new


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), count=st.sampled_from([1, 3, 40, 700]),
       batched=st.sampled_from([1, 12, 512]), surface=st.booleans())
def test_batched_halvings_take_the_steps_of_one_halving_at_a_time(seed, count, batched,
                                                                  surface):
    """Trials of a wavy distance (steps of random sizes, many overshooting by up to
    2^14): each point ends at the same trial, bit for bit, whether its halvings are
    tried together or one after another, and whatever the batch size."""
    rng = np.random.default_rng(seed)
    dims = 2 if surface else 1
    start = rng.uniform(-1.0, 1.0, (count, dims))
    target = rng.uniform(-1.0, 1.0, (count, dims))
    step = (target - start) * 2.0 ** rng.integers(0, 15, (count, 1))
    if not surface:
        start, target, step = start[:, 0], target[:, 0], step[:, 0]

    def trial(idx, st_):
        new = start[idx] + st_
        offset = (new - target[idx]).reshape(len(idx), -1)
        return new, np.sqrt((offset ** 2).sum(axis=1)) + 0.1 * np.sin(40.0 * offset).sum(axis=1) ** 2

    active = np.arange(count)
    dist = trial(active, np.zeros_like(step))[1]
    naive = _halved_one_at_a_time(trial, active, step.copy(), dist)
    fast = _damped(trial, active, step.copy(), dist, batched=batched)
    assert np.array_equal(naive[0], fast[0]) and np.array_equal(naive[1], fast[1])


def test_a_region_excludes_whole_rows_from_the_maximum():
    """Samples outside a probe's region count as 0.  The exact maximum first asks for the
    largest bound of each of the 64 rows of largest maximum: on a grid of fewer rows that
    included rows wholly outside the region (their bound 0, their first sample asked
    for), and a bump there was reported as the maximum (0.5 instead of 0)."""
    u = np.linspace(0.0, 1.0, 5)
    flat = cf.make_surface(np.dstack([*np.meshgrid(u, u, indexing="ij"), np.zeros((5, 5))]))
    bumped_poles = flat.poles.copy()
    bumped_poles[0, 0, 2] = 0.5          # a bump at the corner u = v = 0
    bumped = cf.make_surface(bumped_poles)
    region = box_region((0.5, 1.0, 0.0, 1.0))
    probe = M.SurfaceProbe(flat, per_span=4, region=region, hold_grid=False)
    assert probe.u.size < 64
    value, _ = probe.max_deviation(bumped)
    assert value == pytest.approx(0.0, abs=1e-12)
    whole = M.SurfaceProbe(flat, per_span=4, hold_grid=False).max_deviation(bumped)[0]
    assert whole > 0.2


@settings(max_examples=40, deadline=None)
@given(degree=st.integers(1, 7), spans=st.integers(1, 12), samples=st.integers(2, 60),
       far=st.floats(0.0, 3.0), seed=st.integers(0, 2**31 - 1))
def test_a_distance_floor_lies_below_the_distance_and_within_its_reach(degree, spans,
                                                                       samples, far, seed):
    """``distance_floor`` against the reliability suite's independent distance (scipy
    evaluation, dense samples and golden-section search, an upper bound of the true
    distance): never above it, and below it by at most half the largest step the curve
    can make between two samples (the bound's own slack)."""
    rng = np.random.default_rng(seed)
    knots = random_clamped_knots(rng, degree + spans, degree)
    poles = rng.normal(size=(degree + spans, 3))
    curve = cf.make_curve(poles, knots, degree)
    u = np.unique(np.concatenate([[0.0, 1.0], rng.uniform(0, 1, samples)]))
    points = curve.evaluate(rng.uniform(0, 1, 25)) + far * rng.normal(size=(25, 3))
    floor = distance_floor(curve, u, curve.evaluate(u), points)
    exact = distance_to_curve(points, lambda t: curve_points(poles, knots, degree, None, t),
                              (0.0, 1.0), dense=20_000)
    assert np.all(floor <= exact + 1e-9)
    speed = np.max(degree * np.linalg.norm(np.diff(poles, axis=0), axis=1)
                   / np.maximum(knots[degree + 1:-1] - knots[1:-degree - 1], 1e-300))
    assert np.all(floor >= exact - 0.5 * speed * np.diff(u).max() - 1e-9)


def test_a_curve_probe_refutes_only_candidates_beyond_tol():
    """On the seed curve the family's coarse candidates are refused without a Newton
    iteration, and every candidate refuted is beyond tol by the full two-sided measure;
    the last ones before tol holds are too close to it for the floor and are not."""
    seed = examples.seed_curve()
    density = _source_density(seed.curve.space)
    probe = M.CurveProbe(seed.curve)
    tol = 0.0198
    refuted = {}
    for n in (4, 8, 16, 32, 64, 128):
        faired = project_curve(seed.curve, equidistributed_space(*density, n, 3)).curve
        other, bound = probe.bound(faired)
        refuted[n] = probe.refutes(faired, other, bound, tol)
        if refuted[n]:
            assert probe.max_deviation(faired)[0] > tol
    assert refuted == {4: True, 8: True, 16: True, 32: True, 64: False, 128: False}


@given(seed=st.integers(0, 2**31 - 1), tol=st.sampled_from([0.005, 0.02, 0.08]))
@settings(max_examples=15, deadline=None)
def test_a_curve_verdict_measures_the_way_back_only_where_the_way_there_is_within_tol(seed,
                                                                                       tol):
    """As for surfaces: ``verdict=True`` gives the two-sided value wherever the source's
    distance to the candidate is within tol, and a value above tol elsewhere."""
    curve = noisy_curve(40, 0.02, seed % 1000)
    faired = project_curve(curve, target_space(curve.space, 9)).curve
    probe = M.CurveProbe(curve)
    other, bound = probe.bound(faired)
    idx = np.flatnonzero(bound > tol)
    both = probe.true_distance(faired, other, idx, tol=tol)
    either = probe.true_distance(faired, other, idx, tol=tol, verdict=True)
    assert np.array_equal(both > tol, either > tol)
    within = either <= tol
    assert np.array_equal(either[within], both[within])
    assert np.all(either[~within] <= both[~within])


def test_restart_samples_made_once_give_every_projection_the_feet_made_per_call():
    """``RestartSamples`` kept for a surface and handed to each projection onto it give
    the same feet and distances, bit for bit, as the samples each call makes itself."""
    u, v = np.meshgrid(np.linspace(0, 1, 24), np.linspace(0, 1, 31), indexing="ij")
    z = 8.0 * np.sin(np.pi * u) * np.cos(1.5 * np.pi * v)
    z += 0.05 * np.random.default_rng(5).standard_normal(u.shape)
    surface = cf.make_surface(np.stack([60.0 * u, 90.0 * v, z], axis=-1), degree=(3, 3))
    samples = M.RestartSamples(surface)
    assert samples.tree.n == samples.axes[0].size * samples.axes[1].size
    rng = np.random.default_rng(11)
    for count in (40, 900):
        points = rng.uniform([0, 0, -10], [60, 90, 10], (count, 3))
        u0, v0 = rng.uniform(0, 1, count), rng.uniform(0, 1, count)
        alone = M.closest_points_surface_restarted(surface, points, u0, v0)
        shared = M.closest_points_surface_restarted(surface, points, u0, v0, samples=samples)
        for a, b in zip(alone, shared):
            assert np.array_equal(a, b)


@given(seed=st.integers(0, 2**31 - 1), count=st.integers(1, 400))
@settings(max_examples=30, deadline=None)
def test_nearer_starts_bound_the_projection_from_above(seed, count):
    """Of the sample parameters and the seeds, ``nearer_starts`` keeps per point the one
    whose surface point is nearer (distances evaluated here with ``evaluate_grid`` one
    point at a time), and its distance bounds the restarted projection from that
    start from above, never above the same-parameter distance."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 1, 14), np.linspace(0, 1, 17), indexing="ij")
    z = 6.0 * np.sin(np.pi * u) * np.cos(1.5 * np.pi * v) + 0.1 * rng.standard_normal(u.shape)
    surface = cf.make_surface(np.stack([40.0 * u, 70.0 * v, z], axis=-1), degree=(3, 3))
    uv, seeds = rng.uniform(0, 1, (count, 2)), rng.uniform(0, 1, (count, 2))
    points = rng.uniform([0, 0, -8], [40, 70, 8], (count, 3))
    starts, bound = nearer_starts(surface, points, uv, seeds)

    def distance(at):
        return np.array([np.linalg.norm(surface.evaluate_grid([a], [b])[0, 0] - p)
                         for (a, b), p in zip(at, points)])

    same, seeded = distance(uv), distance(seeds)
    np.testing.assert_allclose(bound, np.minimum(same, seeded), rtol=1e-12, atol=1e-12)
    assert np.all(bound <= same * (1 + 1e-12) + 1e-12)
    nearer = seeded < same
    assert np.array_equal(starts[nearer], seeds[nearer])
    assert np.array_equal(starts[~nearer], uv[~nearer])
    found = M.closest_points_surface_restarted(surface, points, starts[:, 0], starts[:, 1])[2]
    assert np.all(found <= bound * (1 + 1e-12) + 1e-12)
