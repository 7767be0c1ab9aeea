"""OCCT's deviation check against brute force: the largest distances are measured again."""

import numpy as np

import cq_fairing as cf
from cq_fairing.occ.convert import to_geom_surface
from cq_fairing.occ.deviation import _refine_largest


def test_the_largest_upper_bounds_are_measured_again_down_to_a_true_maximum():
    """Points above a bicubic bump carry upper bounds of their distance (the distance to a
    wrong point of the surface, as a Newton run stuck at another extremum gives).  After
    the refinement the largest value is a true distance (brute force on a dense grid of
    the surface), no value is below its true distance, and samples whose bound is below
    the final maximum keep their bound (the walk stops early)."""
    rng = np.random.default_rng(4)
    u = np.linspace(0.0, 1.0, 6)
    grid = np.stack(list(np.meshgrid(u, u, indexing="ij")), axis=-1)
    z = 0.3 * np.sin(3 * grid[..., 0]) * np.cos(2 * grid[..., 1])
    surface = cf.make_surface(np.concatenate([grid, z[..., None]], axis=-1))
    dense = surface.evaluate_grid(np.linspace(0, 1, 600), np.linspace(0, 1, 600)).reshape(-1, 3)
    points = np.column_stack([rng.uniform(0.1, 0.9, (40, 2)), rng.uniform(-0.5, 0.5, 40)])
    true = np.array([np.linalg.norm(dense - p, axis=1).min() for p in points])
    wrong = surface.evaluate_grid(np.array([0.0]), np.array([0.0]))[0, 0]   # a corner
    projected = np.tile(wrong, (points.shape[0], 1))
    bound = np.linalg.norm(points - wrong, axis=1)
    distance = bound.copy()
    geom = to_geom_surface(surface)
    _refine_largest(geom, points, distance, projected)
    assert np.all(distance >= true - 1e-4)             # dense grid: 1e-4 is its spacing
    k = int(np.argmax(distance))
    assert distance[k] <= true[k] + 1e-9 and distance[k] < bound[k]
    untouched = bound < distance.max()
    assert untouched.any() and np.array_equal(distance[untouched], bound[untouched])
    np.testing.assert_allclose(np.linalg.norm(projected - points, axis=1), distance)
