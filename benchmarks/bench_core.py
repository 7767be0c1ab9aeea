"""Core engine benchmarks (issue 2): the seeds' cases, scaling, hybrid versus direct.

Every timing is the median of several runs, and each case also times a peer in the same
run (a dense textbook implementation: dense Gram matrices from the same quadrature and
``numpy.linalg.solve``), because this machine is shared and noisy: compare ratios.

"cold" clears the operator cache first (Gram matrices, factorizations and wavelets are
built inside the timing); "warm" reuses them, as repeated fairing in one process does.

Run:  python benchmarks/bench_core.py [--quick] [--out benchmarks/results/core.md]
"""

import argparse
import time
import tracemalloc

import numpy as np

import cq_fairing as cf
from cq_fairing.core import decomposition as decomposition_module
from cq_fairing.core.spaces import SplineSpace


def clear_cache():
    decomposition_module._cached_decomposition.cache_clear()
    decomposition_module._SPACE_REGISTRY.clear()


def median_time(func, repeats=7, cold=False):
    times = []
    for _ in range(repeats):
        if cold:
            clear_cache()
        start = time.perf_counter()
        func()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def dense_fair(poles, n):
    """Peer: C_n = G_nn^-1 G_nm C_m with dense matrices (same quadrature, dense solve)."""
    m = poles.shape[0] - 3
    source, target = SplineSpace.quasi_uniform(m), SplineSpace.quasi_uniform(n)
    merged = np.union1d(source.breakpoints, target.breakpoints)
    gx, gw = np.polynomial.legendre.leggauss(4)
    a, b = merged[:-1, None], merged[1:, None]
    x = ((a + b) / 2 + (b - a) / 2 * gx).ravel()
    w = ((b - a) / 2 * gw).ravel()
    bs, bt = source.collocation(x).toarray(), target.collocation(x).toarray()
    g_nn = bt.T @ (w[:, None] * bt)
    g_nm = bt.T @ (w[:, None] * bs)
    return np.linalg.solve(g_nn, g_nm @ poles)


def dense_fair_surface(net, nu, nv):
    rows = np.stack([dense_fair(net[i], nv) for i in range(net.shape[0])])
    return np.stack([dense_fair(rows[:, j], nu) for j in range(rows.shape[1])], axis=1)


def curve_rows(quick):
    rng = np.random.default_rng(0)
    rows = []
    for m_poles, n_poles in [(120, 30), (1302, 81)] + ([] if quick else [(20003, 2003)]):
        poles = rng.normal(size=(m_poles, 3))
        n = n_poles - 3
        cold = median_time(lambda: cf.fair_curve(poles, n), cold=True)
        warm = median_time(lambda: cf.fair_curve(poles, n))
        with_details = median_time(lambda: cf.fair_curve(poles, n).details, cold=True)
        peer = median_time(lambda: dense_fair(poles, n), repeats=3) if m_poles < 5000 else np.nan
        rows.append((f"curve {m_poles} -> {n_poles}", cold, warm, with_details, peer))
    return rows


def surface_rows(quick):
    rng = np.random.default_rng(1)
    net = rng.normal(size=(50, 80, 3))
    cold = median_time(lambda: cf.fair_surface(net, (15, 23)), cold=True)
    warm = median_time(lambda: cf.fair_surface(net, (15, 23)))
    details = median_time(lambda: cf.fair_surface(net, (15, 23)).details, cold=True)
    peer = median_time(lambda: dense_fair_surface(net, 15, 23), repeats=3)
    return [("surface 50 x 80 -> 18 x 26", cold, warm, details, peer)]


def scaling_rows(quick):
    sizes = [100, 200, 400, 800, 1000] + ([] if quick else [1600])
    rows = []
    rng = np.random.default_rng(2)
    for size in sizes:
        net = rng.normal(size=(size, size, 3))
        n = int(0.3 * size) - 3
        clear_cache()
        tracemalloc.start()
        start = time.perf_counter()
        cf.fair_surface(net, (n, n))
        elapsed = time.perf_counter() - start
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        warm = median_time(lambda: cf.fair_surface(net, (n, n)), repeats=3)
        rows.append((size, n + 3, elapsed, warm, peak / net.nbytes, peak / 2**20))
    return rows


def hybrid_rows():
    data = cf.core.examples.seed_curve_points() if hasattr(cf.core, "examples") else None
    if data is None:
        t = np.linspace(0, 2 * np.pi, 1300)
        pts = np.c_[np.cos(t), np.sin(t), 0.1 * np.sin(9 * t)] * 10
    else:
        pts = data[0] if isinstance(data, tuple) else data
    poles = cf.interpolate_points(pts).poles
    out = []
    for n in (78, 100, 200):
        direct = cf.fair_curve(poles, n, schedule="direct")
        ladder = cf.fair_curve(poles, n)
        hybrid = cf.fair_curve(poles, n, schedule="hybrid")
        timings = {s: median_time(lambda s=s: cf.fair_curve(poles, n, schedule=s).details, cold=True)
                   for s in ("direct", "auto", "hybrid")}
        x = np.linspace(0, 1, 20001)
        gap = np.abs(direct.curve.evaluate(x) - hybrid.curve.evaluate(x)).max()
        lad = np.abs(direct.poles - ladder.poles).max()
        out.append((n, gap, lad, timings, hybrid.scales, ladder.scales))
    return out


def near_m_rows():
    """Details close to the source (P1): V_1000 -> V_997 and V_2000 -> V_1990, cold."""
    rows = []
    for m, n in ((1000, 997), (2000, 1990)):
        poles = np.random.default_rng(m).normal(size=(m + 3, 3))
        details = median_time(lambda: cf.fair_curve(poles, n).details, repeats=3, cold=True)
        result = cf.fair_curve(poles, n)
        error = np.abs(result.reconstruct() - poles).max() / np.abs(poles).max()
        rows.append((m, n, details, error))
    return rows


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--out")
    args = parser.parse_args()
    lines = ["| case | cold (ms) | warm (ms) | cold + details (ms) | dense peer (ms) | peer / warm |",
             "|---|---|---|---|---|---|"]
    for name, cold, warm, det, peer in curve_rows(args.quick) + surface_rows(args.quick):
        lines.append(f"| {name} | {cold*1e3:.2f} | {warm*1e3:.3f} | {det*1e3:.2f} | "
                     f"{peer*1e3:.2f} | {peer/warm:.0f}x |")
    lines += ["", "| net | target | cold (s) | warm (s) | peak memory / net size | peak (MiB) |",
              "|---|---|---|---|---|---|"]
    for size, target, cold, warm, ratio, mib in scaling_rows(args.quick):
        lines.append(f"| {size} x {size} | {target} x {target} | {cold:.3f} | {warm:.3f} | "
                     f"{ratio:.2f} | {mib:.0f} |")
    lines += ["", "| n | max |hybrid - direct| on the curve | max |ladder - direct| poles | "
              "direct (ms) | ladder (ms) | hybrid (ms) | hybrid scales | ladder scales |",
              "|---|---|---|---|---|---|---|---|"]
    for n, gap, lad, t, hs, ls in hybrid_rows():
        lines.append(f"| {n} | {gap:.2e} | {lad:.1e} | {t['direct']*1e3:.1f} | {t['auto']*1e3:.1f} | "
                     f"{t['hybrid']*1e3:.1f} | {'>'.join(map(str, hs))} | {'>'.join(map(str, ls))} |")
    lines += ["", "| details close to the source | cold + details (s) | reconstruction error |",
              "|---|---|---|"]
    for m, n, details, error in near_m_rows():
        lines.append(f"| {m} -> {n} | {details:.3f} | {error:.1e} |")
    text = "\n".join(lines)
    print(text)
    if args.out:
        with open(args.out, "w") as handle:
            handle.write(text + "\n")


if __name__ == "__main__":
    main()
