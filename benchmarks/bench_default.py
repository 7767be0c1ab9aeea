"""The face default against the adaptive method, on every public real face and the noisy
blade: what the issue's "the best result by default" asks of a face.

Run:  python benchmarks/bench_default.py [--faces IEA impeller testtoler terrain noisy]

Each face is faired by ``cq_fairing.occ.fair_face`` at its default tolerance (1e-3 of
its bounding-box diagonal; the noisy 50 x 80 blade of the workbench tests at 0.05 mm)
with the default (``method="wavelet"``, local search, borders, grading and objective
auto: the winner polished), the default not polished (``objective="compact"``), the
default with free target borders only (``borders="free"``), the method's plain search
(quasi-uniform targets with free borders, not polished: ``grading="uniform",
borders="free", objective="compact"``),
``method="adaptive"``
(compact, borders auto) and ``method="adaptive", objective="fair"``.  Columns: poles, OCCT's
two-sided deviation over the tolerance, the thin-plate bending energy and the
normal-curvature sign changes along iso-lines (``cq_fairing.core.fairness.
fairness_summary``, on the source's lines: the source's figure in brackets), and the
wall time of the call (one run in this process).  The terrain's adaptive runs take minutes.
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from bench_speed import public_faces  # noqa: E402

SETTINGS = (("default", {}), ("default, not polished", {"objective": "compact"}),
            ("default, free borders", {"borders": "free"}),
            ("quasi-uniform, free borders, not polished",
             {"grading": "uniform", "borders": "free", "objective": "compact"}),
            ("adaptive", {"method": "adaptive"}),
            ("adaptive, fair", {"method": "adaptive", "objective": "fair"}))


def noisy_face():
    """The noisy 50 x 80 blade of the workbench tests as a face, and its tolerance."""
    from cq_fairing.core.geometry import make_surface
    from cq_fairing.occ.builders import surface_to_natural_face
    from tests.freecad.face_references import NOISY, noisy_blade_net

    noisy, _, u_knots, v_knots = noisy_blade_net(*NOISY[0])
    return surface_to_natural_face(make_surface(noisy, u_knots, v_knots, (3, 3))), NOISY[1]


def row(label, face, tol, name, options):
    """One table row: ``fair_face(face, tol=tol, **options)`` measured."""
    from cq_fairing.core.fairness import fairness_summary
    from cq_fairing.occ import face_to_surface, fair_face

    source = face_to_surface(face)[0]
    start = time.perf_counter()
    report = fair_face(face, tol=tol, **options)
    seconds = time.perf_counter() - start
    surface = report.surface if report.surface is not None else source
    figures = fairness_summary(source, surface)
    bending, signs = figures["bending_energy"], figures["inflections"]
    ku, kv = surface.poles.shape[:2]
    return (f"| {label} | {tol:.4g} | {name} | {ku} x {kv} = {ku * kv} | "
            f"{(report.max_deviation or 0.0) / tol:.2f} | {bending['after']:.4g} "
            f"({bending['before']:.4g}) | {signs['after']} ({signs['before']}) | "
            f"{seconds:.2f} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--faces", nargs="*", default=None,
                        help="words of the face labels to run (default: all)")
    args = parser.parse_args()
    from cq_fairing.occ import default_tolerance

    faces = [(label, face, default_tolerance(face)) for label, face in public_faces()]
    faces.append(("noisy blade 50 x 80", *noisy_face()))
    print("| face | tol | setting | poles | deviation / tol | bending energy (source) | "
          "curvature sign changes (source) | s |")
    print("|---|---|---|---|---|---|---|---|")
    for label, face, tol in faces:
        if args.faces and not any(word in label for word in args.faces):
            continue
        for name, options in SETTINGS:
            print(row(label, face, tol, name, options), flush=True)


if __name__ == "__main__":
    main()
