"""The workbench's Tolerance mode gives the command line's net, for every method.

The command line's side is ``cq_fairing.occ.fair_face`` with its defaults, and with the
adaptive and energy methods, stored in ``tests/data/face_references.npz`` (FreeCAD's
Python has no OCP): the main suite checks that the file is still what ``fair_face``
gives (``tests/occ/test_face_references.py``), and here the Fairing feature, made with
the same options, must install the same net on the same face (shape, knots and poles to
round-off), or keep the face where the command line keeps it, for the same reason.
Also: the Search and Measure vocabularies and defaults are the core's, an older
document's Search and Measure choices survive its migration, and Measure is refused
with the local search.
"""

import numpy as np
import pytest

import Part
import cq_fairing as cf
from cq_fairing.core.options import DEFAULTS, FACE_SEARCHES, MEASURES
from fairing_wb import conversion, feature, make

import face_references
import fixtures

REFERENCES = face_references.load()
FUSELAGE = face_references.FUSELAGE[0]
(NOISY_U, NOISY_V), NOISY_TOL = face_references.NOISY
# Round-off of the net's size (poles) and of the parameter domain (knots): the stored side
# ran on the main suite's numpy, this one on FreeCAD's; the adaptive method's knots come
# out of an iterative placement, and the core alone, on the same net, places them 3e-11
# apart on the two builds (uniform knots agree exactly).
ROUND_OFF = 1e-9



def _source(doc, case):
    """The document object holding ``case``'s face and the face's name in it."""
    face = case.split("/", 1)[1]
    if face == "noisy":
        surface, _ = fixtures.noisy_blade_surface(NOISY_U, NOISY_V)
        return fixtures.add_shape(doc, surface.toShape(), "Noisy"), "Face1"
    if face == "rational":
        surface = fixtures.rational_blade_surface(*face_references.RATIONAL[0])
        return fixtures.add_shape(doc, surface.toShape(), "Rational"), "Face1"
    if face == "blade":
        name, index, _ = face_references.BLADE
        shape = Part.read(str(fixtures.REPO / "examples" / "data" / name))
        return fixtures.add_shape(doc, shape, "Blade"), f"Face{index + 1}"
    shape = Part.read(str(fixtures.REAL / FUSELAGE))
    return fixtures.add_shape(doc, shape, "Fuselage"), f"Face{int(face.split('/')[1]) + 1}"


def _size(net):
    return float(np.ptp(net.reshape(-1, 3), axis=0).max())


@pytest.mark.parametrize("case", sorted(REFERENCES))
def test_tolerance_mode_gives_the_command_lines_net(doc, case):
    reference = REFERENCES[case]
    options, tol = face_references.setting(case)
    source, sub = _source(doc, case)
    doc.recompute()
    face = source.Shape.getElement(sub)
    before = conversion.surface_from_face(face)
    size = _size(reference["source"])
    assert before.poles.shape == reference["source"].shape
    assert np.abs(before.poles - reference["source"]).max() <= ROUND_OFF * size
    # fair_face fairs the face alone: Joins free, as a fuselage face has neighbours
    obj = make.make_fairing((source, [sub]), tolerance=tol, joins="free", **options)
    doc.recompute()
    assert obj.Search == "local" and obj.isValid(), obj.Status
    after = conversion.surface_from_face(obj.Shape.Faces[0])
    assert after.poles.shape == reference["poles"].shape
    for knots, stored in ((after.u_knots, reference["u_knots"]),
                          (after.v_knots, reference["v_knots"])):
        assert np.abs(knots - stored).max() <= ROUND_OFF * np.ptp(stored)
    assert np.abs(after.poles - reference["poles"]).max() <= ROUND_OFF * size
    # the part on the face itself (a face with neighbours also has its joins measured)
    assert obj.Status.split("; joins: ")[0] == _status(sub, reference, tol)
    if reference["status"] == "faired":
        assert obj.MaxDeviation.Value == pytest.approx(float(reference["max_deviation"]),
                                                       rel=1e-6)
        assert obj.MaxDeviation.Value <= tol
    else:
        assert obj.MaxDeviation.Value == 0.0


def _status(sub, reference, tol):
    """The feature's ``Status`` for the command line's outcome: ``OK`` for a faired face
    (with the command line's note where it has one: graded targets), the command line's
    reason for a face with nothing to fair or one the method does not
    fair (a rational face by energy), and the tolerance and the
    best deviation found for a face kept for its tolerance."""
    if reference["status"] == "faired":
        return f"OK; {sub} faired: {reference['message']}" if reference["message"] else "OK"
    if reference["status"] in ("unchanged", "skipped-rational"):
        return f"OK; {sub} kept unchanged: {reference['message']}"
    assert reference["status"] == "tolerance-not-met"
    best = float(reference["max_deviation"])
    return (f"OK; {sub} kept unchanged: no coarser net within {tol:.4g} mm (best found "
            f"{best:.4g} mm)")


def test_the_nets_differ_from_the_core_search_on_its_own():
    """The comparison means something: the core's linear search, also judged both ways,
    gives the noisy face another net than the command line's default."""
    surface, _ = fixtures.noisy_blade_surface(NOISY_U, NOISY_V)
    linear = make.fair_face(surface.toShape(), tolerance=NOISY_TOL, search="linear")
    assert linear.poles_after != REFERENCES["wavelet/noisy"]["poles"].shape[:2]
    assert linear.max_deviation <= NOISY_TOL


def test_search_and_measure_have_the_cores_values_and_defaults(doc):
    source, sub = _source(doc, "wavelet/noisy")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL)
    assert tuple(obj.getEnumerationsOfProperty("Search")) == FACE_SEARCHES == make.SEARCHES
    assert obj.Search == FACE_SEARCHES[0] == "local"
    assert tuple(obj.getEnumerationsOfProperty("Measure")) == MEASURES == make.MEASURES
    assert obj.Measure == MEASURES[0] == DEFAULTS["measure"] == "geometric"


@pytest.mark.parametrize("saved", ["linear", "polyfit"])
def test_an_older_documents_search_survives_the_migration(doc, tmp_path, saved):
    """A document saved before ``local`` existed (Search enumeration ``linear``,
    ``guaranteed``, ``polyfit``, version 4) opens with ``local`` added and its own
    choice kept by name ("linear" was first, where "local" is now), and fairs with it."""
    source, sub = _source(doc, "wavelet/noisy")
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
        assert fixtures.status_ok(again), again.Status
        face = again.Source[0].Shape.getElement(sub)
        alone = make.fair_face(face, tolerance=NOISY_TOL, search=saved)
        assert again.PolesAfter == " x ".join(map(str, alone.poles_after))


@pytest.mark.parametrize("search, migrated", [("local", "geometric"),
                                               ("linear", "parametric")])
def test_an_older_documents_measure_survives_the_migration(doc, tmp_path, search, migrated):
    """A document saved when ``Measure``'s default was ``parametric`` (its enumeration
    ``parametric``, ``geometric``; version 5): a core search keeps its ``parametric``; a
    local search, which does not use ``Measure`` and took only ``parametric`` then,
    opens with the default ``geometric`` and gives the same net."""
    source, sub = _source(doc, "wavelet/noisy")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL, search=search)
    obj.Measure = ["parametric", "geometric"]
    obj.Measure = "parametric"
    obj.Proxy.Version = 5
    name = obj.Name
    with fixtures.reopened(doc, tmp_path / "old.FCStd") as reopened:
        again = reopened.getObject(name)
        assert again.getEnumerationsOfProperty("Measure") == list(MEASURES)
        assert (again.Search, again.Measure) == (search, migrated)
        reopened.recompute()
        assert fixtures.status_ok(again), again.Status
        face = again.Source[0].Shape.getElement(sub)
        alone = make.fair_face(face, tolerance=NOISY_TOL, search=search, measure=migrated)
        assert again.PolesAfter == " x ".join(map(str, alone.poles_after))


def test_measure_is_refused_with_the_local_search(doc):
    source, sub = _source(doc, "wavelet/noisy")
    face = source.Shape.getElement(sub)
    with pytest.raises(cf.InvalidInputError, match="measure 'parametric' applies to the "
                                                   "core's searches"):
        make.fair_face(face, tolerance=NOISY_TOL, measure="parametric")
    with pytest.raises(cf.InvalidInputError, match="search 'local'"):
        make.make_fairing((source, [sub]), tolerance=NOISY_TOL, measure="parametric")
    obj = make.make_fairing((source, [sub]), tolerance=NOISY_TOL, search="linear",
                            measure="parametric")
    doc.recompute()
    assert fixtures.status_ok(obj), obj.Status
    obj.Search = "local"
    doc.recompute()
    assert not obj.isValid() or "Invalid" in obj.State
    assert obj.Status.startswith("Error: measure 'parametric' applies to the core's searches")


def test_grading_belongs_to_the_wavelet_tolerance_search_and_older_documents_get_it(
        doc, tmp_path):
    """``Grading`` (the command line's ``--grading``) is refused outside the wavelet
    method's Tolerance mode and outside its values; a document saved before the property
    existed opens with ``auto`` and gives the command line's net for each value."""
    source, sub = _source(doc, "wavelet/blade")
    face = source.Shape.getElement(sub)
    tol = face_references.BLADE[2]
    with pytest.raises(cf.InvalidInputError, match="wavelet method's tolerance search only"):
        make.fair_face(face, target=(10, 10), grading="uniform")
    with pytest.raises(cf.InvalidInputError, match="wavelet method's tolerance search only"):
        make.fair_face(face, tolerance=tol, method="energy", grading="uniform")
    with pytest.raises(cf.InvalidInputError, match="grading must be one of"):
        make.fair_face(face, tolerance=tol, grading="graded")
    obj = make.make_fairing((source, [sub]), tolerance=tol, joins="free")
    obj.removeProperty("Grading")   # as saved before version 7
    obj.Proxy.Version = 6
    name = obj.Name
    with fixtures.reopened(doc, tmp_path / "before_grading.FCStd") as reopened:
        again = reopened.getObject(name)
        assert again.getEnumerationsOfProperty("Grading") == list(make.GRADINGS)
        assert again.Grading == "auto" and again.Proxy.Version == feature.VERSION
        for grading, case in (("auto", "wavelet/blade"), ("uniform", "wavelet-uniform/blade")):
            again.Grading = grading
            reopened.recompute()
            assert again.isValid(), again.Status
            shape = REFERENCES[case]["poles"].shape[:2]
            assert again.PolesAfter == " x ".join(map(str, shape)), (grading, again.Status)
