"""Points to surface / curve from x y z files."""

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import points

import fixtures



def _write(path, xyz):
    np.savetxt(path, xyz, fmt="%.9f")
    return str(path)


def test_grid_file_gives_interpolating_surface(doc, tmp_path):
    u, v = np.meshgrid(np.linspace(0, 10, 12), np.linspace(0, 20, 15), indexing="ij")
    grid = np.stack([u, v, np.sin(u / 3) * np.cos(v / 5)], axis=2)
    path = _write(tmp_path / "grid.xyz", grid.reshape(-1, 3))
    obj, message = points.make_points_shape(path, doc=doc)
    assert "12 x 15 point grid" in message
    face = obj.Shape.Faces[0]
    assert (face.Surface.NbUPoles, face.Surface.NbVPoles) == (14, 17)
    far = max(face.distToShape(Part.Vertex(FreeCAD.Vector(*p)))[0] for p in grid.reshape(-1, 3)[::7])
    assert far < 1e-6


def test_single_run_gives_curve(doc, tmp_path):
    t = np.linspace(0, 6, 40)
    run = np.c_[t, np.sin(t), 0 * t]
    obj, message = points.make_points_shape(_write(tmp_path / "run.xyz", run), doc=doc)
    assert "interpolating curve with 42 poles" in message
    edge = obj.Shape.Edges[0]
    assert max(edge.distToShape(Part.Vertex(FreeCAD.Vector(*p)))[0] for p in run) < 1e-6


def test_scattered_scan_is_refused_then_resampled(doc, tmp_path):
    cloud = np.loadtxt(fixtures.REAL / "01_points.asc")[::20]
    path = _write(tmp_path / "scan.xyz", cloud)
    with pytest.raises(cf.InvalidInputError, match="not an ordered grid"):
        points.make_points_shape(path, doc=doc)
    obj, message = points.make_points_shape(path, resample=(30, 30), doc=doc)
    assert "resampled to a 30 x 30 grid" in message
    face = obj.Shape.Faces[0]
    assert face.isValid()
    # The surface passes near the scan: median distance well below the cloud's size.
    sample = cloud[:: max(1, len(cloud) // 150)]
    d = [face.distToShape(Part.Vertex(FreeCAD.Vector(*p)))[0] for p in sample]
    assert np.median(d) < 0.02 * np.ptp(cloud, axis=0).max()


def test_missing_file_is_a_clear_error(doc, tmp_path):
    with pytest.raises(cf.InvalidInputError, match="does not exist"):
        points.make_points_shape(str(tmp_path / "nope.xyz"), doc=doc)
