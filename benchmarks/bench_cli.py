"""Time ``cq-fairing fair`` end to end on real models; per-face times from its JSON report.

Run:  python benchmarks/bench_cli.py [--tol-blade 0.001] [--tol-terrain 1.0]

Each case runs the installed entry point in a subprocess (``python -m cq_fairing.cli``)
into a temporary folder and prints wall time, the per-face times and pole counts that
the report records, and the worst deviation against the tolerance.
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
BLADE = REPO / "examples" / "data" / "IEA_15MW_CFD.stp"


def run_case(name, model, tol, extra=()):
    with tempfile.TemporaryDirectory() as work:
        out, report = Path(work) / "out.step", Path(work) / "report.json"
        command = [sys.executable, "-m", "cq_fairing.cli", "fair", str(model), "-o", str(out),
                   "--tol", str(tol), "--report", str(report), *extra]
        start = time.perf_counter()
        proc = subprocess.run(command, capture_output=True, text=True)
        wall = time.perf_counter() - start
        print(f"\n## {name}: exit {proc.returncode}, wall {wall:.1f} s")
        print("command: cq-fairing " + " ".join(command[3:]))
        if not report.exists():
            print(proc.stderr.strip())
            return
        data = json.loads(report.read_text())
        for face in data["faces"]:
            print(f"  face {face['index']:>3}  {face['status']:<18} poles "
                  f"{face['poles_before']} -> {face['poles_after']}  max dev "
                  f"{face['max_deviation']}  time {face['seconds']} s")
        s = data["summary"]
        print(f"  total {s['seconds']:.1f} s; poles {s['poles_before']} -> {s['poles_after']}; "
              f"worst deviation {s['worst_deviation']} (tol {tol}); valid {s['valid']}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol-blade", type=float, default=0.001)
    parser.add_argument("--tol-terrain", type=float, default=1.0)
    args = parser.parse_args()
    run_case("IEA 15 MW blade (3 faces)", BLADE, args.tol_blade)
    run_case("terrain 312x323 (1 face)", DATA / "terrain.brep", args.tol_terrain)


if __name__ == "__main__":
    main()
