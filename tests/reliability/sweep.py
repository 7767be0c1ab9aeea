"""The tolerance sweep: bundled models x methods x tolerances relative to each model's size.

Every run ends in exactly one of three outcomes, or it is a failure:

``valid``
    The output was written through the product's own validation (``write_shape``: read
    back, ``BRepCheck_Analyzer``, same faces), the faired shape is valid, no edge became
    free (closed shells and solids stay closed), no join opened by more than 1e-7 of the
    model's size beyond its source's gap and no smooth join turns more than its
    source's angle + 0.05 deg (:func:`_join_problems`), every faired face is within the
    tolerance by OCCT's measure and keeps the closed (or periodic) directions of its
    source surface (``IsUClosed``/``IsVClosed``), and every selected B-spline face was
    faired.
``kept``
    As ``valid``, but some selected B-spline face was kept unchanged; its report says why.
``refused``
    ``fair_shape`` raised a :class:`~cq_fairing.errors.FairingError` with a one-line
    message, and nothing was written.

A failure is anything else: another exception (a traceback), an output that failed its
validation, a faired face over the tolerance or opened, a kept face without a reason,
or a run over its time limit (``hang``).  Across the tolerances of one model and method,
no faired face may get more poles at a larger tolerance than at a smaller one where it
was faired too (:func:`monotonicity_failures`; a face kept at a smaller tolerance has no
net of its own there: the source's is not the search's answer).

Each model and method runs in a child process (``python -m tests.reliability.sweep
--child ...``) that reports one JSON line per tolerance; a tolerance that takes longer
than its limit kills the child, is recorded as ``hang``, and a new child goes on with the
next tolerance.

Run ``python -m tests.reliability.sweep --table`` (from the repository root) to print the
full table of RELIABILITY.md (every model, method and tolerance; about an hour on two
cores).
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
FACTORS = (1e-12, 1e-9, 1e-6, 1e-3, 1e-1, 1.0, 1e3, 1e30)
METHODS = ("wavelet", "adaptive", "energy")
# name -> (file, faces (0-based) or None for all)
MODELS = {
    "ring_nurbs": ("tests/data/ring_nurbs.brep", None),
    "fuselage": ("tests/data/fuselage.brep", None),
    "shell_patches": ("tests/data/shell_patches.brep", None),
    "testtoler": ("tests/data/testtoler.brep", None),
    "linkrods": ("tests/data/linkrods.step", None),
    "terrain": ("tests/data/terrain.brep", None),
    "impeller": ("tests/data/impeller.igs", None),
    "IEA_blade": ("examples/data/IEA_15MW_CFD.stp", None),
}
OUTCOMES = ("valid", "kept", "refused")


def run_cell(name, method, factor, faces, work):
    """One run: ``fair_shape`` of model ``name`` at ``factor`` x its bounding-box diagonal,
    written as STEP into ``work``; a dict with ``outcome``, ``why`` and ``poles``
    (``{face index: poles}``)."""
    from cq_fairing.errors import FairingError, InvalidOutputError
    from cq_fairing.occ import default_tolerance, fair_shape, read_shape, write_shape
    from cq_fairing.occ.shapes import free_edge_count

    shape = read_shape(REPO / MODELS[name][0])
    tol = factor * 1e3 * default_tolerance(shape)   # the default is 1e-3 of the diagonal
    try:
        result = fair_shape(shape, tol=tol, method=method, faces=faces)
    except FairingError as exc:
        one_line = "\n" not in str(exc).strip()
        return dict(outcome="refused" if one_line else "failure", why=str(exc), poles={})
    out = Path(work) / f"{name}-{method}-{factor:g}.step"
    try:
        write_shape(result.shape, out, force=True)
    except InvalidOutputError as exc:
        return dict(outcome="failure", why=f"invalid output: {exc}", poles={})
    problems = [] if result.valid else ["the faired shape fails BRepCheck"]
    problems += _join_problems(result, 1e3 * default_tolerance(shape))
    if free_edge_count(result.shape) > free_edge_count(shape):
        problems.append(f"free edges {free_edge_count(shape)} -> "
                        f"{free_edge_count(result.shape)}")
    kept, poles = [], {}
    for report in result.faces:
        if report.status == "skipped-not-selected" or not report.info.is_bspline:
            continue
        problems += _face_problems(report, tol)
        if report.faired:
            poles[report.index] = int(np.prod(report.surface.shape))
        else:
            kept.append(report.index)
    if problems:
        return dict(outcome="failure", why="; ".join(problems[:3]), poles=poles)
    why = f"{len(kept)} kept" if kept else ""
    return dict(outcome="kept" if kept else "valid", why=why, poles=poles)


def _join_problems(result, size):
    """The joins held (``joins="smooth"``, the default) that opened more than 1e-7 of the
    model's ``size`` beyond their source's gap, or whose smooth joins turn more than the
    source's angle + :data:`~cq_fairing.core.joins.ANGLE_SLACK` degrees."""
    from cq_fairing.core.joins import ANGLE_SLACK

    summary = result.joins.summary()
    problems = []
    if summary["max_gap_opened"] > 1e-7 * size:
        problems.append(f"a join opened by {summary['max_gap_opened']:.3g} beyond its "
                        f"source's gap (> 1e-7 x {size:.4g})")
    if summary["max_angle_excess"] > ANGLE_SLACK + 1e-9:
        problems.append(f"a smooth join turns {summary['max_angle_excess']:.3g} deg beyond "
                        f"its source's angle (> {ANGLE_SLACK:g})")
    return problems


def _face_problems(report, tol):
    if not report.faired:
        return [] if report.message else [f"face {report.index + 1} kept without a reason"]
    problems = []
    if not report.max_deviation <= tol:
        problems.append(f"face {report.index + 1} deviates {report.max_deviation:.4g} > "
                        f"tol {tol:.4g}")
    if _closed(report.original) - _closed(report.face):
        problems.append(f"face {report.index + 1} no longer closed along "
                        f"{'/'.join(sorted(_closed(report.original) - _closed(report.face)))}")
    return problems


def _closed(face):
    """The directions (``'u'``, ``'v'``) along which the face's surface is closed or
    periodic, by OCCT."""
    from OCP.BRep import BRep_Tool

    surface = BRep_Tool.Surface_s(face)
    return {d for d, flags in (("u", (surface.IsUClosed(), surface.IsUPeriodic())),
                               ("v", (surface.IsVClosed(), surface.IsVPeriodic())))
            if any(flags)}


def monotonicity_failures(rows):
    """``[text]`` for every face whose poles grow from one tolerance to a larger one
    (``rows``: one model and method, any order)."""
    out, last = [], {}
    for row in sorted(rows, key=lambda r: r["factor"]):
        for face, count in row.get("poles", {}).items():
            before = last.get(face)
            if before is not None and count > before[1]:
                out.append(f"face {int(face) + 1}: {before[1]} poles at {before[0]:g} x size, "
                           f"{count} at {row['factor']:g} x size")
            last[face] = (row["factor"], count)
    return out


def sweep(name, method, factors=FACTORS, limit=300.0, faces=None):
    """The rows of one model and method: one dict per factor (``factor``, ``outcome``,
    ``why``, ``poles``, ``seconds``), each run in a child process within ``limit``
    seconds."""
    faces = MODELS[name][1] if faces is None else faces
    rows, todo = [], list(factors)
    with tempfile.TemporaryDirectory(prefix="cq_sweep_") as work:
        while todo:
            rows += _child(name, method, todo, faces, limit, work)
            todo = [f for f in factors if f not in {r["factor"] for r in rows}]
    return rows


def _child(name, method, factors, faces, limit, work):
    """Rows from one child over ``factors`` until it finishes or a run exceeds ``limit``
    (that run becomes a ``hang`` row)."""
    log = Path(work) / f"{name}-{method}.jsonl"
    log.unlink(missing_ok=True)
    command = [sys.executable, "-m", "tests.reliability.sweep", "--child", name, method,
               json.dumps(list(factors)), json.dumps(faces), str(log), work]
    env = dict(os.environ, PYTHONPATH=str(REPO))
    child = subprocess.Popen(command, cwd=REPO, env=env, stdout=subprocess.DEVNULL,
                             stderr=subprocess.PIPE, text=True)
    rows, started = [], time.monotonic()
    while True:
        done = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
        if len(done) > len(rows):
            rows, started = done, time.monotonic()
        if child.poll() is not None and len(done) == len(rows):
            rows = [json.loads(line) for line in log.read_text().splitlines()] if log.exists() else []
            if len(rows) < len(factors):   # the child died: its current run failed
                rows.append(dict(factor=factors[len(rows)], outcome="failure", poles={},
                                 seconds=0.0, why=f"child exited {child.returncode}: "
                                 f"{(child.stderr.read() or '').strip()[-300:]}"))
            return rows
        if time.monotonic() - started > limit:
            child.kill()
            child.wait()
            return rows + [dict(factor=factors[len(rows)], outcome="hang", poles={},
                                seconds=limit, why=f"over the {limit:g} s limit")]
        time.sleep(0.2)


def _child_main(name, method, factors, faces, log, work):
    for factor in factors:
        start = time.perf_counter()
        try:
            row = run_cell(name, method, factor, faces, work)
        except Exception as exc:   # a traceback is a failure of the sweep's rules
            row = dict(outcome="failure", why=f"{type(exc).__name__}: {exc}", poles={})
        row.update(factor=factor, seconds=round(time.perf_counter() - start, 2))
        with open(log, "a") as handle:
            handle.write(json.dumps(row) + "\n")


def counts(rows):
    """``{outcome: count}`` over ``rows`` (failures and hangs as ``failure``)."""
    out = dict.fromkeys(OUTCOMES + ("failure",), 0)
    for row in rows:
        out[row["outcome"] if row["outcome"] in OUTCOMES else "failure"] += 1
    return out


def table(results):
    """Markdown table: one line per model and method, one cell per factor."""
    head = "| model | method | " + " | ".join(f"{f:g}" for f in FACTORS) + " |"
    lines = [head, "|" + "---|" * (len(FACTORS) + 2)]
    for (name, method), rows in results.items():
        by_factor = {r["factor"]: r for r in rows}
        cells = [_cell(by_factor.get(f)) for f in FACTORS]
        lines.append(f"| {name} | {method} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _cell(row):
    if row is None:
        return ""
    poles = sum(row["poles"].values())
    text = {"valid": f"valid, {poles} poles", "kept": f"{row['why']}, {poles} poles",
            "refused": "refused"}.get(row["outcome"], f"**{row['outcome']}**: {row['why']}")
    return f"{text}, {row['seconds']:.0f} s"


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", nargs=6, metavar=("MODEL", "METHOD", "FACTORS", "FACES",
                                                      "LOG", "WORK"))
    parser.add_argument("--table", action="store_true")
    parser.add_argument("--models", nargs="*", default=list(MODELS))
    parser.add_argument("--methods", nargs="*", default=list(METHODS))
    parser.add_argument("--limit", type=float, default=600.0)
    args = parser.parse_args()
    if args.child:
        name, method, factors, faces, log, work = args.child
        _child_main(name, method, json.loads(factors), json.loads(faces), log, work)
        return
    results, monotone = {}, []
    for name in args.models:
        for method in args.methods:
            rows = sweep(name, method, limit=args.limit)
            results[(name, method)] = rows
            monotone += [f"{name} {method} {m}" for m in monotonicity_failures(rows)]
            print(f"{name} {method}: {counts(rows)}", file=sys.stderr, flush=True)
    print(table(results))
    total = counts([r for rows in results.values() for r in rows])
    print(f"\n{total['valid']} valid / {total['kept']} kept / {total['refused']} refused, "
          f"{total['failure'] + len(monotone)} failures")
    for line in monotone:
        print("pole count grows:", line)


if __name__ == "__main__":
    main()
