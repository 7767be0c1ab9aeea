# Fairing workbench: GUI initialisation. FreeCAD runs this file with exec, so names
# defined at top level are not visible inside methods: import inside them.


class FairingWorkbench(Workbench):  # noqa: F821 (provided by FreeCAD)
    """Multiresolution (wavelet) and energy fairing of B-spline faces and edges."""

    MenuText = "Fairing"
    ToolTip = "Fair B-spline surfaces and curves within a tolerance; deviation maps"

    def __init__(self):
        import fairing_wb

        self.__class__.Icon = fairing_wb.icon_path("Fairing_Workbench")

    def Initialize(self):
        from fairing_wb import commands

        commands.register()
        self.appendToolbar("Fairing", list(commands.TOOLBAR))
        self.appendMenu("&Fairing", list(commands.MENU))

    def Activated(self):
        return

    def Deactivated(self):
        return

    def GetClassName(self):
        return "Gui::PythonWorkbench"


Gui.addWorkbench(FairingWorkbench())  # noqa: F821
