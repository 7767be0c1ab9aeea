"""Curvature against closed forms, maps as real images, atomic writers."""

import json

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing import viz
from cq_fairing.errors import OutputPathError
from cq_fairing.report import atomic_output, build_report, face_entry, write_report


def paraboloid():
    """z = x^2 + y^2 on [-1, 1]^2 as an exact biquadratic Bezier patch."""
    xs = np.array([-1.0, 0.0, 1.0])
    poles = np.zeros((3, 3, 3))
    for i, x in enumerate(xs):
        for j, y in enumerate(xs):
            # Bezier ordinates of x^2 on [-1, 1]: 1, -1, 1
            zx = (1.0, -1.0, 1.0)[i]
            zy = (1.0, -1.0, 1.0)[j]
            poles[i, j] = (x, y, zx + zy)
    knots = np.r_[0, 0, 0, 1, 1, 1.0]
    return cf.BSplineSurface(poles, knots, knots, 2, 2)


def test_curvature_of_a_paraboloid_matches_the_closed_form():
    surface = paraboloid()
    u = v = np.linspace(0, 1, 7)
    curv = viz.surface_curvature(surface, u, v)
    x, y = curv["points"][..., 0], curv["points"][..., 1]
    assert np.allclose(curv["points"][..., 2], x ** 2 + y ** 2)
    r2 = 4 * (x ** 2 + y ** 2)
    assert np.allclose(curv["gaussian"], 4 / (1 + r2) ** 2)
    assert np.allclose(np.abs(curv["mean"]), (2 + r2) / (1 + r2) ** 1.5)


def noisy_pair():
    rng = np.random.default_rng(0)
    u, v = np.meshgrid(np.linspace(0, 100, 30), np.linspace(0, 60, 24), indexing="ij")
    pts = np.stack([u, v, 10 * np.sin(u / 30) * np.cos(v / 25)], -1)
    pts[..., 2] += rng.normal(0, 0.05, u.shape)
    noisy = cf.interpolate_grid(pts)
    faired = cf.fair_surface(noisy.poles, (10, 8), u_knots=noisy.u_knots,
                             v_knots=noisy.v_knots, degree=3).surface
    return noisy, faired


def test_fairing_reduces_energy_and_wiggles():
    noisy, faired = noisy_pair()
    before, after = viz.fairness_measures(noisy), viz.fairness_measures(faired)
    assert after["bending_energy"] < 0.5 * before["bending_energy"]
    assert after["wiggles"] < before["wiggles"]


def colours(path):
    from PIL import Image

    return np.asarray(Image.open(path).convert("RGB")).reshape(-1, 3).astype(int)


def test_deviation_png_and_vtp(tmp_path):
    import pyvista as pv

    noisy, faired = noisy_pair()
    u, v = viz.uv_grid(noisy.domain, 40)
    a, b = noisy.evaluate_grid(u, v), faired.evaluate_grid(u, v)
    d = np.linalg.norm(a - b, axis=-1)
    mesh = viz.deviation_mesh({"points": a, "distance": d, "signed": d})
    stats = viz.render_deviation_map(mesh, tmp_path / "m.png", tolerance=0.2)
    assert stats["max"] == pytest.approx(d.max())
    px = colours(tmp_path / "m.png")
    assert len(np.unique(px, axis=0)) > 50
    green = (px[:, 1] > 120) & (px[:, 0] < 80) & (px[:, 2] < 80)
    red = (px[:, 0] > 170) & (px[:, 1] < 80) & (px[:, 2] < 80)
    assert green.sum() > 100 and red.sum() > 20
    viz.save_mesh(mesh, tmp_path / "m.vtp")
    back = pv.read(tmp_path / "m.vtp")
    assert np.isclose(back.point_data["deviation"].max(), d.max())
    with pytest.raises(OutputPathError):
        viz.save_mesh(mesh, tmp_path / "m.vtp")


def test_curvature_png_uses_one_range_for_both(tmp_path):
    noisy, faired = noisy_pair()
    out = viz.render_curvature_maps(noisy, faired, tmp_path / "c.png", density=50)
    assert out["after"]["wiggles"] < out["before"]["wiggles"]
    px = colours(tmp_path / "c.png")
    blue = (px[:, 2] > 150) & (px[:, 0] < 120)
    red = (px[:, 0] > 150) & (px[:, 2] < 120) & (px[:, 1] < 120)
    assert blue.sum() > 100 and red.sum() > 100


def test_atomic_output_leaves_nothing_on_failure(tmp_path):
    target = tmp_path / "r.json"
    with pytest.raises(RuntimeError):
        with atomic_output(target) as tmp:
            tmp.write_text("partial")
            raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_report_json_and_html(tmp_path):
    face = face_entry(1, surface_type="BSpline", status="ok", poles_before=(10, 10),
                      poles_after=(6, 5), max_deviation=0.01, tolerance=0.02,
                      fairness_before={"bending_energy": float("nan")}, seconds=0.5)
    report = build_report([face, face_entry(2, status="skipped", message="a plane")],
                          tolerance=0.02, method="wavelet")
    write_report(report, tmp_path / "r.json")
    back = json.loads((tmp_path / "r.json").read_text())
    assert back["summary"]["poles_before"] == 100 and back["summary"]["poles_after"] == 30
    assert back["skipped"] == [{"index": 2, "reason": "a plane"}]
    write_report(report, tmp_path / "r.html")
    assert "a plane" in (tmp_path / "r.html").read_text()
    with pytest.raises(OutputPathError):
        write_report(report, tmp_path / "r.txt")
