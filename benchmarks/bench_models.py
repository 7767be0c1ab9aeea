"""Whole real models through ``cq-fairing fair``, wavelet against adaptive, one table.

Run:  python benchmarks/bench_models.py [--tol 0.01] [--models impeller linkrods ...]

Each model and method runs the command line in a subprocess (``python -m
cq_fairing.cli fair``) into a temporary folder; the table takes the faces' outcomes,
pole counts, the worst two-sided deviation (OCCT's check of every faired face) and the
wall time from its JSON report.  Rational faces count separately: the adaptive method
fairs them in homogeneous coordinates.
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"  # bundled models, sources and licences in SOURCES.md there
MODELS = {"impeller": DATA / "impeller.igs", "linkrods": DATA / "linkrods.step",
          "testtoler": DATA / "testtoler.brep",
          "IEA": REPO / "examples" / "data" / "IEA_15MW_CFD.stp"}


def run(model, method, tol):
    """``(exit code, wall seconds, report dict or None)`` of one command-line run."""
    with tempfile.TemporaryDirectory() as work:
        out, report = Path(work) / "out.step", Path(work) / "report.json"
        command = [sys.executable, "-m", "cq_fairing.cli", "fair", str(MODELS[model]),
                   "-o", str(out), "--tol", str(tol), "--method", method, "--report",
                   str(report)]
        start = time.perf_counter()
        proc = subprocess.run(command, capture_output=True, text=True)
        wall = time.perf_counter() - start
        data = json.loads(report.read_text()) if report.exists() else None
    return proc.returncode, wall, data


def row(model, method, tol):
    code, wall, data = run(model, method, tol)
    if data is None:
        return f"| {model} | {method} | exit {code}, no report | | | | | |"
    s, faces = data["summary"], data["faces"]
    rational = sum(1 for f in faces if f["status"] == "ok" and _rational(f))
    return (f"| {model} | {method} | {s['faces_faired']} ({rational}) | "
            f"{s['faces_unchanged']} | {s['faces_tolerance_not_met'] + s['faces_failed']} | "
            f"{s['faces_skipped']} | {s['poles_before']} -> {s['poles_after']} | "
            f"{_figure(s['worst_deviation'])} | {wall:.1f} |")


def _figure(value):
    """A deviation, or "-" where no face was faired."""
    return "-" if value is None else f"{value:.4g}"


def _rational(face):
    return bool(face.get("rational"))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, default=0.01)
    parser.add_argument("--models", nargs="*", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--methods", nargs="*", default=["wavelet", "adaptive"])
    args = parser.parse_args()
    print(f"Command: `python benchmarks/bench_models.py {' '.join(sys.argv[1:])}`\n")
    print(f"tol {args.tol:g} model units on every face\n")
    print("| model | method | faired (rational) | unchanged | over tol or failed | skipped | "
          "poles | worst deviation | wall s |")
    print("|---|---|---|---|---|---|---|---|---|")
    for model in args.models:
        for method in args.methods:
            print(row(model, method, args.tol), flush=True)


if __name__ == "__main__":
    main()
