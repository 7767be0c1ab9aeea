r"""Adaptive target spaces and an energy polish: fewer control points at the same tolerance.

The method is described here; its parts live in one module each:
:mod:`~cq_fairing.core.adaptive_knots` (knot families, error densities),
:mod:`~cq_fairing.core.adaptive_counts` (searches on the count of spans),
:mod:`~cq_fairing.core.polish` (the energy polish and its constrained stages),
:mod:`~cq_fairing.core.adaptive_curve` (:func:`fair_curve_adaptive`),
:mod:`~cq_fairing.core.surface_fit` (one surface fit and its checks) and
:mod:`~cq_fairing.core.adaptive_surface` (:func:`fair_surface_adaptive`).  This module
gathers the public names.

The wavelet fairing of :mod:`cq_fairing.core.fairing` projects onto quasi-uniform
spaces :math:`V_n`.  Where the source needs fine knots in one place only, a uniform
target spends poles everywhere.  This module keeps the *exact* L2 projection

.. math:: C_T = \langle\Phi_T|\Phi_T\rangle^{-1}\langle\Phi_T|\Phi_S\rangle C_S

(Ji et al. 2014, eq. 5-7, valid for any clamped target space :math:`T`; the Gram
matrices are exact, :func:`~cq_fairing.core.gram.gram_matrix`) but lets the target's
knots follow the error:

1. **Knot family.**  A target with ``N`` spans has its breakpoints equidistributing a
   piecewise-constant density :math:`\rho` (:math:`\int_{b_j}^{b_{j+1}}\rho = \frac1N\int\rho`).
   The first density is that of the source's own breakpoints, :math:`\rho = 1/h_S`, so
   a uniform source starts from uniform targets and the top of the family is the source
   space itself.
2. **Count.**  Doubling from 4 spans, then bisection on ``N`` (on the pair
   ``(N_u, N_v)`` along the diagonal and per direction for surfaces) for the smallest
   count whose measured deviation is within ``tol``.
3. **Redistribution.**  From the per-span maximum deviation :math:`e_j` of the last
   candidate, a span of width :math:`h_j` would meet :math:`\theta\,\mathrm{tol}` at width
   :math:`h_j(\theta\,\mathrm{tol}/e_j)^{1/(p+1)}` (the :math:`O(h^{p+1})` error of a
   degree-``p`` spline), so the new density is

   .. math:: \rho_j = \frac{1}{h_j}\Bigl(\frac{e_j}{\theta\,\mathrm{tol}}\Bigr)^{1/(p+1)},

   smoothed over neighbouring spans (slowly varying knot spacing keeps the curvature
   calm) and floored at a fraction of its mean.  The count is lowered one span at a
   time (per direction for surfaces, by doubling strides while the last candidate
   stays below half the tolerance), each with a few redistribution rounds, while the
   tolerance holds.
4. **Polish.**  The remaining budget :math:`\mathrm{tol} - e_{\max}` is spent on fairness:
   the penalised projection

   .. math:: (G_T + \lambda\, G^{(l)}_T)\, C = \langle\Phi_T|\Phi_S\rangle C_S

   (curves: :math:`G^{(3)}`, the energy of Eck and Hadenfeld with ``l = 3``; surfaces:
   its tensor counterpart, :func:`variation_energy_matrix`) with the largest
   :math:`\lambda` (bisection on :math:`\log\lambda`) whose deviation is within ``tol``.
   :math:`\lambda = 0` is the plain L2 projection, so the polish never loses the
   tolerance.  Surfaces go on (:func:`_constrained_stages`): that :math:`\lambda` is set
   by the few patches that reach tol first, so :math:`\lambda` grows further while the
   distance to the source is weighted more on exactly those patches
   (:mod:`cq_fairing.core.weighted`, iteratively reweighted), towards the fairest surface
   within tol, :math:`\min E(S)` subject to the deviation limit.  On the noisy 50 x 80
   blade at tol 0.02 this lowers the curvature-derivative energy of the iso-lines from
   2.1e4 to 3.8e3 and the distance to the noise-free truth from 0.0073 to 0.0057.

Every accepted candidate is checked with the true (closest-point, two-sided) distance
of :mod:`cq_fairing.core.measures` at dense samples (``per_span`` per source span):
the same-parameter distance is an upper bound, so the true distance is computed only
where that bound exceeds the tolerance (largest first, stopping at the first true
excess); the error densities use the bound elsewhere.

The results are :class:`~cq_fairing.core.results.FairResult` /
:class:`~cq_fairing.core.results.SurfaceFairResult` whose ``steps`` are the direct
decomposition source -> target, so ``details`` and ``reconstruct()`` give back the
source exactly for an unpolished result (``polish=False``) with free borders; after
the polish (or with pinned borders, below) the details are still those of the source,
and ``reconstruct()`` returns the source plus the change of the coarse geometry.

5.  **Borders (surfaces).**  The L2 projection spreads its error evenly in the mean, so
    its largest deviation often sits at a corner or on an edge, where fewer basis
    functions overlap.  With pinned borders each border row of the target net is the
    projection of the source's border curve with its end points kept,
    :math:`G_{II}\,x_I = (\langle\Phi_T|\Phi_S\rangle c)_I - G_{IE}\,c_E`, and the
    interior is the projection with the border rows held,
    :math:`(G_u\otimes G_v)_{II}\,X_I = R_I - (G_u\otimes G_v)_{IB}\,X_B`
    (separable, since the interior indices form a tensor grid; the polish adds its
    energy to both).  Corners stay exact, which keeps a B-rep's vertices; on a real
    impeller blade face the compact net drops from 9 x 12 to 8 x 12 poles.

6.  **Rational sources.**  As in the uniform fairing, the projections act on the
    homogeneous net :math:`(w P, w)` (the curve of a rational curve, the surface of a
    rational surface), the candidate is the rational spline of the projected net, and
    its deviation is measured in space against the rational source.  Along a direction
    whose target space contains the source's nothing is approximated: a fillet whose
    section is one rational quadratic span (a circular arc) keeps that section with its
    three poles while the sweep direction is reduced (impeller fillets: 50 x 3 -> 9 x 3
    poles, where a polynomial approximation needs 4 to 6 poles across).  A candidate
    with a weight :math:`\le 0` fails, and so does one with fewer spans along a closed
    direction than :func:`~cq_fairing.core.geometry.fewest_spans` allows.  The energy polish and the objective ``"fair"`` act on
    polynomial geometry and are not applied: the energy of the homogeneous net is not
    that of the surface, and on the impeller fillet of the peer benchmark a polish of it
    lowered the iso-lines' :math:`\int (d\kappa/ds)^2` from 1.81e3 to 1.70e3 but bent
    the circular sections that the projection keeps exact (radius varying by 0.4 %).
"""

from .adaptive_curve import fair_curve_adaptive
from .adaptive_knots import equidistributed_space, error_density
from .adaptive_surface import fair_surface_adaptive
from .polish import net_lengths, variation_energy_matrix

__all__ = ["fair_curve_adaptive", "fair_surface_adaptive", "equidistributed_space",
           "error_density", "net_lengths", "variation_energy_matrix"]
