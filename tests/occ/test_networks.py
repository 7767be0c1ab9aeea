"""Faces at their coarsest faired together by energy (occ.networks): the 99 bicubic
4 x 4 patches of shell_patches.brep (some meeting their neighbours over part of a side
only), measured by OCCT, against the same shell faired face by face (which leaves every
patch as it is); and the L of three one-span patches of
``core.examples.patch_network``, against the core's network fairing of the example
called directly (``tests/core/patch_references``, which the FreeCAD workbench's result
is compared with too)."""

import numpy as np
import pytest
from OCP.BRepBuilderAPI import BRepBuilderAPI_Sewing
from OCP.BRepCheck import BRepCheck_Analyzer

from cq_fairing.core.examples import patch_network
from cq_fairing.core.network_fairing import kept_sentence
from cq_fairing.occ.convert import face_to_surface
from cq_fairing.occ.io import read_shape
from cq_fairing.occ.shapes import fair_shape
from tests.conftest import data_path
from tests.core.patch_references import matching, network_surfaces

from .helpers import brep_round_trip, edges_of, faces_of, tolerances, vertex_reaches, vertices_of
from .test_grids import _occ_face

TOL = 0.083   # the model's default tolerance (1e-3 of its diagonal)
SIZE = 83.1   # its bounding-box diagonal


@pytest.fixture(scope="module")
def shell():
    return read_shape(data_path("shell_patches.brep"))


@pytest.fixture(scope="module")
def runs(shell):
    return {joins: fair_shape(shell, tol=TOL, joins=joins) for joins in ("smooth", "free")}


def test_face_by_face_nothing_can_be_faired(runs):
    assert runs["free"].n_faired == 0
    assert {r.status for r in runs["free"].faces} == {"unchanged"}


def test_a_network_of_patches_is_faired_together(runs):
    result = runs["smooth"]
    networked = [r for r in result.faces if r.faired and "network" in r.message]
    assert len(networked) >= 25
    assert result.joins.summary()["network_faces"] == len(networked)
    assert all(min(r.poles_after) >= 5 for r in networked)   # one span halved each way
    # faces cut at the ends of their partial joins (T-junctions) are faired too
    assert any(max(r.poles_after) > 5 for r in networked)
    assert all(r.max_deviation <= TOL for r in networked)
    assert result.valid and BRepCheck_Analyzer(result.shape).IsValid()


def test_joins_stay_closed_and_turn_no_more_than_the_source_plus_a_twentieth(runs):
    rows = runs["smooth"].joins.rows()
    assert max(r["gap"] - r["source_gap"] for r in rows) <= 1e-7 * SIZE
    assert max(r["angle_excess"] for r in rows if r["kind"] == "smooth") <= 0.05
    assert sum(r["held"] for r in rows) >= 20


def test_vertices_keep_the_source_tolerances_and_cover_every_curve_end(shell, runs, tmp_path):
    """The network faces move their corners (by up to 0.05) and their joins stay closed:
    each vertex moves to the middle of the curve ends at it and keeps the source's
    tolerance, covering every end (OCCT's evaluation), and the shape reads back valid
    from a BREP text file.  An edge's tolerance rises only between a network face and a
    kept one: where two kept faces disagree at a corner by more than the source's
    tolerance of the edge, the network face closes onto one of them."""
    result = runs["smooth"]
    corners = tolerances(vertices_of(result.shape))
    assert np.all(corners <= tolerances(vertices_of(shell)))
    assert np.all(vertex_reaches(result.shape) <= corners)
    raised = np.flatnonzero(tolerances(edges_of(result.shape)) > tolerances(edges_of(shell)))
    faces = faces_of(result.shape)
    for index in raised:
        edge = edges_of(result.shape)[index]
        statuses = {result.faces[i].status for i, face in enumerate(faces)
                    if any(edge.IsSame(e) for e in edges_of(face))}
        assert statuses == {"faired", "unchanged"}
    back = brep_round_trip(result.shape, tmp_path / "faired.brep")
    assert BRepCheck_Analyzer(back).IsValid()


def test_with_the_energy_method_faces_are_faired_again_as_networks(shell):
    """Energy keeps each face's net, so the faces it faired alone are faired again
    together by energy from their sources: every faired face is a network's, its joins
    closed and turning no more than the source + 0.05 deg, and a face with joins that no
    network moved is kept as it was, with that reason."""
    result = fair_shape(shell, tol=TOL, method="energy")
    rows = result.joins.rows()
    assert max(r["gap"] - r["source_gap"] for r in rows) <= 1e-7 * SIZE
    assert max(r["angle_excess"] for r in rows if r["kind"] == "smooth") <= 0.05
    faired = [r for r in result.faces if r.faired]
    assert len(faired) >= 20 and all("network" in r.message for r in faired)
    kept = [r for r in result.faces if "no network of faces moved it" in r.message]
    assert kept and all(r.status == "unchanged" and r.poles_after == r.poles_before
                        for r in kept)
    assert result.valid


@pytest.mark.parametrize("method", ["wavelet", "energy"])
def test_an_l_of_patches_at_their_coarsest_is_the_core_network_of_the_example(method):
    """The sewn L of patch_network at tol 0.01 (its joins turn by up to 3.2 deg, smooth
    below 5): the three faces move together, each exactly as the core's fair_network of
    the example gives it.  Wavelet has nothing to remove from them; energy fairs each
    alone first, and the network fairs them again from their sources."""
    example = patch_network()
    sewing = BRepBuilderAPI_Sewing(1e-5)
    for patch in example.patches:
        sewing.Add(_occ_face(patch))
    sewing.Perform()
    shape = sewing.SewedShape()
    result = fair_shape(shape, tol=0.01, joins="smooth", angle_tol=5.0, method=method)
    assert result.joins.summary()["network_faces"] == 3
    order = matching([face_to_surface(f)[0].poles for f in faces_of(shape)], example.patches)
    reference = network_surfaces(0.01)
    for report, k in zip(result.faces, order):
        assert report.faired and report.surface.shape == reference[k].shape == (5, 5)
        assert np.abs(report.surface.poles - reference[k].poles).max() <= 1e-9 * 2.0


def test_every_face_the_network_keeps_says_why(shell, runs):
    """Each face a network keeps (not asked to) says why in its report: the distance its
    joins alone hold it at, over the tolerance, the neighbours across the smooth joins
    that would turn, which are its neighbours in the model, or that it is planar (its
    source's poles lie in one plane)."""
    result = runs["smooth"]
    reasons = {face: kept_sentence(reason) for network in result.joins.networks
               for face, reason in network.reasons.items()}
    assert len(reasons) >= 50 and any(why.startswith("planar") for why in reasons.values())
    sources = faces_of(shell)
    for face, why in reasons.items():
        report = result.faces[face]
        assert report.status == "unchanged" and report.message == why
        if "stays" in why:
            assert float(why.split("stays ")[1].split()[0]) > TOL
        elif "joins (with face" in why:
            named = {int(k.split()[1]) for k in why.split("joins (with ")[1].split(")")[0]
                     .split(", ")}
            neighbours = {f + 1 for join in result.joins.adjacency.joins_of(face)
                          for f in join.faces if f != face}
            assert named <= neighbours
        elif why.startswith("planar"):
            poles = face_to_surface(sources[face])[0].poles.reshape(-1, 3)
            spread = np.linalg.svd(poles - poles.mean(axis=0), compute_uv=False)
            assert spread[2] <= 1e-9 * spread[0]
        else:
            assert "folds" in why or "between its own pieces" in why


def test_joins_whose_tangency_would_hold_faces_over_keep_the_source_kink(runs):
    """Joins that the source turns by up to 0.9 deg, made tangent, would move the faces
    beside them by more than the tolerance: those joins keep the source's kink instead,
    so that 43 faces are faired.  Joins between two faired faces then still turn like
    the source's, by more than 0.2 deg, and no more than the source's + 0.05 deg."""
    result = runs["smooth"]
    networked = [r for r in result.faces if r.faired and "network" in r.message]
    assert len(networked) >= 42
    kinked = [r for r in result.joins.rows() if r["kind"] == "smooth" and r["angle"] > 0.2
              and all(result.faces[f - 1].faired for f in r["faces"])]
    assert kinked and all(r["angle_excess"] <= 0.05 for r in kinked)


def test_a_join_that_would_turn_keeps_one_of_its_faces(runs):
    """Of the smooth joins that would turn more than the source's + 0.05 deg, one face
    each is kept (the one on most of them) and the other closes onto it, checked again.
    A kept face that names a faired neighbour meets it closed and turning no more than
    the source's + 0.05 deg."""
    result = runs["smooth"]
    rows = result.joins.rows()
    pairs = [(face, other) for network in result.joins.networks
             for face, why in network.reasons.items() if why[0] == "turned"
             for other in why[1] if result.faces[other].faired]
    assert pairs
    for face, other in pairs:
        between = [r for r in rows if set(r["faces"]) == {face + 1, other + 1}]
        assert between
        assert all(r["gap"] - r["source_gap"] <= 1e-7 * SIZE and r["angle_excess"] <= 0.05
                   for r in between)
