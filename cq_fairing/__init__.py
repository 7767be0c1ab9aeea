"""cq-fairing: multiresolution (ARWFA/DWFA) and energy fairing of B-spline curves and surfaces.

The names below come from the numerical core, which imports only numpy and scipy.  They
are loaded on first use (PEP 562 module ``__getattr__``), so ``import cq_fairing`` and
``cq-fairing --help`` load neither numpy's nor scipy's submodules.  The OCP/CadQuery
layer (:mod:`cq_fairing.occ`), the viewers (:mod:`cq_fairing.viz`) and the command line
(:mod:`cq_fairing.cli`) are imported on demand.
"""

import importlib

from .errors import (
    FairingError,
    FileFormatError,
    InvalidInputError,
    InvalidOutputError,
    InvalidTargetError,
    InvalidToleranceError,
    NumericalError,
    OutputPathError,
    ToleranceNotMetError,
    UnsupportedGeometryError,
)

__version__ = "0.1.0"

# public name -> the core module that defines it
_LAZY = {
    **dict.fromkeys(("fair_curve", "fair_surface"), ".core.fairing"),
    **dict.fromkeys(("FairResult", "SurfaceDetails", "SurfaceFairResult"), ".core.results"),
    **dict.fromkeys(("BSplineCurve", "BSplineSurface", "make_curve", "make_surface"),
                    ".core.geometry"),
    **dict.fromkeys(("classify_points", "resample_height_field"), ".core.clouds"),
    **dict.fromkeys(("interpolate_grid", "interpolate_points", "read_xyz"),
                    ".core.interpolation"),
    "SplineSpace": ".core.spaces",
}

__all__ = [
    "fair_curve", "fair_surface", "FairResult", "SurfaceFairResult", "SurfaceDetails",
    "BSplineCurve", "BSplineSurface", "make_curve", "make_surface", "SplineSpace",
    "interpolate_points", "interpolate_grid", "read_xyz", "classify_points",
    "resample_height_field",
    "FairingError", "InvalidInputError", "InvalidTargetError", "InvalidToleranceError",
    "ToleranceNotMetError", "UnsupportedGeometryError", "NumericalError",
    "FileFormatError", "OutputPathError", "InvalidOutputError",
]


def __getattr__(name):
    """Import the core module behind a public name on first access, then keep the name."""
    if name not in _LAZY:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name], __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
