"""One undo step per command: committed when it works, aborted (nothing left) when not."""

import pytest

import FreeCAD
import Part
import cq_fairing as cf
from fairing_wb import deviation_map, make, undo

import fixtures


@pytest.fixture
def doc():
    document = FreeCAD.newDocument("UndoTest")
    document.UndoMode = 1
    name = document.Name
    yield document
    if name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(name)


def test_a_working_block_is_one_undo_step(doc):
    with undo.transaction(doc, "Two boxes"):
        fixtures.add_shape(doc, Part.makeBox(1, 1, 1), "A")
        fixtures.add_shape(doc, Part.makeBox(2, 2, 2), "B")
    assert doc.UndoCount == 1 and doc.UndoNames == ["Two boxes"]
    assert not doc.HasPendingTransaction
    doc.undo()
    assert doc.Objects == []


def test_a_failed_map_is_aborted_with_its_reason(doc):
    box = fixtures.add_shape(doc, Part.makeBox(10, 10, 10), "Box")
    broken = make.make_fairing((box, ["Face1"]), target=(4, 4))
    doc.recompute()
    assert not broken.isValid()  # a plane: nothing faired, no faces to map
    names, steps = [o.Name for o in doc.Objects], doc.UndoCount
    with pytest.raises(cf.FairingError, match="Face1 of Box is a Plane, not a B-spline face"):
        with undo.transaction(doc, "Deviation map"):
            deviation_map.make_map(broken)
            doc.recompute()
            undo.require_valid(deviation_map.find_maps(broken))
    assert [o.Name for o in doc.Objects] == names
    assert doc.UndoCount == steps and not doc.HasPendingTransaction
