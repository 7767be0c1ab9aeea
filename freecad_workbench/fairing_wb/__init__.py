"""FreeCAD "Fairing" workbench: multiresolution fairing of B-spline faces and edges.

Layering (like FreeCAD's FEM and Draft): :mod:`conversion`, :mod:`analysis`, :mod:`make`,
:mod:`feature`, :mod:`points` and :mod:`preferences` work in FreeCAD's App layer
(``freecadcmd``); :mod:`view_provider`, :mod:`task_panel`, :mod:`legend` and
:mod:`commands` need the GUI.  Numbers come from :mod:`cq_fairing` (numpy + scipy);
geometry goes through FreeCAD's own Part module, never OCP.
"""

import os

__version__ = "0.1.0"

RESOURCES = os.path.join(os.path.dirname(os.path.abspath(__file__)), "resources")


def icon_path(name):
    """Absolute path of an SVG icon in ``resources/icons``."""
    return os.path.join(RESOURCES, "icons", name + ".svg")
