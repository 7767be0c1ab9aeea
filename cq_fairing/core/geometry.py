"""Immutable B-spline curves and tensor-product surfaces with documented shapes.

The default constructors trust their arguments (internal fast path, like scipy's
``BSpline.construct_fast``); :func:`make_curve` and :func:`make_surface` validate
user input once and raise :class:`~cq_fairing.errors.InvalidInputError` with a message
that says what to do.
"""

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InvalidInputError
from .spaces import SplineSpace, basis_functions, find_spans, real_array
from .taylor import TaylorSurface

# Products up to these sizes (m n k for a matrix product, n k for a matrix-vector one) run
# on one thread in OpenBLAS (interface/gemm.c and gemv.c: 65536 * 4 and 2304 * 4).  A
# woken OpenBLAS worker spins on the other core after its work is done, and on this
# 2-core test machine that slowed the rest of a blade fit by a quarter (GridBlocks).
ONE_THREAD_GEMM = 65536 * 4
ONE_THREAD_GEMV = 2304 * 4
# Elements of one slice of GridBlocks' sparse product (1 MB): the slice is still in the
# cache when it is transposed into place, and no grid-sized temporary is allocated.
ALONG_V_SLICE = 2 ** 17
# largest coordinate magnitude and smallest non-zero extent accepted: squared distances
# and the fifth powers of a net's lengths (curvature-variation energy) stay in float range
COORDINATE_LIMIT = 1e50
EXTENT_FLOOR = 1e-50
# rows within this fraction of the net's extent coincide (a closed seam, a collapsed border)
COINCIDENT = 1e-9
CLOSED_MIN_SPANS = 3

__all__ = ["BSplineCurve", "BSplineSurface", "make_curve", "make_surface", "as_poles", "extent",
           "closed_axes", "fewest_spans", "collapsed_rows", "collapse_rows", "collapsed_kept",
           "CLOSED_MIN_SPANS", "one_thread_product"]


def extent(poles):
    """Bounding-box diagonal of a pole array (any leading shape, last axis = coordinates):
    the size of a geometry, which scales a converged Newton step or a noise floor."""
    flat = np.asarray(poles).reshape(-1, np.asarray(poles).shape[-1])
    return float(np.linalg.norm(flat.max(axis=0) - flat.min(axis=0)))


def closed_axes(surface):
    """``(u, v)``: True along a direction whose first and last pole rows coincide (within
    :data:`COINCIDENT` of the net's extent), a closed seam such as that of an unperiodized
    periodic surface."""
    size = extent(surface.poles)
    return tuple(bool(np.abs(rows[0] - rows[-1]).max() <= COINCIDENT * size)
                 for rows in (surface.poles, np.swapaxes(surface.poles, 0, 1)))


def fewest_spans(surface):
    r"""The fewest knot spans per direction of a target that can still be a valid face.

    One span along an open direction; :data:`CLOSED_MIN_SPANS` (3) along a closed one
    (:func:`closed_axes`).  A closed direction is faired with its end rows tied, and the
    target space then holds the closed loops of its span count.  The periodic splines of
    :math:`m` uniform spans (those without a corner at the seam) form an
    :math:`m`-dimensional subspace: one or two spans give only a point or a segment
    traversed twice, three (a rounded triangle) are the fewest that enclose an area.  Below
    that a tied net closes only through a corner at the seam: a tube swept along such a
    loop folds through itself there (a torus faired to 4 x 4 poles wrote a STEP file that
    reads back as a self-intersecting wire).  A direction with fewer spans than that keeps
    its own count.
    """
    spans = (surface.u_space.n_spans, surface.v_space.n_spans)
    return tuple(min(CLOSED_MIN_SPANS, n) if closed else 1
                 for closed, n in zip(closed_axes(surface), spans))


@dataclass(frozen=True, eq=False)
class BSplineCurve:
    """A clamped (optionally rational) B-spline curve.

    Attributes
    ----------
    poles : ndarray, shape (k, d)
        Control points (Cartesian, not weighted), ``d`` = 2 or 3 (any ``d >= 1``).
    knots : ndarray, shape (k + degree + 1,)
        Full clamped knot vector.
    degree : int
    weights : ndarray, shape (k,), or None
        Positive weights of a rational curve; ``None`` for a polynomial one.
    """

    poles: np.ndarray
    knots: np.ndarray
    degree: int
    weights: np.ndarray = None

    @cached_property
    def space(self):
        """The :class:`SplineSpace` of the curve."""
        return SplineSpace(self.degree, self.knots)

    @cached_property
    def size(self):
        """:func:`extent` of the poles, kept: every closest-point search asks for it."""
        return extent(self.poles)

    @property
    def is_rational(self):
        return self.weights is not None

    @property
    def n_poles(self):
        return self.poles.shape[0]

    def homogeneous(self):
        """Poles ``(w x, w)`` of shape (k, d + 1); weights 1 when polynomial."""
        w = np.ones(self.n_poles) if self.weights is None else self.weights
        return np.hstack([self.poles * w[:, None], w[:, None]])

    def evaluate(self, u, nu=0):
        """Points (``nu = 0``) or derivatives up to order 2 at parameters ``u``.

        Returns
        -------
        ndarray, shape (len(u), d)
        """
        u = np.asarray(u, dtype=float).ravel()
        if self.weights is None:
            return self.space.evaluate(self.poles, u, nu)
        return _rational_derivative(self.space.evaluate, self.homogeneous(), u, nu)

    @property
    def domain(self):
        return self.space.domain


DEGENERATE = 1e-2   # a normal shorter than this x the longest on the grid is undefined


def folded(normals, reference):
    r"""True where ``normals`` turn by more than 90 degrees from ``reference`` (arrays of
    unnormalised normals, same shape), where both are defined: longer than
    :data:`DEGENERATE` times the longest of their array."""
    lengths = [np.linalg.norm(n, axis=-1) for n in (normals, reference)]
    defined = np.logical_and(*(n > DEGENERATE * max(n.max(), 1e-300) for n in lengths))
    return defined & (np.einsum("...i,...i->...", normals, reference) < 0.0)


@dataclass(frozen=True, eq=False)
class BSplineSurface:
    """A clamped (optionally rational) tensor-product B-spline surface.

    Attributes
    ----------
    poles : ndarray, shape (k_u, k_v, d)
    u_knots : ndarray, shape (k_u + u_degree + 1,)
    v_knots : ndarray, shape (k_v + v_degree + 1,)
    u_degree, v_degree : int
    weights : ndarray, shape (k_u, k_v), or None
    """

    poles: np.ndarray
    u_knots: np.ndarray
    v_knots: np.ndarray
    u_degree: int
    v_degree: int
    weights: np.ndarray = None

    @cached_property
    def u_space(self):
        return SplineSpace(self.u_degree, self.u_knots)

    @cached_property
    def v_space(self):
        return SplineSpace(self.v_degree, self.v_knots)

    @cached_property
    def size(self):
        """:func:`extent` of the poles, kept: every closest-point search asks for it."""
        return extent(self.poles)

    @property
    def is_rational(self):
        return self.weights is not None

    @cached_property
    def taylor(self):
        """:class:`~cq_fairing.core.taylor.TaylorSurface` of the (homogeneous) poles,
        built on first use: fast evaluation at scattered parameters."""
        coefficients = self.homogeneous() if self.is_rational else self.poles
        return TaylorSurface(self.u_space, self.v_space, coefficients)

    @property
    def shape(self):
        """``(k_u, k_v)``: poles per direction."""
        return self.poles.shape[:2]

    def homogeneous(self):
        """Poles ``(w x, w)`` of shape (k_u, k_v, d + 1)."""
        w = np.ones(self.shape) if self.weights is None else self.weights
        return np.concatenate([self.poles * w[..., None], w[..., None]], axis=2)

    def evaluate_grid(self, u, v, nu=0, nv=0):
        """Points or partial derivatives on the grid ``u x v``.

        Returns
        -------
        ndarray, shape (len(u), len(v), d)
        """
        u = np.asarray(u, dtype=float).ravel()
        v = np.asarray(v, dtype=float).ravel()
        if self.weights is None:
            return _grid(self.u_space, self.v_space, self.poles, u, v, nu, nv)
        if nu + nv > 2:
            raise InvalidInputError("rational surfaces evaluate derivatives up to order 2.")
        return _rational_grid(self, u, v, nu, nv)

    def folds_against(self, reference, u, v):
        r"""True where the surface's normal turns by more than 90 degrees from
        ``reference``'s on the grid ``u x v``: :math:`(S_u\times S_v)\cdot
        (R_u\times R_v) < 0`, where both normals are defined (longer than
        :data:`DEGENERATE` times their largest: a collapsed border has none).  A faired
        surface that folds back over itself keeps its distance to the source small but
        reverses its normal there."""
        return folded(*(np.cross(s.evaluate_grid(u, v, 1, 0), s.evaluate_grid(u, v, 0, 1))
                        for s in (self, reference)))

    def grid_blocks(self, u, v, step):
        """:class:`GridBlocks` of this surface on the grid ``u x v``, ``step`` rows per block."""
        return GridBlocks(self, u, v, step)

    @property
    def domain(self):
        """``((u0, u1), (v0, v1))``."""
        return self.u_space.domain, self.v_space.domain


class GridBlocks:
    r"""The points of a surface on the grid ``u x v``, a block of ``step`` rows at a time.

    :math:`W_a(v_j) = \sum_b N_b(v_j) P_{ab}` (homogeneous poles for a rational surface)
    is built once; block ``b`` holds the rows :math:`i \in [b\,step, (b + 1)\,step)`,
    :math:`S(u_i, v_j) = \sum_{a = f_i}^{f_i + p} N_a(u_i)\, W_a(v_j)` with :math:`f_i`
    the first basis function that is non-zero at :math:`u_i`.  The rows of a block that
    share :math:`f_i` are one dense product with :math:`p + 1` terms, which runs 2-4 times
    faster than the sparse collocation product (scipy's sparse kernel is not vectorised):
    a tolerance check walks a million-sample grid this way without holding it.  A row is
    only ever computed inside its own block, by the same products, so it comes out the
    same bit for bit however often it is asked for.
    :meth:`BSplineSurface.evaluate_grid` contracts u first, so the two agree to rounding
    only; it stays as it is because the adaptive search's path depends on the rounding of
    its grids.

    Parameters
    ----------
    surface : BSplineSurface
    u, v : ndarray, shape (n_u,) and (n_v,)
        Grid axes inside the domain.
    step : int
        Rows per block, ``>= 1``.
    """

    def __init__(self, surface, u, v, step):
        u = np.asarray(u, dtype=float).ravel()
        v = np.asarray(v, dtype=float).ravel()
        net = surface.poles if surface.weights is None else surface.homogeneous()
        self._dim = net.shape[2]
        self._along_v = _along_v(surface.v_space.collocation(v), net)
        spans = find_spans(surface.u_space, u)
        self._basis = basis_functions(surface.u_space, u, spans)[0]
        self._first = spans - surface.u_degree
        self._rational = surface.weights is not None
        self.step, self.n_u, self.n_v = step, u.size, v.size
        self.n_blocks = -(-u.size // step)

    def rows_of(self, b):
        """The row indices of block ``b`` as a slice."""
        return slice(b * self.step, min((b + 1) * self.step, self.n_u))

    def block(self, b):
        """Points on the rows of block ``b``, shape (rows, n_v, d): a view ordered
        (u, coordinate, v) in memory (each coordinate's v samples contiguous)."""
        rows = self.rows_of(b)
        first = self._first[rows]
        terms = self._basis.shape[1]
        out = np.empty((first.size, self._along_v.shape[1]))
        cuts = np.r_[0, np.flatnonzero(np.diff(first)) + 1, first.size]
        for lo, hi in zip(cuts[:-1], cuts[1:]):
            f = first[lo]
            _one_thread_matmul(self._basis[rows][lo:hi], self._along_v[f:f + terms],
                               out[lo:hi])
        points = out.reshape(-1, self._dim, self.n_v).transpose(0, 2, 1)
        return points[..., :-1] / points[..., -1:] if self._rational else points


def _along_v(collocation, net):
    r""":math:`W_a(v_j) = \sum_b N_b(v_j) P_{ab}` as shape (k_u, d n_v), ordered
    (a, coordinate, j), built a slice of ``v`` at a time (``ALONG_V_SLICE``): on the terrain's
    final check (312 x 323 poles, 3329 samples along v) 12 ms where one product and one
    transposed copy of the whole took 35 ms.  Each row of the sparse product is computed
    on its own, so the values are those of the whole product bit for bit."""
    ku, kv, dim = net.shape
    rhs = net.transpose(1, 2, 0).reshape(kv, -1)
    n_v = collocation.shape[0]
    out = np.empty((ku, dim, n_v))
    step = max(1, ALONG_V_SLICE // rhs.shape[1])
    for start in range(0, n_v, step):
        part = collocation[start:start + step] @ rhs
        out[:, :, start:start + step] = part.reshape(-1, dim, ku).transpose(2, 1, 0)
    return out.reshape(ku, -1)


def one_thread_product(a, b):
    r"""``tensordot(a, b, axes=(1, 0))`` of a matrix ``a`` (m, k) and an array ``b``
    (k, ...), :math:`\sum_j a_{ij} b_{j\ldots}`, computed on one OpenBLAS thread
    (:func:`_one_thread_matmul`).  A search's small products (a 71 x 138 projection
    operator times a 138 x 21 x 3 net) would otherwise wake a second thread, and on a
    loaded 2-core machine took 10 ms each where one thread takes 0.1 ms."""
    flat = b.reshape(b.shape[0], -1)
    out = np.empty((a.shape[0], flat.shape[1]))
    _one_thread_matmul(a, flat, out)
    return out.reshape((a.shape[0],) + b.shape[1:])


def _one_thread_matmul(a, b, out):
    """``out = a @ b`` in column chunks small enough that OpenBLAS computes each on one
    thread (``ONE_THREAD_GEMM``, ``ONE_THREAD_GEMV``)."""
    terms = a.shape[1]
    chunk = max(1, min(ONE_THREAD_GEMM // (a.shape[0] * terms), ONE_THREAD_GEMV // terms))
    for c in range(0, b.shape[1], chunk):
        np.matmul(a, b[:, c:c + chunk], out=out[:, c:c + chunk])


def _grid(u_space, v_space, net, u, v, nu, nv):
    r""":math:`S_{u^{nu} v^{nv}}` on the grid ``u x v`` as :math:`M_u\,P\,M_v^T` per
    coordinate with the sparse collocation matrices (``p + 1`` non-zeros per row):
    :math:`O((N_u k_v + N_u N_v)(p + 1))` work, where dense factors cost
    :math:`O(N_u k_u k_v + N_u N_v k_v)` (a second on a 400 x 400 net).

    The result is a view of memory ordered (v, coordinate, u): each coordinate's u
    samples are contiguous, which halves the time of the distance between two such grids
    against the (v, u, coordinate) order (6 against 13 ms on an 801 x 1265 grid).  A
    dense BLAS product is up to 3x faster alone for nets of a few poles, but on two cores
    its threads slowed the rest of a fit down more than that.
    """
    return grid_product(u_space.collocation(u, nu), v_space.collocation(v, nv), net)


def grid_product(mu, mv, net):
    r""":math:`M_u\,P\,M_v^T` per coordinate for collocation matrices ``mu`` (N_u, k_u)
    and ``mv`` (N_v, k_v) and a net (k_u, k_v, d): the grid of :func:`_grid`, for
    callers that keep the collocation matrices of the spaces they revisit."""
    ku, kv, d = net.shape
    n_u, n_v = mu.shape[0], mv.shape[0]
    rows = (mu @ net.reshape(ku, kv * d)).reshape(n_u, kv, d)
    planes = mv @ rows.transpose(1, 2, 0).reshape(kv, d * n_u)
    return planes.reshape(n_v, d, n_u).transpose(2, 0, 1)


def _rational_derivative(evaluate, homogeneous, u, nu):
    """Derivatives of ``x = X / w`` from those of the homogeneous curve (order <= 2)."""
    if nu > 2:
        raise InvalidInputError("rational curves evaluate derivatives up to order 2.")
    h = [evaluate(homogeneous, u, k) for k in range(nu + 1)]
    w = [hk[:, -1:] for hk in h]
    x = h[0][:, :-1] / w[0]
    if nu == 0:
        return x
    d1 = (h[1][:, :-1] - w[1] * x) / w[0]
    if nu == 1:
        return d1
    return (h[2][:, :-1] - 2 * w[1] * d1 - w[2] * x) / w[0]


def _rational_grid(surface, u, v, nu, nv):
    """Partial derivatives of a rational surface (total order <= 2), quotient rule."""
    hom = surface.homogeneous()
    H = {(a, b): _grid(surface.u_space, surface.v_space, hom, u, v, a, b)
         for a in range(nu + 1) for b in range(nv + 1)}
    W = {key: val[..., -1:] for key, val in H.items()}
    S = {}
    for a in range(nu + 1):
        for b in range(nv + 1):
            val = H[(a, b)][..., :-1].copy()
            for i in range(a + 1):
                for j in range(b + 1):
                    if i == 0 and j == 0:
                        continue
                    coef = _binom(a, i) * _binom(b, j)
                    val -= coef * W[(i, j)] * S[(a - i, b - j)]
            S[(a, b)] = val / W[(0, 0)]
    return S[(nu, nv)]


def _binom(n, k):
    from math import comb

    return comb(n, k)


def split_pair(value, name):
    """``(u, v)`` from one value for both directions or a pair; ``(None, None)`` for
    ``None``; :class:`InvalidInputError` for anything else."""
    if value is None:
        return None, None
    if np.ndim(value) == 0:
        return value, value
    if len(value) != 2:
        raise InvalidInputError(f"{name} must be one value or a pair (u, v), got {value!r}.")
    return tuple(value)


def _check_scale(arr, name):
    """Refuse coordinates beyond ``COORDINATE_LIMIT`` and a non-zero extent below
    ``EXTENT_FLOOR`` (squared distances would overflow or underflow)."""
    largest = float(np.abs(arr).max(initial=0.0))
    if largest > COORDINATE_LIMIT:
        raise InvalidInputError(
            f"{name} reach {largest:.3g} in magnitude; coordinates up to "
            f"{COORDINATE_LIMIT:.0e} are supported: express the model in larger units."
        )
    flat = arr.reshape(-1, arr.shape[-1])
    extent = float((flat.max(axis=0) - flat.min(axis=0)).max()) if flat.size else 0.0
    if 0.0 < extent < EXTENT_FLOOR:
        raise InvalidInputError(
            f"{name} span only {extent:.3g} model units; extents from {EXTENT_FLOOR:.0e} "
            "are supported (or all points coincident): express the model in smaller units."
        )


def as_poles(poles, name="poles", ndim=2):
    """Validate a pole array: float, finite, of ``ndim`` axes, last axis 1..4 coordinates."""
    arr = real_array(poles, name)
    if arr.ndim != ndim:
        expected = "(k, d)" if ndim == 2 else "(k_u, k_v, d)"
        raise InvalidInputError(
            f"{name} must have shape {expected}, got an array of shape {arr.shape}."
        )
    if arr.shape[-1] < 1 or arr.shape[-1] > 4:
        raise InvalidInputError(
            f"{name} must have 1 to 4 coordinates per point (last axis), got {arr.shape[-1]}."
        )
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise InvalidInputError(
            f"{name} contain NaN or inf (first at index {tuple(int(i) for i in bad)}); "
            "repair or drop those points before fairing."
        )
    _check_scale(arr, name)
    return arr


def _as_weights(weights, shape):
    if weights is None:
        return None
    w = real_array(weights, "weights")
    if w.shape != tuple(shape):
        raise InvalidInputError(f"weights must have shape {tuple(shape)}, got {w.shape}.")
    bad = np.argwhere(~np.isfinite(w) | (w <= 0))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        raise InvalidInputError(
            f"weights must be finite and positive; weight {index} is {float(w[index])!r}. "
            "NaN, inf, zero or negative weights do not define a valid NURBS."
        )
    return None if np.all(w == 1.0) else w


def _check_degree(degree, name="degree"):
    """An integer >= 1, else :class:`InvalidInputError` naming the argument."""
    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
        raise InvalidInputError(f"{name} must be an integer >= 1, got {degree!r}; e.g. {name}=3.")
    return int(degree)


def _default_knots(k, degree, what="curve"):
    if k < degree + 1:
        raise InvalidInputError(
            f"a degree-{degree} {what} needs at least {degree + 1} poles, got {k}; "
            "pass more points or a lower degree."
        )
    return SplineSpace.quasi_uniform(k - degree, degree).knots


def make_curve(poles: ArrayLike, knots: ArrayLike | None = None, degree: int | None = None,
               weights: ArrayLike | None = None) -> BSplineCurve:
    """Validated :class:`BSplineCurve`; without knots, quasi-uniform of degree 3.

    Raises
    ------
    InvalidInputError
        On a wrong shape, NaN/inf, too few poles, bad knots or bad weights.
    """
    P = as_poles(poles, "poles", 2)
    degree = 3 if degree is None else _check_degree(degree)
    if knots is None:
        space = SplineSpace.from_knots(_default_knots(P.shape[0], degree), degree)
    else:
        space = SplineSpace.from_knots(knots, degree)
    if space.dimension != P.shape[0]:
        raise InvalidInputError(
            f"{P.shape[0]} poles need {P.shape[0] + degree + 1} knots for degree {degree}, "
            f"got {space.knots.size}."
        )
    return BSplineCurve(P, space.knots, space.degree, _as_weights(weights, P.shape[:1]))


def make_surface(poles: ArrayLike, u_knots: ArrayLike | None = None,
                 v_knots: ArrayLike | None = None,
                 degree: int | tuple[int, int] | None = None,
                 weights: ArrayLike | None = None) -> BSplineSurface:
    """Validated :class:`BSplineSurface`; ``degree`` is an int or ``(u_degree, v_degree)``.

    Raises
    ------
    InvalidInputError
        On a wrong shape, NaN/inf, too few poles, bad knots or bad weights.
    """
    P = as_poles(poles, "poles", 3)
    du, dv = (3, 3) if degree is None else split_pair(degree, "degree")
    spaces = []
    for knots, k, d, name in ((u_knots, P.shape[0], du, "u"), (v_knots, P.shape[1], dv, "v")):
        d = _check_degree(d)
        t = _default_knots(k, d, f"surface (direction {name})") if knots is None else knots
        space = SplineSpace.from_knots(t, d)
        if space.dimension != k:
            raise InvalidInputError(
                f"{k} poles in {name} need {k + d + 1} {name}_knots for degree {d}, "
                f"got {space.knots.size}."
            )
        spaces.append(space)
    return BSplineSurface(P, spaces[0].knots, spaces[1].knots, spaces[0].degree,
                          spaces[1].degree, _as_weights(weights, P.shape[:2]))


def collapsed_rows(surface):
    """``[(axis, end, point)]`` of the border rows whose poles all lie at one point."""
    size = extent(surface.poles)
    out = []
    for axis in (0, 1):
        rows = np.moveaxis(surface.poles, axis, 0)
        for end in (0, -1):
            if np.ptp(rows[end], axis=0).max() <= COINCIDENT * size:
                out.append((axis, end, rows[end].mean(axis=0)))
    return out


def collapsed_kept(source, faired):
    """``faired`` with every border row that is collapsed in ``source`` (the pole of a
    sphere-like face, the nose of a fuselage) put back onto its point: a projection alone
    spreads it, and a faired face's degenerated edge must stay one point (a STEP file
    of faces that meet at such a point reads back with unclosed wires otherwise)."""
    return collapse_rows(faired, collapsed_rows(source))


def collapse_rows(surface, collapsed):
    """Put every border row of ``collapsed`` back onto its point (weights unchanged)."""
    if not collapsed:
        return surface
    poles = surface.poles.copy()
    for axis, end, point in collapsed:
        np.moveaxis(poles, axis, 0)[end] = point
    return replace(surface, poles=poles)
