"""The real ``cq-fairing`` entry point, run as a subprocess: exit codes, messages, files."""

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import REPO, data_path

BLADE = REPO / "examples" / "data" / "IEA_15MW_CFD.stp"


def run(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "cq_fairing.cli", *map(str, args)],
                          capture_output=True, text=True, cwd=cwd, env=env, timeout=600)


def sha(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def blade_run(tmp_path_factory):
    work = tmp_path_factory.mktemp("blade")
    before = sha(BLADE)
    proc = run("fair", BLADE, "-o", "blade.step", "--tol", "0.001", "--report", "r.json",
               "--deviation-map", "m.png", "--curvature-map", "c.png", cwd=work)
    return work, proc, before


def test_fair_blade_writes_a_valid_step_and_report(blade_run):
    work, proc, before = blade_run
    assert proc.returncode == 0, proc.stderr
    assert sha(BLADE) == before
    from cq_fairing.occ import list_faces, read_shape

    faces = list_faces(read_shape(work / "blade.step"))
    assert len(faces) == 3 and all(f.surface_type == "BSpline" for f in faces)
    report = json.loads((work / "r.json").read_text())
    faired = [f for f in report["faces"] if f["poles_after"] != f["poles_before"]]
    assert faired, "no face was reduced"
    for face in report["faces"]:
        assert face["status"] in ("ok", "unchanged")
        assert face["max_deviation"] <= 0.001
    assert "3/3 faces ok" in proc.stdout
    assert "Statistics on Transfer" not in proc.stdout  # OCCT's banner is silenced


def test_a_face_kept_as_it_was_is_counted_unchanged_not_faired(blade_run):
    """The blade's 4 x 17 root face has no coarser target (the fairing keeps it): the
    summary counted it among the faired faces.  Now it is ``unchanged``, the faired count
    is the two faces whose surface was replaced, and the poles are summed over all three
    (the root face adds 68 on both sides), in the JSON, the terminal line and the HTML."""
    from cq_fairing.report import render_html

    work, proc, _ = blade_run
    report = json.loads((work / "r.json").read_text())
    assert [f["status"] for f in report["faces"]] == ["unchanged", "ok", "ok"]
    root = report["faces"][0]
    assert root["poles_before"] == root["poles_after"] == [4, 17]
    assert "nothing to fair" in root["message"]
    summary = report["summary"]
    assert (summary["faces_ok"], summary["faces_faired"], summary["faces_unchanged"]) == (3, 2, 1)
    assert summary["poles_before"] == 68 + sum(
        np.prod(f["poles_before"]) for f in report["faces"][1:])
    assert summary["poles_before"] - summary["poles_after"] == sum(
        np.prod(f["poles_before"]) - np.prod(f["poles_after"]) for f in report["faces"][1:])
    assert "3/3 faces ok (2 faired, 1 unchanged), 0 over tolerance" in proc.stdout
    page = render_html(report)
    assert "<th>faired</th><td class='l'>2</td>" in page
    assert "<th>unchanged</th><td class='l'>1</td>" in page


def test_the_html_report_lists_every_join_with_its_gap_and_angle(tmp_path):
    """The fuselage's 14 joins, one table row each, in the JSON's order, with its source
    and faired gap and angle: the 10 held joins say so and close to round-off, the 2
    creases stay creases."""
    from html.parser import HTMLParser

    from cq_fairing.report import JOIN_COLUMNS, render_html

    proc = run("fair", data_path("fuselage.brep"), "-o", "out.brep", "--tol", "2.5",
               "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    rows = report["joins"]["rows"]

    class Tables(HTMLParser):
        def __init__(self):
            super().__init__()
            self.tables, self.cell = [], None

        def handle_starttag(self, tag, attrs):
            if tag == "table":
                self.tables.append([])
            elif tag == "tr":
                self.tables[-1].append([])
            elif tag in ("td", "th"):
                self.cell = ""

        def handle_endtag(self, tag):
            if tag in ("td", "th"):
                self.tables[-1][-1].append(self.cell)
                self.cell = None

        def handle_data(self, data):
            if self.cell is not None:
                self.cell += data

    page = Tables()
    page.feed(render_html(report))
    table = next(t for t in page.tables if tuple(t[0]) == JOIN_COLUMNS)[1:]
    assert len(rows) == len(table) == 14
    for row, cells in zip(rows, table):
        assert cells[0] == " - ".join(str(f) for f in row["faces"]) and cells[1] == row["kind"]
        assert cells[2] == ("yes" if row["held"] else "no")
        assert float(cells[4]) == pytest.approx(row["gap"], rel=5e-3, abs=1e-300)
        assert float(cells[6]) == pytest.approx(row["angle"], rel=5e-3, abs=1e-300)
    held = [cells for cells in table if cells[2] == "yes"]
    assert len(held) == 10 and all(float(c[4]) <= 1e-9 for c in held)
    assert sum(c[1] == "crease" for c in table) == 2


def _colours(path):
    from PIL import Image

    image = np.asarray(Image.open(path).convert("RGB")).reshape(-1, 3).astype(int)
    return image


def test_maps_are_non_trivial_images(blade_run):
    work, proc, _ = blade_run
    for name in ("m.png", "c.png"):
        pixels = _colours(work / name)
        assert pixels.shape[0] > 500 * 500
        assert len(np.unique(pixels, axis=0)) > 50
    deviation = _colours(work / "m.png")
    greenish = (deviation[:, 1] > deviation[:, 0] + 60) & (deviation[:, 1] > deviation[:, 2] + 60)
    reddish = (deviation[:, 0] > 180) & (deviation[:, 1] < 80) & (deviation[:, 2] < 80)
    assert greenish.sum() > 1000 and reddish.sum() > 100  # surface and colour bar


def test_inspect_lists_every_face_of_linkrods(tmp_path):
    proc = run("inspect", data_path("linkrods.step"), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stdout.splitlines()
             if line.strip()[:1].isdigit() and "faces:" not in line]
    assert len(lines) == 37
    assert sum("BSpline" in line for line in lines) == 18
    assert "37 faces: 18 BSpline, 4 Cylinder, 6 Plane, 9 Torus" in proc.stdout


def test_a_reader_that_leaves_early_ends_the_command_quietly(tmp_path):
    """``cq-fairing inspect model | head -0``: exit 141 (SIGPIPE's), nothing on stderr.

    The pipe is closed before the model is read (0.8 s), so the first line written
    meets a reader that has gone."""
    env = dict(os.environ, PYTHONPATH=str(REPO))
    proc = subprocess.Popen([sys.executable, "-m", "cq_fairing.cli", "inspect",
                             str(data_path("impeller.igs"))], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=tmp_path, env=env)
    proc.stdout.close()
    assert proc.wait(timeout=600) == 141
    assert proc.stderr.read() == b""


@pytest.mark.parametrize("content", [b"", os.urandom(4096),
                                     b"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(("])
def test_bad_input_files_give_one_line_errors_and_exit_3(tmp_path, content):
    bad = tmp_path / "bad.step"
    bad.write_bytes(content)
    before = sha(bad)
    proc = run("fair", bad, "-o", "out.step", "--tol", "0.1", cwd=tmp_path)
    assert proc.returncode == 3
    assert proc.stderr.count("\n") == 1 and proc.stderr.startswith("cq-fairing: error:")
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "out.step").exists()
    assert sha(bad) == before


def test_truncated_step_file(tmp_path):
    truncated = tmp_path / "cut.step"
    truncated.write_bytes(BLADE.read_bytes()[: 300_000])
    proc = run("fair", truncated, "-o", "out.step", cwd=tmp_path)
    assert proc.returncode == 3, proc.stderr
    assert not (tmp_path / "out.step").exists()


def test_missing_input(tmp_path):
    proc = run("inspect", tmp_path / "nope.step", cwd=tmp_path)
    assert proc.returncode == 3 and "nope.step" in proc.stderr


def test_existing_output_is_not_overwritten_without_force(tmp_path):
    out = tmp_path / "out.step"
    out.write_text("keep me")
    proc = run("fair", BLADE, "-o", out, "--tol", "0.01", cwd=tmp_path)
    assert proc.returncode == 4 and "--force" in proc.stderr
    assert out.read_text() == "keep me"


def test_output_equal_to_input_is_refused(tmp_path):
    copy = tmp_path / "blade.stp"
    copy.write_bytes(BLADE.read_bytes())
    proc = run("fair", copy, "-o", copy, "--force", cwd=tmp_path)
    assert proc.returncode == 4 and "input" in proc.stderr
    assert sha(copy) == sha(BLADE)


def test_output_in_a_missing_folder(tmp_path):
    proc = run("fair", BLADE, "-o", tmp_path / "no" / "out.step", cwd=tmp_path)
    assert proc.returncode == 4 and "does not exist" in proc.stderr


@pytest.mark.parametrize("args", [["--tol", "-1"], ["--tol", "nan"], ["--faces", "0"],
                                  ["--target", "2", "9"], ["--target-degree", "0"],
                                  ["--target-degree", "3", "3", "3"]])
def test_usage_errors_exit_2(tmp_path, args):
    proc = run("fair", BLADE, "-o", "out.step", *args, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "out.step").exists()


def test_points_to_a_faired_curve(tmp_path):
    t = np.linspace(0, 2 * np.pi, 400)
    rng = np.random.default_rng(0)
    pts = np.c_[50 * np.cos(t), 50 * np.sin(t), 5 * np.sin(3 * t)] + rng.normal(0, 0.01, (400, 3))
    np.savetxt(tmp_path / "p.xyz", pts)
    proc = run("points", "p.xyz", "-o", "curve.step", "--tol", "0.05", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "402 ->" in proc.stdout
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    reader.ReadFile(str(tmp_path / "curve.step"))
    assert reader.TransferRoots() >= 1


def test_points_grid_to_a_faired_surface(tmp_path):
    u, v = np.meshgrid(np.linspace(0, 1, 30), np.linspace(0, 1, 40), indexing="ij")
    grid = np.stack([100 * u, 100 * v, 10 * np.sin(3 * u) * np.cos(2 * v)], -1)
    grid += np.random.default_rng(1).normal(0, 0.01, grid.shape)
    np.savetxt(tmp_path / "g.xyz", grid.reshape(-1, 3))
    proc = run("points", "g.xyz", "-o", "surf.step", "--tol", "0.05", "--grid", "30", "40",
               cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    from cq_fairing.occ import list_faces, read_shape

    (face,) = list_faces(read_shape(tmp_path / "surf.step"))
    assert face.surface_type == "BSpline" and face.n_poles_u < 32 and face.n_poles_v < 42


def test_points_in_scan_lines_are_found_a_grid_without_the_option(tmp_path):
    """The 30 x 40 grid of the test above, without --grid: the jumps between its rows
    say it is a grid (not a zig-zag curve through all 1200 points)."""
    u, v = np.meshgrid(np.linspace(0, 1, 30), np.linspace(0, 1, 40), indexing="ij")
    grid = np.stack([100 * u, 100 * v, 10 * np.sin(3 * u) * np.cos(2 * v)], -1)
    np.savetxt(tmp_path / "g.xyz", grid.reshape(-1, 3))
    proc = run("points", "g.xyz", "-o", "surf.step", "--tol", "0.05", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "in 30 rows of 40 (scan lines)" in proc.stdout
    from cq_fairing.occ import list_faces, read_shape

    (face,) = list_faces(read_shape(tmp_path / "surf.step"))
    assert face.surface_type == "BSpline"


def test_a_scattered_scan_is_refused_then_resampled(tmp_path):
    """Every 20th point of the real face scan (01_points.asc): neither a run nor a grid,
    so the command refuses it in one line naming --resample (it used to thread one curve
    through all the points in file order); with --resample a surface is written."""
    np.savetxt(tmp_path / "scan.xyz", np.loadtxt(data_path("01_points.asc"))[::20])
    proc = run("points", "scan.xyz", "-o", "scan.step", cwd=tmp_path)
    assert proc.returncode == 2 and "--resample" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1 and not (tmp_path / "scan.step").exists()
    proc = run("points", "scan.xyz", "-o", "scan.step", "--resample", "20", "20", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "resampled to a 20 x 20 height field" in proc.stdout
    from cq_fairing.occ import list_faces, read_shape

    (face,) = list_faces(read_shape(tmp_path / "scan.step"))
    assert face.surface_type == "BSpline" and face.n_poles_u <= 22
    proc = run("points", "scan.xyz", "-o", "curve.step", "--curve", "--tol", "5", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr   # one curve in file order, when asked for


def test_help_documents_exit_codes():
    proc = subprocess.run(["cq-fairing", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0
    for code in ("0 ", "1 ", "2 ", "3 ", "4 ", "5 ", "130"):
        assert code in proc.stdout


def test_adaptive_fairs_the_rational_faces_of_linkrods(tmp_path):
    """--method adaptive used to skip every rational face ('skipped-rational'); linkrods'
    B-spline faces are rational but two. All 18 are now faired within tol (OCCT's
    two-sided check), the report says which are rational, and the poles drop. Face by
    face: with its joins held, every one of them is kept (its joins run across it)."""
    proc = run("fair", data_path("linkrods.step"), "-o", "out.step", "--tol", "0.01",
               "--method", "adaptive", "--joins", "free", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    bspline = [f for f in report["faces"] if f["surface_type"] == "BSpline"]
    assert len(bspline) == 18 and sum(bool(f["rational"]) for f in bspline) == 16
    assert all(f["status"] in ("ok", "unchanged") for f in bspline)
    assert all(f["max_deviation"] <= 0.01 for f in bspline if f["status"] == "ok")
    faired_rational = [f for f in bspline if f["rational"] and f["status"] == "ok"]
    assert len(faired_rational) >= 14
    assert all(f["rational"] is None for f in report["faces"] if f["surface_type"] != "BSpline")
    assert report["summary"]["poles_after"] < report["summary"]["poles_before"] / 10


def test_target_degree_reaches_every_face_and_refusals_speak_in_options(tmp_path):
    """--target-degree 5: the blade's large face 3, alone (its twin, face 2, not selected,
    would keep it with the joins held), is faired at degree 5 within tol
    (more spans than the source's, the core's grown top). The root face at degree 2 and
    tol 1e-4 is refused, and the refusal names the option, not the API's argument."""
    proc = run("fair", BLADE, "-o", "out.step", "--tol", "0.001", "--method", "adaptive",
               "--faces", "3", "--target-degree", "5", "--joins", "free", "--report", "r.json",
               cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    face = json.loads((tmp_path / "r.json").read_text())["faces"][2]
    assert face["status"] == "ok" and face["degree_after"] == [5, 5]
    assert face["max_deviation"] <= 0.001
    proc = run("fair", BLADE, "-o", "root.step", "--tol", "0.0001", "--method", "adaptive",
               "--faces", "1", "--target-degree", "2", "--report", "root.json", cwd=tmp_path)
    message = json.loads((tmp_path / "root.json").read_text())["faces"][0]["message"]
    assert "--target-degree 3 3" in message and "target_degree=" not in message
