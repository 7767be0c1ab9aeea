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


def test_only_the_batch_engine_imports_dask():
    """Dask is an extra: the package, its adapters' engine and the whole command line
    (``batch`` registered, its parser built) load without it; ``cq_fairing.batch`` is
    the one module that imports it, lazily, when ``batch`` runs."""
    code = (
        "import sys, cq_fairing, cq_fairing.cli, cq_fairing.report;"
        "cq_fairing.cli.build_parser().parse_args(['batch', 'x', '-o', 'y']);"
        "print(','.join(m for m in ('dask', 'distributed', 'rich') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"imported {out.stdout.strip()}"
    from pathlib import Path

    import cq_fairing

    package = Path(cq_fairing.__file__).parent
    importers = sorted(str(p.relative_to(package)) for p in package.rglob("*.py")
                       if "import dask" in p.read_text() or "from distributed" in p.read_text())
    assert importers == ["batch.py"]
