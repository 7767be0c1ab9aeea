"""The numerical core must not pull in OCP, cadquery, pyvista or FreeCAD."""

import subprocess
import sys

FORBIDDEN = ("OCP", "cadquery", "pyvista", "vtk", "FreeCAD", "Part", "PySide2")


def test_core_imports_only_numpy_and_scipy():
    code = (
        "import sys, cq_fairing, cq_fairing.core.fairing, cq_fairing.core.decomposition;"
        "import importlib, pkgutil, cq_fairing.core as core;"
        "[importlib.import_module('cq_fairing.core.' + m.name) for m in pkgutil.iter_modules(core.__path__)];"
        f"bad = [m for m in {FORBIDDEN!r} if m in sys.modules];"
        "print(','.join(bad))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"core imported {out.stdout.strip()}"


def test_core_sources_have_no_adapter_imports():
    from pathlib import Path

    import cq_fairing.core as core

    for path in Path(core.__file__).parent.glob("*.py"):
        text = path.read_text()
        for name in FORBIDDEN:
            assert f"import {name}" not in text and f"from {name}" not in text, (path, name)
