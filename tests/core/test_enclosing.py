"""The smallest enclosing ball, checked by its optimality condition: the centre of the
smallest ball is a convex combination of the points on its sphere (the minimax
problem is convex, so that condition is also sufficient)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import nnls

from cq_fairing.core.enclosing import smallest_enclosing_ball

coordinates = st.floats(-1.0, 1.0, allow_nan=False)
clouds = st.lists(st.tuples(coordinates, coordinates, coordinates), min_size=1, max_size=25)


def _in_hull_of_farthest(points, centre, radius):
    """Residual of the best convex combination of the points on the sphere that gives
    the centre, in units of the cloud's spread around its first point (non-negative
    least squares, the weights' sum as a heavily weighted extra row).  On the sphere:
    to 1e-7 of the spread, and to the round-off of the coordinates (a few spacings of
    doubles at their magnitude: the centre itself is rounded to them)."""
    spread = np.ptp(points, axis=0).max()
    round_off = 4 * np.spacing(np.abs(points).max()) / spread
    local, middle = (points - points[0]) / spread, (centre - points[0]) / spread
    far = local[np.linalg.norm(local - middle, axis=1) >= radius / spread - 1e-7 - round_off]
    rows = np.vstack([far.T, 1e3 * np.ones(len(far))])
    return nnls(rows, np.append(middle, 1e3))[1] - round_off


@settings(max_examples=200, deadline=None)
@given(clouds, st.sampled_from([1.0, 1e-6]), st.sampled_from([0.0, 2.2e4]))
def test_the_ball_contains_every_point_and_its_centre_is_in_the_hull_of_the_farthest(
        cloud, scale, offset):
    """Also for small clouds far from the origin: corners of a model 2.2e4 away spread
    over 1e-6."""
    points = offset + scale * np.array(cloud)
    centre, radius = smallest_enclosing_ball(points)
    assert radius == np.linalg.norm(points - centre, axis=1).max()
    if np.ptp(points, axis=0).max() > 0:
        assert _in_hull_of_farthest(points, centre, radius) <= 1e-6
    else:
        assert radius == 0.0


@given(clouds)
def test_no_point_of_the_cloud_and_not_its_box_centre_covers_it_with_less(cloud):
    points = np.array(cloud)
    _, radius = smallest_enclosing_ball(points)
    box_centre = 0.5 * (points.min(axis=0) + points.max(axis=0))
    for candidate in [*points, box_centre, points.mean(axis=0)]:
        assert radius <= np.linalg.norm(points - candidate, axis=1).max() + 1e-12


def test_two_points_give_their_midpoint_and_a_right_triangle_its_hypotenuse():
    centre, radius = smallest_enclosing_ball([[0, 0, 0], [2, 0, 0]])
    np.testing.assert_allclose(centre, [1, 0, 0])
    assert radius == pytest.approx(1.0)
    centre, radius = smallest_enclosing_ball([[0, 0, 0], [4, 0, 0], [0, 3, 0], [1, 1, 0]])
    np.testing.assert_allclose(centre, [2, 1.5, 0], atol=1e-15)
    assert radius == pytest.approx(2.5)
