r"""Fair the faces of a model together: joins stay closed and smooth.

After the face-by-face pass has chosen each face's target (its tolerance search), the
faces that meet along whole borders of their parameter rectangles (a shell's shared
edges, a compound's coincident boundaries: :func:`~cq_fairing.occ.adjacency.find_joins`)
are projected again together by the core's :func:`~cq_fairing.core.joins.fair_patches`:
each shared border is faired once and both faces take it pole for pole (G0 to
round-off), and across the smooth joins the cross-boundary rows of poles mirror each
other (G1).  A join is held so when the two borders, at equal normalised parameters, lie
within :data:`SOURCE_GAP` times the tolerance: a wider source gap is the source's, and
borders that run along one curve with different parametrizations would pull each
other's faces off their sources; such joins are faired as with ``joins="free"``.  A
face next to one that is not faired (kept, refused, analytic or rational)
takes that face's border exactly where the border is a polynomial B-spline curve.

Each face is then checked against its own tolerance by OCCT, both ways
(:func:`~cq_fairing.occ.deviation.sample_face_deviation`).  A face over its tolerance
gets its targets refined (every span halved, :data:`REFINEMENTS` times at most); a face
still over it is kept as it was, and the joint solve runs again with it fixed, so its
neighbours close onto it.  Its report names the join that binds it.  A face on a smooth
join that turns more than the source's angle + 0.05 degrees somewhere (next to a vertex,
where a mirrored row of the cycle around it is left out) gets its targets refined the
same way: the spans that the vertex's poles reach shrink, and with them the turn (the
fuselage: 0.107 degrees on its targets, 0.017 with them halved once).
"""

from dataclasses import dataclass, field

import numpy as np

from ..core.joins import BorderJoin, JointPatch, fair_patches, turned_patches
from ..core.spaces import SplineSpace
from ..errors import FairingError
from .convert import face_to_surface, is_occt_error
from .faces import collapsed_kept
from .grids import fair_grids
from .networks import fair_networks

__all__ = ["fair_joined", "JointOutcome", "JoinReport", "JOINS", "REFINEMENTS"]

JOINS = ("smooth", "closed", "free")
REFINEMENTS = 2
SOURCE_GAP = 0.5   # borders further apart than this x tol (at equal parameters) stay apart


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
    """

    joins: list
    grids: list
    networks: list


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
    joins : {"smooth", "closed"}
        ``"smooth"``: G0 everywhere and G1 across the smooth joins; ``"closed"``: G0.

    Returns
    -------
    JointOutcome
    """
    border = [j for j in adjacency.joins if _is_border_join(j)]
    readable = _readable_faces(job, {s.face for j in border for s in j.sides})
    border = [j for j in border if all(s.face in readable for s in j.sides) and
              _parametric_gap(j, readable) <= SOURCE_GAP * _tolerance(job, j)]
    grids = fair_grids(job, adjacency, readable, border, _reversed, lambda tol: SOURCE_GAP * tol)
    gridded = {face for grid in grids for face in grid.faces}
    in_grids = [j for j in border if set(j.faces) <= gridded]
    border = [j for j in border if not set(j.faces) & gridded]
    imposed = _project_jointly(job, adjacency, readable, border, joins)
    networks = fair_networks(job, adjacency, readable, border, _reversed,
                             "G1" if joins == "smooth" else "G0")
    moved = {face for network in networks for face in network.moved}
    in_networks = [j for network in networks for j in network.joins if set(j.faces) & moved]
    return JointOutcome(in_grids + imposed + in_networks, grids, networks)


def _project_jointly(job, adjacency, readable, border, joins):
    """The joint projection of the faces faired alone, the others kept; the joins it
    held.  Faces that carry one and the same surface (a surface split into faces by its
    trims) are one patch: their surface is faired once, for all of them, so the joins
    between them stay where the source has them, exactly."""
    group = _shared_surfaces(job, readable, border)
    faces = sorted({group[s.face] for j in border for s in j.sides})
    kept = {i for i in faces if not _fairable(job.reports[i], readable[i])}
    if not faces or len(kept) == len(faces):
        return []
    members = {face: [m for m in group if group[m] == face] for face in faces}
    refined = dict.fromkeys(faces, 0)
    while True:
        result, imposed = _solve(job, readable, faces, kept, refined, border, joins, group)
        checked = _checked(job, readable, faces, kept, result, members)
        over = sorted({group[i] for i, (_, _, deviation) in checked.items()
                       if deviation["max"] > job.tol[i]})
        turned = [i for i in _turned(result, readable, faces, kept)
                  if refined[i] < REFINEMENTS and i not in over]
        if not over and not turned:
            break
        for index in turned:
            refined[index] += 1
        for index in over:
            if refined[index] < REFINEMENTS:
                refined[index] += 1
            else:
                kept.add(index)
                for member in members[index]:
                    worst = max(checked[m][2]["max"] for m in members[index])
                    _keep(job, member, worst, adjacency.joins_of(member))
    for index, (face, surface, deviation) in checked.items():
        _install(job.reports[index], face, surface, deviation)
    inside = [j for j in adjacency.joins if j.faces[0] != j.faces[1]
              and group.get(j.faces[0], -1) == group.get(j.faces[1], -2)
              and group[j.faces[0]] not in kept]
    return imposed + inside


def _shared_surfaces(job, readable, border):
    """``{face: representative}`` over the faces of ``border``: faces whose surfaces are
    identical (poles, knots, degrees) share the representative with the finest target
    (most poles) of those faired alone; every other face represents itself.  A group
    whose faces would bring the same side of the surface into two joins is not formed."""
    faces = sorted({s.face for j in border for s in j.sides})
    by_surface = {}
    for face in faces:
        surface = readable[face]
        key = (surface.u_degree, surface.v_degree, surface.u_knots.tobytes(),
               surface.v_knots.tobytes(), surface.poles.tobytes())
        by_surface.setdefault(key, []).append(face)
    out = {face: face for face in faces}
    for same in by_surface.values():
        sides = [s.side for j in border for s in j.sides if s.face in same]
        if len(same) < 2 or len(sides) != len(set(sides)):
            continue
        fairable = [f for f in same if _fairable(job.reports[f], readable[f])] or same
        rep = max(fairable, key=lambda f: np.prod(job.reports[f].poles_after or (0, 0)))
        out.update(dict.fromkeys(same, rep))
    return out


def _tolerance(job, join):
    """The smaller tolerance of a join's faces (a face not selected has none: ``-inf``
    when neither is selected, so the join is left out)."""
    tols = [job.tol[s.face] for s in join.sides if job.tol.get(s.face) is not None]
    return min(tols) if tols else -np.inf


def _parametric_gap(join, readable, samples=33):
    """Largest distance between the two faces' borders at equal normalised parameters
    (reversed where they run opposite ways): at least the source's gap, and above it
    where the faces run along the join with different parametrizations."""
    t = np.linspace(0.0, 1.0, samples)
    points = []
    for side, ts in zip(join.sides, (t, 1.0 - t if _reversed(join) else t)):
        surface = readable[side.face]
        (u0, u1), (v0, v1) = surface.domain
        if side.side[0] == "u":
            u, v = [u0 if side.side[1] == "0" else u1], v0 + (v1 - v0) * ts
            points.append(surface.evaluate_grid(u, v)[0])
        else:
            u, v = u0 + (u1 - u0) * ts, [v0 if side.side[1] == "0" else v1]
            points.append(surface.evaluate_grid(u, v)[:, 0])
    return float(np.linalg.norm(points[0] - points[1], axis=1).max())


def _is_border_join(join):
    return all(side.side is not None and side.full for side in join.sides)


def _readable_faces(job, indices):
    """``{face: source surface}`` of the faces that read as polynomial, non-periodic
    B-spline nets (the others keep their joins free)."""
    out = {}
    for index in sorted(indices):
        try:
            surface, info = face_to_surface(job.originals[index])
        except Exception as exc:
            if not isinstance(exc, FairingError) and not is_occt_error(exc):
                raise
            continue
        if surface.weights is None and not info.unperiodized:
            out[index] = surface
    return out


def _fairable(report, source):
    """True when the face was faired alone onto polynomial targets on its own domain."""
    return (report.faired and report.surface is not None and report.surface.weights is None
            and report.surface.domain == source.domain)


def _targets(report, refined):
    """The face's target spaces, each span halved ``refined`` times."""
    spaces = (report.surface.u_space, report.surface.v_space)
    for _ in range(refined):
        spaces = tuple(_halved(s) for s in spaces)
    return spaces


def _halved(space):
    """``space`` with a knot in the middle of every span."""
    b, p = space.breakpoints, space.degree
    inner = np.sort(np.concatenate([space.knots[p + 1: -p - 1], 0.5 * (b[1:] + b[:-1])]))
    return SplineSpace(p, np.concatenate([np.full(p + 1, b[0]), inner, np.full(p + 1, b[-1])]))


def _solve(job, readable, faces, kept, refined, border, joins, group):
    """The core's joint projection of ``faces`` (``kept`` fixed; a face stands for every
    face of ``group`` it represents) and the adjacency joins it imposed."""
    position = {face: k for k, face in enumerate(faces)}
    patches = [JointPatch(readable[i], None if i in kept else
                          _targets(job.reports[i], refined[i])) for i in faces]
    core_joins = {BorderJoin(position[group[a.face]], a.side, position[group[b.face]],
                             b.side, _reversed(join), join.kind == "smooth"): join
                  for join in border for a, b in [join.sides]}
    result = fair_patches(patches, list(core_joins),
                          continuity="G1" if joins == "smooth" else "G0")
    return result, [core_joins[j] for j in result.joins]


def _turned(result, readable, faces, kept):
    """The solved faces on a smooth join that turns more than the source's angle +
    :data:`~cq_fairing.core.joins.ANGLE_SLACK` somewhere (around a vertex where a
    mirrored row was left out): halving their spans confines that to a smaller region."""
    moved = [k for k, face in enumerate(faces) if face not in kept]
    turned = turned_patches(result.surfaces, [readable[f] for f in faces], result.joins,
                            moved)
    return [faces[k] for k in turned]


def _reversed(join):
    """True when the two faces' along-parameters run opposite ways."""
    a, b = join.sides
    return ((a.along[1] > a.along[0]) != (b.along[1] > b.along[0])) != join.opposed


def _checked(job, readable, faces, kept, result, members):
    """``{face: (new face, surface, deviation)}`` of every solved face, measured both
    ways by OCCT against its original.  A border row collapsed in the source (the nose of
    a fuselage, where several faces meet at one point) is put back onto its point, which
    the faces that share it then share exactly: the projection alone spreads it, and a
    STEP file of such faces read back as unclosed wires."""
    out = {}
    for k, index in enumerate(faces):
        if index not in kept:
            surface = collapsed_kept(readable[index], result.surfaces[k])
            for member in members[index]:
                out[member] = job.measured(member, surface)
    return out


def _install(report, face, surface, deviation):
    report.face, report.surface, report.poles_after = face, surface, surface.shape
    report.max_deviation, report.deviation, report.result = deviation["max"], deviation, None


def _keep(job, index, deviation, joins):
    """Keep a face that its joins hold over its tolerance; name them."""
    neighbours = sorted({f + 1 for join in joins for f in join.faces if f != index})
    job.reports[index] = job.kept(index, "tolerance-not-met", (
        f"with its joins closed the face stays {deviation:.3g} from its source, over "
        f"tol={job.tol[index]:g}, after {REFINEMENTS} refinements; kept as it was, and "
        f"its neighbours close onto it (joins with faces {neighbours})"))


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
    """

    adjacency: object
    measures: list
    closed_edges: set = field(default_factory=set)
    grids: list = field(default_factory=list)
    networks: list = field(default_factory=list)

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
        """Counts and extremes: ``joins``, ``held``, ``max_gap``, ``max_gap_opened``
        (faired minus source gap), ``smooth``, ``max_smooth_angle`` and its
        ``source_max_smooth_angle``, ``max_angle_excess`` over the smooth joins,
        ``creases``, ``grids`` (the shape of each patch grid faired as one surface),
        ``grid_faces`` (their faces), ``network_faces`` (faces faired together by energy),
        ``non_manifold``, ``point_contacts``."""
        rows = self.rows()
        smooth = [r for r in rows if r["kind"] == "smooth"]
        return dict(
            joins=len(rows), held=sum(r["held"] for r in rows),
            max_gap=max((r["gap"] for r in rows), default=0.0),
            max_gap_opened=max((r["gap"] - r["source_gap"] for r in rows), default=0.0),
            smooth=len(smooth),
            max_smooth_angle=max((r["angle"] for r in smooth), default=0.0),
            source_max_smooth_angle=max((r["source_angle"] for r in smooth), default=0.0),
            max_angle_excess=max((r["angle_excess"] for r in smooth), default=0.0),
            creases=len(rows) - len(smooth),
            grids=[list(g.shape) for g in self.grids],
            grid_faces=sum(len(g.faces) for g in self.grids),
            network_faces=sum(len(n.moved) for n in self.networks),
            non_manifold=len(self.adjacency.non_manifold),
            point_contacts=len(self.adjacency.point_contacts))

    def line(self):
        """The summary as one line, e.g. ``joins: 14 (12 held closed), max gap 2e-12;
        12 smooth, max angle 0.01 deg (source 0); 2 creases``; edges of three or more
        faces and faces that touch at a point only (never joined) are named after it."""
        s = self.summary()
        parts = [f"joins: {s['joins']} ({s['held']} held closed), max gap {s['max_gap']:.2g}",
                 f"{s['smooth']} smooth, max angle {s['max_smooth_angle']:.2g} deg (source "
                 f"{s['source_max_smooth_angle']:.2g})", f"{s['creases']} creases"] \
            if s["joins"] else ["joins: none"]
        if s["grids"]:
            parts.append(f"{len(s['grids'])} patch grids ({s['grid_faces']} faces) faired "
                         "as one surface each")
        if s["network_faces"]:
            parts.append(f"{s['network_faces']} faces at their coarsest faired together")
        if s["non_manifold"]:
            parts.append(f"{s['non_manifold']} non-manifold edges (not joined)")
        if s["point_contacts"]:
            parts.append(f"{s['point_contacts']} point contacts (not joined)")
        return "; ".join(parts)
