"""Loose faces (a compound whose faces share no edge, as an IGES file's) faired with their
joins held, inside FreeCAD (no mocks): the workbench matches their free edges as
``cq-fairing fair`` does (:mod:`cq_fairing.core.free_edges`).

The noisy 2 x 2 patch grid of the core's examples, left unsewn: its joins are the
example's own border joins, and it is faired as the sewn grid is (one surface cut in
four), its gaps measured by OCCT's projection on a copy sewn by Part.  Three trimmed
faces of the impeller with the faces they meet, read from the IGES file and not glued:
their joins pair the faces that Part's general fuse makes share an edge, and they stay
as the source has them, measured by Part's projection along each side's own edge.
"""

import numpy as np
import pytest

import FreeCAD
import Part
from cq_fairing.core.examples import patch_grid
from cq_fairing.core.joins import ANGLE_SLACK
from cq_fairing.core.joint_projection import runs_reversed
from cq_fairing.core.pinned_projection import GAP
from fairing_wb import joins, make

import fixtures
from tests.core.patch_references import grid_pieces
from tests.freecad.app.test_patch_models import (
    FACE_SETTINGS,
    GRID_ANGLE,
    SETTINGS,
    TOL,
    _assert_equal_to,
    _order,
    _part_face,
    _sewn,
)

TRIMMED = (242, 264, 274)              # impeller faces (0-based), as tests/occ/test_pinned.py
NEIGHBOURS = (22, 20, 100, 243, 265, 275)
IMPELLER = dict(tolerance=0.2, target=None, method="wavelet", search="local",
                measure="geometric", objective="compact")



@pytest.fixture
def grid(doc):
    obj = fixtures.add_shape(doc, Part.makeCompound([_part_face(p) for p in patch_grid().patches]),
                             "Loose")
    doc.recompute()
    return obj


def _subs(obj):
    return [f"Face{i + 1}" for i in range(len(obj.Shape.Faces))]


def test_the_loose_grids_joins_are_its_border_joins(grid):
    """No edge is shared, yet the four joins are found: the example's border joins, side
    for side and reversed where the example's is, each side on its own face's edge."""
    faces = grid.Shape.Faces
    assert not fixtures.shared_edges(grid.Shape)
    found = joins.find_joins(faces, GRID_ANGLE)
    expected = {(b.a, b.side_a, b.b, b.side_b, b.reversed) for b in patch_grid().joins}
    got = set()
    for join in found.joins:
        first, second = sorted(join.sides, key=lambda side: side.face)
        got.add((first.face, first.side, second.face, second.side, runs_reversed(join)))
        assert not join.shared and join.kind == "smooth" and join.source_gap <= 1e-6
        for side in join.sides:
            assert side.full
            assert any(e.isSame(found.edges[side.edge]) for e in faces[side.face].Edges)
    assert got == expected


def test_the_loose_grid_is_faired_as_the_sewn_grid(doc, grid):
    """Joins held, the loose grid is one surface faired and cut in four, the same pieces
    as the sewn grid's (tests/freecad/app/test_patch_models.py); by OCCT's projection on
    a copy sewn by Part its joins close to round-off and turn by 1e-4 deg at most (16
    deg in the source); Joins=free opens them."""
    sewn = _sewn(doc, patch_grid().patches, "Sewn")
    assert _order(grid, patch_grid().patches) == [0, 1, 2, 3]
    order = _order(sewn, patch_grid().patches)
    runs = {how: make.fair_elements(grid, _subs(grid), SETTINGS, FACE_SETTINGS, joins=how,
                                    angle_tolerance=GRID_ANGLE) for how in ("smooth", "free")}
    summary = runs["smooth"].joins.summary()
    assert summary["grids"] == [[2, 2]] and summary["joins"] == summary["held"] == 4
    _assert_equal_to(runs["smooth"], [0, 1, 2, 3], grid_pieces(TOL))
    held = fixtures.joins_along(sewn.Shape, [runs["smooth"][k].shape for k in order])
    assert len(held) == 4
    for gap, before, after in held:
        turned = np.minimum(after, 180.0 - after)  # loose faces: orientations disagree
        assert gap <= 1e-9 * 2.0
        assert before.max() > 1.0 and turned.max() <= 1e-4, (before.max(), turned.max())
    opened = fixtures.joins_along(sewn.Shape, [runs["free"][k].shape for k in order])
    assert max(gap for gap, _, _ in opened) > 1e-3
    assert runs["free"].joins.summary()["held"] == 0


def test_a_loose_faces_neighbours_are_the_faces_its_free_edges_meet(grid):
    """Patch 0 meets patches 1 and 2 (the example's joins): those are its neighbours,
    fixed, and its joins with them stay as the source has them."""
    assert [sub for sub, _ in make.neighbour_faces(grid, ["Face1"])] == ["Face2", "Face3"]
    assert [sub for sub, _ in make.neighbour_faces(grid, ["Face1", "Face4"])] == [
        "Face2", "Face3"]
    results = make.fair_elements(grid, ["Face1", "Face4"], SETTINGS, FACE_SETTINGS,
                                 angle_tolerance=GRID_ANGLE)
    rows = results.joins.rows()
    assert len(rows) == 4 and all(r["held"] for r in rows)
    assert all(r["gap"] <= r["source_gap"] + GAP * 2.0 for r in rows), rows


@pytest.fixture(scope="module")
def impeller():
    """The trimmed faces and their neighbours as loose faces (a compound, nothing
    shared), and the face pairs that share an edge once Part's general fuse (fuzzy 1e-3
    mm) has glued them, each glued face found as the loose face its inner points lie on
    (the fuse reorders the faces and may trim them)."""
    doc = FreeCAD.newDocument("LooseImpeller")
    source = Part.read(str(fixtures.REAL / "impeller.igs")).Faces
    faces = [source[i] for i in TRIMMED + NEIGHBOURS]
    obj = fixtures.add_shape(doc, Part.makeCompound(faces), "Impeller")
    doc.recompute()
    glued, _ = faces[0].generalFuse(faces[1:], 1e-3)

    def position(face):
        u0, u1, v0, v1 = face.ParameterRange
        inside = [face.valueAt(u, v) for u in np.linspace(u0, u1, 9)[1:-1]
                  for v in np.linspace(v0, v1, 9)[1:-1] if face.isPartOfDomain(u, v)]
        return min(range(len(faces)), key=lambda k: sum(
            faces[k].distToShape(Part.Vertex(p))[0] for p in inside))

    meeting = {tuple(sorted((position(glued.Faces[i]), position(glued.Faces[j]))))
               for _, i, j in fixtures.shared_edges(glued)}
    yield obj, meeting
    FreeCAD.closeDocument(doc.Name)


def _gaps_along(found, source, faired, count=9):
    """Per join of ``found`` (faces of ``source``, the first ones faired as ``faired``),
    the largest distance, at ``count`` interior points of side 0's own edge, from side
    0's face (faired where it was) at the point's source parameters to side 1's face
    (faired where it was), by Part's projection onto its surface."""
    def face(k):
        return faired[k] if k < len(faired) else source[k]

    rows = []
    for join in found.joins:
        a, b = join.faces
        edge = found.edges[join.sides[0].edge]
        first, last = edge.ParameterRange
        gaps = []
        for t in first + (np.arange(count) + 0.5) / count * (last - first):
            point = face(a).Surface.value(*source[a].Surface.parameter(edge.valueAt(t)))
            foot = face(b).Surface.value(*face(b).Surface.parameter(point))
            gaps.append((foot - point).Length)
        rows.append(max(gaps))
    return np.array(rows)


def test_loose_impeller_faces_keep_their_joins(impeller):
    """The three trimmed faces of the unglued subset are faired with their joins held:
    their joins pair them with the faces the general fuse glues them to, and those are
    their neighbours; each join opens at most GAP x the size beyond the source's gap, by the
    workbench's report and by Part's projection along each side's own edge; faired alone
    (Joins=free) they open them a thousand times wider."""
    obj, meeting = impeller
    subs = ["Face1", "Face2", "Face3"]
    glued = {pair for pair in meeting if min(pair) < 3}
    neighbours = make.neighbour_faces(obj, subs)
    assert {int(sub[4:]) - 1 for sub, _ in neighbours} == {
        k for pair in glued for k in pair} - {0, 1, 2}
    runs = {how: make.fair_elements(obj, subs, IMPELLER, FACE_SETTINGS, joins=how)
            for how in ("smooth", "free")}
    report = runs["smooth"].joins
    found, size = report.found, report.found.size
    in_shape = [int(sub[4:]) - 1 for sub in subs + [sub for sub, _ in neighbours]]
    source = [obj.Shape.Faces[k] for k in in_shape]
    assert {tuple(sorted((in_shape[a], in_shape[b]))) for a, b in
            (j.faces for j in found.joins)} == glued
    assert len(found.joins) >= 3 and not any(j.shared for j in found.joins)
    assert all(r.note.startswith(f"{sub} faired") for r, sub in zip(runs["smooth"], subs))
    rows = report.rows()
    assert all(r["held"] and r["gap"] <= r["source_gap"] + GAP * size for r in rows)
    assert all(r["angle_excess"] <= ANGLE_SLACK for r in rows if r["kind"] == "smooth")
    before = _gaps_along(found, source, [])
    after = _gaps_along(found, source, [r.shape for r in runs["smooth"]])
    assert np.all(after <= before + GAP * size), (before, after)
    alone = _gaps_along(found, source, [r.shape for r in runs["free"]])
    assert np.max(alone - before) > 1e3 * GAP * size


def test_neighbours_of_a_sewn_shell_are_the_faces_owning_their_edges(doc):
    """On a sewn shell (testtoler) the neighbours of a few faces are the faces that
    Part's ``ancestorsOfType`` names as owners of their non-degenerated edges, less the
    faces chosen."""
    obj = fixtures.add_shape(doc, Part.read(str(fixtures.REAL / "testtoler.brep")), "Shell")
    shape = obj.Shape
    faces = shape.Faces
    for chosen in ([0], [3, 17], [5, 6, 30, 41]):
        owners = {k for index in chosen for edge in faces[index].Edges if not edge.Degenerated
                  for owner in shape.ancestorsOfType(edge, Part.Face)
                  for k, face in enumerate(faces) if face.isSame(owner)}
        subs = [f"Face{k + 1}" for k in chosen]
        expected = [f"Face{k + 1}" for k in sorted(owners - set(chosen))]
        assert [sub for sub, _ in make.neighbour_faces(obj, subs)] == expected
        assert expected
