"""Whole models faired with joins held (``joins="smooth"``, the default) against each face
alone (``joins="free"``), in the same run: time, faces faired, poles, and every join's gap
and normal angle measured by projection both ways (``ShapeFairResult.joins``).

    python benchmarks/bench_joins.py            # fuselage at 2.5, testtoler at 0.01
"""

import time
from pathlib import Path

from cq_fairing.occ import read_shape
from cq_fairing.occ.shapes import fair_shape

DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
CASES = (("fuselage.brep", 2.5), ("testtoler.brep", 0.01))


def run(name, tol, joins):
    shape = read_shape(DATA / name)
    start = time.perf_counter()
    result = fair_shape(shape, tol=tol, joins=joins)
    seconds = time.perf_counter() - start
    s = result.joins.summary()
    poles = sum(r.poles_after[0] * r.poles_after[1] for r in result.faces if r.poles_after)
    worst = max((r.max_deviation or 0.0) for r in result.faces if r.faired)
    return (f"| {name} | {tol:g} | {joins} | {seconds:.2f} | {result.n_faired} | {poles} | "
            f"{s['held']}/{s['joins']} | {s['max_gap_opened']:.2g} | "
            f"{s['max_angle_excess']:.3f} | {worst / tol:.2f} | {result.valid} |")


def main():
    print("| model | tol | joins | s | faces faired | poles | joins held | largest gap "
          "opened | largest smooth-join angle excess (deg) | worst deviation / tol | valid |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, tol in CASES:
        for joins in ("smooth", "free"):
            print(run(name, tol, joins))


if __name__ == "__main__":
    main()
