"""Fair the IEA 15 MW blade (bundled STEP) with CadQuery and write the result.

Run:  python examples/cadquery_fair_blade.py [tolerance] [output.step]

The two main blade faces are 17 x 204 poles of degree 3 x 8; the script fairs every
B-spline face within the tolerance (model units of the file), prints the poles before
and after and the deviation OCCT measured, and writes a STEP file.
"""

import sys
from pathlib import Path

import cadquery as cq

from cq_fairing.cadquery_plugin import fair_shape

HERE = Path(__file__).resolve().parent


def main(tol=0.01, output="IEA_15MW_faired.step"):
    blade = cq.importers.importStep(str(HERE / "data" / "IEA_15MW_CFD.stp")).val()
    faired, result = fair_shape(blade, tol=tol, return_report=True)
    print(f"{'face':>4} {'status':<28} {'poles before':>13} {'poles after':>12} {'max dev':>10}")
    for report in result.faces:
        before = "x".join(map(str, report.poles_before)) if report.poles_before else "-"
        after = "x".join(map(str, report.poles_after)) if report.poles_after else "-"
        dev = f"{report.max_deviation:.3g}" if report.max_deviation is not None else "-"
        print(f"{report.index:>4} {report.status:<28} {before:>13} {after:>12} {dev:>10}")
    print(f"valid: {result.valid}, largest gap along shared edges: {result.max_gap:.3g}, "
          f"{result.seconds:.1f} s")
    from cq_fairing.occ import write_shape

    write_shape(faired.wrapped, output, force=True)
    print(f"written {output}")


if __name__ == "__main__":
    args = sys.argv[1:]
    main(float(args[0]) if args else 0.01, *(args[1:2] or []))
