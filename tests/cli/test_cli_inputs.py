"""Bad input files and point files through the real ``cq-fairing`` command: one line on
stderr, nothing on stdout but the command's own output, the documented exit code and no
output file."""

import numpy as np
import pytest

from tests.cli.test_cli import run
from tests.conftest import data_path


def assert_one_line_error(proc, code, tmp_path, fragment=""):
    """Exit ``code``, one ``cq-fairing: error:`` line holding ``fragment``, no output."""
    assert proc.returncode == code, proc.stderr
    assert proc.stderr.startswith("cq-fairing: error:") and proc.stderr.count("\n") == 1, \
        proc.stderr
    assert fragment in proc.stderr
    assert not list(tmp_path.glob("o.*"))


@pytest.mark.parametrize("command", [["inspect"], ["fair", "-o", "o.step"]])
def test_a_truncated_brep_prints_nothing_on_stdout(tmp_path, command):
    """OCCT's BREP reader writes "Not a Curve table" and the like to std::cout on a
    truncated file; the command's output is the one error line on stderr only."""
    cut = tmp_path / "cut.brep"
    cut.write_bytes(data_path("testtoler.brep").read_bytes()[:60000])
    proc = run(command[0], cut, *command[1:], cwd=tmp_path)
    assert_one_line_error(proc, 3, tmp_path, "not a readable BREP file")
    assert proc.stdout == ""


def _write(path, text):
    path.write_text(text)
    return path


@pytest.mark.parametrize("name, text, fragment", [
    ("folder", None, "it is a folder"),
    ("empty.xyz", "", "holds no points (it is empty"),
    ("comments.step", "# nothing\n\n# here\n", "holds no points"),
    ("one.xyz", "0 0 0\n", "holds 1 point; a curve or a surface needs at least 2"),
    ("same.xyz", "1 2 3\n" * 50, "the 50 points of"),
])
def test_point_files_without_a_curve_in_them_are_input_errors(tmp_path, name, text, fragment):
    """A folder (was exit 5, IsADirectoryError), an empty or comments-only file (was
    loadtxt's UserWarning and "must have 3 columns, found 1"), one point (two numpy
    RuntimeWarnings) and 50 identical points (was "tol must be a positive finite length,
    got 0.0"): exit 3 and one line saying what the file holds."""
    source = tmp_path / name
    if text is None:
        source.mkdir()
    else:
        source.write_text(text)
    proc = run("points", source, "-o", "o.step", cwd=tmp_path)
    assert_one_line_error(proc, 3, tmp_path, fragment)
    if name == "same.xyz":
        assert "all coincide at (1, 2, 3)" in proc.stderr


def _scan_lines(tmp_path, rows, columns):
    """``rows`` scan lines of ``columns`` points each, written one after another."""
    u, v = np.meshgrid(np.linspace(0, 1, rows), np.linspace(0, 1, columns), indexing="ij")
    grid = np.stack([100 * u, 100 * v, 10 * np.sin(3 * u) * np.cos(2 * v)], -1)
    np.savetxt(tmp_path / "g.xyz", grid.reshape(-1, 3))
    return tmp_path / "g.xyz"


@pytest.mark.parametrize("option", ["--grid", "--resample"])
@pytest.mark.parametrize("sizes, bad", [(["-20", "-30"], "-20"), (["1", "30"], "1"),
                                        (["20", "x"], "x")])
def test_grid_sizes_below_two_points_are_usage_errors(tmp_path, option, sizes, bad):
    """--grid -20 -30 used to reach numpy's reshape (exit 5, "can only specify one
    unknown dimension")."""
    proc = run("points", _scan_lines(tmp_path, 20, 30), "-o", "o.step", option, *sizes,
               cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1
    assert f"argument {option}: expected a number of points >= 2, got '{bad}'" in proc.stderr
    assert not (tmp_path / "o.step").exists()


def test_a_grid_option_that_contradicts_the_scan_lines_is_refused(tmp_path):
    """20 scan lines of 30 points read as --grid 30 20 made a scrambled surface with
    "max deviation 0" (exit 0); the option is checked against the rows found."""
    source = _scan_lines(tmp_path, 20, 30)
    proc = run("points", source, "-o", "o.step", "--grid", "30", "20", cwd=tmp_path)
    assert_one_line_error(proc, 2, tmp_path, "its points run in 20 rows of 30")
    assert "pass --grid 20 30 or leave --grid out" in proc.stderr
    proc = run("points", source, "-o", "o.step", "--grid", "20", "30", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "o.step").is_file()
