"""FreeCAD "Fairing" workbench: multiresolution fairing of B-spline faces and edges.

Layering (like FreeCAD's FEM and Draft): :mod:`conversion`, :mod:`analysis`, :mod:`make`,
:mod:`feature`, :mod:`points` and :mod:`preferences` work in FreeCAD's App layer
(``freecadcmd``); :mod:`view_provider`, :mod:`task_panel`, :mod:`legend` and
:mod:`commands` need the GUI.  Numbers come from :mod:`cq_fairing` (numpy + scipy);
geometry goes through FreeCAD's own Part module, never OCP.
"""

import importlib.util
import os
import sys

__version__ = "0.1.0"

HERE = os.path.dirname(os.path.realpath(__file__))
RESOURCES = os.path.join(HERE, "resources")
CLONE_ROOT = os.path.dirname(os.path.dirname(HERE))


def icon_path(name):
    """Absolute path of an SVG icon in ``resources/icons``."""
    return os.path.join(RESOURCES, "icons", name + ".svg")


def find_core():
    """Make ``cq_fairing`` importable from the repository this workbench belongs to.

    The workbench is ``<clone>/freecad_workbench``; the core package is
    ``<clone>/cq_fairing``.  When ``cq_fairing`` is not importable (not installed with
    pip, not on ``PYTHONPATH``) and the clone holds it, the clone's root is appended to
    ``sys.path`` (appended: its folders never shadow installed packages).

    Returns
    -------
    str or None
        The folder appended, or None when nothing was needed or found.
    """
    if importlib.util.find_spec("cq_fairing") is not None:
        return None
    if not os.path.isfile(os.path.join(CLONE_ROOT, "cq_fairing", "__init__.py")):
        return None
    sys.path.append(CLONE_ROOT)
    return CLONE_ROOT
