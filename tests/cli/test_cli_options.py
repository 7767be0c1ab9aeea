"""Options of ``cq-fairing fair`` that used to be accepted with another meaning, or to end
without saying why nothing happened: the real command on real files."""

import json

import numpy as np
import pytest

from tests.cli.test_cli import BLADE, run
from tests.cli.test_cli_inputs import assert_one_line_error


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    """A STEP box: six planes, not one B-spline face."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox

    from cq_fairing.occ import write_shape

    path = tmp_path_factory.mktemp("box") / "box.step"
    write_shape(BRepPrimAPI_MakeBox(10.0, 20.0, 30.0).Shape(), path)
    return path


@pytest.fixture(scope="module")
def two_degrees(tmp_path_factory):
    """A STEP compound of two wavy 6 x 6 B-spline faces side by side: face 1 bicubic,
    face 2 biquadratic."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    from cq_fairing.core.geometry import make_surface
    from cq_fairing.occ import write_shape
    from cq_fairing.occ.builders import surface_to_natural_face

    u, v = np.meshgrid(np.linspace(0, 50, 6), np.linspace(0, 50, 6), indexing="ij")
    net = np.stack([u, v, 3 * np.sin(u / 8) * np.cos(v / 11)], -1)
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for degree, shift in ((3, 0.0), (2, 60.0)):
        surface = make_surface(net + [shift, 0.0, 0.0], degree=degree)
        builder.Add(compound, surface_to_natural_face(surface))
    path = tmp_path_factory.mktemp("degrees") / "two.step"
    write_shape(compound, path)
    return path


@pytest.mark.parametrize("faces", ["1-", "-2", "1-2-3", "2-1"])
def test_open_or_malformed_face_ranges_are_usage_errors(tmp_path, faces):
    """--faces 1- was read as face 1 only (int(last or first))."""
    proc = run("fair", BLADE, "-o", "o.step", "--faces", faces, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr
    assert f"expected 1-based face numbers like 1,3-5, got '{faces}'" in proc.stderr
    assert not (tmp_path / "o.step").exists()


def test_a_target_above_a_face_s_poles_is_a_usage_error_in_poles(tmp_path):
    """--target 100 100 was exit 1 "failed" with the reason in core terms ("target scale
    n ... got n=97") only in --report, and the output written; now exit 2 and no
    output, naming the face's poles and the range it allows."""
    proc = run("fair", BLADE, "-o", "o.step", "--target", "100", "100", cwd=tmp_path)
    assert_one_line_error(proc, 2, tmp_path, "--target 100 100 does not fit face 1: it has "
                          "4 x 17 poles and a degree 3 x 3 target, which allows 4 to 4 in u "
                          "and 4 to 17 in v")


@pytest.mark.parametrize("face, degree", [("1", 3), ("2", 2)])
def test_target_poles_are_met_for_the_face_s_own_target_degree(tmp_path, two_degrees,
                                                               face, degree):
    """--target 5 5 gives 5 x 5 poles on the bicubic and on the biquadratic face (the
    scales were poles - 3 for every face, so the quadratic one got 4 x 4)."""
    from cq_fairing.occ import list_faces, read_shape

    proc = run("fair", two_degrees, "-o", "o.step", "--faces", face, "--target", "5", "5",
               cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    info = list_faces(read_shape(tmp_path / "o.step"))[int(face) - 1]
    assert (info.u_degree, info.v_degree) == (degree, degree)
    assert (info.n_poles_u, info.n_poles_v) == (5, 5)


def test_one_target_for_faces_of_different_degrees_is_a_usage_error(tmp_path, two_degrees):
    proc = run("fair", two_degrees, "-o", "o.step", "--target", "5", "5", cwd=tmp_path)
    assert_one_line_error(proc, 2, tmp_path, "different degrees (face 2: 2 x 2; face 1: "
                          "3 x 3)")


def test_a_model_without_b_spline_faces_says_nothing_was_faired(tmp_path, box):
    """A box with --deviation-map and --curvature-map ended with exit 0, no image and no
    word; now one note on stderr says why (and the face messages name --convert, not
    the API's convert=True)."""
    proc = run("fair", box, "-o", "o.step", "--deviation-map", "m.png", "--curvature-map",
               "c.png", "--report", "r.json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == (
        "cq-fairing: note: no face was faired (6 skipped-not-bspline); pass --convert to "
        "fair the faces that are not B-splines; --deviation-map and --curvature-map not "
        "written (they show faired faces).\n")
    assert not (tmp_path / "m.png").exists() and not (tmp_path / "c.png").exists()
    messages = {face["message"] for face in json.loads((tmp_path / "r.json").read_text())["faces"]}
    assert messages == {"Plane face left unchanged; pass --convert to convert it to NURBS "
                        "and fair it."}


def test_faired_faces_give_no_note(tmp_path, two_degrees):
    proc = run("fair", two_degrees, "-o", "o.step", "--tol", "0.5", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "2/2 faces ok" in proc.stdout and proc.stderr == ""


@pytest.mark.parametrize("command", [["fair", BLADE], ["points", "p.xyz"]])
def test_an_empty_or_folder_output_name_is_named_as_such(tmp_path, command):
    """-o '' reported "got '.'", a folder a wrong suffix."""
    np.savetxt(tmp_path / "p.xyz", np.random.default_rng(0).uniform(size=(5, 3)))
    proc = run(*command, "-o", "", cwd=tmp_path)
    assert proc.returncode == 2 and "argument -o/--output: expected a file name, got ''" \
        in proc.stderr
    (tmp_path / "o.step").mkdir()
    proc = run(*command, "-o", "o.step", cwd=tmp_path)
    assert proc.returncode == 4
    assert "--output 'o.step' is a folder; give a file name" in proc.stderr



REFUSED_WITH_ENERGY = [
    (["--method", "energy", "--target-degree", "2"],
     "--target-degree 2 applies to --method wavelet or adaptive only, got --method energy, "
     "which keeps the control points, the degree"),
    (["--method", "energy", "--target-degree", "3", "2"], "--target-degree 3 2 applies to"),
    (["--method", "energy", "--boundary", "fixed"],
     "--boundary fixed applies to --method wavelet or adaptive only"),
    (["--method", "energy", "--objective", "fair"], "--objective fair applies to --method "
                                                    "wavelet or adaptive only, got --method "
                                                    "energy"),
    (["--objective", "faithful"], "--objective faithful applies to --method adaptive only, "
                                  "got --method wavelet"),
    (["--method", "energy", "--grading", "uniform"], "--grading uniform applies to --method "
                                                     "wavelet only, got --method energy"),
]


@pytest.mark.parametrize("command, args, words", [
    *[("fair", args, words) for args, words in REFUSED_WITH_ENERGY],
    *[("batch", args, words) for args, words in REFUSED_WITH_ENERGY],
    ("fair", ["--method", "energy", "--target", "6", "6"],
     "--method energy keeps the control points; give --tol instead of --target"),
    ("fair", ["--grading", "uniform", "--target", "6", "6"],
     "--grading uniform applies to the tolerance search, which does not run with --target"),
])
def test_an_option_the_method_does_not_use_is_a_one_line_usage_error(box, tmp_path, command,
                                                                      args, words):
    """Checked before the model is read (or Dask started): exit 2, the option, why, and
    what to do, on one line."""
    output = ["-o", "o.step"] if command == "fair" else ["-o", "out"]
    proc = run(command, box, *output, *args, cwd=tmp_path)
    assert_one_line_error(proc, 2, tmp_path, words)
    assert proc.stderr.rstrip().endswith(".")
    assert not (tmp_path / "out").exists()


def test_grading_uniform_keeps_the_graded_faces_on_uniform_targets(tmp_path):
    """The IEA blade's faces faired alone (``--joins free``) at 3e-3 of its size: by
    default the two main faces (spanwise spans graded 74 to 1) take graded targets and
    fewer poles, with ``--grading uniform`` uniform ones and more; both within the
    tolerance by OCCT's check."""
    faces = {}
    for grading in ("auto", "uniform"):
        report = tmp_path / f"{grading}.json"
        proc = run("fair", BLADE, "-o", tmp_path / f"{grading}.step", "--joins", "free",
                   "--tol", "0.35", "--grading", grading, "--report", report, cwd=tmp_path)
        assert proc.returncode == 0, proc.stderr
        written = json.loads(report.read_text())
        assert written["grading"] == grading
        faces[grading] = written["faces"]
    for auto, uniform in zip(faces["auto"][1:], faces["uniform"][1:]):
        assert auto["status"] == uniform["status"] == "ok"
        assert "graded like the source's knot spans" in auto["message"]
        assert "graded" not in uniform["message"]
        assert np.prod(auto["poles_after"]) < np.prod(uniform["poles_after"])
        assert max(auto["max_deviation"], uniform["max_deviation"]) <= 0.35
