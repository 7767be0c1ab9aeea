"""Grid recovery from joins (core.patch_layout): placements checked by merging for real."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cq_fairing.core.examples import patch_grid
from cq_fairing.core.joins import BorderJoin
from cq_fairing.core.patch_grid import merge_grid
from cq_fairing.core.patch_layout import ORIENTATIONS, Placement, find_grids


def test_the_example_grid_is_found_whole_with_its_mixed_orientations():
    grid = patch_grid()
    blocks = find_grids(grid.patches, grid.joins)
    assert [b.shape for b in blocks] in ([(2, 2)],)
    block = blocks[0]
    assert sorted(block.patches) == [0, 1, 2, 3]
    oriented = [[c.to_grid(grid.patches[c.patch]) for c in column] for column in block.cells]
    merged = merge_grid(oriented, tol=1e-6)      # refuses borders that do not meet
    assert merged.border_gap < 1e-6
    # every patch is the merged surface on its cell, point for point
    t = np.linspace(0.0, 1.0, 7)
    for i, column in enumerate(block.cells):
        for j, cell in enumerate(column):
            own = cell.to_grid(grid.patches[cell.patch])
            uu, vv = merged.merged_parameters(i, j, t, t)
            expected = own.evaluate_grid(t, t)
            got = merged.surface.evaluate_grid(uu, vv)
            assert np.abs(got - expected).max() < 1e-6


@settings(max_examples=24, deadline=None)
@given(st.sampled_from(ORIENTATIONS), st.integers(0, 3))
def test_from_grid_undoes_to_grid(orientation, which):
    patch = patch_grid().patches[which]
    placement = Placement(0, *orientation)
    back = placement.from_grid(placement.to_grid(patch))
    t = np.linspace(0.0, 1.0, 9)
    assert np.abs(back.evaluate_grid(t, t) - patch.evaluate_grid(t, t)).max() < 1e-12


@settings(max_examples=40, deadline=None)
@given(st.lists(st.sampled_from(ORIENTATIONS), min_size=6, max_size=6), st.integers(0, 5))
def test_a_3_x_2_grid_of_any_orientations_is_recovered(orientations, seed):
    """Cut one surface into 3 x 2 patches, reorient each at random, describe the joins
    as a reader of a model would (sides and reversal), and find the grid again."""
    truth = patch_grid(noise=0.0).patches[0]
    pieces = {}
    for i in range(3):
        for j in range(2):
            pieces[(i, j)] = _sub_patch(truth, i / 3, (i + 1) / 3, j / 2, (j + 1) / 2)
    placements = {cell: Placement(k, *orientations[k]) for k, cell in enumerate(sorted(pieces))}
    patches = [None] * 6
    for cell, placement in placements.items():
        patches[placement.patch] = placement.from_grid(pieces[cell])
    joins = []
    for (i, j), placement in placements.items():
        for direction, other_cell in (("E", (i + 1, j)), ("N", (i, j + 1))):
            other = placements.get(other_cell)
            if other is None:
                continue
            side, forward = placement.side(direction)
            other_side, other_forward = other.side({"E": "W", "N": "S"}[direction])
            joins.append(BorderJoin(placement.patch, side, other.patch, other_side,
                                    forward != other_forward))
    rng = np.random.default_rng(seed)
    rng.shuffle(joins)
    blocks = find_grids(patches, joins)
    assert len(blocks) == 1 and sorted(blocks[0].patches) == list(range(6))
    oriented = [[c.to_grid(patches[c.patch]) for c in column] for column in blocks[0].cells]
    assert merge_grid(oriented, tol=1e-9).border_gap < 1e-9


def test_patches_whose_knots_differ_along_a_join_are_not_merged():
    grid = patch_grid()
    finer = patch_grid(poles=13).patches[1]      # other knots along the shared side
    blocks = find_grids([grid.patches[0], finer, grid.patches[2], grid.patches[3]], grid.joins)
    # the rest is an L of three patches: one rectangle of two, the third alone
    assert [sorted(b.patches) for b in blocks] in ([[0, 2]], [[2, 3]])


def _sub_patch(surface, u0, u1, v0, v1):
    """The part of ``surface`` on [u0, u1] x [v0, v1], refit exactly on [0, 1]^2 (a
    bicubic of one span per patch is the Bezier piece, which a 4 x 4 fit reproduces)."""
    from cq_fairing.core.geometry import BSplineSurface
    s = np.linspace(0.0, 1.0, 4)
    basis = np.array([[1, 0, 0, 0], [-3, 3, 0, 0], [3, -6, 3, 0], [-1, 3, -3, 1]], float)
    powers = np.vander(s, 4, increasing=True)
    to_bezier = np.linalg.inv(powers @ basis)
    points = surface.evaluate_grid(u0 + (u1 - u0) * s, v0 + (v1 - v0) * s)
    net = np.einsum("ia,abd,jb->ijd", to_bezier, points, to_bezier)
    knots = np.array([0, 0, 0, 0, 1, 1, 1, 1], float)
    return BSplineSurface(net, knots, knots, 3, 3)


# -- the pinned projection of a merged grid ------------------------------------------------
def _merged_example():
    grid = patch_grid()
    block = find_grids(grid.patches, grid.joins)[0]
    return merge_grid([[c.to_grid(grid.patches[c.patch]) for c in column]
                       for column in block.cells], tol=1e-6)


def _gauss(breaks, count=8):
    """Gauss-Legendre nodes and weights on every interval of ``breaks``: exact for the
    piecewise polynomials of degree up to 2 count - 1 between them."""
    x, w = np.polynomial.legendre.leggauss(count)
    nodes = [0.5 * (b - a) * x + 0.5 * (a + b) for a, b in zip(breaks[:-1], breaks[1:])]
    weights = [0.5 * (b - a) * w for a, b in zip(breaks[:-1], breaks[1:])]
    return np.concatenate(nodes), np.concatenate(weights)


def _dense_pinned(merged, tu, tv, weight):
    """The same least-squares problem as one dense weighted system on quadrature points
    (exact: Gauss nodes between the union of the target's and the source's knots)."""
    axes = []
    for target, source in ((tu, merged.surface.u_space), (tv, merged.surface.v_space)):
        axes.append(_gauss(np.union1d(target.breakpoints, source.breakpoints)))
    (uq, uw), (vq, vw) = axes
    rows, rhs, wts = [], [], []

    def add(u, v, w):
        bu, bv = tu.collocation(u).toarray(), tv.collocation(v).toarray()
        rows.append(np.einsum("ia,jb->ijab", bu, bv).reshape(len(u) * len(v), -1))
        rhs.append(merged.surface.evaluate_grid(u, v).reshape(-1, 3))
        wts.append(w.reshape(-1))

    add(uq, vq, np.outer(uw, vw))
    add(merged.u_breaks, vq, weight * np.outer(np.ones(merged.u_breaks.size), vw))
    add(uq, merged.v_breaks, weight * np.outer(uw, np.ones(merged.v_breaks.size)))
    root = np.sqrt(np.concatenate(wts))[:, None]
    solution = np.linalg.lstsq(np.concatenate(rows) * root, np.concatenate(rhs) * root,
                               rcond=None)[0]
    return solution.reshape(tu.dimension, tv.dimension, 3)


@pytest.mark.parametrize("weight", [0.0, 1.0, 10.0, 1000.0])
def test_pinned_projection_solves_the_line_weighted_least_squares_problem(weight):
    from cq_fairing.core.spaces import SplineSpace
    merged = _merged_example()
    tu = SplineSpace.quasi_uniform(6, 3, merged.surface.domain[0])
    tv = SplineSpace.quasi_uniform(5, 3, merged.surface.domain[1])
    got = merged.pinned_projection(tu, tv, weight).poles
    assert np.abs(got - _dense_pinned(merged, tu, tv, weight)).max() < 1e-9


def test_a_heavier_pin_never_moves_the_patch_borders_further():
    """The line misfit of a weighted least-squares solution cannot grow with its weight."""
    from cq_fairing.core.spaces import SplineSpace
    merged = _merged_example()
    tu = SplineSpace.quasi_uniform(3, 3, merged.surface.domain[0])
    tv = SplineSpace.quasi_uniform(3, 3, merged.surface.domain[1])
    u, wu = _gauss(np.union1d(tu.breakpoints, merged.surface.u_space.breakpoints))
    v, wv = _gauss(np.union1d(tv.breakpoints, merged.surface.v_space.breakpoints))

    def line_misfit(surface):
        total = 0.0
        for a, b, w in ((merged.u_breaks, v, wv), (u, merged.v_breaks, wu)):
            error = np.sum((surface.evaluate_grid(a, b) - merged.surface.evaluate_grid(a, b))
                           ** 2, axis=-1)
            total += float(np.sum(error * (w[None, :] if a is merged.u_breaks else w[:, None])))
        return total

    misfits = [line_misfit(merged.pinned_projection(tu, tv, w)) for w in (0.0, 1.0, 10.0, 100.0)]
    assert all(b <= a * (1 + 1e-9) for a, b in zip(misfits, misfits[1:]))
    assert misfits[-1] < 0.5 * misfits[0]
