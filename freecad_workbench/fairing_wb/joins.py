r"""Joins among the faces of one Part shape: read, held closed and smooth, measured.

A *join* is a boundary along which two faces of one object's shape meet, at least one
of them being faired, read from the faces alone, as ``cq-fairing fair`` reads them
(:func:`cq_fairing.occ.adjacency.find_joins`):

* an edge shared by exactly two faces: the faces of one shape share their edge objects
  (``Part.Shape.isSame``); an edge of three or more faces is non-manifold and not
  joined, a degenerated edge or a seam is no join;
* two free edges (each used by one face, once), one of each of two loose faces (a
  compound of unsewn faces, an IGES file's), whose end points and probes coincide
  within the coincidence distance (by default 1e-4 of the faces' bounding-box
  diagonal, raised to the edges' tolerances), matched by the core
  (:func:`~cq_fairing.core.free_edges.match_free_edges`), the probes' distance to the
  other edge measured by Part (``distToShape``): a join with ``shared`` ``False``,
  each side on its own edge, ``opposed`` where the edges run opposite ways.  Partial
  overlaps (a T-junction of loose faces) are not matched.

The faces not faired that meet a faired one along a join, its *neighbours*, take part
as fixed faces: they keep their joins as the source has them.  Each side of a join is
located on its face (:func:`find_joins`, the
:class:`~cq_fairing.core.joint_projection.JoinSide` of the core): the border of the
surface's parameter rectangle its p-curve runs along, its border parameters at the
edge's ends, and whether it covers the whole side (no border on a surface that is not a
B-spline: a plane, a cylinder).

A join is measured at ``samples`` fractions :math:`s_k` of side 0's edge range, the
midpoints of equal sub-ranges (the ends, a vertex where several faces may meet at a
collapsed border, are left out: the normal is undefined there), and at the same
fractions of side 1's edge (:math:`1 - s_k` when ``opposed``; a shared edge is both
sides' edge): at the edge parameter :math:`t_k` of :math:`s_k`, the point
:math:`P_k = S_0(c_0(t_k))` of face 0 is projected onto face 1's surface inside its
parameter box, seeded at face 1's p-curve, giving :math:`Q_k`; the gap is
:math:`|P_k - Q_k|` and the angle is that between the unit normals
:math:`\pm S_u \times S_v / |S_u \times S_v|` (turned on a reversed face) at
:math:`P_k` and :math:`Q_k`.  The same is done from face 1 onto face 0, and each sample
keeps the larger gap and angle; two loose faces may disagree in orientation, so their
angle :math:`\alpha` is folded to :math:`\min(\alpha, 180^\circ - \alpha)`.  A
neighbour whose surface is not a B-spline is evaluated and projected onto by FreeCAD's
Part (``Surface.value``, ``Surface.normal``, ``Surface.parameter``).  A join whose
largest source angle is below the angle tolerance is *smooth*, else a *crease*.

Holding the joins is the core's work, in the three steps the OCP layer takes
(:func:`cq_fairing.occ.joint.fair_joined`): :func:`hold_joins` gives it the faces read
as non-periodic B-spline patches, the faces faired alone and those left as they were.
The patch grids that form whole parts of the shape are merged and faired as one
surface each, then cut back at their borders
(:func:`~cq_fairing.core.grid_fairing.fair_grids`); the faces faired alone are projected
again together (:func:`~cq_fairing.core.joint_projection.project_jointly`): a neighbour
has no target, so it is kept and its border constrains the faired face across the
join, and a faired face's side on a join with a face that is no such patch is pinned to
its source; the faces left as they were (already at their coarsest) are faired together
by energy across their joins (:func:`~cq_fairing.core.network_fairing.fair_networks`).
Each face solved is checked against its own tolerance by the caller's measure.
"""

from dataclasses import dataclass, field

import FreeCAD
import numpy as np
import Part

import cq_fairing as cf
from cq_fairing.core.free_edges import COINCIDENCE, EDGE_PROBES, match_free_edges, probe_length
from cq_fairing.core.grid_fairing import fair_grids
from cq_fairing.core.join_summary import summarize, summary_line
from cq_fairing.core.joins import ANGLE_SLACK
from cq_fairing.core.joint_projection import (
    REFINEMENTS,
    Join,
    JoinSide,
    JointProjection,
    border_joins,
    held_joins,
    joint_targets,
    locate_side,
    project_jointly,
    surface_key,
)
from cq_fairing.core.network_fairing import UNMOVED, fair_networks
from cq_fairing.core.options import JOIN_CONTINUITY, JOINS, check_joins
from cq_fairing.core.pinned_faces import held_by_pins

from . import analysis, conversion, trim

__all__ = ["JOINS", "SAMPLES", "TURNED", "UNMOVED_BY_NETWORKS", "FaceJoins", "HeldJoins",
           "JoinReport", "find_joins", "face_neighbours", "measure_joins", "hold_joins",
           "check_joins"]

SAMPLES = 24              # points measured along each join
TURNED = (f"with its joins held its smooth joins would turn more than the source's angle "
          f"+ {ANGLE_SLACK:g} deg after {REFINEMENTS} refinements; its neighbours close "
          "onto it")
UNMOVED_BY_NETWORKS = f"with its joins held, {UNMOVED}; its neighbours close onto it"


@dataclass(frozen=True)
class FaceJoins:
    """The joins among a list of faces (:func:`find_joins`).

    Attributes
    ----------
    joins : list of Join
        Face indices are positions in the list of faces, then of the neighbours.
    samples : list of tuple of numpy.ndarray
        Per join, the ``(n, 2)`` parameters of the measured points on side 0's and on
        side 1's face, each on its own edge (:func:`_tracks`; the faired faces keep
        their parameter domains, so the same parameters measure them).
    sources : dict
        ``{face: BSplineSurface}``: every B-spline face's source surface (every faired
        face, the B-spline neighbours).
    readable : dict
        The faces of ``sources`` that are not periodic: the patches the joint projection
        can solve (rational ones in homogeneous coordinates).
    boxes : dict
        ``{face: (u0, u1, v0, v1)}``: each face's parameter box.
    signs : dict
        ``{face: +1.0 or -1.0}``: ``-1`` on a reversed face (its normal turned).
    non_manifold : int
        Edges of three or more faces, one of them faired (not joined).
    analytic : dict
        ``{face: Part.Face}``: the neighbours whose surface is not a B-spline (measured
        through Part).
    edges : list of Part.Edge
        The edges the joins' sides name (:attr:`JoinSide.edge` indexes them).
    size : float
        The largest bounding-box diagonal of the faces: the scale of the joins'
        distances.
    measures : list of (numpy.ndarray, numpy.ndarray)
        Per join, its gaps and angles with the sources (:func:`measure_joins`).
    """

    joins: list
    samples: list
    sources: dict
    readable: dict
    boxes: dict
    signs: dict
    non_manifold: int = 0
    analytic: dict = field(default_factory=dict)
    edges: list = field(default_factory=list)
    size: float = 1.0
    measures: list = field(default_factory=list)


def _shared_edges(faces):
    """``[(edge, [face indices])]``: every non-degenerated edge of ``faces``, once, with
    the distinct faces that use it."""
    by_hash = {}
    for index, face in enumerate(faces):
        for edge in face.Edges:
            if edge.Degenerated:
                continue
            bucket = by_hash.setdefault(edge.hashCode(), [])
            entry = next((e for e in bucket if e[0].isSame(edge)), None)
            if entry is None:
                bucket.append((edge, [index]))
            elif index not in entry[1]:
                entry[1].append(index)
    return [entry for bucket in by_hash.values() for entry in bucket]


def _free_edges(faces, shared):
    """Positions in ``shared`` (:func:`_shared_edges` of ``faces``) of the free edges:
    used by one face, once (no seam)."""
    face_seams = {}
    free = []
    for k, (edge, owners) in enumerate(shared):
        if len(owners) != 1:
            continue
        if owners[0] not in face_seams:
            face_seams[owners[0]] = trim.seams(faces[owners[0]])
        if not any(edge.isSame(seam) for seam in face_seams[owners[0]]):
            free.append(k)
    return free


def _coincidence(faces):
    """:data:`~cq_fairing.core.free_edges.COINCIDENCE` times the diagonal of the
    bounding box of ``faces``."""
    box = FreeCAD.BoundBox()
    for face in faces:
        box.add(face.BoundBox)
    return COINCIDENCE * (box.DiagonalLength or 1.0)


def _loose_pairs(faces, shared, coincidence):
    """``[(a, b, opposed)]``: positions in ``shared`` (:func:`_shared_edges` of
    ``faces``) of free edges of different faces that are one boundary
    (:func:`~cq_fairing.core.free_edges.match_free_edges`: their
    :data:`~cq_fairing.core.free_edges.EDGE_PROBES` points, uniform in each edge's
    parameter, within ``coincidence`` or the edges' tolerances, at the same fractions
    or else by Part's distance from one edge's probes to the other edge);
    ``opposed``: the edges run in opposite directions."""
    free = _free_edges(faces, shared)
    if len(free) < 2:
        return []
    edges = [shared[k][0] for k in free]
    probes = [np.array([_xyz(edge.valueAt(float(t))) for t in
                        np.linspace(*edge.ParameterRange, EDGE_PROBES)]) for edge in edges]

    def along(i, j):
        return max(edges[j].distToShape(Part.Vertex(FreeCAD.Vector(*map(float, p))))[0]
                   for p in probes[i][1:-1])

    matched = match_free_edges([shared[k][1][0] for k in free], probes,
                               [edge.Tolerance for edge in edges],
                               [probe_length(p) for p in probes], coincidence, along)
    return [(free[i], free[j], opposed) for i, j, opposed in matched]


def face_neighbours(faces, chosen):
    """The faces of ``faces`` (one shape's), not among ``chosen`` (indices), that share a
    non-degenerated edge with a face of ``chosen`` (:func:`_shared_edges`: the same edge
    object, ``Part.Shape.isSame``), or have a free edge that is one boundary with a free
    edge of a face of ``chosen`` (:func:`_loose_pairs`, at the coincidence of all
    ``faces``: a loose face's neighbours); none when every face is chosen."""
    chosen = set(chosen)
    if not chosen or len(chosen) == len(faces):
        return set()
    shared = _shared_edges(faces)
    near = {face for _, owners in shared if chosen.intersection(owners) for face in owners}
    for a, b, _ in _loose_pairs(faces, shared, _coincidence(faces)):
        first, second = shared[a][1][0], shared[b][1][0]
        near.update(other for face, other in ((first, second), (second, first))
                    if face in chosen)
    return near - chosen


def _uv(face, edge, params):
    """``(n, 2)`` parameters of ``edge`` on ``face`` at edge parameters ``params``: its
    p-curve, or its 3-D points projected onto the surface when it has none."""
    pcurve = face.curveOnSurface(edge)
    if pcurve is not None:
        curve = pcurve[0]
        return np.array([[p.x, p.y] for p in (curve.value(float(t)) for t in params)])
    return np.array([face.Surface.parameter(edge.valueAt(float(t))) for t in params])


def _inside(uv, box):
    """``uv`` (n, 2) clipped to ``box`` ``(u0, u1, v0, v1)``: a p-curve may leave its
    B-spline surface's domain by round-off, where the core does not evaluate."""
    u0, u1, v0, v1 = box
    return np.column_stack([np.clip(uv[:, 0], u0, u1), np.clip(uv[:, 1], v0, v1)])


def _join_side(face, index, edge, edge_index, size):
    """The :class:`JoinSide` of ``face``'s ``edge``
    (:func:`~cq_fairing.core.joint_projection.locate_side`); no border on a surface that
    is not a B-spline."""
    if not _is_bspline(face):
        return JoinSide(index, edge_index)
    first, last = edge.ParameterRange
    uv = _uv(face, edge, np.linspace(first, last, 7))
    return locate_side(index, edge_index, uv, face.Surface.bounds(),
                       lambda u, v: _xyz(face.Surface.value(u, v)), edge.Tolerance, size)


def _xyz(vector):
    return vector.x, vector.y, vector.z


def _is_bspline(face):
    return isinstance(face.Surface, Part.BSplineSurface)


def _sources(faces):
    """``{face: BSplineSurface}``: the faces' B-spline surfaces that read as core
    surfaces (any other face is measured through Part and holds no border)."""
    out = {}
    for index, face in enumerate(faces):
        if _is_bspline(face):
            try:
                out[index] = conversion.surface_from_face(face)
            except cf.FairingError:
                continue
    return out


def find_joins(faces, angle_tolerance=1.0, samples=SAMPLES, neighbours=()):
    """The joins of ``faces`` (B-spline faces of one shape) among themselves and with
    their ``neighbours``, classified.

    Parameters
    ----------
    faces : list of Part.Face
        Faces of one object's shape: they share their edges, or are loose faces whose
        free edges coincide.
    angle_tolerance : float
        Degrees: a join whose source normals differ by less all along is smooth.
    samples : int
        Points measured along each join.
    neighbours : sequence of Part.Face
        Faces of the same shape not faired, any surface: their joins with ``faces`` are
        read (they are faces ``len(faces)``, ``len(faces) + 1``, ...), not those among
        themselves.  Their free edges and those of ``faces`` are matched
        (:func:`_loose_pairs`) within :data:`~cq_fairing.core.free_edges.COINCIDENCE`
        times the diagonal of the bounding box of ``faces`` and ``neighbours``.

    Returns
    -------
    FaceJoins
    """
    every = list(faces) + list(neighbours)
    size = max(f.BoundBox.DiagonalLength for f in every)
    sources = _sources(every)
    readable = {i: s for i, s in sources.items()
                if not (every[i].Surface.isUPeriodic() or every[i].Surface.isVPeriodic())}
    boxes = {i: conversion.uv_range(f, sources[i]) if i in sources else f.ParameterRange
             for i, f in enumerate(every)}
    signs = {i: -1.0 if f.Orientation == "Reversed" else 1.0 for i, f in enumerate(every)}
    analytic = {i: f for i, f in enumerate(every) if i not in sources}
    shared = _shared_edges(every)
    edges = [edge for edge, _ in shared]
    pairs, non_manifold = [], 0
    for edge_index, (_, owners) in enumerate(shared):
        if min(owners) >= len(faces):
            continue
        non_manifold += len(owners) > 2
        if len(owners) == 2:
            pairs.append((tuple((face, edge_index) for face in owners), True, False))
    for a, b, opposed in _loose_pairs(every, shared, _coincidence(every)):
        sides = ((shared[a][1][0], a), (shared[b][1][0], b))
        if min(face for face, _ in sides) < len(faces):
            pairs.append((sides, False, opposed))
    tracks = [_tracks(every, edges, sides, opposed, sources, boxes, samples, size)
              for sides, _, opposed in pairs]
    drafts = [Join(sides, "smooth", 0.0, 0.0, None, shared_edge, opposed)
              for (sides, _), (_, shared_edge, opposed) in zip(tracks, pairs)]
    uvs = [uv for _, uv in tracks]
    found = FaceJoins(drafts, uvs, sources, readable, boxes, signs, non_manifold, analytic,
                      edges, size)
    joins = []
    measures = measure_joins(found, sources)
    for draft, (gaps, angles) in zip(drafts, measures):
        angle = float(angles.max())
        joins.append(Join(draft.sides, "smooth" if angle < angle_tolerance else "crease",
                          float(gaps.max()), angle, angles, draft.shared, draft.opposed))
    return FaceJoins(joins, uvs, sources, readable, boxes, signs, non_manifold, analytic,
                     edges, size, measures)


def _tracks(every, edges, sides, opposed, sources, boxes, samples, size):
    """The :class:`JoinSide` of each of ``sides`` (``(face, edge index)`` pairs) and the
    ``(samples, 2)`` parameters of its measured points: the midpoints of equal
    sub-ranges of side 0's edge, and the same fractions of side 1's edge (from its end
    when ``opposed``: loose faces' edges may run opposite ways), on its face's p-curve,
    kept inside a B-spline face's box (:func:`_inside`)."""
    fractions = (np.arange(samples) + 0.5) / samples
    located, uvs = [], []
    for (face, k), turned in zip(sides, (False, opposed)):
        first, last = edges[k].ParameterRange
        params = first + (1.0 - fractions if turned else fractions) * (last - first)
        uv = _uv(every[face], edges[k], params)
        located.append(_join_side(every[face], face, edges[k], k, size))
        uvs.append(_inside(uv, boxes[face]) if face in sources else uv)
    return tuple(located), tuple(uvs)


def _angles(n0, n1):
    return np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n0, n1), -1.0, 1.0)))


def _part_points_and_normals(surface, uv):
    """Points and unit normals of a Part surface at parameters ``uv`` (n, 2)."""
    points = [surface.value(float(u), float(v)) for u, v in uv]
    normals = [surface.normal(float(u), float(v)) for u, v in uv]
    return np.array([tuple(p) for p in points]), np.array([tuple(n) for n in normals])


def _points_and_normals(found, surfaces, face, uv):
    """Points and unit normals of ``face`` at ``uv``: its B-spline surface in
    ``surfaces``, else its Part surface."""
    if face in surfaces:
        return analysis.points_and_normals(surfaces[face], uv[:, 0], uv[:, 1])
    return _part_points_and_normals(found.analytic[face].Surface, uv)


def _feet(found, surfaces, face, points, uv):
    """Closest points on ``face`` from ``points`` (seeded at ``uv``), and the normals
    there: the core's on a B-spline surface inside its box, Part's projection on any
    other surface."""
    if face in surfaces:
        return analysis.foot_points(surfaces[face], points, uv[:, 0], uv[:, 1],
                                    found.boxes[face])
    surface = found.analytic[face].Surface
    feet = [surface.parameter(FreeCAD.Vector(*map(float, p))) for p in points]
    return _part_points_and_normals(surface, np.array(feet, dtype=float))


def _by_face(faces, evaluate, *rows):
    """``evaluate(face, *stacked)`` once per face of ``faces`` over the rows (the sample
    arrays of ``rows``, one per entry of ``faces``) of every entry on that face, split
    back: per entry, the tuple of its rows of each result.  Each sample is evaluated on
    its own (the core's evaluation gives each point the same value in any batch of two
    or more), so it has the values it would have entry by entry; one call per face
    instead of one per join side saves the per-call cost of the batched evaluation."""
    out = [None] * len(faces)
    entries = {}
    for k, face in enumerate(faces):
        entries.setdefault(face, []).append(k)
    for face, ks in entries.items():
        results = evaluate(face, *(np.concatenate([r[k] for k in ks]) for r in rows))
        ends = np.cumsum([len(rows[0][k]) for k in ks])[:-1]
        for k, *parts in zip(ks, *(np.split(r, ends) for r in results)):
            out[k] = parts
    return out


def _one_way(found, legs, surfaces):
    """Per leg ``((a, b), (uv_a, uv_b))``, the gaps and angles from side ``a``'s points to
    side ``b``'s face (module doc), each face evaluated once (:func:`_by_face`).  The
    projections stay leg by leg: the Newton iterations of a batch are not independent
    of the batch to the last bit (projected per face, one angle of linkrods' joins
    differs by 3e-9 degrees)."""
    starts = [a for (a, _), _ in legs]
    on_a = _by_face(starts, lambda face, uv: _points_and_normals(found, surfaces, face, uv),
                    [uv_a for _, (uv_a, _) in legs])
    out = []
    for a, ((_, b), (_, uv_b)), (points, normals) in zip(starts, legs, on_a):
        feet, across = _feet(found, surfaces, b, points, uv_b)
        angles = _angles(found.signs[a] * normals, found.signs[b] * across)
        out.append((np.linalg.norm(points - feet, axis=1), angles))
    return out


def measure_joins(found, surfaces):
    r"""Per join of ``found``, the gaps and the normal angles (degrees) at its samples
    with the faces' surfaces ``surfaces`` (``{face: BSplineSurface}``, the sources or
    faired surfaces on the same parameter domains; a face of ``found.analytic`` through
    Part).  Loose faces (a join not on a shared edge) may disagree in orientation: their
    angle :math:`\alpha` is folded to :math:`\min(\alpha, 180^\circ - \alpha)`.

    A join whose faces both have their sources' surfaces (the same nets) keeps its
    sources' measures, ``found.measures``, where :func:`find_joins` took them: measured
    again, it would give them again.

    Returns
    -------
    list of (numpy.ndarray, numpy.ndarray)
        ``(gaps, angles)`` per join, sample by sample.
    """
    out = list(found.measures) or [None] * len(found.joins)
    todo = [k for k, join in enumerate(found.joins)
            if out[k] is None or any(_moved(found, surfaces, face) for face in join.faces)]
    legs = []
    for k in todo:
        faces, uvs = found.joins[k].faces, found.samples[k]
        legs += [(faces, uvs), (faces[::-1], uvs[::-1])]
    ways = _one_way(found, legs, surfaces)
    for k, there, back in zip(todo, ways[::2], ways[1::2]):
        angles = [a if found.joins[k].shared else np.minimum(a, 180.0 - a)
                  for a in (there[1], back[1])]
        out[k] = (np.maximum(there[0], back[0]), np.maximum(*angles))
    return out


def _moved(found, surfaces, face):
    """True when ``face``'s surface in ``surfaces`` is not its source's net
    (:func:`~cq_fairing.core.joint_projection.surface_key`); a face measured through
    Part is its source."""
    if face not in surfaces:
        return False
    source = found.sources.get(face)
    return source is None or (surfaces[face] is not source
                              and surface_key(surfaces[face]) != surface_key(source))


@dataclass(frozen=True)
class HeldJoins:
    """What :func:`hold_joins` did.

    Attributes
    ----------
    surfaces : dict
        ``{face: BSplineSurface}``: every face solved (a patch grid's pieces, the joint
        projection's faces, the networks' moved faces), as checked.
    kept : dict
        ``{face: deviation}``: the faces the joint projection kept as they were (the
        deviation they stayed at with their joins closed, over their tolerance; ``None``
        where their pinned sides left nothing to fair; :data:`TURNED` where a smooth
        join still turned after the refinements) and no network moved; with the energy
        method the faces no network moved (:data:`UNMOVED_BY_NETWORKS`).
    held : list of Join
        The joins held closed.
    grids : list of GridFairing
        The patch grids faired as one surface each.
    networks : list of NetworkFairing
        The networks of faces faired together by energy.
    """

    surfaces: dict
    kept: dict
    held: list
    grids: list
    networks: list


def _between(joins, faces):
    """The joins of ``joins`` with both faces among ``faces``."""
    return [j for j in joins if set(j.faces) <= set(faces)]


def hold_joins(found, faired, unchanged, tolerances, check, joins="smooth", method="wavelet",
               pinned=frozenset()):
    """Fair the faces of ``found`` together so that their joins stay closed (and, with
    ``joins="smooth"``, smooth), as the OCP layer does: the patch grids that form whole
    parts of the shape as one surface each (:func:`~cq_fairing.core.grid_fairing.fair_grids`),
    the faces faired alone projected again together
    (:func:`~cq_fairing.core.joint_projection.project_jointly`, on the border joins
    between readable faces, :func:`~cq_fairing.core.joint_projection.border_joins`,
    every other side on a join pinned to its source), and the faces left as they were
    faired together by energy (:func:`~cq_fairing.core.network_fairing.fair_networks`).

    Parameters
    ----------
    found : FaceJoins
    faired : dict
        ``{face: BSplineSurface}``: the faces faired alone.
    unchanged : collection of int
        The faces left as their sources that may still move with others: their own
        fairing had nothing to remove.
    tolerances : dict
        ``{face: tol}`` of the faces faired (their neighbours have none: they stay).
    check : callable
        ``check(face, surface) -> float``: the face's two-sided deviation with
        ``surface``.
    joins : {"smooth", "closed", "curvature"}
        ``"smooth"``: G1 across the smooth joins; ``"closed"``: G0 only;
        ``"curvature"``: also G2 where the source is curvature-continuous
        (:data:`~cq_fairing.core.options.JOIN_CONTINUITY`).
    method : {"wavelet", "adaptive", "energy"}
        The method the faces were faired alone with.  ``"energy"`` keeps each face's
        net: the faces faired alone are faired again together by energy from their
        sources, as networks, and a face with joins that no network moved is kept
        (:data:`UNMOVED_BY_NETWORKS`): a joint projection would replace its energy
        fairing by a projection.
    pinned : set of int
        The faces already faired with their joins pinned to their sources
        (:mod:`fairing_wb.pinned`): no grid takes them, and they stand as faces kept
        (their neighbours' sides along them are held at their sources).

    Returns
    -------
    HeldJoins
    """
    continuity = JOIN_CONTINUITY[joins]
    border = border_joins(found.joins, found.readable, tolerances)
    polynomial = {face: s for face, s in found.readable.items() if not s.is_rational}
    loose = {face: s for face, s in polynomial.items() if face not in pinned}
    grids = fair_grids(loose, found.joins, _between(border, loose), tolerances, check)
    pieces = {face: s for grid in grids for face, s in grid.surfaces.items()}
    in_grids = _between(border, pieces)
    border = [j for j in border if not set(j.faces) & set(pieces)]
    if method == "energy":
        networks = fair_networks(polynomial, set(unchanged) | (set(faired) - set(pieces)),
                                 found.joins, tolerances, check, continuity=continuity)
        projection = JointProjection({}, {}, [], {})
        outside = _outside_networks(found, set(faired) - set(pieces), networks)
    else:
        projection = project_jointly(found.readable, joint_targets(found.readable, faired),
                                     found.joins, border, tolerances, check,
                                     continuity=continuity, excluded=set(pieces))
        unmoved = set(unchanged) | {face for face, d in projection.kept.items() if d is None}
        networks = fair_networks(polynomial, unmoved, found.joins, tolerances, check,
                                 continuity=continuity)
        outside = {}
    moved = {face: s for network in networks for face, s in network.surfaces.items()}
    in_networks = [j for network in networks for j in network.joins
                   if set(j.faces) & set(network.surfaces)]
    surfaces = {**pieces, **projection.surfaces, **moved}
    kept = {face: d for face, d in projection.kept.items() if face not in moved}
    kept.update(outside)
    kept.update({face: TURNED for face in projection.turned if face not in moved})
    still = {face for face in found.boxes
             if face not in surfaces and (face not in faired or face in kept)}
    held = (in_grids + held_joins(projection, still) + in_networks
            + held_by_pins(found.joins, set(pinned), still - set(pinned)))
    return HeldJoins(surfaces, kept, held, grids, networks)


def _outside_networks(found, alone, networks):
    """``{face: reason}``: the faces faired ``alone`` by energy, with joins, that no
    network moved; they are kept as they were (:data:`UNMOVED_BY_NETWORKS`)."""
    moved = {face for network in networks for face in network.surfaces}
    joined = {face for join in found.joins for face in join.faces}
    return dict.fromkeys(sorted((alone & joined) - moved), UNMOVED_BY_NETWORKS)


@dataclass(eq=False)
class JoinReport:
    """The joins among the faces of one fairing, in the source and faired.

    Attributes
    ----------
    found : FaceJoins
    measures : list of (numpy.ndarray, numpy.ndarray)
        The faired faces' gaps and angles per join (:func:`measure_joins`).
    held : list of Join
        The joins held closed (:attr:`HeldJoins.held`).
    seconds : float
        Wall time of reading, holding and measuring the joins.
    grids : list of GridFairing
        The patch grids faired as one surface each.
    networks : list of NetworkFairing
        The networks of faces faired together by energy.
    """

    found: FaceJoins
    measures: list
    held: list = field(default_factory=list)
    seconds: float = 0.0
    grids: list = field(default_factory=list)
    networks: list = field(default_factory=list)

    def rows(self):
        """One dict per join: ``faces`` (1-based positions), ``kind``, ``held``,
        ``source_gap``, ``gap``, ``source_angle``, ``angle`` (degrees) and
        ``angle_excess``: the largest of faired minus source angle at one sample."""
        held = {id(join) for join in self.held}
        return [dict(faces=tuple(f + 1 for f in join.faces), kind=join.kind,
                     held=id(join) in held, source_gap=join.source_gap,
                     gap=float(gaps.max()), source_angle=join.source_angle,
                     angle=float(angles.max()),
                     angle_excess=float(np.max(angles - join.source_angles)))
                for join, (gaps, angles) in zip(self.found.joins, self.measures)]

    def summary(self):
        """Counts and extremes (:func:`~cq_fairing.core.join_summary.summarize`), with
        ``grids`` (the shape of each patch grid faired as one surface), ``grid_faces``
        (their faces), ``network_faces`` (faces faired together by energy) and
        ``non_manifold``."""
        return summarize(
            self.rows(), grids=[list(g.shape) for g in self.grids],
            grid_faces=sum(len(g.faces) for g in self.grids),
            network_faces=sum(len(n.moved) for n in self.networks),
            non_manifold=self.found.non_manifold)

    def line(self):
        """The summary as one line, worded as the command line's
        (:func:`~cq_fairing.core.join_summary.summary_line`)."""
        return summary_line(self.summary())
