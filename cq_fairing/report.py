"""Fairing reports: JSON for scripts and a self-contained HTML page for people.

A report is a plain dict (see :func:`build_report`) with one entry per face:
control points before -> after, the largest true distance between original and
faired face against the tolerance, fairness before -> after (bending energy,
curvature range, wiggle count), the time, and the status (``ok``: faired,
``unchanged``: kept its surface, ``tolerance-not-met``, ``skipped`` or ``failed``
with the reason).  :func:`write_json` and :func:`write_html` write it; the HTML page
embeds the PNG maps as base64 so it is one file an engineer can mail to a colleague.

Every writer here goes through :func:`atomic_output`: the data is written to a
temporary file next to the target and renamed over it only when complete, so a
failure never leaves a half-written file.  The renamed file gets the mode a plain
``open(path, "w")`` would give it (the old file's mode when overwriting, else
``0o666`` minus the umask), not the ``0o600`` of :func:`tempfile.mkstemp`.

Temporaries are named ``.cq_fairing_*``.  A process killed with SIGKILL cannot
remove its own; the next write into the same folder removes those left behind:
regular files of this naming pattern, owned by the current user and untouched for
:data:`STALE_SECONDS` (a day; a live writer updates its temporary within seconds).
This module needs the standard library and numpy only.
"""

import base64
import datetime
import html
import json
import math
import os
import stat
import tempfile
import time
from contextlib import contextmanager
from pathlib import Path

from .errors import OutputPathError

__all__ = ["atomic_output", "check_output_path", "build_report", "write_json", "write_html",
           "write_report", "face_entry", "summary_table", "folder_error", "temporary_beside",
           "publish", "remove_stale_temporaries", "TEMP_PREFIX", "STALE_SECONDS", "model_row",
           "batch_summary", "batch_table", "render_batch_html", "write_batch_summary"]

#: Name prefix of every temporary file the writers create next to their target.
TEMP_PREFIX = ".cq_fairing_"
#: Age (seconds since the last change) after which a ``.cq_fairing_*`` file is stale.
STALE_SECONDS = 24 * 3600.0

#: Face statuses that count as success: faired (``ok``), or kept as it was within the
#: tolerance (``unchanged``: nothing to reduce, or restored to close a gap).
OK_STATUSES = ("ok", "unchanged")
#: Face statuses of faces the run did not handle (their poles are not summed).
NOT_HANDLED = ("skipped", "failed")


# -- safe output ----------------------------------------------------------------------------
def check_output_path(path, *, force=False, inputs=()):
    """Validate an output path before any work is done.

    Raises
    ------
    OutputPathError
        If ``path`` is one of ``inputs`` (same file), exists and ``force`` is false, is
        a directory, or its folder does not exist or is not writable.
    """
    path = Path(path)
    for source in inputs:
        source = Path(source)
        if source.exists() and path.exists() and os.path.samefile(source, path) \
                or path.resolve() == source.resolve():
            raise OutputPathError(
                f"output {str(path)!r} is the input file; write to a new file "
                "(the input is never changed)."
            )
    if path.is_dir():
        raise OutputPathError(f"output {str(path)!r} is a directory; give a file name.")
    if path.exists() and not force:
        raise OutputPathError(
            f"output {str(path)!r} already exists; choose another name or pass --force "
            "(force=True) to overwrite it."
        )
    folder = path.resolve().parent
    problem = folder_error(folder)
    if problem:
        raise OutputPathError(f"cannot write output {str(path)!r}: {problem}.")
    if not os.access(folder, os.W_OK):
        raise OutputPathError(f"folder {str(folder)!r} is not writable; choose another output.")
    return path


@contextmanager
def atomic_output(path, *, force=False):
    """Yield a temporary path next to ``path``; rename it onto ``path`` on success.

    The temporary name keeps the suffix of ``path`` (writers that pick the format
    from the suffix still work).  If the block raises, or writes nothing, the
    temporary file is removed and ``path`` is untouched.

    Raises
    ------
    OutputPathError
        See :func:`check_output_path`; also if the block produced no file or an empty
        one, or the rename fails.
    """
    path = check_output_path(path, force=force)
    try:
        tmp = temporary_beside(path)
    except OSError as exc:
        raise OutputPathError(f"cannot write {str(path)!r}: {exc.strerror or exc}.") from exc
    try:
        yield tmp
        if not tmp.exists() or tmp.stat().st_size == 0:
            raise OutputPathError(f"writing {str(path)!r} produced no data; nothing was written.")
        if path.exists() and not force:
            raise OutputPathError(f"output {str(path)!r} appeared while writing; not overwritten.")
        publish(tmp, path)
    except OSError as exc:
        raise OutputPathError(f"cannot write {str(path)!r}: {exc.strerror or exc}.") from exc
    finally:
        if tmp.exists():
            tmp.unlink()


def folder_error(folder):
    """Why ``folder`` cannot hold a new file, or ``None`` when it is an existing folder.

    Returns
    -------
    str or None
        ``"'x' is a file, not a folder"`` when ``folder`` or one of its parents is a
        regular file, ``"folder 'x' does not exist"`` otherwise.
    """
    folder = Path(folder)
    if folder.is_dir():
        return None
    for part in (folder, *folder.parents):
        if part.exists() and not part.is_dir():
            return f"{str(part)!r} is a file, not a folder"
        if part.exists():
            break
    return f"folder {str(folder)!r} does not exist"


def temporary_beside(path):
    """An empty temporary file ``.cq_fairing_*<suffix>`` in the folder of ``path``.

    Stale temporaries of killed writers in that folder are removed first
    (:func:`remove_stale_temporaries`).

    Raises
    ------
    OSError
        The folder does not accept a new file.
    """
    folder = Path(path).resolve().parent
    remove_stale_temporaries(folder)
    fd, tmp = tempfile.mkstemp(prefix=TEMP_PREFIX, suffix=Path(path).suffix, dir=folder)
    os.close(fd)
    return Path(tmp)


def remove_stale_temporaries(folder, max_age=STALE_SECONDS):
    """Remove ``.cq_fairing_*`` regular files of this user untouched for ``max_age`` s.

    Returns
    -------
    list of Path
        The files removed.  Files that vanish or cannot be removed meanwhile are skipped.
    """
    removed, now = [], time.time()
    for entry in Path(folder).glob(TEMP_PREFIX + "*"):
        try:
            info = entry.lstat()
            if (stat.S_ISREG(info.st_mode) and info.st_uid == os.getuid()
                    and now - info.st_mtime > max_age):
                entry.unlink()
                removed.append(entry)
        except OSError:
            continue
    return removed


def publish(tmp, path):
    """Rename the finished ``tmp`` onto ``path`` with the mode a plain write would give.

    That is the mode of the file being replaced, or ``0o666`` minus the process umask
    for a new file (``mkstemp`` creates ``0o600``).
    """
    path = Path(path)
    try:
        mode = stat.S_IMODE(path.stat().st_mode)
    except FileNotFoundError:
        mode = 0o666 & ~_umask()
    os.chmod(tmp, mode)
    os.replace(tmp, path)


def _umask():
    """The process umask (read by setting it and putting it back at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _write_text(path, text, force):
    with atomic_output(path, force=force) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


# -- report content -------------------------------------------------------------------------
def _clean(value):
    """JSON-safe copy: numpy scalars/arrays to Python, NaN/inf to None, tuples to lists."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if hasattr(value, "tolist"):
        return _clean(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


def face_entry(index, *, surface_type=None, status, message="", poles_before=None,
               poles_after=None, max_deviation=None, tolerance=None, fairness_before=None,
               fairness_after=None, seconds=None, deviation=None, degree_before=None,
               degree_after=None, part=None, rational=None):
    """One face of a report (a dict; ``None`` for what does not apply).

    Parameters
    ----------
    index : int
        1-based face index, as listed by ``cq-fairing inspect``.
    status : str
        ``ok`` (the surface was replaced by the faired one), ``unchanged`` (the original
        surface was kept: nothing to reduce, or restored to close a gap),
        ``tolerance-not-met``, ``skipped`` or ``failed``.
    poles_before, poles_after : (int, int)
        Control net sizes.
    max_deviation : float
        Largest true distance (model units) between the original and the faired face,
        both ways (OCCT's check).
    fairness_before, fairness_after : dict
        See :func:`cq_fairing.viz.fairness_measures`.
    deviation : dict, optional
        ``max``, ``mean``, ``rms`` of the dense deviation sample.
    part : str, optional
        In an assembly, the placement the face is on (``"rotor/blade_1"``).
    rational : bool, optional
        Whether the face's surface (B-spline faces) has weights.
    """
    within = None
    if max_deviation is not None and tolerance is not None:
        within = bool(max_deviation <= tolerance)
    return _clean({
        "index": index, "surface_type": surface_type, "status": status, "message": message,
        "poles_before": poles_before, "poles_after": poles_after,
        "degree_before": degree_before, "degree_after": degree_after,
        "max_deviation": max_deviation, "tolerance": tolerance, "within_tolerance": within,
        "deviation": deviation, "fairness_before": fairness_before,
        "fairness_after": fairness_after, "seconds": seconds, "part": part,
        "rational": rational,
    })


def build_report(faces, *, input_path=None, output_path=None, tolerance=None,
                 method=None, objective=None, borders=None, grading=None, max_gap=None,
                 valid=None,
                 maps=None, seconds=None, command=None, units="mm", kept=None, joins=None):
    """The whole report: settings, one entry per face (see :func:`face_entry`), summary.

    The summary counts ``faces_total``, ``faces_ok`` (``ok`` and ``unchanged``),
    ``faces_faired`` (``ok``: the surface was replaced), ``faces_unchanged``,
    ``faces_tolerance_not_met``, ``faces_skipped`` and ``faces_failed``; it sums
    ``poles_before``/``poles_after`` and takes ``worst_deviation`` over the faces the
    run handled (all but ``skipped`` and ``failed``): a kept face counts the same poles
    before and after, so the difference is what fairing removed and the totals what
    those faces hold in the output.

    Returns
    -------
    dict
        Keys ``tool``, ``created``, ``command``, ``input``, ``output``, ``tolerance``,
        ``units``, ``method``, ``objective`` (``"auto"``/``"compact"``/``"faithful"``/
        ``"fair"`` for the adaptive method and the wavelet method with a tolerance, else
        ``None``), ``borders`` (``"auto"``/``"free"``/``"pinned"``
        for the adaptive and wavelet methods, else ``None``), ``grading`` (``"auto"``/``"uniform"``
        for the wavelet method with a tolerance, else ``None``), ``faces``, ``summary``
        (counts, poles before/after,
        worst deviation, largest gap fairing opened between faces (beyond the
        source's own gap on each edge), validity, time), ``maps`` (name ->
        PNG/VTP path), ``skipped`` (index, reason) and ``kept`` (what the output keeps of
        the input besides geometry: counts of ``products``, ``instances``, ``colours``
        and ``layers``, or ``None`` when the output is geometry only), ``joins``
        (``line``: the joins' summary in one line, ``summary`` and ``rows``: per join
        the faces, kind, held, source and faired gap and angle; see
        :class:`~cq_fairing.occ.joint.JoinReport`; ``None`` without a model).
    """
    from . import __version__

    faces = list(faces)
    handled = [f for f in faces if f["status"] not in NOT_HANDLED]
    deviations = [f["max_deviation"] for f in handled if f["max_deviation"] is not None]
    summary = {
        "faces_total": len(faces),
        "faces_faired": sum(f["status"] == "ok" for f in faces),
        "faces_unchanged": sum(f["status"] == "unchanged" for f in faces),
        "faces_ok": sum(f["status"] in OK_STATUSES for f in faces),
        "faces_tolerance_not_met": sum(f["status"] == "tolerance-not-met" for f in faces),
        "faces_skipped": sum(f["status"] == "skipped" for f in faces),
        "faces_failed": sum(f["status"] == "failed" for f in faces),
        "poles_before": sum(_count(f["poles_before"]) for f in handled),
        "poles_after": sum(_count(f["poles_after"]) for f in handled),
        "worst_deviation": max(deviations) if deviations else None,
        "max_gap": max_gap, "valid": valid, "seconds": seconds,
    }
    return _clean({
        "tool": f"cq-fairing {__version__}",
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": command, "input": _str(input_path), "output": _str(output_path),
        "tolerance": tolerance, "units": units, "method": method, "objective": objective,
        "borders": borders, "grading": grading, "kept": kept, "joins": joins,
        "faces": faces, "summary": summary, "maps": {k: _str(v) for k, v in (maps or {}).items()},
        "skipped": [{"index": f["index"], "reason": f["message"]}
                    for f in faces if f["status"] in NOT_HANDLED],
    })


def _str(path):
    return None if path is None else str(path)


def _count(net):
    return 0 if not net else math.prod(int(k) for k in net)


def write_json(report, path, *, force=False):
    """Write ``report`` as indented JSON, atomically. Returns the path."""
    return _write_text(path, json.dumps(report, indent=2, allow_nan=False) + "\n", force)


# -- text and HTML ----------------------------------------------------------------------------
def _fmt(value, digits=4):
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return "x".join(_fmt(v, digits) for v in value)
    return str(value)


def _range(pair):
    return "-" if not pair else f"[{_fmt(pair[0], 3)}, {_fmt(pair[1], 3)}]"


def _fair(face, key, fmt=_fmt):
    before = (face.get("fairness_before") or {}).get(key)
    after = (face.get("fairness_after") or {}).get(key)
    if before is None and after is None:
        return "-"
    return f"{fmt(before)} -> {fmt(after)}"


COLUMNS = ("face", "type", "poles", "max dev", "tol", "energy", "wiggles", "time s", "status")


def _columns(report):
    """The table's columns: a ``part`` column when the faces lie on several placements."""
    several = len({face.get("part") for face in report["faces"]}) > 1
    return COLUMNS + (("part",) if several else ())


def _row(face, columns=COLUMNS):
    part = (face.get("part") or "-",) if "part" in columns else ()
    return (str(face["index"]), face.get("surface_type") or "-",
            f"{_fmt(face['poles_before'])} -> {_fmt(face['poles_after'])}"
            if face["poles_after"] else _fmt(face["poles_before"]),
            _fmt(face["max_deviation"]), _fmt(face["tolerance"]),
            _fair(face, "bending_energy", lambda v: _fmt(v, 3)),
            _fair(face, "wiggles", lambda v: _fmt(v, 3)),
            _fmt(face["seconds"], 3), face["status"]) + part


def summary_table(report):
    """A fixed-width text table of the faces and a summary line (for the terminal)."""
    columns = _columns(report)
    rows = [columns] + [_row(f, columns) for f in report["faces"]]
    widths = [max(len(r[i]) for r in rows) for i in range(len(columns))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    s = report["summary"]
    lines.append(
        f"{s['faces_ok']}/{s['faces_total']} faces ok ({s['faces_faired']} faired, "
        f"{s['faces_unchanged']} unchanged), {s['faces_tolerance_not_met']} over "
        f"tolerance, {s['faces_skipped']} skipped, {s['faces_failed']} failed; poles "
        f"{s['poles_before']} -> {s['poles_after']}; worst deviation "
        f"{_fmt(s['worst_deviation'])} {report['units']} (tolerance {_fmt(report['tolerance'])})"
    )
    if report.get("joins"):
        lines.append(report["joins"]["line"])
    return "\n".join(lines)


_CSS = """
body{font-family:sans-serif;margin:2em;color:#222}table{border-collapse:collapse;margin:1em 0}
th,td{border:1px solid #bbb;padding:4px 8px;text-align:right}th{background:#eee}
td.l{text-align:left}.ok{background:#dfd}.bad{background:#fdd}.skip{background:#eee}
img{max-width:100%;border:1px solid #ccc;margin:0.5em 0}code{background:#f4f4f4}
"""


def _image(path, caption):
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return (f"<figure><img alt='{html.escape(caption)}' src='data:image/png;base64,{data}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def _cells(cells, left):
    """A table row's ``<td>`` cells, those at the indices ``left`` aligned left."""
    return "".join(f"<td class='l'>{html.escape(c)}</td>" if i in left
                   else f"<td>{html.escape(c)}</td>" for i, c in enumerate(cells))


def _html_table(report):
    cls = {"ok": "ok", "unchanged": "ok", "tolerance-not-met": "bad", "failed": "bad",
           "skipped": "skip"}
    columns = _columns(report)
    left = {1, 8, 9} if "part" in columns else {1, 8}  # type, status, part
    head = "".join(f"<th>{html.escape(c)}</th>" for c in columns + ("curvature H",))
    body = []
    for face in report["faces"]:
        cells = _row(face, columns) + (_fair(face, "mean_curvature_range", _range),)
        body.append(f"<tr class='{cls.get(face['status'], '')}'>{_cells(cells, left)}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


JOIN_COLUMNS = ("faces", "kind", "held", "source gap", "gap", "source angle (deg)",
                "angle (deg)", "angle excess (deg)")


def _joins_html(joins):
    """The joins' table: one row per join of the source, its gap and normal angle in the
    source and faired (``rows`` of the report's ``joins``); none for a report without
    joins."""
    rows = (joins or {}).get("rows") or []
    if not rows:
        return "<p>no joins</p>"
    head = "".join(f"<th>{html.escape(c)}</th>" for c in JOIN_COLUMNS)
    body = []
    for row in rows:
        cells = (" - ".join(str(f) for f in row["faces"]), row["kind"],
                 "yes" if row["held"] else "no", _fmt(row["source_gap"], 3),
                 _fmt(row["gap"], 3), _fmt(row["source_angle"], 3), _fmt(row["angle"], 3),
                 _fmt(row["angle_excess"], 3))
        body.append(f"<tr>{_cells(cells, {0, 1, 2})}</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def _method(report):
    """``adaptive (faithful, auto borders)``, ``wavelet (auto borders, auto grading)``,
    or the bare method when it has none."""
    settings = [s for s in (report.get("objective"),
                            report.get("borders") and f"{report['borders']} borders",
                            report.get("grading") and f"{report['grading']} grading") if s]
    return f"{report['method']} ({', '.join(settings)})" if settings else report["method"]


def kept_text(kept):
    """``2 products, 3 instances, 1 colour, 0 layers`` from the report's ``kept`` counts."""
    return ", ".join(f"{count} {name[:-1] if count == 1 else name}"
                     for name, count in kept.items())


def render_html(report):
    """The report as one self-contained HTML page (maps embedded as base64 PNG)."""
    s = report["summary"]
    esc = html.escape
    settings = [("input", report["input"]), ("output", report["output"]),
                ("tolerance", f"{_fmt(report['tolerance'])} {report['units']}"),
                ("method", _method(report)), ("command", report["command"]),
                ("created", report["created"]), ("tool", report["tool"])]
    if report.get("kept"):
        settings.append(("kept from the input", kept_text(report["kept"])))
    summary = [("faces ok / total", f"{s['faces_ok']} / {s['faces_total']}"),
               ("faired", s["faces_faired"]), ("unchanged", s["faces_unchanged"]),
               ("over tolerance", s["faces_tolerance_not_met"]),
               ("skipped", s["faces_skipped"]), ("failed", s["faces_failed"]),
               ("control points", f"{s['poles_before']} -> {s['poles_after']}"),
               ("worst deviation", f"{_fmt(s['worst_deviation'])} {report['units']}"),
               ("largest gap fairing opened between faces", f"{_fmt(s['max_gap'])} {report['units']}"),
               ("valid shape", s["valid"]), ("time", f"{_fmt(s['seconds'], 3)} s")]
    if report.get("joins"):
        summary.append(("joins", report["joins"]["line"]))

    def kv(rows):
        return "<table>" + "".join(f"<tr><th>{esc(str(k))}</th><td class='l'>{esc(_fmt(v))}</td></tr>"
                                   for k, v in rows) + "</table>"

    skipped = "".join(f"<li>face {e['index']}: {esc(e['reason'] or '')}</li>"
                      for e in report["skipped"]) or "<li>none</li>"
    images = "".join(_image(p, name) for name, p in report["maps"].items()
                     if p and str(p).lower().endswith(".png") and Path(p).exists())
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>cq-fairing report"
            f"</title><style>{_CSS}</style></head><body><h1>Fairing report</h1>"
            f"<h2>Settings</h2>{kv(settings)}<h2>Summary</h2>{kv(summary)}"
            f"<h2>Faces</h2><p>max dev: largest true distance from the original face to the "
            f"faired one; energy: thin-plate bending energy before -> after; wiggles: "
            f"sign changes of the mean curvature per iso-line.</p>{_html_table(report)}"
            f"<h2>Joins</h2><p>gap: largest distance between the two faces along the join; "
            f"angle: largest angle between their normals; angle excess: the largest of "
            f"faired minus source angle at the same place; held: closed by construction."
            f"</p>{_joins_html(report.get('joins'))}"
            f"<h2>Skipped or failed</h2><ul>{skipped}</ul><h2>Maps</h2>"
            f"{images or '<p>no maps</p>'}</body></html>\n")


def write_html(report, path, *, force=False):
    """Write :func:`render_html` atomically. Returns the path."""
    return _write_text(path, render_html(report), force)


def write_report(report, path, *, force=False):
    """Write ``.json`` or ``.html``/``.htm`` by the suffix of ``path``.

    Raises
    ------
    OutputPathError
        For another suffix, or see :func:`atomic_output`.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".json":
        return write_json(report, path, force=force)
    if suffix in (".html", ".htm"):
        return write_html(report, path, force=force)
    raise OutputPathError(f"a report must end in .json or .html, got {str(path)!r}.")


# -- a batch of models ----------------------------------------------------------------------
#: Model statuses of a batch: faired now, its earlier output kept (``--resume``), failed.
MODEL_STATUSES = ("done", "resumed", "failed")


def model_row(report=None, *, input_path, status, message="", output_path=None,
              report_path=None, seconds=None, retries=0):
    """One model of a batch summary, from its report (:func:`build_report`; ``None`` for
    a model that failed before one was made).

    Returns
    -------
    dict
        ``input``, ``output``, ``report``, ``status`` (one of :data:`MODEL_STATUSES`),
        ``message``, the report's face counts, poles, worst deviation, tolerance,
        largest gap opened and validity, ``joins`` (its one line), ``joins_total`` and
        ``joins_held``, ``seconds`` and ``retries`` (task runs lost with a worker).
    """
    s = (report or {}).get("summary") or {}
    joins = (report or {}).get("joins") or {}
    counts = joins.get("summary") or {}
    return _clean({
        "input": _str(input_path), "output": _str(output_path), "report": _str(report_path),
        "status": status, "message": message,
        **{key: s.get(key) for key in ("faces_total", "faces_faired", "faces_unchanged",
                                      "faces_tolerance_not_met", "faces_skipped",
                                      "faces_failed", "poles_before", "poles_after",
                                      "worst_deviation", "max_gap", "valid")},
        "tolerance": (report or {}).get("tolerance"), "joins": joins.get("line"),
        "joins_total": counts.get("joins"), "joins_held": counts.get("held"),
        "seconds": seconds, "retries": retries,
    })


def batch_summary(rows, *, command=None, output_dir=None, settings=None, engine=None,
                  seconds=None):
    """The summary of a batch: its settings, one row per model (:func:`model_row`) and
    totals over the models faired or resumed (``models``, ``models_done``,
    ``models_resumed``, ``models_failed``, face counts, poles before/after,
    ``worst_deviation_over_tolerance``: the largest of a model's worst deviation over
    its tolerance, joins and joins held, ``retries``, ``seconds``: the batch's wall time)."""
    from . import __version__

    rows = list(rows)
    handled = [r for r in rows if r["status"] != "failed"]

    def total(key):
        return sum(r[key] or 0 for r in handled)

    ratios = [r["worst_deviation"] / r["tolerance"] for r in handled
              if r["worst_deviation"] is not None and r["tolerance"]]
    summary = {"models": len(rows), **{f"models_{status}": sum(r["status"] == status
                                                              for r in rows)
                                       for status in MODEL_STATUSES},
               **{key: total(key) for key in ("faces_total", "faces_faired",
                                              "faces_unchanged", "faces_tolerance_not_met",
                                              "faces_skipped", "faces_failed",
                                              "poles_before", "poles_after", "joins_total",
                                              "joins_held")},
               "worst_deviation_over_tolerance": max(ratios) if ratios else None,
               "retries": sum(r["retries"] or 0 for r in rows), "seconds": seconds}
    return _clean({
        "tool": f"cq-fairing {__version__}",
        "created": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": command, "output_dir": _str(output_dir), "settings": settings,
        "engine": engine, "models": rows, "summary": summary,
    })


BATCH_COLUMNS = ("model", "status", "faces ok/total", "failed", "poles", "worst dev", "tol",
                 "joins held", "time s", "retries")


def _batch_row(row):
    ok = (row["faces_faired"] or 0) + (row["faces_unchanged"] or 0)
    failed = (row["faces_failed"] or 0) + (row["faces_tolerance_not_met"] or 0)
    done = row["status"] != "failed"
    return (Path(row["input"]).name, row["status"],
            f"{ok}/{row['faces_total']}" if done else "-", str(failed) if done else "-",
            f"{row['poles_before']} -> {row['poles_after']}" if done else "-",
            _fmt(row["worst_deviation"]), _fmt(row["tolerance"]),
            f"{row['joins_held']}/{row['joins_total']}" if row["joins_total"] else "-",
            _fmt(row["seconds"], 3), str(row["retries"]))


def _batch_line(summary):
    s = summary["summary"]
    return (f"{s['models_done'] + s['models_resumed']}/{s['models']} models faired "
            f"({s['models_resumed']} resumed), {s['models_failed']} failed; faces "
            f"{s['faces_faired']} faired, {s['faces_unchanged']} unchanged, "
            f"{s['faces_tolerance_not_met']} over tolerance, {s['faces_failed']} failed; "
            f"poles {s['poles_before']} -> {s['poles_after']}; worst deviation "
            f"{_fmt(s['worst_deviation_over_tolerance'])} x tol; joins held "
            f"{s['joins_held']}/{s['joins_total']}; {s['retries']} retries; "
            f"{_fmt(s['seconds'], 3)} s")


def batch_table(summary):
    """A fixed-width text table of the models, their failures and a totals line."""
    rows = [BATCH_COLUMNS] + [_batch_row(r) for r in summary["models"]]
    widths = [max(len(r[i]) for r in rows) for i in range(len(BATCH_COLUMNS))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in rows]
    lines.insert(1, "  ".join("-" * w for w in widths))
    lines += [f"{Path(r['input']).name}: {r['message']}" for r in summary["models"]
              if r["status"] == "failed"]
    lines.append(_batch_line(summary))
    return "\n".join(lines)


def render_batch_html(summary):
    """The batch summary as one self-contained HTML page."""
    esc = html.escape
    cls = {"done": "ok", "resumed": "ok", "failed": "bad"}
    head = "".join(f"<th>{esc(c)}</th>" for c in BATCH_COLUMNS + ("joins", "message"))
    body = []
    for row in summary["models"]:
        cells = _batch_row(row)
        tds = "".join(f"<td class='l'>{esc(c)}</td>" if i < 2 else f"<td>{esc(c)}</td>"
                      for i, c in enumerate(cells))
        tds += (f"<td class='l'>{esc(row['joins'] or '-')}</td>"
                f"<td class='l'>{esc(row['message'] or '')}</td>")
        body.append(f"<tr class='{cls[row['status']]}'>{tds}</tr>")
    settings = [("command", summary["command"]), ("output folder", summary["output_dir"]),
                ("engine", summary["engine"]), ("created", summary["created"]),
                ("tool", summary["tool"])] + sorted((summary["settings"] or {}).items())
    rows = "".join(f"<tr><th>{esc(str(k))}</th><td class='l'>{esc(_fmt(v))}</td></tr>"
                   for k, v in settings)
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>cq-fairing batch"
            f"</title><style>{_CSS}</style></head><body><h1>Batch fairing summary</h1>"
            f"<h2>Settings</h2><table>{rows}</table><h2>Summary</h2>"
            f"<p>{esc(_batch_line(summary))}</p><h2>Models</h2>"
            f"<p>worst dev: the model's largest face deviation, against its tolerance; "
            f"retries: task runs lost with a worker that died.</p>"
            f"<table><tr>{head}</tr>{''.join(body)}</table></body></html>\n")


def write_batch_summary(summary, json_path, html_path, *, force=False):
    """Write the batch summary as JSON and HTML, each atomically."""
    write_json(summary, json_path, force=force)
    _write_text(html_path, render_batch_html(summary), force)
