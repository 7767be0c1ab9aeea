# Fairing workbench: App-level initialisation (run by FreeCAD with exec; no __file__).
# The workbench's Python package is ``fairing_wb``; nothing needs registering at App level.
