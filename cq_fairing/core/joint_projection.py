r"""Joint projection of a model's faces: which joins are faired across, which sides are
pinned, and the refinement that keeps every face within its tolerance.

A model's faces meet along *joins* (:class:`Join`, two :class:`JoinSide`), read by a
backend from its shapes (OCCT's :func:`~cq_fairing.occ.adjacency.find_joins`, FreeCAD's
Part module in the workbench).  After each face was faired alone (its tolerance search
chose its target spaces), :func:`project_jointly` projects the faces again together
with :func:`~cq_fairing.core.joins.fair_patches`:

* a **border join** (:func:`border_joins`: both faces B-spline patches, rational ones
  solved in homogeneous coordinates, meeting along whole sides of their parameter
  rectangles, whose borders agree at equal normalised parameters within
  :data:`SOURCE_GAP` times the tolerance) is projected with both faces, which share its
  border pole for pole: closed to round-off, and G1 across a smooth join (with
  ``continuity="G2"`` also G2 where the sources are curvature-continuous across it,
  :func:`~cq_fairing.core.joins.holds_curvature`);
* every other side of a face on a join (a neighbour parametrized differently along it,
  analytic or trimmed there; a side shared by several neighbours) is
  **pinned** (:func:`~cq_fairing.core.joins.pinning_patch`): the face keeps its source's
  border curve there and, across a smooth join, its source's tangent plane (not its
  curvature), exactly; the
  join keeps the source's gap and angle wherever its other side is pinned or unchanged;
* faces that carry one and the same surface (one surface split into faces by its trims)
  are one patch, faired once for all of them;
* a face with a join that runs across its surface (a trimmed face's inner edge), or a
  periodic one, can be neither joined nor pinned by border rows: :func:`unholdable`
  names it, and the caller keeps it before the projection, or projects it alone with
  its joins pinned by samples (:mod:`~cq_fairing.core.pinned_projection`) and passes
  it here as a kept face (no target).

Each solved face is then checked against its own tolerance by the backend's two-sided
measure (``check``).  A face over its tolerance gets its targets refined (every span
halved, :data:`REFINEMENTS` times at most), then is kept as it was, and the joint solve
runs again with it fixed, so its neighbours close onto it.  A face on a smooth join that
turns more than the source's angle + :data:`~cq_fairing.core.joins.ANGLE_SLACK` degrees
(next to a vertex, where a mirrored row of the cycle around it is left out) gets its
targets refined the same way, and is kept as it was where it still turns after
:data:`REFINEMENTS`.  A face whose pinned sides leave it a net no smaller than its
source's is kept: nothing is left to fair.

This module imports numpy only (and the core).
"""

from dataclasses import dataclass, field, replace

import numpy as np

from .geometry import collapsed_kept
from .joins import (
    BorderJoin,
    JointPatch,
    fair_patches,
    holds_curvature,
    pinning_patch,
    side_points,
    turned_patches,
)
from .spaces import SplineSpace

__all__ = ["JoinSide", "Join", "JointProjection", "border_joins", "project_jointly",
           "is_border_join", "runs_reversed", "join_tolerance", "surface_key", "unholdable",
           "held_joins", "joint_targets", "locate_side", "refined_targets", "joined_faces",
           "plain_target_options", "model_grading",
           "SOURCE_GAP", "REFINEMENTS"]

SOURCE_GAP = 0.5   # borders further apart than this x tol (at equal parameters) stay apart
REFINEMENTS = 2    # span halvings of a face over its tolerance before it is kept
BORDER_TOLERANCE = 1e-7   # relative to the parameter span: a p-curve sample on a border
FULL_TOLERANCE = 1e-7     # relative to the model size: an edge's end this close to a side's
                          # end in 3-D (or within the edge's tolerance) covers the side there


@dataclass(frozen=True)
class JoinSide:
    """One face's side of a :class:`Join`.

    Attributes
    ----------
    face : int
        0-based face index in the backend's face order.
    edge : int
        The backend's index of this face's edge on the join (for a shell: the shared
        edge, the same for both sides; for loose faces: each face's own edge).
    side : str or None
        ``"u0"``, ``"u1"``, ``"v0"`` or ``"v1"`` when the edge runs along that border of
        the surface's parameter rectangle (``"u0"`` is the iso-line :math:`u = u_{min}`,
        along which :math:`v` varies); ``None`` when it leaves the border (a trimmed
        face, an interior curve) or the surface is not a B-spline surface.
    along : tuple of float
        The border parameter (:math:`v` for a u-side, :math:`u` for a v-side) at the
        start and the end of the edge (in its forward direction); ``(nan, nan)`` when
        ``side`` is ``None``.
    full : bool
        The edge covers the whole side (up to the edge's tolerance in 3-D).
    """

    face: int
    edge: int
    side: str = None
    along: tuple = (float("nan"), float("nan"))
    full: bool = False


@dataclass(frozen=True)
class Join:
    """Two faces meeting along a boundary, as found in the source.

    Attributes
    ----------
    sides : tuple of JoinSide
        Side 0 and side 1; the measurement samples side 0's edge.
    kind : str
        ``"smooth"`` when ``source_angle < angle_tol``, else ``"crease"``.
    source_gap : float
        Largest distance between the two faces along the join, in the source.
    source_angle : float
        Largest angle (degrees) between the two faces' normals along the join.
    source_angles : numpy.ndarray
        The angle (degrees) at each sample, for a point-by-point comparison with a
        faired copy's.
    shared : bool
        ``True``: one edge of the shape used by both faces; ``False``: two coincident
        free edges of loose faces (their normals' angle is folded to at most 90 deg).
    opposed : bool
        The two sides' edges run in opposite directions (``False`` for a shared edge).
    """

    sides: tuple
    kind: str
    source_gap: float
    source_angle: float
    source_angles: np.ndarray = field(default=None, compare=False, repr=False)
    shared: bool = True
    opposed: bool = False

    @property
    def faces(self):
        """``(face of side 0, face of side 1)``."""
        return self.sides[0].face, self.sides[1].face


@dataclass(frozen=True)
class JointProjection:
    """Outcome of :func:`project_jointly`.

    Attributes
    ----------
    surfaces : dict
        ``{face: BSplineSurface}`` of every face solved (each face of a group that
        shares one surface gets that surface), as checked.
    kept : dict
        ``{face: deviation}`` of the faces kept as they were: the deviation they stayed
        at with their joins closed (over their tolerance after :data:`REFINEMENTS`), or
        ``None`` where their pinned sides left nothing to fair.
    held : list of Join
        The joins faired across pole for pole (border joins, and joins between faces of
        one shared surface).
    pinned : dict
        ``{join: {(face, side)}}``: the other joins with a side pinned to its source.
    curved : list of Join
        The joins of ``held`` also held curvature-continuous (``continuity="G2"``).
    turned : list of int
        The faces kept as they were because a smooth join of theirs still turned more
        than the source's angle + :data:`~cq_fairing.core.joins.ANGLE_SLACK` after
        :data:`REFINEMENTS`.
    """

    surfaces: dict
    kept: dict
    held: list
    pinned: dict
    curved: list = field(default_factory=list)
    turned: list = field(default_factory=list)


def locate_side(face, edge, uv, bounds, point, edge_tolerance, size):
    """The :class:`JoinSide` of a face's edge, from its p-curve.

    Parameters
    ----------
    face, edge : int
        The backend's indices of the face and of its edge.
    uv : numpy.ndarray
        ``(n, 2)`` p-curve samples from the edge's start to its end.
    bounds : tuple of float
        ``(u0, u1, v0, v1)``: the surface's parameter rectangle.
    point : callable
        ``point(u, v)``: the surface's 3-D point, as three numbers.
    edge_tolerance, size : float
        The edge's tolerance and the model's size.

    Returns
    -------
    JoinSide
        The border the samples lie on (within :data:`BORDER_TOLERANCE` of the parameter
        span), its border parameters at the edge's ends, and ``full`` when the edge
        covers the side: where it stops short of a side's end, the surface points there
        lie within the edge's tolerance, or :data:`FULL_TOLERANCE` times ``size``, of
        each other (a file's edges often stop a hair inside the surface's bounds).  No
        border when the samples leave it (a trimmed face's inner edge).
    """
    u0, u1, v0, v1 = bounds
    span = max(u1 - u0, v1 - v0)
    borders = {"u0": (0, u0, (v0, v1)), "u1": (0, u1, (v0, v1)),
               "v0": (1, v0, (u0, u1)), "v1": (1, v1, (u0, u1))}
    for name, (axis, level, ends) in borders.items():
        if np.all(np.abs(uv[:, axis] - level) <= BORDER_TOLERANCE * span):
            along = (float(uv[0, 1 - axis]), float(uv[-1, 1 - axis]))
            reach = max(edge_tolerance, FULL_TOLERANCE * size)

            def at(t, axis=axis, level=level):
                return np.asarray(point(*((level, t) if axis == 0 else (t, level))), float)
            full = all(np.linalg.norm(at(end) - at(got)) <= reach
                       for end, got in zip(ends, (min(along), max(along))))
            return JoinSide(face, edge, name, along, bool(full))
    return JoinSide(face, edge)


def is_border_join(join):
    """True when both sides cover whole borders of their faces' parameter rectangles."""
    return all(side.side is not None and side.full for side in join.sides)


def runs_reversed(join):
    """True when the two faces' along-parameters run opposite ways."""
    a, b = join.sides
    return ((a.along[1] > a.along[0]) != (b.along[1] > b.along[0])) != join.opposed


def join_tolerance(join, tolerances):
    """The smaller tolerance of a join's faces (a face not selected has none: ``-inf``
    when neither is selected, so the join is left out)."""
    tols = [tolerances[s.face] for s in join.sides if tolerances.get(s.face) is not None]
    return min(tols) if tols else -np.inf


def border_joins(joins, sources, tolerances):
    """The joins of ``joins`` that :func:`project_jointly` can fair across pole for pole:
    border joins (:func:`is_border_join`) between faces of ``sources`` (non-periodic
    B-spline surfaces ``{face: BSplineSurface}``) whose borders, at equal
    normalised parameters, lie within :data:`SOURCE_GAP` times the join's tolerance
    (:func:`join_tolerance`) of each other.  A wider source gap is the source's, and
    borders that run along one curve with different parametrizations would pull each
    other's faces off their sources: those joins are pinned instead."""
    known = {}   # basis values per space and samples, shared by the joins' faces
    return [j for j in joins if is_border_join(j)
            and all(s.face in sources for s in j.sides)
            and _parametric_gap(j, sources, known) <= SOURCE_GAP * join_tolerance(j, tolerances)]


def _parametric_gap(join, sources, known=None):
    """Largest distance between the two faces' borders at equal normalised parameters
    (reversed where they run opposite ways: :func:`border_gap`, with ``known``)."""
    a, b = join.sides
    return border_gap(sources[a.face], a.side, sources[b.face], b.side, runs_reversed(join),
                      known=known)


def border_gap(first, side_first, second, side_second, reversed_, samples=33, known=None):
    """Largest distance between ``side_first`` of the surface ``first`` and
    ``side_second`` of ``second`` at ``samples`` equal normalised parameters along them
    (``reversed_``: the second's run the other way); ``known``: a dict that keeps the
    basis values at the samples per space for the next call
    (:func:`~cq_fairing.core.joins.side_points`)."""
    t = np.linspace(0.0, 1.0, samples)
    points = [side_points(surface, side, ts, known)
              for surface, side, ts in ((first, side_first, t),
                                        (second, side_second, 1.0 - t if reversed_ else t))]
    return float(np.linalg.norm(points[0] - points[1], axis=1).max())


def joined_faces(joins):
    """The faces that meet another face in ``joins`` (a face's join with itself, a
    closed seam, does not count).  They search with :func:`plain_target_options`."""
    return {face for join in joins if join.faces[0] != join.faces[1] for face in join.faces}


def plain_target_options(grading="auto", borders="auto", objective="auto", held=True):
    """The face options of a face that meets another face (:func:`joined_faces`) in the
    wavelet method's tolerance search: the plain projection (``objective="compact"``),
    and where the joins are ``held`` quasi-uniform targets (``grading="uniform"``),
    whose knots a neighbour searching the same family shares along the join, with free
    borders (``borders="free"``), which the joint projection sets; each where its
    option is ``"auto"`` (a value given explicitly is kept).  Held, the joint
    projection computes the face's net anew, so a polish would be lost; faired alone,
    a polished net with free borders moves its border along the edges it shares
    (linkrods faired face by face at 0.01: 15 faces faired against 18, the others kept
    for the gaps)."""
    chosen = (("grading", "uniform", grading), ("borders", "free", borders)) if held else ()
    return {name: plain for name, plain, given in chosen + (("objective", "compact",
                                                              objective),)
            if given == "auto"}


def model_grading(grading, several, method, by_tolerance):
    """The ``grading`` of the faces of a model (``several``: more than one face): in the
    wavelet method's tolerance search (``method``, ``by_tolerance``; other searches take
    no grading) ``"auto"`` becomes ``"spans"``, without targets graded by the error or
    refined towards pinned borders.  An error-graded net places its own knots and
    slides along its surface, while an edge a face shares with a neighbour faired alone
    keeps its p-curve, so the joins open: the testtoler shell faired face by face at
    0.01 kept 10 faces faired with 11 430 poles in 32.7 s that way, against 11 322
    poles in 4.7 s (``method="adaptive"`` projects those p-curves anew).  Targets
    refined towards pinned borders are less accurate inside, where the edges of a
    trimmed face may run: linkrods faired face by face at 0.01 kept 4 faces for the gaps
    they opened along shared edges and 13 faired, against 18 faired with ``"spans"``."""
    searched = several and method == "wavelet" and by_tolerance
    return "spans" if searched and grading == "auto" else grading


def joint_targets(sources, faired):
    """``{face: (u space, v space)}``: the targets of the faces of ``faired`` (``{face:
    surface faired alone}``) that :func:`project_jointly` may move: on their source's
    domain, and rational where the source is (a rational face faired onto a polynomial
    approximation stays out)."""
    return {face: (s.u_space, s.v_space) for face, s in faired.items()
            if face in sources and s.is_rational == sources[face].is_rational
            and s.domain == sources[face].domain}


def held_joins(projection, unchanged):
    """The joins a :class:`JointProjection` holds closed: faired across pole for pole, or
    pinned to the source on every side whose face moved (``unchanged``: the faces left
    as their sources)."""
    pinned = [join for join, sides in projection.pinned.items()
              if all((s.face, s.side) in sides or s.face in unchanged for s in join.sides)]
    return list(projection.held) + pinned


def unholdable(joins, sources, moved, selected):
    """``{face: [neighbour faces]}``: the faces of ``moved`` with a join that neither a
    shared border nor a pinned side can hold, because its edge runs across the face's
    surface (``side`` ``None``: a trimmed face's inner edge) or the face is not among
    ``sources`` (not read as a B-spline net with borders, a periodic face).  A join
    between two faces of ``selected`` that carry one surface is held by fairing that
    surface once.  The caller keeps these faces as they are, so that their joins stay as
    the source has them."""
    out, selected_sources = {}, set(sources) & set(selected)
    for join in joins:
        a, b = join.faces
        if a == b or ({a, b} <= selected_sources
                      and surface_key(sources[a]) == surface_key(sources[b])):
            continue
        for side, other in zip(join.sides, (b, a)):
            if side.face in moved and (side.side is None or side.face not in sources):
                out.setdefault(side.face, set()).add(other)
    return {face: sorted(others) for face, others in out.items()}


def project_jointly(sources, targets, joins, border, tolerances, check, *, continuity="G1",
                    excluded=frozenset()):
    """Project the faces on ``border`` and the faces with pinned sides together.

    Parameters
    ----------
    sources : dict
        ``{face: BSplineSurface}``: the faces read as non-periodic B-spline patches,
        polynomial or rational (any others stay out, as analytic faces do).
    targets : dict
        ``{face: (SplineSpace, SplineSpace)}``: each face that may move, with the target
        spaces its own tolerance search chose (on its source's domain).  A face of
        ``sources`` without one is kept: its borders constrain its neighbours.
    joins : sequence of Join
        Every join of the model: the sides off ``border`` are pinned.
    border : sequence of Join
        The joins to fair across (:func:`border_joins`, less those the caller fairs
        otherwise).
    tolerances : dict
        ``{face: tol}`` of the faces selected.
    check : callable
        ``check(face, surface) -> float``: the face's two-sided deviation from its source
        with ``surface`` under its trim (the backend's measure).  The surfaces checked
        already have the source's collapsed border rows put back on their points
        (:func:`~cq_fairing.core.geometry.collapsed_kept`); one with weights that are
        not all positive is not checked: it counts as over the tolerance.
    continuity : {"G1", "G0", "G2"}
        ``"G1"``: tangent planes held across smooth joins, and pinned there too;
        ``"G2"``: also the normal curvature across the smooth joins whose sources are
        curvature-continuous (:func:`~cq_fairing.core.joins.holds_curvature`).
    excluded : set of int
        Faces faired otherwise (patch grids): neither solved nor pinned.

    Returns
    -------
    JointProjection
    """
    group = _shared_surfaces(sources, targets, joins, border, tolerances)
    pins = _pins(sources, targets, joins, border, group, tolerances, excluded, continuity)
    group.update({face: face for face in pins if face not in group})
    faces = sorted(set(group.values()))
    kept = {i: None for i in faces if i not in targets}
    if len(kept) == len(faces):
        return JointProjection({}, {}, [], {})
    members = {face: [m for m in group if group[m] == face] for face in faces}
    refined = dict.fromkeys(faces, 0)
    stuck = set()      # kept: still turned after REFINEMENTS
    curved = _curvature_continuous(sources, border, group) if continuity == "G2" else set()
    while True:
        solve = _solve(sources, targets, faces, kept, refined, border, group, pins, continuity,
                       curved)
        solved = {m: collapsed_kept(sources[m], solve.result.surfaces[k])
                  for k, face in enumerate(faces) if face not in kept for m in members[face]}
        deviations = {m: check(m, s) if _positive(s) else np.inf for m, s in solved.items()}
        over = sorted({group[m] for m, d in deviations.items() if d > tolerances[m]})
        turned = [i for i in _turned(solve, faces, kept) if i not in over]
        grown = _grown(solve.result, sources, faces, kept, pins)
        kept.update(dict.fromkeys(grown))
        for face in over:
            if refined[face] < REFINEMENTS:
                refined[face] += 1
            else:
                kept[face] = max(deviations[m] for m in members[face])
        for face in turned:
            if refined[face] < REFINEMENTS:
                refined[face] += 1
            else:
                kept[face] = None
                stuck.add(face)
        if not over and not turned and not grown:
            break
    inside = [j for j in joins if j.faces[0] != j.faces[1]
              and group.get(j.faces[0], -1) == group.get(j.faces[1], -2)
              and group[j.faces[0]] not in kept]
    pinned = {(face, side) for face, side in solve.pinned if face not in kept}
    return JointProjection(solved, {m: d for face, d in kept.items()
                                    if face in targets and face not in stuck
                                    for m in members[face]},
                           solve.imposed + inside, _pinned_joins(joins, border, group, pinned),
                           solve.curved, sorted(m for face in stuck for m in members[face]
                                                if face in targets))


def surface_key(surface):
    """A key equal for identical surfaces (degrees, knots, poles, weights): faces that
    carry one surface split by their trims."""
    weights = b"" if surface.weights is None else surface.weights.tobytes()
    return (surface.u_degree, surface.v_degree, surface.u_knots.tobytes(),
            surface.v_knots.tobytes(), surface.poles.tobytes(), weights)


def _shared_surfaces(sources, targets, joins, border, tolerances):
    """``{face: representative}`` over the faces of ``border`` and the faces joined to one
    that carries the same surface: faces whose surfaces are identical
    (:func:`surface_key`) share the representative with the finest target (most poles)
    of those that may move; every other face represents itself.  A group with a face not
    selected (no tolerance), or whose faces would bring the same side of the surface
    into two joins, is not formed."""
    twins = {f for j in joins if j.faces[0] != j.faces[1]
             and all(f in sources for f in j.faces)
             and surface_key(sources[j.faces[0]]) == surface_key(sources[j.faces[1]])
             for f in j.faces}
    faces = sorted({s.face for j in border for s in j.sides} | twins)
    by_surface = {}
    for face in faces:
        by_surface.setdefault(surface_key(sources[face]), []).append(face)
    out = {face: face for face in faces}
    for same in by_surface.values():
        sides = [s.side for j in border for s in j.sides if s.face in same]
        if len(same) < 2 or len(sides) != len(set(sides)) or \
                any(tolerances.get(f) is None for f in same):
            continue
        movable = [f for f in same if f in targets] or same
        rep = max(movable, key=lambda f: np.prod([s.dimension for s in targets[f]])
                  if f in targets else 0)
        out.update(dict.fromkeys(same, rep))
    return out


def _pins(sources, targets, joins, border, group, tolerances, excluded, continuity):
    """``{face: {side: smooth}}``: the sides of the faces that may move that lie on a join
    off ``border`` (a side on a border join is joined instead); a smooth join pins the
    tangent plane too (``continuity`` G1 or G2)."""
    in_border = {id(j) for j in border}
    joined = {(group.get(s.face, s.face), s.side) for j in border for s in j.sides}
    out = {}
    for join in joins:
        if id(join) in in_border or join.faces[0] == join.faces[1]:
            continue
        for side in join.sides:
            face = group.get(side.face, side.face)
            if (side.side is None or face not in sources or face not in targets
                    or face in excluded or tolerances.get(face) is None
                    or (face, side.side) in joined):
                continue
            smooth = continuity != "G0" and join.kind == "smooth"
            sides = out.setdefault(face, {})
            sides[side.side] = sides.get(side.side, False) or smooth
    return out


def refined_targets(spaces, refined):
    """``spaces`` with each span halved ``refined`` times."""
    for _ in range(refined):
        spaces = tuple(_halved(s) for s in spaces)
    return spaces


def _halved(space):
    """``space`` with a knot in the middle of every span."""
    b, p = space.breakpoints, space.degree
    inner = np.sort(np.concatenate([space.knots[p + 1: -p - 1], 0.5 * (b[1:] + b[:-1])]))
    return SplineSpace(p, np.concatenate([np.full(p + 1, b[0]), inner, np.full(p + 1, b[-1])]))


@dataclass(frozen=True)
class _Solve:
    result: object
    patches: list
    imposed: list
    pinned: set
    curved: list


def _curvature_continuous(sources, border, group):
    """``{id(join)}``: the smooth joins of ``border`` whose sources are
    curvature-continuous across (:func:`~cq_fairing.core.joins.holds_curvature`), measured
    once for all the solves."""
    out = set()
    for join in border:
        a, b = join.sides
        core = BorderJoin(group[a.face], a.side, group[b.face], b.side, runs_reversed(join))
        if join.kind == "smooth" and holds_curvature(sources, core):
            out.add(id(join))
    return out


def _solve(sources, targets, faces, kept, refined, border, group, pins, continuity, curved):
    """The core's joint projection of ``faces`` (``kept`` fixed; a face stands for every
    face of ``group`` it represents; the sides of ``pins`` held at their sources by
    pinning patches after them; the joins of ``curved`` held in G2 where ``continuity``
    asks it)."""
    position = {face: k for k, face in enumerate(faces)}
    patches = [JointPatch(sources[i],
                          None if i in kept else refined_targets(targets[i], refined[i]))
               for i in faces]
    core_joins = {}
    for join in border:
        a, b = join.sides
        core = BorderJoin(position[group[a.face]], a.side, position[group[b.face]], b.side,
                          runs_reversed(join), join.kind == "smooth")
        core_joins[replace(core, curvature=id(join) in curved)] = join
    pinning = []
    for face in faces:
        for side, smooth in pins.get(face, {}).items() if face not in kept else ():
            pinning.append(BorderJoin(position[face], side, len(patches), side, False, smooth,
                                      curvature=False))
            patches.append(pinning_patch(sources[face], side))
    result = fair_patches(patches, list(core_joins) + pinning, continuity=continuity)
    pinned = {(faces[j.a], j.side_a) for j in result.joins if j.b >= len(faces)}
    return _Solve(result, patches, [core_joins[j] for j in result.joins if j in core_joins],
                  pinned, [core_joins[j] for j in result.curved if j in core_joins])


def _pinned_joins(joins, border, group, pinned):
    """``{join: {(face, side)}}``: the joins off ``border`` with a side held at its
    source (``pinned``: ``(patch face, side)``)."""
    in_border = {id(j) for j in border}
    out = {}
    for join in joins:
        sides = {(s.face, s.side) for s in join.sides
                 if (group.get(s.face, s.face), s.side) in pinned}
        if sides and id(join) not in in_border:
            out[join] = sides
    return out


def _turned(solve, faces, kept):
    """The solved faces on a smooth join that turns more than the source's angle +
    :data:`~cq_fairing.core.joins.ANGLE_SLACK` somewhere (a pinning patch is its own
    source)."""
    moved = [k for k, face in enumerate(faces) if face not in kept]
    turned = turned_patches(solve.result.surfaces, [p.source for p in solve.patches],
                            solve.result.joins, moved)
    return [faces[k] for k in turned]


def _positive(surface):
    """False for a rational surface with a weight that is not positive."""
    return not surface.is_rational or bool(np.all(surface.weights > 0))


def _grown(result, sources, faces, kept, pins):
    """The solved faces with pinned sides whose nets are no smaller than their sources'
    (pinned along both directions, the target spaces hold the source's)."""
    return [face for k, face in enumerate(faces) if face not in kept and face in pins
            and np.prod(result.surfaces[k].shape) >= np.prod(sources[face].shape)]
