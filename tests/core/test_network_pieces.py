"""Faces cut at T-junctions into pieces that meet side to side (core.network_pieces), and
the energy network faired across them (core.network_fairing): a brick layout of one
smooth surface, one wide patch under two narrow ones, with noise inside each patch."""

import numpy as np
import pytest

from cq_fairing.core.deviations import deviation
from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.joint_projection import Join, JoinSide, runs_reversed
from cq_fairing.core.network_fairing import fair_networks
from cq_fairing.core.network_pieces import lay_out_pieces
from cq_fairing.core.patch_grid import insert_knot
from cq_fairing.core.spaces import SplineSpace

TOL = 0.01
SIZE = 2.0   # the layout spans [0, 2]^2


def _truth(x, y):
    return np.stack([x, y, 0.3 * np.sin(2 * x) * np.cos(1.5 * y) + 0.1 * x * y], -1)


def bricks(noise=0.002, seed=3, below=False):
    """Patches of one bicubic fit of ``_truth`` on [0, 2]^2 (one span in x, two in y),
    each on [0, 1]^2: 0 the lower half (x in [0, 2]), 1 and 2 the upper half's left and
    right (cut at x = 1), and with ``below`` a patch 3 under patch 0 (y in [-1, 0], patch 0
    mirrored through its bottom border).  Noise on the z of every inner
    pole: the borders stay shared, the joins turn a little."""
    s = np.linspace(0.0, 2.0, 30)
    x_space = SplineSpace.from_knots(np.r_[[0.0] * 4, [2.0] * 4], 3)
    y_space = SplineSpace.from_knots(np.r_[[0.0] * 4, 1.0, [2.0] * 4], 3)
    fit_x, fit_y = (np.linalg.pinv(sp.collocation(s).toarray()) for sp in (x_space, y_space))
    net = np.einsum("ia,abd,jb->ijd", fit_x, _truth(*np.meshgrid(s, s, indexing="ij")),
                    fit_y)
    _, net = insert_knot(y_space.knots, 3, net.transpose(1, 0, 2), 1.0, 2)
    net = net.transpose(1, 0, 2)                        # 4 x 7: rows 0-3 below y = 1
    lower, upper = net[:, :4].copy(), net[:, 3:].copy()
    _, split = insert_knot(x_space.knots, 3, upper, 1.0, 3)
    left, right = split[:4].copy(), split[3:].copy()
    patches = [lower, left, right]
    if below:   # patch 0 mirrored through its bottom border: C1 across it
        patches.append(2.0 * lower[:, :1] - lower[:, ::-1])
    rng = np.random.default_rng(seed)
    bezier = np.r_[[0.0] * 4, [1.0] * 4]
    out = []
    for poles in patches:
        poles = poles.copy()
        poles[1:-1, 1:-1, 2] += rng.normal(0.0, noise, (2, 2))
        out.append(BSplineSurface(poles, bezier, bezier, 3, 3))
    return out


def brick_joins(below=False):
    """The layout's joins as a backend reads them: patch 0's top side meets patch 1 over
    its first half and patch 2 over its second (partial sides), 1 meets 2."""
    joins = [Join((JoinSide(0, 0, "v1", (0.0, 0.5), False), JoinSide(1, 0, "v0", (0.0, 1.0), True)),
                  "smooth", 0.0, 0.0),
             Join((JoinSide(0, 1, "v1", (0.5, 1.0), False), JoinSide(2, 1, "v0", (0.0, 1.0), True)),
                  "smooth", 0.0, 0.0),
             Join((JoinSide(1, 2, "u1", (0.0, 1.0), True), JoinSide(2, 2, "u0", (0.0, 1.0), True)),
                  "smooth", 0.0, 0.0)]
    if below:
        joins.append(Join((JoinSide(3, 3, "v1", (0.0, 1.0), True),
                           JoinSide(0, 3, "v0", (0.0, 1.0), True)), "smooth", 0.0, 0.0))
    return joins


def test_the_wide_patch_is_cut_at_the_t_junction_into_exact_pieces():
    sources = dict(enumerate(bricks()))
    layout = lay_out_pieces(sources, {0, 1, 2}, brick_joins(), dict.fromkeys(sources, TOL),
                            runs_reversed)
    assert [len(layout.grids[f]) for f in (0, 1, 2)] == [2, 1, 1]   # patch 0 cut in u
    assert all(len(layout.grids[f][0]) == 1 for f in (0, 1, 2))
    assert layout.held == set()
    cuts = [j for j in layout.joins if j.cut]
    assert len(cuts) == 1 and len(layout.joins) == 4
    t = np.linspace(0.0, 1.0, 9)
    for k in (p for row in layout.grids[0] for p in row):
        piece = layout.pieces[k]
        (u0, u1), _ = piece.domain
        u = np.linspace(u0, u1, 9)
        assert np.abs(piece.evaluate_grid(u, t) - sources[0].evaluate_grid(u, t)).max() \
            <= 1e-12 * SIZE
    first, second = (layout.pieces[row[0]] for row in layout.grids[0])
    assert first.domain[0] == (0.0, 0.5) and second.domain[0] == (0.5, 1.0)


def test_a_cut_runs_on_into_the_neighbour_across_the_far_side():
    """Patch 3 under patch 0 meets it along a whole side: the cut through the T-junction
    crosses patch 0 and goes on into patch 3, so that their pieces meet side to side."""
    sources = dict(enumerate(bricks(below=True)))
    layout = lay_out_pieces(sources, {0, 1, 2, 3}, brick_joins(below=True),
                            dict.fromkeys(sources, TOL), runs_reversed)
    assert len(layout.grids[3]) == 2 and layout.held == set()
    (_, right), = [layout.pieces[row[0]].domain[0] for row in layout.grids[3][:1]]
    assert right == pytest.approx(0.5, abs=1e-6)
    assert sum(j.cut for j in layout.joins) == 2
    joined = [j for j in layout.joins if {layout.faces[j.a], layout.faces[j.b]} == {0, 3}]
    assert len(joined) == 2


def test_a_join_outside_the_layout_holds_only_the_pieces_along_it():
    """Patch 2 is not laid out (it was faired alone): the piece of patch 0 under it and
    patch 1 beside it are held, the other piece of patch 0 may move."""
    sources = dict(enumerate(bricks()))
    layout = lay_out_pieces(sources, {0, 1}, brick_joins(), dict.fromkeys(sources, TOL),
                            runs_reversed)
    (first,), (second,) = layout.grids[0]
    assert layout.held == {second, layout.grids[1][0][0]}
    assert first not in layout.held


def test_the_bricks_are_faired_together_closed_smooth_and_c2_across_the_cut():
    """All three patches move; the T's borders stay one; patch 0 is C2 across its cut
    (as the source), but in the span where the cut meets the T-junction, where it is C1;
    no join turns more than the source's + 0.05 deg; every patch within TOL."""
    sources = dict(enumerate(bricks()))
    joins = brick_joins()
    calls = []

    def check(face, surface):
        calls.append(face)
        return deviation(sources[face], surface, method="geometric").max

    (network,) = fair_networks(sources, {0, 1, 2}, joins, dict.fromkeys(sources, TOL), check)
    assert network.moved == [0, 1, 2] and network.smoothing > 0
    assert len(network.joins) == 3
    faired = network.surfaces
    assert all(deviation(sources[f], s, method="geometric").max <= TOL
               for f, s in faired.items())
    lower = faired[0]
    assert np.count_nonzero(lower.u_knots == 0.5) == 3    # the cut: a knot of the degree
    t = np.linspace(0.0, 1.0, 41)
    for face, u in ((1, 0.5 * t), (2, 0.5 + 0.5 * t)):   # G0: the T's borders are one
        gap = lower.evaluate_grid(u, [1.0])[:, 0] - faired[face].evaluate_grid(t, [0.0])[:, 0]
        assert np.abs(gap).max() <= 1e-9 * SIZE
    # C1 across the cut, and C2 but in the span next to its end at the T-junction (v = 1)
    for order, v in ((1, np.linspace(0.0, 1.0, 11)), (2, np.linspace(0.0, 0.5, 6))):
        below = lower.evaluate_grid([0.5 - 1e-9], v, order, 0)
        above = lower.evaluate_grid([0.5 + 1e-9], v, order, 0)
        assert np.abs(below - above).max() <= 1e-6 * np.abs(below).max()
    for join in joins:                                   # G1: no more turn than the source
        a, b = join.sides
        ts = np.linspace(*a.along, 33)
        tb = np.linspace(*b.along, 33)
        before = _angles(sources, a, b, ts, tb)
        after = _angles(faired, a, b, ts, tb)
        assert np.max(after - before) <= 0.05


def _angles(surfaces, a, b, ta, tb):
    """Normal angles (degrees) between ``a``'s side at ``ta`` and ``b``'s at ``tb``."""
    normals = []
    for side, t in ((a, ta), (b, tb)):
        s = surfaces[side.face]
        (u0, u1), (v0, v1) = s.domain
        if side.side[0] == "u":
            grid = ([u0 if side.side[1] == "0" else u1], t)
        else:
            grid = (t, [v0 if side.side[1] == "0" else v1])
        n = np.cross(s.evaluate_grid(*grid, 1, 0), s.evaluate_grid(*grid, 0, 1)).reshape(-1, 3)
        normals.append(n / np.linalg.norm(n, axis=1)[:, None])
    cos = np.clip(np.abs(np.sum(normals[0] * normals[1], axis=1)), 0.0, 1.0)
    return np.degrees(np.arccos(cos))
