r"""Lay a network's faces out as pieces that meet side to side, cut at T-junctions.

The energy network (:mod:`cq_fairing.core.network`) ties the border rows of two patches
pole for pole, so each of its joins must cover whole sides of both.  In a shell laid out
like brickwork a face's side meets two neighbours (their common corner, a T-junction,
lies inside the side), or a neighbour over part of its length only.  Such a face is cut
into pieces (:func:`~cq_fairing.core.patch_grid.cut_surface`, exact) along the iso-line
through each end of a partial join that lies inside its side.  That iso-line meets the
opposite side too: the cut runs on into the neighbour there (at the nearest point of
its side) and on, until it ends where a join ends already, on a border of the network,
or at a face outside it.  Then every join covers whole sides of pieces:

* neighbouring pieces of one face meet across a smooth join (the face is smooth there,
  and the network holds G1 across it as across any smooth join);
* a join of the model becomes the joins of the pieces along it, paired in order.

A piece stays as it is (:attr:`PieceLayout.held`) where a join along it leads out of the
layout, cannot be paired, or would tie borders that differ in degree, knots or position
(farther apart than :data:`~cq_fairing.core.joint_projection.SOURCE_GAP` times the
tolerance at equal parameters).  After the fairing each face's pieces are put back
together (:meth:`PieceLayout.face_surface`,
:func:`~cq_fairing.core.patch_grid.join_pieces`): each cut is a knot of full
multiplicity, so the face has more poles than its source.

This module imports numpy only (and the core).
"""

from dataclasses import dataclass

import numpy as np

from .joins import BorderJoin, _along, side_points
from .joint_projection import SOURCE_GAP, border_gap, join_tolerance
from .network import network_joinable
from .patch_grid import cut_surface, join_pieces

__all__ = ["PieceLayout", "lay_out_pieces", "SNAP", "CUTS"]

SNAP = 1e-3      # x a side's parameter range: join ends closer than this are one point
CUTS = 4         # most cuts per face and direction; a face that needs more is held
SAMPLES = 257    # points per search of the nearest point on a side (then refined twice)


@dataclass(frozen=True)
class PieceLayout:
    """A network's faces as pieces.

    Attributes
    ----------
    pieces : list of BSplineSurface
        Every face's pieces, on the face's own parameters.
    faces : list of int
        The face of each piece.
    grids : dict
        ``{face: [[piece]]}``: the face's pieces, ``[i][j]`` the ``i``-th along u and the
        ``j``-th along v.
    joins : list of BorderJoin
        Whole-side joins between pieces (indices into ``pieces``).
    origins : list
        The model's :class:`~cq_fairing.core.joint_projection.Join` of each join of
        ``joins``, ``None`` across a cut.
    held : set of int
        The pieces that keep their surfaces.
    """

    pieces: list
    faces: list
    grids: dict
    joins: list
    origins: list
    held: set

    def face_surface(self, face, surfaces):
        """Face ``face`` from its pieces' ``surfaces`` (indexed like :attr:`pieces`)."""
        grid = self.grids[face]
        if len(grid) == 1 and len(grid[0]) == 1:
            return surfaces[grid[0][0]]
        return join_pieces([[surfaces[k] for k in row] for row in grid])

    def joins_held(self, linked):
        """The model's joins all of whose pieces' joins are among ``linked`` (indices into
        :attr:`joins`)."""
        parts = {}
        for k, origin in enumerate(self.origins):
            if origin is not None:
                parts.setdefault(id(origin), [origin, True])[1] &= k in linked
        return [origin for origin, whole in parts.values() if whole]


def lay_out_pieces(sources, faces, joins, tolerances, reversed_):
    """Cut the ``faces`` at the T-junctions of their joins into pieces that meet side to
    side (module docstring).

    Parameters
    ----------
    sources : dict
        ``{face: BSplineSurface}``, polynomial.
    faces : collection of int
        The faces to lay out (each with a tolerance in ``tolerances``).
    joins : sequence of Join
        Every join of the model: those between two of ``faces`` along their borders are
        laid out, every other one holds the pieces along it.
    tolerances : dict
        ``{face: tol}``.
    reversed_ : callable
        ``reversed_(join)``: the two faces' along-parameters run opposite ways.

    Returns
    -------
    PieceLayout
    """
    faces = set(faces)
    inner = [j for j in joins if set(j.faces) <= faces and j.faces[0] != j.faces[1]
             and all(s.side is not None for s in j.sides)]
    cuts, crowded = _cuts(sources, faces, inner)
    pieces, owners, grids = [], [], {}
    for face in sorted(faces):
        grid = cut_surface(sources[face], *cuts[face])
        grids[face] = [[len(pieces) + i * len(grid[0]) + j for j in range(len(grid[0]))]
                       for i in range(len(grid))]
        for row in grid:
            pieces.extend(row)
            owners.extend([face] * len(row))
    held = {k for face in crowded for row in grids[face] for k in row}
    layout = PieceLayout(pieces, owners, grids, [], [], held)
    _join_across_cuts(layout)
    for join in inner:
        _pair(layout, join, reversed_(join), tolerances)
    laid = {id(j) for j in inner}
    for join in joins:
        if id(join) not in laid:
            for side in join.sides:
                if side.face in faces:
                    held.update(_pieces_along(layout, side))
    return layout


# -- cuts ----------------------------------------------------------------------------------
def _cuts(sources, faces, joins):
    """``({face: (u cuts, v cuts)}, crowded faces)``: the parameters where each face is
    cut, from the ends of its partial joins carried across the faces they cross."""
    cuts = {face: ([], []) for face in faces}
    crowded = set()
    by_side = {}
    for join in joins:
        for k, side in enumerate(join.sides):
            by_side.setdefault((side.face, side.side), []).append((join, k))
    work = []

    def add(face, side, x):
        axis = _along(side)
        lo, hi = sources[face].domain[axis]
        snap = SNAP * (hi - lo)
        have = cuts[face][axis]
        if x <= lo + snap or x >= hi - snap or any(abs(x - c) <= snap for c in have):
            return
        if len(have) >= CUTS:
            crowded.add(face)
            return
        have.append(float(x))
        work.append((face, axis, float(x)))

    for join in joins:
        for side in join.sides:
            if not side.full:
                for x in side.along:
                    add(side.face, side.side, x)
    while work:
        face, axis, x = work.pop()
        for end in (("u0", "u1") if axis == 1 else ("v0", "v1")):
            for join, k in by_side.get((face, end), ()):
                here, there = join.sides[k], join.sides[1 - k]
                lo, hi = sorted(here.along)
                if lo + SNAP * (hi - lo) < x < hi - SNAP * (hi - lo):
                    point = _side_point(sources[face], end, x)
                    add(there.face, there.side,
                        _nearest_on_side(sources[there.face], there.side, point, there.along))
    return {face: tuple(sorted(c) for c in pair) for face, pair in cuts.items()}, crowded


def _side_point(surface, side, x):
    """The point of ``side`` of ``surface`` at its along-parameter ``x``."""
    return _side_points(surface, side, np.array([x]))[0]


def _side_points(surface, side, x):
    """Points of ``side`` at its along-parameters ``x``."""
    lo, hi = surface.domain[_along(side)]
    return side_points(surface, side, (np.asarray(x, dtype=float) - lo) / (hi - lo))


def _nearest_on_side(surface, side, point, along):
    """The along-parameter in ``along`` (a range) of the point of ``side`` nearest
    ``point``: dense samples, then twice finer around the nearest."""
    lo, hi = sorted(along)
    for _ in range(3):
        x = np.linspace(lo, hi, SAMPLES)
        best = int(np.argmin(np.linalg.norm(_side_points(surface, side, x) - point, axis=1)))
        lo, hi = x[max(best - 1, 0)], x[min(best + 1, SAMPLES - 1)]
    return float(x[best])


# -- joins ---------------------------------------------------------------------------------
def _join_across_cuts(layout):
    """The smooth joins between neighbouring pieces of each face."""
    for grid in layout.grids.values():
        for i, row in enumerate(grid):
            for j, piece in enumerate(row):
                if i + 1 < len(grid):
                    layout.joins.append(BorderJoin(piece, "u1", grid[i + 1][j], "u0",
                                                    cut=True))
                    layout.origins.append(None)
                if j + 1 < len(row):
                    layout.joins.append(BorderJoin(piece, "v1", row[j + 1], "v0", cut=True))
                    layout.origins.append(None)


def _pieces_along(layout, side):
    """The pieces along a join side, in the order of its along-parameter, that lie
    within its range (all of them when the side is not a border)."""
    grid = layout.grids[side.face]
    if side.side is None:
        return [k for row in grid for k in row]
    line = ([row[0 if side.side[1] == "0" else -1] for row in grid] if side.side[0] == "v"
            else grid[0 if side.side[1] == "0" else -1])
    axis = _along(side.side)
    lo, hi = sorted(side.along)
    snap = SNAP * (hi - lo)
    return [k for k in line if layout.pieces[k].domain[axis][0] >= lo - snap
            and layout.pieces[k].domain[axis][1] <= hi + snap]


def _pair(layout, join, reversed_, tolerances):
    """Add the joins of the pieces along ``join``, paired in order; hold the pieces of a
    join that cannot be paired or whose pieces do not match."""
    a, b = join.sides
    first, second = _pieces_along(layout, a), _pieces_along(layout, b)
    if reversed_:
        second = second[::-1]
    if len(first) != len(second) or not _covers(layout, a, first) \
            or not _covers(layout, b, second):
        layout.held.update(first + second)
        return
    allowed = SOURCE_GAP * join_tolerance(join, tolerances)
    for pa, pb in zip(first, second):
        piece_join = BorderJoin(pa, a.side, pb, b.side, reversed_, join.kind == "smooth")
        if _matches(layout.pieces, piece_join, allowed):
            layout.joins.append(piece_join)
            layout.origins.append(join)
        else:
            layout.held.update((pa, pb))


def _covers(layout, side, pieces):
    """The ``pieces`` along ``side`` span its whole range."""
    if not pieces:
        return False
    axis = _along(side.side)
    lo, hi = sorted(side.along)
    ends = sorted(layout.pieces[k].domain[axis][e] for k in pieces for e in (0, 1))
    return abs(ends[0] - lo) <= SNAP * (hi - lo) and abs(ends[-1] - hi) <= SNAP * (hi - lo)


def _matches(pieces, join, allowed):
    """The two sides share degree and knots (:func:`network_joinable`) and lie within
    ``allowed`` of each other at equal normalised parameters (:func:`border_gap`)."""
    a, b = pieces[join.a], pieces[join.b]
    return (network_joinable(a, join.side_a, b, join.side_b, join.reversed)
            and border_gap(a, join.side_a, b, join.side_b, join.reversed) <= allowed)
