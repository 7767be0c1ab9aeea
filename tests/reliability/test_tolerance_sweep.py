"""Every tolerance from 1e-12 to 1e30 of a model's size gives a valid model, a face kept
with its reason, or a clean refusal (:mod:`tests.reliability.sweep`), and exit codes by
cause through the command line in a subprocess.

The CI sweep runs the models that fit its budget in full (every method and tolerance);
RELIABILITY.md holds the full table of every bundled model and the command that
regenerates it.
"""

from pathlib import Path

import pytest

from .conftest import data_path, run_cli, sha256
from .sweep import FACTORS, METHODS, counts, monotonicity_failures, sweep

# (model, methods): every tolerance of FACTORS each; the CI share of the full table
CI_CELLS = (("ring_nurbs", METHODS), ("fuselage", METHODS),
            ("shell_patches", METHODS))
LIMIT = 120.0   # seconds per run; the slowest CI run takes about 10 s alone


def test_the_sweep_ends_every_run_valid_kept_or_refused(capsys):
    rows, failures = [], []
    for name, methods in CI_CELLS:
        for method in methods:
            cells = sweep(name, method, limit=LIMIT)
            rows += cells
            failures += [f"{name} {method} at {r['factor']:g} x size: {r['outcome']}: "
                         f"{r['why']}" for r in cells if r["outcome"] not in
                         ("valid", "kept", "refused")]
            failures += [f"{name} {method}: pole count grows, {text}"
                         for text in monotonicity_failures(cells)]
    total = counts(rows)
    runs = sum(len(methods) for _, methods in CI_CELLS) * len(FACTORS)
    with capsys.disabled():
        print(f"\ntolerance sweep: {len(rows)} of {runs} runs, {total['valid']} valid / "
              f"{total['kept']} kept / {total['refused']} refused, {len(failures)} failures")
    assert len(rows) == runs
    assert not failures, "\n".join(failures)


def _read_back(path):
    from cq_fairing.occ import read_shape

    return read_shape(path)


def _one_error_line(proc):
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr[-1500:]
    return lines[0]


def test_ring_at_a_huge_tolerance_writes_a_valid_closed_ring(tmp_path):
    """The coarsest net of a torus periodic in u and v still closes: 3 spans along each
    closed direction (6 x 6 cubic poles), valid after the STEP round trip, closed in u
    and v, no free edge; exit 0."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepCheck import BRepCheck_Analyzer

    from cq_fairing.occ.convert import indexed_faces
    from cq_fairing.occ.shapes import free_edge_count

    source, out = data_path("ring_nurbs.brep"), tmp_path / "ring.step"
    proc = run_cli("fair", source, "-o", out, "--tol", "1e30")
    assert proc.returncode == 0, proc.stderr
    back = _read_back(out)
    assert BRepCheck_Analyzer(back).IsValid()
    [face] = indexed_faces(back)
    surface = BRep_Tool.Surface_s(face)
    assert surface.IsUClosed() and surface.IsVClosed()
    # 6 x 6 clamped poles with tied ends; OCCT's STEP reader may read a closed direction
    # back as periodic, whose seam pole is stored once
    assert (surface.NbUPoles() + surface.IsUPeriodic(),
            surface.NbVPoles() + surface.IsVPeriodic()) == (6, 6)
    assert free_edge_count(back) == free_edge_count(_read_back(source)) == 0


def test_a_tolerance_no_face_can_meet_keeps_the_face_and_exits_1(tmp_path):
    """1e-9 on a ring of size 70 at the default cubic degree (the source is quintic):
    the face is kept with its reason, the output is written, exit 1."""
    out = tmp_path / "ring.step"
    proc = run_cli("fair", data_path("ring_nurbs.brep"), "-o", out, "--tol", "1e-9")
    assert proc.returncode == 1, proc.stderr
    assert "tolerance-not-met" in proc.stdout
    assert "Traceback" not in proc.stderr
    assert out.exists()


def test_unreadable_input_exits_3_and_writes_nothing(tmp_path):
    source, out = tmp_path / "ring.brep", tmp_path / "out.step"
    source.write_bytes(data_path("ring_nurbs.brep").read_bytes()[:4000])
    before = sha256(source)
    proc = run_cli("fair", source, "-o", out, "--tol", "1e30")
    assert proc.returncode == 3
    assert "is not a readable BREP file" in _one_error_line(proc)
    assert not out.exists() and sha256(source) == before


def test_an_output_that_fails_its_own_validation_exits_6_and_writes_nothing(tmp_path):
    """An explicit 4 x 4 target on the ring (one span per closed direction, below the
    coarsest net a tolerance search returns) folds the tube through itself at its seam
    corner; the BREP file reads back as a shape ``BRepCheck_Analyzer`` rejects.  Nothing
    is written, one line says why, exit 6 (not 3: the input was fine)."""
    out = tmp_path / "ring.brep"
    proc = run_cli("fair", data_path("ring_nurbs.brep"), "-o", out, "--target", "4", "4")
    assert proc.returncode == 6, proc.stderr
    line = _one_error_line(proc)
    assert "does not read back as a valid shape" in line and "nothing was written" in line
    assert not out.exists()
    assert not list(Path(tmp_path).glob(".cq_fairing_*"))


@pytest.mark.parametrize("method", METHODS)
def test_ring_at_every_tolerance_through_the_command_line(tmp_path, method):
    """The issue's command at 1e30 and at 1e-12 of the ring's size, each method: exit 0
    with a valid file, or exit 1 with the face kept (never 3 or 6)."""
    for tol in ("1e30", "7e-11"):
        out = tmp_path / f"ring-{method}-{tol}.step"
        proc = run_cli("fair", data_path("ring_nurbs.brep"), "-o", out, "--tol", tol,
                       "--method", method)
        assert proc.returncode in (0, 1), proc.stderr
        assert "Traceback" not in proc.stderr and out.exists()
        assert (proc.returncode == 1) == ("tolerance-not-met" in proc.stdout)
