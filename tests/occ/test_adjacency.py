"""find_joins / measure_joins on real shells, a solid and loose IGES faces, checked against
independent OCCT computations (ancestor maps, projections, BRepExtrema)."""


import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import (
    BRepBuilderAPI_Copy,
    BRepBuilderAPI_MakeEdge,
    BRepBuilderAPI_MakeFace,
    BRepBuilderAPI_MakeVertex,
    BRepBuilderAPI_MakeWire,
)
from OCP.BRepExtrema import BRepExtrema_DistShapeShape
from OCP.gp import gp_Pnt, gp_Vec
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

from cq_fairing.errors import InvalidInputError
from cq_fairing.occ.adjacency import Join, find_joins, measure_joins
from cq_fairing.occ.convert import indexed_faces, replace_surface
from cq_fairing.occ.shapes import free_edge_count
from tests.occ.helpers import compound, faces_of, global_distance, three_faces_on_one_edge


def edge_map(shape):
    emap = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, emap)
    return emap


def distinct_faces(face_list):
    out = []
    for face in face_list:
        if not any(face.IsSame(other) for other in out):
            out.append(face)
    return out


def xyz(point):
    return np.array([point.X(), point.Y(), point.Z()])


@pytest.fixture(scope="module")
def fuselage(real):
    return real("fuselage.brep"), find_joins(real("fuselage.brep"))


# -- shells and solids ----------------------------------------------------------------------
def test_fuselage_has_twelve_tangent_joins_and_two_knife_edge_creases(fuselage):
    shape, adjacency = fuselage
    assert len(adjacency.joins) == 14
    smooth = [j for j in adjacency.joins if j.kind == "smooth"]
    crease = [j for j in adjacency.joins if j.kind == "crease"]
    assert len(smooth) == 12 and len(crease) == 2
    assert all(j.source_angle < 1e-3 for j in smooth)          # exactly G1
    assert all(j.source_gap < 1e-9 for j in adjacency.joins)  # one shared edge
    for join in crease:
        # the tail closes into a knife edge: the oriented normals are 150 deg apart at
        # one end (a 30 deg wedge, the "29.6 deg" crease) and opposite at the tip
        assert 149.5 < join.source_angles.min() < 150.5
        assert join.source_angle > 179.0
        assert np.all(np.diff(join.source_angles) > -1e-6)
    assert adjacency.non_manifold == [] and adjacency.free_edges == 0
    summary = adjacency.summary()
    assert (summary["joins"], summary["smooth"], summary["crease"]) == (14, 12, 2)


def test_fuselage_join_sides_are_whole_parameter_borders(fuselage):
    shape, adjacency = fuselage
    faces = indexed_faces(shape)
    emap = edge_map(shape)
    for join in adjacency.joins:
        assert join.shared and not join.opposed
        assert join.sides[0].edge == join.sides[1].edge
        for side in join.sides:
            assert side.side in ("u0", "u1", "v0", "v1") and side.full
            # independent: the iso-line of the surface on that border is the edge
            surface = BRep_Tool.Surface_s(faces[side.face])
            u0, u1, v0, v1 = surface.Bounds()
            level = {"u0": u0, "u1": u1, "v0": v0, "v1": v1}[side.side]
            edge = TopoDS.Edge_s(emap.FindKey(side.edge).Oriented(TopAbs_FORWARD))
            curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
            a, b = BRep_Tool.Range_s(edge)
            for s in (0.0, 0.3, 1.0):
                w = side.along[0] + s * (side.along[1] - side.along[0])
                uv = (level, w) if side.side[0] == "u" else (w, level)
                on_surface = xyz(surface.Value(*uv))
                on_edge = xyz(curve.Value(a + s * (b - a)))
                assert np.linalg.norm(on_surface - on_edge) < 1e-6 * 2500


def test_fuselage_joins_of_lists_each_face_with_its_neighbours(fuselage):
    _, adjacency = fuselage
    for face in range(8):
        joins = adjacency.joins_of(face)
        assert joins and all(face in j.faces for j in joins)
    assert sum(len(adjacency.joins_of(f)) for f in range(8)) == 2 * 14


def test_testtoler_joins_are_the_edges_of_two_faces(real):
    shape = real("testtoler.brep")
    adjacency = find_joins(shape)
    emap = edge_map(shape)
    two = []
    for i in range(1, emap.Extent() + 1):
        if BRep_Tool.Degenerated_s(TopoDS.Edge_s(emap.FindKey(i))):
            continue
        if len(distinct_faces(emap.FindFromIndex(i))) == 2:
            two.append(i)
    assert sorted(j.sides[0].edge for j in adjacency.joins) == two
    assert len(adjacency.joins) == 97
    assert adjacency.free_edges == free_edge_count(shape) == 30
    # untrimmed faces: every side lies on a border of its parameter rectangle, and covers
    # it (some edges stop up to 7e-5 inside the surface's bounds: 1e-4 or less in 3-D)
    assert all(side.side is not None for j in adjacency.joins for side in j.sides)
    assert all(side.full for j in adjacency.joins for side in j.sides)
    short = [j for j in adjacency.joins if j.faces == (0, 47)][0].sides[0]
    assert 0.0 < 110.9834165 - max(short.along) < 1e-4


def test_testtoler_source_gaps_match_an_independent_projection(real):
    """The largest distance from face 0's join points to face 1's surface
    (GeomAPI_ProjectPointOnSurf over the whole surface) and back, per join."""
    shape = real("testtoler.brep")
    adjacency = find_joins(shape, samples=12)
    faces = indexed_faces(shape)
    emap = edge_map(shape)
    for join in adjacency.joins[::6]:
        edge = TopoDS.Edge_s(emap.FindKey(join.sides[0].edge).Oriented(TopAbs_FORWARD))
        worst = 0.0
        for this, other in (join.sides, join.sides[::-1]):
            face = faces[this.face]
            pcurve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
            a, b = BRep_Tool.Range_s(edge, face)
            surface = BRep_Tool.Surface_s(face)
            points = [xyz(surface.Value(*pcurve.Value(float(t)).Coord()))
                      for t in np.linspace(a, b, 12)]
            worst = max(worst, global_distance(points, faces[other.face]).max())
        assert join.source_gap == pytest.approx(worst, abs=1e-7 * 6000)


def test_shell_patches_matches_its_inventory(real):
    adjacency = find_joins(real("shell_patches.brep"))
    assert len(adjacency.joins) == 178
    summary = adjacency.summary()
    assert 1.2e-4 < summary["max_gap"] < 1.45e-4
    assert 2.9 < summary["max_angle"] < 3.1
    assert 167 <= summary["smooth"] <= 171                     # below 1 deg
    assert sum(j.source_angle < 2.0 for j in adjacency.joins) == 175
    # unclamped knots: the borders are still the Bounds() rectangle's sides
    full = [s for j in adjacency.joins for s in j.sides if s.full]
    assert len(full) > 300 and all(s.side is not None for s in full)


def test_linkrods_seams_are_not_joins(real):
    shape = real("linkrods.step")
    adjacency = find_joins(shape)
    emap = edge_map(shape)
    seams = [i for i in range(1, emap.Extent() + 1)
             if emap.FindFromIndex(i).Size() == 2
             and len(distinct_faces(emap.FindFromIndex(i))) == 1]
    assert len(seams) == 9
    edges = {s.edge for j in adjacency.joins for s in j.sides}
    assert not edges & set(seams)
    assert len(adjacency.joins) == 99 and adjacency.free_edges == 0
    assert all(j.faces[0] != j.faces[1] for j in adjacency.joins)
    # planes, cylinders and tori have no B-spline parameter border to name
    kinds = [BRep_Tool.Surface_s(f).DynamicType().Name() for f in indexed_faces(shape)]
    for join in adjacency.joins:
        for side in join.sides:
            if "BSpline" not in kinds[side.face]:
                assert side.side is None and not side.full


# -- loose faces --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def impeller(real):
    shape = real("impeller.igs")
    before = indexed_faces(shape)
    adjacency = find_joins(shape)
    return shape, before, adjacency


def test_impeller_joins_are_found_by_coincidence(impeller):
    shape, _, adjacency = impeller
    assert len(adjacency.joins) > 400
    assert all(not j.shared for j in adjacency.joins)
    assert all(j.sides[0].edge != j.sides[1].edge for j in adjacency.joins)
    assert all(j.source_angle <= 90.0 for j in adjacency.joins)  # folded
    used = [s.edge for j in adjacency.joins for s in j.sides]
    assert len(used) == len(set(used))
    assert adjacency.free_edges == free_edge_count(shape) - len(used)


def test_impeller_sample_joins_really_coincide(impeller):
    shape, _, adjacency = impeller
    emap = edge_map(shape)
    for join in adjacency.joins[::40]:
        first, second = (TopoDS.Edge_s(emap.FindKey(s.edge)) for s in join.sides)
        limit = max(adjacency.coincidence, BRep_Tool.Tolerance_s(first),
                    BRep_Tool.Tolerance_s(second))
        curve = BRep_Tool.Curve_s(first, 0.0, 0.0)
        a, b = BRep_Tool.Range_s(first)
        for t in np.linspace(a, b, 5):
            vertex = BRepBuilderAPI_MakeVertex(curve.Value(float(t))).Vertex()
            dist = BRepExtrema_DistShapeShape(vertex, second)
            assert dist.IsDone() and dist.Value() <= limit * (1 + 1e-9)
        assert join.source_gap <= 1.5 * limit


def test_impeller_source_is_unchanged(impeller):
    shape, before, _ = impeller
    after = indexed_faces(shape)
    assert len(after) == len(before) == 277
    assert all(a.TShape() == b.TShape() and a.IsEqual(b) for a, b in zip(after, before))
    assert free_edge_count(shape) == 4640


def square(x0, y0, x1, y1):
    corners = [gp_Pnt(x0, y0, 0), gp_Pnt(x1, y0, 0), gp_Pnt(x1, y1, 0), gp_Pnt(x0, y1, 0)]
    wire = BRepBuilderAPI_MakeWire()
    for p, q in zip(corners, corners[1:] + corners[:1]):
        wire.Add(BRepBuilderAPI_MakeEdge(p, q).Edge())
    return BRepBuilderAPI_MakeFace(wire.Wire(), True).Face()


def test_two_loose_squares_join_along_their_common_side():
    adjacency = find_joins(compound(square(0, 0, 1, 1), square(1, 0, 2, 1)))
    assert len(adjacency.joins) == 1
    join = adjacency.joins[0]
    assert join.faces == (0, 1) and not join.shared and join.opposed
    assert join.kind == "smooth" and join.source_angle < 1e-9 and join.source_gap < 1e-12
    assert all(s.side is None for s in join.sides)              # planes
    assert adjacency.free_edges == 6 and adjacency.point_contacts == []


def test_small_faces_of_a_large_model_are_not_joined_across_a_gap_of_their_own_size():
    """The coincidence distance (1e-4 of a 14000-wide model: 1.4) is capped at 1 % of the
    shorter edge: two unit squares 0.05 apart stay apart, 0.005 apart they join."""
    far = square(10000, 10000, 10001, 10001)
    apart = find_joins(compound(square(0, 0, 1, 1), square(1.05, 0, 2.05, 1), far))
    close = find_joins(compound(square(0, 0, 1, 1), square(1.005, 0, 2.005, 1), far))
    assert apart.coincidence > 1.0 and apart.joins == []
    assert [j.faces for j in close.joins] == [(0, 1)]


def test_squares_touching_at_a_corner_are_a_point_contact():
    adjacency = find_joins(compound(square(0, 0, 1, 1), square(1, 1, 2, 2)))
    assert adjacency.joins == [] and adjacency.point_contacts == [(0, 1)]
    apart = find_joins(compound(square(0, 0, 1, 1), square(1.5, 1.5, 2, 2)))
    assert apart.point_contacts == []


def test_an_edge_of_three_faces_is_non_manifold():
    faces, spine = three_faces_on_one_edge()
    shape = compound(*faces)
    adjacency = find_joins(shape)
    emap = edge_map(shape)
    assert adjacency.non_manifold == [emap.FindIndex(spine)]
    assert adjacency.joins == []


# -- measuring a changed copy ----------------------------------------------------------------
def moved_copy(shape, moved, offset):
    """A copy of ``shape`` whose face ``moved`` is translated by ``offset`` along its
    normal at the middle of its parameter box; the normal."""
    copy = BRepBuilderAPI_Copy(shape, True, False).Shape()
    face = indexed_faces(copy)[moved]
    surface = BRep_Tool.Surface_s(face)
    u0, u1, v0, v1 = surface.Bounds()
    p, du, dv = gp_Pnt(), gp_Vec(), gp_Vec()
    surface.D1(0.5 * (u0 + u1), 0.5 * (v0 + v1), p, du, dv)
    normal = du.Crossed(dv).Normalized()
    replace_surface(face, surface.Translated(normal.Multiplied(offset)))
    return copy, normal


def test_measure_joins_on_the_source_repeats_the_source_values(fuselage):
    shape, adjacency = fuselage
    measures = measure_joins(shape, adjacency.joins)
    for join, measure in zip(adjacency.joins, measures):
        assert measure.gap == join.source_gap and measure.angle == join.source_angle
        np.testing.assert_array_equal(measure.angles, join.source_angles)


def test_measure_joins_sees_a_face_moved_along_its_normal(fuselage):
    shape, adjacency = fuselage
    offset, moved = 0.01, 5
    copy, normal = moved_copy(shape, moved, offset)
    emap = edge_map(copy)
    measures = measure_joins(copy, adjacency.joins)
    for join, measure in zip(adjacency.joins, measures):
        if moved not in join.faces:
            assert measure.gap < 1e-9
            continue
        # independent, both ways: the edge's 3-D curve stays on the unmoved face, the
        # moved face's points are those points translated; each set's distance to the
        # other face's surface (GeomAPI_ProjectPointOnSurf) at the same samples
        still = join.faces[1] if join.faces[0] == moved else join.faces[0]
        edge = TopoDS.Edge_s(emap.FindKey(join.sides[0].edge).Oriented(TopAbs_FORWARD))
        curve = BRep_Tool.Curve_s(edge, 0.0, 0.0)
        a, b = BRep_Tool.Range_s(edge)
        points = np.array([xyz(curve.Value(float(t))) for t in np.linspace(a, b, 24)])
        shifted = points + offset * xyz(normal)
        expected = np.maximum(global_distance(points, faces_of(copy)[moved]),
                              global_distance(shifted, faces_of(copy)[still]))
        assert measure.gap <= offset * (1 + 1e-6)
        assert measure.gap > 0.5 * offset
        # an orthogonal projection misses a closest point on the face's border (along
        # the knife edge the moved face overhangs): never below it; the ends are corners
        assert np.all(measure.gaps[1:-1] <= expected[1:-1] * (1 + 1e-6) + 1e-9)
        if join.kind == "smooth":
            np.testing.assert_allclose(measure.gaps[1:-1], expected[1:-1], rtol=1e-3, atol=1e-6)
        forward = global_distance(points[[0, -1]], faces_of(copy)[moved])
        assert np.all(measure.gaps[[0, -1]] >= forward * (1 - 1e-3))
        # a translation turns no normal; the projected points shift a little along the
        # surface (0.003 deg; up to 0.16 deg next to the tail's tip, where it turns fast)
        turn = np.abs(measure.angles - join.source_angles)
        assert np.median(turn) < 1e-2 and turn.max() < 0.5


def test_each_join_measured_alone_is_measured_the_same_among_all(impeller, fuselage):
    """All joins are measured at once (each face's points evaluated together, one
    projection run): every figure is the one the join gets measured alone, to the bit,
    on rational B-spline faces, surfaces of revolution and loose joins (the impeller)
    and the fuselage's knife edge, whose tip is a pole."""
    for shape, adjacency in ((impeller[0], impeller[2]), fuselage):
        joins = adjacency.joins[::9] if len(adjacency.joins) > 100 else adjacency.joins
        together = measure_joins(shape, joins)
        for join, measure in zip(joins, together):
            alone = measure_joins(shape, [join])[0]
            np.testing.assert_array_equal(measure.gaps, alone.gaps)
            np.testing.assert_array_equal(measure.angles, alone.angles)


def test_joins_between_unchanged_faces_keep_their_source_measure(fuselage):
    """``Adjacency.measure``: a join between two faces left as they were keeps its source
    measure, which is what measuring it again gives, to the bit; the joins of the moved
    face are measured again (as ``measure_joins`` measures them)."""
    shape, adjacency = fuselage
    moved, offset = 5, 0.01
    copy, _ = moved_copy(shape, moved, offset)
    others = set(range(len(indexed_faces(copy)))) - {moved}
    kept = adjacency.measure(copy, unchanged=others)
    again = adjacency.measure(copy)
    fresh = measure_joins(copy, adjacency.joins)
    assert len(kept) == len(again) == len(fresh) == len(adjacency.joins) == 14
    for join, source, k, a, f in zip(adjacency.joins, adjacency.measures, kept, again, fresh):
        np.testing.assert_array_equal(k.gaps, a.gaps)
        np.testing.assert_array_equal(k.angles, a.angles)
        np.testing.assert_allclose(k.gaps, f.gaps, rtol=1e-9, atol=1e-12 * 2500)
        np.testing.assert_allclose(k.angles, f.angles, rtol=1e-9, atol=1e-6)
        if moved in join.faces:
            assert k.gap > 0.5 * offset
        else:
            assert k is source and k.gap == join.source_gap and k.angle == join.source_angle
            np.testing.assert_array_equal(k.angles, join.source_angles)


def test_fair_shape_reports_the_joins_as_measured_on_its_result(real):
    """The joins between faces fair_shape left unchanged take their source measure: the
    report is the whole result measured again, to the bit."""
    from cq_fairing.occ.shapes import fair_shape

    result = fair_shape(real("fuselage.brep"), tol=2.5)
    adjacency = result.joins.adjacency
    unchanged = {i for i, face in enumerate(result.faces) if not face.faired}
    assert any(set(join.faces) <= unchanged for join in adjacency.joins)
    assert any(not set(join.faces) <= unchanged for join in adjacency.joins)
    for reported, measured in zip(result.joins.measures, adjacency.measure(result.shape)):
        np.testing.assert_array_equal(reported.gaps, measured.gaps)
        np.testing.assert_array_equal(reported.angles, measured.angles)


# -- input checks ---------------------------------------------------------------------------
@pytest.mark.parametrize("options", [
    dict(angle_tol=0), dict(angle_tol=-1.0), dict(angle_tol=180.0), dict(angle_tol=float("nan")),
    dict(angle_tol="1"), dict(angle_tol=True), dict(samples=1), dict(samples=2.5),
    dict(samples=True), dict(coincidence=0.0), dict(coincidence=-1e-3),
    dict(coincidence=float("inf")), dict(coincidence="small"),
])
def test_bad_options_raise_invalid_input(fuselage, options):
    shape, _ = fuselage
    with pytest.raises(InvalidInputError) as info:
        find_joins(shape, **options)
    name = next(iter(options))
    assert name in str(info.value) and "got" in str(info.value)


def test_bad_shape_and_foreign_joins_raise_invalid_input(real, fuselage):
    shape, adjacency = fuselage
    with pytest.raises(InvalidInputError):
        find_joins(None)
    with pytest.raises(InvalidInputError, match="same faces and edges"):
        measure_joins(shape, find_joins(real("testtoler.brep")).joins)
    with pytest.raises(InvalidInputError, match="Join"):
        measure_joins(shape, [(0, 1)])
    with pytest.raises(InvalidInputError, match="samples"):
        measure_joins(shape, adjacency.joins, samples=0)
    with pytest.raises(InvalidInputError, match="unchanged"):
        adjacency.measure(shape, unchanged=["0"])
    with pytest.raises(InvalidInputError, match="same faces and edges"):
        find_joins(real("testtoler.brep")).measure(shape)
    with pytest.raises(InvalidInputError, match="face index"):
        adjacency.joins_of("0")
    assert isinstance(adjacency.joins[0], Join)
