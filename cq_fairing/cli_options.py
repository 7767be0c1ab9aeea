"""What the ``cq-fairing`` commands share: exit codes, the argument parser's one-line
errors, argument types and the fairing options of ``fair`` and ``batch``."""

import argparse

from .core.options import (
    BORDERS,
    BOUNDARIES,
    DEFAULTS,
    GRADINGS,
    JOINS,
    METHOD_DOES,
    METHODS,
    OBJECTIVES,
    face_applies,
)
from .errors import InvalidInputError

EXIT_OK, EXIT_TOLERANCE, EXIT_USAGE, EXIT_INPUT, EXIT_OUTPUT, EXIT_INTERNAL = 0, 1, 2, 3, 4, 5
EXIT_INVALID_OUTPUT = 6
EXIT_INTERRUPTED = 130
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a writer whose reader left



class Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors: the problem and where to read more (exit 2)."""

    def error(self, message):
        self.exit(EXIT_USAGE, f"{self.prog}: error: {message}; see {self.prog} --help\n")


def integer_at_least(minimum, what):
    """An argparse type: an integer ``>= minimum``, else "expected ``what`` >= minimum"."""
    def parse(text):
        try:
            value = int(text)
        except ValueError:
            value = minimum - 1
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected {what} >= {minimum}, got {text!r}")
        return value
    return parse


degree = integer_at_least(1, "a degree")


def positive_float(text):
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive length, got {text!r}") from None
    if not value > 0 or value == float("inf"):
        raise argparse.ArgumentTypeError(f"expected a positive finite length, got {text!r}")
    return value


def add_fairing_options(parser):
    """How the faces are faired: the options ``fair`` and ``batch`` share."""
    parser.add_argument("--method", choices=METHODS, default=DEFAULTS["method"],
                        help="wavelet: uniform targets (default); adaptive: targets whose "
                             "knots follow the error, fewer poles; energy: keeps the "
                             "poles, moves each within --tol (adaptive and energy need "
                             "--tol or its default, not --target)")
    parser.add_argument("--objective", choices=OBJECTIVES,
                        help="auto (default): with --method wavelet the fewest poles, "
                             "polished with the largest fairing penalty within --tol; with "
                             "--method adaptive compact. compact = fewest poles within "
                             "--tol, the plain projection; faithful (adaptive) = stop at "
                             "the estimated noise level; fair = wavelet: as auto; "
                             "adaptive: the fairest of the fewest poles and up to two more "
                             "spans per direction (slower)")
    parser.add_argument("--borders", choices=BORDERS,
                        help="with --method wavelet or adaptive: the target's border rows; "
                             "auto = pinned to the face's border curves (corners kept) "
                             "where that gives fewer poles (default; with --target: "
                             "free), free = plain projection, pinned = always")
    parser.add_argument("--grading", choices=GRADINGS,
                        help="with --method wavelet and --tol: auto = also targets graded "
                             "like a face's knot spans, with pinned borders targets refined "
                             "towards them, and where uniform ones keep more "
                             "than a quarter of its poles targets graded by the error (the "
                             "adaptive method's knots); the fewest poles win (default; in "
                             "a model of several faces: spans; a face that shares a held "
                             "join keeps uniform ones), spans = uniform and span-graded "
                             "targets, uniform = uniform targets only")
    parser.add_argument("--joins", choices=JOINS, default=JOINS[0],
                        help="smooth = faces that meet along whole borders are faired together, "
                             "joins closed and tangent where the source was (default); "
                             "curvature = also curvature-continuous (G2) where the source "
                             "was; closed = closed only; free = each face alone")
    parser.add_argument("--angle-tol", type=float, default=1.0, metavar="DEG",
                        help="a join whose source normals differ by less is smooth, else a "
                             "crease (default 1 degree)")
    parser.add_argument("--target-degree", type=degree, nargs="+", metavar="P",
                        help="degree of the faired surfaces, one for both directions or "
                             "P_U P_V (default: each face's own, at most 3; not with "
                             "--method energy, which keeps it)")
    parser.add_argument("--boundary", choices=BOUNDARIES,
                        help="free = the face borders may move within --tol (default); "
                             "fixed = put the source's border rows of poles back (not with "
                             "--method energy, which keeps them anyway)")
    parser.add_argument("--convert", action="store_true",
                        help="convert non-B-spline faces to B-splines and fair them too")


def check_method(args):
    """Refuse the fairing options ``args.method`` does not use
    (:func:`cq_fairing.core.options.face_applies`: --objective and --borders need
    --method wavelet or adaptive, --objective faithful adaptive, --grading wavelet,
    --target-degree and --boundary not energy),
    --grading with --target (no search runs), and --target with the methods that choose
    their own net.  An option spelled out at its default is no request, as
    in the API."""
    for name in ("objective", "borders", "grading", "target_degree", "boundary"):
        value = getattr(args, name)
        allowed = [method for method in face_applies(name, value) if method in METHODS]
        if value in (None, DEFAULTS[name]) or args.method in allowed:
            continue
        option = "--" + name.replace("_", "-")
        shown = " ".join(map(str, value)) if isinstance(value, list) else value
        raise InvalidInputError(
            f"{option} {shown} applies to --method {' or '.join(allowed)} only, got "
            f"--method {args.method}, which {METHOD_DOES[args.method]}; add --method "
            f"{allowed[-1]} or drop {option}.")
    if args.target is not None and args.grading not in (None, DEFAULTS["grading"]):
        raise InvalidInputError(f"--grading {args.grading} applies to the tolerance search, "
                                "which does not run with --target; drop --grading or give "
                                "--tol instead of --target.")
    if args.method != "wavelet" and args.target is not None:
        what = "keeps the control points" if args.method == "energy" else \
            "chooses the target itself"
        raise InvalidInputError(f"--method {args.method} {what}; give --tol instead of "
                                "--target, or use --method wavelet.")


def fairing_keywords(args):
    """The fairing options of ``fair`` and ``batch`` as ``fair_shape``'s keywords, an
    option not given at its default (:data:`cq_fairing.core.options.DEFAULTS`)."""
    return dict(method=args.method, objective=args.objective or DEFAULTS["objective"],
                borders=args.borders or DEFAULTS["borders"],
                boundary=args.boundary or DEFAULTS["boundary"],
                grading=args.grading or DEFAULTS["grading"],
                target_degree=target_degree_option(args.target_degree),
                joins=args.joins, angle_tol=args.angle_tol)


def target_degree_option(values):
    """--target-degree P or P_U P_V as ``fair_shape``'s ``target_degree`` (``None``: each
    face's own, at most 3)."""
    if values is None:
        return None
    if len(values) > 2:
        raise InvalidInputError(
            f"--target-degree takes one degree or two (u and v), got {len(values)}: "
            f"{' '.join(map(str, values))}.")
    return (values[0], values[-1])
