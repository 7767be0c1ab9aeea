"""The adaptive method (knots that follow the error) and its objectives inside FreeCAD.

Checked on the seeded noisy 50 x 80 bicubic face of :mod:`fixtures` at 0.05 mm: the
tolerance by FreeCAD's own ``distToShape`` (independent of the core's closest points),
the pole count against the wavelet method, the feature's properties through save and
reopen, the plain-words refusal of target mode, and a real rational face.
"""

import warnings

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import feature, make

import fixtures

TOL = 0.05


@pytest.fixture(scope="module")
def face():
    surface, _ = fixtures.noisy_blade_surface(50, 80)
    return surface.toShape()


@pytest.fixture(scope="module")
def faired(face):
    """One :class:`make.FairedShape` per setting (the adaptive runs take seconds), through
    the core's option names: an old spelling would raise its DeprecationWarning here."""
    settings = {"wavelet linear": dict(search="linear"),
                "wavelet guaranteed": dict(search="guaranteed"),
                "adaptive compact": dict(method="adaptive", objective="compact"),
                "adaptive faithful": dict(method="adaptive", objective="faithful"),
                "adaptive fair": dict(method="adaptive", objective="fair"),
                "adaptive free": dict(method="adaptive", borders="free")}
    with warnings.catch_warnings():
        warnings.filterwarnings("error", r".*is deprecated, use", DeprecationWarning)
        return {name: make.fair_face(face, tolerance=TOL, **kw) for name, kw in settings.items()}



@pytest.fixture
def noisy(doc, face):
    obj = fixtures.add_shape(doc, face, "Noisy")
    doc.recompute()
    return obj


def _count(poles):
    return int(np.prod(poles))


def _ok(obj):
    return fixtures.status_ok(obj)


@pytest.mark.parametrize("objective", ["compact", "faithful", "fair"])
def test_adaptive_meets_the_tolerance_by_freecad_distance(face, faired, objective):
    result = faired[f"adaptive {objective}"]
    shape = result.shape.Faces[0]
    assert shape.isValid()
    assert result.max_deviation <= TOL
    assert fixtures.sample_distance(shape, face, 15) <= TOL


def test_adaptive_needs_fewer_poles_than_wavelet(faired):
    """On this face: wavelet 39 x 62 (linear) / 37 x 64 (guaranteed), adaptive 19 x 21."""
    wavelet = min(_count(faired[k].poles_after) for k in ("wavelet linear",
                                                          "wavelet guaranteed"))
    for objective in ("compact", "faithful"):
        assert _count(faired[f"adaptive {objective}"].poles_after) <= wavelet
    assert 2 * _count(faired["adaptive compact"].poles_after) < wavelet


def test_adaptive_targets_have_non_uniform_knots(faired):
    surface = faired["adaptive compact"].shape.Faces[0].Surface
    spans = [np.diff(surface.getUKnots()), np.diff(surface.getVKnots())]
    assert any(s.max() > 1.05 * s.min() for s in spans)


def test_objective_needs_the_adaptive_method_and_borders_a_tolerance_search(face):
    with pytest.raises(cf.InvalidInputError, match="applies to the adaptive method only"):
        make.fair_face(face, tolerance=TOL, objective="faithful")
    with pytest.raises(cf.InvalidInputError, match="wavelet method's tolerance search only"):
        make.fair_face(face, target=(10, 10), borders="free")
    with pytest.raises(cf.InvalidInputError, match="wavelet method's tolerance search only"):
        make.fair_face(face, tolerance=TOL, method="energy", borders="pinned")
    with pytest.raises(cf.InvalidInputError, match="borders must be one of"):
        make.fair_face(face, tolerance=TOL, method="adaptive", borders="edges")


def test_borders_reach_the_core(face, faired):
    """Auto pins the borders on this face (the corner poles are the source's, 11 x 11);
    free ones are the plain projection (corners move, more poles), within TOL too."""
    corners = [(0, 0), (0, -1), (-1, 0), (-1, -1)]

    def corner_poles(shape):
        poles = np.array([[tuple(p) for p in row] for row in shape.Faces[0].Surface.getPoles()])
        return np.array([poles[i, j] for i, j in corners])

    source = corner_poles(face)
    np.testing.assert_allclose(corner_poles(faired["adaptive compact"].shape), source,
                               atol=1e-9)
    free = faired["adaptive free"]
    assert np.abs(corner_poles(free.shape) - source).max() > 1e-6
    assert _count(free.poles_after) > _count(faired["adaptive compact"].poles_after)
    assert fixtures.sample_distance(free.shape.Faces[0], face, 15) <= TOL


def test_target_mode_is_refused_in_plain_words(doc, noisy, face):
    with pytest.raises(cf.InvalidInputError, match="needs tolerance mode"):
        make.fair_face(face, target=(18, 26), method="adaptive")
    obj = make.make_fairing((noisy, ["Face1"]), target=(18, 26), method="adaptive")
    doc.recompute()
    assert not obj.isValid()
    assert obj.Status.startswith("Error: the adaptive method chooses the control points")


def test_rational_face_is_faired_and_stays_rational(doc):
    """A rational trimmed face of linkrods (7 x 73 poles, degree 6 x 8, weights 0.86-1)
    at 0.01 mm: the feature recomputes, the face is rational with positive weights and
    fewer poles, and FreeCAD's own distToShape finds it within the tolerance (alone:
    Joins free, as its joins with its neighbours run across its surface)."""
    shape = Part.read(str(fixtures.REAL / "linkrods.step"))
    src = fixtures.add_shape(doc, shape, "Linkrods")
    index = next(i for i, f in enumerate(shape.Faces)
                 if isinstance(f.Surface, Part.BSplineSurface)
                 and f.Surface.isURational() and f.Surface.NbVPoles == 73)
    obj = make.make_fairing((src, [f"Face{index + 1}"]), tolerance=0.01, method="adaptive",
                            joins="free")
    doc.recompute()
    assert obj.isValid() and obj.Status.startswith("OK; joins: 6 (0 held closed)"), obj.Status
    surface = obj.Shape.Faces[0].Surface
    assert surface.isURational() or surface.isVRational()
    assert min(w for row in surface.getWeights() for w in row) > 0
    assert surface.NbUPoles * surface.NbVPoles < 7 * 73
    assert obj.MaxDeviation <= 0.01
    assert fixtures.sample_distance(obj.Shape.Faces[0], shape.Faces[index], 15) <= 0.01


def test_feature_faithful_save_reopen_keeps_method_and_objective(doc, noisy, faired,
                                                                  tmp_path):
    obj = make.make_fairing((noisy, ["Face1"]), tolerance=TOL, method="adaptive",
                            objective="faithful")
    doc.recompute()
    assert _ok(obj), obj.Status
    assert obj.PolesAfter == " x ".join(map(str, faired["adaptive faithful"].poles_after))
    assert fixtures.sample_distance(obj.Shape.Faces[0], noisy.Shape.Faces[0], 12) <= TOL
    with fixtures.reopened(doc, tmp_path / "adaptive.FCStd") as reopened:
        again = reopened.getObject("Fairing")
        assert (again.Method, again.Objective) == ("adaptive", "faithful")
        again.Objective = "compact"
        reopened.recompute()
        assert _ok(again), again.Status
        assert again.PolesAfter == " x ".join(map(str, faired["adaptive compact"].poles_after))
        assert again.Borders == "auto"
        again.Borders = "free"
        reopened.recompute()
        assert _ok(again), again.Status
        assert again.PolesAfter == " x ".join(map(str, faired["adaptive free"].poles_after))


def test_the_wavelet_default_is_polished_within_the_tolerance(doc, noisy, face):
    """The wavelet method's tolerance search polishes its winner by default (Objective
    ``auto``, a new feature's): the same control points as ``compact``, within the
    tolerance by FreeCAD's own distance, less thin-plate bending energy by the core's
    quadrature, and the note says so."""
    from cq_fairing.core.fairness import fairness_summary
    from fairing_wb import conversion

    plain = make.fair_face(face.Faces[0], tolerance=TOL, objective="compact")
    polished = make.fair_face(face.Faces[0], tolerance=TOL)
    assert polished.poles_after == plain.poles_after
    assert "polished" in polished.note and "polished" not in plain.note
    assert fixtures.sample_distance(polished.shape.Faces[0], face.Faces[0], 15) <= TOL
    source = conversion.surface_from_face(face.Faces[0])
    bending = [fairness_summary(source, conversion.surface_from_face(r.shape.Faces[0]))
               ["bending_energy"]["after"] for r in (polished, plain)]
    assert bending[0] < bending[1]
    obj = make.make_fairing((noisy, ["Face1"]), tolerance=TOL)
    assert obj.Objective == "auto" == make.OBJECTIVES[0]
    doc.recompute()
    assert _ok(obj), obj.Status
    assert obj.PolesAfter == " x ".join(map(str, polished.poles_after))


def test_document_of_version_1_migrates(doc, noisy, tmp_path):
    """A version-1 document: Method offered wavelet/energy only, no Objective (added in
    version 2) and no Borders (version 3)."""
    obj = make.make_fairing((noisy, ["Face1"]), target=(18, 26), method="wavelet")
    doc.recompute()
    obj.Method = ["wavelet", "energy"]
    obj.removeProperty("Objective")
    obj.removeProperty("Borders")
    with fixtures.reopened(doc, tmp_path / "version1.FCStd") as reopened:
        again = reopened.getObject("Fairing")
        assert again.getEnumerationsOfProperty("Method") == list(make.METHODS)
        assert (again.Method, again.Objective, again.Borders) == ("wavelet", "compact", "auto")
        assert again.Proxy.Version == feature.VERSION
        again.Method = "adaptive"
        reopened.recompute()
        assert "needs tolerance mode" in again.Status  # target mode, refused in words


def test_adaptive_edge_within_tolerance_by_freecad_distance():
    points = [FreeCAD.Vector(x, 10 * np.sin(x / 10), 0.05 * (-1) ** i)
              for i, x in enumerate(np.linspace(0, 60, 61))]
    curve = Part.BSplineCurve()
    curve.interpolate(points)
    source = curve.toShape()
    result = make.fair_edge(source, tolerance=0.1, method="adaptive", objective="faithful")
    edge = result.shape
    far = max(source.distToShape(Part.Vertex(edge.valueAt(t)))[0]
              for t in np.linspace(*edge.ParameterRange, 200))
    assert far <= 0.1
    assert result.poles_after[0] < result.poles_before[0]
