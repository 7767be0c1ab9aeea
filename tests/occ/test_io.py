"""Reading and writing model files: typed errors, atomic writes, round trips."""

import hashlib
import os
import stat
import time

import numpy as np
import pytest

from cq_fairing.errors import FileFormatError, InvalidOutputError, OutputPathError
from cq_fairing.occ import list_faces, read_shape, write_shape
from tests.conftest import data_path
from tests.occ.helpers import area, faces_of, volume


@pytest.mark.parametrize("name, n_faces", [
    ("linkrods.step", 37), ("IEA_15MW_CFD.stp", 3), ("impeller.igs", 277),
    ("testtoler.brep", 56), ("ring_nurbs.brep", 1), ("terrain.brep", 1)])
def test_reads_every_real_model(real, name, n_faces):
    assert len(list_faces(real(name))) == n_faces


def test_missing_empty_corrupt_truncated_and_unknown_files(tmp_path):
    with pytest.raises(FileFormatError, match="no such file"):
        read_shape(tmp_path / "absent.step")
    (tmp_path / "empty.step").write_bytes(b"")
    with pytest.raises(FileFormatError, match="empty"):
        read_shape(tmp_path / "empty.step")
    (tmp_path / "junk.step").write_text("this is not STEP\n" * 10)
    with pytest.raises(FileFormatError):
        read_shape(tmp_path / "junk.step")
    (tmp_path / "junk.brep").write_text("DBRep_DrawableShape\nnonsense\n")
    with pytest.raises(FileFormatError):
        read_shape(tmp_path / "junk.brep")
    data = data_path("linkrods.step").read_bytes()
    (tmp_path / "half.step").write_bytes(data[: len(data) // 2])
    with pytest.raises(FileFormatError):
        read_shape(tmp_path / "half.step")
    (tmp_path / "model.obj").write_text("v 0 0 0\n")
    with pytest.raises(FileFormatError, match="suffix"):
        read_shape(tmp_path / "model.obj")


def test_step_without_faces_is_refused(tmp_path):
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    writer = STEPControl_Writer()
    writer.Transfer(BRepBuilderAPI_MakeVertex(gp_Pnt(1, 2, 3)).Vertex(), STEPControl_AsIs)
    writer.Write(str(tmp_path / "point.step"))
    with pytest.raises(FileFormatError, match="no shape with faces"):
        read_shape(tmp_path / "point.step")


@pytest.mark.parametrize("suffix", [".step", ".brep"])
def test_write_round_trip_keeps_faces_and_geometry(real, tmp_path, suffix):
    shape = real("linkrods.step")
    out = tmp_path / f"copy{suffix}"
    write_shape(shape, out)
    back = read_shape(out)
    assert len(faces_of(back)) == len(faces_of(shape))
    assert volume(back) == pytest.approx(volume(shape), rel=1e-6)
    assert area(back) == pytest.approx(area(shape), rel=1e-6)
    assert sorted(os.listdir(tmp_path)) == [out.name]  # no temporary file left


def test_write_refuses_bad_outputs_and_never_touches_the_input(real, tmp_path):
    shape = real("ring_nurbs.brep")
    out = tmp_path / "ring.brep"
    write_shape(shape, out)
    digest = hashlib.sha256(out.read_bytes()).hexdigest()
    with pytest.raises(OutputPathError, match="already exists"):
        write_shape(shape, out)
    with pytest.raises(OutputPathError, match="input"):
        write_shape(shape, out, force=True, input_path=out)
    assert hashlib.sha256(out.read_bytes()).hexdigest() == digest
    write_shape(shape, out, force=True)
    with pytest.raises(OutputPathError, match="does not exist"):
        write_shape(shape, tmp_path / "missing" / "x.brep")
    with pytest.raises(OutputPathError, match="folder"):
        write_shape(shape, tmp_path)
    with pytest.raises(OutputPathError):
        write_shape(shape, "/proc/cq_fairing_cannot_write_here.brep")
    with pytest.raises(FileFormatError, match="suffix"):
        write_shape(shape, tmp_path / "ring.iges")


def test_invalid_shape_is_not_written(tmp_path):
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    compound = TopoDS_Compound()
    BRep_Builder().MakeCompound(compound)
    with pytest.raises(InvalidOutputError, match="cannot be read back .*nothing was written"):
        write_shape(compound, tmp_path / "empty.brep")
    assert not list(tmp_path.iterdir())


def test_step_unit_setting_is_restored(real, tmp_path):
    from OCP.Interface import Interface_Static

    before = Interface_Static.CVal_s("write.step.unit")
    write_shape(real("ring_nurbs.brep"), tmp_path / "ring_m.step", unit="M")
    assert Interface_Static.CVal_s("write.step.unit") == before
    back = read_shape(tmp_path / "ring_m.step")
    assert volume(back) == pytest.approx(volume(real("ring_nurbs.brep")), rel=1e-6, abs=1e-9)
    assert area(back) == pytest.approx(area(real("ring_nurbs.brep")), rel=1e-6)
    assert np.isfinite(area(back))


def test_step_unit_is_read_and_kept(real, tmp_path):
    from cq_fairing.occ.io import step_length_unit

    assert step_length_unit(data_path("linkrods.step")) == "MM"
    out = tmp_path / "ring_in_m.step"
    write_shape(real("ring_nurbs.brep"), out, unit="M")
    assert step_length_unit(out) == "M"
    assert "SI_UNIT($,.METRE.)" in out.read_text().replace(" ", "")


# -- G4, G6, G8 and file modes -------------------------------------------------------------
QUIET = """
import sys
from cq_fairing.occ import read_shape, write_shape
shape = read_shape(sys.argv[1])
write_shape(shape, sys.argv[2])
read_shape(sys.argv[2])
"""


def test_reading_and_writing_print_nothing(tmp_path):
    """G4: OCCT's transfer banner and statistics are silenced in occ/io.py itself (a
    script using the API sees an empty stdout), and OCCT's messenger is restored."""
    import subprocess
    import sys

    from OCP.Message import Message

    from tests.conftest import REPO, data_path

    proc = subprocess.run([sys.executable, "-c", QUIET, str(data_path("IEA_15MW_CFD.stp")),
                           str(tmp_path / "out.step")], capture_output=True, text=True,
                          env=dict(os.environ, PYTHONPATH=str(REPO)), timeout=120)
    assert proc.returncode == 0, proc.stderr[-800:]
    assert proc.stdout == ""
    before = Message.DefaultMessenger_s().Printers().Size()
    read_shape(data_path("IEA_15MW_CFD.stp"))
    assert Message.DefaultMessenger_s().Printers().Size() == before >= 1


def test_written_files_get_the_mode_of_a_plain_write(real, tmp_path):
    """mkstemp creates 0600; a new output gets 0666 minus the umask, an overwritten one
    keeps its mode, for models and for reports alike."""
    from cq_fairing.report import build_report, write_report

    shape = real("ring_nurbs.brep")
    old = os.umask(0o027)
    try:
        write_shape(shape, tmp_path / "new.step")
        write_report(build_report([]), tmp_path / "r.json")
        kept = tmp_path / "kept.brep"
        kept.write_text("old")
        os.chmod(kept, 0o604)
        write_shape(shape, kept, force=True)
    finally:
        os.umask(old)
    assert stat.S_IMODE((tmp_path / "new.step").stat().st_mode) == 0o640
    assert stat.S_IMODE((tmp_path / "r.json").stat().st_mode) == 0o640
    assert stat.S_IMODE(kept.stat().st_mode) == 0o604


def test_stale_temporaries_of_killed_writers_are_removed(real, tmp_path):
    """G6: `.cq_fairing_*` files a SIGKILLed writer left (planted here, two days old) are
    removed by the next write into the folder; a fresh one (a live writer's), one of
    another user and unrelated hidden files stay."""
    from cq_fairing.report import STALE_SECONDS

    def plant(name, age, uid=None):
        path = tmp_path / name
        path.write_text("partial")
        stamp = time.time() - age
        os.utime(path, (stamp, stamp))
        if uid is not None:
            os.chown(path, uid, -1)
        return path

    stale = plant(".cq_fairing_k1l2m3.step", 2 * STALE_SECONDS)
    stale_report = plant(".cq_fairing_q9w8.json", 2 * STALE_SECONDS)
    fresh = plant(".cq_fairing_live.step", 60)
    foreign = plant(".cq_fairing_other.step", 2 * STALE_SECONDS, uid=os.getuid() + 4242)
    unrelated = plant(".hidden.step", 2 * STALE_SECONDS)
    write_shape(real("ring_nurbs.brep"), tmp_path / "out.brep")
    assert not stale.exists() and not stale_report.exists()
    assert fresh.exists() and foreign.exists() and unrelated.exists()


def test_an_output_under_a_regular_file_is_named_as_a_file(real, tmp_path):
    """G8: 'x' is a file, not a folder (API and report writers)."""
    from cq_fairing.report import check_output_path

    blocker = tmp_path / "afile"
    blocker.write_text("x")
    for target in (blocker / "out.step", blocker / "deeper" / "out.step"):
        with pytest.raises(OutputPathError, match="afile' is a file, not a folder"):
            write_shape(real("ring_nurbs.brep"), target)
        with pytest.raises(OutputPathError, match="afile' is a file, not a folder"):
            check_output_path(target)
