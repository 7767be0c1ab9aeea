"""cq-fairing: multiresolution (ARWFA/DWFA) and energy fairing of B-spline curves and surfaces.

The names below come from the numerical core, which imports only numpy and scipy.
The OCP/CadQuery layer (:mod:`cq_fairing.occ`), the viewers (:mod:`cq_fairing.viz`)
and the command line (:mod:`cq_fairing.cli`) are imported on demand.
"""

from .core.fairing import (FairResult, SurfaceDetails, SurfaceFairResult, fair_curve,
                           fair_surface)
from .core.geometry import BSplineCurve, BSplineSurface, make_curve, make_surface
from .core.clouds import classify_points, resample_height_field
from .core.interpolation import interpolate_grid, interpolate_points, read_xyz
from .core.spaces import SplineSpace
from .errors import (FairingError, FileFormatError, InvalidInputError, InvalidOutputError,
                     InvalidTargetError, InvalidToleranceError, NumericalError,
                     OutputPathError, ToleranceNotMetError, UnsupportedGeometryError)

__version__ = "0.1.0"

__all__ = [
    "fair_curve", "fair_surface", "FairResult", "SurfaceFairResult", "SurfaceDetails",
    "BSplineCurve", "BSplineSurface", "make_curve", "make_surface", "SplineSpace",
    "interpolate_points", "interpolate_grid", "read_xyz", "classify_points",
    "resample_height_field",
    "FairingError", "InvalidInputError", "InvalidTargetError", "InvalidToleranceError",
    "ToleranceNotMetError", "UnsupportedGeometryError", "NumericalError",
    "FileFormatError", "OutputPathError", "InvalidOutputError",
]
