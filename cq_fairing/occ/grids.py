r"""Fair the patch grids of a model as single surfaces.

A hull or a panel built as a grid of patches cannot be faired patch by patch: a
bicubic patch of one span is already at its coarsest, and fairing each patch alone
leaves a kink at every patch edge.  The faces that meet along whole sides across
smooth joins are laid out on a grid (:func:`~cq_fairing.core.patch_layout.find_grids`);
each rectangular block that forms a whole part of the model (no join of its faces
leads out of it or across it) is merged into one surface
(:func:`~cq_fairing.core.patch_grid.merge_grid`), projected onto the fewest
quasi-uniform poles within the tolerance with its patch borders pinned
(:meth:`~cq_fairing.core.patch_grid.MergedGrid.pinned_projection`, searched as a face's
target by :func:`~cq_fairing.occ.search.search_scales`), and cut back into its patches
at the original joins (:func:`~cq_fairing.core.patch_grid.split_grid`).  The pieces
share their borders pole for pole (G0 to round-off), the merged surface is C2 across
the former patch edges, and the fairing runs across them: on the noisy 2 x 2 grid of
:func:`cq_fairing.core.examples.patch_grid` at tol 0.01, 8 curvature sign changes
along eight lines across the joins, against 24 face by face and 82 in the source.

Each piece is then checked against its own face by OCCT, both ways.  When a piece is
over its face's tolerance the block is faired again at :data:`SHRINK` times the
tolerance, :data:`RETRIES` times at most; a block that still misses is left to the
face-by-face and joint passes.  The merged surface's border rows are averages of the
patches' border rows, which lie within ``merge_gap(tol)`` of each other.

Patches whose parametrizations do not match across their joins (the speed of u jumps
from one patch to the next, differently along each join) cannot be followed by one
smooth surface without sliding along it; the pinned borders and the per-face check
keep such a block's pieces on their faces, or leave the block to the other passes.
"""

from dataclasses import dataclass

import numpy as np

from ..core.geometry import collapsed_kept
from ..core.joins import BorderJoin
from ..core.patch_grid import merge_grid, split_grid
from ..core.patch_layout import find_grids
from ..errors import FairingError, ToleranceNotMetError
from .faces import SurfaceSampler, target_degrees
from .search import search_scales

__all__ = ["fair_grids", "GridFairing", "RETRIES", "SHRINK"]

RETRIES = 2
SHRINK = 0.5
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
    tolerance : float
        The tolerance the merged surface was faired to.
    """

    faces: list
    shape: tuple
    merged: object
    faired: object
    tolerance: float


def fair_grids(job, adjacency, readable, joins, reversed_, merge_gap):
    """Fair every grid block among ``joins`` that stands alone as one surface; install
    the pieces.

    A block stands alone when every join of its faces ties two neighbouring cells of
    the block: the block is a whole connected part of the model.  A join to a face
    outside (or across the block, closing a ring) would tie a piece of the merged
    fairing, whose border runs where the smooth merged surface puts it, to a face that
    keeps its own border: such blocks are left to the joint projection.

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
        After its first pass; the reports of the faces of every block faired here are
        replaced by the pieces' reports.
    adjacency : Adjacency
        Every join of the model.
    readable : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    joins : list of Join
        Whole-side joins between faces of ``readable``; the smooth ones may be crossed.
    reversed_ : callable
        ``reversed_(join)``: whether the two faces' along-parameters run opposite ways.
    merge_gap : callable
        ``merge_gap(tol)``: the largest distance between border poles merged into one.

    Returns
    -------
    list of GridFairing
    """
    faces = sorted(f for f in readable if job.tol.get(f) is not None)
    position = {face: k for k, face in enumerate(faces)}
    smooth = [BorderJoin(position[a.face], a.side, position[b.face], b.side, reversed_(j))
              for j in joins if j.kind == "smooth" for a, b in [j.sides]
              if a.face in position and b.face in position]
    done = []
    for block in find_grids([readable[f] for f in faces], smooth):
        members = [faces[k] for k in block.patches]
        cell_faces = [[faces[c.patch] for c in column] for column in block.cells]
        if not _stands_alone(cell_faces, adjacency):
            continue
        outcome = _fair_block(job, block, cell_faces, readable, merge_gap)
        if outcome is not None:
            done.append(GridFairing(members, block.shape, *outcome))
    return done


def _stands_alone(cell_faces, adjacency):
    """True when every join of the block's faces ties neighbouring cells."""
    cell = {f: (i, j) for i, column in enumerate(cell_faces) for j, f in enumerate(column)}
    for face in cell:
        for join in adjacency.joins_of(face):
            a, b = join.faces
            if a not in cell or b not in cell:
                return False
            (ia, ja), (ib, jb) = cell[a], cell[b]
            if abs(ia - ib) + abs(ja - jb) != 1:
                return False
    return True


def _fair_block(job, block, cell_faces, readable, merge_gap):
    """Merge, fair, cut and check one block; ``(merged, faired, tol)`` when every piece
    is within its face's tolerance (their reports installed), else ``None``."""
    tol = min(job.tol[f] for column in cell_faces for f in column)
    grid = [[cell.to_grid(readable[f]) for cell, f in zip(column, faces)]
            for column, faces in zip(block.cells, cell_faces)]
    try:
        merged = merge_grid(grid, tol=merge_gap(tol))
    except FairingError:
        return None
    goal = tol
    for _ in range(RETRIES + 1):
        faired = _fair_merged(merged, goal, job.options["target_degree"])
        if faired is None:
            return None
        pieces = split_grid(merged, faired)
        checked = {f: job.measured(f, collapsed_kept(readable[f],
                                                     cell.from_grid(pieces[i][j])))
                   for i, (column, faces) in enumerate(zip(block.cells, cell_faces))
                   for j, (cell, f) in enumerate(zip(column, faces))}
        if all(deviation["max"] <= job.tol[f] for f, (_, _, deviation) in checked.items()):
            _install(job, checked, readable, cell_faces, block.shape)
            return merged.surface, faired, goal
        goal *= SHRINK
    return None


def _fair_merged(merged, tol, target_degree):
    """The merged surface faired onto the fewest quasi-uniform poles within ``tol`` of it
    (:func:`~cq_fairing.occ.search.search_scales`, as a face's search, with the patch
    borders pinned: :meth:`~cq_fairing.core.patch_grid.MergedGrid.pinned_projection`);
    ``None`` when no target is.

    A candidate is measured where each piece must stay: on the patch borders, by the
    same-parameter distance (the pieces then cover their patches), and inside, by the
    distance to the faired tangent planes at :data:`SAMPLES` parameters per patch and
    direction (a smooth target slides along the surface where the patches'
    parametrizations do not match, which that distance does not count).  The tangent
    planes do not see a surface that folds back over itself (the same points, the
    normal reversed), so a candidate whose normal turns by more than 90 degrees from
    the source's anywhere on the samples counts as out of tolerance.  A direction that
    crosses joins is always coarsened: kept, its knots of multiplicity ``degree`` would
    keep every kink of the source."""
    surface = merged.surface
    u, v = (_samples(breaks) for breaks in (merged.u_breaks, merged.v_breaks))
    sampler = SurfaceSampler((u, v, np.ones((u.size, v.size), dtype=bool)), surface)
    lines = [(merged.u_breaks, v), (u, merged.v_breaks)]
    on_lines = [surface.evaluate_grid(a, b) for a, b in lines]

    def distance(faired):
        if faired.folds_against(surface, u, v).any():
            return np.inf
        slide = max(float(np.linalg.norm(faired.evaluate_grid(a, b) - exact, axis=-1).max())
                    for (a, b), exact in zip(lines, on_lines))
        return max(slide, sampler.normal(faired))

    def projection(target_u, target_v):
        return merged.pinned_projection(target_u or surface.u_space,
                                        target_v or surface.v_space)

    keep = tuple(count == 1 for count in merged.shape)
    try:
        _, faired, _, _ = search_scales(surface, tol, target_degrees(surface, target_degree),
                                        distance, keep=keep, projection=projection)
    except ToleranceNotMetError:
        return None
    return faired


def _samples(breaks):
    """:data:`SAMPLES` parameters in every patch interval, its ends included."""
    return np.unique(np.concatenate([np.linspace(a, b, SAMPLES)
                                     for a, b in zip(breaks[:-1], breaks[1:])]))


def _install(job, checked, readable, cell_faces, shape):
    members = ", ".join(str(f + 1) for column in cell_faces for f in column)
    message = f"faired as one surface with faces {members} ({shape[0]} x {shape[1]} patch grid)"
    for index, measured in checked.items():
        job.faired(index, measured, message, readable[index].shape)
