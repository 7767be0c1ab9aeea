"""The projection with pinned samples (cq_fairing.core.pinned_projection) against a dense
naive KKT solve, the plain projection, and a target that holds the source along an edge."""

import numpy as np
import pytest

from cq_fairing.core.geometry import BSplineSurface
from cq_fairing.core.pinned_projection import PinnedEdge, pin_deviation, pin_face, project_pinned
from cq_fairing.core.projection import project_surface
from cq_fairing.core.spaces import SplineSpace
from tests.core.naive import basis_matrix, dense_gram


def _source(rng, spans=(10, 9), rational=False, relief=0.02):
    """A smooth bicubic surface with a little random relief (and random weights)."""
    su, sv = (SplineSpace.quasi_uniform(n, 3) for n in spans)
    u, v = np.meshgrid(su.greville, sv.greville, indexing="ij")
    relief = relief * rng.standard_normal(u.shape)
    poles = np.stack([u, v, 0.3 * np.sin(3 * u) * np.cos(2 * v) + relief], axis=-1)
    weights = rng.uniform(0.9, 1.1, u.shape) if rational else None
    return BSplineSurface(poles + [5.0, -3.0, 2.0], su.knots, sv.knots, 3, 3, weights)


def _curve(t):
    return np.column_stack([0.1 + 0.8 * t, 0.25 + 0.5 * t ** 2])


@pytest.mark.parametrize("rational", [False, True])
def test_without_samples_it_is_the_plain_projection(rational):
    source = _source(np.random.default_rng(1), (8, 8), rational)
    target = tuple(SplineSpace.quasi_uniform(n, 3) for n in (4, 2))
    pinned = project_pinned(source, target, np.zeros((0, 2)), np.zeros(0, bool))
    plain = project_surface(source, *target).surface
    assert np.abs(pinned.poles - plain.poles).max() <= 1e-11
    if rational:
        assert np.abs(pinned.weights - plain.weights).max() <= 1e-11


def test_matches_a_dense_naive_kkt_solve():
    """min |T - S|^2 in L2 under T = S and n.T_u = n.T_v = 0 at the samples: the dense
    KKT system [[G, C^T], [C, 0]] (scipy's basis functions, Gauss quadrature), solved by
    numpy, gives the same poles."""
    source = _source(np.random.default_rng(2))
    target = tuple(SplineSpace.quasi_uniform(n, 3) for n in (5, 4))
    uv = _curve(np.linspace(0.0, 1.0, 6))
    pinned = project_pinned(source, target, uv, np.ones(len(uv), bool), lever=0.3)

    (tu, tv), (su, sv) = target, (source.u_space, source.v_space)
    gram = np.kron(dense_gram(tu.knots, 3, tu.knots, 3), dense_gram(tv.knots, 3, tv.knots, 3))
    mixed = np.kron(dense_gram(tu.knots, 3, su.knots, 3), dense_gram(tv.knots, 3, sv.knots, 3))
    count = gram.shape[0]
    a = np.kron(np.eye(3), gram)
    b = np.concatenate([mixed @ source.poles[..., k].ravel() for k in range(3)])

    def rows(nu, nv):
        bu, bv = (basis_matrix(s.knots, 3, x, n) for s, x, n in ((tu, uv[:, 0], nu),
                                                                  (tv, uv[:, 1], nv)))
        return np.einsum("ni,nj->nij", bu, bv).reshape(len(uv), -1)

    def source_at(nu, nv):
        bu, bv = (basis_matrix(s.knots, 3, x, n) for s, x, n in ((su, uv[:, 0], nu),
                                                                  (sv, uv[:, 1], nv)))
        return np.einsum("ni,nj,ijk->nk", bu, bv, source.poles)

    normal = np.cross(source_at(1, 0), source_at(0, 1))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    c = [np.kron(np.eye(3)[k], rows(0, 0)) for k in range(3)]
    c += [np.hstack([normal[:, k:k + 1] * rows(*d) for k in range(3)]) for d in ((1, 0), (0, 1))]
    c = np.vstack(c)
    d = np.concatenate([source_at(0, 0)[:, k] for k in range(3)] + [np.zeros(2 * len(uv))])
    kkt = np.block([[a, c.T], [c, np.zeros((len(c), len(c)))]])
    naive = np.linalg.lstsq(kkt, np.concatenate([b, d]), rcond=None)[0][:3 * count]
    poles = np.moveaxis(naive.reshape(3, tu.dimension, tv.dimension), 0, -1)
    assert np.abs(pinned.poles - poles).max() <= 1e-8
    gap, angle = pin_deviation(pinned, source, uv, np.ones(len(uv), bool))
    assert gap <= 1e-10 and angle <= 1e-7


@pytest.mark.parametrize("rational", [False, True])
def test_a_target_that_holds_the_edge_pins_it_exactly(rational):
    """Along the iso-line v = 0.5, a breakpoint of both targets, the target's u space is
    the source's: the edge is held everywhere along it, not only at the samples, and the
    tangent plane (pinned in its normal component at the samples only) to a small angle
    between them; the target stays the L2 projection elsewhere (its deviation from the
    source is about the plain projection's)."""
    source = _source(np.random.default_rng(3), (6, 8), rational, relief=0.002)
    target = (source.u_space, SplineSpace.quasi_uniform(2, 3))
    edge = PinnedEdge(lambda t: np.column_stack([t, np.full(len(t), 0.5)]), True)
    outcome = pin_face(source, target, [edge], gap=1e-9, angle=0.025, refinements=0)
    assert outcome.met and outcome.refined == 0
    dense = np.linspace(0.0, 1.0, 997)
    gap, angle = pin_deviation(outcome.surface, source, edge.uv(dense), np.ones(997, bool))
    assert gap <= 1e-9 and angle <= 0.025
    grid = np.linspace(0.0, 1.0, 41)
    plain = project_surface(source, *target).surface
    moved, alone = (np.abs(s.evaluate_grid(grid, grid) - source.evaluate_grid(grid, grid)).max()
                    for s in (outcome.surface, plain))
    assert moved <= 3.0 * alone


def test_a_coarse_target_gets_finer_until_the_edge_holds():
    """A target too coarse for the samples' residual is refined (spans halved) until the
    edge holds, and the outcome reports what it measured."""
    source = _source(np.random.default_rng(4), (8, 16))
    target = tuple(SplineSpace.quasi_uniform(1, 3) for _ in range(2))
    edge = PinnedEdge(lambda t: np.column_stack([t, np.full(len(t), 0.5)]), False)
    outcome = pin_face(source, target, [edge], gap=1e-9, angle=0.05, refinements=3)
    assert outcome.met and outcome.refined == 3      # 8 spans in u: the source's own
    assert outcome.gap <= 1e-9
    short = pin_face(source, target, [edge], gap=1e-9, angle=0.05, refinements=1)
    assert not short.met and short.gap > 1e-9
