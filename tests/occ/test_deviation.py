"""OCCT's deviation check against brute force: the largest distances are measured again,
and the way back from the faired face too."""

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.occ.builders import surface_to_natural_face
from cq_fairing.occ.convert import to_geom_surface
from cq_fairing.occ.deviation import _refine_largest, sample_face_deviation
from tests.occ.helpers import global_distance


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


def test_a_faired_face_reaching_beyond_the_original_is_measured_on_the_way_back():
    """The faired patch covers the original and half a unit more (x up to 10.5 where the
    original ends at 10): every original point lies on it (the way there is 0), but its
    own points reach 0.5 beyond.  The check measures both ways, as OCCT's own projection
    of the faired points onto the original finds."""
    u = np.linspace(0.0, 1.0, 4)
    grid = np.stack(list(np.meshgrid(u, u, indexing="ij")), axis=-1)

    def patch(length):
        net = np.concatenate([grid * [length, 1.0], np.zeros((4, 4, 1))], axis=-1)
        return surface_to_natural_face(cf.make_surface(net))

    original, faired = patch(10.0), patch(10.5)
    samples = sample_face_deviation(original, faired, density=21)
    assert samples["distance"].max() <= 1e-9
    independent = global_distance(samples["faired_points"], original)
    beyond = samples["faired_points"][:, 0] > 10.0
    independent[beyond] = samples["faired_points"][beyond, 0] - 10.0   # nearest: the end x = 10
    np.testing.assert_allclose(samples["distance_back"], independent, atol=1e-9)
    assert samples["max"] == pytest.approx(0.5)
