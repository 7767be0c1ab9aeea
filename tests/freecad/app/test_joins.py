"""Several faces of one shape faired together: joins held closed and smooth, inside
FreeCAD (no mocks).

The fuselage (8 bicubic patches, 14 shared edges: 12 tangent joins and 2 creases where
the fin's faces meet) is checked with OCCT's own projection and normals through Part,
independently of the workbench's measure (the core's closest points).  With some faces
selected, the others take part as fixed faces: the fuselage's B-spline faces, and the
cylinder and torus next to linkrods' trimmed B-spline faces.
"""

import dataclasses

import numpy as np
import pytest

import Part
import cq_fairing as cf
from fairing_wb import feature, joins, make

import fixtures

TOL = 5.0  # mm; at 2.5 no fuselage face has a coarser quasi-uniform net within it
SETTINGS = {"tolerance": TOL, "target": None, "method": "wavelet", "search": "linear",
            "measure": "parametric", "objective": "compact"}
FACE_SETTINGS = {"boundary": "free", "borders": "auto"}



@pytest.fixture
def fuselage(doc):
    obj = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / "fuselage.brep")), "Fuselage")
    doc.recompute()
    return obj


def _subs(obj):
    return [f"Face{i + 1}" for i in range(len(obj.Shape.Faces))]


def _faired(fuselage, how):
    return make.fair_elements(fuselage, _subs(fuselage), SETTINGS, FACE_SETTINGS, joins=how)


def test_joins_through_part_match_occt_ancestors_and_normals(fuselage):
    """14 joins (edges of two faces by OCCT's ancestor map); creases where Part's normals
    turn by more than 1 deg at the edges' midpoints: 2."""
    shape = fuselage.Shape
    found = joins.find_joins(list(shape.Faces))
    shared = fixtures.shared_edges(shape)
    assert len(found.joins) == len(shared) == 14
    assert sorted(tuple(sorted(j.faces)) for j in found.joins) == sorted(
        (i, j) for _, i, j in shared)
    middles = [(e.valueAt(sum(e.ParameterRange) / 2), i, j) for e, i, j in shared]
    creases = sum(np.degrees(fixtures.normal_at(shape.Faces[i], point).getAngle(
        fixtures.normal_at(shape.Faces[j], point))) > 1.0 for point, i, j in middles)
    assert creases == sum(j.kind == "crease" for j in found.joins) == 2
    assert all(side.side is not None and side.full for j in found.joins for side in j.sides)


@pytest.mark.parametrize("how", ["smooth", "curvature"])
def test_smooth_joins_stay_closed_and_turn_no_more_than_the_source(fuselage, how):
    """"curvature" holds what "smooth" does, and the curvature where the source has it."""
    source = fuselage.Shape
    size = source.BoundBox.DiagonalLength
    results = _faired(fuselage, how)
    faired = [r.shape for r in results]
    assert sum(r.note == "" for r in results) >= 4  # faces were faired, not all kept
    for result, face in zip(results, source.Faces):
        assert result.max_deviation <= TOL
        assert fixtures.sample_distance(result.shape, face) <= TOL
    rows = results.joins.rows()
    assert all(r["gap"] <= 1e-9 * size for r in rows if r["held"])
    assert sum(r["held"] for r in rows) >= 10
    for gap, before, after in fixtures.joins_along(source, faired):
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
    opened = fixtures.joins_along(fuselage.Shape, [r.shape for r in results])
    assert max(gap for gap, _, _ in opened) > 1e-3


def test_feature_holds_joins_by_default_and_reports_them(doc, fuselage):
    smooth = make.make_fairing(fuselage, tolerance=TOL)
    free = make.make_fairing(fuselage, tolerance=TOL, joins="free", name="Free")
    doc.recompute()
    assert (smooth.Joins, smooth.AngleTolerance.Value, free.Joins) == ("smooth", 1.0, "free")
    for obj in (smooth, free):
        assert obj.isValid() and obj.Shape.isValid(), obj.Status
        assert obj.Status.startswith("OK") and 0 < obj.MaxDeviation.Value <= TOL
        assert len(obj.Shape.Faces) == 8
    # as the command line (cq-fairing fair fuselage.brep --tol 5): every join held
    assert "; joins: 14 (14 held closed), max gap " in smooth.Status
    assert "12 smooth" in smooth.Status and smooth.Status.endswith("2 creases")
    assert "; joins: 14 (0 held closed)" in free.Status
    # the faired faces are sewn on their own shared borders: one shell, no edge
    # tolerance raised above the source's
    assert len(smooth.Shape.Shells) == 1
    assert max(e.Tolerance for e in smooth.Shape.Edges) <= max(
        e.Tolerance for e in fuselage.Shape.Edges)


def _to_neighbours(source, selected, faired, count=9):
    """Per shared edge of ``source`` between a face of ``selected`` (0-based indices) and
    a face not selected: that face's index, and the largest gap from the selected face's
    source, and from its faired face ``faired[k]`` (same order as ``selected``), to the
    other face's source surface, by OCCT's projection at ``count`` interior points."""
    rows = []
    for edge, i, j in fixtures.shared_edges(source):
        if (i in selected) == (j in selected):
            continue
        mine, other = (i, j) if i in selected else (j, i)
        first, last = edge.ParameterRange
        before, after = [], []
        for t in first + (np.arange(count) + 0.5) / count * (last - first):
            u, v = source.Faces[mine].Surface.parameter(edge.valueAt(t))
            for gaps, face in ((before, source.Faces[mine]),
                               (after, faired[selected.index(mine)])):
                point = face.Surface.value(u, v)
                a, b = source.Faces[other].Surface.parameter(point)
                gaps.append((source.Faces[other].Surface.value(a, b) - point).Length)
        rows.append((other, max(before), max(after)))
    return rows


def test_joins_with_faces_not_selected_stay_as_the_source_has_them(fuselage):
    """Two faces of eight faired: their joins with the six others are held where the
    source has them (the faces not selected are fixed); Joins=free opens them."""
    source = fuselage.Shape
    size = source.BoundBox.DiagonalLength
    subs = ["Face5", "Face6"]
    assert [sub for sub, _ in make.neighbour_faces(fuselage, subs)] == [
        "Face1", "Face2", "Face7", "Face8"]
    smooth = make.fair_elements(fuselage, subs, SETTINGS, FACE_SETTINGS, joins="smooth")
    free = make.fair_elements(fuselage, subs, SETTINGS, FACE_SETTINGS, joins="free")
    assert all(r.note == "" and r.max_deviation <= TOL for r in smooth)  # both faired
    held = _to_neighbours(source, [4, 5], [r.shape for r in smooth])
    assert len(held) == 4
    assert all(after <= before + 1e-9 * size for _, before, after in held), held
    opened = _to_neighbours(source, [4, 5], [r.shape for r in free])
    assert max(after for _, _, after in opened) > 1e-3
    # the report counts the joins with the neighbours: 4, and the 2 between the faces
    assert smooth.joins.summary()["joins"] == free.joins.summary()["joins"] == 6
    assert smooth.joins.summary()["held"] == 6 and free.joins.summary()["held"] == 0
    assert smooth.joins.summary()["max_gap"] <= 1e-9 * size


def test_one_face_selected_keeps_its_joins_with_the_others(doc, fuselage):
    """One face of eight, as ``cq-fairing fair fuselage.brep --faces 5``: its joins with
    its four neighbours are held where the source has them, by default; Joins=free
    fairs it alone and opens them."""
    source = fuselage.Shape
    size = source.BoundBox.DiagonalLength
    smooth = make.make_fairing((fuselage, ["Face5"]), tolerance=TOL)
    free = make.make_fairing((fuselage, ["Face5"]), tolerance=TOL, joins="free",
                             name="Free")
    doc.recompute()
    for obj in (smooth, free):
        assert obj.isValid() and obj.Status.startswith("OK"), obj.Status
        assert 0 < obj.MaxDeviation.Value <= TOL
        assert fixtures.sample_distance(obj.Shape.Faces[0], source.Faces[4]) <= TOL
    held = _to_neighbours(source, [4], [smooth.Shape.Faces[0]])
    assert sorted(other for other, _, _ in held) == [0, 5, 5, 7]  # two edges with Face6
    assert all(after <= before + 1e-9 * size for _, before, after in held), held
    opened = _to_neighbours(source, [4], [free.Shape.Faces[0]])
    assert max(after for _, _, after in opened) > 1e-3
    assert "; joins: " in smooth.Status and " held closed" in smooth.Status

def test_joins_with_analytic_neighbours_are_measured_through_part(doc):
    """Linkrods Face18 and Face20 are trimmed along a cylinder (Face2): those joins run
    across their surfaces, so Joins=smooth keeps both faces and every join, with the
    cylinder and the torus too, measures as the source; Joins=free fairs them alone and
    opens the joins, the cylinder's measured as OCCT measures them."""
    rods = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / "linkrods.step")), "Rods")
    doc.recompute()
    source = rods.Shape
    subs = ["Face18", "Face20"]
    neighbours = make.neighbour_faces(rods, subs)
    kinds = {sub: type(face.Surface).__name__ for sub, face in neighbours}
    assert kinds["Face2"] == "Cylinder" and kinds["Face16"] == "Toroid"
    settings = {**SETTINGS, "tolerance": 0.01}
    smooth = make.fair_elements(rods, subs, settings, FACE_SETTINGS, joins="smooth")
    assert all("Face2" in r.note and "run across its surface" in r.note for r in smooth)
    rows = smooth.joins.rows()
    assert len(rows) == 10 and all(r["gap"] == r["source_gap"] for r in rows)
    free = make.fair_elements(rods, subs, settings, FACE_SETTINGS, joins="free")
    assert all(r.note == "" for r in free)
    assert max(after for _, _, after in _to_neighbours(
        source, [17, 19], [r.shape for r in free])) > 1e-4
    cylinder = [sub for sub, _ in neighbours].index("Face2") + 3  # 1-based, after 2 faces
    measured = [r for r in free.joins.rows() if cylinder in r["faces"]]
    assert len(measured) == 2
    for row in measured:
        k = row["faces"][0] - 1
        low, high = _cylinder_gap_bounds(source, (17, 19)[k], free[k].shape)
        assert low * (1 - 1e-6) <= row["gap"] <= high + row["source_gap"], (row, low, high)


def _cylinder_gap_bounds(source, index, faired, samples=joins.SAMPLES):
    """Bounds on the gap between ``faired`` (of source face ``index``) and linkrods'
    cylinder (Face2) along their edge, at the workbench's sample parameters: below, the
    larger of OCCT's unbounded projections of the faired points onto the cylinder and
    of the edge's points onto the faired surface; above, the distance from the edge's
    points to the faired surface at the source's parameters of those points (a point of
    the faired face, not the closest)."""
    cylinder, face = source.Faces[1], source.Faces[index]
    (edge,) = [e for e in face.Edges if any(e.isSame(c) for c in cylinder.Edges)]
    first, last = edge.ParameterRange
    low = high = 0.0
    for t in first + (np.arange(samples) + 0.5) / samples * (last - first):
        point = edge.valueAt(t)
        on_faired = faired.Surface.value(*face.Surface.parameter(point))
        foot = cylinder.Surface.value(*cylinder.Surface.parameter(on_faired))
        back = faired.Surface.value(*faired.Surface.parameter(point))
        low = max(low, (foot - on_faired).Length, (back - point).Length)
        high = max(high, (on_faired - point).Length)
    return low, high


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
        assert again.isValid() and "; joins: 6 (" in again.Status, again.Status


def test_joins_of_faces_on_their_sources_keep_the_sources_measures(fuselage):
    """Measured with the sources' nets (copies), every join gives the measures
    ``find_joins`` took; with one face faired, the joins of that face are measured
    again, as a measurement from scratch gives them, and they open."""
    shape = fuselage.Shape
    found = joins.find_joins(list(shape.Faces))
    fresh = dataclasses.replace(found, measures=[])
    copies = {face: dataclasses.replace(s, poles=s.poles.copy())
              for face, s in found.sources.items()}
    kept = joins.measure_joins(found, copies)
    assert all(a is b for pair, source in zip(kept, found.measures)
               for a, b in zip(pair, source))
    faired = make.fair_face(shape.Faces[4], **SETTINGS).surface
    moved = joins.measure_joins(found, {**copies, 4: faired})
    scratch = joins.measure_joins(fresh, {**copies, 4: faired})
    for join, after, again, before in zip(found.joins, moved, scratch, found.measures):
        assert all(np.array_equal(a, b) for a, b in zip(after, again))
        assert (4 in join.faces) == (after[0].max() > before[0].max() + 1e-6)
