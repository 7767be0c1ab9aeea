"""Deviation and curvature maps against FreeCAD's own distance and curvature."""

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import analysis, conversion, deviation_map, make

import fixtures



@pytest.fixture
def fairing(doc):
    surface, _ = fixtures.noisy_blade_surface(50, 80, noise=0.2)
    source = fixtures.add_shape(doc, surface.toShape(), "Noisy")
    obj = make.make_fairing((source, ["Face1"]), target=(12, 20))
    doc.recompute()
    assert obj.isValid(), obj.Status
    return obj


def test_deviation_map_values_match_occt_distance(doc, fairing):
    dmap = deviation_map.make_map(fairing)
    dmap.Samples = 20
    doc.recompute()
    assert dmap.isValid()
    assert dmap.Mesh.CountPoints == 400 == len(dmap.Values) == len(dmap.VertexColors)
    source_face, faired_face = fairing.Source[0].Shape.Faces[0], fairing.Shape.Faces[0]
    source = conversion.surface_from_face(source_face)
    u, v = analysis.sample_parameters(conversion.uv_range(source_face, source), 20)
    source_points = source.evaluate_grid(u, v).reshape(-1, 3)
    points = dmap.Mesh.Points
    for i in range(0, 400, 37):
        there = source_face.distToShape(Part.Vertex(points[i].Vector))[0]
        back = faired_face.distToShape(Part.Vertex(FreeCAD.Vector(*source_points[i])))[0]
        assert dmap.Values[i] == pytest.approx(max(there, back),
                                               abs=2e-3 * max(dmap.Maximum, 1e-9) + 1e-6)
    assert dmap.Maximum <= fairing.MaxDeviation.Value * 1.05
    assert dmap.Unit == "mm"


def test_two_sided_deviation_sees_a_face_that_stops_short():
    """A plane patch 10 x 10 and a 'faired' one on the same plane and parameter domain
    that stops at x = 9: every faired sample lies on the source (one way: 0), the
    source's border x = 10 is 1 from the faired face."""
    from cq_fairing.core.geometry import make_surface

    def patch(length):
        corners = [[[0, 0, 0], [0, 10, 0]], [[length, 0, 0], [length, 10, 0]]]
        return make_surface(np.array(corners, float), degree=1)

    source, faired = patch(10.0), patch(9.0)
    box = (0.0, 1.0, 0.0, 1.0)
    _, one_way = analysis.signed_deviation(source, faired, box, 11)
    _, both = analysis.two_sided_deviation(source, faired, box, 11)
    assert np.abs(one_way).max() < 1e-12
    assert np.abs(both).max() == pytest.approx(1.0, abs=1e-9)
    # at parameter u the source point 10 u lies max(0, 10 u - 9) from the faired face
    u = np.linspace(0, 1, 11)
    np.testing.assert_allclose(np.abs(both), np.maximum(0, 10 * u - 9)[:, None] * np.ones(11),
                               atol=1e-9)


def test_deviation_at_the_border_matches_occt_on_the_iea_blade(doc):
    """IEA blade Face2 at 0.5 mm (the linear search, geometric measure): the largest deviation sits at a
    corner sample whose closest source point lies on the face's border.  Foot points
    that slide along the border give FreeCAD's distance there (they once stopped at
    0.6076 where ``distToShape`` gives 0.4962, above the tolerance)."""
    shape = Part.read(str(fixtures.BLADE))
    blade = fixtures.add_shape(doc, shape, "Blade")
    obj = make.make_fairing((blade, ["Face2"]), tolerance=0.5, search="linear",
                            measure="geometric")
    doc.recompute()
    assert obj.isValid(), obj.Status
    source_face = shape.Faces[1]
    source = conversion.surface_from_face(source_face)
    faired = conversion.surface_from_face(obj.Shape.Faces[0])
    points, d = analysis.signed_deviation(source, faired, conversion.uv_range(source_face, source),
                                          30)
    occt = np.array([source_face.distToShape(Part.Vertex(FreeCAD.Vector(*p)))[0]
                     for p in points.reshape(-1, 3)])
    np.testing.assert_allclose(np.abs(d).ravel(), occt, rtol=1e-3, atol=1e-6)
    assert obj.MaxDeviation.Value == pytest.approx(occt.max(), rel=1e-3)
    assert obj.MaxDeviation.Value <= 0.5


def test_colours_run_green_to_red(doc, fairing):
    dmap = deviation_map.make_map(fairing)
    doc.recompute()
    low, high = deviation_map.AnalysisMap.range(dmap)
    assert low == 0.0 and high == pytest.approx(dmap.Maximum)
    i_max = int(np.argmax(dmap.Values))
    i_min = int(np.argmin(dmap.Values))
    red, green = dmap.VertexColors[i_max], dmap.VertexColors[i_min]
    assert red[0] > 0.8 and red[1] < 0.1
    assert green[1] > green[0]


def test_map_does_not_touch_the_faired_model(doc, fairing):
    poles = fairing.Shape.Faces[0].Surface.getPoles()
    seconds = fairing.FairingTime  # changes on every recompute of the fairing
    deviation_map.make_map(fairing)
    doc.recompute()
    assert fairing.FairingTime == seconds
    assert fairing.Shape.Faces[0].Surface.getPoles() == poles
    assert fairing.State == [] or fairing.State == ["Up-to-date"]


def test_curvature_of_a_cylinder_face_closed_form():
    radius = 7.0
    face = Part.makeCylinder(radius, 20).Faces[0].toNurbs().Faces[0]
    core = conversion.surface_from_face(face)
    _, mean = analysis.curvature(core, face.ParameterRange, 9, "mean")
    _, gauss = analysis.curvature(core, face.ParameterRange, 9, "gaussian")
    assert np.abs(np.abs(mean) - 1 / (2 * radius)).max() < 1e-6
    assert np.abs(gauss).max() < 1e-8


def test_curvature_is_undefined_only_where_a_border_collapses(doc):
    """A sphere's NURBS face collapses its first and last pole rows to the poles: there
    the normal, and with it the curvature, is undefined (NaN); everywhere else the mean
    curvature is 1/r.  The map leaves the undefined samples out instead of colouring
    them with whatever a division by zero gives."""
    radius = 5.0
    face = Part.makeSphere(radius).Faces[0].toNurbs().Faces[0]
    core = conversion.surface_from_face(face)
    _, mean = analysis.curvature(core, face.ParameterRange, 9, "mean")
    undefined = np.isnan(mean)
    assert undefined.sum() == 18
    assert np.abs(np.abs(mean[~undefined]) - 1 / radius).max() < 1e-9
    source = fixtures.add_shape(doc, face, "Sphere")
    obj = make.make_fairing((source, ["Face1"]), target=(5, 5))
    doc.recompute()
    assert obj.isValid(), obj.Status
    cmap = deviation_map.make_map(obj, "MeanCurvature", "Source")
    cmap.Samples = 9
    doc.recompute()
    assert cmap.isValid()
    assert cmap.Mesh.CountPoints == len(cmap.Values) == 81 - 18
    assert np.abs(np.abs(cmap.Values) - 1 / radius).max() < 1e-9


def test_curvature_matches_occt_on_the_blade():
    face = fixtures.blade_shape().Faces[1]
    core = conversion.surface_from_face(face)
    u0, u1, v0, v1 = face.ParameterRange
    _, mean = analysis.curvature(core, face.ParameterRange, 5, "mean")
    us, vs = np.linspace(u0, u1, 5), np.linspace(v0, v1, 5)
    occt = np.array([[face.Surface.curvature(u, v, "Mean") for v in vs] for u in us])
    # OCCT's sign follows its own normal; compare magnitudes.
    assert np.allclose(np.abs(mean), np.abs(occt), rtol=1e-5, atol=1e-9)


def test_curvature_maps_before_after_share_range(doc, fairing):
    faired, source = deviation_map.make_curvature_maps(fairing)
    doc.recompute()
    deviation_map.share_range([faired, source])
    doc.recompute()
    assert faired.isValid() and source.isValid()
    assert (faired.RangeMin, faired.RangeMax) == (source.RangeMin, source.RangeMax)
    # Fairing calmed the curvature: its spread is smaller than the noisy source's.
    assert np.std(faired.Values) < np.std(source.Values)
    box, shifted = fairing.Shape.BoundBox, source.Mesh.BoundBox  # shown beside
    assert shifted.XMin > box.XMax or shifted.YMin > box.YMax


def test_map_survives_save_and_reopen(doc, fairing, tmp_path):
    dmap = deviation_map.make_map(fairing)
    doc.recompute()
    values = list(dmap.Values)
    with fixtures.reopened(doc, tmp_path / "map.FCStd") as reopened:
        again = [o for o in reopened.Objects if o.TypeId == "Mesh::FeaturePython"][0]
        again.touch()
        reopened.recompute()
        assert again.isValid()
        assert again.Values == pytest.approx(values)


def test_switch_map_to_gaussian_curvature(doc, fairing):
    cmap = deviation_map.make_map(fairing, "MeanCurvature", "Faired")
    cmap.Samples = 21  # odd: the middle sample sits at the middle of the UV box
    doc.recompute()
    cmap.Kind = "GaussianCurvature"
    doc.recompute()
    assert cmap.isValid() and cmap.Unit == "1/mm^2"
    core = conversion.surface_from_face(fairing.Shape.Faces[0])
    _, gauss = analysis.curvature(core, fairing.Shape.Faces[0].ParameterRange, cmap.Samples,
                                  "gaussian")
    assert np.allclose(cmap.Values, gauss.ravel())
    face = fairing.Shape.Faces[0]
    u0, u1, v0, v1 = face.ParameterRange
    occt = face.Surface.curvature(0.5 * (u0 + u1), 0.5 * (v0 + v1), "Gauss")
    assert gauss[10, 10] == pytest.approx(occt, rel=1e-6, abs=1e-12)


def test_map_of_a_sewn_multi_face_fairing(doc):
    blade = fixtures.add_shape(doc, fixtures.blade_shape(), "Blade")
    obj = make.make_fairing((blade, ["Face1", "Face2", "Face3"]), target=(12, 40))
    doc.recompute()
    assert obj.isValid(), obj.Status
    dmap = deviation_map.make_map(obj)
    dmap.Samples = 12
    doc.recompute()
    assert dmap.isValid() and dmap.Mesh.CountPoints == 3 * 144
    assert dmap.Maximum <= 1.05 * obj.MaxDeviation.Value


def test_maps_of_a_trimmed_face_cover_its_trim_only(doc):
    """On linkrods Face21 (trimmed) 173 of 3600 map vertices lay outside the faired face,
    up to 0.089 mm away, and the map's area exceeded the face's (QA D9): the maps keep
    the samples on the trim only, and MaxDeviation is their largest distance."""
    rods = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / "linkrods.step")), "Rods")
    fairing = make.make_fairing((rods, ["Face21"]), target=(7, 40))
    doc.recompute()
    face = fairing.Shape.Faces[0]
    for kind in ("Deviation", "MeanCurvature"):
        mapped = deviation_map.make_map(fairing, kind)
        mapped.recompute()
        points = mapped.Mesh.Points
        assert len(mapped.Values) == len(points) == len(mapped.VertexColors)
        assert 0.8 * 3600 < len(points) < 3600  # samples outside the trim are dropped
        assert all(face.isInside(FreeCAD.Vector(p.x, p.y, p.z), 1e-4, True) for p in points)
        assert mapped.Mesh.Area <= face.Area
    deviation = deviation_map.find_maps(fairing, "Deviation")[0]
    assert fairing.MaxDeviation.Value == pytest.approx(deviation.Maximum, rel=0.5)


def test_the_sampled_check_is_the_largest_distance_over_every_sample():
    """``SampledDeviation`` measures only the samples whose parametric distance could beat
    the largest distance found; its value is the maximum over all samples, bit for bit,
    for nets from far too coarse to the one that passes 0.05 mm."""
    face = fixtures.noisy_blade_surface(50, 80)[0].toShape().Faces[0]
    source = conversion.surface_from_face(face)
    u, v = np.linspace(0, 1, 101), np.linspace(0, 1, 161)
    cu, cv = 0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1])
    check = analysis.SampledDeviation(source, ((u, v, np.ones((101, 161), bool)),
                                               (cu, cv, np.ones((100, 160), bool))))
    for n in ((9, 6), (20, 30), (35, 62)):
        faired = cf.fair_surface(source.poles, n, u_knots=source.u_knots,
                                 v_knots=source.v_knots, degree=(3, 3)).surface
        assert check(faired) == check.distances(faired).max() > 0.0
