"""Interactive speed: start-up, real faces and the seed curve against OCCT in the same run.

Run:  python benchmarks/bench_speed.py [--rounds 5] [--parts startup faces curve]

* ``startup``: wall time of a fresh interpreter running ``import cq_fairing`` and
  ``python -m cq_fairing.cli --help`` (median of ``--rounds`` runs each), next to a bare
  ``python -c pass`` on the same machine.
* ``faces``: every public real face (the IEA blade's main face, an impeller blade face,
  the rational impeller fillet, the largest testtoler strip, the terrain) faired the
  default way, ``fair_face(face)`` (default tolerance: 1e-3 of the face's bounding-box
  diagonal; wavelet method, local search, details, OCCT's two-sided check of the result
  included), warm in this process, against OCCT's tolerance fit of the face's samples
  at the same tolerance (``GeomAPI_PointsToBSplineSurface`` on the sample grid of
  ``bench_peers.py``, its own check of the points included,
  ``peers.fitters.occt_fit``).  Each round runs OCCT's fit and then ours back to back;
  each runs once untimed first.  A peer slower than 10 s gets a third of the rounds.
* ``curve``: the seed curve (1302 poles) at tol 0.02, ``fair_curve(poles, tol=0.02)``
  with its defaults (``method="auto"``) and with ``method="wavelet"``, against OCCT's
  ``GeomAPI_PointsToBSpline`` fit of the 1300 points, the three in alternation as above.

Ratios are medians of ours against the peer's median in the same run; the per-round
ratios show the spread.
"""

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_peers import DATA, REPO, _impeller_blade, _impeller_fillet, _longest, seed_case  # noqa: E402
from peers.fitters import METHODS, Case  # noqa: E402

SLOW = 10.0  # s: a peer slower than this gets a third of the rounds (at least 3)


def _median_wall(command, rounds):
    times = []
    for _ in range(rounds):
        start = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def startup(rounds):
    print("| command | median wall s |")
    print("|---|---|")
    for label, code in (("python -c pass", ["-c", "pass"]),
                        ("python -c \"import cq_fairing\"", ["-c", "import cq_fairing"]),
                        ("python -m cq_fairing.cli --help", ["-m", "cq_fairing.cli", "--help"])):
        print(f"| `{label}` | {_median_wall([sys.executable, *code], rounds):.3f} |", flush=True)


def public_faces():
    """``[(label, face)]`` of the public real faces."""
    from cq_fairing.occ import read_shape
    from cq_fairing.occ.convert import indexed_faces

    iea = REPO / "examples" / "data" / "IEA_15MW_CFD.stp"
    testtoler = DATA / "testtoler.brep"
    impeller = indexed_faces(read_shape(DATA / "impeller.igs"))
    return [("IEA blade main face", indexed_faces(read_shape(iea))[_longest(iea)[0]]),
            ("impeller blade face", impeller[_impeller_blade()[0]]),
            ("impeller fillet (rational)", impeller[_impeller_fillet()[0]]),
            ("testtoler strip", indexed_faces(read_shape(testtoler))[_longest(testtoler)[0]]),
            ("terrain", indexed_faces(read_shape(DATA / "terrain.brep"))[0])]


def face_samples(face, tol):
    """The :class:`Case` OCCT fits: the face's surface on ``bench_peers.py``'s grid
    (2 samples per pole and direction, 30 to 200) at ``tol``."""
    import numpy as np

    from cq_fairing.occ import face_to_surface

    surface, _ = face_to_surface(face)
    ku, kv = surface.poles.shape[:2]
    nu, nv = int(np.clip(2 * ku, 30, 200)), int(np.clip(2 * kv, 30, 200))
    (u0, u1), (v0, v1) = surface.domain
    u, v = np.linspace(u0, u1, nu), np.linspace(v0, v1, nv)
    return Case(f"{nu}x{nv} pts", "surface", surface.evaluate_grid(u, v), (u, v), surface, tol)


def alternate(runs, rounds):
    """Per-round wall times of ``runs`` (``{name: callable}``, the peer first), each run
    once untimed first; fewer rounds when the first is slow."""
    first = None
    for run in runs.values():
        start = time.perf_counter()
        run()
        first = first or time.perf_counter() - start
    if first > SLOW:
        rounds = max(3, rounds // 3)
    times = {name: [] for name in runs}
    for _ in range(rounds):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - start)
    return times, rounds


def _ratio(x):
    return f"{x:.1f}x" if x >= 1 else f"{x:.2f}x ({1 / x:.1f}x slower)"


def _row(label, detail, peer_times, our_times, rounds):
    ratios = sorted(p / o for p, o in zip(peer_times, our_times))
    peer, ours = statistics.median(peer_times), statistics.median(our_times)
    print(f"| {label} | {detail} | {peer:.3f} | {ours:.4f} | {_ratio(peer / ours)} | "
          f"{_ratio(ratios[0])}, {_ratio(statistics.median(ratios))}, {_ratio(ratios[-1])} "
          f"({rounds} rounds) |", flush=True)


def faces(rounds):
    from cq_fairing.occ import default_tolerance, fair_face

    print("| face | tol; ours: poles, OCCT-checked deviation; OCCT: samples, poles | "
          "OCCT fit median s | ours median s | ratio | per-round ratios (min, median, max) |")
    print("|---|---|---|---|---|---|")
    for label, face in public_faces():
        tol = default_tolerance(face)
        case = face_samples(face, tol)
        results = {}

        def peer(case=case, results=results):
            results["peer"] = METHODS["OCCT PointsToBSpline p3"](case)[0]

        def ours(face=face, results=results):
            results["ours"] = fair_face(face)

        times, n = alternate({"peer": peer, "ours": ours}, rounds)
        report, fitted = results["ours"], results["peer"]
        detail = (f"{tol:.4g}; {report.status} {report.poles_before} -> {report.poles_after}, "
                  f"{report.max_deviation:.4g}; {case.name}, "
                  f"{fitted.poles.shape[0]}x{fitted.poles.shape[1]}")
        _row(label, detail, times["peer"], times["ours"], n)


def curve(rounds):
    import cq_fairing as cf

    case = seed_case()
    source = case.source
    results = {}

    def peer():
        results["peer"] = METHODS["OCCT PointsToBSpline"](case)[0]

    def ours(key, **options):
        def run():
            results[key] = cf.fair_curve(source.poles, tol=case.tol, knots=source.knots,
                                         degree=source.degree, **options)
        return run

    print("| case | tol; ours: poles, deviation; OCCT: poles | OCCT fit median s | "
          "ours median s | ratio | per-round ratios (min, median, max) |")
    print("|---|---|---|---|---|---|")
    times, n = alternate({"peer": peer, "wavelet": ours("wavelet", method="wavelet"),
                          "auto": ours("auto")}, rounds)
    for method, label in (("wavelet", '`method="wavelet"`'), ("auto", 'default `"auto"`')):
        result = results[method]
        detail = (f"{case.tol:g}; {result.curve.poles.shape[0]}, {result.max_deviation:.4g}; "
                  f"{results['peer'].poles.shape[0]}")
        _row(f"seed curve (1300 pts), {label}", detail, times["peer"], times[method], n)


PARTS = {"startup": startup, "faces": faces, "curve": curve}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--parts", nargs="*", default=list(PARTS), choices=list(PARTS))
    args = parser.parse_args()
    print(f"Command: `python benchmarks/bench_speed.py {' '.join(sys.argv[1:])}`")
    for part in args.parts:
        print(f"\n{part}:\n")
        PARTS[part](args.rounds)


if __name__ == "__main__":
    main()
