"""The trim classification of grid samples (``fairing_wb.trim.on_face``) gives OCCT's
``isPartOfDomain`` at every sample, on real trimmed faces, inside FreeCAD (no mocks)."""

import numpy as np
import pytest

import Part
from cq_fairing.core.face_search import sample_counts
from fairing_wb import conversion, trim

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


def _trimmed(name, count):
    """The first ``count`` B-spline faces of ``name`` that have a trim polygon."""
    faces = [f for f in _bspline_faces(name, 10 ** 6) if trim._polygon(f) is not None]
    return faces[:count]


@pytest.mark.parametrize("name", ["linkrods.step", "impeller.igs"])
def test_p_curve_points_are_parts_values(name):
    """The polygon's vertices, evaluated by the core on B-spline p-curves, are Part's
    ``value`` at the same parameters to rounding (1e-12 of the parameter box)."""
    for face in _trimmed(name, 8):
        u0, u1, v0, v1 = face.ParameterRange
        for edge in face.Edges:
            found = face.curveOnSurface(edge)
            if found is None:
                continue
            curve, first, last = found
            t = np.linspace(first, last, 41)
            part = np.array([(p.x, p.y) for p in (curve.value(float(x)) for x in t)])
            assert np.abs(trim.curve_points(curve, t) - part).max() <= 1e-12 * max(
                u1 - u0, v1 - v0)


def test_near_is_the_band_around_the_segments():
    """The samples OCCT is asked near the trim are those within the band of a segment
    of the polygon, by the distance to every segment measured one by one."""
    face = _trimmed("impeller.igs", 1)[0]
    segments, band = trim._polygon(face)
    u0, u1, v0, v1 = face.ParameterRange
    u, v = np.linspace(u0, u1, 61), np.linspace(v0, v1, 47)
    near = trim._near(segments, band, u, v)
    a, b = segments[:, 0], segments[:, 1]
    for i, j in [(i, j) for i in range(len(u)) for j in range(len(v))]:
        p = np.array([u[i], v[j]])
        t = np.clip(np.sum((p - a) * (b - a), axis=1)
                    / np.maximum(np.sum((b - a) ** 2, axis=1), 1e-300), 0.0, 1.0)
        distance = np.linalg.norm(a + t[:, None] * (b - a) - p, axis=1).min()
        assert near[i, j] == (distance <= band), (i, j, distance, band)
    assert 0 < near.sum() < 0.2 * near.size


def test_search_grids_are_classified_as_occt_classifies_them():
    """The grids a tolerance search samples on real trimmed faces (its counts over the
    face's parameter box, and the centres of their cells), asked of one
    :class:`trim.Trim` each: OCCT's answer at every sample."""
    for face in _trimmed("impeller.igs", 12):
        source = conversion.surface_from_face(face)
        u0, u1, v0, v1 = conversion.uv_range(face, source)
        u, v = (np.linspace(u0, u1, n) for n in sample_counts(source))
        once = trim.Trim(face)
        for grid in ((u, v), (0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1]))):
            assert np.array_equal(once.on_face(*grid), _occt(face, *grid))
