r"""Deviation and fairness measures between an original and a faired curve or surface:
the public names of :mod:`~cq_fairing.core.evaluation` (samples and derivatives),
:mod:`~cq_fairing.core.closest_points` (foot points by damped Newton iterations),
:mod:`~cq_fairing.core.probes` (samples reused over many candidates),
:mod:`~cq_fairing.core.deviations` (same-parameter and two-sided true distances) and
:mod:`~cq_fairing.core.fairness` (curvatures, bending energies, wiggle counts), in one
place.  Each of those modules states its mathematics.
"""

from .closest_points import (
                             RestartSamples,
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
    "closest_points_surface_restarted", "RestartSamples",
    "CurveProbe", "SurfaceProbe", "deviation", "deviation_map",
    "curve_curvature", "curvature_derivative_energy", "surface_curvatures",
    "bending_energy", "count_extrema", "count_sign_changes", "curve_wiggles",
    "surface_wiggles", "fairness_summary",
]
