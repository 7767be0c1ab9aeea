"""The bad-input catalogue through the command line, in a subprocess, as a user runs it:
``python -m cq_fairing.cli fair IN -o OUT --tol T [--force]`` (the README's command).

Each case expects a non-zero exit code, exactly one error line on stderr naming the problem
(also for usage errors: no usage block, G7), no Python traceback, no output file, and the
input's bytes unchanged (sha256).  The exit codes are the CLI's
documented ones: 2 usage, 3 input, 4 output, 130 interrupted.
"""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from .conftest import REPO, data_path, interruptible, run_cli, sha256

BLADE = data_path("IEA_15MW_CFD.stp")


@pytest.fixture(scope="module")
def cli_help():
    proc = run_cli("fair", "--help", timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.fixture
def blade(tmp_path, cli_help):
    """A one-face STEP file (wiggly bicubic patch, 14 x 12 poles): fast to fair."""
    from .test_load import _write_step

    path = tmp_path / "patch.stp"
    _write_step(path)
    return path


def _assert_clean_failure(proc, out, inputs=(), fragment=None):
    assert proc.returncode not in (0, None), proc.stdout[-500:]
    lines = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr[-1500:]
    assert "Traceback" not in proc.stderr
    if fragment:
        assert fragment.lower() in lines[0].lower(), lines[0]
    assert not Path(out).exists() or Path(out).is_dir()
    for path, digest in inputs:
        assert sha256(path) == digest
    return lines[0]


@pytest.mark.parametrize("tol", ["0", "-1", "nan", "inf", "abc", "1e-400"])
def test_bad_tolerance(blade, tmp_path, tol):
    out = tmp_path / "out.step"
    before = sha256(blade)
    proc = run_cli("fair", blade, "-o", out, f"--tol={tol}")
    line = _assert_clean_failure(proc, out, [(blade, before)], fragment="argument --tol")
    assert proc.returncode == 2                                  # G7: one line and a hint
    assert line.startswith("cq-fairing fair: error:") and line.endswith(
        "; see cq-fairing fair --help")


HOSTILE = {
    "missing": None,
    "empty": b"",
    "random": os.urandom(64_000),
    "truncated": BLADE.read_bytes()[:200_000],
    "header-only": b"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\nENDSEC;\nEND-ISO-10303-21;\n",
}


@pytest.mark.parametrize("kind", sorted(HOSTILE))
def test_hostile_input_files(tmp_path, cli_help, kind):
    src, out = tmp_path / f"{kind}.step", tmp_path / "out.step"
    if HOSTILE[kind] is not None:
        src.write_bytes(HOSTILE[kind])
    inputs = [(src, sha256(src))] if src.exists() else []
    proc = run_cli("fair", src, "-o", out, "--tol", "0.01")
    _assert_clean_failure(proc, out, inputs)


def test_input_is_a_folder(tmp_path, cli_help):
    out = tmp_path / "out.step"
    _assert_clean_failure(run_cli("fair", tmp_path, "-o", out, "--tol", "0.01"), out)


def test_existing_output_is_kept_without_force(blade, tmp_path):
    out = tmp_path / "out.step"
    out.write_text("precious")
    proc = run_cli("fair", blade, "-o", out, "--tol", "0.05")
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert out.read_text() == "precious"
    proc = run_cli("fair", blade, "-o", out, "--tol", "0.05", "--force")
    assert proc.returncode == 0, proc.stderr[-1500:]
    assert out.stat().st_size > 1000


@pytest.mark.parametrize("where", ["missing-folder", "under-a-file", "proc"])
def test_unwritable_output(blade, tmp_path, where):
    """Root ignores chmod, so 'read-only' is a path under a regular file or in /proc."""
    blocker = tmp_path / "file.txt"
    blocker.write_text("x")
    out = {"missing-folder": tmp_path / "no" / "out.step",
           "under-a-file": blocker / "out.step",
           "proc": Path("/proc/cq_fairing_cli.step")}[where]
    before = sha256(blade)
    fragment = {"missing-folder": "does not exist", "under-a-file": "is a file, not a folder",
                "proc": "cannot write"}[where]                                     # G8
    _assert_clean_failure(run_cli("fair", blade, "-o", out, "--tol", "0.05"), out,
                          [(blade, before)], fragment=fragment)


def test_output_same_as_input(blade):
    before = sha256(blade)
    proc = run_cli("fair", blade, "-o", blade, "--tol", "0.05", "--force")
    assert proc.returncode != 0 and "Traceback" not in proc.stderr
    assert sha256(blade) == before


def test_sigint_leaves_no_partial_output(tmp_path, cli_help):
    src, out = data_path("terrain.brep"), tmp_path / "terrain_faired.step"
    before = sha256(src)
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "cq_fairing.cli", "fair", str(src), "-o",
                             str(out), "--tol", "2"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path,
                            preexec_fn=interruptible)
    time.sleep(6.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0
    assert "Traceback" not in err
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name != "terrain_faired.step"
                and p.suffix in (".step", ".stp", ".tmp")]
    assert sha256(src) == before


def _split_u_spans(face):
    """``face``'s B-spline surface with a knot inserted in the middle of every u-span: the
    same surface on twice the u-poles (OCCT's exact knot insertion), as a new face."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.TColStd import TColStd_Array1OfInteger, TColStd_Array1OfReal

    surface = BRep_Tool.Surface_s(face).Copy()
    knots = [surface.UKnot(i) for i in range(1, surface.NbUKnots() + 1)]
    middles = [(a + b) / 2 for a, b in zip(knots[:-1], knots[1:])]
    values, multiplicities = (TColStd_Array1OfReal(1, len(middles)),
                              TColStd_Array1OfInteger(1, len(middles)))
    for i, knot in enumerate(middles, start=1):
        values.SetValue(i, knot)
        multiplicities.SetValue(i, 1)
    surface.InsertUKnots(values, multiplicities, 0.0, True)
    return BRepBuilderAPI_MakeFace(surface, 1e-7).Face()


@pytest.fixture(scope="module")
def slow_and_quick(tmp_path_factory, cli_help):
    """A real STEP model of four faces: three small wiggly bicubic patches (about 0.05 s
    each) and the terrain face with its u-spans split in two (621 x 323 poles, the same
    surface; 6-7 s on 2 cores at tol 0.005, faired back to 312 x 323)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    from cq_fairing.occ import read_shape, write_shape
    from cq_fairing.occ.convert import indexed_faces

    from .test_occ_inputs import bspline_surface, face_of

    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    terrain = _split_u_spans(indexed_faces(read_shape(data_path("terrain.brep")))[0])
    for face in (face_of(bspline_surface(16, 14, wiggle=0.01, seed=0)), terrain,
                 face_of(bspline_surface(16, 14, wiggle=0.01, seed=1)),
                 face_of(bspline_surface(14, 12, wiggle=0.01, seed=2))):
        builder.Add(compound, face)
    path = tmp_path_factory.mktemp("slow") / "slow_and_quick.step"
    write_shape(compound, path)
    return path


def test_cli_jobs_and_a_per_face_time_limit(slow_and_quick, tmp_path):
    """G2: ``--jobs 2 --face-timeout 1`` on a real four-face STEP model: the terrain face
    exceeds the limit, is reported failed and kept as it was; the three others are
    faired within tol; the output is written, valid, with all four faces; exit code 1
    (a requested face failed), no traceback, the input unchanged."""
    import json

    from OCP.BRepCheck import BRepCheck_Analyzer

    from cq_fairing.occ import read_shape
    from cq_fairing.occ.convert import face_to_surface, indexed_faces

    out, report = tmp_path / "out.step", tmp_path / "r.json"
    before = sha256(slow_and_quick)
    start = time.monotonic()
    proc = run_cli("fair", slow_and_quick, "-o", out, "--tol", "0.005", "--jobs", "2",
                   "--face-timeout", "1", "--report", report, "--progress", timeout=240)
    assert time.monotonic() - start < 120
    assert proc.returncode == 1, proc.stderr[-1500:]
    assert "Traceback" not in proc.stderr and "4/4" in proc.stderr    # the progress line
    faces = json.loads(report.read_text())["faces"]
    assert [f["status"] for f in faces] == ["ok", "failed", "ok", "ok"]
    assert faces[1]["message"] == "time limit 1 s exceeded; kept the original"
    assert all(f["max_deviation"] <= 0.005 and f["poles_after"] != f["poles_before"]
               for f in faces if f["status"] == "ok")
    written = read_shape(out)
    assert BRepCheck_Analyzer(written).IsValid() and len(indexed_faces(written)) == 4
    kept, _ = face_to_surface(indexed_faces(written)[1])
    source, _ = face_to_surface(indexed_faces(read_shape(slow_and_quick))[1])
    assert kept.shape == source.shape == (621, 323)
    assert np.allclose(kept.poles, source.poles, rtol=0, atol=1e-9 * 11600)
    assert sha256(slow_and_quick) == before


@pytest.mark.parametrize("option", [["--jobs", "0"], ["--jobs", "two"],
                                    ["--face-timeout", "0"], ["--face-timeout", "nan"]])
def test_bad_jobs_and_time_limits_are_usage_errors(blade, tmp_path, option):
    out = tmp_path / "out.step"
    proc = run_cli("fair", blade, "-o", out, *option)
    line = _assert_clean_failure(proc, out, fragment=f"argument {option[0]}")
    assert proc.returncode == 2 and line.endswith("see cq-fairing fair --help")
