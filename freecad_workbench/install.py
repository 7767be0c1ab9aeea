#!/usr/bin/env python3
"""Install the Fairing workbench for the current user: ``python3 freecad_workbench/install.py``.

Links ``<FreeCAD user data>/Mod/Fairing`` to the repository's root, the layout the Addon
Manager's git clone gives: FreeCAD reads the root ``package.xml`` and runs
``freecad_workbench/Init.py``, which puts the root on ``sys.path`` so ``import cq_fairing``
works inside FreeCAD.  The user data folder is ``$FREECAD_USER_HOME`` if set, else
``~/.local/share/FreeCAD`` (the default of Debian's FreeCAD 0.20 and 1.0).  Then checks that
FreeCAD's Python (``/usr/bin/python3`` on Debian) imports the core: it needs numpy >= 1.24
and scipy >= 1.10 there (``apt-get install python3-numpy python3-scipy``).

Options: ``--mod-dir DIR`` overrides the Mod folder, ``--python EXE`` names FreeCAD's
interpreter, ``--uninstall`` removes the link.
"""

import argparse
import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
LINK_NAME = "Fairing"


def default_mod_dir():
    home = os.environ.get("FREECAD_USER_HOME")
    base = Path(home) if home else Path.home() / ".local" / "share" / "FreeCAD"
    return base / "Mod"


def check_core(python):
    """Import the core with FreeCAD's Python; returns the error text or ''."""
    code = (f"import sys; sys.path.insert(0, {str(REPO)!r}); import numpy, scipy, cq_fairing; "
            "print(numpy.__version__, scipy.__version__)")
    out = subprocess.run([python, "-c", code], capture_output=True, text=True)
    return "" if out.returncode == 0 else out.stderr.strip().splitlines()[-1]


def install(mod_dir):
    mod_dir.mkdir(parents=True, exist_ok=True)
    link = mod_dir / LINK_NAME
    if link.is_symlink() or link.exists():
        if link.resolve() != REPO:
            raise SystemExit(f"error: {link} exists and is not a link to {REPO}; remove it first.")
    else:
        link.symlink_to(REPO, target_is_directory=True)
    return link


def uninstall(mod_dir):
    link = mod_dir / LINK_NAME
    if link.is_symlink():
        link.unlink()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mod-dir", type=Path, default=None)
    parser.add_argument("--python", default="/usr/bin/python3")
    parser.add_argument("--uninstall", action="store_true")
    args = parser.parse_args(argv)
    mod_dir = args.mod_dir or default_mod_dir()
    if args.uninstall:
        uninstall(mod_dir)
        print(f"removed {mod_dir / LINK_NAME}")
        return 0
    link = install(mod_dir)
    print(f"workbench: {link} -> {REPO} (package.xml, freecad_workbench/, cq_fairing/)")
    problem = check_core(args.python)
    if problem:
        print(f"warning: cq_fairing does not import with {args.python}: {problem}",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
