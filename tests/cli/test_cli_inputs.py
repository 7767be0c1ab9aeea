"""Bad input files and point files through the real ``cq-fairing`` command: one line on
stderr, nothing on stdout but the command's own output, the documented exit code and no
output file."""

import numpy as np
import pytest

from tests.cli.test_cli import run
from tests.conftest import REAL_DATA


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
    cut.write_bytes((REAL_DATA / "testtoler.brep").read_bytes()[:60000])
    proc = run(command[0], cut, *command[1:], cwd=tmp_path)
    assert_one_line_error(proc, 3, tmp_path, "not a readable BREP file")
    assert proc.stdout == ""
