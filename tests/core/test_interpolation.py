"""Data points to control points (patent step 1)."""

import warnings

import numpy as np
import pytest

import cq_fairing as cf


def test_1300_points_give_1302_quasi_uniform_poles_that_interpolate():
    t = np.linspace(0, 2 * np.pi, 1300)
    pts = np.c_[np.cos(t), np.sin(t), np.sin(5 * t)]
    curve = cf.interpolate_points(pts)
    assert curve.poles.shape == (1302, 3)
    assert curve.space.is_quasi_uniform and curve.space.n_spans == 1299
    assert np.abs(curve.evaluate(np.linspace(0, 1, 1300)) - pts).max() < 1e-12
    # natural end conditions: zero second derivative at both ends
    assert np.abs(curve.evaluate([0.0, 1.0], 2)).max() < 1e-8


@pytest.mark.parametrize("method", ["chord", "centripetal"])
def test_non_uniform_parameters_interpolate(method):
    rng = np.random.default_rng(0)
    pts = np.cumsum(rng.uniform(0.1, 2.0, (40, 3)), axis=0)
    curve = cf.interpolate_points(pts, method)
    u = cf.core.interpolation.parameters(pts, method)
    assert np.abs(curve.evaluate(u) - pts).max() < 1e-9
    assert not curve.space.is_quasi_uniform


def test_grid_interpolation():
    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 2, 17), indexing="ij")
    grid = np.stack([u, v, np.sin(3 * u) * np.cos(2 * v)], axis=-1)
    surf = cf.interpolate_grid(grid)
    assert surf.poles.shape == (14, 19, 3)
    vals = surf.evaluate_grid(np.linspace(0, 1, 12), np.linspace(0, 1, 17))
    assert np.abs(vals - grid).max() < 1e-12


def test_bad_points():
    with pytest.raises(cf.InvalidInputError, match="at least 2 points"):
        cf.interpolate_points(np.zeros((1, 3)))
    with pytest.raises(cf.InvalidInputError, match="coincide"):
        cf.interpolate_points(np.zeros((5, 3)), "chord")
    with pytest.raises(cf.InvalidInputError, match="NaN"):
        cf.interpolate_points(np.array([[0, 0, 0], [1, np.nan, 0], [2, 0, 0]]))


def test_read_xyz(tmp_path):
    path = tmp_path / "p.xyz"
    path.write_text("# header\n0 0 0\n1 2 3\n\n4 5 6\n")
    assert cf.read_xyz(path).shape == (3, 3)
    (tmp_path / "bad.xyz").write_text("0 0\n1 1\n")
    with pytest.raises(cf.InvalidInputError, match="3 columns"):
        cf.read_xyz(tmp_path / "bad.xyz")
    with pytest.raises(cf.InvalidInputError, match="does not exist"):
        cf.read_xyz(tmp_path / "missing.xyz")


def test_read_xyz_refuses_folders_empty_files_and_single_points(tmp_path):
    """Each in one typed sentence, without numpy's empty-file warning."""
    cases = {"folder": (tmp_path, "is a folder"),
             "empty.xyz": ("", "holds no points"),
             "comments.xyz": ("# scan\n\n", "holds no points"),
             "one.xyz": ("1 2 3\n", "holds 1 point")}
    for name, (content, fragment) in cases.items():
        path = content if name == "folder" else tmp_path / name
        if name != "folder":
            path.write_text(content)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            with pytest.raises(cf.InvalidInputError, match=fragment):
                cf.read_xyz(path)
    (tmp_path / "two.xyz").write_text("1 2 3\n4 5 6\n")
    assert cf.read_xyz(tmp_path / "two.xyz").shape == (2, 3)
