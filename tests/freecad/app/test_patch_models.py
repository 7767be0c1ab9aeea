"""Models made of patches, faired as ``cq-fairing fair`` fairs them, inside FreeCAD (no
mocks): a patch grid that forms a whole shell is merged and faired as one surface, and
faces already at their coarsest are faired together by energy.

The shells are sewn by Part from the core's example patches; each result is compared
with the core's functions called directly on the example (``tests/core/patch_references``,
the references ``cq_fairing.occ.fair_shape`` is compared with in ``tests/occ``), and its
joins and deviations are measured with OCCT's projection and normals through Part,
independently of the workbench's measure.
"""

from dataclasses import replace

import numpy as np

import FreeCAD
import Part
from cq_fairing.core.examples import patch_grid, patch_network
from fairing_wb import make

import fixtures
from tests.core.patch_references import grid_pieces, matching, network_surfaces
from tests.core.test_network_pieces import bricks

TOL = 0.01
GRID_ANGLE = 20.0     # the noisy grid's joins turn by up to 16 deg: smooth ones here
NETWORK_ANGLE = 5.0   # the L's joins turn by up to 3.2 deg
SETTINGS = {"tolerance": TOL, "target": None, "method": "wavelet", "search": "linear",
            "measure": "parametric", "objective": "compact"}
FACE_SETTINGS = {"boundary": "free", "borders": "auto"}
# search and measure belong to the wavelet method: energy takes their defaults
ENERGY = dict(SETTINGS, method="energy", search=make.SEARCHES[0], measure=make.MEASURES[0])



def _part_face(surface):
    """A Part face on a core surface, built with Part's own constructor."""
    knots = [np.unique(k, return_counts=True) for k in (surface.u_knots, surface.v_knots)]
    part = Part.BSplineSurface()
    part.buildFromPolesMultsKnots(
        [[FreeCAD.Vector(*map(float, p)) for p in row] for row in surface.poles],
        [int(m) for m in knots[0][1]], [int(m) for m in knots[1][1]],
        [float(k) for k in knots[0][0]], [float(k) for k in knots[1][0]],
        False, False, surface.u_degree, surface.v_degree)
    return Part.Face(part)


def _sewn(doc, patches, name):
    """The patches sewn into one shell by Part, as a document object."""
    shape = Part.makeCompound([_part_face(p) for p in patches])
    shape.sewShape(1e-5)
    assert len(shape.Shells) == 1 and len(shape.Shells[0].Faces) == len(patches)
    obj = fixtures.add_shape(doc, shape.Shells[0], name)
    doc.recompute()
    return obj


def _net(face):
    """``(poles, u knots, v knots)`` of a Part face's surface, knots expanded."""
    surface = face.Surface
    poles = np.array([[tuple(p) for p in row] for row in surface.getPoles()])
    return (poles, np.repeat(surface.getUKnots(), surface.getUMultiplicities()),
            np.repeat(surface.getVKnots(), surface.getVMultiplicities()))


def _order(obj, patches):
    """The example patch of each face of ``obj`` (sewing may reorder them)."""
    return matching([_net(face)[0] for face in obj.Shape.Faces], patches)


def _fair(obj, joins, angle, method="wavelet"):
    subs = [f"Face{i + 1}" for i in range(len(obj.Shape.Faces))]
    settings = SETTINGS if method == "wavelet" else dict(ENERGY, method=method)
    return make.fair_elements(obj, subs, settings, FACE_SETTINGS, joins=joins,
                              angle_tolerance=angle)


def _assert_equal_to(results, order, reference):
    """Every faired face (the Part face installed) is the reference piece of its patch:
    the same knots, poles to 1e-9 of the model's size."""
    for result, k in zip(results, order):
        poles, u_knots, v_knots = _net(result.shape)
        assert poles.shape == reference[k].poles.shape
        assert np.abs(u_knots - reference[k].u_knots).max() <= 1e-12
        assert np.abs(v_knots - reference[k].v_knots).max() <= 1e-12
        assert np.abs(poles - reference[k].poles).max() <= 1e-9 * 2.0


def _assert_within_tolerance(obj, results):
    for result, face in zip(results, obj.Shape.Faces):
        assert result.note == "" and result.max_deviation <= TOL
        assert fixtures.sample_distance(result.shape, face) <= TOL
        assert fixtures.sample_distance(face, result.shape) <= TOL


def test_a_patch_grid_is_faired_as_one_surface_cut_in_four(doc):
    """The sewn 2 x 2 grid: one surface faired across the joins and cut back, so the four
    pieces meet to round-off with the same normals (the source's joins turn by up to
    16 deg); the pieces are the core's merge of the example faired and cut."""
    obj = _sewn(doc, patch_grid().patches, "Grid")
    results = _fair(obj, "smooth", GRID_ANGLE)
    summary = results.joins.summary()
    assert summary["grids"] == [[2, 2]] and summary["grid_faces"] == 4
    assert summary["joins"] == summary["held"] == 4
    _assert_within_tolerance(obj, results)
    _assert_equal_to(results, _order(obj, patch_grid().patches), grid_pieces(TOL))
    rows = fixtures.joins_along(obj.Shape, [r.shape for r in results])
    assert len(rows) == 4
    for gap, before, after in rows:
        assert gap <= 1e-9 * 2.0
        assert before.max() > 1.0 and after.max() <= 1e-4, (before.max(), after.max())


def test_faces_at_their_coarsest_are_faired_together_by_energy(doc):
    """The sewn L of three one-span bicubic patches: alone each face has nothing to
    remove; together they are faired by energy across their joins, closed and G1 (the
    source's joins turn by up to 3.2 deg), exactly as the core's network fairing of the
    example."""
    example = patch_network()
    obj = _sewn(doc, example.patches, "L")
    alone = _fair(obj, "free", NETWORK_ANGLE)
    assert all(r.poles_after == (4, 4) and r.max_deviation <= 1e-9 * 2.0 for r in alone)
    results = _fair(obj, "smooth", NETWORK_ANGLE)
    summary = results.joins.summary()
    assert summary["network_faces"] == 3 and summary["joins"] == summary["held"] == 2
    assert all(r.poles_after == (5, 5) for r in results)
    _assert_within_tolerance(obj, results)
    _assert_equal_to(results, _order(obj, example.patches), network_surfaces(TOL))
    for gap, before, after in fixtures.joins_along(obj.Shape, [r.shape for r in results]):
        assert gap <= 1e-9 * 2.0
        assert before.max() > 0.5 and after.max() <= 1e-4, (before.max(), after.max())


def test_with_the_energy_method_the_faces_are_the_same_network(doc):
    """Energy fairs each face of the L alone first (moving its poles on its own net);
    with the joins held the faces are faired again together from their sources, so the
    result is the same network as the core's (and the command line's)."""
    example = patch_network()
    obj = _sewn(doc, example.patches, "L")
    alone = _fair(obj, "free", NETWORK_ANGLE, "energy")
    assert all(r.poles_after == (4, 4) and r.max_deviation > 1e-6 for r in alone)
    results = _fair(obj, "smooth", NETWORK_ANGLE, "energy")
    assert results.joins.summary()["network_faces"] == 3
    _assert_equal_to(results, _order(obj, example.patches), network_surfaces(TOL))


def test_with_the_energy_method_a_tight_tolerance_keeps_the_source_kinks(doc):
    """At 0.001 mm energy moves each face of the L alone; with the joins held, tangent
    joins would hold the faces further than that, so the joins keep the source's kinks:
    the three faces are faired together within 0.001, their joins closed and turning
    like the source's, no more than its angle + 0.05 deg."""
    obj = _sewn(doc, patch_network().patches, "L")
    alone, held = (make.fair_elements(obj, [f"Face{i + 1}" for i in range(3)],
                                      dict(ENERGY, tolerance=0.001),
                                      FACE_SETTINGS, joins=joins,
                                      angle_tolerance=NETWORK_ANGLE)
                   for joins in ("free", "smooth"))
    assert all(0 < r.max_deviation <= 0.001 for r in alone)
    assert held.joins.summary()["network_faces"] == 3
    assert all(r.poles_after == (5, 5) and 0 < r.max_deviation <= 0.001 for r in held)
    for gap, before, after in fixtures.joins_along(obj.Shape, [r.shape for r in held]):
        assert gap <= 1e-9 * 2.0
        assert before.max() > 0.5 and np.max(after - before) <= 0.05, (before, after)


def test_faces_meeting_at_a_t_junction_are_faired_as_pieces(doc):
    """The sewn bricks of ``tests/core/test_network_pieces`` (one wide one-span patch
    under two narrow ones: Part's sewing splits its top edge at the T-junction): the wide
    face is cut at the T and faired with its neighbours by energy, the three faces stay
    closed and turn no more than the source + 0.05 deg, within the tolerance, and the
    wide face comes back with its cut as a knot of the degree's multiplicity."""
    obj = _sewn(doc, bricks(), "Bricks")
    assert sorted(len(face.Edges) for face in obj.Shape.Faces) == [4, 4, 5]
    results = _fair(obj, "smooth", NETWORK_ANGLE)
    summary = results.joins.summary()
    assert summary["network_faces"] == 3 and summary["joins"] == summary["held"] == 3
    _assert_within_tolerance(obj, results)
    wide = [r for r, face in zip(results, obj.Shape.Faces) if len(face.Edges) == 5][0]
    _, u_knots, _ = _net(wide.shape)
    assert np.count_nonzero(np.isclose(u_knots, 0.5, atol=1e-12)) == 3
    for gap, before, after in fixtures.joins_along(obj.Shape, [r.shape for r in results]):
        assert gap <= 1e-9 * 2.0
        assert after.max() <= before.max() + 0.05, (before.max(), after.max())


def _flat_corner_l():
    """The L of patch_network with its corner patch flattened (z = 0, and the border rows
    its neighbours share with it)."""
    example = patch_network()
    nets = [p.poles.copy() for p in example.patches]
    nets[0][..., 2] = 0.0
    for join in example.joins:
        rows = {"u0": nets[join.b][0], "u1": nets[join.b][-1], "v0": nets[join.b][:, 0],
                "v1": nets[join.b][:, -1]}
        rows[join.side_b][..., 2] = 0.0
    return [replace(p, poles=net) for p, net in zip(example.patches, nets)]


def test_the_feature_reports_grids_networks_and_why_faces_stay(doc):
    """The feature's Status names the patch grid faired as one surface, the faces faired
    together by energy, and why a face at its coarsest stays as it is (the L with its
    corner face planar: energy could only bend it, and its neighbours close onto it)."""
    grid = make.make_fairing(_sewn(doc, patch_grid().patches, "Grid"), tolerance=TOL,
                             angle_tolerance=GRID_ANGLE)
    network = make.make_fairing(_sewn(doc, patch_network().patches, "L"), tolerance=TOL,
                                angle_tolerance=NETWORK_ANGLE, name="Network")
    flat = make.make_fairing(_sewn(doc, _flat_corner_l(), "FlatL"), tolerance=0.05,
                             angle_tolerance=NETWORK_ANGLE, name="Flat")
    doc.recompute()
    for obj in (grid, network, flat):
        assert obj.isValid() and obj.Shape.isValid(), obj.Status
        assert len(obj.Shape.Shells) == 1
    assert grid.Status.startswith("OK; joins: 4 (4 held closed)")
    assert grid.Status.endswith("; 1 patch grids (4 faces) faired as one surface each")
    assert network.Status.endswith("; 3 faces at their coarsest faired together")
    assert network.PolesAfter == "5 x 5; 5 x 5; 5 x 5"
    assert flat.Status.startswith("OK; Face1 kept unchanged: planar: energy fairing could "
                                  "only bend it out of its plane"), flat.Status
    assert flat.Status.endswith("; 2 faces at their coarsest faired together")
    assert flat.PolesAfter == "4 x 4; 5 x 5; 5 x 5" and 0 < flat.MaxDeviation.Value <= 0.05
