"""The CadQuery examples run and the bundled blade ships with its license."""

import hashlib
import subprocess
import sys

from tests.conftest import REPO

EXAMPLES = REPO / "examples"


def test_bundled_blade_is_the_unchanged_upstream_file():
    data = (EXAMPLES / "data" / "IEA_15MW_CFD.stp").read_bytes()
    assert hashlib.sha256(data).hexdigest() == \
        "2dada8507c566515774e9ecc0d5d1ed77221d26a3cb99ea1a55ac95fbb9edfd9"
    assert "Apache License" in (EXAMPLES / "data" / "LICENSE-IEA_15MW_CFD.txt").read_text()
    assert "IEA_15MW_CFD.stp" in (EXAMPLES / "data" / "README.md").read_text()


def test_fair_blade_example_writes_a_step_file(tmp_path):
    out = tmp_path / "blade.step"
    run = subprocess.run([sys.executable, str(EXAMPLES / "cadquery_fair_blade.py"), "0.01",
                          str(out)], capture_output=True, text=True, cwd=REPO, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "valid: True" in run.stdout and out.stat().st_size > 0


def test_workplane_plugin_example(tmp_path):
    run = subprocess.run([sys.executable, str(EXAMPLES / "cadquery_workplane_plugin.py")],
                         capture_output=True, text=True, cwd=REPO, timeout=300)
    assert run.returncode == 0, run.stderr
    assert "solid valid: True" in run.stdout and "faired" in run.stdout
