"""Installing the workbench: the Addon Manager's git clone, install.py's link, package.xml.

Each install is checked end to end: a fresh ``freecadcmd`` with only that ``Mod`` folder
(no ``PYTHONPATH``, no user site-packages) runs the workbench's ``Init.py``, imports
``cq_fairing`` from the installed tree and fairs a noisy face.
"""

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import addon

REPO = Path(__file__).resolve().parents[3]
INSTALL = REPO / "freecad_workbench" / "install.py"

FAIR_A_FACE = """
import json, sys
import FreeCAD, Part
sys.path.insert(0, {fixtures!r})
import fixtures
import cq_fairing, fairing_wb.make
doc = FreeCAD.newDocument("AddonCheck")
noisy, _ = fixtures.noisy_blade_surface(50, 80)
source = fixtures.add_shape(doc, noisy.toShape(), "Noisy")
fairing = fairing_wb.make.make_fairing((source, ["Face1"]), tolerance=0.05)
doc.recompute()
surface = fairing.Shape.Faces[0].Surface
json.dump({{"core": cq_fairing.__file__, "workbench": fairing_wb.__file__,
           "valid": fairing.isValid(), "deviation": fairing.MaxDeviation.Value,
           "poles": [surface.NbUPoles, surface.NbVPoles]}}, open({out!r}, "w"))
"""


def run_freecad_with(mod_dir, home):
    """Fair a 50 x 80 noisy face in a fresh ``freecadcmd`` whose user folder holds only
    ``mod_dir``; returns what it reports (paths of the modules it imported, figures)."""
    out = home / "result.json"
    script = home / "fair_a_face.py"
    script.write_text(FAIR_A_FACE.format(fixtures=str(REPO / "tests" / "freecad"), out=str(out)))
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(FREECAD_USER_HOME=str(mod_dir.parent), HOME=str(home), PYTHONNOUSERSITE="1")
    run = subprocess.run(["freecadcmd", "-c", f"exec(open({str(script)!r}).read())"],
                         stdin=subprocess.DEVNULL, capture_output=True, text=True, env=env,
                         cwd=home, timeout=300)
    assert out.exists(), run.stdout[-2000:] + run.stderr[-2000:]
    return json.loads(out.read_text())


def check_fairs_from(tree, report):
    assert Path(report["core"]).resolve().is_relative_to(tree.resolve() / "cq_fairing"), report
    assert Path(report["workbench"]).resolve().is_relative_to(
        tree.resolve() / "freecad_workbench"), report
    assert report["valid"] and report["deviation"] <= 0.05, report
    assert report["poles"][0] * report["poles"][1] < 50 * 80, report


def test_addon_manager_clone_fairs_a_face(tmp_path):
    """Clone into ``Mod/`` as the Addon Manager does: the clone's Init.py finds its core."""
    url = os.environ.get("FAIRING_ADDON_URL") or addon.publish(REPO, tmp_path / "published")
    home = tmp_path / "home"
    home.mkdir()
    clone = addon.clone(url, home / "FreeCAD" / "Mod")
    assert not (clone / "cq_fairing" / "__init__.py").samefile(REPO / "cq_fairing" / "__init__.py")
    check_fairs_from(clone, run_freecad_with(clone.parent, home))


def test_workbench_folder_alone_finds_its_core(tmp_path):
    """A Mod entry linking ``freecad_workbench`` alone: FreeCAD puts only that folder on
    the path, and ``Init.py`` (``fairing_wb.find_core``) adds the repository's root."""
    home = tmp_path / "home"
    mod = home / "FreeCAD" / "Mod"
    mod.mkdir(parents=True)
    (mod / "Fairing").symlink_to(REPO / "freecad_workbench", target_is_directory=True)
    check_fairs_from(REPO, run_freecad_with(mod, home))


def test_install_py_links_the_root_and_fairs_a_face(tmp_path):
    home = tmp_path / "home"
    mod = home / "FreeCAD" / "Mod"
    python = shutil.which("python3", path="/usr/bin")
    out = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod)], capture_output=True,
                         text=True)
    assert out.returncode == 0, out.stderr
    link = mod / "Fairing"
    assert link.is_symlink() and link.resolve() == REPO
    check_fairs_from(REPO, run_freecad_with(mod, home))
    again = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod)], capture_output=True,
                           text=True)
    assert again.returncode == 0  # idempotent
    gone = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod), "--uninstall"],
                          capture_output=True, text=True)
    assert gone.returncode == 0 and not link.exists() and not link.is_symlink()


def test_package_xml_is_complete_for_the_addon_manager():
    import FreeCAD

    meta = FreeCAD.Metadata(str(REPO / "package.xml"))
    project = (REPO / "pyproject.toml").read_text()
    version = re.search(r'^version = "([^"]+)"', project, re.M)[1]
    assert (meta.Name, meta.Version) == ("Fairing", version)
    assert meta.Maintainer and all(m["name"] for m in meta.Maintainer)
    assert [license["name"] for license in meta.License] == ["LGPL-2.1-or-later"]
    assert all((REPO / license["file"]).read_text().lstrip().startswith(
        "GNU LESSER GENERAL PUBLIC LICENSE") for license in meta.License)
    assert meta.FreeCADMin.startswith("0.20")
    assert {d["package"] for d in meta.Depend} == {"numpy", "scipy"}
    assert (REPO / meta.Icon).is_file()
    workbench = meta.Content["workbench"][0]
    assert (workbench.Classname, workbench.Subdirectory) == ("FairingWorkbench",
                                                             "freecad_workbench")
    folder = REPO / workbench.Subdirectory
    assert (folder / "Init.py").is_file() and (folder / "InitGui.py").is_file()
    assert (folder / workbench.Icon).is_file()
