#!/usr/bin/env python3
"""Install the Fairing workbench for the current user: ``python3 freecad_workbench/install.py``.

1. Links ``<FreeCAD user data>/Mod/Fairing`` to this folder (FreeCAD finds ``Init.py`` /
   ``InitGui.py`` there; the user data folder is ``$FREECAD_USER_HOME`` if set, else
   ``~/.local/share/FreeCAD``, the default of Debian's FreeCAD 0.20).
2. Writes ``cq_fairing_repo.pth`` into the user site-packages of FreeCAD's Python
   (``/usr/bin/python3`` on Debian), so ``import cq_fairing`` works inside FreeCAD.
   The core needs numpy >= 1.24 and scipy >= 1.10 there
   (``apt-get install python3-numpy python3-scipy``).

Options: ``--mod-dir DIR`` and ``--site-dir DIR`` override both places, ``--python EXE``
names FreeCAD's interpreter, ``--uninstall`` removes the link and the .pth file.
"""

import argparse
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
LINK_NAME = "Fairing"
PTH_NAME = "cq_fairing_repo.pth"


def default_mod_dir():
    home = os.environ.get("FREECAD_USER_HOME")
    base = Path(home) if home else Path.home() / ".local" / "share" / "FreeCAD"
    return base / "Mod"


def default_site_dir(python):
    out = subprocess.run([python, "-c", "import site; print(site.getusersitepackages())"],
                         capture_output=True, text=True, check=True)
    return Path(out.stdout.strip())


def check_core(python):
    """Import the core with FreeCAD's Python; returns the error text or ''."""
    code = ("import sys; sys.path.insert(0, %r); import numpy, scipy, cq_fairing; "
            "print(numpy.__version__, scipy.__version__)" % str(REPO))
    out = subprocess.run([python, "-c", code], capture_output=True, text=True)
    return "" if out.returncode == 0 else out.stderr.strip().splitlines()[-1]


def install(mod_dir, site_dir):
    mod_dir.mkdir(parents=True, exist_ok=True)
    link = mod_dir / LINK_NAME
    if link.is_symlink() or link.exists():
        if link.resolve() != HERE:
            raise SystemExit(f"error: {link} exists and is not a link to {HERE}; remove it first.")
    else:
        link.symlink_to(HERE, target_is_directory=True)
    site_dir.mkdir(parents=True, exist_ok=True)
    (site_dir / PTH_NAME).write_text(str(REPO) + "\n")
    return link, site_dir / PTH_NAME


def uninstall(mod_dir, site_dir):
    link = mod_dir / LINK_NAME
    if link.is_symlink():
        link.unlink()
    pth = site_dir / PTH_NAME
    if pth.exists():
        pth.unlink()


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--mod-dir", type=Path, default=None)
    parser.add_argument("--site-dir", type=Path, default=None)
    parser.add_argument("--python", default="/usr/bin/python3")
    parser.add_argument("--uninstall", action="store_true")
    args = parser.parse_args(argv)
    mod_dir = args.mod_dir or default_mod_dir()
    site_dir = args.site_dir or default_site_dir(args.python)
    if args.uninstall:
        uninstall(mod_dir, site_dir)
        print(f"removed {mod_dir / LINK_NAME} and {site_dir / PTH_NAME}")
        return 0
    link, pth = install(mod_dir, site_dir)
    print(f"workbench: {link} -> {HERE}\ncore: {pth} adds {REPO} to {args.python}'s path")
    problem = check_core(args.python)
    if problem:
        print(f"warning: cq_fairing does not import with {args.python}: {problem}",
              file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
