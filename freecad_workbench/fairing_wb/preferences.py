"""User preferences of the workbench (``User parameter:BaseApp/Preferences/Mod/Fairing``).

* ``DefaultTolerance`` (float, mm): 0 means relative, 1e-3 of the model's bounding-box
  diagonal (tolerances default relative to the model's size, never global state).
* ``SampleDensity`` (int): samples per direction of deviation and curvature maps.
* ``ColorLow`` / ``ColorHigh`` (unsigned RGBA ints): the ends of the colour ramp
  (green = 0 to red = max by default).
"""

import FreeCAD

__all__ = ["params", "default_tolerance", "sample_density", "colors", "set_colors",
           "RELATIVE_TOLERANCE", "DENSITY_RANGE"]

PATH = "User parameter:BaseApp/Preferences/Mod/Fairing"
RELATIVE_TOLERANCE = 1e-3
GREEN, RED = (0.0, 0.8, 0.0), (0.9, 0.0, 0.0)


def params():
    return FreeCAD.ParamGet(PATH)


def default_tolerance(shape=None):
    """The preferred tolerance in mm, or ``1e-3 x`` the shape's bounding-box diagonal."""
    value = params().GetFloat("DefaultTolerance", 0.0)
    if value > 0 or shape is None:
        return value if value > 0 else 0.01
    return RELATIVE_TOLERANCE * shape.BoundBox.DiagonalLength


DENSITY_RANGE = (8, 400)  # samples per direction of the maps (the dialog's range)


def sample_density():
    """Samples per direction of the maps, within :data:`DENSITY_RANGE` whatever is saved."""
    low, high = DENSITY_RANGE
    return min(max(low, params().GetInt("SampleDensity", 60)), high)


def _unpack(packed):
    return tuple(((packed >> shift) & 0xFF) / 255.0 for shift in (24, 16, 8))


def _pack(rgb):
    r, g, b = (int(round(255 * c)) & 0xFF for c in rgb)
    return (r << 24) | (g << 16) | (b << 8)


def colors():
    """``(low, high)`` RGB float triples of the colour ramp."""
    p = params()
    return (_unpack(p.GetUnsigned("ColorLow", _pack(GREEN))),
            _unpack(p.GetUnsigned("ColorHigh", _pack(RED))))


def set_colors(low, high):
    params().SetUnsigned("ColorLow", _pack(low))
    params().SetUnsigned("ColorHigh", _pack(high))
