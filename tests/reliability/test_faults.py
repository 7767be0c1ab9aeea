"""Faults injected into real processes: Ctrl-C (SIGINT) and SIGKILL during a long fairing,
and a write that runs out of room (RLIMIT_FSIZE, as on a full disk).  After each fault:
no output file under the final name, no temporary file left (a SIGKILLed writer cannot
clean up; the next write into the folder removes its stale temporary, G6), the input
byte-identical (sha256)."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from .conftest import REPO, data_path, interruptible, sha256

TERRAIN = data_path("terrain.brep")

PIPELINE = """
import sys
from cq_fairing.occ import fair_shape, read_shape, write_shape
source, target = sys.argv[1], sys.argv[2]
shape = read_shape(source)
print("read", flush=True)
mode = sys.argv[3]
options = dict(n=int(mode[2:])) if mode.startswith("n=") else dict(tol=float(mode))
result = fair_shape(shape, **options)
print("faired", flush=True)
write_shape(result.shape, target, input_path=source)
print("written", flush=True)
"""


def _start(tmp_path, tol="2.0"):
    out = tmp_path / "out.brep"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-c", PIPELINE, str(TERRAIN), str(out), tol],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=env, cwd=tmp_path, preexec_fn=interruptible)
    return proc, out


def _wait_for(proc, word, timeout=120):
    start = time.monotonic()
    while time.monotonic() - start < timeout:
        line = proc.stdout.readline()
        if word in line:
            return
        if proc.poll() is not None:
            break
    pytest.fail(f"the pipeline never printed {word!r}: {proc.stderr.read()[-500:]}")


def _leftovers(folder):
    return sorted(p.name for p in Path(folder).iterdir() if p.name.startswith(".cq_fairing_"))


@pytest.mark.parametrize("delay", [1.0])
def test_sigint_during_fairing_leaves_nothing(tmp_path, delay):
    before = sha256(TERRAIN)
    proc, out = _start(tmp_path)
    _wait_for(proc, "read")
    time.sleep(delay)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0, "the run finished before the signal; use a longer job"
    assert "KeyboardInterrupt" in err
    assert not out.exists() and _leftovers(tmp_path) == []
    assert sha256(TERRAIN) == before


def test_sigkill_never_leaves_a_partial_file_under_the_final_name(tmp_path):
    proc, out = _start(tmp_path, "n=100")
    _wait_for(proc, "faired", timeout=240)
    proc.kill()                                   # as soon as writing starts
    proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.fail("the write finished before SIGKILL; the test did not test anything")
    assert not out.exists()                       # a hidden .cq_fairing_* temp may remain


def test_the_next_write_removes_what_a_killed_writer_left(tmp_path):
    """G6: a writer killed with SIGKILL while its temporary exists (stopped right after
    creating it, then killed); once that temporary is older than STALE_SECONDS (aged
    here with utime), the next write into the folder removes it."""
    from cq_fairing.report import STALE_SECONDS

    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-c", STOPPED_WRITER, str(data_path("ring_nurbs.brep")),
                             str(tmp_path / "killed.brep")], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env)
    _wait_for(proc, "temporary")
    proc.kill()
    proc.communicate(timeout=60)
    (left,) = _leftovers(tmp_path)
    stamp = time.time() - 2 * STALE_SECONDS
    os.utime(tmp_path / left, (stamp, stamp))
    from cq_fairing.occ import read_shape, write_shape

    write_shape(read_shape(data_path("ring_nurbs.brep")), tmp_path / "next.brep")
    assert _leftovers(tmp_path) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["next.brep"]


STOPPED_WRITER = """
import os, signal, sys
import cq_fairing.report as report
from cq_fairing.occ import read_shape, write_shape
beside = report.temporary_beside
def stop_after(path):
    tmp = beside(path)
    print("temporary", tmp, flush=True)
    os.kill(os.getpid(), signal.SIGSTOP)
    return tmp
report.temporary_beside = stop_after   # the one atomic writer every output goes through
write_shape(read_shape(sys.argv[1]), sys.argv[2])
"""


FSIZE = """
import resource, signal, sys
from cq_fairing.errors import FairingError
from cq_fairing.occ import read_shape, write_shape
shape = read_shape(sys.argv[1])
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)        # writes past the limit fail with EFBIG
resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
try:
    write_shape(shape, sys.argv[2])
except FairingError as exc:
    print(type(exc).__name__, exc)
    sys.exit(3)
"""


def test_write_that_runs_out_of_room_leaves_nothing(tmp_path):
    """linkrods (37 faces) written as STEP under a 200 kB file-size limit: the writer
    fails part-way, the error is typed and the temporary file is removed."""
    out = tmp_path / "out.step"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.run([sys.executable, "-c", FSIZE, str(data_path("linkrods.step")),
                           str(out)],
                          capture_output=True, text=True, env=env, timeout=120)
    assert proc.returncode == 3, proc.stderr[-800:]
    (line,) = proc.stdout.strip().splitlines()      # OCCT prints nothing of its own (G4)
    assert line.startswith("OutputPathError cannot write")
    assert "File too large after 200000 of" in line and "MB free on the device" in line
    assert not out.exists() and _leftovers(tmp_path) == []
