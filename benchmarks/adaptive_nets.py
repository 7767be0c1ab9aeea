"""The nets our adaptive fitters choose on the peer cases, one line each: run it in two
checkouts and diff the outputs to see whether a change (a faster measure, say) moved any
net, before re-running the peer tables.

    python benchmarks/adaptive_nets.py > after.txt           # blade 50x80 and real faces
    python benchmarks/adaptive_nets.py --big > after_big.txt  # 400x400 blade and terrain

Each line: case, tolerance, fitter, poles, setting (spans, polish lambda, borders kept)
and wall time. The cases and fitters are those of ``bench_peers.py``.
"""

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_peers import SURFACE_ONLY, cases, n_poles  # noqa: E402
from peers.fitters import METHODS  # noqa: E402

FITTERS = ("ours wavelet adaptive", "ours wavelet adaptive free", "ours wavelet adaptive p5",
           "ours wavelet faithful p5", "ours wavelet faithful p7")
BIG_FITTERS = ("ours wavelet adaptive", "ours wavelet adaptive p5", "ours wavelet faithful p5")


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--big", action="store_true",
                        help="the 400x400 blade and the terrain only (minutes per fitter)")
    args = parser.parse_args()
    chosen = cases(False, args.big)
    chosen = chosen[-2:] if args.big else chosen
    for case in chosen:
        for name in BIG_FITTERS if args.big else FITTERS:
            if case.kind == "curve" and name in SURFACE_ONLY:
                continue
            start = time.perf_counter()
            geometry, setting = METHODS[name](case)
            print(f"{case.name} | tol {case.tol:.6g} | {name} | {n_poles(geometry)} | "
                  f"{setting} | {time.perf_counter() - start:.2f} s", flush=True)


if __name__ == "__main__":
    main()
