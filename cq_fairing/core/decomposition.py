r"""One multiresolution step: L2 projection, wavelet details and exact reconstruction.

For a source space :math:`S` (any degree, any clamped knots; the seeds' :math:`V_m`)
and a target space :math:`V_n` on the same domain (Ji et al. 2014, eq. 4-14):

.. math::

    C_n &= A\,C_S, \qquad A = \langle\Phi_n|\Phi_n\rangle^{-1}\langle\Phi_n|\Phi_S\rangle
          = G_{nn}^{-1} E                                            && (5\text{-}7)\\
    D_n &= B\,C_S, \qquad B = \langle\Psi_n|\Psi_n\rangle^{-1}\langle\Psi_n|\Phi_S\rangle
          = (Q^T G_{SS} Q)^{-1} Q^T G_{SS}                            && (8\text{-}10)\\
    C_S &= [P\,|\,Q_r] \begin{bmatrix} C_n \\ D_n\end{bmatrix},
          \qquad [P\,|\,Q_r] = \begin{bmatrix} A \\ B\end{bmatrix}^{-1}  && (11\text{-}14)

where :math:`\Psi_n = \Phi_S Q` are the compact wavelets of
:mod:`cq_fairing.core.wavelets`.  :math:`C_n` is the coefficient vector of the
L2-best approximation of the source curve in :math:`V_n`.

Nothing dense of size ``k x k`` is formed: :math:`G_{nn}` and :math:`Q^T G_{SS} Q` are
banded SPD (banded Cholesky), and reconstruction solves the sparse square system
:math:`[E;\ Q^T G_{SS}]\, C_S = [G_{nn} C_n;\ Q^T G_{SS} Q\, D_n]` with one sparse LU,
so it is exact to rounding whether or not :math:`E Q` vanishes to the last digit.

When :math:`V_n \subset S` (nested spaces, e.g. dyadic DWFA steps), :math:`P` is the
knot-insertion refinement matrix (:func:`refinement_matrix`), sparse and exact.

Conditioning guard
------------------
A solve with condition number :math:`\kappa` may lose a relative :math:`\kappa\,
\varepsilon_{mach}`.  The wavelet Gram :math:`Q^T G_{SS} Q` (details) and the synthesis
matrix :math:`[E;\ Q^T G_{SS}]` (reconstruction) have their 1-norm condition estimated
(:func:`~cq_fairing.core.banded.condition_1`) when they are factored; above
:data:`WAVELET_CONDITION_LIMIT` and :data:`CONDITION_LIMIT` a :class:`~cq_fairing.errors.NumericalError` refuses the details
or the reconstruction instead of returning inexact ones.  Large :math:`\kappa` comes
from one step of a large span ratio (the wavelet Gram grows like :math:`(m/n)^8`,
:mod:`cq_fairing.core.schedule`) or from a target the source barely resolves
(synthesis).  The coarse projection only needs :math:`G_{nn}` (:math:`\kappa < 40`)
and is never refused.
"""

from functools import cached_property, lru_cache

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import NumericalError
from .banded import BandedSPD, condition_1
from .gram import gram_matrix
from .wavelets import COMPACT_RATIO_LIMIT, nonpivot_columns, row_ranges, wavelet_matrix

__all__ = ["Decomposition", "decomposition", "refinement_matrix", "is_subspace",
           "CONDITION_LIMIT", "WAVELET_CONDITION_LIMIT"]

CONDITION_LIMIT = 1e8
r"""Largest estimated 1-norm condition number of the synthesis matrix a step accepts
(reconstruction).  Measured reconstruction errors are about :math:`0.03\,\kappa
\varepsilon_{mach}`, below 1e-9 relative at the limit."""

WAVELET_CONDITION_LIMIT = 1e9
r"""Largest estimated 1-norm condition number of the wavelet Gram a step accepts
(details).  Its effect on reconstruction is damped: measured errors are about
:math:`3\cdot 10^{-3}\,\kappa\varepsilon_{mach}`, below 1e-9 relative at the limit.
Every step of the default ladder stays below 1e5, one direct step of span ratio 16 near
2.5e7 and of ratio 24 near 4e8 (quasi-uniform cubic spaces); ratio 100 reaches 2e10."""


class Decomposition:
    """The analysis and synthesis operators between a source and a target space.

    Parameters
    ----------
    source, target : SplineSpace
        ``target.dimension < source.dimension``, same domain.

    Notes
    -----
    Operators are built lazily: a coarse projection (all accuracy control needs)
    never builds wavelets.  Obtain instances through :func:`decomposition`, which
    caches them per pair of spaces.
    """

    def __init__(self, source, target):
        self.source = source
        self.target = target

    # -- matrices -------------------------------------------------------------------
    @cached_property
    def E(self):
        r""":math:`\langle\Phi_n|\Phi_S\rangle`, sparse, shape (r, k)."""
        return gram_matrix(self.target, self.source).tocsr()

    @cached_property
    def target_gram(self):
        r"""Banded Cholesky of :math:`G_{nn} = \langle\Phi_n|\Phi_n\rangle`."""
        return BandedSPD(gram_matrix(self.target))

    @cached_property
    def source_gram(self):
        r""":math:`G_{SS} = \langle\Phi_S|\Phi_S\rangle`, sparse, shape (k, k)."""
        return gram_matrix(self.source).tocsr()

    @cached_property
    def Q(self):
        """Compact wavelets in the source basis, sparse, shape (k, k - r)."""
        source_spans = self.source.dimension - self.source.degree
        compact = self.nested or self.target.n_spans <= COMPACT_RATIO_LIMIT * source_spans
        return wavelet_matrix(self.E, compact=compact).tocsc()

    @cached_property
    def _wavelet_moments(self):
        r""":math:`Q^T G_{SS}`, sparse, shape (k - r, k)."""
        return (self.Q.T @ self.source_gram).tocsr()

    @cached_property
    def wavelet_gram(self):
        r"""Banded Cholesky of :math:`\langle\Psi_n|\Psi_n\rangle = Q^T G_{SS} Q`.

        Raises
        ------
        NumericalError
            If it is not positive definite or its condition exceeds
            :data:`WAVELET_CONDITION_LIMIT`.
        """
        matrix = self._wavelet_moments @ self.Q
        try:
            gram = BandedSPD(matrix)
        except NumericalError as exc:
            raise NumericalError(self._wavelet_message("is not positive definite")) from exc
        kappa = gram.condition_estimate()
        if kappa > WAVELET_CONDITION_LIMIT:
            raise NumericalError(self._wavelet_message(
                f"has condition number {kappa:.1e}, above the limit {WAVELET_CONDITION_LIMIT:.0e}"))
        return gram

    def _wavelet_message(self, what):
        m, n = self.source.n_spans, self.target.n_spans
        return (f"the wavelet Gram <Psi|Psi> of the step from {m} to {n} knot spans (ratio "
                f"{m / n:.3g}) {what}: its details "
                "and reconstruction would lose digits. One step is well conditioned up to a "
                "span ratio of about 16: with schedule='direct' use schedule='auto' (same "
                "faired result through steps of ratio 2 to 6); otherwise choose a target "
                "closer to the source.")

    @cached_property
    def _synthesis_lu(self):
        """Sparse LU of the stacked analysis matrix ``[E; Q^T G_SS]`` (k x k).

        Raises
        ------
        NumericalError
            If it is singular or its condition exceeds :data:`CONDITION_LIMIT`.
        """
        stacked = sp.vstack([self.E, self._wavelet_moments]).tocsc()
        try:
            lu = spla.splu(stacked)
        except RuntimeError as exc:  # SuperLU: "Factor is exactly singular"
            raise NumericalError(self._synthesis_message(f"is singular ({exc})")) from exc
        kappa = condition_1(stacked, lu.solve, lambda x: lu.solve(x, trans="T"))
        if kappa > CONDITION_LIMIT:
            raise NumericalError(self._synthesis_message(
                f"has condition number {kappa:.1e}, above the limit {CONDITION_LIMIT:.0e}"))
        return lu

    def _synthesis_message(self, what):
        return (f"reconstruction from {self.target.dimension} target poles to the source's "
                f"{self.source.dimension} is refused: the synthesis matrix [E; Q^T G] {what}, "
                "because the source barely resolves "
                "the target (its knots are locally sparser than the target's). The faired "
                "poles are accurate; for exact details and reconstruction choose a smaller n.")

    @cached_property
    def matched_rank(self):
        """Rank of ``E`` implied by its sparsity (greedy matching of columns to rows), cheaply."""
        lo, hi = row_ranges(self.E)
        return min(nonpivot_columns(lo, hi)[1], self.target.dimension)

    @property
    def resolves_target(self):
        """True when ``E`` has full row rank by its sparsity (:attr:`matched_rank`).

        Checked before building wavelets; a ``False`` means the target space is locally
        finer than the source and the decomposition is not invertible.
        """
        return self.matched_rank >= self.target.dimension

    @cached_property
    def nested(self):
        """True when the target space is a subspace of the source space."""
        return is_subspace(self.target, self.source)

    @cached_property
    def refinement(self):
        """Knot-insertion matrix ``R`` with ``Phi_n = Phi_S R`` (nested spaces only)."""
        return refinement_matrix(self.target, self.source)

    # -- operations on coefficient arrays (first axis = basis index) --------------------
    def coarse(self, coefficients):
        """``C_n = G_nn^{-1} E C_S``: the L2-best approximation in the target space."""
        c = np.asarray(coefficients, dtype=float)
        flat = _flat(c)
        return self.target_gram.solve(self.E @ flat).reshape((self.target.dimension,) + c.shape[1:])

    def detail(self, coefficients):
        """``D_n = (Q^T G Q)^{-1} Q^T G C_S``: the wavelet coefficients."""
        c = np.asarray(coefficients, dtype=float)
        flat = _flat(c)
        return self.wavelet_gram.solve(self._wavelet_moments @ flat).reshape(
            (self.Q.shape[1],) + c.shape[1:]
        )

    def reconstruct(self, coarse, detail):
        """Exact inverse of (:meth:`coarse`, :meth:`detail`): ``C_S = P C_n + Q_r D_n``."""
        cn = np.asarray(coarse, dtype=float)
        dn = np.asarray(detail, dtype=float)
        rhs_top = self.target_gram_matrix @ _flat(cn)
        rhs_bottom = (self._wavelet_moments @ self.Q) @ _flat(dn)
        rhs = np.vstack([rhs_top, rhs_bottom])
        if rhs.shape[1] == 0:
            return np.zeros((self.source.dimension,) + cn.shape[1:])
        return self._synthesis_lu.solve(rhs).reshape((self.source.dimension,) + cn.shape[1:])

    def upsample(self, coarse):
        """``P C_n``: the source-space coefficients of the coarse part alone.

        For nested spaces this is exact knot insertion (the same curve); otherwise
        the minimum-norm source function whose projection is the coarse curve.
        """
        cn = np.asarray(coarse, dtype=float)
        if self.nested:
            flat = _flat(cn)
            return (self.refinement @ flat).reshape((self.source.dimension,) + cn.shape[1:])
        zero = np.zeros((self.source.dimension - self.target.dimension,) + cn.shape[1:])
        return self.reconstruct(cn, zero)

    @cached_property
    def target_gram_matrix(self):
        """:math:`G_{nn}` as a sparse matrix."""
        return gram_matrix(self.target).tocsr()


def _flat(array):
    """View (k, ...) as (k, prod(...)), also when a trailing axis is empty."""
    return array.reshape(array.shape[0], int(np.prod(array.shape[1:], dtype=int)))


@lru_cache(maxsize=64)
def _cached_decomposition(source_key, target_key):
    source, target = _SPACE_REGISTRY[source_key], _SPACE_REGISTRY[target_key]
    return Decomposition(source, target)


_SPACE_REGISTRY = {}


def decomposition(source, target):
    """Cached :class:`Decomposition` for a pair of spaces (keyed by degree and knots)."""
    _SPACE_REGISTRY.setdefault(source.key, source)
    _SPACE_REGISTRY.setdefault(target.key, target)
    if len(_SPACE_REGISTRY) > 512:
        _SPACE_REGISTRY.clear()
        _cached_decomposition.cache_clear()
        _SPACE_REGISTRY[source.key] = source
        _SPACE_REGISTRY[target.key] = target
    return _cached_decomposition(source.key, target.key)


def is_subspace(coarse, fine, rtol=1e-12):
    """True when every spline of ``coarse`` is also a spline of ``fine``.

    Holds for equal degrees when each interior knot of ``coarse`` appears in ``fine``
    with at least the same multiplicity (knots compared to ``rtol`` of the domain).
    """
    if coarse.degree != fine.degree or coarse.domain != fine.domain:
        return False
    lo, hi = coarse.domain
    tol = rtol * (hi - lo)
    p = coarse.degree
    fine_inner = fine.knots[p + 1: -p - 1]
    for value, count in zip(*np.unique(coarse.knots[p + 1: -p - 1], return_counts=True)):
        if np.count_nonzero(np.abs(fine_inner - value) <= tol) < count:
            return False
    return True


def refinement_matrix(coarse, fine):
    r"""Knot-insertion matrix ``R`` (fine x coarse) with :math:`\Phi_c = \Phi_f R`.

    Oslo algorithm (Cohen, Lyche, Riesenfeld 1980) in the matrix-product form of
    Lyche and Mørken: row ``j`` holds the discrete B-splines
    :math:`\alpha_{\mu-p..\mu}(j) = R_1(t_{j+1}) \cdots R_p(t_{j+p})`, where
    ``tau_mu <= t_j < tau_{mu+1}``.  This is the seeds' dyadic ``P_j`` when the
    fine knots are the coarse ones with every span halved.

    Parameters
    ----------
    coarse, fine : SplineSpace
        ``coarse`` must be a subspace of ``fine`` (:func:`is_subspace`).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (k_fine, k_coarse)
    """
    tau, t, p = coarse.knots, fine.knots, coarse.degree
    k_fine, k_coarse = fine.dimension, coarse.dimension
    rows, cols, vals = [], [], []
    for j in range(k_fine):
        mu = int(np.searchsorted(tau, t[j], side="right") - 1)
        mu = min(max(mu, p), k_coarse - 1)
        b = np.ones(1)
        for k in range(1, p + 1):
            x = t[j + k]
            left = tau[mu - k + 1: mu + 1]
            right = tau[mu + 1: mu + k + 1]
            denom = right - left
            w = np.divide(x - left, denom, out=np.zeros(k), where=denom > 0)
            nb = np.zeros(k + 1)
            nb[:-1] += (1.0 - w) * b
            nb[1:] += w * b
            b = nb
        rows.append(np.full(p + 1, j))
        cols.append(np.arange(mu - p, mu + 1))
        vals.append(b)
    return sp.csr_matrix(
        (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
        shape=(k_fine, k_coarse),
    )
