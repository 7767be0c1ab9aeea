"""The workbench's Preview work on the noisy 50 x 80 fixture, and whole models, timed
inside FreeCAD.

``make.fair_face`` is what the Fair Surface panel's Preview runs (fairing, the two-sided
check and the figures): best of ``FAIRING_ROUNDS`` (3) warm runs per setting, against the
0.5 s Preview target.  The GUI script (``.ci/freecad_tests.sh``) also clicks Preview and
prints its wall time as ``timing:`` lines.

With ``FAIRING_MODELS=1``, Fair Surface on every B-spline face of each bundled model
(``make.fair_elements``, what the Fairing feature runs, at the tolerances of
``benchmarks/bench_joins.py``), joins held (the default) and each face alone: wall time,
faces faired, the joins held, the largest gap they open and the largest angle they add
over the source's (the workbench's own join measure, :class:`fairing_wb.joins.JoinReport`).

    freecadcmd benchmarks/bench_workbench.py           # default: 3 rounds
    FAIRING_ROUNDS=5 freecadcmd benchmarks/bench_workbench.py
    FAIRING_MODELS=1 freecadcmd benchmarks/bench_workbench.py   # the models table
"""

import os
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
for path in (REPO, REPO / "freecad_workbench", REPO / "tests" / "freecad"):
    sys.path.insert(0, str(path))

import fixtures  # noqa: E402
import FreeCAD  # noqa: E402
import Part  # noqa: E402
from fairing_wb import make  # noqa: E402

TARGET = 0.5   # seconds, the Preview target
SETTINGS = (("target 18 x 26", dict(target=(18, 26))),
            ("Tolerance 0.05 mm, defaults (search local, borders auto)",
             dict(tolerance=0.05)),
            ("Tolerance 0.05 mm, borders free", dict(tolerance=0.05, borders="free")),
            ("Tolerance 0.05 mm, search linear", dict(tolerance=0.05, search="linear")),
            ("Tolerance 0.05 mm, energy", dict(tolerance=0.05, method="energy")))


def best_of(rounds, face, options):
    """``(best wall seconds, the last result)`` of ``make.fair_face`` over ``rounds``."""
    times, result = [], None
    for _ in range(rounds):
        start = time.perf_counter()
        result = make.fair_face(face, **options)
        times.append(time.perf_counter() - start)
    return min(times), result


MODELS = (("fuselage.brep", 2.5), ("testtoler.brep", 0.01), ("shell_patches.brep", 0.083),
          ("linkrods.step", 0.01), ("impeller.igs", 0.2))
SETTINGS_OF_THE_FEATURE = {"target": None, "method": "wavelet", "search": "local",
                           "measure": "geometric", "objective": "auto"}


def models():
    """One row per model and ``Joins`` setting (module notes)."""
    print("| model | tol | Joins | s | faces faired | joins held | largest gap opened | "
          "largest angle added (deg) |")
    print("|---|---|---|---|---|---|---|---|")
    doc = FreeCAD.newDocument("Models")
    for name, tol in MODELS:
        obj = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / name)), "Model")
        subs = [f"Face{k + 1}" for k, face in enumerate(obj.Shape.Faces)   # as the feature
                if isinstance(face.Surface, Part.BSplineSurface)]             # on an object
        for joins in ("smooth", "free"):
            start = time.perf_counter()
            results = make.fair_elements(obj, subs, {**SETTINGS_OF_THE_FEATURE,
                                                     "tolerance": tol},
                                         {"boundary": "free", "borders": "auto"}, joins=joins)
            seconds = time.perf_counter() - start
            s = results.joins.summary()
            faired = sum(r.max_deviation > 0 for r in results)   # a kept face has 0
            print(f"| {name} | {tol:g} | {joins} | {seconds:.2f} | {faired} / {len(subs)} | "
                  f"{s['held']} / {s['joins']} | {s['max_gap_opened']:.2g} | "
                  f"{s['max_angle_excess']:.3f} |", flush=True)
    FreeCAD.closeDocument(doc.Name)


def main():
    if os.environ.get("FAIRING_MODELS"):
        models()
        return
    rounds = int(os.environ.get("FAIRING_ROUNDS", "3"))
    surface, _ = fixtures.noisy_blade_surface(50, 80)
    face = surface.toShape().Faces[0]
    make.fair_face(face, target=(18, 26))   # warm: imports and caches
    print(f"| setting | poles | max deviation (mm) | best of {rounds} s | "
          f"within {TARGET} s |")
    print("|---|---|---|---|---|")
    for label, options in SETTINGS:
        seconds, result = best_of(rounds, face, options)
        poles = " x ".join(map(str, result.poles_after))
        print(f"| {label} | {poles} | {result.max_deviation:.4g} | {seconds:.3f} | "
              f"{'met' if seconds <= TARGET else 'missed'} |", flush=True)


main()
