r"""Deviation probes: a source sampled once, measured against many candidates.

A :class:`CurveProbe` or :class:`SurfaceProbe` keeps the source's dense samples and
derivatives, bounds each candidate's deviation by the same-parameter distance and
computes the true (closest-point) distance only where that bound exceeds the running
maximum or the tolerance (:mod:`cq_fairing.core.deviations`).
"""


import numpy as np
from scipy.spatial import cKDTree

from ..errors import InvalidInputError
from .closest_points import _closest_from_starts, _distance, closest_points_surface, distance_floor
from .evaluation import _derivatives_in_domain, curve_derivatives, sample_parameters, within_box
from .geometry import grid_product
from .spaces import clamp

DEVIATIONS = ("geometric", "parametric")


BLOCK_SAMPLES = 65_536  # grid samples per block of rows when a probe does not hold its grid


COLLOCATIONS = 128     # collocation matrices a probe keeps (per target space and axis)


REFUTERS = 2           # samples of largest bound a curve probe's refutation looks at


FIRST_BATCH = 256      # samples of largest bound a BoundWalk hands out first


ROUNDING = 1e-12       # share of the extent by which two evaluation routes may differ


# -- probes: cached source samples, fast maxima --------------------------------------------------
class CurveProbe:
    """Dense samples of a source curve, reused to measure many faired candidates.

    Parameters
    ----------
    source : BSplineCurve
    per_span : int
        Samples per span of the merged breakpoints of the source and each candidate.
    method : {"geometric", "parametric"}
    u : ndarray, optional
        Explicit, fixed sample parameters (overrides ``per_span``).
    """

    def __init__(self, source, per_span=8, method="geometric", u=None):
        _check_method(method)
        self.source = source
        self.method = method
        self.per_span = per_span
        self._fixed = u is not None
        self._set_samples(sample_parameters(source.space, per_span=per_span) if u is None else u)

    def _set_samples(self, u):
        self.u = u
        self.points = curve_derivatives(self.source, u, 0)[0]
        self._tree = None

    def _adapt(self, faired):
        """Use ``per_span`` samples per span of the merged breakpoints of both curves."""
        if self._fixed:
            return
        u = sample_parameters(self.source.space, faired.space, per_span=self.per_span)
        if u.size != self.u.size or not np.array_equal(u, self.u):
            self._set_samples(u)

    @property
    def tree(self):
        if self._tree is None:
            self._tree = cKDTree(self.points)
        return self._tree

    def bound(self, faired):
        """Faired points and the same-parameter distance at every sample."""
        other = curve_derivatives(faired, self.u, 0)[0]
        return other, _distance(other, self.points)

    def true_distance(self, faired, other, idx, tol=None, verdict=False):
        """Two-sided true distance at samples ``idx`` (max of both directions).

        With ``tol``, extra Newton starts are only tried where the first exceeds ``tol``,
        and values ``<= tol`` are upper bounds (the iterations stop there).  With
        ``verdict`` (and ``tol``) the distance from the faired points back to the source
        is only measured where the source's distance to the faired curve is within
        ``tol`` (as :meth:`SurfaceProbe.true_distance`): a value above ``tol`` is then
        one direction's, enough to refuse the candidate.
        """
        if idx.size == 0:
            return np.zeros(0)
        d_fs = _closest_from_starts(faired, self.points[idx], self.u, lambda: cKDTree(other),
                                    self.u[idx], tol=tol)
        if not verdict:
            return np.maximum(d_fs, self._to_source(other, idx, tol))
        back = d_fs <= tol
        if back.any():
            d_fs[back] = np.maximum(d_fs[back], self._to_source(other, idx[back], tol))
        return d_fs

    def _to_source(self, other, idx, tol):
        """Distance from the faired points ``other[idx]`` to the source."""
        return _closest_from_starts(self.source, other[idx], self.u, lambda: self.tree,
                                    self.u[idx], tol=tol)

    def refutes(self, faired, other, bound, tol, leaders=REFUTERS):
        """Whether ``faired`` provably deviates by more than ``tol`` (no Newton iteration).

        The :func:`distance_floor` of ``faired`` from one of the ``leaders`` source
        samples of largest ``bound`` (above ``tol``) exceeds ``tol`` by more than
        rounding (``1e-9`` of the curve's size).  The true distance there, which
        :meth:`true_distance` can only over-estimate, then exceeds ``tol`` too: a
        tolerance check refuses ``faired`` either way.  ``False`` for a rational
        ``faired`` or samples that do not end at its domain's ends.

        Parameters
        ----------
        faired : BSplineCurve
        other, bound : ndarray
            ``faired``'s points and the same-parameter distances (:meth:`bound`).
        tol : float
        leaders : int
        """
        lo, hi = faired.domain
        if faired.is_rational or self.u[0] != lo or self.u[-1] != hi:
            return False
        first = bound.size - min(leaders, bound.size)
        idx = np.argpartition(bound, first)[first:]
        idx = idx[bound[idx] > tol]
        if idx.size == 0:
            return False
        floor = distance_floor(faired, self.u, other, self.points[idx])
        return bool(floor.max() > tol + 1e-9 * faired.size)

    def max_deviation(self, faired, tol=None):
        """Largest deviation (dense samples); with ``tol`` stop once it is exceeded.

        Returns
        -------
        value : float
            The maximum; with ``tol`` and a miss, a value ``> tol`` that is a lower bound.
        index : int
            Sample index where it occurs.
        """
        self._adapt(faired)
        other, bound = self.bound(faired)
        bound = _FlatBound(bound)
        if self.method == "parametric":
            return bound.argmax()
        return _pruned_max(bound, lambda idx, below: self.true_distance(faired, other, idx, below),
                           tol)


def box_region(box):
    """The ``region`` of a parameter box ``(u0, u1, v0, v1)``: the samples inside it,
    its borders included."""
    u0, u1, v0, v1 = box
    return lambda u, v: np.outer((u >= u0) & (u <= u1), (v >= v0) & (v <= v1))


def _region_mask(region, u, v):
    """``region(u, v)`` checked: a boolean array of shape (len(u), len(v))."""
    mask = np.asarray(region(u, v))
    if mask.shape != (u.size, v.size) or mask.dtype != bool:
        raise InvalidInputError(
            f"region(u, v) must return a boolean array of shape ({u.size}, {v.size}) "
            f"(one flag per sample), got {mask.dtype} of shape {mask.shape}; fix the "
            "region callable.")
    return mask


class SurfaceProbe:
    """Dense grid samples of a source surface, reused to measure many candidates.

    Parameters
    ----------
    source : BSplineSurface
    per_span : int
    method : {"geometric", "parametric"}
    uv : (ndarray, ndarray), optional
        Explicit grid axes (override ``per_span``).
    keep_feet : bool
        Keep each sample's last foot parameters, the Newton starts of the next candidate
        (a search that measures many nearby candidates on the same grid).
    bounds : ((u0, u1), (v0, v1)), optional
        Parameter box of both geometries that the foot points stay in (a face's UV box,
        with ``uv`` sampled inside it); default the source's whole domain.
    region : callable, optional
        ``region(u, v) -> bool array (len(u), len(v))``: the samples whose deviation
        counts (a trimmed face's domain); the others count as 0, so a candidate is
        measured, and its error spread, only where the face is.  Default: everywhere.
    hold_grid : bool
        Keep the source's grid points and each candidate's in full (the adaptive search's
        probe, capped at 400k samples, whose path depends on the rounding of those
        grids).  Without, a measurement walks the grid in blocks of rows and evaluates
        points only where the exact distance is needed (:class:`_LazyGrid`): a check of
        a million-sample grid then holds a few MB instead of about 90, and the uniform
        search on the 400 x 400 blade (10 million samples per check) peaks at 214 MB
        instead of 1151 MB.
    """

    def __init__(self, source, per_span=8, method="geometric", uv=None, keep_feet=False,
                 hold_grid=True, bounds=None, region=None):
        _check_method(method)
        self.source = source
        self.bounds = bounds
        self.region = region
        self.method = method
        self.per_span = per_span
        self.keep_feet = keep_feet
        self.hold_grid = hold_grid
        self._prior = None
        self._fixed = uv is not None
        if uv is None:
            uv = within_box(sample_parameters(source.u_space, per_span=per_span),
                            sample_parameters(source.v_space, per_span=per_span), bounds)
        self._set_samples(*uv)

    def _set_samples(self, u, v):
        self.u, self.v = u, v
        self.points = (self.source.evaluate_grid(u, v) if self.hold_grid
                       else _LazyGrid(self.source, u, v))
        self._half_step = (0.5 * np.gradient(u), 0.5 * np.gradient(v))
        self._outside = None if self.region is None else ~_region_mask(self.region, u, v)
        self._feet = {}
        self._prior_cells = None
        self._source_blocks = None
        self._collocations = {}
        self._strided = {}

    def _keep(self, key, i, j, u, v):
        """Remember the feet ``(u, v)`` of samples ``(i, j)`` on the ``"source"`` or on
        the ``"faired"`` geometry (``keep_feet`` only; the grid's own parameters elsewhere)."""
        if not self.keep_feet:
            return
        if key not in self._feet:
            self._feet[key] = np.stack(np.meshgrid(self.u, self.v, indexing="ij"), axis=-1)
        feet = self._feet[key]
        feet.reshape(-1, 2)[i * feet.shape[1] + j] = np.stack([u, v], axis=-1)

    def _last_feet(self, key, i, j):
        """Foot parameters last found at samples ``(i, j)``: this probe's own, else those
        of an adopted probe (:meth:`adopt_feet`) interpolated bilinearly; ``None`` if
        neither.  Successive candidates of a search differ little, so their feet are
        Newton starts that converge at once even where a candidate slides along the
        source (its same-parameter point is far from the foot)."""
        if key in self._feet:
            feet = _at(self._feet[key], i, j)
            return feet[:, 0], feet[:, 1]
        prior = self._prior
        if prior is not None and key in prior._feet:
            if self._prior_cells is None:
                self._prior_cells = (_cell(prior.u, self.u), _cell(prior.v, self.v))
            (a, wa), (b, wb) = self._prior_cells
            return _bilinear(prior._feet[key], (a[i], wa[i]), (b[j], wb[j]))
        return None

    def _adapt(self, faired):
        """Use ``per_span`` samples per span of the merged breakpoints, per direction."""
        if self._fixed:
            return
        u, v = within_box(
            sample_parameters(self.source.u_space, faired.u_space, per_span=self.per_span),
            sample_parameters(self.source.v_space, faired.v_space, per_span=self.per_span),
            self.bounds)
        if (u.size, v.size) != (self.u.size, self.v.size) or not (
                np.array_equal(u, self.u) and np.array_equal(v, self.v)):
            self._set_samples(u, v)

    def adopt_feet(self, other):
        """Start from the feet that ``other`` (a probe of the same source on another grid)
        found last, interpolated bilinearly at each sample when it is measured: a dense
        check after a search on a coarser grid.  ``other``'s grid is fixed (explicit
        ``uv``): the cells of its grid that hold this grid's samples are found once."""
        self._prior, self._prior_cells = other, None

    def bound(self, faired):
        """Faired points on the grid (a :class:`_LazyGrid` without ``hold_grid``) and the
        same-parameter distance at every sample, shape (len(u), len(v)); 0 outside the
        ``region``, whose samples are then never measured further."""
        if not self.hold_grid:
            blocks = self._bound_blocks(faired)
            return _LazyGrid(faired, self.u, self.v), np.concatenate(
                [blocks.block(b) for b in range(blocks.n_blocks)])
        other = self._grid_of(faired)
        bound = _distance(other, self.points)
        if self._outside is not None:
            bound[self._outside] = 0.0
        return other, bound

    def _grid_of(self, faired):
        """``faired.evaluate_grid(u, v)``, the same values, with the collocation matrices
        kept per space (at most ``COLLOCATIONS``): the adaptive search measures about
        three candidates per distinct target space."""
        if faired.is_rational:
            return faired.evaluate_grid(self.u, self.v)
        return grid_product(self._collocation(0, faired.u_space),
                            self._collocation(1, faired.v_space), faired.poles)

    def _collocation(self, axis, space):
        """Collocation matrix of ``space`` at this grid's ``axis`` parameters, kept."""
        key = (axis, space.key)
        if key not in self._collocations:
            if len(self._collocations) >= COLLOCATIONS:
                self._collocations.clear()
            self._collocations[key] = space.collocation((self.u, self.v)[axis])
        return self._collocations[key]

    def _bound_blocks(self, faired):
        """:class:`_BoundBlocks` of ``faired`` on this grid, about ``BLOCK_SAMPLES`` per
        block."""
        step = max(1, BLOCK_SAMPLES // self.v.size)
        if self._source_blocks is None or self._source_blocks.step != step:
            self._source_blocks = self.source.grid_blocks(self.u, self.v, step)
        return _BoundBlocks(self._source_blocks, faired.grid_blocks(self.u, self.v, step),
                            self._outside)

    def true_distance(self, faired, other, flat_idx, window=2, tol=None, verdict=False):
        """Two-sided true distance at flat grid indices ``flat_idx``.

        With ``tol``, the second Newton start is only tried where the first exceeds
        ``tol``, and values ``<= tol`` are upper bounds (the iterations stop there).
        With ``verdict`` (and ``tol``) the distance from the faired points back to the
        source is only measured where the source's distance to the faired surface is
        within ``tol``: a value above ``tol`` is then one direction's, enough to refuse
        the candidate.
        """
        if flat_idx.size == 0:
            return np.zeros(0)
        if self._outside is not None and self._outside.ravel()[flat_idx].any():
            return self._inside_only(faired, other, flat_idx, window, tol, verdict)
        i, j = np.unravel_index(flat_idx, self.points.shape[:2])
        source_points, faired_points = _at(self.points, i, j), _at(other, i, j)
        same = _distance(faired_points, source_points)
        d_fs = self._one_way(faired, self.points, other, i, j, source_points, same, window,
                             tol)
        if not verdict:
            return np.maximum(d_fs, self._one_way(self.source, other, self.points, i, j,
                                                  faired_points, same, window, tol))
        back = d_fs <= tol
        if back.any():
            d_fs[back] = np.maximum(d_fs[back], self._one_way(
                self.source, other, self.points, i[back], j[back], faired_points[back],
                same[back], window, tol))
        return d_fs

    def _inside_only(self, faired, other, flat_idx, window, tol, verdict):
        """:meth:`true_distance` with 0 at the samples outside the ``region``, which count
        as 0 everywhere (a maximum that asks for the largest bound of every row, as
        ``_pruned_max`` does on a grid of at most 64 rows, asks for rows wholly outside
        too)."""
        inside = ~self._outside.ravel()[flat_idx]
        distance = np.zeros(flat_idx.size)
        distance[inside] = self.true_distance(faired, other, flat_idx[inside], window, tol,
                                              verdict)
        return distance

    def _one_way(self, target, here, there, i, j, p, same, window, tol=None):
        """Distance from the points ``p = here[i, j]`` to ``target`` (sampled as ``there``
        on the grid), whose same-parameter distances ``|there[i, j] - p|`` are ``same``.

        A sample whose same-parameter distance is within ``tol`` needs no search.  Newton
        starts from the same parameter, or from the last foot (:meth:`_last_feet`) where
        that lies more than half a sample spacing away (the candidate slides along the
        source); where the result stays above ``tol`` it starts again from the nearest
        ``there`` sample within ``window`` (with ``tol`` and ``window`` 0, it does not).

        Without ``hold_grid`` the grid's points come from the evaluation Newton starts
        with, so ``same`` is the distance at a start on the same parameter, bit for bit,
        and Newton skips that evaluation.  A held grid is evaluated otherwise (a grid
        product), which may round the last bit differently, and a search's later
        candidates start from the feet this one leaves: Newton evaluates its starts.
        """
        key = "source" if target is self.source else "faired"
        u0, v0 = self.u[i], self.v[j]
        start = same.copy() if not self.hold_grid else np.full(same.size, np.nan)
        last = self._last_feet(key, i, j)
        if last is not None:
            lu, lv = last
            slid = (np.abs(lu - u0) > self._half_step[0][i]) | \
                (np.abs(lv - v0) > self._half_step[1][j])
            u0, v0 = np.where(slid, lu, u0), np.where(slid, lv, v0)
            start[slid] = np.nan
        if tol is None:
            u0, v0, d = self._from_both_starts(target, here, there, p, i, j, u0, v0, start,
                                               window)
            self._keep(key, i, j, u0, v0)
            return d
        d = same.copy()
        todo = np.flatnonzero(d > tol)
        if todo.size:
            u0[todo], v0[todo], d[todo] = closest_points_surface(
                target, p[todo], u0[todo], v0[todo], stop_below=tol, bounds=self.bounds,
                start_distance=start[todo])
            todo = todo[d[todo] > tol]
        if todo.size and window:
            wu, wv = _window_start(here, there, i[todo], j[todo], self.u, self.v, window)
            fu, fv, fd = closest_points_surface(target, p[todo], wu, wv, stop_below=tol,
                                                bounds=self.bounds)
            better = fd < d[todo]
            k = todo[better]
            u0[k], v0[k], d[k] = fu[better], fv[better], fd[better]
        self._keep(key, i, j, u0, v0)
        return d

    def _from_both_starts(self, target, here, there, p, i, j, u0, v0, start, window):
        """Feet and distances of ``p`` on ``target`` from both starts (``(u0, v0)``, whose
        distances ``start`` are known where not NaN, and the nearest ``there`` sample
        within ``window``), the smaller distance kept (the first start's on ties).  One
        Newton run over both sets of starts: each point iterates on its own, so the
        values are those of two runs (to rounding: the vector kernels may round a point's
        last bit differently in another batch), in half the vector operations' calls
        (which is what a few hundred points cost)."""
        wu, wv = _window_start(here, there, i, j, self.u, self.v, window)
        n = p.shape[0]
        fu, fv, fd = closest_points_surface(target, np.concatenate([p, p]),
                                            np.concatenate([u0, wu]), np.concatenate([v0, wv]),
                                            bounds=self.bounds,
                                            start_distance=np.concatenate(
                                                [start, np.full(n, np.nan)]))
        pick = np.where(fd[n:] < fd[:n], np.arange(n, 2 * n), np.arange(n))
        return fu[pick], fv[pick], fd[pick]

    def max_deviation(self, faired, tol=None, stride=4):
        """As :meth:`CurveProbe.max_deviation`; the index is flat over the grid.

        With ``tol``, every ``stride``-th sample per direction is checked first: a miss
        there is a miss of the dense grid (same samples), found at 1/stride^2 the cost.
        """
        if tol is not None and stride > 1 and min(self.points.shape[:2]) > 4 * stride:
            self._adapt(faired)
            sub = self._strided_probe(stride)
            value, k = sub.max_deviation(faired, tol, stride=1)
            if value > tol:
                i, j = np.unravel_index(k, sub.points.shape[:2])
                return value, int(np.ravel_multi_index((i * stride, j * stride),
                                                       self.points.shape[:2]))
        self._adapt(faired)
        if self.hold_grid:
            other, bound = self.bound(faired)
            bound = _FlatBound(bound.ravel())
        else:
            other = _LazyGrid(faired, self.u, self.v)
            bound = _RowBound(self._bound_blocks(faired), self.v.size,
                              None if self.method == "parametric" else tol)
        if self.method == "parametric":
            return bound.argmax()
        return _pruned_max(bound, lambda idx, below: self.true_distance(faired, other, idx,
                                                                         tol=below), tol)

    def _strided_probe(self, stride):
        """The probe of every ``stride``-th sample per direction, made once per grid: its
        source points, region mask and collocation matrices serve every candidate (it
        keeps no feet, so each measurement is that of a new probe)."""
        if stride not in self._strided:
            self._strided[stride] = SurfaceProbe(
                self.source, method=self.method, uv=(self.u[::stride], self.v[::stride]),
                region=self.region)
        return self._strided[stride]


class _LazyGrid:
    """The points of ``surface`` on the grid ``u x v``, evaluated only where indexed:
    ``grid[i, j]`` with index arrays gives shape (len(i), d).  A tolerance check needs
    the exact distance at a few hundred of a million samples (and their neighbours)."""

    def __init__(self, surface, u, v):
        self.surface, self.u, self.v = surface, u, v
        self.shape = (u.size, v.size, surface.poles.shape[-1])

    def __getitem__(self, index):
        i, j = index
        return _derivatives_in_domain(self.surface, self.u[i], self.v[j], 0)[(0, 0)]


class _FlatBound:
    """The same-parameter bound of every sample, held in full (flat sample index)."""

    def __init__(self, values):
        self.values = values
        self.size = values.size

    def argmax(self):
        """``(largest bound, its flat index)``, the first one on ties."""
        k = int(np.argmax(self.values))
        return float(self.values[k]), k

    def leaders(self, k):
        """Flat indices of ``k`` samples of large bound: here the ``k`` largest (any
        ``k`` of them on ties)."""
        return np.argpartition(self.values, -k)[-k:]

    def above(self, threshold):
        """``(flat indices, bounds)`` of the samples whose bound exceeds ``threshold``,
        indices ascending."""
        idx = np.flatnonzero(self.values > threshold)
        return idx, self.values[idx]


class _BoundBlocks:
    """The same-parameter distance of a faired surface from its source on a grid, a block
    of rows at a time (two :class:`~cq_fairing.core.geometry.GridBlocks` with the same
    grid and ``step``)."""

    def __init__(self, source, faired, outside=None):
        self._source, self._faired, self._outside = source, faired, outside
        self.step, self.n_blocks, self.n_u = source.step, source.n_blocks, source.n_u
        self.rows_of = source.rows_of

    def block(self, b):
        """Shape (rows of block ``b``, n_v); 0 at the samples ``outside`` the region."""
        distance = _distance(self._faired.block(b), self._source.block(b))
        if self._outside is not None:
            distance[self._outside[self.rows_of(b)]] = 0.0
        return distance


class _RowBound:
    """The same-parameter bound on a grid, held as each row's maximum only.

    One pass over the blocks of rows keeps the maximum of each row and where it sits,
    and with ``tol`` the samples above ``tol`` (those a tolerance check can ask for).
    Any other samples asked for are recomputed with their whole blocks, which give the
    same values bit for bit (:class:`~cq_fairing.core.geometry.GridBlocks`).  A final
    check then holds no grid-sized array and runs no partition over one (85 MB and
    10.7 million samples on the terrain; the 400 x 400 blade's uniform search peaks at
    147 MB instead of 225 MB).

    Parameters
    ----------
    blocks : _BoundBlocks
    n_v : int
        Samples per row.
    tol : float or None
    """

    def __init__(self, blocks, n_v, tol):
        self._blocks, self._n_v, self._tol = blocks, n_v, tol
        n_u = blocks.n_u
        self.size = n_u * n_v
        self.row_max, self._row_arg = np.empty(n_u), np.empty(n_u, dtype=np.intp)
        kept = []
        for b in range(blocks.n_blocks):
            rows = blocks.rows_of(b)
            block = blocks.block(b)
            self._row_arg[rows] = np.argmax(block, axis=1)
            self.row_max[rows] = block[np.arange(block.shape[0]), self._row_arg[rows]]
            if tol is not None:
                kept.append(self._flat_above(np.arange(rows.start, rows.stop), block, tol))
        if tol is not None:
            self._kept = tuple(np.concatenate(part) for part in zip(*kept))

    def _flat_above(self, index, block, threshold):
        i, j = np.nonzero(block > threshold)
        return index[i] * self._n_v + j, block[i, j]

    def argmax(self):
        i = int(np.argmax(self.row_max))
        return float(self.row_max[i]), i * self._n_v + int(self._row_arg[i])

    def leaders(self, k):
        """Flat indices of the largest bound of each of the ``k`` rows of largest maximum
        (all rows if fewer): the largest bound is among them, and no row is recomputed."""
        rows = np.argpartition(self.row_max, -min(k, self.row_max.size))[-k:]
        return rows * self._n_v + self._row_arg[rows]

    def above(self, threshold):
        if self._tol is not None and threshold >= self._tol:
            idx, values = self._kept
            keep = values > threshold
            return idx[keep], values[keep]
        return self._recomputed(np.flatnonzero(self.row_max > threshold), threshold)

    def _recomputed(self, rows, threshold):
        """``(flat indices, bounds)`` above ``threshold`` on ``rows`` (ascending), each
        recomputed with its block."""
        parts = []
        for b in np.unique(rows // self._blocks.step):
            start = self._blocks.rows_of(b).start
            picked = rows[rows // self._blocks.step == b]
            parts.append(self._flat_above(picked, self._blocks.block(b)[picked - start],
                                          threshold))
        if not parts:
            return np.zeros(0, dtype=np.intp), np.zeros(0)
        return tuple(np.concatenate(part) for part in zip(*parts))


class BoundWalk:
    r"""Samples in decreasing order of an upper bound of their values, handed out in
    doubling batches: the walk behind a maximum measured only where it can be reached.

    Every sample passed over has a value at most its bound, so once :attr:`next_bound`
    is at most the largest value measured, the maximum over all samples is known
    without measuring the rest.

    Parameters
    ----------
    bound : ndarray, shape (q,)
        An upper bound of each sample's value.
    first : int, optional
        Size of the first batch (default ``FIRST_BATCH``); each next batch is twice the
        last.
    order : ndarray of int, optional
        ``np.argsort(bound)[::-1]`` if already at hand.
    """

    def __init__(self, bound, first=FIRST_BATCH, order=None):
        self.bound = bound
        self.order = np.argsort(bound)[::-1] if order is None else order
        self._start, self._batch = 0, first

    @property
    def next_bound(self):
        """The largest bound not yet handed out (``-inf`` once all are)."""
        if self._start >= self.order.size:
            return -np.inf
        return float(self.bound[self.order[self._start]])

    def take(self, floor=-np.inf):
        """The next batch of sample indices, in decreasing order of their bounds, cut
        before the first whose bound is at most ``floor`` (the caller's level: those
        cannot reach it)."""
        batch = self.order[self._start:self._start + self._batch]
        if floor > -np.inf:   # bounds sorted down (a NaN first would unsort them)
            batch = batch[:np.searchsorted(-self.bound[batch], -floor, side="left")]
        self._start += batch.size
        self._batch *= 2
        return batch

    def taken(self):
        """Every sample index handed out so far."""
        return self.order[:self._start]

    def rest(self):
        """Every sample index not handed out."""
        return self.order[self._start:]


def _pruned_max(bound, exact, tol):
    """Max of the true distance over all samples, computing it only where ``bound`` can win.

    ``bound`` (:class:`_FlatBound` or :class:`_RowBound`) is ``>= exact`` sample-wise.
    ``exact(idx, below)`` returns the true distance at samples ``idx`` where it exceeds
    ``below`` and an upper bound ``<= below`` elsewhere (its Newton iterations stop
    there); ``below=None`` asks for every value exactly.  Candidates (bound above the
    tolerance, or above the largest true distance at 64 samples of large bound,
    ``bound.leaders(64)``) are processed in
    decreasing order of the bound, in doubling batches, each with ``below`` the running
    maximum (a sample that cannot beat it needs no exact value), until the next bound
    cannot beat the running maximum.  Without ``tol`` the exact maximum is returned.
    With ``tol`` the search also stops as soon as the maximum exceeds ``tol`` (the value
    returned is then an exact sample distance ``> tol``, a lower bound of the maximum)
    or once no remaining bound exceeds ``tol`` (the value returned is then an upper
    bound ``<= tol``).
    """
    best, best_i = -1.0, bound.argmax()[1]
    if tol is not None:
        candidates, values = bound.above(tol)
        if candidates.size == 0:
            return bound.argmax()
    else:
        top = bound.leaders(min(64, bound.size))
        d = exact(top, None)
        k = int(np.argmax(d))
        best, best_i = float(d[k]), int(top[k])
        candidates, values = bound.above(best)
        keep = ~np.isin(candidates, top)
        candidates, values = candidates[keep], values[keep]
    walk = BoundWalk(values)
    while walk.next_bound > best:
        if tol is not None and walk.next_bound <= tol:
            return max(best, walk.next_bound), best_i
        idx = candidates[walk.take()]
        d = exact(idx, best if tol is None else max(best, tol))
        k = int(np.argmax(d))
        if d[k] > best:
            best, best_i = float(d[k]), int(idx[k])
        if tol is not None and best > tol:
            return best, best_i
    if tol is not None and best <= tol:
        rest = walk.next_bound if walk.rest().size else tol   # all measured: the others'
        return max(best, min(rest, tol)), best_i              # bounds are at most tol
    return best, best_i


def _check_method(method):
    if method not in DEVIATIONS:
        raise InvalidInputError(
            f"deviation must be one of {DEVIATIONS}, got {method!r}."
        )


def _bilinear(values, cell_x, cell_y):
    """Bilinear interpolation of a grid ``values`` (n_x, n_y, 2) at points given by their
    cells ``(k, weight)`` along x and along y (:func:`_cell`): two arrays (q,)."""
    (a, wa), (b, wb) = cell_x, cell_y
    wa, wb = wa[:, None], wb[:, None]
    out = ((1 - wa) * ((1 - wb) * _at(values, a, b) + wb * _at(values, a, b + 1))
           + wa * ((1 - wb) * _at(values, a + 1, b) + wb * _at(values, a + 1, b + 1)))
    return out[:, 0], out[:, 1]


def _cell(x, xq):
    """Index ``k`` of the cell ``[x_k, x_k+1]`` holding each ``xq`` and its weight there."""
    xq = np.clip(xq, x[0], x[-1])
    k = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
    return k, (xq - x[k]) / (x[k + 1] - x[k])


def _window_start(here, there, i, j, u, v, window=2):
    """Parameters of the nearest ``there`` sample within +-window of each (i, j) (the
    first of equals in row-major window order), all neighbours read in one indexing."""
    nu, nv = here.shape[:2]
    offsets = np.arange(-window, window + 1)
    ii = clamp(i[:, None, None] + offsets[None, :, None], 0, nu - 1)
    jj = clamp(j[:, None, None] + offsets[None, None, :], 0, nv - 1)
    ii, jj = (x.reshape(i.size, -1) for x in np.broadcast_arrays(ii, jj))
    near = _at(there, ii.ravel(), jj.ravel()).reshape(ii.shape + (-1,))
    k = np.argmin(np.linalg.norm(near - _at(here, i, j)[:, None, :], axis=2), axis=1)
    rows = np.arange(i.size)
    return u[ii[rows, k]], v[jj[rows, k]]


def _at(grid, i, j):
    """``grid[i, j]`` for index arrays ``i``, ``j``, shape (len(i), d): one ``take`` on
    the flattened grid when it is a C-contiguous array (a fifth of the time of indexing
    by two arrays), else the grid's own indexing (a :class:`_LazyGrid`)."""
    if isinstance(grid, np.ndarray) and grid.flags.c_contiguous:
        return grid.reshape(-1, grid.shape[-1]).take(i * grid.shape[1] + j, axis=0)
    return grid[i, j]
