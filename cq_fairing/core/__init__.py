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
results        FairResult / SurfaceFairResult: faired geometry, details, reconstruction
plans          target spaces and the plans of spaces a projection visits
projection     the wavelet projection onto a target space
options        method options of fair_curve / fair_surface, validated once
fairing        fair_curve / fair_surface: validation and dispatch to one method
interpolation  data points to control points
evaluation     sample parameters and derivatives of curves and surfaces
closest_points closest points on curves and surfaces (damped Newton)
enclosing      the smallest ball enclosing a few points (Welzl)
probes         a source sampled once, measured against many candidates
deviations     deviation (true closest-point distance) and deviation maps
fairness       curvature (one implementation), energies, wiggles, fairness summaries
measures       the public names of evaluation, closest_points, probes, deviations, fairness
regions        where a trimmed face lies on a parameter grid (trim polygon, exact near it)
accuracy       accuracy control: the fewest poles within a tolerance
adaptive       adaptive (non-uniform) targets: the method and its public names
adaptive_knots knot families equidistributing an error density
adaptive_counts searches for the smallest passing count of spans
polish         the energy polish and its constrained stages
adaptive_curve fair_curve_adaptive, and its faithful fit where the noise sets the size
auto_curve     the curves' default: the adaptive fit chosen per curve
surface_fit    one adaptive surface fit and its checks
adaptive_surface fair_surface_adaptive
weighted       span-weighted L2 projections
fidelity       noise level and the discrepancy principle
energy         Eck-Hadenfeld energy fairing
joins          joint projection of patches meeting along borders: closed and smooth joins
pinned_projection a face's projection with its joins pinned to its source at samples
patch_grid     a regular grid of patches as one surface, and split back exactly
robustness     conditioning reports and local frames
examples       synthetic geometry with a noise-free truth
"""
