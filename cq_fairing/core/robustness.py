r"""Numerical robustness aids: conditioning reports and a local coordinate frame.

Conditioning
------------
A fairing step from a source space :math:`S` (dimension :math:`k`) to a target
:math:`V_n` (dimension :math:`r`) solves three linear systems
(:mod:`cq_fairing.core.decomposition`):

* the target Gram matrix :math:`G_{nn} = \langle\Phi_n|\Phi_n\rangle` (coarse part,
  eq. 5-7 of Ji et al. 2014);
* the wavelet Gram matrix :math:`\langle\Psi|\Psi\rangle = Q^T G_{SS} Q` (details,
  eq. 8-10);
* the synthesis system :math:`[E;\ Q^T G_{SS}]` (reconstruction, eq. 11-14).

Their spectral condition numbers :math:`\kappa_2 = \lambda_{\max}/\lambda_{\min}`
(symmetric positive definite) or :math:`\sigma_{\max}/\sigma_{\min}` bound the relative
error of each solve by roughly :math:`\kappa\,\varepsilon_{mach}`.
:func:`step_conditioning` reports them for one step and :func:`plan_conditioning` for
every step a schedule visits (:mod:`cq_fairing.core.schedule`).  For the Gram matrices
the extreme eigenvalues come from ``scipy.linalg.eig_banded`` on the band, so large
spaces stay cheap; the synthesis matrix is square but not symmetric and its condition
number is computed densely (``numpy.linalg.cond``) only up to :data:`DENSE_LIMIT`
rows, ``nan`` above.

Local frame
-----------
The faired poles :math:`C_n = A\,C_S` are an affine image of the source poles, because
the rows of :math:`A` sum to one (constants lie in every clamped spline space): fairing
commutes with translation and scaling *in exact arithmetic*.  In floating point a part far
from the origin loses :math:`\log_{10}(|c| / \text{size})` digits of its own size,
:math:`|c|` being its distance from the origin.  :class:`LocalFrame` moves the poles to
their bounding-box centre and scales them to unit size before fairing, and maps the
result back: the error is then relative to the part's size, not to its position.
Rational geometry is framed in Cartesian coordinates, which keeps the weights unchanged.

This module imports numpy and scipy only.
"""

from typing import NamedTuple

import numpy as np
import scipy.linalg as la

from ..errors import InvalidInputError
from .decomposition import decomposition
from .gram import gram_matrix
from .plans import checked_plan

__all__ = ["StepConditioning", "step_conditioning", "plan_conditioning",
           "banded_condition", "LocalFrame", "DENSE_LIMIT"]

DENSE_LIMIT = 600
"""Largest source dimension for which the synthesis condition number is computed densely."""


class StepConditioning(NamedTuple):
    """Condition numbers of one decomposition step (``nan`` where not computed).

    Attributes
    ----------
    source_spans, target_spans : int
        Knot spans of the source and target spaces.
    target_gram : float
        :math:`\\kappa_2(G_{nn})`.
    wavelet_gram : float
        :math:`\\kappa_2(Q^T G_{SS} Q)`; ``inf`` when it is not positive definite.
    synthesis : float
        :math:`\\kappa_2([E;\\ Q^T G_{SS}])`; ``nan`` above :data:`DENSE_LIMIT`.
    """

    source_spans: int
    target_spans: int
    target_gram: float
    wavelet_gram: float
    synthesis: float


def banded_condition(matrix):
    r"""Spectral condition number :math:`\lambda_{\max}/\lambda_{\min}` of a sparse SPD band.

    Parameters
    ----------
    matrix : scipy.sparse matrix, shape (k, k)
        Symmetric; only the upper band is read.

    Returns
    -------
    float
        ``inf`` when the smallest eigenvalue is not positive (numerically indefinite).
    """
    coo = matrix.tocoo()
    k = coo.shape[0]
    if k == 0:
        return 1.0
    width = int(np.abs(coo.row - coo.col).max()) if coo.nnz else 0
    upper = coo.col >= coo.row
    band = np.zeros((width + 1, k))
    np.add.at(band, (width + coo.row[upper] - coo.col[upper], coo.col[upper]),
              coo.data[upper])
    low = la.eig_banded(band, eigvals_only=True, select="i", select_range=(0, 0))[0]
    high = la.eig_banded(band, eigvals_only=True, select="i", select_range=(k - 1, k - 1))[0]
    return float(high / low) if low > 0 else float("inf")


def step_conditioning(source, target):
    """Condition numbers of the step ``source -> target`` (see module notes).

    Parameters
    ----------
    source, target : SplineSpace
        ``target.dimension < source.dimension``, same domain.

    Returns
    -------
    StepConditioning
    """
    step = decomposition(source, target)
    wavelets = step._wavelet_moments @ step.Q
    synthesis = float("nan")
    if source.dimension <= DENSE_LIMIT:
        stacked = np.vstack([step.E.toarray(), step._wavelet_moments.toarray()])
        synthesis = float(np.linalg.cond(stacked))
    return StepConditioning(source.n_spans, target.n_spans,
                            banded_condition(gram_matrix(target)),
                            banded_condition(wavelets), synthesis)


def plan_conditioning(source, target, schedule="auto"):
    """:func:`step_conditioning` for every step of a schedule, source first.

    Returns
    -------
    list of StepConditioning
    """
    spaces = checked_plan(source, target, schedule)
    return [step_conditioning(a, b) for a, b in zip(spaces[:-1], spaces[1:])
            if not a.same_as(b)]


class LocalFrame(NamedTuple):
    r"""An affine frame :math:`x_{local} = (x - c) / s` around a set of points.

    Attributes
    ----------
    centre : ndarray, shape (d,)
        Bounding-box centre :math:`c` of the points.
    scale : float
        Half the bounding-box diagonal :math:`s` (1 for coincident points), so local
        coordinates lie in the unit ball.
    """

    centre: np.ndarray
    scale: float

    @classmethod
    def around(cls, points):
        """The frame centred on the bounding box of ``points`` (shape (..., d)), finite only."""
        pts = np.asarray(points, dtype=float)
        if pts.size == 0 or not np.all(np.isfinite(pts)):
            raise InvalidInputError(
                "a local frame needs a non-empty set of finite points; repair NaN/inf first."
            )
        flat = pts.reshape(-1, pts.shape[-1])
        lo, hi = flat.min(axis=0), flat.max(axis=0)
        half = 0.5 * float(np.linalg.norm(hi - lo))
        return cls(0.5 * (lo + hi), half if half > 0 else 1.0)

    def to_local(self, points):
        """Points in the frame: ``(points - centre) / scale``."""
        return (np.asarray(points, dtype=float) - self.centre) / self.scale

    def to_global(self, points):
        """Inverse of :meth:`to_local`: ``points * scale + centre``."""
        return np.asarray(points, dtype=float) * self.scale + self.centre

    def length_to_local(self, length):
        """A length (e.g. a tolerance) in frame units: ``length / scale``."""
        return length / self.scale
