"""The workbench's Tolerance mode with its defaults gives the command line's net.

The command line's side is ``cq_fairing.occ.fair_face`` with its defaults, stored in
``tests/data/face_references.npz`` (FreeCAD's Python has no OCP): the main suite checks
that the file is still what ``fair_face`` gives (``tests/occ/test_face_references.py``),
and here the Fairing feature, made with its defaults, must install the same net on the
same face (shape, knots and poles to round-off), or keep the face where the command line
keeps it.  Also: the Search vocabulary and default are the core's, an older document's
Search choice survives its migration, and Measure is refused with the local search.
"""

import numpy as np
import pytest

import FreeCAD
import Part
import cq_fairing as cf
from cq_fairing.core.options import FACE_SEARCHES
from fairing_wb import conversion, feature, make

import face_references
import fixtures

REFERENCES = face_references.load()
FUSELAGE, FUSELAGE_TOL = face_references.FUSELAGE
(NOISY_U, NOISY_V), NOISY_TOL = face_references.NOISY
ROUND_OFF = 1e-9  # of the net's size


@pytest.fixture
def doc():
    document = FreeCAD.newDocument("SameAsCli")
    name = document.Name
    yield document
    if name in FreeCAD.listDocuments():
        FreeCAD.closeDocument(name)


def _source(doc, case):
    """The document object holding ``case``'s face and the face's name in it."""
    if case == "noisy":
        surface, _ = fixtures.noisy_blade_surface(NOISY_U, NOISY_V)
        return fixtures.add_shape(doc, surface.toShape(), "Noisy"), "Face1"
    shape = Part.read(str(fixtures.REAL / FUSELAGE))
    return fixtures.add_shape(doc, shape, "Fuselage"), f"Face{int(case.split('/')[1]) + 1}"


def _size(net):
    return float(np.ptp(net.reshape(-1, 3), axis=0).max())


@pytest.mark.parametrize("case", sorted(REFERENCES))
def test_default_tolerance_mode_gives_the_command_lines_net(doc, case):
    reference = REFERENCES[case]
    source, sub = _source(doc, case)
    doc.recompute()
    face = source.Shape.getElement(sub)
    before = conversion.surface_from_face(face)
    size = _size(reference["source"])
    assert before.poles.shape == reference["source"].shape
    assert np.abs(before.poles - reference["source"]).max() <= ROUND_OFF * size
    tol = NOISY_TOL if case == "noisy" else FUSELAGE_TOL
    obj = make.make_fairing((source, [sub]), tolerance=tol)
    doc.recompute()
    assert obj.Search == "local" and obj.isValid(), obj.Status
    after = conversion.surface_from_face(obj.Shape.Faces[0])
    assert after.poles.shape == reference["poles"].shape
    assert np.abs(after.u_knots - reference["u_knots"]).max() <= 1e-12
    assert np.abs(after.v_knots - reference["v_knots"]).max() <= 1e-12
    assert np.abs(after.poles - reference["poles"]).max() <= ROUND_OFF * size
    if reference["status"] == "unchanged":
        assert obj.Status.startswith(f"OK; {sub} kept unchanged: "), obj.Status
        assert obj.MaxDeviation.Value == 0.0
    else:
        assert reference["status"] == "faired" and obj.Status == "OK", obj.Status
        assert obj.MaxDeviation.Value == pytest.approx(float(reference["max_deviation"]),
                                                       rel=1e-6)
        assert obj.MaxDeviation.Value <= tol


def test_the_nets_differ_from_the_core_search_on_its_own():
    """The comparison means something: the core's linear search, also judged both ways,
    gives the noisy face another net than the command line's default."""
    surface, _ = fixtures.noisy_blade_surface(NOISY_U, NOISY_V)
    linear = make.fair_face(surface.toShape(), tolerance=NOISY_TOL, search="linear")
    assert linear.poles_after != REFERENCES["noisy"]["poles"].shape[:2]
    assert linear.max_deviation <= NOISY_TOL


def test_search_has_the_cores_values_and_default(doc):
    source, sub = _source(doc, "noisy")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL)
    assert tuple(obj.getEnumerationsOfProperty("Search")) == FACE_SEARCHES == make.SEARCHES
    assert obj.Search == FACE_SEARCHES[0] == "local"


@pytest.mark.parametrize("saved", ["linear", "polyfit"])
def test_an_older_documents_search_survives_the_migration(doc, tmp_path, saved):
    """A document saved before ``local`` existed (Search enumeration ``linear``,
    ``guaranteed``, ``polyfit``, version 4) opens with ``local`` added and its own
    choice kept by name ("linear" was first, where "local" is now), and fairs with it."""
    source, sub = _source(doc, "noisy")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL)
    obj.Search = ["linear", "guaranteed", "polyfit"]
    obj.Search = saved
    obj.Proxy.Version = 4
    name = obj.Name
    with fixtures.reopened(doc, tmp_path / "old.FCStd") as reopened:
        again = reopened.getObject(name)
        assert again.getEnumerationsOfProperty("Search") == list(make.SEARCHES)
        assert again.Search == saved
        assert again.Proxy.Version == feature.VERSION
        reopened.recompute()
        assert again.isValid() and again.Status == "OK", again.Status
        face = again.Source[0].Shape.getElement(sub)
        alone = make.fair_face(face, tolerance=NOISY_TOL, search=saved)
        assert again.PolesAfter == " x ".join(map(str, alone.poles_after))


def test_measure_is_refused_with_the_local_search(doc):
    source, sub = _source(doc, "noisy")
    face = source.Shape.getElement(sub)
    with pytest.raises(cf.InvalidInputError, match="measure 'geometric' applies to the "
                                                   "core's searches"):
        make.fair_face(face, tolerance=NOISY_TOL, measure="geometric")
    with pytest.raises(cf.InvalidInputError, match="search 'local'"):
        make.make_fairing((source, [sub]), tolerance=NOISY_TOL, measure="geometric")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL, search="linear",
                            measure="geometric")
    doc.recompute()
    assert obj.isValid() and obj.Status == "OK", obj.Status
    obj.Search = "local"
    doc.recompute()
    assert not obj.isValid() or "Invalid" in obj.State
    assert obj.Status.startswith("Error: measure 'geometric' applies to the core's searches")
