r"""Fair the faces whose joins run across their surfaces, each join pinned to its source.

A trimmed face's inner edge leaves its parameter rectangle's borders: no shared or
pinned border row can hold it (:func:`~cq_fairing.core.joint_projection.unholdable`).
Such a face is projected onto its own target (its tolerance search's spaces) with every
one of its joins pinned to its source by equality rows at samples of the edge's p-curve
on the face: the point, and the tangent plane across a smooth join
(:func:`~cq_fairing.core.pinned_projection.pin_face`).  Its neighbours then meet it as
they met its source, to within the residual measured between the samples: each side of
a join within its share of the budget, and which faces are tried, are the core's rule
(:mod:`cq_fairing.core.pinned_faces`).  The face is then checked by
OCCT against its tolerance (:meth:`~cq_fairing.occ.shapes._Job.measured`) as every
solved face is.  A face that misses the budget after
:data:`~cq_fairing.core.joint_projection.REFINEMENTS` span halvings, or its tolerance,
is kept as it was, and its report names its joins; so is a face with a join that the
source leaves open by more than :data:`~cq_fairing.core.joint_projection.SOURCE_GAP`
times its tolerance (the neighbour then lies off the face's edge, where its measure
projects it onto the face's moved interior).  In the joint projection a pinned
face stands as a kept one: its neighbours' sides along it are held at its source.
"""

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

from ..core.joint_projection import joint_targets, unholdable
from ..core.pinned_faces import (
    attempt_pin,
    over_sentence,
    pinned_sentence,
    pinned_sides,
    unpinned_sentence,
)
from ..core.pinned_projection import PinnedEdge
from .pcurves import pcurve_points

__all__ = ["pin_unholdable"]


def pin_unholdable(job, adjacency, sources, continuity):
    """Fair each faired face with a join no border row can hold with all its joins
    pinned to its source; keep those that cannot be.

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
        After its first pass: the reports of the faces pinned or kept are replaced.
    adjacency : Adjacency
        The source's joins.
    sources : dict
        ``{face: BSplineSurface}``: the faces read as non-periodic B-spline nets (a face
        not among them is kept).
    continuity : {"G0", "G1", "G2"}
        ``"G0"`` pins the points only; otherwise the smooth joins pin the tangent
        planes too.

    Returns
    -------
    set of int
        The faces pinned and faired.
    """
    moved = {face for face, report in enumerate(job.reports) if report.faired}
    found = unholdable(adjacency.joins, sources, moved, job.tol)
    targets = joint_targets(sources, {face: job.reports[face].surface for face in found})
    pinned, curves = set(), _Curves(job.source)
    for face, neighbours in found.items():
        joins = adjacency.joins_of(face)
        edges = curves.edges(job.originals[face], face, joins, continuity)
        target = None if job.options["method"] == "energy" else targets.get(face)
        attempt = attempt_pin(sources.get(face), target, edges, joins, adjacency.size,
                              job.tol[face])
        if not attempt.met:
            _keep(job, face, neighbours, attempt)
            continue
        outcome = attempt.outcome
        measured = job.measured(face, outcome.surface, sources.get(face))
        if measured[2]["max"] > job.tol[face]:
            _keep_over(job, face, measured[2]["max"], outcome.refined, neighbours)
            continue
        job.faired(face, measured, (
            f"faired with its joins (with faces {[n + 1 for n in neighbours]}) pinned to "
            f"its source: {pinned_sentence(outcome)}"), sources[face].shape)
        pinned.add(face)
    return pinned


class _Curves:
    """The join edges of the source's faces as p-curves, indexed as the adjacency's."""

    def __init__(self, shape):
        self.edge_map = TopTools_IndexedDataMapOfShapeListOfShape()
        TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, self.edge_map)

    def edges(self, face, index, joins, continuity):
        """A :class:`~cq_fairing.core.pinned_projection.PinnedEdge` per side of ``joins``
        on face ``index``; ``None`` when one has no p-curve on the face."""
        out = []
        for side, smooth in pinned_sides(joins, index, continuity):
            edge = TopoDS.Edge_s(self.edge_map.FindKey(side.edge).Oriented(TopAbs_FORWARD))
            curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            if curve is None:
                return None
            first, last = BRep_Tool.Range_s(edge, face)
            out.append(PinnedEdge(_sampler(curve, first, last), smooth))
        return out


def _sampler(curve, first, last):
    """``uv(t)``: the p-curve's points at ``first + t (last - first)``
    (:func:`~cq_fairing.occ.pcurves.pcurve_points`)."""
    points = pcurve_points(curve)

    def uv(t):
        return points(first + np.asarray(t, float) * (last - first))
    return uv


def _keep(job, face, neighbours, attempt):
    """Keep a face whose joins run across its surface, saying why ``attempt``
    (:func:`~cq_fairing.core.pinned_faces.attempt_pin`) did not pin it."""
    why = unpinned_sentence(f"faces {[n + 1 for n in neighbours]}", attempt)
    job.reports[face] = job.kept(face, "unchanged", (
        f"{why}: kept as it was (joins='free' fairs it alone)"))


def _keep_over(job, face, deviation, refined, neighbours):
    """Keep a face that its pinned joins hold over its tolerance."""
    job.reports[face] = job.kept(face, "tolerance-not-met", (
        f"{over_sentence(deviation, job.tol[face], refined)}; kept as it was, and its "
        f"neighbours close onto it (joins with faces {[n + 1 for n in neighbours]})"))
