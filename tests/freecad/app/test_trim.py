"""The trim classification of grid samples (``fairing_wb.trim.on_face``) gives OCCT's
``isPartOfDomain`` at every sample, on real trimmed faces, inside FreeCAD (no mocks)."""

import numpy as np
import pytest

import Part
from fairing_wb import trim

import fixtures


def _bspline_faces(name, count):
    shape = Part.read(str(fixtures.REAL / name))
    return [f for f in shape.Faces if isinstance(f.Surface, Part.BSplineSurface)][:count]


def _occt(face, u, v):
    return np.array([[face.isPartOfDomain(float(a), float(b)) for b in v] for a in u])


@pytest.mark.parametrize("name, count", [("linkrods.step", 18), ("impeller.igs", 24)])
def test_every_sample_is_classified_as_occt_classifies_it(name, count):
    """Grids over and a little beyond each face's parameter box, shifted at random so
    that rows fall anywhere against the trims' vertices; OCCT is asked only near the
    trim, on far fewer samples than the grids hold."""
    rng = np.random.default_rng(7)
    samples = trimmed = asked = 0
    for face in _bspline_faces(name, count):
        u0, u1, v0, v1 = face.ParameterRange
        du, dv = 0.05 * (u1 - u0), 0.05 * (v1 - v0)
        u = np.linspace(u0 - du, u1 + du, 29) + rng.uniform(-0.5, 0.5) * du
        v = np.linspace(v0 - dv, v1 + dv, 23) + rng.uniform(-0.5, 0.5) * dv
        fast = trim.on_face(face, u, v)
        occt = _occt(face, u, v)
        assert np.array_equal(fast, occt), (name, face.ParameterRange)
        samples += fast.size
        trimmed += int((~occt).sum())
        segments, band = trim._polygon(face)
        asked += int((trim._even_odd(segments, u, v)[1] | trim._near(segments, band, u, v))
                     .sum())
    assert trimmed > 0.05 * samples      # trims that cut the grids: the rule is exercised
    assert asked < 0.25 * samples, (asked, samples)


def test_a_face_on_a_seam_is_asked_sample_by_sample():
    """The doubly periodic ring has seams: no polygon, OCCT at every sample."""
    face = Part.read(str(fixtures.REAL / "ring_nurbs.brep")).Faces[0]
    assert trim._polygon(face) is None
    u0, u1, v0, v1 = face.ParameterRange
    u, v = np.linspace(u0, u1, 9), np.linspace(v0, v1, 7)
    assert np.array_equal(trim.on_face(face, u, v), _occt(face, u, v))
