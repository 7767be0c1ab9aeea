"""The report of one model faired by :func:`~cq_fairing.occ.fair_shape`: one entry per
face (status, poles, deviation, fairness before and after) and the model's joins, as
``cq-fairing fair --report`` and ``cq-fairing batch`` write it (:mod:`cq_fairing.report`
renders it)."""

import re

__all__ = ["shape_report", "faired_reports", "source_and_box"]

STATUS = {"faired": "ok", "unchanged": "unchanged", "tolerance-not-met": "tolerance-not-met",
           "failed": "failed"}



def source_and_box(face):
    """The original face's core surface and its UV box (for before/after measures)."""
    from .occ import face_to_surface
    from .occ.builders import face_uv_box

    return face_to_surface(face.original)[0], face_uv_box(face.original)


def faired_reports(result):
    """The reports of the faces faired in ``result``, with their surfaces and originals."""
    return [f for f in result.faces
            if f.status == "faired" and f.surface is not None and f.original is not None]


def shape_report(result, tol, seconds, *, input_path, output_path, method, objective=None,
                 borders=None, grading=None, kept=None, parts=None, command=None):
    """The report dict of ``result`` (:func:`cq_fairing.report.build_report`);
    ``objective`` for ``"adaptive"`` and ``"wavelet"`` with a tolerance, ``borders``
    for ``"adaptive"`` and ``"wavelet"``, ``grading`` for ``"wavelet"`` with a
    tolerance only."""
    from .report import build_report, face_entry
    from .viz import fairness_measures

    faired = faired_reports(result)
    entries = []
    for index, face in enumerate(result.faces):
        before = after = None
        if face in faired:
            source, box = source_and_box(face)
            before = fairness_measures(source, box)
            after = fairness_measures(face.surface, box)
        deviation = face.deviation
        stats = None if not deviation else {k: deviation.get(k) for k in ("max", "mean", "rms")}
        entries.append(face_entry(
            index + 1, surface_type=face.info.surface_type if face.info else None,
            status=STATUS.get(face.status, "skipped"), message=_in_options(face.message),
            poles_before=face.poles_before, poles_after=face.poles_after,
            max_deviation=face.max_deviation, tolerance=face.tolerance,
            fairness_before=before, fairness_after=after, seconds=face.seconds,
            deviation=stats, part=parts[index] if parts else None,
            degree_before=_degrees(face.info),
            degree_after=_degrees(face.info if face.status == "unchanged" else face.surface),
            rational=face.info.rational if face.info and face.info.is_bspline else None))
    searched = method == "adaptive" or (method == "wavelet" and tol)
    return build_report(entries, input_path=input_path, output_path=output_path,
                        tolerance=tol, method=method,
                        objective=(objective or "auto") if searched else None,
                        borders=(borders or "auto") if method != "energy" else None,
                        grading=(grading or "auto") if method == "wavelet" and tol else None,
                        max_gap=result.max_gap, joins=_joins_entry(result.joins),
                        valid=result.valid, seconds=seconds, kept=kept,
                        command=command, units="model units")


def _joins_entry(joins):
    """The report's ``joins``: one line, the summary and a row per join."""
    return dict(line=joins.line(), summary=joins.summary(), rows=joins.rows())


def _degrees(geometry):
    """``(u_degree, v_degree)`` of a surface or of a B-spline face's info, else ``None``."""
    if geometry is None or not getattr(geometry, "u_degree", None):
        return None
    return geometry.u_degree, geometry.v_degree


def _in_options(message):
    """A face message in the command's terms (the API's ``convert=True`` is ``--convert``,
    ``target_degree=(p, q)`` is ``--target-degree p q``)."""
    if not message:
        return message
    message = message.replace("pass convert=True", "pass --convert")
    return re.sub(r"target_degree=\((\d+), (\d+)\)", r"--target-degree \1 \2", message)
