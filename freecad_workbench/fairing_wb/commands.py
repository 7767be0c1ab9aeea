"""GUI commands of the Fairing workbench (``Fairing_*``), each one undo transaction.

Every command that changes the document echoes its scriptable call to the Python
console through ``FreeCADGui.doCommand`` (like FreeCAD's own workbenches), so a macro
recording replays it.
"""

import FreeCAD
import FreeCADGui

import cq_fairing as cf

from . import deviation_map, feature, icon_path, make, preferences, task_panel, undo
from .qt import QtWidgets

__all__ = ["register", "TOOLBAR", "MENU", "COMMANDS"]


def _selected_fairing():
    """The selected Fairing feature (or the fairing of a selected map), else None."""
    for obj in FreeCADGui.Selection.getSelection():
        kind = getattr(getattr(obj, "Proxy", None), "Type", None)
        if kind == feature.TYPE:
            return obj
        if kind == deviation_map.TYPE:
            return obj.Fairing
    return None


def _has_document():
    return FreeCAD.ActiveDocument is not None and FreeCADGui.Control.activeDialog() is False


class _Command:
    """Base: resources from class attributes."""

    name = icon = menu = tip = ""

    def GetResources(self):
        return {"Pixmap": icon_path(self.icon), "MenuText": self.menu, "ToolTip": self.tip}


class FairSurface(_Command):
    name, icon = "Fairing_FairSurface", "Fairing_FairSurface"
    menu = "Fair surface"
    tip = "Fair the selected B-spline face(s) within a tolerance (parametric result)"
    kind = "Face"

    def IsActive(self):
        return _has_document() and task_panel.selection_link(self.kind) is not None

    def Activated(self):
        link = task_panel.selection_link(self.kind)
        FreeCADGui.Control.showDialog(task_panel.FairSurfacePanel(link, kind=self.kind))


class FairCurve(FairSurface):
    name, icon = "Fairing_FairCurve", "Fairing_FairCurve"
    menu = "Fair curve"
    tip = "Fair the selected B-spline edge(s) within a tolerance (parametric result)"
    kind = "Edge"


class _MapCommand(_Command):
    kind = "Deviation"

    def IsActive(self):
        fairing = _selected_fairing()
        return _has_document() and fairing is not None and any(
            s.startswith("Face") for s in fairing.Source[1])

    def Activated(self):
        fairing = _selected_fairing()
        maps = deviation_map.find_maps(fairing, None if self.kind != "Deviation" else self.kind)
        maps = [m for m in maps if (m.Kind == "Deviation") == (self.kind == "Deviation")]
        if maps:
            self.toggle(fairing, maps)
        else:
            self.create(fairing)

    @staticmethod
    def toggle(fairing, maps):
        """Show/hide existing maps with their legends (view only, no transaction); shown,
        they hide the shapes under them (``ViewProviderMap``), hidden, the fairing shows
        again."""
        visible = not maps[0].ViewObject.Visibility
        for m in maps:
            m.ViewObject.Visibility = visible
        if not visible:
            fairing.ViewObject.Visibility = True

    def create(self, fairing):
        """New map(s) in one undo step; a failed map undoes the step and says why."""
        try:
            with undo.transaction(fairing.Document, self.menu):
                FreeCADGui.doCommand("import fairing_wb.deviation_map")
                FreeCADGui.doCommand(f"fairing = App.ActiveDocument.getObject({fairing.Name!r})")
                FreeCADGui.doCommand(self.call)
                FreeCADGui.doCommand("App.ActiveDocument.recompute()")
                undo.require_valid(deviation_map.find_maps(fairing))
                if self.kind != "Deviation":
                    FreeCADGui.doCommand("fairing_wb.deviation_map.share_range(maps)")
                    FreeCADGui.doCommand("App.ActiveDocument.recompute()")
        except Exception as error:  # a command: anything uncaught would be lost
            QtWidgets.QMessageBox.warning(None, self.menu, make.error_sentence(error))


class DeviationMap(_MapCommand):
    name, icon = "Fairing_DeviationMap", "Fairing_DeviationMap"
    menu = "Deviation map"
    tip = ("Colour map of the distance between faired and source, both ways (green 0 to "
           "red max); toggles")
    kind = "Deviation"
    call = "maps = [fairing_wb.deviation_map.make_map(fairing, 'Deviation')]"


class CurvatureMap(_MapCommand):
    name, icon = "Fairing_CurvatureMap", "Fairing_CurvatureMap"
    menu = "Curvature map"
    tip = "Mean curvature before (beside) and after fairing on one colour scale; toggles"
    kind = "MeanCurvature"
    call = "maps = list(fairing_wb.deviation_map.make_curvature_maps(fairing, 'MeanCurvature'))"


class Levels(_Command):
    name, icon = "Fairing_Levels", "Fairing_Levels"
    menu = "Multiresolution levels"
    tip = "Step through the scales of the selected face and see it change"

    def IsActive(self):
        return _has_document() and task_panel.selection_link("Face") is not None

    def Activated(self):
        link = task_panel.selection_link("Face")
        link = (link[0], link[1][:1])
        try:
            panel = task_panel.LevelsPanel(link)
        except cf.FairingError as error:
            QtWidgets.QMessageBox.warning(None, "Multiresolution levels", str(error))
            return
        FreeCADGui.Control.showDialog(panel)


class PointsToSurface(_Command):
    name, icon = "Fairing_PointsToSurface", "Fairing_PointsToSurface"
    menu = "Points to surface / curve"
    tip = "Interpolate an x y z point file (grid -> surface, one run -> curve)"

    def IsActive(self):
        return FreeCADGui.Control.activeDialog() is False

    def Activated(self):
        path, _ = QtWidgets.QFileDialog.getOpenFileName(
            None, "Points to surface / curve", "", "Point files (*.xyz *.asc *.txt);;All (*)")
        if path:
            self.run(path)

    @staticmethod
    def run(path, ask=True):
        """Read ``path``; a scattered cloud asks whether to resample (one transaction)."""
        from . import points

        try:
            cloud = cf.read_xyz(path)
        except cf.FairingError as error:
            QtWidgets.QMessageBox.warning(None, "Points to surface", str(error))
            return None
        resample = None
        if points.classify(cloud)[0] == "scattered":
            n = preferences.sample_density()
            answer = QtWidgets.QMessageBox.question(
                None, "Points to surface",
                f"The {len(cloud)} points are not an ordered grid. Resample them onto a "
                f"{n} x {n} grid over their best-fit plane (height field)?") if ask else \
                QtWidgets.QMessageBox.Yes
            if answer != QtWidgets.QMessageBox.Yes:
                return None
            resample = (n, n)
        doc = FreeCAD.ActiveDocument or FreeCAD.newDocument("Points")
        try:
            with undo.transaction(doc, "Points to surface"):
                FreeCADGui.doCommand("import fairing_wb.points")
                FreeCADGui.doCommand(f"obj, message = fairing_wb.points.make_points_shape("
                                     f"{path!r}, resample={resample!r})")
                FreeCADGui.doCommand("App.ActiveDocument.recompute()")
                undo.require_valid(doc.Objects[-1:])
        except Exception as error:  # a command: anything uncaught would be lost
            QtWidgets.QMessageBox.warning(None, "Points to surface", make.error_sentence(error))
            return None
        return doc.Objects[-1]


class Preferences(_Command):
    name, icon = "Fairing_Preferences", "Fairing_Preferences"
    menu = "Preferences..."
    tip = "Default tolerance, map colours and sample density"

    def IsActive(self):
        return True

    def Activated(self):
        from .preferences_dialog import PreferencesDialog

        PreferencesDialog().exec_()


COMMANDS = (FairSurface, FairCurve, DeviationMap, CurvatureMap, Levels, PointsToSurface,
            Preferences)
TOOLBAR = tuple(c.name for c in COMMANDS[:-1])
MENU = tuple(c.name for c in COMMANDS)


def register():
    """Add every command to FreeCAD (idempotent)."""
    for command in COMMANDS:
        FreeCADGui.addCommand(command.name, command())
