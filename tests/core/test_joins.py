"""Joint projection of patches (cq_fairing.core.joins) on a grid with a known answer: four
noisy patches fitted to one smooth surface, one of them parametrized backwards and one
transposed (cq_fairing.core.examples.patch_grid).  Points and normals are evaluated with scipy's B-spline basis
(tests/core/naive.py), not with the code under test."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cq_fairing.core.examples import patch_grid
from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.joins import (
    BorderJoin,
    JointPatch,
    JoinTurns,
    UnionFind,
    cross_curvatures,
    fair_patches,
    holds_curvature,
    join_angles,
    pinning_patch,
    tied_in_order,
)
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.errors import InvalidInputError

from .naive import basis_matrix, dense_gram

SAMPLES = np.linspace(0.0, 1.0, 101)


def _grid(noise=0.003, seed=1):
    return patch_grid(noise, seed)


def _derivatives(surface, u, v):
    """Point, S_u and S_v at (u_k, v_k) by scipy's basis (naive)."""
    out = []
    for nu, nv in ((0, 0), (1, 0), (0, 1)):
        bu = basis_matrix(surface.u_knots, surface.u_degree, u, nu)
        bv = basis_matrix(surface.v_knots, surface.v_degree, v, nv)
        out.append(np.einsum("ka,abd,kb->kd", bu, surface.poles, bv))
    return out


def _border(surface, side, t):
    (u0, u1), (v0, v1) = surface.domain
    fixed = np.full_like(t, {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side])
    u, v = (fixed, v0 + (v1 - v0) * t) if side[0] == "u" else (u0 + (u1 - u0) * t, fixed)
    point, su, sv = _derivatives(surface, u, v)
    normal = np.cross(su, sv)
    return point, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def _joins_measured(surfaces, joins):
    """Largest gap and normal angle (degrees) over all joins at 101 samples each."""
    gap = angle = 0.0
    for join in joins:
        pa, na = _border(surfaces[join.a], join.side_a, SAMPLES)
        pb, nb = _border(surfaces[join.b], join.side_b,
                         1 - SAMPLES if join.reversed else SAMPLES)
        gap = max(gap, np.linalg.norm(pa - pb, axis=1).max())
        cos = np.clip(np.abs(np.sum(na * nb, axis=1)), -1, 1)
        angle = max(angle, np.degrees(np.arccos(cos)).max())
    return gap, angle


def _deviation(surfaces, patches):
    g = np.linspace(0, 1, 41)
    u, v = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    return max(np.linalg.norm(_derivatives(s, u, v)[0] - _derivatives(p, u, v)[0], axis=1).max()
               for s, p in zip(surfaces, patches))


def _targets(patches, n=4):
    target = SplineSpace.quasi_uniform(n, 3)
    return [JointPatch(p, (target, target)) for p in patches]


def test_closed_joins_share_their_borders_to_round_off():
    patches, joins = _grid()
    result = fair_patches(_targets(patches), joins, continuity="G0")
    gap, _ = _joins_measured(result.surfaces, joins)
    alone = [fair_patches([p], []).surfaces[0] for p in _targets(patches)]
    assert gap <= 1e-9 * 2.0                        # model size about 2
    assert _joins_measured(alone, joins)[0] > 1e-3  # faired alone, the joins open


def test_smooth_joins_keep_one_tangent_plane_and_cost_little_accuracy():
    patches, joins = _grid()
    targets = _targets(patches)
    alone = [fair_patches([p], []).surfaces[0] for p in targets]
    closed = fair_patches(targets, joins, continuity="G0")
    smooth = fair_patches(targets, joins, continuity="G1")
    gap, angle = _joins_measured(smooth.surfaces, joins)
    assert gap <= 1e-9 * 2.0
    assert _joins_measured(alone, joins)[1] > 5.0
    assert _joins_measured(closed.surfaces, joins)[1] > 4.0
    assert angle < 1e-4
    assert smooth.g1_rows > 0
    assert _deviation(smooth.surfaces, patches) < 1.5 * _deviation(alone, patches)


@given(st.lists(st.integers(1, 6), min_size=8, max_size=8), st.integers(0, 50))
def test_tangent_planes_agree_at_the_inner_vertex_whatever_the_targets(sizes, seed):
    """The grid's four joins cross at its inner vertex (x = y = 1): opposite joins share
    one ratio and the edges through the vertex run straight through it, so the cycle of
    mirrored rows around it closes and the tangent planes agree everywhere, whatever
    each patch's target."""
    patches, joins = _grid(seed=seed)
    targets = [JointPatch(p, (SplineSpace.quasi_uniform(nu, 3), SplineSpace.quasi_uniform(nv, 3)))
               for p, nu, nv in zip(patches, sizes[::2], sizes[1::2])]
    gap, angle = _joins_measured(fair_patches(targets, joins).surfaces, joins)
    assert gap <= 1e-9 * 2.0
    assert angle < 1e-4


def _three_by_three(seed, sizes):
    """Nine noisy bicubic patches of one height field on [0, 3]^2 (unit squares, all
    running the same way), each on its own quasi-uniform target, and their 12 joins: four
    inner vertices, each line of joins crossing two of them."""
    rng = np.random.default_rng(seed)
    space = SplineSpace.quasi_uniform(6, 3)
    s = np.linspace(0.0, 1.0, 40)
    fit = np.linalg.pinv(space.collocation(s).toarray())
    u, v = np.meshgrid(s, s, indexing="ij")
    patches, joins = [], []
    for i in range(3):
        for j in range(3):
            x, y = i + u, j + v
            net = np.einsum("ia,abd,jb->ijd", fit,
                            np.stack([x, y, 0.2 * np.sin(1.3 * x) * np.cos(y) + 0.05 * x * y], -1),
                            fit)
            net[1:-1, 1:-1] += rng.normal(0.0, 0.003, net[1:-1, 1:-1].shape)
            source = BSplineSurface(net, space.knots, space.knots, 3, 3)
            target = tuple(SplineSpace.quasi_uniform(n, 3) for n in sizes[3 * i + j])
            patches.append(JointPatch(source, target))
            if i:
                joins.append(BorderJoin(3 * (i - 1) + j, "u1", 3 * i + j, "u0"))
            if j:
                joins.append(BorderJoin(3 * i + j - 1, "v1", 3 * i + j, "v0"))
    return patches, joins


@given(st.integers(0, 50), st.lists(st.tuples(st.integers(1, 5), st.integers(1, 5)),
                                    min_size=9, max_size=9))
def test_lines_of_joins_through_several_vertices_stay_smooth(seed, sizes):
    patches, joins = _three_by_three(seed, sizes)
    result = fair_patches(patches, joins)
    gap, angle = _joins_measured(result.surfaces, joins)
    assert gap <= 1e-9 * 3.0
    assert angle < 1e-4
    assert _joins_measured([p.source for p in patches], joins)[1] > 0.1   # the source turns


def _cross_curvature(surface, side, t):
    """Normal curvature of ``surface`` in its cross direction along ``side`` (the
    curvature of the iso-line that crosses it, projected on the normal), by scipy's
    basis."""
    (u0, u1), (v0, v1) = surface.domain
    fixed = np.full_like(t, {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side])
    u, v = (fixed, v0 + (v1 - v0) * t) if side[0] == "u" else (u0 + (u1 - u0) * t, fixed)
    du, dv = (1, 0) if side[0] == "u" else (0, 1)
    first = [np.einsum("ka,abd,kb->kd", basis_matrix(surface.u_knots, 3, u, nu),
                       surface.poles, basis_matrix(surface.v_knots, 3, v, nv))
             for nu, nv in ((1, 0), (0, 1), (du, dv), (2 * du, 2 * dv))]
    su, sv, cross, second = first
    normal = np.cross(su, sv)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    return np.abs(np.sum(normal * second, axis=1)) / np.sum(cross * cross, axis=1)


def _curvature_jump(surfaces, joins):
    """Largest difference of the cross normal curvatures of the two sides of any join,
    and the largest such curvature."""
    jump = largest = 0.0
    for join in joins:
        ka = _cross_curvature(surfaces[join.a], join.side_a, SAMPLES)
        kb = _cross_curvature(surfaces[join.b], join.side_b,
                              1 - SAMPLES if join.reversed else SAMPLES)
        jump, largest = max(jump, np.abs(ka - kb).max()), max(largest, ka.max(), kb.max())
    return jump, largest


@given(st.lists(st.integers(1, 6), min_size=8, max_size=8), st.integers(0, 50))
def test_g2_holds_the_normal_curvature_across_every_join(sizes, seed):
    """The second rows of both sides match too (the cross curves C2 in one parameter):
    the normal curvature across each join is the same on both sides, to round-off,
    at the inner vertex too; with G1 alone it jumps."""
    patches, joins = _grid(seed=seed)
    targets = [JointPatch(p, (SplineSpace.quasi_uniform(nu, 3), SplineSpace.quasi_uniform(nv, 3)))
               for p, nu, nv in zip(patches, sizes[::2], sizes[1::2])]
    g2 = fair_patches(targets, joins, continuity="G2").surfaces
    gap, angle = _joins_measured(g2, joins)
    jump, largest = _curvature_jump(g2, joins)
    assert gap <= 1e-9 * 2.0 and angle < 1e-4
    assert jump <= 1e-7 * max(largest, 1.0)


def test_g2_is_what_g1_leaves_open():
    patches, joins = _grid()
    targets = _targets(patches)
    g1, g2 = (fair_patches(targets, joins, continuity=c).surfaces for c in ("G1", "G2"))
    assert _curvature_jump(g1, joins)[0] > 0.5
    assert _curvature_jump(g2, joins)[0] < 1e-9
    assert _deviation(g2, patches) < 1.5 * _deviation(g1, patches)


@given(st.integers(0, 50), st.lists(st.tuples(st.integers(3, 5), st.integers(3, 5)),
                                    min_size=9, max_size=9))
def test_g2_along_lines_of_joins_through_several_vertices(seed, sizes):
    """The middle patch has G2 joins on all four sides: with six poles or more across,
    three rows at each end, all are held."""
    patches, joins = _three_by_three(seed, sizes)
    result = fair_patches(patches, joins, continuity="G2")
    jump, largest = _curvature_jump(result.surfaces, joins)
    assert len(result.curved) == len(joins)
    assert _joins_measured(result.surfaces, joins)[1] < 1e-4
    assert jump <= 1e-7 * max(largest, 1.0)


def test_g2_is_left_out_where_a_patch_has_too_few_rows_across():
    """One span across the middle row of patches (four poles in u: the joins along u
    share their knots) cannot carry three rows for each of two opposite G2 joins: the
    joins across u stay G1, and say so; those across v are G2."""
    sizes = [(4, 4)] * 3 + [(1, 4)] * 3 + [(4, 4)] * 3
    patches, joins = _three_by_three(0, sizes)
    result = fair_patches(patches, joins, continuity="G2")
    across_u = [j for j in joins if j.side_a[0] == "u"]
    assert len(across_u) == 6 and not set(across_u) & set(result.curved)
    assert set(result.curved) == set(joins) - set(across_u)
    assert _joins_measured(result.surfaces, joins)[1] < 1e-4


@pytest.mark.parametrize("kept", [0, 3])   # side a of both its joins; side b of both
def test_a_kept_patch_constrains_its_neighbours_exactly(kept):
    """The neighbours take the kept patch's borders and mirror its cross rows: closed
    and G1 along the joins (away from the inner vertex, which is no crossing with a
    patch kept)."""
    patches, joins = _grid()
    targets = _targets(patches)
    targets[kept] = JointPatch(patches[kept])
    result = fair_patches(targets, joins)
    assert result.surfaces[kept] is patches[kept]
    for join in (j for j in joins if kept in (j.a, j.b)):
        pa, na = _border(result.surfaces[join.a], join.side_a, SAMPLES)
        pb, nb = _border(result.surfaces[join.b], join.side_b,
                         1 - SAMPLES if join.reversed else SAMPLES)
        assert np.linalg.norm(pa - pb, axis=1).max() <= 1e-9 * 2.0
        far = np.linalg.norm(pa[:, :2] - 1.0, axis=1) > 0.76
        cos = np.clip(np.abs(np.sum(na * nb, axis=1)), -1, 1)
        assert np.degrees(np.arccos(cos[far])).max() < 1e-5


@pytest.mark.parametrize("continuity", ["G0", "G1"])
def test_patches_all_kept_come_back_as_they_are(continuity):
    """With every patch kept there is nothing to solve: the sources come back."""
    patches, joins = _grid()
    result = fair_patches([JointPatch(p) for p in patches], joins, continuity=continuity)
    assert all(s is p for s, p in zip(result.surfaces, patches))


@given(st.sampled_from(["u0", "u1", "v0", "v1"]), st.integers(1, 4))
def test_a_pinned_side_keeps_the_source_border_and_tangent_plane(side, n):
    """A side joined to its pinning patch keeps the source's border curve and normals
    along it, whatever the target, while the rest of the patch is projected."""
    patch = _grid()[0][0]
    result = fair_patches(_targets([patch], n) + [pinning_patch(patch, side)],
                          [BorderJoin(0, side, 1, side)])
    faired = result.surfaces[0]
    (pf, nf), (ps, ns) = (_border(s, side, SAMPLES) for s in (faired, patch))
    assert np.linalg.norm(pf - ps, axis=1).max() <= 1e-9 * 2.0
    assert np.degrees(np.arccos(np.clip(np.sum(nf * ns, axis=1), -1, 1))).max() < 1e-5
    across = 0 if side[0] == "u" else 1
    assert faired.shape[across] == n + 3 < patch.shape[across]


def _rational_pair(seed=3):
    """Patches 0 and 2 of the grid (joined v1 to v0) with random weights in [0.7, 1.5],
    equal along their common border."""
    patches, joins = _grid()
    rng = np.random.default_rng(seed)
    weights = [rng.uniform(0.7, 1.5, p.shape) for p in (patches[0], patches[2])]
    weights[1][:, 0] = weights[0][:, -1]
    pair = [BSplineSurface(p.poles, p.u_knots, p.v_knots, 3, 3, w)
            for p, w in zip((patches[0], patches[2]), weights)]
    return pair, [BorderJoin(0, "v1", 1, "v0")]


def test_rational_patches_are_joined_in_homogeneous_coordinates():
    pair, joins = _rational_pair()
    targets = _targets(pair)
    joint = fair_patches(targets, joins)
    alone = [fair_patches([p], []).surfaces[0] for p in targets]
    assert all(s.is_rational and np.all(s.weights > 0) for s in joint.surfaces)
    (pa, na), (pb, nb) = (_rational_border(s, side)
                          for s, side in zip(joint.surfaces, ("v1", "v0")))
    assert np.linalg.norm(pa - pb, axis=1).max() <= 1e-9 * 2.0
    assert np.degrees(np.arccos(np.clip(np.abs(np.sum(na * nb, axis=1)), -1, 1))).max() < 1e-5
    (pa, na), (pb, nb) = (_rational_border(s, side) for s, side in zip(alone, ("v1", "v0")))
    assert np.linalg.norm(pa - pb, axis=1).max() > 1e-3
    assert np.degrees(np.arccos(np.clip(np.abs(np.sum(na * nb, axis=1)), -1, 1))).max() > 1.0


@given(st.sampled_from(["u0", "u1", "v0", "v1"]), st.integers(0, 20))
def test_a_pinned_rational_side_keeps_its_border_and_tangent_plane(side, seed):
    patch = _rational_pair(seed)[0][0]
    result = fair_patches(_targets([patch]) + [pinning_patch(patch, side)],
                          [BorderJoin(0, side, 1, side)])
    (pf, nf), (ps, ns) = (_rational_border(s, side) for s in (result.surfaces[0], patch))
    assert np.linalg.norm(pf - ps, axis=1).max() <= 1e-9 * 2.0
    assert np.degrees(np.arccos(np.clip(np.sum(nf * ns, axis=1), -1, 1))).max() < 1e-5


def _rational_border(surface, side):
    """Points and unit normals along a side by the surface's own (rational) evaluation."""
    return _own_border(surface, side, SAMPLES)


@given(st.integers(3, 7), st.sampled_from(["G0", "G1"]))
def test_any_target_size_closes_the_joins(n, continuity):
    patches, joins = _grid(seed=n)
    result = fair_patches(_targets(patches, n), joins, continuity=continuity)
    assert _joins_measured(result.surfaces, joins)[0] <= 1e-9 * 2.0
    assert all(s.shape == (n + 3, n + 3) for s in result.surfaces)


def test_a_chord_tied_to_its_own_reverse_is_dropped_with_a_reason():
    patches, _ = _grid()
    twisted = [BorderJoin(0, "u1", 1, "u1"), BorderJoin(0, "u0", 1, "u0", reversed=True)]
    result = fair_patches(_targets(patches)[:2], twisted)
    assert len(result.joins) == 1 and "reverse" in result.dropped[0][1]


def test_bad_input_is_refused_with_what_to_do():
    patches, joins = _grid()
    targets = _targets(patches)
    with pytest.raises(InvalidInputError, match="one of"):
        fair_patches(targets, [BorderJoin(0, "w1", 1, "u1")])
    with pytest.raises(InvalidInputError, match="two joins"):
        fair_patches(targets, [BorderJoin(0, "u1", 1, "u1"), BorderJoin(0, "u1", 2, "v0")])
    with pytest.raises(InvalidInputError, match="continuity"):
        fair_patches(targets, joins, continuity="C1")


def _bezier_patch(f):
    """The biquadratic Bezier patch of ``f(u, v) -> (x, y, z)`` (exact for a map of degree
    two in each parameter), its poles from nine samples."""
    knots = np.array([0.0, 0.0, 0.0, 1.0, 1.0, 1.0])
    x = np.array([0.0, 0.5, 1.0])
    b = SplineSpace(2, knots).collocation(x).toarray()
    values = np.array([[f(u, v) for v in x] for u in x])
    poles = np.einsum("ai,ijd,bj->abd", np.linalg.inv(b), values, np.linalg.inv(b))
    return BSplineSurface(poles, knots, knots, 2, 2)


def test_source_angles_are_measured_between_the_same_places_of_both_sides():
    """Two patches of z = 0.2 x^2 + 0.1 y (+ 0.3 (x - 1) y beyond x = 1) meet along x = 1,
    the second one parametrized along the join by y = (s + s^2) / 2.  The sources' angle
    along the join is the analytic angle at each point (side b's nearest point), not at
    equal parameters, which are other places."""
    a = _bezier_patch(lambda u, v: (u, v, 0.2 * u * u + 0.1 * v))
    def y(s):
        return 0.5 * (s + s * s)

    b = _bezier_patch(lambda u, s: (1 + u, y(s), 0.2 * (1 + u) ** 2 + 0.1 * y(s)
                                    + 0.3 * u * y(s)))
    join = BorderJoin(0, "u1", 1, "u0", reversed=False, smooth=True)
    turns = JoinTurns([a, b], [join])
    t = turns.samples
    n_a = np.array([-0.4, -0.1, 1.0])
    n_b = np.stack([-(0.4 + 0.3 * t), np.full_like(t, -0.1), np.ones_like(t)], axis=1)
    cos = n_b @ n_a / np.linalg.norm(n_b, axis=1) / np.linalg.norm(n_a)
    exact = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    assert np.abs(turns.source[0] - exact).max() <= 0.05
    assert np.abs(join_angles([a, b], join, t) - exact).max() > 0.5


def test_a_source_is_curvature_continuous_where_both_sides_agree_at_the_same_places():
    """One smooth surface z = 0.05 x^2 + 0.3 x^2 y cut at x = 1, the second piece
    parametrized along the cut by y = (s + s^2) / 2: G2 across the cut.  At equal
    parameters the cross curvatures are compared at other places and differ by up to
    about a fifth; at the same places they agree."""
    def y(s):
        return 0.5 * (s + s * s)

    a = _bezier_patch(lambda u, v: (u, v, 0.05 * u * u + 0.3 * u * u * v))
    b = _bezier_patch(lambda u, s: (1 + u, y(s), 0.05 * (1 + u) ** 2
                                    + 0.3 * (1 + u) ** 2 * y(s)))
    join = BorderJoin(0, "u1", 1, "u0", reversed=False, smooth=True)
    t = np.linspace(0.0, 1.0, 33)
    ka, kb = cross_curvatures([a, b], join, t)
    assert np.abs(ka - kb).max() > 0.1 * np.abs(ka).max()
    assert holds_curvature([a, b], join)


def _projection_residual(surface, source):
    r"""The gradient of :math:`\|S - S_{source}\|_{L^2}^2 / 2` over the poles of
    ``surface``, :math:`G_u X G_v^T - G_{uS} C G_{vS}^T` (dense Gauss grams, naive)."""
    def grams(axis):
        knots = [(s.u_knots, s.u_degree) if axis == 0 else (s.v_knots, s.v_degree)
                 for s in (surface, source)]
        return dense_gram(*knots[0], *knots[0]), dense_gram(*knots[0], *knots[1])

    (gu, eu), (gv, ev) = grams(0), grams(1)
    return (np.einsum("ia,abd,jb->ijd", gu, surface.poles, gv)
            - np.einsum("ia,abd,jb->ijd", eu, source.poles, ev))


def test_a_shared_border_is_the_least_squares_compromise_of_both_patches():
    """Moving a shared border pole (not one next to a vertex) moves both patches: the
    closed (G0) projection's error gradients over it from the two patches cancel, while
    each alone is far from zero (each source pulls its own way)."""
    patches, joins = _grid()
    result = fair_patches(_targets(patches), joins, continuity="G0")
    join = joins[0]                      # patch 0 side u1 is patch 1 side u1, same way
    first, second = (_projection_residual(result.surfaces[i], patches[i])[-1, 2:-2]
                     for i in (join.a, join.b))
    assert np.linalg.norm(first + second, axis=1).max() \
        <= 1e-8 * np.linalg.norm(first, axis=1).min()
    assert np.linalg.norm(first, axis=1).min() > 1e-7


@given(st.lists(st.tuples(st.integers(0, 11), st.integers(0, 11)), max_size=40))
def test_pairs_tied_in_order_are_those_a_union_find_ties_one_after_the_other(pairs):
    """``tied_in_order`` (Kruskal's forest, the pairs' positions as weights) against
    ``UnionFind.tie`` taking the pairs one by one, repeated pairs and a node with itself
    included."""
    union = UnionFind()
    expected = [k for k, (a, b) in enumerate(pairs) if union.tie(a, b) is None]
    assert tied_in_order(pairs, 12).tolist() == expected


def _angles_at(surfaces, join, t, border):
    """Normal angles (degrees) across ``join`` at ``t`` from ``border(surface, side, t)``
    (points and unit normals)."""
    na = border(surfaces[join.a], join.side_a, t)[1]
    nb = border(surfaces[join.b], join.side_b, 1 - t if join.reversed else t)[1]
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(na * nb, axis=1)), 0.0, 1.0)))


def _own_border(surface, side, t):
    """Points and unit normals along a side by the surface's own evaluation (rational
    where it is)."""
    (u0, u1), (v0, v1) = surface.domain
    u, v = ([{"u0": u0, "u1": u1}[side]], v0 + (v1 - v0) * t) if side[0] == "u" else \
        (u0 + (u1 - u0) * t, [{"v0": v0, "v1": v1}[side]])
    point, su, sv = (surface.evaluate_grid(u, v, nu, nv).reshape(len(t), 3)
                     for nu, nv in ((0, 0), (1, 0), (0, 1)))
    normal = np.cross(su, sv)
    return point, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def test_join_angles_of_nets_on_the_same_spaces_share_their_basis_values():
    """Basis values kept per space (``known``, as JoinTurns keeps them) from one set of
    patches to the next on the same spaces: the angles of the grid's joins (every kind
    of side, one reversed), and of a rational pair, are those of scipy's bases and of
    the surfaces' own rational evaluation, for the sources and for other nets."""
    patches, joins = _grid()
    pair, pair_joins = _rational_pair()
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 1.0, 33)
    for surfaces, links, border in ((patches, joins, _border), (pair, pair_joins, _own_border)):
        known = {}
        moved = [BSplineSurface(s.poles + rng.normal(0.0, 0.02, s.poles.shape), s.u_knots,
                                s.v_knots, 3, 3, s.weights) for s in surfaces]
        sizes = []
        for nets in (surfaces, moved):
            for join in links:
                expected = _angles_at(nets, join, t, border)
                assert np.abs(join_angles(nets, join, t, known=known) - expected).max() <= 1e-6
                assert np.abs(join_angles(nets, join, t) - expected).max() <= 1e-6
            sizes.append(len(known))
        assert sizes[0] == sizes[1] > 0     # the second nets found every value known
