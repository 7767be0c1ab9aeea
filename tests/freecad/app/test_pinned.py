"""The workbench fairs a face whose joins run across its surface with every join pinned
to its source (fairing_wb.pinned), as ``cq-fairing fair`` does: the impeller's three
trimmed faces and the faces they meet, inside FreeCAD.

The impeller file is a compound of loose faces.  Here the subset is glued first by
Part's general fuse (fuzzy 1e-3 mm, below the tolerance): the faces keep their
surfaces, and the edges where they meet become shared
(tests/freecad/app/test_loose_faces.py fairs the same faces unglued, their free edges
matched)."""

import pytest

import FreeCAD
import Part
from cq_fairing.core.joins import ANGLE_SLACK
from cq_fairing.core.pinned_projection import GAP
from fairing_wb import make

import fixtures

TOL = 0.2
TRIMMED = (242, 264, 274)              # impeller faces (0-based), as tests/occ/test_pinned.py
NEIGHBOURS = (22, 20, 100, 243, 265, 275)
# the command line's pinned nets of TRIMMED (u, v), checked there by tests/occ/test_pinned.py
PINNED_POLES = ((5, 4), (5, 4), (4, 3))
SETTINGS = dict(tolerance=TOL, target=None, method="wavelet", search="local",
                measure="geometric", objective="compact")
FACE_SETTINGS = dict(boundary="free", borders="auto")


@pytest.fixture(scope="module")
def impeller():
    """The glued subset as a document object, and the names of the trimmed faces in it
    (the general fuse reorders the faces: each is found by its centre and area)."""
    doc = FreeCAD.newDocument("Pinned")
    source = Part.read(str(fixtures.REAL / "impeller.igs")).Faces
    faces = [source[i] for i in TRIMMED + NEIGHBOURS]
    glued, _ = faces[0].generalFuse(faces[1:], 1e-3)
    obj = fixtures.add_shape(doc, glued, "Impeller")
    doc.recompute()

    def name(face):
        k = min(range(len(glued.Faces)),
                key=lambda k: (glued.Faces[k].CenterOfMass - face.CenterOfMass).Length)
        assert abs(glued.Faces[k].Area - face.Area) < 1e-4 * face.Area
        return f"Face{k + 1}"

    yield obj, [name(source[i]) for i in TRIMMED]
    FreeCAD.closeDocument(doc.Name)


@pytest.fixture(scope="module")
def runs(impeller):
    obj, subs = impeller
    return {joins: make.fair_elements(obj, subs, SETTINGS, FACE_SETTINGS, joins=joins)
            for joins in ("smooth", "free")}


def test_trimmed_faces_are_pinned_to_the_command_lines_nets(runs):
    """Each trimmed face is faired with its joins pinned, onto the command line's net,
    within the tolerance by the workbench's two-sided measure, and its shape is valid."""
    smooth = runs["smooth"]
    assert [r.poles_after for r in smooth] == list(PINNED_POLES)
    for result in smooth:
        assert "pinned to its source" in result.note, result.note
        assert 0 < result.max_deviation <= TOL
        assert result.shape.isValid()
    assert Part.Compound([r.shape for r in smooth]).isValid()


def test_pinned_joins_stay_within_the_budget(runs):
    """Every join of the trimmed faces is held: it opens at most GAP x the size beyond
    the source's gap, and a smooth one turns at most ANGLE_SLACK beyond the source's
    angle, sample for sample, by the workbench's join report; faired alone (Joins=free)
    the same faces open them a thousand times wider."""
    report = runs["smooth"].joins
    size = report.found.size
    rows = report.rows()
    assert len(rows) >= 3 and all(r["held"] for r in rows)
    assert all(r["gap"] <= r["source_gap"] + GAP * size for r in rows)
    assert all(r["angle_excess"] <= ANGLE_SLACK for r in rows if r["kind"] == "smooth")
    alone = runs["free"].joins.rows()
    assert max(r["gap"] - r["source_gap"] for r in alone) > 1e3 * GAP * size
