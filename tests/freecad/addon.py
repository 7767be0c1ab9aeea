"""Install the repository as FreeCAD's Addon Manager does: a git clone into ``Mod/``.

``publish`` turns the repository's files (tracked and new, not ignored; the working tree
as the next commit would have it) into a one-commit git repository: what a pushed
branch serves.  ``clone`` then clones that into ``<user data>/Mod/<name>`` with
``git clone --depth 1``, as the Addon Manager does; FreeCAD reads the clone's root
``package.xml`` and runs ``freecad_workbench/Init.py``.

    python3 tests/freecad/addon.py publish REPO DEST.git
    python3 tests/freecad/addon.py clone URL MOD_DIR
"""

import shutil
import subprocess
import sys
from pathlib import Path

ADDON_NAME = "cq-fairing"


def _git(*args, cwd=None):
    out = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True)
    if out.returncode != 0:
        raise RuntimeError(f"git {' '.join(args)} failed in {cwd}: {out.stderr.strip()}")
    return out.stdout


def publish(repo, dest):
    """Copy ``repo``'s files (as ``git ls-files`` lists them) into a new one-commit git
    repository at ``dest``; returns ``dest`` (a path ``git clone`` accepts)."""
    repo, dest = Path(repo), Path(dest)
    listed = _git("ls-files", "-z", "--cached", "--others", "--exclude-standard", cwd=repo)
    dest.mkdir(parents=True)
    for name in filter(None, listed.split("\0")):
        source = repo / name
        if source.is_file():  # tracked files deleted in the working tree are left out
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, dest / name)
    _git("init", "-q", cwd=dest)
    _git("add", "-A", cwd=dest)
    _git("-c", "user.name=cq-fairing tests", "-c", "user.email=tests@invalid", "commit", "-q",
         "-m", "published tree", cwd=dest)
    return dest


def clone(url, mod_dir, name=ADDON_NAME):
    """``git clone --depth 1 url mod_dir/name``; returns the clone's path."""
    target = Path(mod_dir) / name
    target.parent.mkdir(parents=True, exist_ok=True)
    _git("clone", "-q", "--depth", "1", f"file://{Path(url).resolve()}", str(target))
    return target


if __name__ == "__main__":
    command, first, second = sys.argv[1:4]
    print({"publish": publish, "clone": clone}[command](first, second))
