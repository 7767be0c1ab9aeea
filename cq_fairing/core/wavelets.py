r"""Compactly supported wavelets as the null space of :math:`E = \langle\Phi_n|\Phi_S\rangle`.

The wavelet space :math:`W_n` is the part of the source space :math:`S` that is
orthogonal to the target space :math:`V_n`.  Writing a wavelet in the source basis,
:math:`\psi = \Phi_S q`, orthogonality to every :math:`\varphi^n_i` reads
:math:`E q = 0`: the wavelet matrix :math:`Q` (one column per wavelet) spans the null
space of :math:`E` (Ji et al., *null space wavelet construction*, eq. 8).

Construction (column windows, echelon form)
-------------------------------------------
Scan the columns of :math:`E` from the left.  Because :math:`E` is totally positive
with an interval of (significant) rows per column, the rank of any run of consecutive columns is the
size of a greedy matching between columns and the rows they touch.  Column ``c`` is a
*non-pivot* when it does not raise the rank of the columns before it; there are exactly
``k - r`` of them when ``E`` has full row rank ``r``.  For each non-pivot ``c`` take the
shortest window of columns ``[a, c]`` that has more columns than touched rows and solve

.. math::  E_{[\cdot, a..c-1]}\, x = -E_{[\cdot, c]}, \qquad q = (x, 1)

in the least-squares sense (``q`` is the null vector of the window block closest to
the unit vector of column ``c``, from an SVD); ``q`` vanishes outside ``[a, c]`` (compact support) and its
last non-zero sits at ``c``.  Since the ``c`` differ, ``Q`` is in column echelon form, so
it has full rank ``k - r`` by construction: no duplicate, dependent wavelets, whatever
the ratio ``n/m``.  Each column is scaled so its entry of largest magnitude is ``+1``
(the seed's Table 4 normalisation).

For the seed's example ``m = 10, n = 5`` the windows are columns 1-8, 2-10, 3-11,
4-12 and 6-13 (1-based): within the seed's 9-column windows, whose one-dimensional null
spaces they therefore reproduce.
"""

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from ..errors import NumericalError

__all__ = ["row_ranges", "nonpivot_columns", "wavelet_matrix"]


COMPACT_RATIO_LIMIT = 0.4
"""Above this ratio of target to source spans (non-nested) the shortest windows stop being
numerically dependent (near-coincident knots make them nearly singular) and the true
wavelets decay slowly instead of having short support; an orthonormal null-space
basis from projections onto ker E (banded solves, see ``_fill_global``) is used instead.  The default ladder schedule keeps
every step below 1/3, so this only happens when the target itself keeps more than 40 %
of the source's poles."""


def row_ranges(E, threshold=1e-10):
    """For each column of ``E``, the first and last row holding a significant entry.

    An entry is significant when it exceeds ``threshold`` times the largest entry of
    its column.  Basis functions whose supports barely overlap (knots that are close
    but not equal, such as ``4/7`` and ``67/117``) give entries near rounding level;
    treating them as structural zeros keeps every window well conditioned, at the cost
    of ``E Q`` being zero only to about ``threshold`` relative, which the exact
    reconstruction (a sparse LU of the stacked analysis matrix) does not rely on.

    Returns
    -------
    lo, hi : ndarray of int, shape (k,)
        Non-decreasing in the column index.
    """
    csc = sp.csc_matrix(E)
    k = csc.shape[1]
    col_of = np.repeat(np.arange(k), np.diff(csc.indptr))
    col_max = np.zeros(k)
    np.maximum.at(col_max, col_of, np.abs(csc.data))
    keep = np.abs(csc.data) > threshold * col_max[col_of]
    rows, cols = csc.indices[keep], col_of[keep]
    lo = np.full(k, csc.shape[0])
    hi = np.full(k, -1)
    np.minimum.at(lo, cols, rows)
    np.maximum.at(hi, cols, rows)
    lo = np.maximum.accumulate(lo)
    hi = np.minimum.accumulate(hi[::-1])[::-1]
    return lo, hi


def nonpivot_columns(lo, hi):
    """Columns that do not raise the rank of the columns to their left (greedy matching)."""
    nonpivots = []
    next_row = -1
    for c, (first, last) in enumerate(zip(lo.tolist(), hi.tolist())):
        next_row = max(next_row, first)
        if next_row <= last:
            next_row += 1
        else:
            nonpivots.append(c)
    return np.array(nonpivots, dtype=int), next_row


def _window_starts(columns, lo, hi):
    """Largest ``a <= c`` such that columns ``a..c`` touch fewer rows than they count."""
    starts = np.full(columns.size, -1)
    pending = np.arange(columns.size)
    width = 1
    while pending.size:
        a = columns[pending] - width
        valid = a >= 0
        ok = np.zeros(pending.size, dtype=bool)
        ok[valid] = (width + 1) > (hi[columns[pending[valid]]] - lo[a[valid]] + 1)
        starts[pending[ok]] = a[ok]
        pending = pending[~ok & valid]
        width += 1
    return starts


def _column_band(E, lo, width):
    """``band[j, t] = E[lo[j] + t, j]`` for the rows each column touches."""
    coo = E.tocoo()
    offset = coo.row - lo[coo.col]
    keep = (offset >= 0) & (offset < width)
    band = np.zeros((E.shape[1], width))
    band[coo.col[keep], offset[keep]] = coo.data[keep]
    return band


def _window_blocks(band, lo, starts, ends, n_rows):
    """Dense blocks ``E[lo[a] .. lo[a]+n_rows-1, a..c]`` for windows of equal shape."""
    n_cols = ends[0] - starts[0] + 1
    cols = starts[:, None] + np.arange(n_cols)[None, :]               # (N, W)
    rows = lo[starts][:, None] + np.arange(n_rows)[None, :]           # (N, R)
    offset = rows[:, :, None] - lo[cols][:, None, :]                  # (N, R, W)
    inside = (offset >= 0) & (offset < band.shape[1])
    values = band[cols[:, None, :], np.clip(offset, 0, band.shape[1] - 1)]
    return np.where(inside, values, 0.0)


def _solve_windows(band, lo, hi, starts, ends, rank_tol=1e-10):
    """Null vectors of each window block, projected from the unit vector of its last column.

    For a block ``B`` (touched rows x window columns) with SVD null basis ``N``, the
    vector ``q = N N^T e_last`` is the null vector closest to ``e_last``; it is
    non-zero in the last entry exactly when the last column depends on the others.
    Windows whose last entry is (numerically) zero are returned as failed.
    """
    vectors = [None] * starts.size
    failed = []
    shapes = np.stack([ends - starts + 1, hi[ends] - lo[starts] + 1], axis=1)
    for n_cols, n_rows in np.unique(shapes, axis=0):
        members = np.flatnonzero((shapes[:, 0] == n_cols) & (shapes[:, 1] == n_rows))
        blocks = _window_blocks(band, lo, starts[members], ends[members], int(n_rows))
        _, s, vh = np.linalg.svd(blocks, full_matrices=True)
        padded = np.zeros((members.size, n_cols))
        padded[:, : s.shape[1]] = s
        null = padded <= rank_tol * padded[:, :1]                       # (N, W)
        q = np.einsum("nj,nj,nji->ni", null, vh[:, :, -1], vh)
        peak = np.abs(q).max(axis=1)
        for local, member in enumerate(members):
            if abs(q[local, -1]) > 1e-9 * peak[local]:
                vectors[member] = q[local]
            else:
                failed.append(member)
    return vectors, failed


def wavelet_matrix(E, compact=True):
    r"""Compactly supported, full-rank basis ``Q`` of the null space of ``E``.

    Parameters
    ----------
    E : scipy.sparse matrix, shape (r, k)
        :math:`\langle \Phi_n | \Phi_S \rangle` (target rows, source columns).
    compact : bool, optional
        Build compact column-window wavelets (default).  ``False`` gives an orthonormal
        null-space basis (projections onto :math:`\ker E`, banded solves); :class:`~.decomposition.Decomposition` asks
        for it when the target keeps more than :data:`COMPACT_RATIO_LIMIT` of the
        source's spans and the spaces are not nested.

    Returns
    -------
    scipy.sparse.csc_matrix, shape (k, k - r)
        Column ``i`` holds wavelet ``i`` in the source basis; ``E Q = 0`` up to the
        significance threshold of :func:`row_ranges` (about 1e-10 relative).

    Raises
    ------
    NumericalError
        If ``E`` is not of full row rank (the target space is not resolved by the
        source) or a null vector fails its residual check.
    """
    r, k = E.shape
    lo, hi = row_ranges(E)
    columns, matched = nonpivot_columns(lo, hi)
    if columns.size != k - r or matched < r:
        raise NumericalError(
            f"<Phi_n|Phi_S> ({r}x{k}) has rank {k - columns.size}, expected {r}: the "
            "target space is not resolved by the source space; choose a smaller target."
        )
    if columns.size == 0:
        return sp.csc_matrix((k, 0))
    if not compact:
        vectors, starts = [None] * columns.size, np.zeros(columns.size, dtype=int)
        _fill_global(E, vectors, starts, list(range(columns.size)))
        return _assemble(vectors, starts, k)
    band = _column_band(E, lo, int((hi - lo).max()) + 1)
    starts = _window_starts(columns, lo, hi)
    vectors, failed = _solve_windows(band, lo, hi, starts, columns)
    if failed:  # one retry with windows three times as wide, then global null vectors
        idx = np.array(failed)
        starts[idx] = np.maximum(columns[idx] - 3 * (columns[idx] - starts[idx] + 1), 0)
        retry, _ = _solve_windows(band, lo, hi, starts[idx], columns[idx])
        for j, member in enumerate(idx):
            vectors[member] = retry[j]
    missing = [i for i, v in enumerate(vectors) if v is None]
    if missing:
        _fill_global(E, vectors, starts, missing)
    return _assemble(vectors, starts, k)


def _fill_global(E, vectors, starts, missing):
    r"""Complete the basis with global null vectors where no window is well conditioned.

    This happens when ``n`` is close to ``m``: the wavelets then decay but are not
    compactly supported, and the echelon pivots implied by the sparsity pattern carry
    entries at rounding level.  The ``w = len(missing)`` remaining directions are the
    orthogonal projections onto :math:`\ker E` of fixed pseudo-random vectors
    :math:`Z` (``k x w``, seed 0),

    .. math:: \Pi Z = Z - E^T (E E^T)^{-1} E Z,

    made orthogonal to the compact wavelets already found (then projected again, since
    those satisfy :math:`E q = 0` only to the threshold of :func:`row_ranges`) and
    orthonormalised (QR).
    :math:`E` is banded, so the sparse solve costs about :math:`O(k w p)` instead of
    the :math:`O(k^3)` of a dense SVD of ``E``.  A
    Gaussian :math:`Z` projected onto the ``w``-dimensional complement has rank ``w``
    with probability one; the rank and :math:`E Q = 0` are checked.

    Raises
    ------
    NumericalError
        If ``E`` is numerically rank deficient (the target is not resolved).
    """
    k = E.shape[1]
    E = sp.csr_matrix(E)
    project = _null_projector(E)
    basis = project(np.random.default_rng(0).standard_normal((k, len(missing))))
    found = [i for i, v in enumerate(vectors) if v is not None]
    if found:
        compact = np.zeros((k, len(found)))
        for j, i in enumerate(found):
            compact[starts[i]: starts[i] + vectors[i].size, j] = vectors[i]
        ortho, _ = np.linalg.qr(compact)
        basis = project(basis - ortho @ (ortho.T @ basis))   # compact E q ~ 1e-10 only
    left, right = np.linalg.qr(basis)
    sing = np.linalg.svd(right, compute_uv=False)
    residual = np.abs(E @ left).max() if left.size else 0.0
    if sing[-1] < 1e-8 * sing[0] or residual > 1e-8 * np.abs(E.data).max():
        raise NumericalError(_UNRESOLVED.format(f"null-space residual {residual:.1e}"))
    for j, i in enumerate(missing):
        vectors[i] = left[:, j]
        starts[i] = 0


_UNRESOLVED = ("wavelet construction failed: <Phi_n|Phi_S> does not have full row rank "
               "numerically ({}); the target space is not resolved by the source. Choose "
               "a smaller target.")


def _null_projector(E):
    r"""The orthogonal projector :math:`z \mapsto \Pi z` onto :math:`\ker E`.

    Solves the augmented system :math:`\begin{bmatrix} I & E^T \\ E & 0\end{bmatrix}
    \begin{bmatrix} x \\ y\end{bmatrix} = \begin{bmatrix} z \\ 0\end{bmatrix}`
    (sparse LU; its conditioning is that of :math:`E`, not of :math:`E E^T`), with one
    step of iterative refinement; :math:`x = \Pi z`.
    """
    r, k = E.shape
    augmented = sp.bmat([[sp.identity(k), E.T], [E, None]], format="csc")
    try:
        lu = splu(augmented)
    except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
        raise NumericalError(_UNRESOLVED.format("E is singular")) from exc

    def project(z):
        rhs = np.vstack([z, np.zeros((r, z.shape[1]))])
        x = lu.solve(rhs)
        x += lu.solve(rhs - augmented @ x)
        return x[:k]

    return project


def _assemble(vectors, starts, k):
    """Stack window vectors into a sparse matrix, each scaled to max entry +1."""
    data, rows, cols = [], [], []
    for i, (q, a) in enumerate(zip(vectors, starts)):
        peak = q[np.argmax(np.abs(q))]
        data.append(q / peak)
        rows.append(np.arange(a, a + q.size))
        cols.append(np.full(q.size, i))
    return sp.csc_matrix(
        (np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))),
        shape=(k, len(vectors)),
    )
