r"""Banded symmetric positive definite solves that factor once and solve often.

Gram matrices of B-spline bases are symmetric positive definite and banded
(bandwidth = degree for one space).  :class:`BandedSPD` stores the upper band,
factors it with a banded Cholesky (LAPACK ``pbtrf``) in ``O(k w^2)`` and solves
any number of right-hand sides in ``O(k w)`` each: no dense inverse is ever built.

:func:`kron_solve` solves a tensor-product system direction by direction with two
such factors.  :func:`condition_1` estimates :math:`\kappa_1(A) = \|A\|_1 \|A^{-1}\|_1` of any
factored matrix from a few solves (Hager 1984; Higham 1988, LAPACK ``xLACON``):
deterministic, a lower bound that is within a factor of about 3 in practice.
"""

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..errors import NumericalError

__all__ = ["BandedSPD", "bandwidth", "condition_1", "kron_solve"]


def bandwidth(matrix):
    """Largest ``|i - j|`` over the non-zeros of a sparse matrix."""
    coo = sp.coo_matrix(matrix)
    if coo.nnz == 0:
        return 0
    return int(np.abs(coo.row - coo.col).max())


class BandedSPD:
    """Cholesky factor of a sparse symmetric positive definite banded matrix.

    Parameters
    ----------
    matrix : scipy.sparse matrix, shape (k, k)
        Symmetric positive definite; only its upper band is read.

    Raises
    ------
    NumericalError
        If the matrix is not numerically positive definite.
    """

    def __init__(self, matrix):
        coo = sp.coo_matrix(matrix)
        k = coo.shape[0]
        width = bandwidth(coo)
        upper = coo.col >= coo.row
        band = np.zeros((width + 1, k))
        rows, cols = coo.row[upper], coo.col[upper]
        np.add.at(band, (width + rows - cols, cols), coo.data[upper])
        try:
            self._factor = la.cholesky_banded(band, lower=False)
        except la.LinAlgError as exc:
            raise NumericalError(
                f"a {k}x{k} Gram matrix is not numerically positive definite ({exc}): its "
                "basis is (nearly) linearly dependent; check the knots for collapsed spans."
            ) from exc
        self.size = k
        self.width = width
        self._matrix = sp.csr_matrix(matrix)

    def solve(self, rhs):
        """Solve ``G x = rhs`` for ``rhs`` of shape (k, ...).

        One step of iterative refinement (``x += G^{-1}(rhs - G x)``, a sparse product
        and a second banded solve) recovers the digits lost to ill-conditioning of
        wavelet Gram matrices (condition numbers up to ~1e8 for ``n << m``).
        """
        rhs = np.asarray(rhs, dtype=float)
        flat = rhs.reshape(self.size, int(np.prod(rhs.shape[1:], dtype=int)))
        if flat.size == 0:
            return rhs.copy()
        x = la.cho_solve_banded((self._factor, False), flat, check_finite=False)
        residual = flat - self._matrix @ x
        x += la.cho_solve_banded((self._factor, False), residual, check_finite=False)
        return x.reshape(rhs.shape)

    def condition_estimate(self):
        """:math:`\\kappa_1(G)` estimated from a few solves (:func:`condition_1`)."""
        return condition_1(self._matrix, self.solve, self.solve)


def condition_1(matrix, solve, solve_transposed, iterations=5):
    r"""Estimate :math:`\kappa_1(A) = \|A\|_1 \|A^{-1}\|_1` from solves with ``A`` and ``A^T``.

    Hager's power iteration on :math:`\|A^{-1}x\|_1` over the unit 1-norm ball
    (start :math:`x = \mathbf 1 / k`, then the vertex :math:`e_j` with
    :math:`j = \arg\max_i |(A^{-T}\operatorname{sign}(A^{-1}x))_i|`), with Higham's
    extra test vector :math:`b_i = (-1)^i (1 + i/(k-1))` that guards against the rare
    cases where the iteration stalls.

    Parameters
    ----------
    matrix : scipy.sparse matrix, shape (k, k)
    solve, solve_transposed : callable
        ``x -> A^{-1} x`` and ``x -> A^{-T} x`` for ``x`` of shape (k, 1).
    iterations : int
        At most this many power steps (LAPACK uses 5).

    Returns
    -------
    float
        A lower bound of :math:`\kappa_1(A)`, ``inf`` when a solve is not finite.
    """
    k = matrix.shape[0]
    if k == 0:
        return 1.0
    norm = float(abs(sp.csc_matrix(matrix)).sum(axis=0).max())
    x = np.full((k, 1), 1.0 / k)
    estimate = 0.0
    for _ in range(iterations):
        y = solve(x)
        if not np.all(np.isfinite(y)):
            return float("inf")
        estimate = max(estimate, float(np.abs(y).sum()))
        z = solve_transposed(np.where(y >= 0, 1.0, -1.0))
        j = int(np.argmax(np.abs(z)))
        if np.abs(z[j, 0]) <= float(z[:, 0] @ x[:, 0]):
            break
        x = np.zeros((k, 1))
        x[j] = 1.0
    alternating = ((-1.0) ** np.arange(k) * (1 + np.arange(k) / max(k - 1, 1)))[:, None]
    extra = 2.0 * float(np.abs(solve(alternating)).sum()) / (3.0 * k)
    return norm * max(estimate, extra)


def kron_solve(factor_u, factor_v, rhs):
    r"""Solve :math:`(A_u \otimes A_v)\, x = r` for a net ``rhs`` (k_u, k_v, d): one
    solve per direction, :math:`x = A_u^{-1} r A_v^{-T}` column block by column block.

    ``factor_u`` and ``factor_v`` are factored matrices with a ``solve`` method
    (:class:`BandedSPD`, or a ``scipy.sparse.linalg.splu`` factor)."""
    ku, kv = rhs.shape[:2]
    x = factor_u.solve(rhs.reshape(ku, -1)).reshape(ku, kv, -1)
    y = factor_v.solve(np.swapaxes(x, 0, 1).reshape(kv, -1))
    return np.swapaxes(y.reshape(kv, ku, -1), 0, 1)
