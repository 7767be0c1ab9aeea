"""The OCP layer stays an adapter: importing cq_fairing must not load OCP."""

import subprocess
import sys


def test_import_cq_fairing_does_not_load_ocp():
    code = "import sys, cq_fairing; print('OCP' in sys.modules, 'cadquery' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "False"]


def test_public_api_names():
    import cq_fairing.occ as occ

    for name in ("read_shape", "write_shape", "face_to_surface", "surface_to_face",
                 "fair_face", "fair_shape", "list_faces", "FaceInfo", "FaceFairReport",
                 "ShapeFairResult", "sample_face_deviation"):
        assert hasattr(occ, name), name
