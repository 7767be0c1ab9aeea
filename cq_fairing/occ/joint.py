r"""Fair the faces of a model together: joins stay closed and smooth.

After the face-by-face pass has chosen each face's target (its tolerance search), the
joins of the source (a shell's shared edges, a compound's coincident boundaries:
:func:`~cq_fairing.occ.adjacency.find_joins`) are held by the core: patch grids that
form whole parts of the model are merged and faired as one surface
(:mod:`cq_fairing.occ.grids`), the faces faired alone are projected again together
(:func:`~cq_fairing.core.joint_projection.project_jointly`: border joins shared pole for
pole by both faces' projection, G1 across the smooth ones, every other side of a face on
a join pinned to its source), and the faces already at their coarsest are faired
together by energy (:mod:`cq_fairing.occ.networks`).  With the energy method the
networks take the faces faired alone too, faired again together by energy from their
sources, and a face with joins that no network moved is kept.  A face with a join that
runs across its surface (a trimmed face's inner edge) is projected first, alone, with
every one of its joins pinned to its source (:mod:`cq_fairing.occ.pinned`); it then
stands as a kept face for the others (or is kept, where the pins cannot hold).  This
module supplies the OCCT side: the faces read as B-spline patches, each face's target, and OCCT's two-sided
deviation of each solved face (:func:`~cq_fairing.occ.deviation.sample_face_deviation`);
it installs the results and names, in each kept face's report, the joins that bind it.
"""

from dataclasses import dataclass, field

import numpy as np

from ..core.join_summary import summarize, summary_line
from ..core.joins import ANGLE_SLACK
from ..core.joint_projection import (
    REFINEMENTS,
    SOURCE_GAP,
    JointProjection,
    border_joins,
    held_joins,
    joint_targets,
    project_jointly,
    runs_reversed,
)
from ..core.network_fairing import UNMOVED
from ..core.options import JOIN_CONTINUITY
from ..core.pinned_faces import held_by_pins
from ..errors import FairingError
from .convert import face_to_surface, is_occt_error
from .grids import fair_grids
from .networks import fair_networks
from .pinned import pin_unholdable

__all__ = ["fair_joined", "JointOutcome", "JoinReport"]


@dataclass(frozen=True)
class JointOutcome:
    """What :func:`fair_joined` did.

    Attributes
    ----------
    joins : list of Join
        The joins held closed (their faces were solved or kept together).
    grids : list of GridFairing
        The patch grids faired as one surface each (:mod:`cq_fairing.occ.grids`).
    networks : list of NetworkFairing
        The faces at their coarsest faired together by energy
        (:mod:`cq_fairing.occ.networks`).
    curved : list of Join
        The joins held curvature-continuous by the joint projection (``"curvature"``).
    """

    joins: list
    grids: list
    networks: list
    curved: list = field(default_factory=list)


def fair_joined(job, adjacency, joins):
    """Project the faces of ``job`` that meet along whole borders together.

    The patch grids among them that form whole parts of the model are faired first,
    each as one surface (:func:`~cq_fairing.occ.grids.fair_grids`): their pieces share
    their borders pole for pole.  The faces faired alone are then projected together,
    and the faces that were already at their coarsest are faired together by energy
    across their joins (:func:`~cq_fairing.occ.networks.fair_networks`).

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
        After its first pass: ``job.reports`` hold each face's target; the reports of
        the faces solved together are replaced here.
    adjacency : Adjacency
        The source's joins.
    joins : {"smooth", "curvature", "closed"}
        ``"smooth"``: G0 everywhere and G1 across the smooth joins; ``"curvature"``:
        also G2 where the source is curvature-continuous (energy networks keep G1);
        ``"closed"``: G0 (:data:`~cq_fairing.core.options.JOIN_CONTINUITY`).

    Returns
    -------
    JointOutcome
    """
    sided = {s.face for j in adjacency.joins for s in j.sides if s.side is not None}
    read = _readable_faces(job, sided | _trimmed(adjacency))   # each face read once
    readable = {face: s for face, s in read.items() if face in sided}
    continuity = JOIN_CONTINUITY[joins]
    pinned = pin_unholdable(job, adjacency, read, continuity)
    border = border_joins(adjacency.joins, readable, job.tol)
    polynomial = {face: s for face, s in readable.items() if not s.is_rational}
    loose = {face: s for face, s in polynomial.items() if face not in pinned}
    grids = fair_grids(job, adjacency, loose, _between(border, loose),
                       runs_reversed, lambda tol: SOURCE_GAP * tol)
    gridded = {face for grid in grids for face in grid.faces}
    in_grids = _between(border, gridded)
    border = [j for j in border if not set(j.faces) & gridded]
    if job.options["method"] == "energy":
        networks = _energy_networks(job, adjacency, polynomial, continuity, gridded)
        joint = JointProjection({}, {}, [], {})
    else:
        joint = _project_jointly(job, adjacency, readable, border, continuity, gridded,
                                 pinned)
        networks = fair_networks(job, adjacency, polynomial, runs_reversed, continuity)
    moved = {face for network in networks for face in network.moved}
    in_networks = [j for network in networks for j in network.joins if set(j.faces) & moved]
    unchanged = {face for face, report in enumerate(job.reports)
                 if not report.faired and face not in moved}
    return JointOutcome(in_grids + held_joins(joint, unchanged | pinned) + in_networks
                        + held_by_pins(adjacency.joins, pinned, unchanged), grids, networks,
                        [j for j in joint.curved if set(j.faces) <= set(joint.surfaces)])


def _energy_networks(job, adjacency, polynomial, continuity, gridded):
    """The faces the energy method faired alone are faired again together by energy,
    from their sources, as networks (energy keeps each face's net: a joint projection
    onto it would replace energy fairing by a projection); a face with joins that no
    network moved is kept as it was (its joins stay as the source has them), with the
    reason."""
    alone = {face for face in polynomial if job.reports[face].faired} - gridded
    networks = fair_networks(job, adjacency, polynomial, runs_reversed, continuity,
                             refaired=alone)
    moved = {face for network in networks for face in network.moved}
    reasoned = {face for network in networks for face in network.reasons}
    for face in sorted(alone - moved - reasoned):
        joins = adjacency.joins_of(face)
        if joins:
            neighbours = sorted({f + 1 for join in joins for f in join.faces if f != face})
            job.reports[face] = job.kept(face, "unchanged", (
                f"with its joins (with faces {neighbours}) held, {UNMOVED}: kept as it "
                "was, and its neighbours close onto it (joins='free' fairs it alone)"))
    return networks


def _between(joins, faces):
    """The joins of ``joins`` with both faces among ``faces``."""
    return [j for j in joins if set(j.faces) <= set(faces)]


def _project_jointly(job, adjacency, readable, border, continuity, gridded, pinned):
    """The core's joint projection of the faces faired alone, measured by OCCT; installs
    the solved faces and keeps those it returns kept.  The faces of ``pinned`` stand as
    kept faces: their joins are held at their sources (:mod:`cq_fairing.occ.pinned`)."""
    targets = joint_targets(readable, {face: report.surface for face, report
                                       in enumerate(job.reports)
                                       if report.faired and face not in pinned})
    measured = {}

    def check(face, surface):
        measured[face] = job.measured(face, surface, readable[face])
        return measured[face][2]["max"]

    joint = project_jointly(readable, targets, adjacency.joins, border, job.tol, check,
                            continuity=continuity, excluded=gridded)
    for face in joint.surfaces:
        _install(job.reports[face], *measured[face])
    for face, deviation in joint.kept.items():
        _keep(job, face, deviation, adjacency.joins_of(face))
    for face in joint.turned:
        _keep_turned(job, face, adjacency.joins_of(face))
    return joint


def _trimmed(adjacency):
    """The faces with a join that runs across their surface (``side`` ``None``)."""
    return {s.face for j in adjacency.joins for s in j.sides if s.side is None}


def _readable_faces(job, indices):
    """``{face: source surface}`` of the faces that read as non-periodic B-spline nets,
    polynomial or rational (the others keep their joins as the source has them)."""
    out = {}
    for index in sorted(indices):
        try:
            surface, info = face_to_surface(job.originals[index])
        except Exception as exc:
            if not isinstance(exc, FairingError) and not is_occt_error(exc):
                raise
            continue
        if not info.unperiodized:
            out[index] = surface
    return out


def _install(report, face, surface, deviation):
    report.face, report.surface, report.poles_after = face, surface, surface.shape
    report.max_deviation, report.deviation, report.result = deviation["max"], deviation, None


def _keep(job, index, deviation, joins):
    """Keep a face that its joins hold over its tolerance, or whose pinned sides leave it
    nothing to fair (``deviation`` ``None``); name its joins."""
    neighbours = sorted({f + 1 for join in joins for f in join.faces if f != index})
    if deviation is None:
        job.reports[index] = job.kept(index, "unchanged", (
            f"its joins (with faces {neighbours}), held where the source has them, leave no "
            "net smaller than the source's: kept as it was"))
        return
    what = (f"stays {deviation:.3g} from its source, over tol={job.tol[index]:g}, after "
            f"{REFINEMENTS} refinements" if np.isfinite(deviation)
            else "gets weights that are not all positive")
    job.reports[index] = job.kept(index, "tolerance-not-met", (
        f"with its joins closed the face {what}; kept as it was, and its neighbours close "
        f"onto it (joins with faces {neighbours})"))


def _keep_turned(job, index, joins):
    """Keep a face whose smooth joins still turn more than the source's angle + the slack
    after :data:`~cq_fairing.core.joint_projection.REFINEMENTS`; name its joins."""
    neighbours = sorted({f + 1 for join in joins for f in join.faces if f != index})
    job.reports[index] = job.kept(index, "unchanged", (
        f"with its joins held its smooth joins (with faces {neighbours}) would turn more "
        f"than the source's angle + {ANGLE_SLACK:g} deg after {REFINEMENTS} refinements; "
        "kept as it was, and its neighbours close onto it"))


@dataclass(eq=False)
class JoinReport:
    """Every join of a model, in the source and faired (:attr:`ShapeFairResult.joins`).

    Attributes
    ----------
    adjacency : Adjacency
        The source's joins (:func:`~cq_fairing.occ.adjacency.find_joins`).
    measures : list of JoinMeasure
        The faired shape's gap and angle along each join, in ``adjacency.joins`` order.
    closed_edges : set of int
        Edges of the joins held closed by the joint projection.
    grids : list of GridFairing
        The patch grids faired as one surface each.
    networks : list of NetworkFairing
        The networks of faces faired together by energy.
    curved : list of Join
        The joins held curvature-continuous (G2) by the joint projection.
    """

    adjacency: object
    measures: list
    closed_edges: set = field(default_factory=set)
    grids: list = field(default_factory=list)
    networks: list = field(default_factory=list)
    curved: list = field(default_factory=list)

    def rows(self):
        """One dict per join: ``faces`` (1-based), ``kind``, ``held`` (closed by
        construction), ``source_gap``, ``gap``, ``source_angle``, ``angle`` (degrees) and
        ``angle_excess``: the largest of faired minus source angle at the same sample."""
        out = []
        for join, measure in zip(self.adjacency.joins, self.measures):
            excess = float(np.max(measure.angles - join.source_angles)) \
                if join.source_angles is not None and len(measure.angles) else 0.0
            out.append(dict(
                faces=tuple(f + 1 for f in join.faces), kind=join.kind,
                held=all(side.edge in self.closed_edges for side in join.sides),
                source_gap=join.source_gap, gap=measure.gap, source_angle=join.source_angle,
                angle=measure.angle, angle_excess=excess))
        return out

    def summary(self):
        """Counts and extremes (:func:`~cq_fairing.core.join_summary.summarize`), with
        ``grids`` (the shape of each patch grid faired as one surface), ``grid_faces``
        (their faces), ``network_faces`` (faces faired together by energy), ``curved``
        (joins held curvature-continuous),
        ``non_manifold`` and ``point_contacts``."""
        return summarize(
            self.rows(), grids=[list(g.shape) for g in self.grids],
            grid_faces=sum(len(g.faces) for g in self.grids),
            network_faces=sum(len(n.moved) for n in self.networks),
            curved=len(self.curved),
            non_manifold=len(self.adjacency.non_manifold),
            point_contacts=len(self.adjacency.point_contacts))

    def line(self):
        """The summary as one line (:func:`~cq_fairing.core.join_summary.summary_line`),
        e.g. ``joins: 14 (12 held closed), max gap 2e-12; 12 smooth, max angle 0.01 deg
        (source 0); 2 creases``."""
        return summary_line(self.summary())
