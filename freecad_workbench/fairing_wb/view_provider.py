"""View providers of the Fairing feature and of the analysis maps (GUI only)."""

import FreeCADGui

from . import icon_path

__all__ = ["ViewProviderFairing", "ViewProviderMap"]


class ViewProviderFairing:
    """Shows the faired shape; double-click edits it in the Fair Surface task panel."""

    def __init__(self, vobj):
        vobj.Proxy = self

    def attach(self, vobj):
        self.Object = vobj.Object

    def getIcon(self):
        return icon_path("Fairing_Feature")

    def claimChildren(self):
        source = self.Object.Source
        return [source[0]] if source else []

    def setEdit(self, vobj, mode=0):
        if mode != 0:
            return None
        from . import task_panel

        FreeCADGui.Control.showDialog(task_panel.FairSurfacePanel(fairing=vobj.Object))
        return True

    def unsetEdit(self, vobj, mode=0):
        FreeCADGui.Control.closeDialog()
        return True

    def updateData(self, obj, prop):
        if prop == "Shape" and obj.ViewObject and obj.ViewObject.Visibility:
            self._hide_maps_on(obj)

    def onChanged(self, vobj, prop):
        if prop == "Visibility" and vobj.Visibility:
            self._hide_maps_on(vobj.Object)

    @staticmethod
    def _hide_maps_on(obj):
        """A shown fairing hides the maps drawn on its source faces, the converse of
        ``ViewProviderMap._show_alone``: whichever was shown last is seen alone."""
        from . import deviation_map

        if obj.Source and not obj.Document.Restoring:
            for other in deviation_map.maps_on(*obj.Source):
                other.ViewObject.Visibility = False

    def doubleClicked(self, vobj):
        FreeCADGui.ActiveDocument.setEdit(vobj.Object.Name)
        return True

    def onDelete(self, vobj, subelements):
        """Show the source again when the fairing is deleted."""
        source = vobj.Object.Source
        if source and source[0].ViewObject:
            source[0].ViewObject.Visibility = True
        return True

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    dumps = __getstate__
    loads = __setstate__


class ViewProviderMap:
    """Per-vertex colours (``Coloring``) plus a Coin legend for a deviation/curvature map."""

    def __init__(self, vobj):
        vobj.Proxy = self
        if "ShowLegend" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyBool", "ShowLegend", "Legend",
                             "Show the colour legend")
            vobj.ShowLegend = True

    def attach(self, vobj):
        from . import legend

        self.Object = vobj.Object
        self.ViewObject = vobj
        self.legend = legend.Legend()
        vobj.RootNode.addChild(self.legend.node)
        self._refresh(vobj)

    def getIcon(self):
        kind = getattr(self.Object, "Kind", "Deviation")
        return icon_path("Fairing_DeviationMap" if kind == "Deviation" else
                         "Fairing_CurvatureMap")

    def updateData(self, obj, prop):
        if prop in ("VertexColors", "Maximum", "Minimum", "Unit") and obj.ViewObject:
            self._refresh(obj.ViewObject)
        if prop == "Mesh" and obj.ViewObject:
            self._show_alone(obj.ViewObject)

    def onChanged(self, vobj, prop):
        if prop in ("Visibility", "ShowLegend"):
            self._refresh(vobj)
        if prop == "Visibility":
            self._show_alone(vobj)

    @staticmethod
    def _show_alone(vobj):
        """A shown map hides the shapes it lies on (``deviation_map.covered``) and the other
        maps drawn there: at the same place, within the tolerance, their faces would show
        through the colours in patches."""
        from . import deviation_map

        obj = vobj.Object
        if not vobj.Visibility or getattr(obj, "Fairing", None) is None \
                or obj.Document.Restoring:
            return
        under = deviation_map.covered(obj)
        others = deviation_map.maps_on(*obj.Fairing.Source) if under else []
        for other in under + [m for m in others if m.Name != obj.Name]:
            other.ViewObject.Visibility = False

    def _refresh(self, vobj):
        from . import deviation_map, preferences

        obj = vobj.Object
        if not hasattr(self, "legend") or "Unit" not in obj.PropertiesList:
            return
        if obj.Values and len(obj.VertexColors) == obj.Mesh.CountPoints:
            vobj.Coloring = False
            vobj.Coloring = True
        low, high = deviation_map.AnalysisMap.range(obj)
        title = obj.Kind if obj.Kind == "Deviation" else f"{obj.Kind} ({obj.Which})"
        self.legend.update(title, low, high, obj.Unit, preferences.colors())
        shown = vobj.Visibility and getattr(vobj, "ShowLegend", True)
        self.legend.show(bool(shown))

    def finishRestoring(self, vobj=None):
        """Reopened documents show grey meshes until Coloring is toggled.

        FreeCAD 0.20 calls this without arguments; the view object comes from attach().
        """
        self._refresh(vobj or self.ViewObject)

    def __getstate__(self):
        return None

    def __setstate__(self, state):
        return None

    dumps = __getstate__
    loads = __setstate__
