"""The OCP layer stays an adapter: importing cq_fairing, or asking the command line for
help, must not load OCP (nor scipy, whose submodules are loaded on first use)."""

import subprocess
import sys

HEAVY = ("OCP", "cadquery", "scipy")


def _loaded_after(statement):
    """Which of ``HEAVY`` a fresh interpreter holds after running ``statement``."""
    code = (f"import sys\n{statement}\n"
            f"print(' '.join(m for m in {HEAVY!r} if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return out.stdout.split()


def test_import_cq_fairing_does_not_load_ocp():
    assert _loaded_after("import cq_fairing") == []


def test_cli_help_does_not_load_ocp():
    statement = ("import contextlib, io\nfrom cq_fairing.cli import main\n"
                 "with contextlib.redirect_stdout(io.StringIO()) as text:\n"
                 "    try:\n        main(['--help'])\n    except SystemExit as exc:\n"
                 "        assert exc.code == 0, exc.code\n"
                 "assert 'usage: cq-fairing' in text.getvalue(), text.getvalue()")
    assert _loaded_after(statement) == []


def test_core_names_load_on_first_use():
    assert _loaded_after("import cq_fairing\ncq_fairing.fair_surface") == ["scipy"]


def test_public_api_names():
    import cq_fairing.occ as occ

    for name in ("read_shape", "write_shape", "face_to_surface", "surface_to_face",
                 "fair_face", "fair_shape", "list_faces", "FaceInfo", "FaceFairReport",
                 "ShapeFairResult", "sample_face_deviation"):
        assert hasattr(occ, name), name
