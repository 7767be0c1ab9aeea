"""Energy fairing of a patch network (core.network) on the noisy 2 x 2 grid of
core.examples.patch_grid: joins measured with scipy's bases (tests.core.naive),
deviation on a dense grid, against the sources and the joint projection."""

import numpy as np
import pytest

from cq_fairing.core.examples import patch_grid
from cq_fairing.core.joins import BorderJoin
from cq_fairing.core.network import fair_network, network_joinable
from cq_fairing.errors import InvalidInputError

from .naive import basis_matrix
from .test_joins import _joins_measured


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
