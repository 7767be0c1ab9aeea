r"""Find the regular grids in a layout of patches that meet along whole sides.

A model built as a patch grid (a hull, a panel) arrives as faces and shared edges, each
face with its own parameter directions.  :func:`find_grids` recovers the grid: it walks
the joins from a seed patch and gives every patch it reaches a grid cell
:math:`(x, y)` and a :class:`Placement`, the exchange and reversals of its parameter
directions that make its u run along the grid's x and its v along y
(:func:`~cq_fairing.core.patch_grid.oriented`).  The walk sees the joins only, so a
ring of patches closing on itself (a tube) is unrolled: the join that would close it
is left out of the grid.

A grid cell is joined to its x neighbour when the patches meet along the sides that the
placements put there, with their along-parameters running the same way in the grid,
and the patches could be merged there: equal degrees and the same knots along the
shared side (normalised to :math:`[0, 1]`, within
:data:`~cq_fairing.core.patch_grid.KNOT_TOLERANCE`).  The grids are then the largest
rectangles of cells whose every inner neighbour pair is so joined, taken greedily:
each is merged into one surface by :func:`~cq_fairing.core.patch_grid.merge_grid`.

This module imports numpy only.
"""

from collections import deque
from dataclasses import dataclass

import numpy as np

from .patch_grid import KNOT_TOLERANCE, oriented

__all__ = ["Placement", "GridBlock", "find_grids"]

STEPS = {"W": (-1, 0), "E": (1, 0), "S": (0, -1), "N": (0, 1)}
OPPOSITE = {"W": "E", "E": "W", "S": "N", "N": "S"}
ORIENTATIONS = [(s, fu, fv) for s in (False, True) for fu in (False, True)
                for fv in (False, True)]


@dataclass(frozen=True)
class Placement:
    r"""A patch in its grid cell: ``oriented(patch, swap, flip_u, flip_v)`` has its u
    along the grid's x (west to east) and its v along y (south to north).

    With :math:`x' = 1 - x` if ``flip_u`` else :math:`x` (likewise :math:`y'`), the grid
    point :math:`(x, y)` of the cell is the patch's normalised parameter
    :math:`(u, v) = (y', x')` if ``swap`` else :math:`(x', y')`.
    """

    patch: int
    swap: bool = False
    flip_u: bool = False
    flip_v: bool = False

    def side(self, direction):
        """``(side, forward)``: the patch's side (one of ``"u0" "u1" "v0" "v1"``) at the
        cell's ``direction`` (``"W" "E" "S" "N"``), and whether its along-parameter
        runs the way the grid does along that side."""
        across_x = direction in "WE"
        flip_across, flip_along = ((self.flip_u, self.flip_v) if across_x
                                   else (self.flip_v, self.flip_u))
        letter = ("v" if self.swap else "u") if across_x else ("u" if self.swap else "v")
        end = "1" if (direction in "EN") != flip_across else "0"
        return letter + end, not flip_along

    def to_grid(self, surface):
        """The patch in grid orientation."""
        return oriented(surface, self.swap, self.flip_u, self.flip_v)

    def from_grid(self, surface):
        """A surface in grid orientation back in the patch's own directions (the inverse
        of :meth:`to_grid`: the reversals first, then the exchange)."""
        return oriented(oriented(surface, False, self.flip_u, self.flip_v), self.swap)


@dataclass(frozen=True)
class GridBlock:
    """A rectangle of patches that merge into one surface.

    Attributes
    ----------
    cells : tuple of tuple of Placement
        ``cells[i][j]``: the patch ``i``-th along x and ``j``-th along y, as
        :func:`~cq_fairing.core.patch_grid.merge_grid` takes them after
        :meth:`Placement.to_grid`.
    """

    cells: tuple

    @property
    def patches(self):
        """The patch indices of the block."""
        return [cell.patch for column in self.cells for cell in column]

    @property
    def shape(self):
        """``(m, n)``: cells along x and y."""
        return len(self.cells), len(self.cells[0])


def find_grids(surfaces, joins, min_patches=2):
    """The rectangular grids of patches among ``joins``, largest first.

    Parameters
    ----------
    surfaces : sequence of BSplineSurface
        The patches, clamped; joins refer to them by index.
    joins : iterable of BorderJoin
        Whole-side joins (:class:`~cq_fairing.core.joins.BorderJoin`); the caller passes
        the ones across which the patches may be faired as one surface (smooth ones).
    min_patches : int, optional
        Smallest block returned (default 2).

    Returns
    -------
    list of GridBlock
        Disjoint blocks of at least ``min_patches`` patches, in the greedy order
        (largest area first).
    """
    links = _links_by_patch(joins)
    placed, blocks = {}, []
    for seed in range(len(surfaces)):
        if seed not in placed:
            cells = _walk(seed, links, placed)
            blocks.extend(_rectangles(cells, _joined_pairs(cells, links, surfaces),
                                      min_patches))
    return sorted(blocks, key=lambda b: -len(b.patches))


def _links_by_patch(joins):
    """``{patch: [(side, other patch, other side, reversed)]}`` both ways."""
    out = {}
    for join in joins:
        out.setdefault(join.a, []).append((join.side_a, join.b, join.side_b, join.reversed))
        out.setdefault(join.b, []).append((join.side_b, join.a, join.side_a, join.reversed))
    return out


def _neighbour_placement(placement, direction, other, other_side, reversed_):
    """The placement of ``other`` in the cell at ``direction`` of ``placement``'s cell,
    joined along ``other_side``."""
    forward = placement.side(direction)[1] != reversed_
    wanted = (other_side, forward)
    for orientation in ORIENTATIONS:
        candidate = Placement(other, *orientation)
        if candidate.side(OPPOSITE[direction]) == wanted:
            return candidate
    raise AssertionError("every side and along-direction has one placement")


def _walk(seed, links, placed):
    """Breadth-first placement of the patches reachable from ``seed``:
    ``{(x, y): Placement}``; ``placed`` collects every patch placed.  A patch that
    would land on an occupied cell is left for a later walk."""
    cells, queue = {(0, 0): Placement(seed)}, deque([((0, 0), Placement(seed))])
    placed[seed] = (0, 0)
    while queue:
        (x, y), placement = queue.popleft()
        for direction, (dx, dy) in STEPS.items():
            side = placement.side(direction)[0]
            for own, other, other_side, reversed_ in links.get(placement.patch, ()):
                cell = (x + dx, y + dy)
                if own != side or other in placed or cell in cells:
                    continue
                neighbour = _neighbour_placement(placement, direction, other, other_side,
                                                 reversed_)
                cells[cell], placed[other] = neighbour, cell
                queue.append((cell, neighbour))
    return cells


def _joined_pairs(cells, links, surfaces):
    """The neighbouring cell pairs ``((x, y), (x + 1, y))`` and ``((x, y), (x, y + 1))``
    whose patches are joined as their placements say and could be merged there."""
    where = {placement.patch: cell for cell, placement in cells.items()}
    pairs = set()
    for cell, placement in cells.items():
        for direction in "EN":
            step = STEPS[direction]
            next_cell = (cell[0] + step[0], cell[1] + step[1])
            other = cells.get(next_cell)
            if other is None:
                continue
            side, forward = placement.side(direction)
            other_side, other_forward = other.side(OPPOSITE[direction])
            for own, patch, patch_side, reversed_ in links.get(placement.patch, ()):
                if (own == side and patch == other.patch and patch_side == other_side
                        and (forward != other_forward) == reversed_
                        and where.get(patch) == next_cell
                        and _mergeable(surfaces, placement, other, direction)):
                    pairs.add((cell, next_cell))
    return pairs


def _mergeable(surfaces, placement, other, direction):
    """Equal degrees, and the same normalised knots along the shared side, in grid
    orientation."""
    a = placement.to_grid(surfaces[placement.patch])
    b = other.to_grid(surfaces[other.patch])
    if (a.u_degree, a.v_degree) != (b.u_degree, b.v_degree) or a.poles.shape[-1] != b.poles.shape[-1]:
        return False
    ka, kb = (a.v_knots, b.v_knots) if direction == "E" else (a.u_knots, b.u_knots)
    return ka.size == kb.size and np.abs(_unit(ka) - _unit(kb)).max() <= KNOT_TOLERANCE


def _unit(knots):
    return (knots - knots[0]) / (knots[-1] - knots[0])


def _rectangles(cells, pairs, min_patches):
    """Greedy cover of ``cells`` by the largest joined rectangles."""
    free, blocks = dict(cells), []
    while True:
        best = _largest_rectangle(free, pairs)
        if best is None:
            return blocks
        (x0, y0), (x1, y1) = best
        if (x1 - x0 + 1) * (y1 - y0 + 1) < min_patches:
            return blocks
        blocks.append(GridBlock(tuple(tuple(free[(x, y)] for y in range(y0, y1 + 1))
                                      for x in range(x0, x1 + 1))))
        for x in range(x0, x1 + 1):
            for y in range(y0, y1 + 1):
                del free[(x, y)]


def _largest_rectangle(free, pairs):
    """Corners ``((x0, y0), (x1, y1))`` of the largest rectangle of free cells whose
    inner neighbour pairs are all joined; ``None`` when no cell is free."""
    best, best_area = None, 0
    for (x0, y0) in sorted(free):
        top = _column_run(free, pairs, x0, y0)
        x1 = x0
        while top >= y0:
            area = (x1 - x0 + 1) * (top - y0 + 1)
            if area > best_area:
                best, best_area = ((x0, y0), (x1, top)), area
            following = _column_run(free, pairs, x1 + 1, y0)
            top = min(top, following, _row_run(pairs, x1, y0, top))
            x1 += 1
    return best


def _column_run(free, pairs, x, y0):
    """Highest ``y`` such that cells ``(x, y0 .. y)`` are free and joined in y; ``y0 - 1``
    when ``(x, y0)`` is not free."""
    y = y0 - 1
    while (x, y + 1) in free and (y < y0 or ((x, y), (x, y + 1)) in pairs):
        y += 1
    return y


def _row_run(pairs, x, y0, top):
    """Highest ``y <= top`` such that cells ``(x, y)`` and ``(x + 1, y)`` are joined for
    all of ``y0 .. y``."""
    y = y0 - 1
    while y < top and ((x, y + 1), (x + 1, y + 1)) in pairs:
        y += 1
    return y
