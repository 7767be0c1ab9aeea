"""The numerical core of cq-fairing: numpy and scipy only.

Modules
-------
spaces         clamped B-spline spaces, basis functions and derivatives
gram           exact banded Gram matrices (Gauss-Legendre on merged knots)
banded         banded Cholesky solves
wavelets       compact wavelets as the null space of <Phi_n|Phi_S>
decomposition  one ARWFA/DWFA step: projection, details, exact reconstruction
schedule       direct, dyadic and hybrid schedules
geometry       immutable curve and surface objects
taylor         spline pieces in Taylor form: fast evaluation at scattered parameters
fairing        fair_curve / fair_surface and their results
interpolation  data points to control points
measures       deviation (true closest-point distance) and fairness measures
regions        where a trimmed face lies on a parameter grid (trim polygon, exact near it)
accuracy       accuracy control: the fewest poles within a tolerance
adaptive       adaptive (non-uniform) targets, energy polish and constrained stages
weighted       span-weighted L2 projections
fidelity       noise level and the discrepancy principle
energy         Eck-Hadenfeld energy fairing
joins          joint projection of patches meeting along borders: closed and smooth joins
patch_grid     a regular grid of patches as one surface, and split back exactly
robustness     conditioning reports and local frames
examples       synthetic geometry with a noise-free truth
"""
