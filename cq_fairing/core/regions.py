r"""Where a trimmed face lies on a parameter grid: its trim polygon, and exact answers near it.

A trimmed face uses the part of its surface's parameter domain that its boundary
curves (p-curves) enclose.  The deviation of a faired face counts there only
(:class:`~cq_fairing.core.measures.SurfaceProbe`'s ``region``), and asking a CAD kernel
about every sample of a dense grid costs microseconds each.  :class:`TrimRegion`
classifies a whole grid at once:

* the trim loops come as polylines through points of the p-curves, within ``accuracy``
  of them;
* every grid row :math:`v = v_j` is cut with the polyline segments (half-open in
  :math:`v`, so a vertex on the row counts once), and a sample :math:`(u_i, v_j)` is
  inside when an odd number of crossings lies left of :math:`u_i` (the even-odd rule;
  holes and the orientation of the loops need nothing more);
* a sample within ``accuracy`` of the polyline may lie on the other side of the true
  curve, so the samples near the polyline are given to the ``exact`` classifier (the
  kernel's own): the segments are walked in steps :math:`h` (the larger of
  ``accuracy`` and a quarter of the grid's median spacing, or longer when the polyline
  would need more than ``MAX_WALK_POINTS`` of them), and every grid
  node in the box of half-width ``accuracy`` :math:`+ h/2` around a walked point is
  marked.  A node within ``accuracy`` of a segment is within :math:`h/2` more of a
  walked point, hence marked; a node farther than ``accuracy`` from every segment is
  on the same side of the polyline as of the true curve, which lies within
  ``accuracy`` of it.

The answer is then exactly the classifier's wherever the polygon could be wrong, at
the cost of one classifier call per sample along the trim instead of one per sample.
"""

import numpy as np

from ..errors import InvalidInputError

__all__ = ["TrimRegion"]

MAX_WALK_POINTS = 100_000  # points walked along the polygon, at most about


class TrimRegion:
    """``region(u, v)`` of a trimmed face: even-odd on its trim polygon, exact near it.

    Parameters
    ----------
    loops : list of (k, 2) array_like
        Closed polylines of the trim in parameter space (outer boundary and holes, any
        orientation; the last point joins the first), within ``accuracy`` of the true
        boundary curves.
    exact : callable
        ``exact(u, v) -> bool array (n,)`` for parameter points ``(u[k], v[k])``: the
        face's own classification (on the boundary counts as inside), asked only for
        samples near the polylines.
    accuracy : float
        Largest distance between the polylines and the curves they sample, ``>= 0``.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    >>> disc = TrimRegion([np.c_[np.cos(t), np.sin(t)]],
    ...                   lambda u, v: u ** 2 + v ** 2 <= 1.0, accuracy=1e-4)
    >>> disc(np.linspace(-1, 1, 5), np.array([0.0])).ravel().tolist()
    [True, True, True, True, True]
    """

    def __init__(self, loops, exact, accuracy):
        if not callable(exact):
            raise InvalidInputError(
                f"exact must be a callable exact(u, v) -> booleans, got {type(exact).__name__}.")
        if not np.isfinite(accuracy) or accuracy < 0:
            raise InvalidInputError(
                f"accuracy must be a finite distance >= 0, got {accuracy!r}.")
        self.segments = _segments(loops)
        self.exact = exact
        self.accuracy = float(accuracy)

    def __call__(self, u, v):
        """Booleans of shape (len(u), len(v)): which samples ``(u_i, v_j)`` lie on the face."""
        u, v = _grid_axis(u, "u"), _grid_axis(v, "v")
        inside = _even_odd(self.segments, u, v)
        near = _near_nodes(self.segments, u, v, self.accuracy)
        i, j = np.nonzero(near)
        if i.size:
            inside[i, j] = np.asarray(self.exact(u[i], v[j]), dtype=bool)
        return inside


def _segments(loops):
    """All polyline segments as an array (s, 2, 2): [start, end] x [u, v]."""
    pieces = []
    for loop in loops:
        points = np.asarray(loop, dtype=float)
        if points.ndim != 2 or points.shape[1] != 2 or points.shape[0] < 2 \
                or not np.isfinite(points).all():
            raise InvalidInputError(
                "each trim loop must be a finite (k, 2) array of (u, v) points with k >= 2, "
                f"got shape {points.shape}; pass the discretised p-curves of one wire.")
        pieces.append(np.stack([points, np.roll(points, -1, axis=0)], axis=1))
    if not pieces:
        raise InvalidInputError("a trim region needs at least one loop, got none.")
    return np.concatenate(pieces)


def _grid_axis(x, name):
    x = np.asarray(x, dtype=float)
    if x.ndim != 1 or x.size == 0 or np.any(np.diff(x) <= 0):
        raise InvalidInputError(
            f"{name} must be a non-empty increasing 1-D array of grid parameters, got "
            f"shape {x.shape}.")
    return x


def _even_odd(segments, u, v):
    """Even-odd rule on the grid: crossings of each row left of each sample."""
    (u0, v0), (u1, v1) = segments[:, 0].T, segments[:, 1].T
    inside = np.zeros((u.size, v.size), dtype=bool)
    for j, row in enumerate(v):
        cut = (v0 <= row) != (v1 <= row)           # half-open in v: a vertex counts once
        if not cut.any():
            continue
        t = (row - v0[cut]) / (v1[cut] - v0[cut])
        crossings = np.sort(u0[cut] + t * (u1[cut] - u0[cut]))
        inside[:, j] = np.searchsorted(crossings, u, side="left") % 2 == 1
    return inside


def _near_nodes(segments, u, v, accuracy):
    """Grid nodes that may lie within ``accuracy`` of a segment (see the module notes)."""
    start, end = segments[:, 0], segments[:, 1]
    lengths = np.linalg.norm(end - start, axis=1)
    spacing = min(np.median(np.diff(x)) if x.size > 1 else np.inf for x in (u, v))
    step = max(accuracy, 0.25 * spacing if np.isfinite(spacing) else 0.0,
               lengths.sum() / MAX_WALK_POINTS, 1e-300)
    points = _walk(start, end, np.ceil(lengths / step).astype(int) + 1)
    reach = accuracy + 0.5 * step
    lo_u, hi_u = np.searchsorted(u, points[:, 0] - reach), np.searchsorted(u, points[:, 0] + reach, "right")
    lo_v, hi_v = np.searchsorted(v, points[:, 1] - reach), np.searchsorted(v, points[:, 1] + reach, "right")
    rows, cols = hi_u - lo_u, hi_v - lo_v
    count = rows * cols                       # nodes in each walked point's box
    box = np.repeat(np.arange(count.size), count)
    offset = np.arange(box.size) - np.repeat(np.cumsum(count) - count, count)
    near = np.zeros((u.size, v.size), dtype=bool)
    near[lo_u[box] + offset // cols[box], lo_v[box] + offset % cols[box]] = True
    return near


def _walk(start, end, steps):
    """Points along each segment ``k``: ``steps[k] + 1`` equally spaced, both ends included."""
    owner = np.repeat(np.arange(start.shape[0]), steps + 1)
    first = np.repeat(np.cumsum(steps + 1) - (steps + 1), steps + 1)
    fraction = (np.arange(owner.size) - first) / steps[owner]
    return start[owner] + fraction[:, None] * (end[owner] - start[owner])
