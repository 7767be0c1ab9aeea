"""Qt classes for the workbench's GUI modules, from whichever Qt FreeCAD was built with.

FreeCAD ships a ``PySide`` module that re-exports its own binding (PySide2 for Qt 5,
PySide6 for Qt 6 builds of FreeCAD 1.x).  FreeCAD 0.21 and later provide
``PySide.QtWidgets``; in FreeCAD 0.20 the shim's ``QtGui`` also holds the widget classes.
GUI modules import ``QtCore``, ``QtGui`` and ``QtWidgets`` from here and name no binding.
"""

from PySide import QtCore, QtGui

try:
    from PySide import QtWidgets
except ImportError:  # FreeCAD 0.20: the widgets live in the shim's QtGui
    QtWidgets = QtGui

__all__ = ["QtCore", "QtGui", "QtWidgets"]
