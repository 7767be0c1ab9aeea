"""Tables 1-3 of Ji et al. (2014) on the eq. 15 curve, next to the seed's numbers.

Run:  python examples/seed_curve_tables.py

The curve: R = 65, a = 3.5, b = 13 mm, 1300 points with Gaussian noise (sigma 0.002 mm,
seed 2014), interpolated to 1302 poles (cq_fairing.core.examples.seed_curve).  Errors are
the true (closest-point, two-sided) maximum distance at 8 samples per span; the seed's
software measured at its data points.  Schedule: the seed's hybrid (ARWFA to 1024, DWFA
halvings, ARWFA last).
"""

import time

import numpy as np

from cq_fairing.core.accuracy import dyadic_table, fair_curve_to_tolerance, polyfit_scale
from cq_fairing.core.examples import seed_curve
from cq_fairing.core.measures import curve_curvature, sample_parameters

SEED_TABLE1 = {10: 0.005, 9: 0.006, 8: 0.006, 7: 0.008, 6: 0.037, 5: 0.352, 4: 3.915}
SEED_TABLE2 = [(85, 0.015), (77, 0.021), (78, 0.020)]
SEED_TABLE3 = {2: 91, 3: 88, 4: 81, 5: 80, 6: 79}
TOL = 0.02


def main():
    seed = seed_curve()
    u = sample_parameters(seed.truth.space)
    kappa, _ = curve_curvature(seed.truth, u[(u > 0.01) & (u < 0.99)])
    print(f"eq. 15 truth curvature: {kappa.min():.3f} .. {kappa.max():.3f} /mm "
          "(seed: 0.080 .. 0.108)\n")

    table = dyadic_table(seed.curve, 4, schedule="hybrid")
    print("Table 1: max fairing error per dyadic scale")
    print("| j | n | poles | seed max error | ours | lg(ours) |")
    print("|---|---|---|---|---|---|")
    for j, n, e in table:
        print(f"| {j} | {n} | {n + 3} | {SEED_TABLE1[j]:.3f} | {e:.4f} | {np.log10(e):.3f} |")

    result = fair_curve_to_tolerance(seed.curve, TOL, strategy="linear", schedule="hybrid")
    rows = [r for r in result.table if r.n not in {n for _, n, _ in table} | {1299}]
    print(f"\nTable 2: linear-hypothesis iterations (tol {TOL} mm)")
    print("| iteration | seed n | seed error | ours n | ours poles | ours error |")
    print("|---|---|---|---|---|---|")
    for i in range(max(len(rows), len(SEED_TABLE2))):
        sn, se = SEED_TABLE2[i] if i < len(SEED_TABLE2) else ("", "")
        on = f"{rows[i].n} | {rows[i].poles} | {rows[i].deviation:.4f}" if i < len(rows) else " | | "
        print(f"| {i + 1} | {sn} | {se} | {on} |")

    points = [(j, e) for j, _, e in table]
    print("\nTable 3: scale from the least-squares polynomial of each order")
    print("| order | seed n | ours n |")
    print("|---|---|---|")
    for order in range(2, 7):
        j = polyfit_scale(points, TOL, order, (6.0, 7.0))
        print(f"| {order} | {SEED_TABLE3[order]} | {int(np.ceil(2 ** j)) if j is not None else '-'} |")

    print("\nAll strategies (hybrid schedule):")
    print("| strategy | n | poles | max deviation | evaluations | time [s] |")
    print("|---|---|---|---|---|---|")
    for strategy in ("linear", "polyfit", "guaranteed"):
        start = time.perf_counter()
        res = fair_curve_to_tolerance(seed.curve, TOL, strategy=strategy, schedule="hybrid")
        took = time.perf_counter() - start
        print(f"| {strategy} | {res.n} | {res.n + 3} | {res.max_deviation:.4f} | "
              f"{res.evaluations} | {took:.2f} |")


if __name__ == "__main__":
    main()
