r"""Fair the patch grids of a model as single surfaces.

A hull or a panel built as a grid of patches cannot be faired patch by patch: a
bicubic patch of one span is already at its coarsest, and fairing each patch alone
leaves a kink at every patch edge.  The faces that meet along whole sides across
smooth joins are laid out on a grid (:func:`~cq_fairing.core.patch_layout.find_grids`);
each rectangular block that forms a whole part of the model (no join of its faces
leads out of it or across it) is merged into one surface
(:func:`~cq_fairing.core.patch_grid.merge_grid`), projected onto the fewest
quasi-uniform poles within the tolerance with its patch borders pinned
(:func:`fair_merged`), and cut back into its patches at the original joins
(:func:`~cq_fairing.core.patch_grid.split_grid`).  The pieces share their borders pole
for pole (G0 to round-off), the merged surface is C2 across the former patch edges,
and the fairing runs across them: on the noisy 2 x 2 grid of
:func:`cq_fairing.core.examples.patch_grid` at tol 0.01, 8 curvature sign changes
along eight lines across the joins, against 24 face by face and 82 in the source.

Each piece is then checked against its own face by the backend's two-sided measure
(``check``: OCCT's in the OCP layer, the workbench's through FreeCAD's Part module).
When a piece is over its face's tolerance (the search's measure bounds the distance on
its samples only, the check measures densely and both ways), the merged target gets
more spans in each direction it may coarsen (:func:`grown_scales`: by the miss, at
least one), :data:`RETRIES` times at most; a block that still misses is left to the
face-by-face and joint passes.  Growing the accepted target keeps the fairing across
the patches when a check misses by little, where a new search at a smaller tolerance
can end on a much larger target (the search is not monotone).  The merged surface's border rows are averages of the
patches' border rows, which lie within ``merge_gap(tol)`` of each other.

Patches whose parametrizations do not match across their joins (the speed of u jumps
from one patch to the next, differently along each join) cannot be followed by one
smooth surface without sliding along it; the pinned borders and the per-face check
keep such a block's pieces on their faces, or leave the block to the other passes.

This module imports numpy only (and the core).
"""

import math
from dataclasses import dataclass

import numpy as np

from ..errors import FairingError, ToleranceNotMetError
from .geometry import collapsed_kept
from .joins import BorderJoin
from .joint_projection import SOURCE_GAP, runs_reversed
from .patch_grid import merge_grid, split_grid
from .patch_layout import find_grids
from .plans import target_space
from .scale_search import SurfaceSampler, max_scales, search_scales, target_degrees

__all__ = ["fair_grids", "fair_merged", "grown_scales", "source_merge_gap", "GridFairing",
           "RETRIES", "GROWTH", "SAMPLES"]

RETRIES = 2
GROWTH = 2.0   # a retry at most multiplies a direction's spans by this
SAMPLES = 17   # same-parameter samples per patch and direction in the merged search


@dataclass(frozen=True)
class GridFairing:
    """One block faired as one surface.

    Attributes
    ----------
    faces : list of int
        The block's faces, ``faces[i * n + j]`` in grid cell ``[i][j]``.
    shape : (int, int)
        Patches along the grid's two directions.
    merged : BSplineSurface
        The source patches merged.
    faired : BSplineSurface
        The merged surface faired, before it was cut.
    scales : (int or None, int or None)
        The faired surface's spans per direction (``None``: the merged surface's own
        space kept in that direction).
    surfaces : dict
        ``{face: BSplineSurface}``: each face's piece, on its source's parameter domain
        and in its directions, as checked.
    """

    faces: list
    shape: tuple
    merged: object
    faired: object
    scales: tuple
    surfaces: dict


def source_merge_gap(tol):
    """The largest distance between border poles merged into one at tolerance ``tol``:
    :data:`~cq_fairing.core.joint_projection.SOURCE_GAP` times ``tol``, the gap below
    which the joint projection shares two borders too."""
    return SOURCE_GAP * tol


def fair_grids(sources, joins, border, tolerances, check, *, target_degree=None,
               reversed_=runs_reversed, merge_gap=source_merge_gap):
    """Fair every grid block among ``border`` that stands alone as one surface.

    A block stands alone when every join of its faces ties two neighbouring cells of
    the block: the block is a whole connected part of the model.  A join to a face
    outside (or across the block, closing a ring) would tie a piece of the merged
    fairing, whose border runs where the smooth merged surface puts it, to a face that
    keeps its own border: such blocks are left to the joint projection.

    Parameters
    ----------
    sources : dict
        ``{face: BSplineSurface}`` of the polynomial faces that may be joined.
    joins : sequence of Join
        Every join of the model.
    border : sequence of Join
        Whole-side joins between faces of ``sources``; the smooth ones may be crossed.
    tolerances : dict
        ``{face: tol}`` of the faces that may move (a face without one is left out).
    check : callable
        ``check(face, surface) -> float``: the face's two-sided deviation from its source
        with ``surface`` under its trim (the backend's measure).  The pieces checked
        have the source's collapsed border rows put back on their points
        (:func:`~cq_fairing.core.geometry.collapsed_kept`).
    target_degree : int or (int, int), optional
        The merged target's degrees (:func:`~cq_fairing.core.scale_search.target_degrees`).
    reversed_ : callable, optional
        ``reversed_(join)``: whether the two faces' along-parameters run opposite ways.
    merge_gap : callable, optional
        ``merge_gap(tol)``: the largest distance between border poles merged into one.

    Returns
    -------
    list of GridFairing
        The blocks whose every piece is within its face's tolerance.
    """
    faces = sorted(f for f in sources if tolerances.get(f) is not None)
    position = {face: k for k, face in enumerate(faces)}
    smooth = [BorderJoin(position[a.face], a.side, position[b.face], b.side, reversed_(j))
              for j in border if j.kind == "smooth" for a, b in [j.sides]
              if a.face in position and b.face in position]
    done = []
    for block in find_grids([sources[f] for f in faces], smooth):
        cell_faces = [[faces[c.patch] for c in column] for column in block.cells]
        if not _stands_alone(cell_faces, joins):
            continue
        outcome = _fair_block(block, cell_faces, sources, tolerances, check, target_degree,
                              merge_gap)
        if outcome is not None:
            done.append(outcome)
    return done


def _stands_alone(cell_faces, joins):
    """True when every join of the block's faces ties neighbouring cells."""
    cell = {f: (i, j) for i, column in enumerate(cell_faces) for j, f in enumerate(column)}
    for join in joins:
        a, b = join.faces
        if a not in cell and b not in cell:
            continue
        if a not in cell or b not in cell:
            return False
        (ia, ja), (ib, jb) = cell[a], cell[b]
        if abs(ia - ib) + abs(ja - jb) != 1:
            return False
    return True


def _fair_block(block, cell_faces, sources, tolerances, check, target_degree, merge_gap):
    """Merge, fair, cut and check one block: its :class:`GridFairing` when every piece
    is within its face's tolerance, else ``None``."""
    tol = min(tolerances[f] for column in cell_faces for f in column)
    grid = [[cell.to_grid(sources[f]) for cell, f in zip(column, faces)]
            for column, faces in zip(block.cells, cell_faces)]
    try:
        merged = merge_grid(grid, tol=merge_gap(tol))
        fit = _MergedFit(merged, target_degree)
        scales, faired = fit.search(tol)
    except (FairingError, ToleranceNotMetError):
        return None
    for _ in range(RETRIES + 1):
        pieces = split_grid(merged, faired)
        surfaces = {f: collapsed_kept(sources[f], cell.from_grid(pieces[i][j]))
                    for i, (column, faces) in enumerate(zip(block.cells, cell_faces))
                    for j, (cell, f) in enumerate(zip(column, faces))}
        deviations = {f: check(f, surface) for f, surface in surfaces.items()}
        if all(deviations[f] <= tolerances[f] for f in surfaces):
            return GridFairing([f for column in cell_faces for f in column], block.shape,
                               merged.surface, faired, scales, surfaces)
        miss = max(deviations[f] / tolerances[f] for f in surfaces)
        grown = _within(fit, grown_scales(scales, miss, fit.top, fit.degrees), tol)
        if grown is None:
            return None
        scales, faired = grown
    return None


def _within(fit, candidates, tol):
    """The first of ``candidates`` (scales) whose pinned projection is within ``tol`` by
    the search's own measure: ``(scales, faired)``, or ``None``."""
    for scales in candidates:
        faired = fit.project(scales)
        if fit.distance(faired) <= tol:
            return scales, faired
    return None


def grown_scales(scales, miss, top, degrees):
    r"""The targets to try after a target's pieces missed their check by the ratio
    ``miss`` (deviation over tolerance, > 1), fewest poles first: each direction that
    can grow alone, then all together.  A direction grows to :math:`\min(n_{max},
    \max(n + 1, \lceil n \min(g, \text{miss}^{1/(p+1)}) \rceil))` spans, :math:`g` =
    :data:`GROWTH` (the distance of a degree-:math:`p` projection falls about as
    :math:`h^{p+1}` with the span :math:`h`); one kept (``None``) or at its largest
    ``top`` stays.  Near the noise of a source the distance is not monotone in the
    spans, hence the several targets."""
    grown = []
    for n, largest, degree in zip(scales, top, degrees):
        if n is None or largest is None or n >= largest:
            grown.append(n)
            continue
        factor = min(GROWTH, miss ** (1.0 / (degree + 1)))
        grown.append(min(largest, max(n + 1, math.ceil(n * factor))))
    alone = [tuple(g if k == axis else n for k, (n, g) in enumerate(zip(scales, grown)))
             for axis in range(len(scales))]
    candidates = {c for c in alone + [tuple(grown)] if c != tuple(scales)}
    return sorted(candidates, key=lambda c: _poles(c, top, degrees))


def _poles(scales, top, degrees):
    """Poles of a target (a kept direction counted at its largest scale)."""
    return math.prod((top_n if n is None else n) + degree
                     for n, top_n, degree in zip(scales, top, degrees) if top_n is not None)


def fair_merged(merged, tol, target_degree=None):
    """A merged patch grid faired onto the fewest quasi-uniform poles within ``tol`` of it
    (:func:`~cq_fairing.core.scale_search.search_scales`, as a face's search, with the
    patch borders pinned: :meth:`~cq_fairing.core.patch_grid.MergedGrid.pinned_projection`).

    A candidate is measured where each piece must stay: on the patch borders, by the
    same-parameter distance (the pieces then cover their patches), and inside, by the
    distance to the faired tangent planes at :data:`SAMPLES` parameters per patch and
    direction (a smooth target slides along the surface where the patches'
    parametrizations do not match, which that distance does not count).  The tangent
    planes do not see a surface that folds back over itself (the same points, the
    normal reversed), so a candidate whose normal turns by more than 90 degrees from
    the source's anywhere on the samples counts as out of tolerance.  A direction that
    crosses joins is always coarsened: kept, its knots of multiplicity ``degree`` would
    keep every kink of the source.

    Parameters
    ----------
    merged : MergedGrid
        From :func:`~cq_fairing.core.patch_grid.merge_grid`.
    tol : float
    target_degree : int or (int, int), optional
        Default ``min(3, degree)`` per direction.

    Returns
    -------
    BSplineSurface
        On the merged domain; cut it with :func:`~cq_fairing.core.patch_grid.split_grid`.

    Raises
    ------
    ToleranceNotMetError
        No target is within ``tol``.
    """
    return _MergedFit(merged, target_degree).search(tol)[1]


class _MergedFit:
    """The targets of a merged grid (:func:`fair_merged`): the pinned projection onto
    ``n`` spans per direction (:meth:`project`), its measure (:meth:`distance`) and the
    search for the fewest poles within a tolerance (:meth:`search`)."""

    def __init__(self, merged, target_degree):
        surface = merged.surface
        self.merged = merged
        self.degrees = target_degrees(surface, target_degree)
        self.top = max_scales(surface, self.degrees)
        u, v = (_samples(breaks) for breaks in (merged.u_breaks, merged.v_breaks))
        self.samples = (u, v)
        self.sampler = SurfaceSampler((u, v, np.ones((u.size, v.size), dtype=bool)), surface)
        self.lines = [(merged.u_breaks, v), (u, merged.v_breaks)]
        self.on_lines = [surface.evaluate_grid(a, b) for a, b in self.lines]

    def distance(self, faired):
        """The larger of the same-parameter distance on the patch borders and the
        distance to the tangent planes inside; infinite where ``faired`` folds."""
        if faired.folds_against(self.merged.surface, *self.samples).any():
            return np.inf
        slide = max(float(np.linalg.norm(faired.evaluate_grid(a, b) - exact, axis=-1).max())
                    for (a, b), exact in zip(self.lines, self.on_lines))
        return max(slide, self.sampler.normal(faired))

    def project(self, scales):
        """The pinned projection onto ``scales`` spans (``None`` keeps a direction)."""
        spaces = [None if n is None else target_space(space, int(n), degree)
                  for n, space, degree in zip(scales, (self.merged.surface.u_space,
                                                       self.merged.surface.v_space),
                                              self.degrees)]
        return self._projection(*spaces)

    def _projection(self, target_u, target_v):
        surface = self.merged.surface
        return self.merged.pinned_projection(target_u or surface.u_space,
                                             target_v or surface.v_space)

    def search(self, tol):
        """``(scales, faired)`` of the fewest poles within ``tol`` by :meth:`distance`."""
        keep = tuple(count == 1 for count in self.merged.shape)
        target, faired, _, _ = search_scales(self.merged.surface, tol, self.degrees,
                                             self.distance, keep=keep,
                                             projection=self._projection)
        return tuple(None if space is None else space.n_spans for space in target), faired


def _samples(breaks):
    """:data:`SAMPLES` parameters in every patch interval, its ends included."""
    return np.unique(np.concatenate([np.linspace(a, b, SAMPLES)
                                     for a, b in zip(breaks[:-1], breaks[1:])]))
