"""merge_grid / split_grid / oriented / insert_knot: exactness against scipy's B-splines,
bit-equal shared borders, smooth joins after fairing, typed errors."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import BSpline

import cq_fairing as cf
from cq_fairing import InvalidInputError, InvalidToleranceError, UnsupportedGeometryError
from cq_fairing.core.geometry import BSplineSurface, make_surface
from cq_fairing.core.patch_grid import (
    cut_surface,
    insert_knot,
    join_pieces,
    merge_grid,
    oriented,
    split_grid,
)
from tests.core.naive import basis_matrix

seeds = st.integers(0, 2**31 - 1)


# -- independent evaluation (scipy bases) --------------------------------------------------
def evaluate(surface, u, v, du=0, dv=0):
    """Points or partial derivatives on the grid u x v, shape (len(u), len(v), d)."""
    bu = basis_matrix(surface.u_knots, surface.u_degree, np.asarray(u, float), du)
    bv = basis_matrix(surface.v_knots, surface.v_degree, np.asarray(v, float), dv)
    return np.einsum("ia,abd,jb->ijd", bu, surface.poles, bv)


def size(poles):
    flat = poles.reshape(-1, poles.shape[-1])
    return np.linalg.norm(flat.max(axis=0) - flat.min(axis=0))


def inside(rng, domain, count=7):
    lo, hi = domain
    return np.sort(rng.uniform(lo, hi, count))


def to_merged(x, domain, breaks):
    """The affine map of a patch parameter onto its interval of the merged domain."""
    (a, b), (lo, hi) = domain, breaks
    return lo + (np.asarray(x) - a) / (b - a) * (hi - lo)


def random_inner(rng, count):
    return np.sort(rng.choice(np.arange(1, 20), count, replace=False)) / 20.0


def clamped(inner, degree, lo=0.0, hi=1.0):
    return np.concatenate([np.full(degree + 1, lo), lo + (hi - lo) * inner,
                           np.full(degree + 1, hi)])


def random_grid(rng, m, n, p, q):
    """Patches cut from one random net: grid row i shares its u knots (each patch on its
    own random domain), neighbouring patches share the border pole rows."""
    u_inner = [random_inner(rng, rng.integers(0, 4)) for _ in range(m)]
    v_inner = [random_inner(rng, rng.integers(0, 4)) for _ in range(n)]
    ku = [x.size + p + 1 for x in u_inner]
    kv = [x.size + q + 1 for x in v_inner]
    ou, ov = np.r_[0, np.cumsum(np.array(ku) - 1)], np.r_[0, np.cumsum(np.array(kv) - 1)]
    net = rng.normal(size=(ou[-1] + 1, ov[-1] + 1, 3)) * 10 + [100.0, -50.0, 7.0]
    patches = []
    for i in range(m):
        row = []
        for j in range(n):
            a, c = rng.uniform(-5, 5, 2)
            b, d = a + rng.uniform(0.1, 10), c + rng.uniform(0.1, 10)
            poles = net[ou[i]:ou[i] + ku[i], ov[j]:ov[j] + kv[j]].copy()
            row.append(make_surface(poles, clamped(u_inner[i], p, a, b),
                                    clamped(v_inner[j], q, c, d), (p, q)))
        patches.append(row)
    return patches, net


def cut_into_grid(surface, u_cuts, v_cuts):
    """Patches of ``surface`` between the cuts (not at its knots), by scipy's knot
    insertion."""
    p, q = surface.u_degree, surface.v_degree
    bu = BSpline(surface.u_knots, surface.poles, p)
    for x in u_cuts:
        bu = bu.insert_knot(x, p)
    bv = BSpline(surface.v_knots, bu.c.transpose(1, 0, 2), q)
    for x in v_cuts:
        bv = bv.insert_knot(x, q)
    net = bv.c.transpose(1, 0, 2)
    u_parts = scipy_pieces(bu.t, p, u_cuts)
    v_parts = scipy_pieces(bv.t, q, v_cuts)
    return [[make_surface(net[su, sv], tu, tv, (p, q)) for tv, sv in v_parts]
            for tu, su in u_parts]


def scipy_pieces(t, p, cuts):
    bounds = [t[0], *cuts, t[-1]]
    out = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        first = int(np.flatnonzero(t == lo)[0])
        start = 0 if lo == t[0] else first - 1
        inner = t[(t > lo) & (t < hi)]
        out.append((np.r_[[lo] * (p + 1), inner, [hi] * (p + 1)],
                    slice(start, start + inner.size + p + 1)))
    return out


def smooth_surface(rng, k=9, degree=3, bump=0.0):
    """A bicubic graph over [0, 10] x [0, 6]: z = 0.05 (x^2 + y^2) plus random waves."""
    t = clamped(np.sort(rng.uniform(0.05, 0.95, k - degree - 1)), degree)
    g = np.convolve(t[1:-1], np.ones(degree) / degree, mode="valid")
    x, y = np.meshgrid(10 * g, 6 * g, indexing="ij")
    z = 0.05 * (x**2 + y**2) + bump * np.sin(x) * np.cos(y)
    return make_surface(np.stack([x, y, z], axis=-1), t, t, degree)


def normals(surface, u, v):
    n = np.cross(evaluate(surface, u, v, 1, 0), evaluate(surface, u, v, 0, 1))
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


# -- exactness ---------------------------------------------------------------------------
@given(seed=seeds, m=st.integers(1, 3), n=st.integers(1, 3), p=st.integers(2, 4),
       q=st.integers(2, 4), breaks=st.sampled_from(["chord", "uniform"]))
def test_split_of_the_merge_reproduces_every_patch(seed, m, n, p, q, breaks):
    rng = np.random.default_rng(seed)
    patches, net = random_grid(rng, m, n, p, q)
    merged = merge_grid(patches, breaks=breaks)
    pieces = split_grid(merged, merged.surface)
    scale = 1e-12 * size(net)
    assert merged.surface.domain == ((0.0, m), (0.0, n))
    for i in range(m):
        for j in range(n):
            patch, piece = patches[i][j], pieces[i][j]
            (du, dv) = patch.domain
            assert piece.domain == patch.domain
            u, v = inside(rng, du), inside(rng, dv)
            expected = evaluate(patch, u, v)
            assert np.abs(evaluate(piece, u, v) - expected).max() <= scale
            mu = to_merged(u, du, merged.u_breaks[i:i + 2])
            mv = to_merged(v, dv, merged.v_breaks[j:j + 2])
            assert np.abs(evaluate(merged.surface, mu, mv) - expected).max() <= scale


@given(seed=seeds, m=st.integers(1, 3), n=st.integers(1, 3), p=st.integers(1, 4),
       q=st.integers(1, 4), on_breaks=st.booleans())
def test_split_of_any_surface_on_the_merged_domain_is_exact(seed, m, n, p, q, on_breaks):
    rng = np.random.default_rng(seed)
    patches, _ = random_grid(rng, m, n, 3, 2)
    merged = merge_grid(patches)
    knots = []
    for breaks, degree in ((merged.u_breaks, p), (merged.v_breaks, q)):
        inner = rng.uniform(0, breaks[-1], rng.integers(0, 12))
        if on_breaks:   # knots on a break, and (degree >= 2) one a rounding error away
            near = np.nextafter(breaks[1:-1], np.inf) if degree >= 2 else []
            inner = np.r_[inner, breaks[1:-1], near]
        inner = np.sort(inner[(inner > 0) & (inner < breaks[-1])])
        knots.append(np.r_[[0.0] * (degree + 1), inner, [breaks[-1]] * (degree + 1)])
    poles = rng.normal(size=(knots[0].size - p - 1, knots[1].size - q - 1, 3))
    surface = BSplineSurface(poles, knots[0], knots[1], p, q)
    pieces = split_grid(merged, surface)
    for i in range(m):
        for j in range(n):
            piece = pieces[i][j]
            assert (piece.u_degree, piece.v_degree) == (p, q)
            make_surface(piece.poles, piece.u_knots, piece.v_knots, (p, q))  # valid knots
            (du, dv) = merged.domains[i, j]
            u, v = inside(rng, du), inside(rng, dv)
            mu = to_merged(u, du, merged.u_breaks[i:i + 2])
            mv = to_merged(v, dv, merged.v_breaks[j:j + 2])
            gap = np.abs(evaluate(piece, u, v) - evaluate(surface, mu, mv)).max()
            assert gap <= 1e-12 * size(poles)
            if i + 1 < m:
                assert np.array_equal(piece.poles[-1], pieces[i + 1][j].poles[0])
            if j + 1 < n:
                assert np.array_equal(piece.poles[:, -1], pieces[i][j + 1].poles[:, 0])


@given(seed=seeds, p=st.integers(1, 4), q=st.integers(1, 4), cuts=st.tuples(
    st.integers(0, 3), st.integers(0, 3)))
def test_pieces_cut_from_a_surface_join_back_into_it(seed, p, q, cuts):
    """cut_surface against scipy's evaluation of the uncut surface, and join_pieces of
    the pieces (some of them refined first, as a fairing may return them) against it."""
    rng = np.random.default_rng(seed)
    knots = [clamped(random_inner(rng, rng.integers(0, 5)), d, 0.0, w)
             for d, w in ((p, 3.0), (q, 2.0))]
    poles = rng.normal(size=(knots[0].size - p - 1, knots[1].size - q - 1, 3))
    surface = BSplineSurface(poles, knots[0], knots[1], p, q)
    u_cuts = np.sort(rng.uniform(0.1, 2.9, cuts[0]))
    v_cuts = np.sort(rng.uniform(0.1, 1.9, cuts[1]))
    pieces = cut_surface(surface, u_cuts, v_cuts)
    assert (len(pieces), len(pieces[0])) == (cuts[0] + 1, cuts[1] + 1)
    scale = 1e-12 * size(poles)
    for row in pieces:
        for piece in row:
            u, v = inside(rng, piece.domain[0]), inside(rng, piece.domain[1])
            assert np.abs(evaluate(piece, u, v) - evaluate(surface, u, v)).max() <= scale
    refined = [[_refined_inside(piece, rng) for piece in row] for row in pieces]
    joined = join_pieces(refined)
    u, v = inside(rng, (0.0, 3.0), 23), inside(rng, (0.0, 2.0), 19)
    assert np.abs(evaluate(joined, u, v) - evaluate(surface, u, v)).max() <= 1e3 * scale
    for x, degree, t in ((u_cuts, p, joined.u_knots), (v_cuts, q, joined.v_knots)):
        assert all(np.count_nonzero(t == c) == degree for c in x)


def _refined_inside(piece, rng):
    """``piece`` with a knot inserted in u, half of the time: the same surface on finer
    knots."""
    if rng.random() < 0.5:
        return piece
    (lo, hi), _ = piece.domain
    t, net = insert_knot(piece.u_knots, piece.u_degree, piece.poles, lo + 0.37 * (hi - lo))
    return BSplineSurface(net, t, piece.v_knots, piece.u_degree, piece.v_degree)


def rational_points(poles, weights, tu, tv, p, q, u, v):
    hom = np.concatenate([poles * weights[..., None], weights[..., None]], axis=-1)
    h = evaluate(BSplineSurface(hom, tu, tv, p, q), u, v)
    return h[..., :-1] / h[..., -1:]


def test_a_rational_surface_is_split_in_homogeneous_coordinates():
    rng = np.random.default_rng(13)
    merged = merge_grid(random_grid(rng, 2, 2, 3, 3)[0])
    tu = clamped(np.sort(rng.uniform(0.1, 0.9, 4)), 3, 0.0, 2.0)
    tv = clamped(np.sort(rng.uniform(0.1, 0.9, 3)), 2, 0.0, 2.0)
    poles, weights = rng.normal(size=(8, 6, 3)), rng.uniform(0.5, 2.0, (8, 6))
    pieces = split_grid(merged, make_surface(poles, tu, tv, (3, 2), weights))
    for i in range(2):
        for j in range(2):
            piece, (du, dv) = pieces[i][j], merged.domains[i, j]
            u, v = inside(rng, du), inside(rng, dv)
            mu = to_merged(u, du, merged.u_breaks[i:i + 2])
            mv = to_merged(v, dv, merged.v_breaks[j:j + 2])
            got = rational_points(piece.poles, piece.weights, piece.u_knots, piece.v_knots,
                                  3, 2, u, v)
            expected = rational_points(poles, weights, tu, tv, 3, 2, mu, mv)
            assert np.abs(got - expected).max() <= 1e-12 * size(poles)


@pytest.mark.parametrize("breaks", ["chord", "uniform"])
def test_patches_cut_from_one_surface_merge_back_into_it(breaks):
    rng = np.random.default_rng(7)
    original = smooth_surface(rng, bump=0.5)
    u_cuts, v_cuts = [0.4], [0.55]
    patches = cut_into_grid(original, u_cuts, v_cuts)
    merged = merge_grid(patches, breaks=breaks)
    assert merged.border_gap == 0.0          # cut by one insertion: the borders are equal
    u_orig = np.r_[0.0, u_cuts, 1.0]
    v_orig = np.r_[0.0, v_cuts, 1.0]
    for i in range(2):
        for j in range(2):
            du, dv = (u_orig[i], u_orig[i + 1]), (v_orig[j], v_orig[j + 1])
            u, v = np.linspace(*du, 15), np.linspace(*dv, 15)
            mu = to_merged(u, du, merged.u_breaks[i:i + 2])
            mv = to_merged(v, dv, merged.v_breaks[j:j + 2])
            gap = np.abs(evaluate(merged.surface, mu, mv) - evaluate(original, u, v)).max()
            assert gap <= 1e-12 * size(original.poles)


def test_chord_breaks_follow_the_border_lengths():
    # a plane x = 10 u, y = 6 v (linear in the parameter) cut at u = 0.3 and v = 0.6
    t = clamped(np.array([0.25, 0.5, 0.75]), 3)
    g = np.convolve(t[1:-1], np.ones(3) / 3, mode="valid")
    x, y = np.meshgrid(10 * g, 6 * g, indexing="ij")
    plane = make_surface(np.stack([x, y, np.zeros_like(x)], axis=-1), t, t, 3)
    patches = cut_into_grid(plane, [0.3], [0.6])
    chord = merge_grid(patches)
    assert np.allclose(chord.u_breaks, [0.0, 0.6, 2.0], rtol=0, atol=1e-12)
    assert np.allclose(chord.v_breaks, [0.0, 1.2, 2.0], rtol=0, atol=1e-12)
    uniform = merge_grid(patches, breaks="uniform")
    assert np.array_equal(uniform.u_breaks, [0.0, 1.0, 2.0])


# -- fairing across the joins --------------------------------------------------------------
def sign_changes(values):
    signs = np.sign(values[np.abs(values) > 0])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def normal_curvature_along_u(surface, u, v):
    """S_uu . N / |S_u|^2 along the iso-line v (one value per u)."""
    su, suu = evaluate(surface, u, [v], 1, 0)[:, 0], evaluate(surface, u, [v], 2, 0)[:, 0]
    n = normals(surface, u, [v])[:, 0]
    return np.einsum("id,id->i", suu, n) / np.einsum("id,id->i", su, su)


@pytest.fixture(scope="module")
def noisy_grid():
    """A 3 x 2 grid cut from a convex graph, noise on every patch's interior poles."""
    rng = np.random.default_rng(3)
    original = smooth_surface(rng, k=14)
    patches = cut_into_grid(original, [0.3, 0.55], [0.45])
    noisy = []
    for row in patches:
        out = []
        for s in row:
            poles = s.poles.copy()
            poles[1:-1, 1:-1, 2] += rng.normal(0, 0.02, poles[1:-1, 1:-1, 2].shape)
            out.append(make_surface(poles, s.u_knots, s.v_knots, (3, 3)))
        noisy.append(out)
    merged = merge_grid(noisy)
    s = merged.surface
    faired = cf.fair_surface(s.poles, (6, 4), u_knots=s.u_knots, v_knots=s.v_knots,
                             degree=(s.u_degree, s.v_degree)).surface
    return merged, faired, split_grid(merged, faired)


def test_faired_pieces_share_their_borders_bit_for_bit(noisy_grid):
    merged, faired, pieces = noisy_grid
    m, n = merged.shape
    for i in range(m):
        for j in range(n):
            if i + 1 < m:
                assert np.array_equal(pieces[i][j].poles[-1], pieces[i + 1][j].poles[0])
            if j + 1 < n:
                assert np.array_equal(pieces[i][j].poles[:, -1], pieces[i][j + 1].poles[:, 0])
            (du, dv) = merged.domains[i, j]
            u, v = np.linspace(*du, 9), np.linspace(*dv, 9)
            mu = to_merged(u, du, merged.u_breaks[i:i + 2])
            mv = to_merged(v, dv, merged.v_breaks[j:j + 2])
            gap = np.abs(evaluate(pieces[i][j], u, v) - evaluate(faired, mu, mv)).max()
            assert gap <= 1e-12 * size(faired.poles)


def test_faired_pieces_join_with_equal_normals(noisy_grid):
    merged, _, pieces = noisy_grid
    m, n = merged.shape
    angles = []
    for i in range(m):
        for j in range(n):
            (u0, u1), (v0, v1) = merged.domains[i, j]
            if i + 1 < m:
                v = np.linspace(v0, v1, 11)
                a = normals(pieces[i][j], [u1], v)[0]
                b = normals(pieces[i + 1][j], [merged.domains[i + 1, j, 0, 0]], v)[0]
                angles.append(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                         np.einsum("id,id->i", a, b)))
            if j + 1 < n:
                u = np.linspace(u0, u1, 11)
                a = normals(pieces[i][j], u, [v1])[:, 0]
                b = normals(pieces[i][j + 1], u, [merged.domains[i, j + 1, 1, 0]])[:, 0]
                angles.append(np.arctan2(np.linalg.norm(np.cross(a, b), axis=-1),
                                         np.einsum("id,id->i", a, b)))
    assert np.concatenate(angles).max() <= 1e-9
    # the noisy patches themselves meet at a visible kink
    (u0, u1), (v0, v1) = merged.domains[0, 0]
    v = np.linspace(v0, v1, 11)[1:-1]
    s = merged.surface
    left = normals(s, [merged.u_breaks[1] - 1e-9], to_merged(v, (v0, v1), merged.v_breaks[:2]))
    right = normals(s, [merged.u_breaks[1] + 1e-9], to_merged(v, (v0, v1), merged.v_breaks[:2]))
    assert np.arccos(np.clip(np.einsum("id,id->i", left[0], right[0]), -1, 1)).max() > 1e-3


def test_fairing_removes_curvature_sign_changes_across_the_joins(noisy_grid):
    merged, faired, _ = noisy_grid
    middles = 0.5 * (merged.u_breaks[:-1] + merged.u_breaks[1:])
    u = np.linspace(middles[0], middles[-1], 501)         # crosses both u joins
    counts = []
    for v in np.r_[0.5 * (merged.v_breaks[:-1] + merged.v_breaks[1:]), 0.05, 1.95]:
        before = sign_changes(normal_curvature_along_u(merged.surface, u, v))
        after = sign_changes(normal_curvature_along_u(faired, u, v))
        assert after < before
        counts.append((before, after))
    assert sum(b for b, _ in counts) >= 12                # 4 + 2 + 6 + 4 with this noise
    assert all(a == 0 for _, a in counts)                 # the truth is convex


# -- orientation and knot insertion --------------------------------------------------------
@pytest.mark.parametrize("swap,flip_u,flip_v", [(True, False, False), (False, True, False),
                                                (False, False, True), (True, True, True)])
def test_oriented_reparametrises_exactly(swap, flip_u, flip_v):
    rng = np.random.default_rng(11)
    s = make_surface(rng.normal(size=(6, 5, 3)), clamped(np.array([0.3, 0.7]), 3, 2.0, 5.0),
                     clamped(np.array([0.4]), 3, -1.0, 0.5), (3, 3))
    o = oriented(s, swap=swap, flip_u=flip_u, flip_v=flip_v)
    (a, b), (c, d) = o.domain
    u, v = inside(rng, (a, b)), inside(rng, (c, d))
    uu, vv = (a + b - u if flip_u else u), (c + d - v if flip_v else v)
    expected = evaluate(s, vv, uu).transpose(1, 0, 2) if swap else evaluate(s, uu, vv)
    assert np.abs(evaluate(o, u, v) - expected).max() <= 1e-13 * size(s.poles)
    assert o.domain == ((s.domain[1] if swap else s.domain[0]),
                        (s.domain[0] if swap else s.domain[1]))


def test_oriented_brings_a_transposed_reversed_patch_into_the_grid():
    rng = np.random.default_rng(5)
    patches = cut_into_grid(smooth_surface(rng), [0.5], [0.5])
    turned = oriented(oriented(patches[1][1], flip_v=True), swap=True)
    with pytest.raises(InvalidInputError):
        merge_grid([patches[0], [patches[1][0], turned]])
    back = oriented(turned, swap=True, flip_v=True)
    merged = merge_grid([patches[0], [patches[1][0], back]])
    assert merged.border_gap <= 1e-12 * size(merged.surface.poles)


@given(seed=seeds, degree=st.integers(1, 5), times=st.integers(1, 5))
def test_insert_knot_matches_scipy(seed, degree, times):
    rng = np.random.default_rng(seed)
    times = min(times, degree)
    t = clamped(np.sort(rng.uniform(0.05, 0.95, 4)), degree)
    c = rng.normal(size=(t.size - degree - 1, 2, 3))
    x = float(rng.uniform(0.01, 0.99))
    knots, coefficients = insert_knot(t, degree, c, x, times)
    reference = BSpline(t, c, degree).insert_knot(x, times)
    assert np.array_equal(knots, reference.t)
    assert np.abs(coefficients - reference.c).max() <= 1e-13 * np.abs(c).max()


@pytest.mark.parametrize("x,times,words", [(0.0, 1, "open domain"), (1.5, 1, "open domain"),
                                           (0.5, 3, "times must be"), (0.5, 0, "times must be")])
def test_insert_knot_refuses_bad_arguments(x, times, words):
    t = clamped(np.array([0.5]), 2)
    with pytest.raises(InvalidInputError, match=words):
        insert_knot(t, 2, np.zeros((4, 3)), x, times)


# -- errors --------------------------------------------------------------------------------
@pytest.fixture
def grid2x2():
    return cut_into_grid(smooth_surface(np.random.default_rng(2)), [0.4], [0.6])


def test_borders_apart_beyond_tol_are_refused_and_within_tol_averaged(grid2x2):
    row = grid2x2[1]
    poles = row[0].poles.copy()
    poles[0, 2] += [0.0, 0.0, 1e-3]                  # a pole of the border with [0][0]
    moved = make_surface(poles, row[0].u_knots, row[0].v_knots, (3, 3))
    grid = [grid2x2[0], [moved, row[1]]]
    with pytest.raises(InvalidInputError, match=r"patch \[0\]\[0\] is followed in u by "
                                                r"patch \[1\]\[0\].*0.001 apart.*larger tol"):
        merge_grid(grid)
    merged = merge_grid(grid, tol=2e-3)
    assert merged.border_gap == pytest.approx(1e-3, rel=1e-9)
    shared = merged.surface.poles[grid2x2[0][0].shape[0] - 1, 2]
    expected = 0.5 * (grid2x2[0][0].poles[-1, 2] + poles[0, 2])
    assert np.allclose(shared, expected, rtol=0, atol=1e-15 * size(poles))


def test_different_degrees_are_refused(grid2x2):
    s = grid2x2[0][1]
    tv = clamped(np.array([0.5]), 4, *s.domain[1])          # v degree 4
    other = make_surface(np.ones((s.shape[0], 6, 3)), s.u_knots, tv, (3, 4))
    with pytest.raises(InvalidInputError, match=r"same degrees.*\(3, 3\).*\[0\]\[1\] has \(3, 4\)"):
        merge_grid([[grid2x2[0][0], other], grid2x2[1]])


def test_knots_that_differ_along_a_grid_row_are_refused(grid2x2):
    s = grid2x2[0][1]
    tu, poles = insert_knot(s.u_knots, 3, s.poles, 0.5 * sum(s.domain[0]))
    other = make_surface(poles, tu, s.v_knots, (3, 3))
    with pytest.raises(InvalidInputError, match=r"grid row 0 must share their u knots.*"
                                                r"insert the missing knots"):
        merge_grid([[grid2x2[0][0], other], grid2x2[1]])
    moved = s.u_knots.copy()
    moved[4] += 1e-3 * (moved[-1] - moved[0])             # same count, one knot moved
    other = make_surface(s.poles, moved, s.v_knots, (3, 3))
    with pytest.raises(InvalidInputError, match=r"grid row 0 must share their u knots"):
        merge_grid([[grid2x2[0][0], other], grid2x2[1]])


@pytest.mark.parametrize("patches,error,words", [
    ([], InvalidInputError, "m x n nested list"),
    ([[1.0]], InvalidInputError, "must be a BSplineSurface"),
    ("abc", InvalidInputError, "must be a BSplineSurface"),
])
def test_malformed_grids_are_refused(patches, error, words):
    with pytest.raises(error, match=words):
        merge_grid(patches)


def test_ragged_rational_and_bad_options_are_refused(grid2x2):
    with pytest.raises(InvalidInputError, match="rows of lengths"):
        merge_grid([grid2x2[0], grid2x2[1][:1]])
    s = grid2x2[0][0]
    rational = make_surface(s.poles, s.u_knots, s.v_knots, (3, 3),
                            weights=np.linspace(1, 2, s.poles[..., 0].size).reshape(s.shape))
    with pytest.raises(UnsupportedGeometryError, match="rational"):
        merge_grid([[rational]])
    with pytest.raises(InvalidToleranceError, match="positive finite"):
        merge_grid(grid2x2, tol=-1.0)
    with pytest.raises(InvalidInputError, match="breaks must be one of"):
        merge_grid(grid2x2, breaks="arc")


def test_split_refuses_a_surface_on_another_domain(grid2x2):
    merged = merge_grid(grid2x2)
    s = merged.surface
    other = BSplineSurface(s.poles, s.u_knots / 2, s.v_knots, 3, 3)
    with pytest.raises(InvalidInputError, match="merged domain"):
        split_grid(merged, other)
    with pytest.raises(InvalidInputError, match="MergedGrid"):
        split_grid(s, s)


def test_split_refuses_more_knots_than_the_degree_on_a_break(grid2x2):
    merged = merge_grid(grid2x2, breaks="uniform")
    b = merged.u_breaks[1]
    tu = np.r_[[0.0] * 2, b, np.nextafter(b, 3.0), [2.0] * 2]      # degree 1: a jump at b
    surface = BSplineSurface(np.zeros((4, 3, 3)), tu, np.r_[0.0, 0.0, 2.0, 2.0], 1, 1)
    with pytest.raises(InvalidInputError, match="more than its degree 1"):
        split_grid(merged, surface)
