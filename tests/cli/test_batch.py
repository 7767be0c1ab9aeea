"""``cq-fairing batch`` on real Dask clusters on localhost (2 workers): the outputs equal
the serial ``fair_shape`` run, a corrupt input is reported while the others are done, a
worker killed mid-run costs a retry and nothing else, ``--resume`` skips what is up to
date, and a scheduler and workers started apart (``dask scheduler``, ``dask worker``)
run it the same."""

import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from tests.cli.test_cli import run
from tests.conftest import REPO, data_path

MODELS = ("IEA_15MW_CFD.stp", "testtoler.brep", "ring_nurbs.brep")
REL_TOL = "0.003"    # of each model's diagonal: loose, so the models fair in seconds
ENV = dict(os.environ, PYTHONPATH=str(REPO), DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES="1")


def _folder(path, names, corrupt=False):
    path.mkdir()
    for name in names:
        shutil.copy(data_path(name), path / name)
    if corrupt:   # the first 20 kB of a BREP file: its reader refuses the rest
        (path / "broken.brep").write_bytes(data_path("ring_nurbs.brep").read_bytes()[:20000])
    return path


def _summary(out):
    return json.loads((out / "summary.json").read_text())


def _report(out, name):
    return json.loads((out / (name.rsplit(".", 1)[0] + ".report.json")).read_text())


@pytest.fixture(scope="module")
def serial():
    """``{model: (tolerance, fair_shape result)}``: each model faired in this process,
    serially, at the tolerance the batch gives it (3e-3 of its diagonal)."""
    from cq_fairing.occ import default_tolerance, fair_shape, read_shape

    out = {}
    for name in MODELS:
        shape = read_shape(data_path(name))
        tol = default_tolerance(shape) * (float(REL_TOL) / 1e-3)
        out[name] = tol, fair_shape(shape, tol=tol)
    return out


def _assert_equal_to_serial(out, name, serial):
    """The batch's output of ``name`` has the serial run's faces: the same statuses and
    nets (pole for pole, to the written file's round-off) and the same tolerance."""
    from cq_fairing.occ import read_shape
    from cq_fairing.occ.convert import face_to_surface, indexed_faces

    tol, result = serial[name]
    report = _report(out, name)
    assert report["tolerance"] == pytest.approx(tol, rel=1e-12)
    statuses = [f["status"] for f in report["faces"]]
    assert statuses == [{"faired": "ok"}.get(f.status, f.status) for f in result.faces]
    written = indexed_faces(read_shape(out / name))
    assert len(written) == len(result.faces)
    for face, expected in zip(written, result.faces):
        if expected.faired:
            surface, _ = face_to_surface(face)
            assert surface.poles.shape == expected.surface.poles.shape
            assert np.allclose(surface.poles, expected.surface.poles, rtol=0, atol=1e-9 * tol)
    assert report["joins"]["line"] == result.joins.line()


@pytest.fixture(scope="module")
def local_batch(tmp_path_factory):
    """The three models and a corrupt file, on the command's own local cluster."""
    work = tmp_path_factory.mktemp("batch")
    inputs = _folder(work / "in", MODELS, corrupt=True)
    proc = run("batch", inputs, "-o", work / "out", "--rel-tol", REL_TOL, "--workers", "2",
               "--quiet", cwd=work)
    return work, proc


def test_a_local_cluster_gives_the_serial_results_and_reports_a_corrupt_input(
        local_batch, serial):
    work, proc = local_batch
    assert proc.returncode == 3, proc.stderr[-2000:]      # an input did not read
    out = work / "out"
    for name in MODELS:
        _assert_equal_to_serial(out, name, serial)
        assert _report(out, name)["batch"]["retries"] == 0
    summary = _summary(out)
    rows = {os.path.basename(r["input"]): r for r in summary["models"]}
    assert rows["broken.brep"]["status"] == "failed"
    assert "not a readable BREP file" in rows["broken.brep"]["message"]
    assert "broken.brep" in rows["broken.brep"]["message"] and "cq_fairing_" not in \
        rows["broken.brep"]["message"]                   # the input's name, not a temporary
    assert not (out / "broken.brep").exists()
    totals = summary["summary"]
    assert (totals["models"], totals["models_done"], totals["models_failed"]) == (4, 3, 1)
    assert totals["faces_total"] == sum(len(r.faces) for _, r in serial.values())
    assert totals["poles_after"] == sum(rows[n]["poles_after"] for n in MODELS)
    assert totals["poles_after"] < totals["poles_before"]
    assert totals["joins_held"] == sum(r.joins.summary()["held"] for _, r in serial.values())
    assert summary["engine"] == "Dask local cluster, 2 workers"
    assert "Batch fairing summary" in (out / "summary.html").read_text()
    assert "is not a readable BREP file" in proc.stdout      # the failure under the table


def test_resume_skips_what_is_up_to_date_and_redoes_the_rest(local_batch, tmp_path, serial):
    """A copy of the batch's outputs: the ring's output damaged, the blade's report
    recording other options.  ``--resume`` fairs those two again (as the first run and
    the serial one did) and keeps testtoler's files byte for byte; without --resume or
    --force nothing is overwritten (exit 4)."""
    work, _ = local_batch
    out = tmp_path / "out"
    shutil.copytree(work / "out", out)
    inputs = _folder(tmp_path / "in", MODELS)
    proc = run("batch", inputs, "-o", out, "--rel-tol", REL_TOL, "--quiet", cwd=tmp_path)
    assert proc.returncode == 4 and "--resume" in proc.stderr
    (out / "ring_nurbs.brep").write_bytes(b"damaged")
    blade = _report(out, "IEA_15MW_CFD.stp")
    blade["batch"]["options"]["angle_tol"] = 2.0
    (out / "IEA_15MW_CFD.report.json").write_text(json.dumps(blade))
    kept = (out / "testtoler.brep").stat().st_mtime_ns, (out / "testtoler.brep").read_bytes()
    proc = run("batch", inputs, "-o", out, "--rel-tol", REL_TOL, "--workers", "2", "--resume",
               "--quiet", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    statuses = {os.path.basename(r["input"]): r["status"] for r in _summary(out)["models"]}
    assert statuses == {"IEA_15MW_CFD.stp": "done", "testtoler.brep": "resumed",
                        "ring_nurbs.brep": "done"}
    assert ((out / "testtoler.brep").stat().st_mtime_ns,
            (out / "testtoler.brep").read_bytes()) == kept
    assert (out / "ring_nurbs.brep").read_bytes() == (work / "out/ring_nurbs.brep").read_bytes()
    _assert_equal_to_serial(out, "IEA_15MW_CFD.stp", serial)


def _free_port():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _kill_a_busy_worker(client, proc, timeout=120):
    """SIGKILL the worker process running a face of the batch, once one runs; returns
    its pid."""
    start = time.monotonic()
    while time.monotonic() - start < timeout and proc.poll() is None:
        busy = [address for address, keys in client.processing().items()
                if any("cq-fairing-face" in str(key) for key in keys)]
        if busy:
            pid = client.run(os.getpid, workers=[busy[0]])[busy[0]]
            os.kill(pid, signal.SIGKILL)
            return pid
        time.sleep(0.05)
    pytest.fail("no face task ran on the cluster: " + (proc.stderr.read() if proc.stderr else ""))


def test_a_worker_killed_mid_run_costs_a_retry_and_nothing_else(tmp_path, serial):
    """A real LocalCluster (2 worker processes, allowed-failures 1 as the command sets
    it); the batch runs on it through --scheduler; a worker is killed while it fairs a
    face of testtoler.  Its task runs again elsewhere, the batch completes, the retry is
    in the model's report and the summary, and the output equals the serial run."""
    from cq_fairing.batch import open_cluster

    inputs = _folder(tmp_path / "in", ("testtoler.brep",))
    client, cluster = open_cluster(workers=2, quiet=True)
    with cluster, client:
        proc = subprocess.Popen(
            [sys.executable, "-m", "cq_fairing.cli", "batch", str(inputs), "-o",
             str(tmp_path / "out"), "--rel-tol", REL_TOL, "--scheduler",
             cluster.scheduler_address, "--quiet"], cwd=tmp_path, env=ENV,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        killed = _kill_a_busy_worker(client, proc)
        stdout, stderr = proc.communicate(timeout=600)
        assert killed not in client.run(os.getpid).values()
    assert proc.returncode == 0, stderr[-2000:]
    out = tmp_path / "out"
    _assert_equal_to_serial(out, "testtoler.brep", serial)
    assert _report(out, "testtoler.brep")["batch"]["retries"] >= 1
    assert _summary(out)["summary"]["retries"] >= 1
    assert _summary(out)["models"][0]["status"] == "done"


def test_a_scheduler_and_workers_started_apart(tmp_path, serial):
    """``dask scheduler`` and ``dask worker --nworkers 2`` as processes of their own on
    localhost ports; the batch of the blade and the ring runs on them through
    --scheduler and gives the serial results."""
    from distributed import Client

    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    daemons = [subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host",
                                 "127.0.0.1", "--port", str(port), "--no-dashboard"],
                                env=ENV, cwd=tmp_path, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL)]
    try:
        daemons.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", address, "--nworkers", "2",
             "--nthreads", "1", "--no-dashboard"], env=ENV, cwd=tmp_path,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        inputs = _folder(tmp_path / "in", ("IEA_15MW_CFD.stp", "ring_nurbs.brep"))
        proc = run("batch", inputs, "-o", tmp_path / "out", "--rel-tol", REL_TOL,
                   "--scheduler", address, "--quiet", cwd=tmp_path)
    finally:
        for daemon in reversed(daemons):
            daemon.terminate()
            daemon.wait(timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for name in ("IEA_15MW_CFD.stp", "ring_nurbs.brep"):
        _assert_equal_to_serial(tmp_path / "out", name, serial)
    assert _summary(tmp_path / "out")["engine"] == f"Dask scheduler {address}, 2 workers"


@pytest.mark.parametrize("args, code, fragment", [
    (["--tol", "1", "--rel-tol", "0.01"], 2, "not allowed with argument"),
    (["--scheduler", "tcp://127.0.0.1:9", "--workers", "2"], 2, "not both"),
    (["--objective", "faithful"], 2, "--method adaptive")])
def test_bad_batch_options_are_refused_in_one_line(tmp_path, args, code, fragment):
    inputs = _folder(tmp_path / "in", ("ring_nurbs.brep",))
    proc = run("batch", inputs, "-o", tmp_path / "out", "--quiet", *args, cwd=tmp_path)
    assert proc.returncode == code, proc.stderr[-2000:]
    assert fragment in proc.stderr and "Traceback" not in proc.stderr
    assert not (tmp_path / "out" / "ring_nurbs.brep").exists()


def test_two_models_of_one_name_and_a_path_with_no_model_are_refused(tmp_path):
    first = _folder(tmp_path / "a", ("ring_nurbs.brep",))
    second = _folder(tmp_path / "b", ("ring_nurbs.brep",))
    proc = run("batch", first, second, "-o", tmp_path / "out", cwd=tmp_path)
    assert proc.returncode == 2 and "would both be written to" in proc.stderr
    proc = run("batch", tmp_path / "none*.step", "-o", tmp_path / "out", cwd=tmp_path)
    assert proc.returncode == 3 and "names no model file" in proc.stderr


def test_fair_shape_on_dask_workers_is_bit_identical_to_one_process(serial):
    """``fair_shape(engine=DaskFaces(...))`` from a client of a 2-worker LocalCluster: the
    blade's faces are fitted on the workers (its joins then solved here) and every net,
    deviation, status and join equals the serial run's exactly."""
    from cq_fairing.batch import DaskFaces, open_cluster
    from cq_fairing.occ import fair_shape, read_shape

    tol, expected = serial["IEA_15MW_CFD.stp"]
    client, cluster = open_cluster(workers=2, quiet=True)
    with cluster, client:
        result = fair_shape(read_shape(data_path("IEA_15MW_CFD.stp")), tol=tol,
                            engine=DaskFaces("blade", in_task=False))
    assert [f.status for f in result.faces] == [f.status for f in expected.faces]
    assert sum(f.faired for f in result.faces) == 2
    for face, reference in zip(result.faces, expected.faces):
        assert face.max_deviation == reference.max_deviation
        if reference.faired:
            assert np.array_equal(face.surface.poles, reference.surface.poles)
    assert result.joins.line() == expected.joins.line() and result.valid


def test_local_workers_keep_one_blas_thread_and_no_malloc_trim_threshold():
    """The workers of ``open_cluster`` (a fresh interpreter, whose environment has no
    ``MALLOC_TRIM_THRESHOLD_``) run with one BLAS thread, as Dask sets it, and without
    Dask's ``MALLOC_TRIM_THRESHOLD_=65536`` (``cq_fairing.batch.WORKER_ENVIRON``)."""
    script = ("import json, os\n"
              "from cq_fairing.batch import open_cluster\n"
              "client, cluster = open_cluster(workers=2, quiet=True)\n"
              "names = ('MALLOC_TRIM_THRESHOLD_', 'OPENBLAS_NUM_THREADS')\n"
              "seen = client.run(lambda: [os.environ.get(n) for n in names])\n"
              "print(json.dumps(list(seen.values())))\n"
              "client.close(); cluster.close()\n")
    env = {k: v for k, v in ENV.items() if k != "MALLOC_TRIM_THRESHOLD_"}
    proc = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert json.loads(proc.stdout.splitlines()[-1]) == [[None, "1"], [None, "1"]]
