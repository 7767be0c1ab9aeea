r"""A regular grid of B-spline patches as one surface, and back.

Patches :math:`S_{ij}` (:math:`0 \le i < m`, :math:`0 \le j < n`) of equal degrees
:math:`(p, q)` form a grid when :math:`S_{ij}` is followed in u by :math:`S_{i+1,j}` and in
v by :math:`S_{i,j+1}`, the patches of grid row :math:`i` share their u knots and those of
grid column :math:`j` their v knots (each up to an affine map), and neighbouring border
pole rows coincide.  Such a grid is one tensor-product B-spline surface whose knots at
the joins have multiplicity :math:`p` (in u) and :math:`q` (in v): a clamped knot vector
on :math:`[U_i, U_{i+1}]` followed by one on :math:`[U_{i+1}, U_{i+2}]` is, after merging
the two end knots into one knot of multiplicity :math:`p` and the two border pole rows
into one row, the knot vector of a spline that is exactly the two pieces (C0 in the
parameter, the same point set).

:func:`merge_grid` builds that surface (:class:`MergedGrid`); fairing it onto a coarser
quasi-uniform space (:func:`~cq_fairing.core.fairing.fair_surface`) gives a surface that
is smooth across the former joins.  :func:`split_grid` cuts any surface on the merged
domain back into patches by knot insertion (:func:`insert_knot`, Boehm's algorithm)
and maps every piece affinely onto its patch's original parameter domain.

This module imports numpy and scipy only.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from ..errors import InvalidInputError, InvalidToleranceError, UnsupportedGeometryError
from .geometry import BSplineSurface, extent
from .gram import gram_matrix, sandwiched
from .spaces import SplineSpace

__all__ = ["MergedGrid", "merge_grid", "split_grid", "cut_surface", "join_pieces", "oriented",
           "insert_knot"]

# largest difference of two normalised knot vectors (on [0, 1]) that still counts as equal
KNOT_TOLERANCE = 1e-9
# default border tolerance, relative to the extent of all the patches' poles
BORDER_TOLERANCE = 1e-9
# knots closer than this (relative to the domain width) to a break are taken as the break
SNAP = 1e-12
# weight of the break lines in MergedGrid.pinned_projection, per unit of merged parameter
PIN_WEIGHT = 10.0
# samples per knot span of a border curve when its length is measured (breaks="chord")
LENGTH_SAMPLES = 8
BREAKS = ("chord", "uniform")


@dataclass(frozen=True, eq=False)
class MergedGrid:
    r"""An m x n grid of patches merged into one surface (:func:`merge_grid`).

    Attributes
    ----------
    surface : BSplineSurface
        The merged surface on :math:`[U_0, U_m] \times [V_0, V_n]`; knots of multiplicity
        :math:`p` at :math:`U_1, \dots, U_{m-1}` and :math:`q` at :math:`V_1, \dots, V_{n-1}`.
    u_breaks : ndarray, shape (m + 1,)
        :math:`U_0 = 0 < U_1 < \dots < U_m = m`: patch ``[i][j]`` covers
        :math:`[U_i, U_{i+1}]` in u.
    v_breaks : ndarray, shape (n + 1,)
        :math:`V_0 = 0 < \dots < V_n = n`, likewise in v.
    domains : ndarray, shape (m, n, 2, 2)
        ``domains[i, j] = ((u0, u1), (v0, v1))``: the original parameter domain of patch
        ``[i][j]``, onto which :func:`split_grid` maps its piece back.
    border_gap : float
        Largest distance between two border poles that were averaged into one.
    """

    surface: BSplineSurface
    u_breaks: np.ndarray
    v_breaks: np.ndarray
    domains: np.ndarray
    border_gap: float

    @property
    def shape(self):
        """``(m, n)``: patches per direction."""
        return self.domains.shape[:2]

    def merged_parameters(self, i, j, u, v):
        r"""Parameters of the merged surface for parameters ``(u, v)`` of patch ``[i][j]``.

        .. math:: U = U_i + \frac{u - u_0}{u_1 - u_0} (U_{i+1} - U_i), \qquad
                  V = V_j + \frac{v - v_0}{v_1 - v_0} (V_{j+1} - V_j)

        Returns
        -------
        (ndarray, ndarray)
            Same shapes as ``u`` and ``v``.
        """
        (u0, u1), (v0, v1) = self.domains[i, j]
        return (_affine(u, (u0, u1), self.u_breaks[i:i + 2]),
                _affine(v, (v0, v1), self.v_breaks[j:j + 2]))

    def pinned_projection(self, target_u, target_v, weight=PIN_WEIGHT):
        r"""The merged surface projected onto ``target_u x target_v`` with the patch
        borders pinned: the least-squares surface

        .. math:: \min_T \iint |T - S|^2 + w \sum_i \int |T(U_i, v) - S(U_i, v)|^2 dv
                  + w \sum_j \int |T(u, V_j) - S(u, V_j)|^2 du

        over the breaks :math:`U_0 .. U_m`, :math:`V_0 .. V_n` (the block's border
        included).  Patches rarely share their parametrization across a join (one
        patch's u runs faster at the join than its neighbour's), and a smooth target
        cannot follow a jump of speed: the plain projection slides along the surface
        there, and its pieces leave the patches they should cover.  The line terms hold
        the former joins where they were, so each piece covers its patch.  With
        :math:`\Phi_u` the target's functions at the breaks, :math:`N_u` the source's,
        :math:`G` Gram and :math:`E` cross Gram matrices, the normal equations are

        .. math:: (G_u + w \Phi_u^T\Phi_u)\, C\, G_v + w\, G_u\, C\, \Phi_v^T\Phi_v
                  = (E_u + w \Phi_u^T N_u)\, P\, E_v^T + w\, E_u P N_v^T \Phi_v,

        solved exactly by the generalized eigenvectors of the two u matrices (one
        small solve per eigenvalue).

        Parameters
        ----------
        target_u, target_v : SplineSpace
            On the merged domain.
        weight : float, optional
            :math:`w`, relative to the merged parameter (each patch spans about one
            unit).

        Returns
        -------
        BSplineSurface
        """
        source = self.surface
        terms = []
        for target, space, breaks in ((target_u, source.u_space, self.u_breaks),
                                      (target_v, source.v_space, self.v_breaks)):
            at_breaks = target.collocation(breaks).toarray()
            terms.append((gram_matrix(target).toarray(), gram_matrix(target, space).toarray(),
                          at_breaks, at_breaks.T @ space.collocation(breaks).toarray()))
        (gu, eu, fu, nu), (gv, ev, fv, nv) = terms
        rhs = (sandwiched(eu + weight * nu, source.poles, ev)
               + weight * sandwiched(eu, source.poles, nv))
        # A1 C B1 + A2 C B2 = R with A2 Q = A1 Q diag(lam), Q^T A1 Q = I:  C = Q Y,
        # (B1 + lam_i B2) y_i = (Q^T R)_i
        lam, q = sla.eigh(gu, gu + weight * fu.T @ fu)
        pinned_v = weight * fv.T @ fv
        projected = np.einsum("ai,ajd->ijd", q, rhs)
        rows = np.stack([np.linalg.solve(gv + value * pinned_v, y)
                         for value, y in zip(lam, projected)])
        poles = np.einsum("ia,ajd->ijd", q, rows)
        return BSplineSurface(poles, target_u.knots, target_v.knots, target_u.degree,
                              target_v.degree)


# -- orientation ---------------------------------------------------------------------------
def oriented(surface, swap=False, flip_u=False, flip_v=False):
    r"""The same surface with its parameter directions exchanged and/or reversed.

    ``swap`` first exchanges u and v (:math:`S'(u, v) = S(v, u)`, poles transposed);
    ``flip_u`` and ``flip_v`` then reverse a direction of the result on the same domain,
    :math:`S'(u, v) = S(a + b - u, v)` for the u domain :math:`[a, b]` (poles reversed,
    knots reflected :math:`t'_k = a + b - t_{K-k}`).  The poles and weights are only
    permuted; the reflected interior knots are rounded once (relative :math:`10^{-16}`),
    the clamped end knots stay exact.  Bring patches into grid orientation with it before
    :func:`merge_grid`.

    Parameters
    ----------
    surface : BSplineSurface
    swap, flip_u, flip_v : bool, optional

    Returns
    -------
    BSplineSurface
    """
    if not isinstance(surface, BSplineSurface):
        raise InvalidInputError(
            f"oriented expects a BSplineSurface, got {type(surface).__name__}; build one "
            "with make_surface(poles, u_knots, v_knots, degree).")
    poles, weights = surface.poles, surface.weights
    tu, tv, p, q = surface.u_knots, surface.v_knots, surface.u_degree, surface.v_degree
    w = np.ones(surface.shape) if weights is None else weights
    if swap:
        poles, w, tu, tv, p, q = poles.transpose(1, 0, 2), w.T, tv, tu, q, p
    if flip_u:
        poles, w, tu = poles[::-1], w[::-1], _reflected(tu)
    if flip_v:
        poles, w, tv = poles[:, ::-1], w[:, ::-1], _reflected(tv)
    weights = None if weights is None else np.ascontiguousarray(w)
    return BSplineSurface(np.ascontiguousarray(poles), tu, tv, p, q, weights)


def _reflected(t):
    """Knots ``t0 + t1 - t[::-1]`` of the reversed parameter, clamped ends exact."""
    back = t[::-1]
    out = (t[0] + t[-1]) - back
    out[back == t[-1]] = t[0]
    out[back == t[0]] = t[-1]
    return out


def _affine(x, src, dst):
    r""":math:`d_0 + (x - s_0) (d_1 - d_0) / (s_1 - s_0)`, with :math:`s_0 \mapsto d_0` and
    :math:`s_1 \mapsto d_1` exactly (clamped end knots stay equal to the domain ends)."""
    x = np.asarray(x, dtype=float)
    out = dst[0] + (x - src[0]) * ((dst[1] - dst[0]) / (src[1] - src[0]))
    out = np.where(x == src[0], dst[0], out)
    return np.where(x == src[1], dst[1], out)


# -- knot insertion ------------------------------------------------------------------------
def insert_knot(knots, degree, coefficients, x, times=1):
    r"""Insert the knot ``x`` ``times`` times into a clamped spline (Boehm's algorithm).

    One insertion of :math:`x \in [t_\mu, t_{\mu+1})` gives the same spline with the
    coefficients

    .. math:: Q_i = \alpha_i P_i + (1 - \alpha_i) P_{i-1}, \qquad
              \alpha_i = \frac{x - t_i}{t_{i+p} - t_i}
              \quad (\mu - p + 1 \le i \le \mu),

    :math:`Q_i = P_i` below and :math:`Q_i = P_{i-1}` above that range (The NURBS Book,
    eq. 5.15).  Each insertion is one vectorised operation over all trailing axes of
    ``coefficients`` (the other direction of a surface net, the coordinates).

    Parameters
    ----------
    knots : array_like, shape (k + p + 1,)
        Clamped knot vector.
    degree : int
    coefficients : array_like, shape (k, ...)
    x : float
        Inside the open domain :math:`(t_p, t_k)`.
    times : int, optional
        Insertions, so that the multiplicity of ``x`` stays at most ``degree``.

    Returns
    -------
    knots : ndarray, shape (k + times + p + 1,)
    coefficients : ndarray, shape (k + times, ...)

    Raises
    ------
    InvalidInputError
        Bad knots, coefficients of the wrong length, ``x`` outside the open domain or a
        resulting multiplicity above ``degree``.
    """
    space = SplineSpace.from_knots(knots, degree)
    c = np.asarray(coefficients, dtype=float)
    if c.ndim < 1 or c.shape[0] != space.dimension:
        raise InvalidInputError(
            f"coefficients must have {space.dimension} rows (one per basis function), got "
            f"shape {c.shape}; pass the poles along the first axis.")
    lo, hi = space.domain
    x = float(x)
    if not lo < x < hi:
        raise InvalidInputError(
            f"the knot to insert must lie inside the open domain ({lo}, {hi}), got {x}; "
            "the domain ends are already clamped.")
    have = int(np.count_nonzero(space.knots == x))
    if isinstance(times, bool) or not isinstance(times, (int, np.integer)) or times < 1 \
            or have + times > space.degree:
        raise InvalidInputError(
            f"times must be an integer from 1 to {space.degree - have} (the knot {x} has "
            f"multiplicity {have}, at most the degree {space.degree}), got {times!r}.")
    return _insert(space.knots, space.degree, c, x, int(times))


def _insert(t, p, c, x, times):
    """:func:`insert_knot` on trusted arguments."""
    for _ in range(times):
        mu = int(np.searchsorted(t, x, side="right")) - 1
        i = np.arange(mu - p + 1, mu + 1)
        alpha = ((x - t[i]) / (t[i + p] - t[i])).reshape((-1,) + (1,) * (c.ndim - 1))
        middle = alpha * c[i] + (1.0 - alpha) * c[i - 1]
        c = np.concatenate([c[:mu - p + 1], middle, c[mu:]])
        t = np.insert(t, mu + 1, x)
    return t, c


# -- merge ---------------------------------------------------------------------------------
def merge_grid(patches, *, tol=None, breaks="chord"):
    r"""Merge an m x n grid of patches into one B-spline surface.

    Patch ``[i][j]`` is followed in u by ``[i + 1][j]`` and in v by ``[i][j + 1]``; all
    are non-rational, clamped, of the same degrees :math:`(p, q)` and already in grid
    orientation (:func:`oriented`).  The patches of grid row :math:`i` must share their u
    knots up to an affine map, those of grid column :math:`j` their v knots; neighbouring
    border pole rows must coincide within ``tol`` and are averaged into one shared row.

    Patch ``[i][j]`` becomes the part :math:`[U_i, U_{i+1}] \times [V_j, V_{j+1}]` of the
    merged surface, its knots mapped affinely; the joins :math:`U_i` are knots of
    multiplicity :math:`p` (:math:`V_j` of multiplicity :math:`q`), so the merged surface
    is exactly the patches: C0 in the parameter, G0 (one shared pole row) in space.

    Parameters
    ----------
    patches : sequence of sequences of BSplineSurface
        ``patches[i][j]``, m rows of n patches each.
    tol : float, optional
        Largest distance between border poles that count as the same point; default
        ``1e-9`` times the extent of all poles.  Pass e.g. a model's sewing tolerance.
    breaks : {"chord", "uniform"}, optional
        ``"uniform"``: :math:`U_i = i`, :math:`V_j = j`.  Patches of different sizes then
        get unit intervals each, so the merged parameter is not proportional to length
        across the grid (valid, but a quasi-uniform fairing target then puts as many poles
        on a small patch as on a large one).  ``"chord"`` (default): the interval of grid
        row :math:`i` is proportional to the mean length :math:`L_i` of its patches' u
        border curves, :math:`U_i = m \sum_{i' < i} L_{i'} / \sum_{i'} L_{i'}` (so still
        :math:`U_m = m`), likewise in v: a quasi-uniform target then spreads its poles by
        length.

    Returns
    -------
    MergedGrid

    Raises
    ------
    InvalidInputError
        A grid that is not rectangular or holds something other than surfaces; different
        degrees or coordinate counts; knots that do not match along a grid row or column;
        borders farther apart than ``tol``; an unknown ``breaks``.
    InvalidToleranceError
        ``tol`` not a positive finite number.
    UnsupportedGeometryError
        A rational patch.
    """
    grid = _grid_of(patches)
    if breaks not in BREAKS:
        raise InvalidInputError(f"breaks must be one of {BREAKS}, got {breaks!r}.")
    p, q = _common_degrees(grid)
    u_rows = [_shared_knots([s.u_knots for s in row], i, "row", "u") for i, row in enumerate(grid)]
    v_cols = [_shared_knots([s.v_knots for s in col], j, "column", "v")
              for j, col in enumerate(zip(*grid))]
    tol = _border_tolerance(grid, tol)
    gap = _border_gap(grid, tol)
    u_breaks, v_breaks = _breaks(grid, breaks)
    mapped = [[BSplineSurface(s.poles, _affine(u_rows[i], (0.0, 1.0), u_breaks[i:i + 2]),
                              _affine(v_cols[j], (0.0, 1.0), v_breaks[j:j + 2]), p, q)
               for j, s in enumerate(row)] for i, row in enumerate(grid)]
    surface = join_pieces(mapped)
    domains = np.array([[s.domain for s in row] for row in grid])
    return MergedGrid(surface, u_breaks, v_breaks, domains, gap)


def _grid_of(patches):
    """``patches`` as a rectangular list of lists of non-rational surfaces."""
    shape_message = ("patches must be an m x n nested list of BSplineSurface "
                     "(patches[i][j], i along u, j along v), m, n >= 1")
    try:
        grid = [list(row) for row in patches]
    except TypeError as exc:
        raise InvalidInputError(
            f"{shape_message}, got {type(patches).__name__}; wrap a single row in a list."
        ) from exc
    lengths = [len(row) for row in grid]
    if not grid or min(lengths) == 0 or len(set(lengths)) != 1:
        raise InvalidInputError(f"{shape_message}, got rows of lengths {lengths}; "
                                "pad or drop patches so that every row has n patches.")
    for i, row in enumerate(grid):
        for j, s in enumerate(row):
            if not isinstance(s, BSplineSurface):
                raise InvalidInputError(
                    f"patch [{i}][{j}] must be a BSplineSurface, got {type(s).__name__}; "
                    "build it with make_surface(poles, u_knots, v_knots, degree).")
            if s.is_rational:
                raise UnsupportedGeometryError(
                    f"patch [{i}][{j}] is rational; merge_grid merges non-rational patches "
                    "only: approximate it by a non-rational surface first.")
    return grid


def _common_degrees(grid):
    """The degrees ``(p, q)`` and coordinate count shared by all patches."""
    first = grid[0][0]
    want = (first.u_degree, first.v_degree, first.poles.shape[2])
    for i, row in enumerate(grid):
        for j, s in enumerate(row):
            got = (s.u_degree, s.v_degree, s.poles.shape[2])
            if got[:2] != want[:2]:
                raise InvalidInputError(
                    f"all patches must have the same degrees (p, q); patch [0][0] has "
                    f"{want[:2]}, patch [{i}][{j}] has {got[:2]}: elevate the degree of the "
                    "lower one, or orient the patch (oriented(..., swap=True)) if u and v "
                    "are exchanged.")
            if got[2] != want[2]:
                raise InvalidInputError(
                    f"all patches must have the same number of coordinates; patch [0][0] "
                    f"has {want[2]}, patch [{i}][{j}] has {got[2]}.")
    return want[:2]


def _shared_knots(knot_vectors, index, line, direction):
    """Mean of the knot vectors normalised to [0, 1]; :class:`InvalidInputError` when two
    differ by more than ``KNOT_TOLERANCE``."""
    normed = [_affine(t, (t[0], t[-1]), (0.0, 1.0)) for t in knot_vectors]
    for other, t in enumerate(normed[1:], start=1):
        same = t.size == normed[0].size and np.abs(t - normed[0]).max() <= KNOT_TOLERANCE
        if not same:
            a, b = ((index, 0), (index, other)) if line == "row" else ((0, index), (other, index))
            raise InvalidInputError(
                f"the patches of grid {line} {index} must share their {direction} knots up to "
                f"an affine map; normalised to [0, 1], patch [{a[0]}][{a[1]}] has "
                f"{_short(normed[0])} and patch [{b[0]}][{b[1]}] has {_short(t)}: insert the "
                f"missing knots (insert_knot) so that both carry the same {direction} knots, "
                "or check the patches' orientation (oriented).")
    return np.mean(normed, axis=0)


def _short(t):
    return np.array2string(t, precision=6, threshold=12, separator=", ",
                           max_line_width=10**6)


def _border_tolerance(grid, tol):
    """``tol``, validated; default ``BORDER_TOLERANCE`` times the extent of all poles."""
    if tol is None:
        every = np.concatenate([s.poles.reshape(-1, s.poles.shape[2]) for row in grid for s in row])
        return BORDER_TOLERANCE * extent(every)
    value = float(tol) if np.ndim(tol) == 0 and np.isreal(tol) else np.nan
    if not (np.isfinite(value) and value > 0):
        raise InvalidToleranceError(
            f"tol must be a positive finite length (the largest gap between border poles "
            f"that count as one point), got {tol!r}.")
    return value


def _border_gap(grid, tol):
    """Largest distance between the border pole rows of neighbouring patches;
    :class:`InvalidInputError` when one exceeds ``tol``."""
    largest = 0.0
    m, n = len(grid), len(grid[0])
    for i in range(m):
        for j in range(n):
            if i + 1 < m:
                largest = max(largest, _pair_gap(grid, (i, j), (i + 1, j), "u", tol))
            if j + 1 < n:
                largest = max(largest, _pair_gap(grid, (i, j), (i, j + 1), "v", tol))
    return largest


def _pair_gap(grid, a, b, direction, tol):
    """Largest distance between the facing border rows of patches ``a`` and ``b``."""
    pa, pb = grid[a[0]][a[1]].poles, grid[b[0]][b[1]].poles
    end, start = (pa[-1], pb[0]) if direction == "u" else (pa[:, -1], pb[:, 0])
    distance = np.linalg.norm(end - start, axis=-1)
    worst = int(np.argmax(distance))
    if distance[worst] > tol:
        raise InvalidInputError(
            f"patch [{a[0]}][{a[1]}] is followed in {direction} by patch [{b[0]}][{b[1]}], so "
            f"its last {direction} border pole row must coincide with the other's first one "
            f"within tol = {tol:.3g}; they are {distance[worst]:.3g} apart (pole {worst}): "
            "orient the patches so that these borders face each other (oriented), or pass "
            "a larger tol (e.g. the model's sewing tolerance).")
    return float(distance[worst])


def _breaks(grid, breaks):
    """Break parameters ``(U, V)``, each on ``[0, count]``."""
    m, n = len(grid), len(grid[0])
    if breaks == "uniform":
        return np.arange(m + 1, dtype=float), np.arange(n + 1, dtype=float)
    u_lengths = [np.mean([_length(s.u_space, s.poles[:, k]) for s in row for k in (0, -1)])
                 for row in grid]
    v_lengths = [np.mean([_length(s.v_space, s.poles[k]) for s in col for k in (0, -1)])
                 for col in zip(*grid)]
    return _scaled(u_lengths, "row", "u"), _scaled(v_lengths, "column", "v")


def _length(space, poles):
    """Length of the curve ``poles`` in ``space``: chords of ``LENGTH_SAMPLES`` samples
    per knot span."""
    b = space.breakpoints
    steps = np.arange(LENGTH_SAMPLES) / LENGTH_SAMPLES
    x = np.append((b[:-1, None] + np.diff(b)[:, None] * steps).ravel(), b[-1])
    points = space.evaluate(poles, x)
    return float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())


def _scaled(lengths, line, direction):
    """:math:`U_i = m \\sum_{i' < i} L_{i'} / \\sum L`, ends exactly 0 and m."""
    lengths = np.asarray(lengths)
    if np.any(lengths <= 0):
        bad = int(np.argmin(lengths))
        raise InvalidInputError(
            f"grid {line} {bad} has {direction} borders of zero length, so breaks='chord' "
            "cannot place it; drop the degenerate patches or pass breaks='uniform'.")
    out = lengths.size * np.concatenate([[0.0], np.cumsum(lengths)]) / lengths.sum()
    out[0], out[-1] = 0.0, float(lengths.size)
    return out


# -- split ---------------------------------------------------------------------------------
def split_grid(merged, surface):
    r"""Cut a surface on the merged domain into the grid's patches, exactly.

    Every interior break :math:`U_i` is inserted into the u knots until its multiplicity is
    the surface's u degree :math:`p'` (:func:`insert_knot`; knots within
    :math:`10^{-12}` of the domain width of a break are taken as the break), likewise in
    v.  The spline is then the same, and the poles between two breaks with the knots
    between them, clamped, are the piece on that interval; neighbouring pieces share the
    pole row at their break (the same row of one refined net, so bit-equal).  Piece
    ``[i][j]`` is mapped affinely onto the original domain of patch ``[i][j]``.

    Parameters
    ----------
    merged : MergedGrid
    surface : BSplineSurface
        Any degrees and knots on the domain of ``merged.surface``, e.g. a faired
        ``fair_surface(merged.surface.poles, n, u_knots=..., v_knots=..., degree=...)``
        result's ``surface``.  Rational surfaces are cut in homogeneous coordinates.

    Returns
    -------
    list of list of BSplineSurface
        ``pieces[i][j]`` with the degrees of ``surface``.

    Raises
    ------
    InvalidInputError
        If ``merged`` or ``surface`` has the wrong type, ``surface`` lives on another
        domain, or more knots than its degree lie (within :math:`10^{-12}`) on a break.
    """
    if not isinstance(merged, MergedGrid) or not isinstance(surface, BSplineSurface):
        raise InvalidInputError(
            f"split_grid expects a MergedGrid (from merge_grid) and a BSplineSurface, got "
            f"{type(merged).__name__} and {type(surface).__name__}.")
    _require_merged_domain(merged, surface)
    pieces = cut_surface(surface, merged.u_breaks[1:-1], merged.v_breaks[1:-1])
    return [[_mapped(piece, merged.domains[i, j]) for j, piece in enumerate(row)]
            for i, row in enumerate(pieces)]


def cut_surface(surface, u_cuts=(), v_cuts=()):
    r"""Cut a surface at interior parameters into a grid of pieces, exactly.

    Every cut is inserted into the knots until its multiplicity is the degree
    (:func:`insert_knot`; knots within :data:`SNAP` of the domain width of a cut are taken
    as the cut).  The spline is then the same, and the poles between two cuts with the
    knots between them, clamped, are the piece on that interval, on the surface's own
    parameters; neighbouring pieces share the pole row at their cut (bit-equal).

    Parameters
    ----------
    surface : BSplineSurface
        Rational surfaces are cut in homogeneous coordinates.
    u_cuts, v_cuts : sequence of float
        Increasing parameters inside the open domain.

    Returns
    -------
    list of list of BSplineSurface
        ``pieces[i][j]`` on :math:`[u_i, u_{i+1}] \times [v_j, v_{j+1}]`, with the cuts
        and the domain's ends as :math:`u_i` and :math:`v_j`.

    Raises
    ------
    InvalidInputError
        More knots than the degree lie (within :data:`SNAP`) on a cut.
    """
    u_cuts, v_cuts = (np.asarray(c, dtype=float) for c in (u_cuts, v_cuts))
    net = surface.homogeneous() if surface.is_rational else surface.poles
    tu, net = _refined(surface.u_knots, surface.u_degree, net, u_cuts)
    tv, net_t = _refined(surface.v_knots, surface.v_degree, net.transpose(1, 0, 2), v_cuts)
    net = net_t.transpose(1, 0, 2)
    return [[_piece(surface, net, ku, su, kv, sv)
             for kv, sv in _pieces(tv, surface.v_degree, v_cuts)]
            for ku, su in _pieces(tu, surface.u_degree, u_cuts)]


def join_pieces(pieces):
    r"""The surface that is exactly a grid of pieces (the inverse of :func:`cut_surface`).

    Piece ``[i][j]`` is followed in u by ``[i + 1][j]`` and in v by ``[i][j + 1]``, on
    the same parameters (piece ``[i][j]`` ends in u where ``[i + 1][j]`` begins).  The
    pieces of one grid column (same u interval) get the union of their u knots, those of
    one grid row the union of their v knots (:func:`insert_knot`: the same pieces);
    neighbouring border pole rows are averaged into one row, and each cut becomes a knot
    of multiplicity equal to the degree, so the surface is C0 in the parameter there and
    as smooth in space as the pieces meet.

    Parameters
    ----------
    pieces : sequence of sequences of BSplineSurface
        Polynomial pieces of equal degrees, m rows of n.

    Returns
    -------
    BSplineSurface
    """
    grid = [list(row) for row in pieces]
    p, q = grid[0][0].u_degree, grid[0][0].v_degree
    u_knots = [_knot_union([s.u_knots for s in row], p) for row in grid]
    v_knots = [_knot_union([s.v_knots for s in col], q) for col in zip(*grid)]
    nets = [[_with_knots(s, u_knots[i], v_knots[j]) for j, s in enumerate(row)]
            for i, row in enumerate(grid)]
    rows = [_stacked([net for net in row], axis=1) for row in nets]
    return BSplineSurface(_stacked(rows, axis=0), _chained(u_knots, p), _chained(v_knots, q),
                          p, q)


def _knot_union(knot_vectors, degree):
    """The clamped knot vector holding every interior knot of ``knot_vectors`` (one
    interval) as often as the most of them does."""
    inner = [t[degree + 1:-degree - 1] for t in knot_vectors]
    values = np.unique(np.concatenate(inner))
    counts = [max(int(np.count_nonzero(t == x)) for t in inner) for x in values]
    t = knot_vectors[0]
    return np.concatenate([t[:degree + 1], np.repeat(values, counts), t[-degree - 1:]])


def _with_knots(surface, u_knots, v_knots):
    """The poles of ``surface`` on the finer knots ``u_knots`` and ``v_knots``."""
    net = surface.poles
    for axis, (have, want, p) in enumerate(((surface.u_knots, u_knots, surface.u_degree),
                                            (surface.v_knots, v_knots, surface.v_degree))):
        moved, t = np.moveaxis(net, axis, 0), have
        for x in np.unique(want[p + 1:-p - 1]):
            missing = int(np.count_nonzero(want == x) - np.count_nonzero(t == x))
            if missing > 0:
                t, moved = _insert(t, p, moved, x, missing)
        net = np.moveaxis(moved, 0, axis)
    return net


def _stacked(nets, axis):
    """Nets following each other along ``axis``, each shared border row averaged."""
    out = nets[0]
    for net in nets[1:]:
        first, rest = np.split(net, [1], axis=axis)
        last = np.take(out, [-1], axis=axis)
        out = np.concatenate([np.delete(out, -1, axis=axis), 0.5 * (last + first), rest],
                             axis=axis)
    return out


def _chained(knot_vectors, degree):
    """Clamped knot vectors of consecutive intervals as one, each joint a knot of
    multiplicity ``degree``."""
    out = knot_vectors[0][:-1]
    for t in knot_vectors[1:]:
        out = np.concatenate([out, t[degree + 1:-1]])
    return np.concatenate([out, knot_vectors[-1][-1:]])


def _require_merged_domain(merged, surface):
    """:class:`InvalidInputError` unless ``surface`` lives on the merged domain."""
    for (lo, hi), b, name in zip(surface.domain, (merged.u_breaks, merged.v_breaks), "uv"):
        slack = 1e-12 * (b[-1] - b[0])
        if abs(lo - b[0]) > slack or abs(hi - b[-1]) > slack:
            raise InvalidInputError(
                f"the surface to split must live on the merged domain; its {name} domain is "
                f"[{lo}, {hi}], the grid's is [{b[0]}, {b[-1]}]: fair merged.surface with "
                "its own knots (the fairing target keeps the source's domain).")


def _refined(t, p, c, cuts):
    """Knots and coefficients with every cut of multiplicity at least ``p``."""
    t = t.copy()
    for x in cuts:
        t[np.abs(t - x) <= SNAP * (t[-1] - t[0])] = x
    for x in cuts:
        have = int(np.count_nonzero(t == x))
        if have > p:
            raise InvalidInputError(
                f"the surface to split has {have} knots within {SNAP:.0e} of the domain "
                f"width of the break {x}, more than its degree {p}: it (nearly) jumps there "
                "and its pieces could not share a border; remove the clustered knots.")
        if have < p:
            t, c = _insert(t, p, c, x, p - have)
    return t, c


def _pieces(t, p, cuts):
    """``(knots, slice of coefficients)`` of each piece between the cuts of refined knots."""
    bounds = np.concatenate([[t[0]], cuts, [t[-1]]])
    out = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        inner = t[(t > lo) & (t < hi)]
        start = int(np.searchsorted(t, lo, side="right")) - p - 1
        knots = np.concatenate([np.full(p + 1, lo), inner, np.full(p + 1, hi)])
        out.append((knots, slice(start, start + inner.size + p + 1)))
    return out


def _piece(surface, net, ku, su, kv, sv):
    """The piece of the refined net ``net`` on the knots ``ku`` x ``kv``."""
    block = net[su, sv].copy()
    poles, weights = block, None
    if surface.is_rational:
        poles, weights = block[..., :-1] / block[..., -1:], block[..., -1]
    return BSplineSurface(poles, ku, kv, surface.u_degree, surface.v_degree, weights)


def _mapped(piece, domain):
    """``piece`` with its knots mapped affinely onto ``domain`` ``((u0, u1), (v0, v1))``."""
    (u0, u1), (v0, v1) = domain
    ku, kv = piece.u_knots, piece.v_knots
    return BSplineSurface(piece.poles, _affine(ku, (ku[0], ku[-1]), (u0, u1)),
                          _affine(kv, (kv[0], kv[-1]), (v0, v1)), piece.u_degree,
                          piece.v_degree, piece.weights)
