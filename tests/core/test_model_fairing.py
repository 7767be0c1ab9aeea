"""The whole-model steps of the core that every backend calls: patch grids faired as one
surface (core.grid_fairing) and faces at their coarsest faired together by energy
(core.network_fairing), on the example patch models with the core's own two-sided
deviation as the backend's check."""

import numpy as np

from cq_fairing.core.deviations import deviation
from cq_fairing.core.examples import patch_grid, patch_network
from cq_fairing.core.grid_fairing import RETRIES, fair_grids, grown_scales
from cq_fairing.core.joint_projection import Join, JoinSide
from cq_fairing.core.network_fairing import fair_networks, kept_reasons, kept_sentence
from tests.core.patch_references import grid_pieces, network_surfaces

TOL = 0.01
SIZE = 2.0   # the examples span [0, 2]^2


def _joins(example):
    """The example's border joins as a backend reads them: whole sides, smooth."""
    return [Join((JoinSide(j.a, k, j.side_a, (0.0, 1.0), True),
                  JoinSide(j.b, k, j.side_b, (1.0, 0.0) if j.reversed else (0.0, 1.0), True)),
                 "smooth", 0.0, 0.0)
            for k, j in enumerate(example.joins)]


def _checker(sources, calls):
    """A backend's check: the core's geometric deviation, each call recorded."""
    def check(face, surface):
        calls.append(face)
        return deviation(sources[face], surface, method="geometric").max
    return check


def _assert_same(surfaces, reference):
    for face, surface in surfaces.items():
        assert surface.shape == reference[face].shape
        assert np.abs(surface.poles - reference[face].poles).max() <= 1e-9 * SIZE


def test_a_grid_that_stands_alone_is_one_surface_cut_back():
    example = patch_grid()
    sources = dict(enumerate(example.patches))
    joins, calls = _joins(example), []
    grids = fair_grids(sources, joins, joins, dict.fromkeys(sources, TOL),
                       _checker(sources, calls))
    assert len(grids) == 1 and sorted(grids[0].faces) == [0, 1, 2, 3]
    assert sorted(grids[0].shape) == [2, 2]
    assert sorted(calls) == [0, 1, 2, 3]   # each piece checked once: within at once
    _assert_same(grids[0].surfaces, grid_pieces(TOL))


def test_a_grid_with_a_join_leading_out_is_left_to_the_other_steps():
    """Patch 3 also meets a face outside the grid (a neighbour without a tolerance):
    the block is no whole part of the model."""
    example = patch_grid()
    sources = dict(enumerate(example.patches))
    joins = _joins(example)
    outside = Join((JoinSide(3, 9, "u1", (0.0, 1.0), True),
                    JoinSide(4, 9, "u0", (0.0, 1.0), True)), "smooth", 0.0, 0.0)
    calls = []
    assert fair_grids(sources, joins + [outside], joins, dict.fromkeys(sources, TOL),
                      _checker(sources, calls)) == []
    assert calls == []


def test_a_grid_whose_pieces_miss_the_check_gets_a_finer_target():
    """A first round over the check: the block's target grows (the miss is unbounded:
    each direction's spans at most double, fewest poles first), and the block is kept
    when that round passes."""
    example = patch_grid()
    sources = dict(enumerate(example.patches))
    joins, calls = _joins(example), []
    (first,) = fair_grids(sources, joins, joins, dict.fromkeys(sources, TOL),
                          _checker(sources, []))
    measure = _checker(sources, calls)

    def first_over(face, surface):
        value = measure(face, surface)
        return np.inf if calls.count(face) == 1 else value

    (grid,) = fair_grids(sources, joins, joins, dict.fromkeys(sources, TOL), first_over)
    top = (first.merged.u_space.dimension - 3, first.merged.v_space.dimension - 3)
    assert grid.scales in grown_scales(first.scales, np.inf, top, (3, 3))
    assert np.prod(grid.faired.shape) > np.prod(first.faired.shape)
    assert sorted(calls) == [0, 0, 1, 1, 2, 2, 3, 3]
    assert all(deviation(sources[f], s).max <= TOL for f, s in grid.surfaces.items())


def test_a_missed_target_grows_by_the_miss_fewest_poles_first():
    """1 % over: one span more in each direction (1.01 ** (1 / 4) rounds up to the
    next span), alone first; 16 times over: the spans double (16 ** (1 / 4) = 2, the
    cap), capped by the largest scale; a kept direction stays."""
    assert grown_scales((3, 4), 1.01, (20, 20), (3, 3)) == [(3, 5), (4, 4), (4, 5)]
    assert grown_scales((3, 4), 16.0, (20, 6), (3, 3)) == [(3, 6), (6, 4), (6, 6)]
    assert grown_scales((3, None), np.inf, (20, None), (3, 3)) == [(6, None)]
    assert grown_scales((20, 6), 2.0, (20, 6), (3, 3)) == []


def test_a_grid_always_over_the_check_is_left_after_its_retries():
    example = patch_grid()
    sources = dict(enumerate(example.patches))
    joins, calls = _joins(example), []

    def over(face, surface):
        calls.append(face)
        return np.inf

    assert fair_grids(sources, joins, joins, dict.fromkeys(sources, TOL), over) == []
    rounds = calls.count(0)   # until the retries run out or no target is within
    assert 1 <= rounds <= RETRIES + 1 and sorted(calls) == sorted([0, 1, 2, 3] * rounds)


def test_faces_at_their_coarsest_are_one_network():
    example = patch_network()
    sources = dict(enumerate(example.patches))
    joins, calls = _joins(example), []
    networks = fair_networks(sources, {0, 1, 2}, joins, dict.fromkeys(sources, TOL),
                             _checker(sources, calls))
    assert len(networks) == 1 and networks[0].moved == [0, 1, 2] and networks[0].kept == []
    assert len(networks[0].joins) == 2 and networks[0].smoothing > 0
    _assert_same(networks[0].surfaces, dict(enumerate(network_surfaces(TOL))))
    assert all(deviation(sources[f], s).max <= TOL for f, s in networks[0].surfaces.items())


def test_a_face_with_a_join_outside_the_network_keeps_its_surface():
    """Face 2 was faired alone (not unchanged): the link 0-2 drops, so face 0, whose join
    with face 2 is no link, keeps its surface and constrains face 1."""
    example = patch_network()
    sources = dict(enumerate(example.patches))
    joins, calls = _joins(example), []
    networks = fair_networks(sources, {0, 1}, joins, dict.fromkeys(sources, TOL),
                             _checker(sources, calls))
    assert [n.moved for n in networks] == [[1]] and networks[0].kept == [0]
    assert set(calls) == {1}
    moved, t = networks[0].surfaces[1], np.linspace(0.0, 1.0, 11)
    border = moved.evaluate_grid([0.0], t) - sources[0].evaluate_grid([1.0], t)  # u0 / u1
    assert moved.shape == (5, 5) and np.abs(border).max() <= 1e-9 * SIZE


def test_a_kept_face_takes_the_worst_of_its_pieces_reasons():
    """Two pieces of face 5: a distance over the tolerance outweighs a turned join; a
    turned join alone names the faces across it, none across a cut between its own
    pieces; an infinite distance is a fold; a face whose pieces are planar is."""
    join_faces = [(5, 7), (5, 5), (9, 5)]
    both = kept_reasons({5: [0, 1]}, {0: ("turned", [0]), 1: ("tolerance", 0.2)},
                        [0.1, 0.1], join_faces)
    assert both == {5: ("tolerance", 0.2, 0.1)}
    turned = kept_reasons({5: [0, 1], 6: [2]}, {0: ("turned", [0, 2]), 1: ("turned", [1])},
                          [0.1, 0.1, 0.1], join_faces)
    assert turned == {5: ("turned", [7, 9])}   # face 6's piece kept for no reason: none
    assert "(with face 8, face 10)" in kept_sentence(turned[5])
    assert "between its own pieces" in kept_sentence(("turned", []))
    assert "stays 0.2 from its source" in kept_sentence(both[5])
    assert "folds" in kept_sentence(("tolerance", np.inf, 0.1))
    planar = kept_reasons({5: [0, 1], 6: [2]}, {0: ("planar",), 1: ("turned", [1]),
                                                2: ("planar",)}, [0.1, 0.1, 0.1], join_faces)
    assert planar == {5: ("turned", []), 6: ("planar",)}
    assert kept_sentence(planar[6]).startswith("planar")
