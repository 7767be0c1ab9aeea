"""Point files: a run, a grid of scan lines or a scattered cloud; a cloud as a height field."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import cq_fairing as cf
from tests.conftest import data_path


def test_a_run_a_grid_of_scan_lines_and_a_scan_are_told_apart():
    """A helix is one run; rows of a grid written one after another are a grid (the
    step back to the next row's start is a jump); the real scan of a face
    (01_points.asc, scan lines of unequal length) is scattered, as is every 20th of it."""
    t = np.linspace(0.0, 4 * np.pi, 300)
    assert cf.classify_points(np.c_[np.cos(t), np.sin(t), 0.1 * t]) == ("curve", None)
    u, v = np.meshgrid(np.linspace(0, 5, 6), np.linspace(0, 8, 9), indexing="ij")
    grid = np.stack([u, v, np.sin(u) * np.cos(v / 3)], axis=-1)
    assert cf.classify_points(grid.reshape(-1, 3)) == ("grid", (6, 9))
    scan = np.loadtxt(data_path("01_points.asc"))
    assert cf.classify_points(scan)[0] == cf.classify_points(scan[::20])[0] == "scattered"


@given(seed=st.integers(0, 2**31 - 1), shape=st.tuples(st.integers(2, 12), st.integers(2, 12)))
@settings(max_examples=25, deadline=None)
def test_a_plane_resampled_as_a_height_field_stays_the_plane(seed, shape):
    """Scattered points of a tilted plane: every grid point lies on the plane (linear
    interpolation on the triangulation reproduces it; cells outside the hull take the
    nearest point's height, also on the plane since the frame is the plane's own), and
    the grid spans the points' extent along the plane."""
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-5.0, 5.0, (200, 2))
    points = np.c_[xy, 0.3 * xy[:, 0] - 0.2 * xy[:, 1] + 1.0]
    grid, outside = cf.resample_height_field(points, shape)
    assert grid.shape == shape + (3,) and 0 <= outside <= shape[0] * shape[1]
    residual = grid[..., 2] - (0.3 * grid[..., 0] - 0.2 * grid[..., 1] + 1.0)
    assert np.abs(residual).max() < 1e-9
    _, _, axes = np.linalg.svd(points - points.mean(axis=0))
    for axis in axes[:2]:   # the grid spans the points along both in-plane axes
        along, at = points @ axis, grid.reshape(-1, 3) @ axis
        assert np.allclose([at.min(), at.max()], [along.min(), along.max()], atol=1e-9)


def test_resampling_refuses_a_line_and_a_grid_below_two_points():
    line = np.outer(np.linspace(0.0, 1.0, 50), [1.0, 2.0, 3.0])
    with pytest.raises(cf.InvalidInputError, match="lie on a line"):
        cf.resample_height_field(line, (10, 10))
    square = np.random.default_rng(0).uniform(size=(50, 3))
    with pytest.raises(cf.InvalidInputError, match="integers of at least 2"):
        cf.resample_height_field(square, (1, 10))


_CLOUD = np.random.default_rng(3).uniform(size=(50, 3))


@pytest.mark.parametrize("points, fragment", [
    (np.arange(10.0), "shape (k, d)"), (None, "shape (k, d)"), ("abc", "numeric array"),
    (np.zeros((0, 3)), "at least 2 points, got 0"), (np.zeros((1, 3)), "at least 2 points, got 1"),
    (np.r_[_CLOUD, [[0.0, np.nan, 0.0]]], "NaN or inf (first at index (50, 1))"),
    (_CLOUD[:, :2], "3 coordinates (x y z) each, got 2")])
@pytest.mark.filterwarnings("error")
def test_classify_points_refuses_what_is_not_two_or_more_finite_points(points, fragment):
    """A 1-D array, None, text, fewer than 2 points, NaN and (N, 2) arrays raise
    InvalidInputError naming the problem (they used to raise numpy errors, or come back
    "curve" with RuntimeWarnings)."""
    with pytest.raises(cf.InvalidInputError) as caught:
        cf.classify_points(points)
    assert fragment in str(caught.value)


@pytest.mark.parametrize("points, shape, fragment", [
    (_CLOUD.tolist(), (10,), "got (10,)"), (_CLOUD, 10, "got 10"),
    (_CLOUD, (2.7, 3.9), "got (2.7, 3.9)"), (_CLOUD, (True, 5), "got (True, 5)"),
    (_CLOUD, (4, 4, 4), "got (4, 4, 4)"), (_CLOUD, None, "got None"),
    (np.r_[_CLOUD, [[np.nan] * 3]], (5, 5), "NaN or inf"),
    (_CLOUD[:, :2], (5, 5), "3 coordinates (x y z)"),
    (_CLOUD[:2], (5, 5), "a height field needs at least 3 points, got 2"),
    (np.ones((20, 3)), (5, 5), "in one point")])
@pytest.mark.filterwarnings("error")
def test_resample_height_field_refuses_bad_points_and_grid_sizes(points, shape, fragment):
    """Fractional sizes were truncated silently, and the other cases raised numpy or
    Python errors (AttributeError, LinAlgError, IndexError, TypeError, ValueError)."""
    with pytest.raises(cf.InvalidInputError) as caught:
        cf.resample_height_field(points, shape)
    assert fragment in str(caught.value)


def test_resampling_takes_a_list_and_numpy_integer_sizes():
    grid, _ = cf.resample_height_field(_CLOUD.tolist(), (np.int64(4), 5))
    assert grid.shape == (4, 5, 3) and np.all(np.isfinite(grid))
