"""The one-command install links the workbench and makes the core importable."""

import os
import subprocess
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
INSTALL = REPO / "freecad_workbench" / "install.py"


def test_install_and_uninstall(tmp_path):
    mod, site = tmp_path / "Mod", tmp_path / "site"
    python = "/usr/bin/python3"
    out = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod), "--site-dir", str(site)],
                         capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    link = mod / "Fairing"
    assert link.is_symlink() and link.resolve() == REPO / "freecad_workbench"
    assert (link / "InitGui.py").exists() and (link / "package.xml").exists()
    assert (site / "cq_fairing_repo.pth").read_text().strip() == str(REPO)
    # The .pth makes the core importable from a clean interpreter using that site dir.
    env = dict(os.environ, PYTHONPATH="")
    code = f"import site; site.addsitedir({str(site)!r}); import cq_fairing; print(cq_fairing.__file__)"
    check = subprocess.run([python, "-c", code], capture_output=True, text=True, env=env, cwd="/")
    assert check.returncode == 0 and str(REPO) in check.stdout, check.stderr
    again = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod), "--site-dir", str(site)],
                           capture_output=True, text=True)
    assert again.returncode == 0  # idempotent
    gone = subprocess.run([python, str(INSTALL), "--mod-dir", str(mod), "--site-dir", str(site),
                           "--uninstall"], capture_output=True, text=True)
    assert gone.returncode == 0 and not link.exists() and not (site / "cq_fairing_repo.pth").exists()


def test_package_xml_parses_with_freecads_metadata_reader():
    import FreeCAD

    meta = FreeCAD.Metadata(str(REPO / "freecad_workbench" / "package.xml"))
    assert meta.Name == "Fairing"
    workbench = meta.Content["workbench"][0]
    assert (workbench.Classname, workbench.Subdirectory) == ("FairingWorkbench", "./")
    assert (REPO / "freecad_workbench" / meta.Icon).exists()
