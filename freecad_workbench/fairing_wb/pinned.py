r"""Fair the faces whose joins run across their surfaces, each join pinned to its source.

A trimmed face's inner edge leaves its parameter rectangle's borders: no shared or
pinned border row can hold it (:func:`~cq_fairing.core.joint_projection.unholdable`).
As ``cq-fairing fair`` does (``cq_fairing.occ.pinned``), such a face is projected onto
its own target (its tolerance search's spaces) with every one of its joins pinned to
its source at samples of the edge's p-curve on the face, the tangent plane too across a
smooth join (:func:`~cq_fairing.core.pinned_projection.pin_face`), within the core's
budgets and rules (:mod:`cq_fairing.core.pinned_faces`).  Here FreeCAD's Part supplies
the p-curves (``Part.Face.curveOnSurface``: the Geom2d curve on the face and the edge's
range on it, sampled from the edge's start to its end), and the caller's measure checks
each pinned face against its tolerance.  A join edge is never a seam of its face (a
seam is no join, :mod:`fairing_wb.joins`), so the edge's orientation does not choose
between two p-curves.
"""

from dataclasses import dataclass

import numpy as np

from cq_fairing.core.joint_projection import joint_targets
from cq_fairing.core.pinned_faces import (
    attempt_pin,
    over_sentence,
    pinned_sentence,
    pinned_sides,
    unpinned_sentence,
)
from cq_fairing.core.pinned_projection import PinnedEdge

from .trim import curve_points

__all__ = ["PinnedFaces", "pin_faces"]


@dataclass(frozen=True)
class PinnedFaces:
    """What :func:`pin_faces` did.

    Attributes
    ----------
    surfaces : dict
        ``{face: BSplineSurface}``: the faces pinned, each within its tolerance.
    deviations : dict
        ``{face: float}``: their deviations by the caller's measure.
    notes : dict
        ``{face: str}``: for a face pinned, what its joins do; for a face kept, why
        (in the command line's words, the neighbours named as the elements).
    """

    surfaces: dict
    deviations: dict
    notes: dict


def pin_faces(found, elements, stuck, alone, tolerance, continuity, method, check):
    """Pin the joins of each face of ``stuck`` to its source, or say why it is kept.

    Parameters
    ----------
    found : FaceJoins
        The joins (:func:`fairing_wb.joins.find_joins`).
    elements : sequence of (str, Part.Face)
        The faces of ``found``, in its order, with their names.
    stuck : dict
        ``{face: [neighbour faces]}``: the faces whose joins run across their surfaces
        (:func:`~cq_fairing.core.joint_projection.unholdable`).
    alone : dict
        ``{face: BSplineSurface}``: the faces faired alone (their targets).
    tolerance : float
    continuity : {"G0", "G1", "G2"}
        ``"G0"`` pins the points only; otherwise the smooth joins pin the tangent planes.
    method : {"wavelet", "adaptive", "energy"}
        ``"energy"`` keeps each face's net: no face is projected (each is kept).
    check : callable
        ``check(face, surface) -> float``: the face's two-sided deviation.

    Returns
    -------
    PinnedFaces
    """
    targets = joint_targets(found.readable, {face: alone[face] for face in stuck
                                             if face in alone})
    surfaces, deviations, notes = {}, {}, {}
    for face, neighbours in stuck.items():
        names = ", ".join(elements[n][0] for n in neighbours)
        joins = [join for join in found.joins if face in join.faces]
        edges = _edges(found, elements[face][1], face, joins, continuity)
        target = None if method == "energy" else targets.get(face)
        attempt = attempt_pin(found.readable.get(face), target, edges, joins, found.size,
                              tolerance)
        if not attempt.met:
            notes[face] = f"{unpinned_sentence(names, attempt)} (Joins=free fairs it alone)"
            continue
        deviation = check(face, attempt.outcome.surface)
        if deviation > tolerance:
            notes[face] = (f"{over_sentence(deviation, tolerance, attempt.outcome.refined)}; "
                           "its neighbours close onto it")
            continue
        surfaces[face], deviations[face] = attempt.outcome.surface, deviation
        notes[face] = (f"faired with its joins (with {names}) pinned to its source: "
                       f"{pinned_sentence(attempt.outcome)}")
    return PinnedFaces(surfaces, deviations, notes)


def _edges(found, face, index, joins, continuity):
    """A :class:`~cq_fairing.core.pinned_projection.PinnedEdge` per side of ``joins`` on
    face ``index`` (``face``, a Part.Face); ``None`` when one has no p-curve on it."""
    out = []
    for side, smooth in pinned_sides(joins, index, continuity):
        pcurve = face.curveOnSurface(found.edges[side.edge])
        if pcurve is None:
            return None
        out.append(PinnedEdge(_sampler(*pcurve), smooth))
    return out


def _sampler(curve, first, last):
    """``uv(t)``: the p-curve's points at ``first + t (last - first)``
    (:func:`trim.curve_points`)."""
    def uv(t):
        return curve_points(curve, first + np.asarray(t, float) * (last - first))
    return uv
