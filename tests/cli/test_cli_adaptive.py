"""``cq-fairing fair --method adaptive [--objective faithful|fair]`` on a small STEP file."""

import json

import numpy as np
import pytest

from tests.cli.test_cli import run

TOL = 0.1  # mm; a 100 x 30 mm blade whose net carries 0.02 mm of noise


@pytest.fixture()
def blade_step(tmp_path):
    """A one-face STEP file: the noisy 22 x 32 blade net of the core's examples."""
    from cq_fairing.core.examples import blade_surface
    from cq_fairing.occ import write_shape
    from cq_fairing.occ.builders import surface_to_natural_face

    path = tmp_path / "in.step"
    write_shape(surface_to_natural_face(blade_surface(shape=(20, 30)).surface), path)
    return path


@pytest.mark.parametrize("objective", ["faithful", "fair"])
def test_adaptive_objective_writes_a_valid_step_within_tol(blade_step, tmp_path, objective):
    proc = run("fair", blade_step, "-o", "out.step", "--tol", TOL, "--method", "adaptive",
               "--objective", objective, "--borders", "free", "--report", "r.json",
               cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    from OCP.BRepCheck import BRepCheck_Analyzer

    from cq_fairing.occ import read_shape
    from tests.occ.helpers import faces_of, global_distance, occ_points, uv_box_grid

    before, = faces_of(read_shape(blade_step))
    after, = faces_of(read_shape(tmp_path / "out.step"))
    assert BRepCheck_Analyzer(after).IsValid()
    u, v = uv_box_grid(before, 15, 15)
    distance = global_distance(occ_points(before, u, v).reshape(-1, 3), after)
    assert distance.max() <= TOL * (1 + 1e-6)  # STEP round trip, OCCT's projection
    report = json.loads((tmp_path / "r.json").read_text())
    assert (report["method"], report["objective"], report["borders"]) == (
        "adaptive", objective, "free")
    face, = report["faces"]
    assert face["status"] == "ok" and face["poles_before"] == [22, 32]
    assert np.prod(face["poles_after"]) < 22 * 32 / 4


@pytest.mark.parametrize("args, words", [
    (["--objective", "faithful"], "applies to --method adaptive only"),
    (["--method", "energy", "--borders", "pinned"],
     "applies to --method wavelet or adaptive only"),
    (["--method", "adaptive", "--target", "6", "6"], "give --tol instead of --target")])
def test_objective_or_target_with_the_wrong_method_is_a_usage_error(blade_step, tmp_path,
                                                                     args, words):
    proc = run("fair", blade_step, "-o", "out.step", *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert words in proc.stderr and len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out.step").exists()
