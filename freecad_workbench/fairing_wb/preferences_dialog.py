"""Preferences dialog of the workbench (GUI only); values live in :mod:`preferences`."""

import FreeCADGui

from . import preferences
from .qt import QtGui, QtWidgets

__all__ = ["PreferencesDialog"]


class PreferencesDialog(QtWidgets.QDialog):
    """Default tolerance (mm, 0 = relative to the model), sample density, ramp colours."""

    def __init__(self, parent=None):
        super().__init__(parent or FreeCADGui.getMainWindow())
        self.setObjectName("FairingPreferences")
        self.setWindowTitle("Fairing preferences")
        layout = QtWidgets.QFormLayout(self)
        # parented to the dialog at once: an unparented widget of a temporary UiLoader
        # was sometimes deleted before the layout took it ("Internal C++ object already
        # deleted" in one CI run of the GUI script)
        loader = FreeCADGui.UiLoader()
        self.tolerance = loader.createWidget("Gui::QuantitySpinBox", self)
        self.tolerance.setObjectName("fairing_default_tolerance")
        self.tolerance.setProperty("unit", "mm")
        self.tolerance.setProperty("decimals", 4)
        self.tolerance.setProperty("rawValue",
                                   preferences.params().GetFloat("DefaultTolerance", 0.0))
        self.tolerance.setToolTip("0 means 1e-3 of the model's bounding-box diagonal")
        self.density = QtWidgets.QSpinBox()
        self.density.setObjectName("fairing_sample_density")
        self.density.setRange(*preferences.DENSITY_RANGE)
        self.density.setValue(preferences.sample_density())
        self.colors = list(preferences.colors())
        self.buttons = []
        for i, text in enumerate(("Colour at 0 / min", "Colour at max")):
            button = QtWidgets.QPushButton()
            button.setObjectName(f"fairing_color_{i}")
            button.clicked.connect(lambda _=False, k=i: self._pick(k))
            self.buttons.append(button)
            layout.addRow(text, button)
        layout.addRow("Default tolerance", self.tolerance)
        layout.addRow("Samples per direction", self.density)
        box = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.Ok |
                                         QtWidgets.QDialogButtonBox.Cancel)
        box.accepted.connect(self.accept)
        box.rejected.connect(self.reject)
        layout.addRow(box)
        self._paint()

    def _paint(self):
        for button, rgb in zip(self.buttons, self.colors):
            red, green, blue = (int(255 * c) for c in rgb)
            button.setStyleSheet(f"background-color: rgb({red},{green},{blue})")

    def _pick(self, index):
        color = QtWidgets.QColorDialog.getColor(QtGui.QColor.fromRgbF(*self.colors[index]), self)
        if color.isValid():
            self.colors[index] = (color.redF(), color.greenF(), color.blueF())
            self._paint()

    def accept(self):
        p = preferences.params()
        p.SetFloat("DefaultTolerance", float(self.tolerance.property("rawValue")))
        p.SetInt("SampleDensity", self.density.value())
        preferences.set_colors(*self.colors)
        super().accept()
