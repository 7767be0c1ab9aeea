r"""Deviation and fairness measures between an original and a faired curve or surface.

This module gathers the public names of :mod:`~cq_fairing.core.evaluation` (samples and
derivatives), :mod:`~cq_fairing.core.closest_points`, :mod:`~cq_fairing.core.probes`,
:mod:`~cq_fairing.core.deviations` and :mod:`~cq_fairing.core.fairness`.

Deviation
---------
Both geometries are sampled at the same dense parameters: ``per_span`` (default 8)
equally spaced parameters in every knot span of the finer space, the ends and all
breakpoints included (:func:`sample_parameters`).  Two distances are offered:

* ``"parametric"``: the same-parameter distance :math:`|A(u) - B(u)|`.  It costs one
  evaluation and is an *upper bound* of the true distance from :math:`A(u)` to the
  geometry :math:`B` (and from :math:`B(u)` to :math:`A`).
* ``"geometric"``: the true (closest-point) distance, in both directions, whose
  maximum is the two-sided Hausdorff estimate

  .. math:: h(A, B) = \max\Bigl(\max_{u} d(A(u), B),\; \max_{u} d(B(u), A)\Bigr).

  The foot point on a curve :math:`C` solves :math:`C'(t)\cdot(C(t) - P) = 0` by Newton's
  method (vectorised over all points, clamped to the domain) started at the nearest
  sample; on a surface the 2x2 Newton system of
  :math:`(S_u\cdot(S-P),\ S_v\cdot(S-P)) = 0` is used, started at the nearest sample
  in a window of :math:`\pm 2` samples around the same parameter (both surfaces share
  their parametrisation).  Every distance returned is the distance to an actual point
  of the geometry, so it can only over-estimate the exact point-to-geometry distance,
  never under-estimate it: tolerance checks stay on the safe side.

Maxima use the cheap bound to skip work: the true distance is computed only at samples
whose same-parameter distance exceeds the running maximum (or the tolerance), in
decreasing order of the bound.

Fairness
--------
Curvature :math:`\kappa = |C'\times C''|/|C'|^3` and torsion
:math:`\tau = (C'\times C'')\cdot C'''/|C'\times C''|^2` along curves; principal, mean
and Gaussian curvature of surfaces from the fundamental forms; the bending energies

.. math::  E_C = \int |C''(t)|^2\,dt, \qquad
           E_S = \iint |S_{uu}|^2 + 2|S_{uv}|^2 + |S_{vv}|^2 \,du\,dv

computed exactly from Gram matrices of derivatives (:func:`~cq_fairing.core.gram.gram_matrix`
with ``nu = 2``, tensor products for surfaces; polynomial geometry); the number of
curvature extrema and of inflections (wiggle count) and
:math:`\int (d\kappa/ds)^2\,ds` along curves.
"""

from .closest_points import (
                             closest_points_curve,
                             closest_points_surface,
                             closest_points_surface_restarted,
)
from .deviations import Deviation, DeviationMap, deviation, deviation_map
from .evaluation import curve_derivatives, sample_parameters, surface_derivatives
from .fairness import (
                             bending_energy,
                             count_extrema,
                             count_sign_changes,
                             curvature_derivative_energy,
                             curve_curvature,
                             curve_wiggles,
                             fairness_summary,
                             surface_curvatures,
                             surface_wiggles,
)
from .geometry import extent
from .probes import CurveProbe, SurfaceProbe

__all__ = [
    "Deviation", "DeviationMap", "sample_parameters", "extent", "curve_derivatives",
    "surface_derivatives", "closest_points_curve", "closest_points_surface",
    "closest_points_surface_restarted",
    "CurveProbe", "SurfaceProbe", "deviation", "deviation_map",
    "curve_curvature", "curvature_derivative_energy", "surface_curvatures",
    "bending_energy", "count_extrema", "count_sign_changes", "curve_wiggles",
    "surface_wiggles", "fairness_summary",
]
