# Fairing workbench: App-level initialisation (run by FreeCAD with exec; no __file__).
# FreeCAD has put this folder on sys.path. The core package cq_fairing sits in the
# repository's root (a clone made by the Addon Manager, or the checkout install.py links):
# find_core() puts that root on sys.path unless cq_fairing is importable already.
import fairing_wb

fairing_wb.find_core()
