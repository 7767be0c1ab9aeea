"""Several faces of one shape faired together: joins held closed and smooth, inside
FreeCAD (no mocks).

The fuselage (8 bicubic patches, 14 shared edges: 12 tangent joins and 2 creases where
the fin's faces meet) is checked with OCCT's own projection and normals through Part,
independently of the workbench's measure (the core's closest points).
"""

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import feature, joins, make

import fixtures

TOL = 5.0  # mm; at 2.5 no fuselage face has a coarser quasi-uniform net within it
SETTINGS = {"tolerance": TOL, "target": None, "method": "wavelet", "search": "linear",
            "measure": "parametric", "objective": "compact"}
FACE_SETTINGS = {"boundary": "free", "borders": "auto"}


@pytest.fixture
def doc():
    document = FreeCAD.newDocument("JoinsTest")
    name = document.Name
    yield document
    if name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(name)


@pytest.fixture
def fuselage(doc):
    obj = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / "fuselage.brep")), "Fuselage")
    doc.recompute()
    return obj


def _subs(obj):
    return [f"Face{i + 1}" for i in range(len(obj.Shape.Faces))]


def _shared_edges(shape):
    """``[(edge, face i, face j)]``: the non-degenerated edges of exactly two faces, by
    OCCT's ancestor map."""
    out = []
    for edge in shape.Edges:
        owners = [i for i, f in enumerate(shape.Faces)
                  if any(f.isSame(a) for a in shape.ancestorsOfType(edge, Part.Face))]
        if not edge.Degenerated and len(owners) == 2:
            out.append((edge, *owners))
    return out


def _normal(face, point):
    u, v = face.Surface.parameter(point)
    return face.normalAt(u, v)


def _along(source, faired, count=9):
    """Per shared edge of ``source``: the largest gap (OCCT projection of face i's faired
    points onto face j's faired surface) and the source and faired normal angles
    (degrees, ``Part.Face.normalAt``) at ``count`` interior points."""
    rows = []
    for edge, i, j in _shared_edges(source):
        first, last = edge.ParameterRange
        gaps, before, after = [], [], []
        for t in first + (np.arange(count) + 0.5) / count * (last - first):
            point = edge.valueAt(t)
            u, v = source.Faces[i].Surface.parameter(point)
            on_i = faired[i].Surface.value(u, v)
            a, b = faired[j].Surface.parameter(on_i)
            gaps.append((faired[j].Surface.value(a, b) - on_i).Length)
            before.append(np.degrees(_normal(source.Faces[i], point).getAngle(
                _normal(source.Faces[j], point))))
            after.append(np.degrees(faired[i].normalAt(u, v).getAngle(
                faired[j].normalAt(a, b))))
        rows.append((max(gaps), np.array(before), np.array(after)))
    return rows


def _faired(fuselage, how):
    return make.fair_elements(fuselage, _subs(fuselage), SETTINGS, FACE_SETTINGS, joins=how)


def test_joins_through_part_match_occt_ancestors_and_normals(fuselage):
    """14 joins (edges of two faces by OCCT's ancestor map); creases where Part's normals
    turn by more than 1 deg at the edges' midpoints: 2."""
    shape = fuselage.Shape
    found = joins.find_joins(list(shape.Faces))
    shared = _shared_edges(shape)
    assert len(found.joins) == len(shared) == 14
    assert sorted(tuple(sorted(j.faces)) for j in found.joins) == sorted(
        (i, j) for _, i, j in shared)
    creases = sum(np.degrees(_normal(shape.Faces[i], e.valueAt(sum(e.ParameterRange) / 2))
                             .getAngle(_normal(shape.Faces[j],
                                               e.valueAt(sum(e.ParameterRange) / 2)))) > 1.0
                  for e, i, j in shared)
    assert creases == sum(j.kind == "crease" for j in found.joins) == 2
    assert all(side.side is not None and side.full for j in found.joins for side in j.sides)


def test_smooth_joins_stay_closed_and_turn_no_more_than_the_source(fuselage):
    source = fuselage.Shape
    size = source.BoundBox.DiagonalLength
    results = _faired(fuselage, "smooth")
    faired = [r.shape for r in results]
    assert sum(r.note == "" for r in results) >= 4  # faces were faired, not all kept
    for result, face in zip(results, source.Faces):
        assert result.max_deviation <= TOL
        assert fixtures.sample_distance(result.shape, face) <= TOL
    rows = results.joins.rows()
    assert all(r["gap"] <= 1e-9 * size for r in rows if r["held"])
    assert sum(r["held"] for r in rows) >= 10
    for gap, before, after in _along(source, faired):
        assert gap <= 1e-9 * size
        if before.max() < 1.0:
            assert np.all(after <= before + 0.05), (before, after)
        else:
            assert after.max() > 1.0  # a crease stays a crease
    summary = results.joins.summary()
    assert (summary["joins"], summary["smooth"], summary["creases"]) == (14, 12, 2)
    assert summary["max_angle_excess"] <= 0.05


def test_free_joins_open(fuselage):
    """Each face alone: the same faces open their joins (the test above can fail)."""
    results = _faired(fuselage, "free")
    assert results.joins.summary()["held"] == 0
    assert results.joins.summary()["max_gap"] > 1e-3
    assert max(gap for gap, _, _ in _along(fuselage.Shape, [r.shape for r in results])) > 1e-3


def test_feature_holds_joins_by_default_and_reports_them(doc, fuselage):
    smooth = make.make_fairing(fuselage, tolerance=TOL)
    free = make.make_fairing(fuselage, tolerance=TOL, joins="free", name="Free")
    doc.recompute()
    assert (smooth.Joins, smooth.AngleTolerance.Value, free.Joins) == ("smooth", 1.0, "free")
    for obj in (smooth, free):
        assert obj.isValid() and obj.Shape.isValid(), obj.Status
        assert obj.Status.startswith("OK") and 0 < obj.MaxDeviation.Value <= TOL
        assert len(obj.Shape.Faces) == 8
    assert "; joins: 14 (10 held closed), max gap " in smooth.Status
    assert "12 smooth" in smooth.Status and smooth.Status.endswith("2 creases")
    assert "; joins: 14 (0 held closed)" in free.Status
    # the faired faces are sewn on their own shared borders: one shell, no edge
    # tolerance raised above the source's
    assert len(smooth.Shape.Shells) == 1
    assert max(e.Tolerance for e in smooth.Shape.Edges) <= max(
        e.Tolerance for e in fuselage.Shape.Edges)


def test_bad_join_options_are_refused_in_words(fuselage):
    with pytest.raises(cf.InvalidInputError, match="joins must be one of"):
        make.make_fairing(fuselage, tolerance=TOL, joins="tight")
    with pytest.raises(cf.InvalidInputError, match="angle tolerance must be an angle"):
        make.make_fairing(fuselage, tolerance=TOL, angle_tolerance=0)


def test_document_without_join_properties_migrates(doc, fuselage, tmp_path):
    obj = make.make_fairing((fuselage, ["Face5", "Face6"]), tolerance=TOL, joins="free")
    doc.recompute()
    obj.removeProperty("Joins")
    obj.removeProperty("AngleTolerance")
    with fixtures.reopened(doc, tmp_path / "version3.FCStd") as reopened:
        again = reopened.getObject("Fairing")
        assert (again.Joins, again.AngleTolerance.Value) == ("smooth", 1.0)
        assert again.getEnumerationsOfProperty("Joins") == list(make.JOINS)
        assert again.Proxy.Version == feature.VERSION
        reopened.recompute()
        assert again.isValid() and "; joins: 2 (" in again.Status, again.Status
