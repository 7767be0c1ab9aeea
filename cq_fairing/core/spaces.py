r"""Clamped B-spline spaces and their basis functions.

A space :math:`S = \operatorname{span}\{N_{i,p}\}_{i=0}^{k-1}` is fixed by its degree
:math:`p` and a clamped, non-decreasing knot vector
:math:`t_0 = \dots = t_p < t_{p+1} \le \dots < t_k = \dots = t_{k+p}` of length
:math:`k + p + 1`.  The parameter domain is :math:`[t_p, t_k]`.

The seeds' quasi-uniform space :math:`V_n` of degree 3 has the knots
:math:`0,0,0,0,1/n,\dots,1-1/n,1,1,1,1` and :math:`n + 3` basis functions
(Ji et al. 2014, section 2.1); :meth:`SplineSpace.quasi_uniform` builds it for
any degree and domain.

This module imports numpy only.
"""

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np

from ..errors import InvalidInputError, InvalidTargetError


def real_array(values, name):
    """``values`` as a float array; :class:`InvalidInputError` for text, complex numbers or
    anything else that is not a real numeric array."""
    numeric = f"{name} must be a numeric array, got {type(values).__name__}."
    try:
        raw = np.asarray(values)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(numeric) from exc
    if raw.dtype.kind == "c":
        raise InvalidInputError(
            f"{name} must be real numbers, got complex numbers; pass the real part "
            "explicitly if that is what you mean."
        )
    try:
        return raw.astype(float)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(numeric) from exc

QUASI_UNIFORM_SPACES = 1024   # quasi-uniform spaces kept (:meth:`SplineSpace.quasi_uniform`)

__all__ = ["SplineSpace", "basis_functions", "find_spans", "require_in_domain", "clamp"]


@dataclass(frozen=True, eq=False)
class SplineSpace:
    """A clamped B-spline space.

    Parameters
    ----------
    degree : int
        Polynomial degree ``p >= 1`` (never "order": order is ``p + 1``).
    knots : ndarray, shape (k + p + 1,)
        Full clamped knot vector (end knots repeated ``p + 1`` times).

    Notes
    -----
    Build spaces with :meth:`from_knots` (validates) or :meth:`quasi_uniform`;
    the constructor itself trusts its arguments, like scipy's
    ``BSpline.construct_fast``.
    """

    degree: int
    knots: np.ndarray

    # -- construction -------------------------------------------------------------
    @classmethod
    def from_knots(cls, knots, degree):
        """Validate a clamped knot vector and build the space.

        Raises
        ------
        InvalidInputError
            If the knots are not finite, not non-decreasing, not clamped, have an
            interior multiplicity above ``degree``, or are too few for ``degree``.
        """
        if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or degree < 1:
            raise InvalidInputError(
                f"degree must be an integer >= 1, got {degree!r}; pass e.g. degree=3."
            )
        degree = int(degree)
        t = real_array(knots, "knots")
        if t.ndim != 1:
            raise InvalidInputError(
                f"knots must be a 1-D array, got shape {t.shape}; pass the full knot vector."
            )
        if t.size < 2 * degree + 2:
            raise InvalidInputError(
                f"a degree-{degree} space needs at least {2 * degree + 2} knots "
                f"({degree + 1} poles), got {t.size}; add knots or lower the degree."
            )
        if not np.all(np.isfinite(t)):
            raise InvalidInputError("knots contain NaN or inf; pass finite knot values.")
        if np.any(np.diff(t) < 0):
            raise InvalidInputError(
                "knots must be non-decreasing; sort them or check the source file."
            )
        if t[degree] >= t[-degree - 1]:
            raise InvalidInputError(
                f"the knot domain [t_p, t_k] = [{t[degree]}, {t[-degree - 1]}] is empty; "
                "the knot vector must span an interval of positive length."
            )
        if np.any(t[: degree + 1] != t[0]) or np.any(t[-degree - 1:] != t[-1]):
            raise InvalidInputError(
                f"knots must be clamped (first and last knot repeated degree + 1 = "
                f"{degree + 1} times); got {t[: degree + 1]} ... {t[-degree - 1:]}. "
                "Convert periodic knots to clamped ones first (the OCP adapter and the "
                "FreeCAD workbench do this for faces)."
            )
        interior = t[degree + 1: -degree - 1]
        if interior.size and (interior[0] <= t[0] or interior[-1] >= t[-1]):
            raise InvalidInputError(
                f"an end knot is repeated more than degree + 1 = {degree + 1} times, which "
                "gives basis functions with empty support; remove the extra end knots."
            )
        if interior.size:
            _, counts = np.unique(interior, return_counts=True)
            if counts.max() > degree:
                raise InvalidInputError(
                    f"an interior knot is repeated {counts.max()} times, more than the "
                    f"degree {degree}; the basis would be discontinuous. Remove the extra knots."
                )
        return cls(degree, t)

    @classmethod
    def quasi_uniform(cls, n, degree=3, domain=(0.0, 1.0)):
        """The space ``V_n``: ``n`` equal spans, ``n + degree`` basis functions.

        Parameters
        ----------
        n : int
            Number of knot spans (the seeds' scale factor), ``n >= 1``.
        degree : int, optional
            Polynomial degree, default 3.
        domain : (float, float), optional
            Parameter interval, default ``(0, 1)``.
        """
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
            raise InvalidTargetError(f"scale n must be an integer >= 1, got {n!r}.")
        return _quasi_uniform(int(n), int(degree), float(domain[0]), float(domain[1]))

    # -- basic facts ----------------------------------------------------------------
    @property
    def dimension(self):
        """Number of basis functions ``k = len(knots) - degree - 1``."""
        return self.knots.size - self.degree - 1

    @property
    def domain(self):
        """Parameter interval ``(t_p, t_k)``."""
        return float(self.knots[self.degree]), float(self.knots[-self.degree - 1])

    @cached_property
    def breakpoints(self):
        """Distinct knot values, shape (spans + 1,)."""
        return np.unique(self.knots)

    @property
    def n_spans(self):
        """Number of non-empty knot spans."""
        return self.breakpoints.size - 1

    @cached_property
    def is_quasi_uniform(self):
        """True when the interior knots are simple and equally spaced."""
        b = self.breakpoints
        if b.size != self.dimension - self.degree + 1:
            return False
        steps = np.diff(b)
        return bool(np.allclose(steps, steps[0], rtol=1e-12, atol=0.0))

    @cached_property
    def greville(self):
        """Greville abscissae, shape (k,): averages of ``degree`` consecutive knots."""
        p, t = self.degree, self.knots
        window = np.lib.stride_tricks.sliding_window_view(t[1:-1], p)
        return window.mean(axis=1)

    @cached_property
    def support(self):
        """Support interval of each basis function, shape (k, 2)."""
        p, t = self.degree, self.knots
        k = self.dimension
        return np.stack([t[:k], t[p + 1: p + 1 + k]], axis=1)

    @cached_property
    def key(self):
        """Hashable identity (degree and knot bytes), used to cache operators."""
        return (self.degree, self.knots.tobytes())

    def same_as(self, other):
        """True when both spaces have the same degree and knots."""
        return self.key == other.key

    # -- evaluation ---------------------------------------------------------------------
    def collocation(self, x, nu=0):
        """Sparse collocation matrix ``M[j, i] = N_i^{(nu)}(x_j)``.

        Parameters
        ----------
        x : array_like, shape (q,)
            Parameters inside the domain.
        nu : int, optional
            Derivative order.

        Returns
        -------
        scipy.sparse.csr_matrix, shape (q, k)
        """
        import scipy.sparse as sp

        x = np.asarray(x, dtype=float).ravel()
        spans = find_spans(self, x)
        values = basis_functions(self, x, spans, nu)[nu]
        p = self.degree
        cols = spans[:, None] - p + np.arange(p + 1)[None, :]
        # row j holds the p + 1 functions from spans[j] - p on, in increasing order: the
        # CSR arrays directly (what the triplet form sorts into, zeros kept, without the sort)
        return sp.csr_matrix(
            (values.ravel(), cols.ravel(), np.arange(0, (x.size + 1) * (p + 1), p + 1)),
            shape=(x.size, self.dimension))

    def basis_values(self, x, order=0):
        """Dense values ``B[nu, j, i] = N_i^{(nu)}(x_j)`` of every basis function and its
        derivatives up to ``order``: the rows of :meth:`collocation` for ``nu = 0 ..
        order`` at once, for a few parameters.

        Returns
        -------
        ndarray, shape (order + 1, q, k)
        """
        x = np.asarray(x, dtype=float).ravel()
        spans = find_spans(self, x)
        values = basis_functions(self, x, spans, order)
        p = self.degree
        out = np.zeros((order + 1, x.size, self.dimension))
        columns = spans[:, None] - p + np.arange(p + 1)
        np.put_along_axis(out, np.broadcast_to(columns, values.shape), values, axis=2)
        return out

    def evaluate(self, coefficients, x, nu=0):
        """Evaluate ``sum_i c_i N_i^{(nu)}(x)``.

        Parameters
        ----------
        coefficients : ndarray, shape (k, ...)
        x : array_like, shape (q,)
        nu : int, optional

        Returns
        -------
        ndarray, shape (q, ...)
        """
        c = np.asarray(coefficients, dtype=float)
        x = np.asarray(x, dtype=float).ravel()
        spans = find_spans(self, x)
        values = basis_functions(self, x, spans, nu)[nu]
        p = self.degree
        idx = spans[:, None] - p + np.arange(p + 1)[None, :]
        gathered = c[idx]  # (q, p+1, ...)
        return np.einsum("qj,qj...->q...", values, gathered)


@lru_cache(maxsize=QUASI_UNIFORM_SPACES)
def _quasi_uniform(n, degree, lo, hi):
    """:meth:`SplineSpace.quasi_uniform`, one space per scale, degree and domain (its
    knots read-only): a tolerance search asks for the same targets again and again, and
    their breakpoints, keys and Taylor forms are then made once."""
    t = np.concatenate([np.full(degree, lo), np.linspace(lo, hi, n + 1), np.full(degree, hi)])
    t.flags.writeable = False
    return SplineSpace(degree, t)


def find_spans(space, x):
    """Index ``mu`` with ``t_mu <= x < t_{mu+1}`` for each parameter (right end closed).

    Parameters
    ----------
    space : SplineSpace
    x : ndarray, shape (q,)

    Returns
    -------
    ndarray of int, shape (q,), values in ``[p, k - 1]``.
    """
    require_in_domain(space, x)
    spans = np.searchsorted(space.knots, x, side="right") - 1
    return clamp(spans, space.degree, space.dimension - 1)


def clamp(x, lo, hi):
    r"""``np.clip(x, lo, hi)``, :math:`\min(\max(x, lo), hi)` elementwise (NaN stays NaN),
    without its argument handling, which under numpy 1.x costs more than the work on
    the few hundred parameters of a Newton step."""
    return np.minimum(np.maximum(x, lo), hi)


def require_in_domain(space, x):
    """Raise :class:`InvalidInputError` unless every parameter ``x`` lies in the domain
    (up to a relative 1e-12)."""
    if not x.size:
        return
    lo, hi = space.domain
    least, largest = x.min(), x.max()
    if np.isnan(least):   # NaN parameters pass (they evaluate to NaN), as they always did
        least, largest = np.nanmin(x), np.nanmax(x)
    if least < lo - 1e-12 * max(1.0, abs(lo)) or largest > hi + 1e-12 * max(1.0, abs(hi)):
        raise InvalidInputError(
            f"parameters must lie in the domain [{lo}, {hi}], got "
            f"[{np.nanmin(x)}, {np.nanmax(x)}]; clip or rescale them."
        )


def basis_functions(space, x, spans, nu=0):
    r"""Non-zero basis functions and derivatives at ``x`` (The NURBS Book, A2.3).

    Parameters
    ----------
    space : SplineSpace
    x : ndarray, shape (q,)
    spans : ndarray of int, shape (q,)
        From :func:`find_spans`.
    nu : int
        Highest derivative order wanted.

    Returns
    -------
    ndarray, shape (nu + 1, q, p + 1)
        ``out[d, j, r] = N^{(d)}_{spans[j] - p + r}(x_j)``; derivatives above the
        degree are zero.
    """
    t, p = space.knots, space.degree
    q = x.size
    # arrays indexed [..., point] so that every vector operation runs on contiguous memory
    left = np.empty((p + 1, q))
    right = np.empty((p + 1, q))
    ndu = np.empty((p + 1, p + 1, q))  # ndu[j, r]: basis (upper), knot diffs (lower)
    ndu[0, 0] = 1.0
    for j in range(1, p + 1):
        left[j] = x - t[spans + 1 - j]
        right[j] = t[spans + j] - x
        saved = np.zeros(q)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    out = np.zeros((nu + 1, p + 1, q))
    out[0] = ndu[:, p]
    if nu > 0:
        out[1:min(nu, p) + 1] = _derivative_rows(ndu, min(nu, p))
    factor = float(p)
    for k in range(1, min(nu, p) + 1):
        out[k] *= factor
        factor *= p - k
    return np.ascontiguousarray(out.transpose(0, 2, 1))


def _derivative_rows(ndu, nu):
    r"""Rows ``1 .. nu`` (``nu <= p``) of A2.3's derivatives before their factors
    :math:`p!/(p-k)!`, from its table ``ndu``, every ``r`` at once.

    Step ``k`` turns the coefficients ``a[r, j]`` of step ``k - 1`` (one before step 1)
    into ``(a[r, j] - a[r, j - 1]) / ndu[p - k + 1, r - k + j]`` and sums
    ``a[r, j] ndu[r - k + j, p - k]``.  For one ``j`` the ``r`` of A2.3's ranges are
    ``k - j .. p - j`` (``r - k + j = 0 .. p - k``), one slice: every value is computed by
    A2.3's operations and the sum in its order of ``j`` (up to the sign of zeros), in a
    few vector operations per ``j`` instead of per ``(r, j)``.

    Returns
    -------
    ndarray, shape (nu, p + 1, q)
    """
    p, q = ndu.shape[0] - 1, ndu.shape[2]
    a = np.ones((p + 1, 1, q))
    rows = np.zeros((nu, p + 1, q))
    for k in range(1, nu + 1):
        pk = p - k
        new = np.empty((p + 1, k + 1, q))   # entries outside the ranges are never read
        for j in range(k + 1):
            r = slice(k - j, p - j + 1)
            if j == 0:
                numerator = a[r, 0]
            elif j == k:
                numerator = -a[r, k - 1]
            else:
                numerator = a[r, j] - a[r, j - 1]
            new[r, j] = _safe_divide(numerator, ndu[pk + 1, :pk + 1])
            rows[k - 1, r] = rows[k - 1, r] + new[r, j] * ndu[:pk + 1, pk]
        a = new
    return rows


def _safe_divide(numerator, denominator):
    """``numerator / denominator`` with 0 where the denominator is 0 (repeated knots)."""
    out = np.zeros_like(numerator)
    np.divide(numerator, denominator, out=out, where=denominator != 0)
    return out
