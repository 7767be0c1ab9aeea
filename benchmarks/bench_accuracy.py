"""Accuracy-controlled fairing: evaluations and time per call, as a markdown table.

Run:  python benchmarks/bench_accuracy.py [--repeats 3] [--skip-large]

Cases: the eq. 15 seed curve (1302 poles) to 0.02 mm with each strategy; the noisy
blade net of 50 x 80 poles and of 400 x 400 poles (cq_fairing.core.examples.blade_surface,
noise 0.02 mm) to 0.08 mm with the guaranteed search.  "cold" is the first call (operators
built); "median" is over the following repeats (operators cached per pair of spaces).
"""

import argparse
import statistics
import time

from cq_fairing.core.accuracy import fair_curve_to_tolerance, fair_surface_to_tolerance
from cq_fairing.core.examples import blade_surface, seed_curve


def timed(call, repeats):
    times, result = [], None
    for _ in range(repeats + 1):
        start = time.perf_counter()
        result = call()
        times.append(time.perf_counter() - start)
    warm = statistics.median(times[1:]) if repeats else float("nan")
    return result, times[0], warm


class _Rows:
    """Print each markdown row as soon as it is measured."""

    def append(self, row):
        name, poles, dev, ev, cold, warm = row
        print(f"| {name} | {poles} | {dev:.4f} | {ev} | {cold:.2f} | {warm:.2f} |", flush=True)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--skip-large", action="store_true")
    args = parser.parse_args()
    print("| case | poles out | max deviation | evaluations | cold [s] | median warm [s] |")
    print("|---|---|---|---|---|---|", flush=True)
    rows = _Rows()
    curve = seed_curve().curve
    for strategy in ("guaranteed", "linear", "polyfit"):
        res, cold, warm = timed(lambda: fair_curve_to_tolerance(curve, 0.02, strategy=strategy),
                                args.repeats)
        rows.append((f"seed curve 1302 poles, tol 0.02, {strategy}", f"{res.n + 3}",
                     res.max_deviation, res.evaluations, cold, warm))
    cases = [((48, 78), args.repeats)]
    if not args.skip_large:
        cases.append(((398, 398), 0))
    for shape, repeats in cases:
        net = blade_surface(shape=shape).surface
        res, cold, warm = timed(lambda: fair_surface_to_tolerance(net, 0.08), repeats)
        k = net.poles.shape
        rows.append((f"blade net {k[0]}x{k[1]}, tol 0.08, guaranteed",
                     f"{res.poles.shape[0]}x{res.poles.shape[1]}", res.max_deviation,
                     res.evaluations, cold, warm))


if __name__ == "__main__":
    main()
