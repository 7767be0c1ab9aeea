"""Speed against OCCT's tolerance fit, timed in alternation: the ratio the issue's goal asks for.

Run:  python benchmarks/bench_speed_pairs.py [--rounds 9] [--big] [--cases blade IEA ...]

``bench_peers.py`` times each method several times in a row, one method after another; on
a 2-core machine whose speed drifts by a third between minutes, two rows of one table can
see different machines.  Here each round runs the OCCT fit and then ours on the same case
in the same process, so every round's ratio compares like with like, and the spread of
the per-round ratios shows how far one figure can be trusted.  The peer is the OCCT fit
the goal table of ``BENCHMARKS.md`` compares with (``PAIRS``: ``GeomAPI_PointsToBSpline``
at its default degree or at degree 3), and ours are our fastest settings that meet tol
there.  Each method runs once before the rounds (imports, OCCT's first-use costs); our
adaptive fits start from a fresh source object every run
(``peers.fitters.wavelet_adaptive``).
"""

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_peers import cases  # noqa: E402
from peers.fitters import METHODS  # noqa: E402

# (case name prefix, tol or None for any, the OCCT fit the goal table of BENCHMARKS.md
# compares with, our settings that meet tol and are the fastest there)
PAIRS = [
    ("seed curve", None, "OCCT PointsToBSpline", ("ours wavelet faithful p7",)),
    ("blade 50x80", 0.02, "OCCT PointsToBSpline", ("ours wavelet uniform", "ours wavelet faithful p7")),
    ("blade 50x80", 0.05, "OCCT PointsToBSpline p3", ("ours wavelet faithful p7",)),
    ("IEA blade", None, "OCCT PointsToBSpline", ("ours wavelet adaptive",)),
    ("impeller blade", None, "OCCT PointsToBSpline p3", ("ours wavelet adaptive",)),
    ("impeller fillet", None, "OCCT PointsToBSpline p3", ("ours wavelet uniform",
                                                           "ours wavelet adaptive")),
    ("testtoler strip", None, "OCCT PointsToBSpline p3", ("ours wavelet adaptive",)),
    ("blade 400x400", None, "OCCT PointsToBSpline p3", ("ours wavelet faithful p5",)),
    ("terrain", None, "OCCT PointsToBSpline p3", ("ours wavelet faithful p5",)),
]
SLOW = 10.0  # s: a peer slower than this gets a third of the rounds (at least 3)


def pair_for(case):
    return next((peer, ours) for prefix, tol, peer, ours in PAIRS
                if case.name.startswith(prefix) and (tol is None or abs(case.tol - tol) < 1e-12))


def alternate(case, peer, ours, rounds):
    """Per-round wall times of the ``peer`` and of each of ``ours``, run back to back in
    each round (after one untimed run each); fewer rounds when the peer is slow."""
    start = time.perf_counter()
    METHODS[peer](case)
    if time.perf_counter() - start > SLOW:
        rounds = max(3, rounds // 3)
    for method in ours:
        METHODS[method](case)
    times = {method: [] for method in (peer,) + ours}
    for _ in range(rounds):
        for method in times:
            start = time.perf_counter()
            METHODS[method](case)
            times[method].append(time.perf_counter() - start)
    return times, rounds


def _ratio(x):
    return f"{x:.1f}x" if x >= 1 else f"{x:.2f}x ({1 / x:.0f}x slower)"


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--rounds", type=int, default=9)
    parser.add_argument("--big", action="store_true", help="also the 400x400 blade and the terrain")
    parser.add_argument("--cases", nargs="*", help="only cases whose name starts with one of these")
    args = parser.parse_args()
    print(f"Command: `python benchmarks/bench_speed_pairs.py {' '.join(sys.argv[1:])}`\n")
    print("| case, tol | peer | ours | peer median s | ours median s | ratio of medians | "
          "per-round ratios (min, median, max) |")
    print("|---|---|---|---|---|---|---|")
    for case in cases(False, args.big):
        if args.cases and not any(case.name.startswith(c) for c in args.cases):
            continue
        peer, ours = pair_for(case)
        times, rounds = alternate(case, peer, ours, args.rounds)
        t_peer = times[peer]
        for method in ours:
            ratios = sorted(p / o for p, o in zip(t_peer, times[method]))
            print(f"| {case.name.split(' (')[0]}, {case.tol:.4g} | {peer} | {method} | "
                  f"{statistics.median(t_peer):.3f} | {statistics.median(times[method]):.4f} | "
                  f"{_ratio(statistics.median(t_peer) / statistics.median(times[method]))} | "
                  f"{_ratio(ratios[0])}, {_ratio(statistics.median(ratios))}, "
                  f"{_ratio(ratios[-1])} ({rounds} rounds) |", flush=True)


if __name__ == "__main__":
    main()
