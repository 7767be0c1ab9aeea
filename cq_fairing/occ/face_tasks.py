"""One face's fairing as a task: its report, whatever happens to it.

A model's faces are faired one by one, in this process or in workers
(:mod:`cq_fairing.occ.engine`); a face that cannot be faired keeps its surface and says
why, so that the others go on.
"""

import time

import numpy as np

from ..errors import FairingError, ToleranceNotMetError
from .convert import face_info, is_occt_error
from .faces import FaceFairReport, fair_face

__all__ = ["fair_one_face", "kept_face_report"]


def fair_one_face(index, face, options):
    """``fair_face(face, **options)`` with the face's failures turned into its report.

    A :class:`~cq_fairing.errors.FairingError`, an OCCT exception
    (``Standard_Failure`` and its kinds, see :func:`is_occt_error`) or a
    ``numpy.linalg.LinAlgError`` gives status ``'tolerance-not-met'`` (for
    :class:`~cq_fairing.errors.ToleranceNotMetError`) or ``'failed'`` with a one-line
    message; the face is kept, and its report keeps the face's type, its poles (before and
    after alike: the output holds the original) and the time spent.  Any other exception
    is a bug and propagates.
    """
    start = time.perf_counter()
    try:
        report = fair_face(face, **options)
    except Exception as exc:
        if not isinstance(exc, (FairingError, np.linalg.LinAlgError)) and not is_occt_error(exc):
            raise
        status = "tolerance-not-met" if isinstance(exc, ToleranceNotMetError) else "failed"
        report = kept_face_report(face, status, _one_line(exc), tolerance=options.get("tol"),
                                  seconds=time.perf_counter() - start)
    report.index = index
    return report


def kept_face_report(original, status, message, index=None, tolerance=None, seconds=0.0):
    """:class:`FaceFairReport` of a face kept as it was (refused, failed, or restored):
    its type, its poles (before and after alike: the output holds the original) and the
    time spent on it."""
    info = _info_if_readable(original)
    poles = (info.n_poles_u, info.n_poles_v) if info and info.n_poles_u else None
    return FaceFairReport(original, status, message, original=original, info=info,
                          poles_before=poles, poles_after=poles, tolerance=tolerance,
                          seconds=seconds, index=index)


def _info_if_readable(face):
    """:func:`~cq_fairing.occ.face_info` of a face whose fairing failed, ``None`` when
    OCCT cannot read it either."""
    try:
        return face_info(face)
    except Exception as exc:
        if not is_occt_error(exc):
            raise
        return None


def _one_line(exc):
    text = " ".join(str(exc).split())
    if isinstance(exc, FairingError):
        return text
    where = "OCCT" if is_occt_error(exc) else "linear algebra"
    return f"{where} error {type(exc).__name__} ({text or 'no message'}); kept the original"
