"""Batch fairing: the impeller, testtoler and the IEA blade as one batch, serial against
Dask workers; wall time and peak memory.

Run:  python benchmarks/bench_batch.py [--workers 1 2]

"serial" runs ``cq-fairing fair`` on each model in turn (one process each, the default
tolerance: 1e-3 of the model's diagonal); "batch, N workers" runs ``cq-fairing batch
--workers N`` on the three at once (a local Dask cluster, the same default tolerance).  Peak
memory is the largest sum of resident set sizes over the command's process tree
(itself, the scheduler, the workers), sampled every 0.05 s with psutil; the CPU time is
the tree's user + system time (``getrusage(RUSAGE_CHILDREN)``).  A Markdown table row is
printed per case (with the poles of the faired models, summed from the reports: the
same in every row), and the load average before and after (the machine may be shared).
"""

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil

REPO = Path(__file__).resolve().parents[1]
MODELS = [REPO / "tests" / "data" / "impeller.igs", REPO / "tests" / "data" / "testtoler.brep",
          REPO / "examples" / "data" / "IEA_15MW_CFD.stp"]


def _cpu():
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def measure(command, cwd):
    """``(wall seconds, CPU seconds, peak MB of the process tree, exit code)`` of
    ``command``; the CPU time is the process tree's (every process waited for)."""
    start, cpu = time.perf_counter(), _cpu()
    proc = psutil.Popen(command, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    peak = 0
    while proc.poll() is None:
        try:
            tree = [proc] + proc.children(recursive=True)
            peak = max(peak, sum(p.memory_info().rss for p in tree))
        except psutil.Error:
            pass
        time.sleep(0.05)
    return time.perf_counter() - start, _cpu() - cpu, peak / 1e6, proc.returncode


def serial(work):
    wall = cpu = peak = 0.0
    codes, poles = [], 0
    for model in MODELS:
        report = work / (model.stem + ".json")
        command = [sys.executable, "-m", "cq_fairing.cli", "fair", str(model), "-o",
                   str(work / (model.stem + ".step")), "--report", str(report), "--force"]
        seconds, cpu_seconds, mb, code = measure(command, work)
        wall, cpu, peak = wall + seconds, cpu + cpu_seconds, max(peak, mb)
        codes.append(code)
        poles += json.loads(report.read_text())["summary"]["poles_after"]
    return wall, cpu, peak, codes, poles


def batch(work, workers):
    inputs = work / "in"
    inputs.mkdir()
    for model in MODELS:
        shutil.copy(model, inputs)
    command = [sys.executable, "-m", "cq_fairing.cli", "batch", str(inputs), "-o",
               str(work / f"out{workers}"), "--workers", str(workers), "--quiet", "--force"]
    seconds, cpu, mb, code = measure(command, work)
    shutil.rmtree(inputs)
    summary = json.loads((work / f"out{workers}" / "summary.json").read_text())
    return seconds, cpu, mb, [code], summary["summary"]["poles_after"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, nargs="+", default=[2])
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.1f}' for x in psutil.getloadavg())}")
    print("| run | wall s | CPU s | peak MB (process tree) | exit codes | poles after |\n"
          "|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as folder:
        work = Path(folder)
        rows = [("serial (`fair`, one model after another)", serial(work))]
        rows += [(f"batch, {n} worker{'s' * (n > 1)}", batch(work, n)) for n in args.workers]
        for name, (wall, cpu, peak, codes, poles) in rows:
            print(f"| {name} | {wall:.1f} | {cpu:.1f} | {peak:.0f} | {codes} | {poles} |")
    print(f"load average after: {' '.join(f'{x:.1f}' for x in psutil.getloadavg())}")


if __name__ == "__main__":
    main()
