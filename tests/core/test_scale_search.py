"""The face search's sampler against independent evaluations: its sparse grid products
equal the surface's own grid and derivative evaluation, on polynomial and rational nets,
and the one-thread product equals numpy's."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cq_fairing as cf
from cq_fairing.core.evaluation import surface_derivatives
from cq_fairing.core.geometry import one_thread_product
from cq_fairing.core.plans import target_space
from cq_fairing.core.scale_search import SurfaceSampler, project, search_scales


def _surface(rational, seed=3):
    """A bumpy 9 x 7 net of degrees (3, 2), with weights in [0.5, 2] when ``rational``."""
    rng = np.random.default_rng(seed)
    u, v = np.meshgrid(np.linspace(0, 4, 9), np.linspace(0, 3, 7), indexing="ij")
    poles = np.stack([u, v, 0.4 * np.sin(u) * np.cos(2 * v) + 0.1 * rng.normal(size=u.shape)],
                     axis=-1)
    weights = rng.uniform(0.5, 2.0, u.shape) if rational else None
    return cf.make_surface(poles, degree=(3, 2), weights=weights)


def _sampler_grid(surface, seed=5):
    """Uneven samples over the domain and a random mask of those on the face."""
    rng = np.random.default_rng(seed)
    (u0, u1), (v0, v1) = surface.domain
    u = np.sort(np.r_[u0, rng.uniform(u0, u1, 23), u1])
    v = np.sort(np.r_[v0, rng.uniform(v0, v1, 17), v1])
    return u, v, rng.random((u.size, v.size)) < 0.7


@pytest.mark.parametrize("rational", [False, True])
def test_the_samplers_points_are_the_surfaces_own_grid(rational):
    """``evaluate`` (sparse ``M_u P M_v^T``, homogeneous then divided) equals
    ``evaluate_grid`` on the samples inside the mask, for the source and another net."""
    surface = _surface(rational)
    grid = _sampler_grid(surface)
    sampler = SurfaceSampler(grid, surface)
    u, v, inside = grid
    np.testing.assert_allclose(sampler.reference, surface.evaluate_grid(u, v)[inside],
                               rtol=0, atol=1e-12)
    other = _surface(rational, seed=8)
    np.testing.assert_allclose(sampler.evaluate(other), other.evaluate_grid(u, v)[inside],
                               rtol=0, atol=1e-12)
    expected = np.linalg.norm(other.evaluate_grid(u, v)[inside] - sampler.reference, axis=1)
    assert sampler.parametric(other) == pytest.approx(expected.max(), abs=1e-12)


@pytest.mark.parametrize("rational", [False, True])
def test_the_normal_estimate_is_the_distance_to_the_tangent_planes(rational):
    """``normal`` against the tangent planes of the Taylor-form derivatives
    (:func:`surface_derivatives`, quotient rule applied): :math:`\\max_i |(p_i - S)
    \\cdot n| / |n|` with :math:`n = S_u \\times S_v` at each sample's parameters."""
    surface, faired = _surface(rational), _surface(rational, seed=8)
    grid = _sampler_grid(surface)
    sampler = SurfaceSampler(grid, surface)
    u, v, inside = grid
    uu, vv = (x[inside] for x in np.meshgrid(u, v, indexing="ij"))
    d = surface_derivatives(faired, uu, vv, 1)
    normal = np.cross(d[(1, 0)], d[(0, 1)])
    offset = surface_derivatives(surface, uu, vv, 0)[(0, 0)] - d[(0, 0)]
    expected = np.abs(np.einsum("ij,ij->i", offset, normal)) / np.linalg.norm(normal, axis=1)
    assert sampler.normal(faired) == pytest.approx(expected.max(), rel=1e-10)
    assert sampler.normal(faired) < sampler.parametric(faired)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 300), st.integers(1, 200), st.integers(1, 40), st.integers(1, 4),
       st.integers(0, 2 ** 32 - 1))
def test_the_one_thread_product_is_numpys(rows, terms, columns, dim, seed):
    """Column chunks small enough for one OpenBLAS thread give numpy's tensordot."""
    rng = np.random.default_rng(seed)
    a, b = rng.normal(size=(rows, terms)), rng.normal(size=(terms, columns, dim))
    np.testing.assert_allclose(one_thread_product(a, b), np.tensordot(a, b, axes=(1, 0)),
                               rtol=1e-12, atol=1e-12 * terms)


def test_where_the_normal_vanishes_the_estimate_is_the_parametric_distance():
    """A net with its first u-row collapsed to one point (a sphere's pole): there
    :math:`S_u \\times S_v = 0`, so those samples count their parametric distance, the
    others their distance to the tangent plane, computed here from the Taylor-form
    derivatives."""
    surface, faired = _surface(False), _surface(False, seed=8)
    poles = faired.poles.copy()
    poles[0] = poles[0].mean(axis=0)
    faired = cf.make_surface(poles, faired.u_knots, faired.v_knots, (3, 2))
    grid = _sampler_grid(surface)
    u, v, inside = grid
    uu, vv = (x[inside] for x in np.meshgrid(u, v, indexing="ij"))
    d = surface_derivatives(faired, uu, vv, 1)
    normal = np.cross(d[(1, 0)], d[(0, 1)])
    length = np.linalg.norm(normal, axis=1)
    offset = surface_derivatives(surface, uu, vv, 0)[(0, 0)] - d[(0, 0)]
    degenerate = length <= 1e-12 * length.max()
    assert degenerate.any() and not degenerate.all()
    expected = np.where(degenerate, np.linalg.norm(offset, axis=1),
                        np.abs(np.einsum("ij,ij->i", offset, normal)) /
                        np.where(degenerate, 1.0, length))
    assert SurfaceSampler(grid, surface).normal(faired) == pytest.approx(expected.max(),
                                                                          rel=1e-10)


def test_a_family_bounded_by_another_winner_measures_only_fewer_poles():
    """``search_scales(..., fewer_than=b)`` measures no candidate with ``b`` or more
    poles, and gives either ``None`` or a candidate with fewer than ``b`` poles within
    tol; with ``b`` one above the full search's winner it finds that winner."""
    surface = _surface(False)
    (u0, u1), (v0, v1) = surface.domain
    grid = (np.linspace(u0, u1, 40), np.linspace(v0, v1, 30), np.ones((40, 30), bool))
    sampler = SurfaceSampler(grid, surface)
    coarsest = project(surface, target_space(surface.u_space, 1, 3),
                       target_space(surface.v_space, 1, 2))
    tol = 0.3 * sampler.parametric(coarsest)
    full = search_scales(surface, tol, (3, 2), sampler.parametric)
    winner = full[1].shape[0] * full[1].shape[1]
    for bound in (winner + 1, winner, winner - 1):
        seen = []

        def measured(faired):
            seen.append(faired.shape[0] * faired.shape[1])
            return sampler.parametric(faired)

        found = search_scales(surface, tol, (3, 2), measured, fewer_than=bound)
        assert all(poles < bound for poles in seen)
        if found is not None:
            assert found[1].shape[0] * found[1].shape[1] < bound and found[2] <= tol
        if bound == winner + 1:
            assert found is not None and found[1].shape == full[1].shape
            assert len(seen) < full[3]
