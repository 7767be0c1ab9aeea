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
fairing        fair_curve / fair_surface and their results
interpolation  data points to control points
"""
