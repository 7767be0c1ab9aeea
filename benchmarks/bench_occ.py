"""Time per face of the OCP layer on the IEA 15 MW blade and the terrain patch.

Run:  python benchmarks/bench_occ.py [--repeat 1] [--tol-iea 0.01] [--tol-terrain 25]

For each B-spline face: reading the net (``face_to_surface``), the tolerance search and
rebuild (``fair_face`` without details), the core's wavelet details for the chosen
target (``fair_face`` with details), and the deviation check alone
(``sample_face_deviation``).  Prints a Markdown table (best of ``--repeat``).
"""

import argparse
import time
from pathlib import Path

from cq_fairing.occ import face_to_surface, fair_face, read_shape, sample_face_deviation, search
from cq_fairing.occ.convert import indexed_faces

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "tests" / "data"  # bundled models, sources and licences in SOURCES.md there
LOCAL = REPO / "examples" / "data"


def best(func, repeat):
    """Smallest wall time of ``repeat`` cold runs (the search's operator cache cleared)."""
    times, value = [], None
    for _ in range(repeat):
        search._OPERATORS.clear()
        start = time.perf_counter()
        value = func()
        times.append(time.perf_counter() - start)
    return min(times), value


def bench_face(label, face, tol, repeat, details):
    t_read, (surface, _) = best(lambda: face_to_surface(face), repeat)
    t_fair, report = best(lambda: fair_face(face, tol=tol, details=False), repeat)
    row = [label, "x".join(map(str, surface.shape[:2])), f"{tol:g}", report.status,
           "x".join(map(str, report.poles_after)), f"{report.max_deviation:.3g}",
           f"{t_read:.3f}", f"{t_fair:.2f}"]
    if report.faired:
        t_dev, _ = best(lambda: sample_face_deviation(face, report.face, density=60), repeat)
        row.append(f"{t_dev:.2f}")
        if details:
            t_det, _ = best(lambda: fair_face(face, tol=tol, details=True), 1)
            row.append(f"{t_det:.2f}")
        else:
            row.append("-")
    print("| " + " | ".join(row) + " |", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--tol-iea", type=float, default=0.01)
    parser.add_argument("--tol-terrain", type=float, default=25.0)
    parser.add_argument("--details", action="store_true",
                        help="also time fair_face with the core's wavelet details")
    args = parser.parse_args()
    print("| face | net | tol | status | faired net | max dev (OCCT) | read net s | "
          "fair_face s | deviation 60x60 s | with details s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    blade = read_shape(LOCAL / "IEA_15MW_CFD.stp")
    for i, face in enumerate(indexed_faces(blade)):
        bench_face(f"IEA blade #{i}", face, args.tol_iea, args.repeat, args.details)
    terrain, = indexed_faces(read_shape(DATA / "terrain.brep"))
    bench_face("terrain", terrain, args.tol_terrain, args.repeat, args.details)


if __name__ == "__main__":
    main()
