"""Energy fairing of a patch network (core.network) on the noisy 2 x 2 grid of
core.examples.patch_grid: joins measured with scipy's bases (tests.core.naive),
deviation on a dense grid, against the sources and the joint projection."""

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from cq_fairing.core.examples import patch_grid, patch_network
from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.joins import BorderJoin, JoinTurns, UnionFind
from cq_fairing.core.network import (
    KKT_EPS,
    RHS_BLOCK,
    SAMPLES,
    PatchNetwork,
    _constraints,
    _curvature_rows,
    _Forms,
    _solved,
    _straightened,
    _System,
    fair_network,
    network_joinable,
)
from cq_fairing.core.patch_grid import insert_knot
from cq_fairing.core.spaces import SplineSpace
from cq_fairing.errors import InvalidInputError

from .naive import basis_matrix, dense_gram
from .test_joins import SAMPLES as ALONG
from .test_joins import _border, _joins_measured


def _dense_deviation(surfaces, sources):
    g = np.linspace(0.0, 1.0, 61)
    out = []
    for s, p in zip(surfaces, sources):
        points = [np.einsum("ia,abd,jb->ijd", basis_matrix(x.u_knots, x.u_degree, g),
                            x.poles, basis_matrix(x.v_knots, x.v_degree, g)) for x in (s, p)]
        out.append(np.linalg.norm(points[0] - points[1], axis=-1).max())
    return np.array(out)


def _bending(surface):
    """Thin-plate energy by Gauss quadrature of second derivatives (scipy bases)."""
    x, w = np.polynomial.legendre.leggauss(6)
    b = surface.u_space.breakpoints
    nodes = np.concatenate([0.5 * (q - p) * x + 0.5 * (p + q) for p, q in zip(b[:-1], b[1:])])
    weights = np.concatenate([0.5 * (q - p) * w for p, q in zip(b[:-1], b[1:])])

    def d(nu, nv):
        return np.einsum("ia,abd,jb->ijd", basis_matrix(surface.u_knots, 3, nodes, nu),
                         surface.poles, basis_matrix(surface.v_knots, 3, nodes, nv))
    density = (np.sum(d(2, 0) ** 2, -1) + 2 * np.sum(d(1, 1) ** 2, -1)
               + np.sum(d(0, 2) ** 2, -1))
    return float(weights @ density @ weights)


@pytest.fixture(scope="module")
def grid():
    return patch_grid()


@pytest.fixture(scope="module")
def faired(grid):
    return fair_network(grid.patches, grid.joins, 0.005)


def test_joins_close_to_round_off_and_turn_less_than_the_slack(grid, faired):
    gap, angle = _joins_measured(faired.surfaces, grid.joins)
    assert gap <= 1e-9 * 2.0
    assert _joins_measured(grid.patches, grid.joins)[1] > 10.0     # the noisy source
    assert angle <= 0.05
    assert faired.g1_rows > 0 and not faired.kept


def test_every_patch_stays_within_tolerance_and_bends_less(grid, faired):
    assert faired.smoothing > 0
    assert _dense_deviation(faired.surfaces, grid.patches).max() <= 0.005 * 1.02
    for before, after in zip(grid.patches, faired.surfaces):
        assert _bending(after) < 0.5 * _bending(before)


def test_a_larger_tolerance_never_gives_a_rougher_network(grid):
    energies = [sum(_bending(s) for s in fair_network(grid.patches, grid.joins, tol).surfaces)
                for tol in (0.003, 0.005, 0.01)]
    assert energies[0] >= energies[1] >= energies[2]


def test_a_kept_patch_keeps_its_surface_and_holds_its_neighbours(grid):
    result = fair_network(grid.patches, grid.joins, 0.005, kept=[0])
    assert 0 in result.kept
    assert np.array_equal(result.surfaces[0].poles, grid.patches[0].poles)
    gap, _ = _joins_measured(result.surfaces, grid.joins[:2])
    assert gap <= 1e-9 * 2.0


def test_a_tolerance_below_what_the_joins_need_keeps_every_patch(grid):
    result = fair_network(grid.patches, grid.joins, 1e-4)
    assert result.kept == {0, 1, 2, 3}
    assert all(s is p for s, p in zip(result.surfaces, grid.patches))


def test_each_patch_the_network_keeps_has_its_reason(grid):
    """A patch asked to be kept has no reason; one the joins alone hold over its own
    (tiny) tolerance has ``("tolerance", d)``, ``d`` over that tolerance; on the grid at
    a tolerance below what its joins need, every patch has a reason: held tangent its
    joins would hold it over, and with their source kinks kept they would turn more
    than the source's, ``("turned", joins)``, joins that keep their kinks."""
    example = patch_network()
    asked = fair_network(example.patches, example.joins, 0.01, kept=[0])
    assert asked.kept == {0} and asked.reasons == {}
    result = fair_network(example.patches, example.joins, [0.01, 1e-12, 0.01])
    assert result.kept == {1} and set(result.reasons) == {1}
    kind, distance = result.reasons[1]
    assert kind == "tolerance" and distance > 1e-12
    grid_result = fair_network(grid.patches, grid.joins, 1e-4)
    assert set(grid_result.reasons) == {0, 1, 2, 3}
    assert all(k == "turned" and joins and set(joins) <= grid_result.kinked
               for k, joins in grid_result.reasons.values())


def _angles(surfaces, join):
    """The normal angle (degrees) across ``join`` at 101 equal parameters along it."""
    _, na = _border(surfaces[join.a], join.side_a, ALONG)
    _, nb = _border(surfaces[join.b], join.side_b, 1 - ALONG if join.reversed else ALONG)
    return np.degrees(np.arccos(np.clip(np.abs(np.sum(na * nb, axis=1)), 0.0, 1.0)))


@pytest.mark.parametrize(("example", "tol", "kinked"), [
    ("L", 0.002, {1}), ("L", 0.001, {0, 1}), ("crossing", 0.002, {0, 2})])
def test_a_join_whose_tangency_would_hold_a_patch_over_keeps_the_source_kink(
        example, tol, kinked):
    """The L of patch_network and the one-span 2 x 2 grid (a crossing) at tolerances
    below what tangent joins need: made tangent, the joins hold patches over their
    tolerance (which were then kept).  The joins along which tangency would move the
    source's poles by more than the tolerance keep the source's kink instead: every
    patch moves, within its tolerance, the joins stay closed and turn no more than the
    source's + 0.05 deg at the same parameters, those joins by more than 0.5 deg, and
    the L's other join is tangent (at the crossing, whose rows at the vertex the kinked
    joins share, the others turn less than the source's)."""
    source = patch_network() if example == "L" else patch_grid(poles=4)
    network = PatchNetwork(source.patches, source.joins)
    tangent = _System(network.forms, set(), network.sides, "G1", network.spread,
                      network.vertices)
    assert _dense_deviation(tangent.surfaces(tangent.solve(0.0)), source.patches).max() > tol
    result = fair_network(source.patches, source.joins, tol)
    assert result.kinked == kinked and not result.kept and result.smoothing > 0
    assert _dense_deviation(result.surfaces, source.patches).max() <= tol * 1.02
    assert _joins_measured(result.surfaces, source.joins)[0] <= 1e-9 * 2.0
    for k, join in enumerate(source.joins):
        faired, before = _angles(result.surfaces, join), _angles(source.patches, join)
        assert np.max(faired - before) <= 0.05
        if k in kinked:
            assert faired.max() > 0.5
        elif example == "L":
            assert faired.max() <= 0.05


def test_a_planar_patch_is_kept_and_its_neighbours_close_onto_it():
    """The L of patch_network with its corner patch flattened (z = 0, and the border
    rows its neighbours share with it): the planar patch keeps its surface, with the
    reason ``("planar",)``, and the two others move and close onto it."""
    source = patch_network()
    patches = [p.poles.copy() for p in source.patches]
    patches[0][..., 2] = 0.0
    for join in source.joins:
        _border_row_of(patches[join.b], join.side_b)[..., 2] = 0.0
    patches = [replace(p, poles=poles) for p, poles in zip(source.patches, patches)]
    result = fair_network(patches, source.joins, 0.05)
    assert result.kept == {0} and result.reasons == {0: ("planar",)}
    assert np.array_equal(result.surfaces[0].poles, patches[0].poles)
    assert all(_dense_deviation([result.surfaces[k]], [patches[k]])[0] > 1e-4 for k in (1, 2))
    assert _joins_measured(result.surfaces, source.joins)[0] <= 1e-9 * 2.0


def test_one_span_patches_are_refined_and_stay_the_same_surface_where_kept():
    one_span = patch_grid(poles=4)
    result = fair_network(one_span.patches, one_span.joins, 0.02)
    moved = [s for k, s in enumerate(result.surfaces) if k not in result.kept]
    assert moved and all(s.shape == (5, 5) for s in moved)
    assert _dense_deviation(result.surfaces, one_span.patches).max() <= 0.02 * 1.02


def test_joins_along_different_knots_are_refused(grid):
    other = patch_grid(poles=13).patches[1]
    assert not network_joinable(grid.patches[0], "u1", other, "u1", False)
    with pytest.raises(InvalidInputError, match="differ in degree or knots"):
        fair_network([grid.patches[0], other], [BorderJoin(0, "u1", 1, "u1")], 0.01)


def _border_row(surface, side):
    """The border poles along ``side`` in the order of its along-parameter."""
    return _border_row_of(surface.poles, side)


def _border_row_of(poles, side):
    """The border row of a net ``poles`` along ``side`` (a view)."""
    return {"u0": poles[0], "u1": poles[-1], "v0": poles[:, 0], "v1": poles[:, -1]}[side]


def test_joined_borders_are_one_row_of_poles_to_the_last_bit(grid, faired):
    """G0 is held exactly: both patches take the very same border poles, also next to a
    kept patch, whose border stays its source's, and with G0 alone (no mirrored rows)."""
    g0 = fair_network(grid.patches, grid.joins, 0.005, continuity="G0")
    assert g0.g1_rows == 0 and g0.smoothing > 0
    for result in (faired, fair_network(grid.patches, grid.joins, 0.005, kept=[0]), g0):
        for join in grid.joins:
            a = _border_row(result.surfaces[join.a], join.side_a)
            b = _border_row(result.surfaces[join.b], join.side_b)
            assert np.array_equal(a, b[::-1] if join.reversed else b)
    kept = fair_network(grid.patches, grid.joins, 0.005, kept=[0])
    assert np.array_equal(_border_row(kept.surfaces[1], "u1"), _border_row(grid.patches[0], "u1"))


@pytest.fixture(scope="module")
def mixed(grid):
    """The grid with patch 2 refined across u (a knot at u = 0.05, the same surface): its
    join with patch 0 runs along other knots and is left out; patches on two kinds of
    spaces, interleaved."""
    patch = grid.patches[2]
    knots, net = insert_knot(patch.u_knots, 3, patch.poles, 0.05)
    refined = BSplineSurface(net, knots, patch.v_knots, 3, 3)
    patches = [grid.patches[0], grid.patches[1], refined, grid.patches[3]]
    joins = [j for j in grid.joins if network_joinable(
        patches[j.a], j.side_a, patches[j.b], j.side_b, j.reversed)]
    assert len(joins) == 3
    return patches, joins


def _probe_samples(space):
    """The documented samples of a direction: three per span and SAMPLES over the domain."""
    b = space.breakpoints
    return np.unique(np.concatenate([np.linspace(p, q, 3) for p, q in zip(b[:-1], b[1:])]
                                    + [np.linspace(b[0], b[-1], SAMPLES)]))


def test_sampled_deviations_are_the_same_parameter_distances_on_the_samples(mixed):
    """Each patch's deviation is the largest distance to its source at equal parameters on
    its samples, evaluated here with scipy's bases, for patches on different spaces."""
    patches, joins = mixed
    result = fair_network(patches, joins, 0.005)
    assert result.smoothing > 0 and len(result.kept) < len(patches)
    for k, (source, surface) in enumerate(zip(patches, result.surfaces)):
        u, v = _probe_samples(source.u_space), _probe_samples(source.v_space)
        points = [np.einsum("ia,abd,jb->ijd", basis_matrix(s.u_knots, 3, u), s.poles,
                            basis_matrix(s.v_knots, 3, v)) for s in (source, surface)]
        expected = 0.0 if k in result.kept else np.linalg.norm(points[0] - points[1], axis=-1).max()
        assert result.deviations[k] == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert np.all(result.deviations <= 0.005)


def test_each_patch_gets_the_forms_of_its_own_spaces(mixed):
    """The L2 and thin-plate forms, built once per pair of spaces, against dense Gauss
    quadrature of scipy's bases for every patch."""
    patches, _ = mixed
    forms = _Forms(patches)
    for k, patch in enumerate(patches):
        block = slice(forms.offsets[k], forms.offsets[k + 1])
        g = [[dense_gram(s.knots, 3, s.knots, 3, nu) for nu in (0, 1, 2)]
             for s in (patch.u_space, patch.v_space)]
        mass = np.kron(g[0][0], g[1][0])
        energy = np.kron(g[0][2], g[1][0]) + 2 * np.kron(g[0][1], g[1][1]) + \
            np.kron(g[0][0], g[1][2])
        scaled = np.trace(mass) / np.trace(energy) * energy
        assert np.allclose(forms.mass[block, block].toarray(), mass, rtol=1e-9,
                           atol=1e-12 * np.abs(mass).max())
        assert np.allclose(forms.energy[block, block].toarray(), scaled, rtol=1e-9,
                           atol=1e-12 * np.abs(scaled).max())
        assert forms.mass[block].nnz == forms.mass[block, block].nnz   # block-diagonal


def test_a_network_prepared_once_fairs_each_tolerance_as_a_fresh_one(grid):
    """The forms and samples a PatchNetwork keeps do not depend on the tolerance or the
    kept patches: fairing it again gives what a fresh fair_network gives, to the bit."""
    network = PatchNetwork(grid.patches, grid.joins)
    for tol, kept in ((0.01, ()), (0.005, (0,)), (0.003, ())):
        again, fresh = network.fair(tol, kept=kept), fair_network(grid.patches, grid.joins, tol,
                                                                   kept=kept)
        assert again.smoothing == fresh.smoothing and again.kept == fresh.kept
        assert np.array_equal(again.deviations, fresh.deviations)
        assert all(np.array_equal(a.poles, b.poles)
                   for a, b in zip(again.surfaces, fresh.surfaces))


@pytest.mark.parametrize("tol", [0.005, 0.01])
def test_the_grid_crossing_holds_g1_exactly(grid, tol):
    """The four joins cross at the grid's inner vertex: opposite joins share one ratio
    and the edges run straight through it, so the cycle of mirrored rows closes and the
    tangent planes agree there too (with one row of the cycle left out they turned by
    0.03 deg)."""
    result = fair_network(grid.patches, grid.joins, tol)
    assert not result.kept
    assert _joins_measured(result.surfaces, grid.joins)[1] <= 1e-4


def test_a_vertex_open_between_kept_patches_stays_as_open_as_in_the_source(grid):
    """Patches 0 and 1 kept, patch 1's corner at the inner vertex moved 1e-3 off the
    others (an open vertex): the moving patches' corners there stay at their own source
    points, so no join at the vertex opens beyond its source; elsewhere their borders are
    the kept patches' borders pole for pole."""
    patches = list(grid.patches)
    corners = [_inner_corner(p) for p in patches]
    poles = patches[1].poles.copy()
    poles[corners[1]] += [0.0, 0.0, 1e-3]
    patches[1] = BSplineSurface(poles, patches[1].u_knots, patches[1].v_knots, 3, 3)
    result = fair_network(patches, grid.joins, 0.01, kept=[0, 1])
    moved = sorted(set(range(4)) - result.kept)
    assert moved == [2, 3]
    for f in moved:
        assert np.array_equal(result.surfaces[f].poles[corners[f]], patches[f].poles[corners[f]])
    source_gap = _joins_measured(patches, grid.joins)[0]
    assert 1e-3 <= source_gap <= _joins_measured(result.surfaces, grid.joins)[0] + 1e-12
    assert _joins_measured(result.surfaces, grid.joins)[0] <= source_gap + 1e-9


def _inner_corner(patch):
    """The index of a patch's corner pole nearest the grid's centre (1, 1)."""
    net = patch.poles
    candidates = [(0, 0), (0, -1), (-1, 0), (-1, -1)]
    return min(candidates, key=lambda c: np.linalg.norm(net[c][:2] - [1.0, 1.0]))


def _fan(poles=6, noise=0.003, seed=3):
    """Three bicubic patches around the vertex (0.5, 0.5) of z = 0.3 sin 2x cos 1.5y + 0.1 xy:
    the rhombi between the rays at 90, 210 and 330 degrees, poles on the bilinear map of
    each rhombus with noise on the z of those off its two joined sides.  Patch k runs along ray k in u
    and along ray k + 1 in v, so its side v0 is side u0 of patch k - 1: three smooth
    joins meet at the vertex, a fan (no two of its edges in line)."""
    centre = np.array([0.5, 0.5])
    rays = [np.array([np.cos(a), np.sin(a)]) for a in np.radians([90.0, 210.0, 330.0])]
    s = np.linspace(0.0, 1.0, poles)[:, None, None]
    t = np.linspace(0.0, 1.0, poles)[None, :, None]
    knots = SplineSpace.quasi_uniform(poles - 3, 3).knots
    rng = np.random.default_rng(seed)
    patches = []
    for k in range(3):
        xy = centre + s * rays[k] + t * rays[(k + 1) % 3]
        z = 0.3 * np.sin(2 * xy[..., 0]) * np.cos(1.5 * xy[..., 1]) + 0.1 * xy[..., 0] * xy[..., 1]
        z[1:, 1:] += rng.normal(0.0, noise, z[1:, 1:].shape)
        patches.append(BSplineSurface(np.dstack([xy, z]), knots, knots, 3, 3))
    return patches, [BorderJoin(k, "v0", (k + 2) % 3, "u0") for k in range(3)]


def _coupled_kkt_poles(network, system, mirrored, planes, lam):
    """The poles from a dense solve of the whole KKT system over x, y and z together, as
    the module documents it: the constraints on vec(C) (coordinate after coordinate) are
    the mirrored rows A per coordinate and the tangent-plane rows R = [diag(n_d) D]_d,
    on C = P z + h."""
    forms, three = network.forms, np.identity(3)
    basis, held = system.basis.toarray(), system.held
    mass, energy = forms.mass.toarray(), forms.energy.toarray()
    difference, normals = planes
    rows = np.vstack([np.kron(three, mirrored.toarray()),
                      np.hstack([normals[:, [d]] * difference.toarray() for d in range(3)])])
    b = rows @ np.kron(three, basis)
    scale = np.mean(np.diag(mass) + lam * np.diag(energy))
    kkt = np.block([[np.kron(three, basis.T @ (mass + lam * energy) @ basis), scale * b.T],
                    [scale * b, -KKT_EPS * scale * np.identity(len(b))]])
    forms_rhs = basis.T @ (mass @ (forms.source - held) - lam * energy @ held)
    rhs = np.concatenate([forms_rhs.T.ravel(), -scale * rows @ held.T.ravel()])
    unknowns = basis.shape[1]
    z = np.linalg.solve(kkt, rhs)[:3 * unknowns].reshape(3, unknowns).T
    return basis @ z + held


@pytest.mark.parametrize("kept", [(), (0,)])
def test_the_schur_complement_solves_the_coupled_kkt_system_of_a_fan(kept):
    """At the fan vertex the tangent-plane rows couple x, y and z: the system factorizes
    one coordinate's KKT matrix and brings the plane rows in by their Schur complement.
    Its poles are those of a dense solve of the whole coupled system, to round-off, with
    and without a kept patch (whose poles the plane rows then hold on their right-hand
    side); and the edges from the vertex lie in its tangent plane."""
    patches, joins = _fan()
    network = PatchNetwork(patches, joins)
    system = _System(network.forms, set(kept), network.sides, "G1", network.spread,
                     network.vertices)
    assert np.array_equal(np.flatnonzero(system.fixed), np.arange(6 * 6 * len(kept)))  # no split
    _, mirrored, _, planes, g1_rows = _constraints(system, network.sides, "G1",
                                                   np.array([], dtype=int), network.vertices)
    difference, normals = planes
    assert g1_rows > 0 and difference.shape[0] == (1 if kept else 3)   # one per free edge
    assert np.all(np.abs(normals).max(axis=0) > 0.1)           # x, y and z coupled
    size = np.ptp(network.forms.source, axis=0).max()
    for lam in (0.0, 1e-3, 1.0):
        poles = system.solve(lam)
        assert np.abs(poles - _coupled_kkt_poles(network, system, mirrored, planes, lam)).max() \
            <= 1e-11 * size
        assert np.abs(np.einsum("rd,rd->r", normals, difference @ poles)).max() <= 1e-9 * size


def test_parts_joined_only_through_kept_patches_each_get_their_own_energy_weight():
    """The L of patch_network with its corner patch 0 kept: patches 1 and 2 meet only it,
    so they are independent parts, each with the largest weight within its own tolerance
    (a tight one on patch 1 does not hold back patch 2): each is the network solved with
    the other one kept too."""
    example = patch_network()
    tols = [0.01, 0.003, 0.01]
    both = fair_network(example.patches, example.joins, tols, kept=[0])
    assert both.kept == {0}
    alone = {part: fair_network(example.patches, example.joins, tols, kept=[0, other])
             for part, other in ((1, 2), (2, 1))}
    for part, result in alone.items():
        assert np.abs(both.surfaces[part].poles - result.surfaces[part].poles).max() \
            <= 1e-9 * 2.0
    assert alone[2].smoothing > 5 * alone[1].smoothing > 0
    assert both.smoothing == pytest.approx(alone[1].smoothing)


def test_forms_of_a_patch_on_any_domain_are_its_own():
    """The Gram matrices scaled from the unit interval against dense quadrature on the
    patch's own domain [0.5, 2] x [-1, 0.3]."""
    rng = np.random.default_rng(5)
    u_knots = np.r_[[0.5] * 4, 0.9, 1.4, [2.0] * 4]
    v_knots = np.r_[[-1.0] * 4, -0.2, [0.3] * 4]
    patch = BSplineSurface(rng.normal(size=(6, 5, 3)), u_knots, v_knots, 3, 3)
    forms = _Forms([patch])
    g = [[dense_gram(t, 3, t, 3, nu) for nu in (0, 1, 2)] for t in (u_knots, v_knots)]
    mass = np.kron(g[0][0], g[1][0])
    energy = np.kron(g[0][2], g[1][0]) + 2 * np.kron(g[0][1], g[1][1]) + np.kron(g[0][0], g[1][2])
    scaled = np.trace(mass) / np.trace(energy) * energy
    assert np.allclose(forms.mass.toarray(), mass, rtol=1e-9, atol=1e-12 * np.abs(mass).max())
    assert np.allclose(forms.energy.toarray(), scaled, rtol=1e-9,
                       atol=1e-12 * np.abs(scaled).max())


def _tangent_l(bump=0.02):
    """The L of patch_network without noise (its joins tangent: one C2 surface cut), with
    one pole bumped inside each patch, away from the rows next to its joins."""
    example = patch_network(noise=0.0)
    patches = []
    for patch, (i, j) in zip(example.patches, ((1, 1), (2, 1), (1, 2))):
        poles = patch.poles.copy()
        poles[i, j, 2] += bump
        patches.append(BSplineSurface(poles, patch.u_knots, patch.v_knots, 3, 3))
    return patches, example.joins


def test_a_network_tangent_in_the_source_gets_its_rows_where_closed_joins_turn():
    """Joins tangent in the source are first held closed only; closed alone, the L's
    joins turn more than the slack under the energy, so they get their mirrored rows and
    the patches move with no join turning more than the slack (without the rows they
    would be kept)."""
    patches, joins = _tangent_l()
    assert JoinTurns(patches, joins).tangent()
    assert not JoinTurns(patch_network().patches, joins).tangent()   # the noisy L
    result = fair_network(patches, joins, 0.01)
    assert not result.kept and result.smoothing > 0 and result.g1_rows > 0
    gap, angle = _joins_measured(result.surfaces, joins)
    assert gap <= 1e-9 * 2.0 and angle <= 0.05
    assert _dense_deviation(result.surfaces, patches).max() <= 0.01 * 1.02


def _constraints_one_by_one(system, network, split, held=None):
    """The constraints of :func:`_constraints` by the rules it states, one tie at a time
    with a union-find: the kept poles one held class; the joins' border poles tied pair
    after pair, a pair that joins two classes a G0 identity; the rows join after join
    (mirrored rows, those at a fan vertex left out, then the C2 rows of a cut), a row
    that joins two classes of its ends not joined yet kept.  ``(ties, rows, planes'
    pairs)``."""
    sides, vertices = network.sides, network.vertices
    g0 = UnionFind()
    for index in np.flatnonzero(system.fixed).tolist():
        g0.tie("held", index)
    apart = set(split.tolist())
    ties = [(a, b) for _, border_a, _, border_b, _, _ in sides
            for a, b in zip(border_a.tolist(), border_b.tolist())
            if a not in apart and b not in apart and g0.tie(a, b) is None]
    mirrored = {k for k, side in enumerate(sides) if side[0].smooth
                and (held is None or k in held)}
    fans, ratios = {}, [side[-1] for side in sides]
    if mirrored:
        ends = {vertices.along[k][e] for k in mirrored for e in (0, -1)}
        fans = {root: c for root, c in vertices.fans_among(system.fixed).items() if root in ends}
        ratios = _straightened(sides, vertices.crossings_among(system.fixed, fans))
    cycles, rows = UnionFind(), []
    for k, (join, border_a, inner_a, border_b, inner_b, _) in enumerate(sides):
        if not (join.cut or k in mirrored):
            continue
        for root, ia, na, ib, nb in zip(vertices.along[k], *(
                x.tolist() for x in (border_a, inner_a, border_b, inner_b))):
            if root not in fans and cycles.tie(g0.find(na)[0], g0.find(nb)[0]) is None:
                rows.append(dict(zip((na, ia, nb, ib), (1.0, -1.0, ratios[k], -ratios[k]))))
        if join.cut:
            for poles, values in _curvature_rows(network.forms, join, vertices):
                if cycles.tie(g0.find(poles[2])[0], g0.find(poles[5])[0]) is None:
                    rows.append(dict(zip(poles, values)))
    return ties, rows


@pytest.mark.parametrize("example, kept, held", [
    ("grid", (), None), ("grid", (0,), None), ("grid", (1, 2), {0, 2}),
    ("fan", (), None), ("fan", (0,), None), ("l", (), {1}), ("l", (0,), None)])
def test_the_constraints_are_those_of_ties_taken_one_at_a_time(example, kept, held):
    """The G0 identities and the rows kept, found for all at once (spanning forests),
    are those a union-find taking them one after the other keeps, in the same order:
    on the grid (its inner crossing; one join a cut of one surface, with its C2 rows),
    the fan (a vertex held in one tangent plane) and the L, with kept patches and with
    some joins held closed only."""
    if example == "fan":
        patches, joins = _fan()
    else:
        source = patch_grid() if example == "grid" else patch_network()
        patches, joins = source.patches, list(source.joins)
        if example == "grid":
            joins[1] = replace(joins[1], cut=True)
    network = PatchNetwork(patches, joins)
    system = _System(network.forms, set(kept), network.sides, "G1", network.spread,
                     network.vertices, held)
    split = np.array([], dtype=int)
    ties, mirrored, _, planes, g1_rows = _constraints(system, network.sides, "G1", split,
                                                      network.vertices, held)
    expected_ties, expected_rows = _constraints_one_by_one(system, network, split, held)
    assert [tuple(t) for t in np.asarray(ties).tolist()] == expected_ties
    assert g1_rows == len(expected_rows) == mirrored.shape[0] > 0
    for row, expected in zip(mirrored.tolil().rows, expected_rows):
        assert set(row) == set(expected)
    assert np.allclose(mirrored.toarray(), [
        [expected.get(c, 0.0) for c in range(mirrored.shape[1])] for expected in expected_rows])
    assert (planes[0].shape[0] > 0) == (example == "fan")


def test_many_right_hand_sides_are_solved_a_block_at_a_time_as_one():
    """``_solved`` takes the columns RHS_BLOCK at a time: the same solution as a dense
    solve, for a count of columns that is no multiple of the block."""
    rng = np.random.default_rng(7)
    matrix = sp.random(60, 60, density=0.1, random_state=8) + 10.0 * sp.identity(60)
    columns = rng.normal(size=(60, 3 * RHS_BLOCK + 5))
    solved = _solved(spla.splu(matrix.tocsc()), columns)
    assert np.allclose(solved, np.linalg.solve(matrix.toarray(), columns), rtol=1e-10,
                       atol=1e-12)



def test_a_patch_without_joins_is_a_network_of_its_own(grid):
    """No join, no row: the patch takes the largest weight within the tolerance, as a
    part of its own, and stays within it on the dense grid."""
    result = fair_network(grid.patches[:1], [], 0.01)
    assert result.smoothing > 0 and not result.kept and result.g1_rows == 0
    assert _dense_deviation(result.surfaces, grid.patches[:1]).max() <= 0.01 * 1.02
