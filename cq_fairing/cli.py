"""The ``cq-fairing`` command line: fair STEP/IGES/BREP models, inspect them, fair point files.

Subcommands
-----------
``fair IN -o OUT [--tol T | --target NU NV] [--faces 1,3-5]
[--method wavelet|adaptive|energy] [--objective auto|compact|faithful|fair]
[--borders auto|free|pinned] [--grading auto|uniform]
[--joins smooth|closed|free|curvature] [--angle-tol DEG]
[--target-degree P [Q]] [--jobs N]
[--face-timeout S] [--report r.json|r.html] [--deviation-map m.png|m.vtp]
[--curvature-map c.png] [--force]``
    Fair the B-spline faces of a model and write the rebuilt model (STEP or BREP).
    ``--method adaptive`` lets the knots follow the error (fewer poles at the same
    tolerance; rational faces stay rational, without the energy polish) and takes
    ``--objective faithful`` to stop at the estimated noise level instead of at the
    fewest poles, or ``--objective fair`` for the fairest of the fewest poles and a few
    more; with the wavelet method ``--objective compact`` keeps the plain projection where
    the default (``auto``) polishes the fewest-poles net with the largest fairing
    penalty within the tolerance.  ``--borders free|pinned`` chooses the target's border rows of the wavelet
    and adaptive methods (default ``auto``: pinned to the source's border curves where
    that gives fewer poles).
    ``--jobs N`` fairs N faces at once in worker processes; ``--face-timeout S`` gives
    up on a face after S seconds (reported failed, kept unchanged).
``batch INPUTS... -o OUT_DIR [--tol T | --rel-tol R] [fair's fairing options]
[--scheduler tcp://HOST:PORT | --workers N] [--resume] [--force] [--quiet]``
    Fair many models on a Dask cluster (:mod:`cq_fairing.cli_batch`,
    ``pip install "cq-fairing[dask]"``): per model the faired file and its report, and
    a summary over all of them.
``inspect IN``
    One line per face: type, degrees, poles, rational, periodic, trimmed, in a solid.
``points IN.xyz -o OUT.step [--tol T] [--grid NU NV | --resample NU NV | --curve]``
    Interpolate ``x y z`` points (one per line) and fair the curve (or the surface of a
    grid of ``NU x NV`` points, rows of ``NV`` points, found from the jumps between rows
    when ``--grid`` is not given, and checked against them when it is); a scattered
    cloud is refused unless ``--resample`` puts it onto a grid (a height field over its
    best-fit plane).  A file with no point, one point or coincident points is refused.

Exit codes
----------
0  success: every requested face met the tolerance
1  some requested face missed the tolerance or failed and was kept unchanged (the output
   is still written; the summary says why)
2  usage error (bad option or value): one line, then see cq-fairing fair --help
3  input file missing, empty, corrupt or of an unknown format
4  output path refused (exists without --force, is the input, folder missing/unwritable)
5  internal error (run with --debug for the traceback)
6  the output failed its own validation (it does not read back as a valid shape with
   every face); nothing was written
130 interrupted (Ctrl-C); no partial output is left behind

Every file is written to a temporary name beside the target, read back and checked,
then renamed into place; the input file is never modified.
"""

import argparse
import os
import sys
import time
from pathlib import Path

from .cli_options import (
    EXIT_BROKEN_PIPE,
    EXIT_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_INVALID_OUTPUT,
    EXIT_OK,
    EXIT_OUTPUT,
    EXIT_TOLERANCE,
    EXIT_USAGE,
    Parser,
    add_fairing_options,
    check_method,
    fairing_keywords,
    integer_at_least,
    positive_float,
    target_degree_option,
)
from .errors import (
    FairingError,
    FileFormatError,
    InvalidInputError,
    InvalidOutputError,
    OutputPathError,
    ToleranceNotMetError,
)
from .shape_report import faired_reports, shape_report, source_and_box

__all__ = ["main", "build_parser"]


# -- argument parsing --------------------------------------------------------------------
_jobs = integer_at_least(1, "a number of worker processes")
_point_count = integer_at_least(2, "a number of points")


def _seconds(text):
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not 0 < value < float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {text!r}")
    return value




def _file_name(text):
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a file name, got {text!r}")
    return Path(text)


def _face_list(text):
    """Parse ``1,3-5`` (1-based, as ``inspect`` prints) into 0-based indices."""
    indices = []
    try:
        for part in text.split(","):
            first, dash, last = part.strip().partition("-")
            lo = int(first)
            hi = int(last) if dash else lo   # "1-" is no range: int("") refuses it
            if lo < 1 or hi < lo:
                raise ValueError
            indices.extend(range(lo - 1, hi))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected 1-based face numbers like 1,3-5, got {text!r}") from None
    return sorted(set(indices))


def build_parser():
    """The argparse parser of ``cq-fairing`` (exit codes in the epilog)."""
    epilog = __doc__[__doc__.index("Exit codes"):__doc__.index("Every file")]
    parser = Parser(
        prog="cq-fairing", description="Multiresolution (wavelet) and energy fairing of "
        "B-spline curves and surfaces.", epilog=epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal errors")
    sub = parser.add_subparsers(dest="command", required=True)

    fair = sub.add_parser("fair", help="fair the B-spline faces of a STEP/IGES/BREP model")
    fair.add_argument("input", type=Path)
    fair.add_argument("-o", "--output", type=_file_name, required=True, help=".step/.stp or .brep")
    fair.add_argument("--tol", type=positive_float,
                      help="largest allowed deviation in model units "
                           "(default 1e-3 of the model's bounding-box diagonal)")
    fair.add_argument("--target", type=int, nargs=2, metavar=("NU", "NV"),
                      help="explicit target poles per direction instead of --tol")
    fair.add_argument("--faces", type=_face_list, help="faces to fair, 1-based (default: all)")
    add_fairing_options(fair)
    fair.add_argument("--report", type=_file_name, help="report file: .json or .html")
    fair.add_argument("--deviation-map", type=_file_name, help="deviation map: .png or .vtp")
    fair.add_argument("--curvature-map", type=_file_name,
                      help="curvature before/after of the most deviated faired face: .png")
    fair.add_argument("--jobs", type=_jobs, default=1, metavar="N",
                      help="fair N faces at once, each in a worker process (default 1); "
                           "the result is the same for any N")
    fair.add_argument("--face-timeout", type=_seconds, metavar="S",
                      help="give up on a face after S seconds: it is reported failed and "
                           "kept unchanged, the others go on (default: no limit)")
    fair.add_argument("--force", action="store_true", help="overwrite existing outputs")
    fair.add_argument("--progress", action="store_true",
                      help="show the progress line even when stderr is not a terminal")
    fair.set_defaults(handler=command_fair)

    inspect = sub.add_parser("inspect", help="list the faces of a model")
    inspect.add_argument("input", type=Path)
    inspect.set_defaults(handler=command_inspect)

    points = sub.add_parser("points", help="fair a curve or grid surface through x y z points")
    points.add_argument("input", type=Path)
    points.add_argument("-o", "--output", type=_file_name, required=True,
                        help=".step/.stp or .brep")
    points.add_argument("--tol", type=positive_float,
                        help="largest allowed deviation (default 1e-3 of the points' extent)")
    points.add_argument("--grid", type=_point_count, nargs=2, metavar=("NU", "NV"),
                        help="the points form NU rows of NV points: fit a surface (rows "
                             "separated by jumps are found without it, and must match it)")
    points.add_argument("--resample", type=_point_count, nargs=2, metavar=("NU", "NV"),
                        help="a scattered cloud: resample it onto an NU x NV grid, a height "
                             "field over its best-fit plane, and fit a surface")
    points.add_argument("--curve", action="store_true",
                        help="one curve through the points in file order, however unevenly "
                             "spaced")
    points.add_argument("--parametrization", choices=("uniform", "chord", "centripetal"),
                        default="uniform")
    points.add_argument("--force", action="store_true")
    points.set_defaults(handler=command_points)

    from .cli_batch import add_batch_command
    add_batch_command(sub)
    return parser


# -- progress -----------------------------------------------------------------------------
class _Progress:
    """A one-line progress bar on stderr (only on a terminal, or when asked)."""

    def __init__(self, enabled):
        self.enabled = enabled
        self.start = time.perf_counter()

    def __call__(self, done, total, report=None):
        if not self.enabled:
            return
        width = 30
        filled = int(width * done / max(total, 1))
        elapsed = time.perf_counter() - self.start
        sys.stderr.write(f"\r  faces [{'#' * filled}{'.' * (width - filled)}] "
                         f"{done}/{total}  {elapsed:6.1f} s")
        if done >= total:
            sys.stderr.write("\n")
        sys.stderr.flush()


# -- fair ------------------------------------------------------------------------------------
def command_fair(args):
    from .occ import default_tolerance, fair_shape, list_faces
    from .occ.io import WRITE_SUFFIXES, read_model, write_model
    from .report import check_output_path

    outputs = [p for p in (args.output, args.report, args.deviation_map, args.curvature_map) if p]
    _check_suffixes(args)
    check_method(args)
    target_degree = target_degree_option(args.target_degree)
    for path in outputs:
        check_output_path(path, force=args.force, inputs=(args.input,))
    if args.tol is not None and args.target is not None:
        raise InvalidInputError("give --tol or --target, not both.")
    started = time.perf_counter()
    model = read_model(args.input)
    if args.convert:
        model = model.converted()  # once, here: --target is checked on the converted faces
    shape = model.shape
    infos = list_faces(shape)
    if args.faces and max(args.faces) >= len(infos):
        raise InvalidInputError(
            f"--faces names face {max(args.faces) + 1}, but {args.input} has {len(infos)} faces.")
    n = _target_scales(args.target, [infos[i] for i in args.faces or range(len(infos))],
                       target_degree)
    tol = None if args.target else (args.tol or default_tolerance(shape))
    progress = _Progress(args.progress or sys.stderr.isatty())
    result = fair_shape(shape, tol=tol, n=n, faces=args.faces, progress=progress,
                        details=False, jobs=args.jobs, face_timeout=args.face_timeout,
                        in_place=True, **fairing_keywords(args))
    write_model(model, args.output, force=args.force, input_path=args.input)
    kept = model.contents() if WRITE_SUFFIXES[Path(args.output).suffix.lower()] == "step" else {}
    report = shape_report(result, tol, time.perf_counter() - started, kept=kept or None,
                          parts=model.face_parts(), input_path=args.input,
                          output_path=args.output, method=args.method,
                          objective=args.objective, borders=args.borders,
                          grading=args.grading,
                          command="cq-fairing " + " ".join(sys.argv[1:]))
    _write_maps(args, result, tol, report)
    _note_nothing_faired(args, result)
    if args.report:
        from .report import write_report
        write_report(report, args.report, force=args.force)
    from .report import summary_table
    print(summary_table(report))
    return EXIT_OK if _all_requested_met(args, result) else EXIT_TOLERANCE


def _check_suffixes(args):
    checks = [(args.output, (".step", ".stp", ".brep"), "--output"),
              (args.report, (".json", ".html", ".htm"), "--report"),
              (args.deviation_map, (".png", ".vtp"), "--deviation-map"),
              (args.curvature_map, (".png",), "--curvature-map")]
    for path, suffixes, option in checks:
        if path is not None:
            _check_suffix(path, suffixes, option)


def _check_suffix(path, suffixes, option):
    """Refuse an output ``path`` that is a folder or does not end in one of ``suffixes``."""
    if path.is_dir():
        raise OutputPathError(f"{option} {str(path)!r} is a folder; give a file name ending "
                              f"in {' or '.join(suffixes)}.")
    if path.suffix.lower() not in suffixes:
        raise OutputPathError(f"{option} must end in {' or '.join(suffixes)}, got {str(path)!r}.")


def _target_scales(target, infos, target_degree=None):
    """--target NU NV (poles per direction) as the core's scales ``n = poles - degree``.

    The target degree is ``target_degree``, or else the face's own, at most 3, per
    direction (as ``fair_face`` chooses it).  Each selected face with poles (B-spline or
    Bezier) must allow the poles asked for: from its target degree + 1 up to its own
    count; and since one scale goes to every face, their target degrees must agree.
    """
    if target is None:
        return None
    degrees = {}
    for info in (i for i in infos if i.n_poles_u):
        own = target_degree or (min(3, info.u_degree), min(3, info.v_degree))
        _check_target_poles(target, info, own)
        degrees.setdefault(own, []).append(info.index + 1)
    if len(degrees) > 1:
        kinds = "; ".join(f"face{'s' * (len(faces) > 1)} {_ranges(faces)}: {du} x {dv}"
                          for (du, dv), faces in sorted(degrees.items()))
        raise InvalidInputError(
            f"--target gives poles per direction, but the selected faces' targets have "
            f"different degrees ({kinds}), so the same poles are different targets; "
            "select faces of one degree with --faces, give --target-degree, or use --tol.")
    du, dv = next(iter(degrees), (3, 3))
    return target[0] - du, target[1] - dv


def _check_target_poles(target, info, degrees):
    """Refuse a --target outside what ``info``'s face allows (degree + 1 to its poles)."""
    own = (info.n_poles_u, info.n_poles_v)
    if all(d + 1 <= t <= k for t, d, k in zip(target, degrees, own)):
        return
    allowed = " and ".join(f"{d + 1} to {k} in {name}"
                           for d, k, name in zip(degrees, own, "uv"))
    raise InvalidInputError(
        f"--target {target[0]} {target[1]} does not fit face {info.index + 1}: it has "
        f"{own[0]} x {own[1]} poles and a degree {degrees[0]} x {degrees[1]} target, "
        f"which allows {allowed}; choose --target within that, select other faces with "
        "--faces, or use --tol.")


def _ranges(numbers):
    """``[1, 2, 3, 5]`` -> ``"1-3,5"`` (the --faces syntax)."""
    runs = []
    for number in numbers:
        if runs and number == runs[-1][1] + 1:
            runs[-1][1] = number
        else:
            runs.append([number, number])
    return ",".join(str(a) if a == b else f"{a}-{b}" for a, b in runs)


def _all_requested_met(args, result):
    requested = set(args.faces) if args.faces else None
    for index, face in enumerate(result.faces):
        if face.status in ("tolerance-not-met", "failed"):
            return False
        if requested is not None and index in requested and face.status.startswith("skipped"):
            return False
    return True


def _note_nothing_faired(args, result):
    """One note on stderr when no face was faired: the faces' statuses, the maps not
    written, and ``--convert`` where faces were skipped for not being B-splines."""
    if faired_reports(result):
        return
    counts = {}
    for face in result.faces:
        if face.status != "skipped-not-selected":
            counts[face.status] = counts.get(face.status, 0) + 1
    why = ", ".join(f"{count} {status}" for status, count in sorted(counts.items()))
    maps = " and ".join(option for option, path in (("--deviation-map", args.deviation_map),
                                                    ("--curvature-map", args.curvature_map))
                        if path)
    notes = [f"no face was faired ({why})"]
    if "skipped-not-bspline" in counts and not args.convert:
        notes.append("pass --convert to fair the faces that are not B-splines")
    if maps:
        notes.append(f"{maps} not written (they show faired faces)")
    print(f"cq-fairing: note: {'; '.join(notes)}.", file=sys.stderr)


def _write_maps(args, result, tol, report):
    faired = faired_reports(result)
    maps = {}
    if args.deviation_map and faired:
        maps["deviation"] = str(_deviation_map(args, faired, tol))
    if args.curvature_map and faired:
        from .viz import render_curvature_maps

        worst = max(faired, key=lambda f: f.max_deviation or 0.0)
        source, box = source_and_box(worst)
        render_curvature_maps(source, worst.surface, args.curvature_map, box=box,
                              force=args.force, title=f"face {result.faces.index(worst) + 1}")
        maps["curvature"] = str(args.curvature_map)
    report["maps"] = {**report.get("maps", {}), **maps}


def _deviation_map(args, faired, tol):
    from .occ import sample_face_deviation
    from .viz import deviation_mesh, render_deviation_map, save_mesh

    meshes = []
    for face in faired:
        samples = face.deviation or sample_face_deviation(face.original, face.face)
        meshes.append(deviation_mesh(samples, face_index=face.index))
    if args.deviation_map.suffix.lower() == ".vtp":
        save_mesh(meshes, args.deviation_map, force=args.force)
    else:
        render_deviation_map(meshes, args.deviation_map, tolerance=tol, units="model units",
                             force=args.force)
    return args.deviation_map


# -- inspect ---------------------------------------------------------------------------------
def command_inspect(args):
    from .occ import list_faces
    from .occ.io import read_model

    model = read_model(args.input)
    infos = list_faces(model.shape)
    parts = model.face_parts()
    show_parts = len(set(parts)) > 1  # an assembly: say which placement each face is on
    if model.contents():
        from .report import kept_text
        print("model:", kept_text(model.contents()))
    print(f"{'face':>5}  {'type':<14} {'degree':>7} {'poles':>9}  rational periodic trimmed "
          f"in-solid{'  part' if show_parts else ''}")
    for info, part in zip(infos, parts):
        degree = f"{info.u_degree}x{info.v_degree}" if info.u_degree else "-"
        poles = f"{info.n_poles_u}x{info.n_poles_v}" if info.n_poles_u else "-"
        periodic = "".join(d for d, p in (("u", info.u_periodic), ("v", info.v_periodic)) if p)
        print(f"{info.index + 1:>5}  {info.surface_type:<14} {degree:>7} {poles:>9}  "
              f"{_yes(info.rational):<8} {periodic or 'no':<8} {_yes(info.trimmed):<7} "
              f"{_yes(info.in_solid):<8}{'  ' + str(part) if show_parts else ''}".rstrip())
    counts = {}
    for info in infos:
        counts[info.surface_type] = counts.get(info.surface_type, 0) + 1
    print(f"{len(infos)} faces: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    return EXIT_OK


def _yes(flag):
    return "yes" if flag else "no"


# -- points ----------------------------------------------------------------------------------
def command_points(args):
    import numpy as np

    from . import fair_curve, fair_surface, interpolate_grid, interpolate_points
    from .report import check_output_path

    _check_suffix(args.output, (".step", ".stp", ".brep"), "--output")
    check_output_path(args.output, force=args.force, inputs=(args.input,))
    points = _read_points(args.input)
    extent = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    tol = args.tol or 1e-3 * extent
    grid, note = _points_grid(points, args)
    if grid is not None:
        source = interpolate_grid(grid, args.parametrization)
        result = fair_surface(source.poles, tol=tol, u_knots=source.u_knots,
                              v_knots=source.v_knots, degree=3)
        shape = _surface_shape(result.surface)
        sizes = f"{source.shape[0]}x{source.shape[1]} -> {result.poles.shape[0]}x{result.poles.shape[1]}"
    else:
        source = interpolate_points(points, args.parametrization)
        result = fair_curve(source.poles, tol=tol, knots=source.knots, degree=3,
                            method="wavelet")
        shape = _curve_shape(result.curve)
        sizes = f"{source.n_poles} -> {result.poles.shape[0]}"
    from .occ import write_shape
    from .occ.builders import write_edge

    writer = write_shape if grid is not None else write_edge
    writer(shape, args.output, force=args.force, input_path=args.input)
    print(f"{points.shape[0]} points{note}, poles {sizes}, max deviation "
          f"{result.max_deviation:.4g} (tolerance {tol:.4g}), written to {args.output}")
    return EXIT_OK


def _points_grid(points, args):
    """``(grid (NU, NV, 3) or None for a curve, note for the summary)``: ``--grid``,
    ``--resample``, or what the points' order says (:func:`cq_fairing.classify_points`);
    a scattered cloud without ``--resample`` is refused."""
    from . import classify_points, resample_height_field

    if sum(map(bool, (args.grid, args.resample, args.curve))) > 1:
        raise InvalidInputError("give one of --grid, --resample and --curve.")
    if args.curve:
        return None, ""
    if args.resample:
        grid, outside = resample_height_field(points, args.resample)
        return grid, (f" resampled to a {args.resample[0]} x {args.resample[1]} height field "
                      f"({outside} cells outside the cloud took the nearest height)")
    kind, shape = classify_points(points)
    if args.grid:
        return _given_grid(points, args, shape if kind == "grid" else None), ""
    if kind == "grid":
        return points.reshape(*shape, 3), f" in {shape[0]} rows of {shape[1]} (scan lines)"
    if kind == "scattered":
        raise InvalidInputError(
            f"the {points.shape[0]} points of {args.input} are neither one run (a curve) nor "
            "rows of equal length separated by jumps (a grid): a scattered cloud; pass "
            "--resample 40 40 to fit a surface to it as a height field over its best-fit "
            "plane, --grid NU NV if its rows have NV points, or --curve if they are one "
            "unevenly spaced curve.")
    return None, ""


def _given_grid(points, args, found):
    """The points as the ``--grid NU NV`` grid; refused when the count differs or when
    their scan lines (``found``: (rows, columns) or None) say another grid."""
    nu, nv = args.grid
    if nu * nv != points.shape[0]:
        raise InvalidInputError(
            f"--grid {nu} {nv} needs {nu * nv} points, {args.input} has {points.shape[0]}.")
    if found is not None and found != (nu, nv):
        raise InvalidInputError(
            f"--grid {nu} {nv} does not match {args.input}: its points run in {found[0]} "
            f"rows of {found[1]} (scan lines, told apart by the jumps between rows); pass "
            f"--grid {found[0]} {found[1]} or leave --grid out.")
    return points.reshape(nu, nv, 3)


def _read_points(path):
    """The ``(N, 3)`` points of a point file: at least 2, not all in one place.

    Raises
    ------
    FileFormatError
        A missing file or a folder, unreadable numbers, no or one point, coincident points.
    """
    import numpy as np

    from . import read_xyz

    if not path.is_file():
        problem = "it is a folder" if path.is_dir() else "no such file"
        raise FileFormatError(f"cannot read '{path}': {problem}; give a file of x y z points.")
    try:
        points = read_xyz(path)
    except OSError as exc:
        raise FileFormatError(f"cannot read '{path}': {exc.strerror}.") from exc
    except InvalidInputError as exc:
        raise FileFormatError(_no_points(path) or str(exc)) from exc
    if not np.ptp(points, axis=0).any():
        raise FileFormatError(
            f"the {points.shape[0]} points of '{path}' all coincide at "
            f"({', '.join(f'{c:g}' for c in points[0])}); a curve or a surface needs points "
            "in at least two places.")
    return points


def _no_points(path):
    """The message for a point file without any data line, else ``None``."""
    with open(path, "rb") as handle:
        if any(line.split(b"#")[0].strip() for line in handle):
            return None
    return (f"'{path}' holds no points (it is empty or has only blank and # comment "
            "lines); write one 'x y z' point per line.")


def _curve_shape(curve):
    from .occ.builders import curve_to_edge

    return curve_to_edge(curve)


def _surface_shape(surface):
    from .occ.builders import surface_to_natural_face

    return surface_to_natural_face(surface)


# -- entry point -----------------------------------------------------------------------------
_EXIT_BY_ERROR = ((FileFormatError, EXIT_INPUT), (OutputPathError, EXIT_OUTPUT),
                  (InvalidOutputError, EXIT_INVALID_OUTPUT),
                  (ToleranceNotMetError, EXIT_TOLERANCE), (InvalidInputError, EXIT_USAGE),
                  (FairingError, EXIT_INTERNAL))


def main(argv=None):
    """Run ``cq-fairing``; returns (and, as a script, exits with) the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.handler(args)
    except KeyboardInterrupt:
        print("cq-fairing: interrupted; no output was written.", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:  # the reader went away (``| head``): stop quietly, like cat
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except FairingError as exc:
        code = next(code for kind, code in _EXIT_BY_ERROR if isinstance(exc, kind))
        print(f"cq-fairing: error: {exc}", file=sys.stderr)
        return code
    except Exception as exc:  # an internal error: one line, the traceback with --debug
        if args.debug:
            raise
        print(f"cq-fairing: internal error: {type(exc).__name__}: {exc} "
              "(run with --debug for the traceback)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
