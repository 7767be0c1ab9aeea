"""OCCT's deviation check against brute force: the largest distances are measured again,
and the way back from the faired face too."""

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.occ.builders import surface_to_natural_face
from cq_fairing.occ.convert import to_geom_surface
from cq_fairing.occ.deviation import _refine_largest, sample_face_deviation
from tests.occ.helpers import global_distance


def test_the_largest_upper_bounds_are_measured_again_down_to_a_true_maximum():
    """Points above a bicubic bump carry upper bounds of their distance (the distance to a
    wrong point of the surface, as a Newton run stuck at another extremum gives).  After
    the refinement the largest value is a true distance (brute force on a dense grid of
    the surface), no value is below its true distance, and samples whose bound is below
    the final maximum keep their bound (the walk stops early)."""
    rng = np.random.default_rng(4)
    u = np.linspace(0.0, 1.0, 6)
    grid = np.stack(list(np.meshgrid(u, u, indexing="ij")), axis=-1)
    z = 0.3 * np.sin(3 * grid[..., 0]) * np.cos(2 * grid[..., 1])
    surface = cf.make_surface(np.concatenate([grid, z[..., None]], axis=-1))
    dense = surface.evaluate_grid(np.linspace(0, 1, 600), np.linspace(0, 1, 600)).reshape(-1, 3)
    points = np.column_stack([rng.uniform(0.1, 0.9, (40, 2)), rng.uniform(-0.5, 0.5, 40)])
    true = np.array([np.linalg.norm(dense - p, axis=1).min() for p in points])
    wrong = surface.evaluate_grid(np.array([0.0]), np.array([0.0]))[0, 0]   # a corner
    projected = np.tile(wrong, (points.shape[0], 1))
    bound = np.linalg.norm(points - wrong, axis=1)
    distance = bound.copy()
    geom = to_geom_surface(surface)
    _refine_largest(geom, points, distance, projected)
    assert np.all(distance >= true - 1e-4)             # dense grid: 1e-4 is its spacing
    k = int(np.argmax(distance))
    assert distance[k] <= true[k] + 1e-9 and distance[k] < bound[k]
    untouched = bound < distance.max()
    assert untouched.any() and np.array_equal(distance[untouched], bound[untouched])
    np.testing.assert_allclose(np.linalg.norm(projected - points, axis=1), distance)


def test_a_faired_face_reaching_beyond_the_original_is_measured_on_the_way_back():
    """The faired patch covers the original and half a unit more (x up to 10.5 where the
    original ends at 10): every original point lies on it (the way there is 0), but its
    own points reach 0.5 beyond.  The check measures both ways, as OCCT's own projection
    of the faired points onto the original finds."""
    u = np.linspace(0.0, 1.0, 4)
    grid = np.stack(list(np.meshgrid(u, u, indexing="ij")), axis=-1)

    def patch(length):
        net = np.concatenate([grid * [length, 1.0], np.zeros((4, 4, 1))], axis=-1)
        return surface_to_natural_face(cf.make_surface(net))

    original, faired = patch(10.0), patch(10.5)
    samples = sample_face_deviation(original, faired, density=21)
    assert samples["distance"].max() <= 1e-9
    independent = global_distance(samples["faired_points"], original)
    beyond = samples["faired_points"][:, 0] > 10.0
    independent[beyond] = samples["faired_points"][beyond, 0] - 10.0   # nearest: the end x = 10
    np.testing.assert_allclose(samples["distance_back"], independent, atol=1e-9)
    assert samples["max"] == pytest.approx(0.5)


def _real_faired(real, name, pick, tol):
    """A face of a bundled model (the ``pick(surface)``-th match) and its face faired
    at ``tol`` with explicit scales kept small, so the distances are far from zero."""
    from cq_fairing.occ import face_to_surface, fair_face
    from tests.occ.helpers import faces_of

    for face in faces_of(real(name)):
        try:
            surface, _ = face_to_surface(face)
        except cf.UnsupportedGeometryError:
            continue
        if pick(surface):
            return face, fair_face(face, tol=tol, details=False)
    raise LookupError(name)


def test_an_untrimmed_face_keeps_every_sample_and_occt_puts_each_on_the_face(real):
    """The testtoler strip is untrimmed: its deviation keeps every one of the 30 x 30
    samples of its UV box without classifying them, and OCCT's classifier
    (``BRepTopAdaptor_FClass2d``, as for trimmed faces) finds each inside or on it."""
    from OCP.BRepTopAdaptor import BRepTopAdaptor_FClass2d
    from OCP.gp import gp_Pnt2d
    from OCP.TopAbs import TopAbs_IN, TopAbs_ON

    from cq_fairing.occ.convert import face_info

    face, report = _real_faired(real, "testtoler.brep", lambda s: s.shape[0] > 100, 2.0)
    assert not face_info(face).trimmed
    samples = sample_face_deviation(face, report.face, density=30)
    assert samples["uv"].shape == (900, 2)
    classifier = BRepTopAdaptor_FClass2d(face, 1e-9)
    assert all(classifier.Perform(gp_Pnt2d(float(u), float(v))) in (TopAbs_IN, TopAbs_ON)
               for u, v in samples["uv"])


REAL_FACES = {
    "IEA main face": ("IEA_15MW_CFD.stp", lambda s: s.shape[1] > 200, 0.05),
    "testtoler strip": ("testtoler.brep", lambda s: s.shape[0] > 100, 2.0),
    "impeller fillet (rational)": ("impeller.igs",
                                   lambda s: s.shape == (50, 3) and s.is_rational, 2e-3),
}


@pytest.mark.parametrize("label", list(REAL_FACES))
def test_batched_distances_agree_with_occts_global_projection(real, label):
    """The batched distances (the core's Newton for every sample, OCCT at the maxima) are
    never above OCCT's own GeomAPI_ProjectPointOnSurf distance (where OCCT finds an
    orthogonal projection; its extrema are approximate, and a border point can be
    nearer), agree with it to far below the tolerance at every sample, and the maximum
    is OCCT's to round-off.  That they are never below the true distance is the dense
    test's part."""
    name, pick, tol = REAL_FACES[label]
    face, report = _real_faired(real, name, pick, tol)
    assert report.faired
    samples = sample_face_deviation(face, report.face, density=30)
    there = global_distance(samples["points"], report.face)
    back = global_distance(samples["faired_points"], face)
    for batched, occt in ((samples["distance"], there), (samples["distance_back"], back)):
        found = np.isfinite(occt)           # OCCT finds no orthogonal projection off borders
        assert found.mean() > 0.5
        assert np.all(batched[found] <= occt[found] + 1e-6 * tol)
        assert np.median(occt[found] - batched[found]) <= 1e-6 * tol
    assert samples["max"] <= tol
    assert samples["max"] <= max(there[np.isfinite(there)].max(),
                                 back[np.isfinite(back)].max()) + 1e-6 * tol


@pytest.mark.parametrize("label", list(REAL_FACES))
def test_batched_distances_agree_with_a_naive_dense_search(real, label):
    """Against brute force: the nearest of 600 x 600 points of the faired surface (its
    own core evaluation) is at most ``spacing`` farther than the true foot point, so the
    batched distance lies within [dense - spacing, dense]."""
    from scipy.spatial import cKDTree

    from cq_fairing.occ import face_to_surface

    name, pick, tol = REAL_FACES[label]
    face, report = _real_faired(real, name, pick, tol)
    samples = sample_face_deviation(face, report.face, density=20)
    faired, _ = face_to_surface(report.face)
    (u0, u1), (v0, v1) = faired.domain
    dense = faired.evaluate_grid(np.linspace(u0, u1, 600), np.linspace(v0, v1, 600))
    spacing = max(np.linalg.norm(np.diff(dense, axis=0), axis=-1).max(),
                  np.linalg.norm(np.diff(dense, axis=1), axis=-1).max())
    nearest, _ = cKDTree(dense.reshape(-1, 3)).query(samples["points"])
    assert np.all(samples["distance"] <= nearest + 1e-9 * tol)
    assert np.all(samples["distance"] >= nearest - spacing)


@pytest.mark.parametrize("label", list(REAL_FACES))
def test_the_check_measures_where_the_maximum_can_be_and_finds_every_samples_maximum(real,
                                                                                      label):
    """The check walks the samples down their parametric distance and stops where none
    left can reach the maximum.  Against measuring every sample both ways (the core's
    batched projection for all, OCCT's judge on all): the same maximum to the bit, every
    sample passed over below the share of it the judge looks at (on the IEA face, most
    samples); the field, completed when read, agrees at every sample; and the result
    pickles as a plain dict with its field."""
    import pickle

    from cq_fairing.core.closest_points import closest_points_surface_restarted
    from cq_fairing.core.evaluation import surface_derivatives
    from cq_fairing.occ import face_to_surface
    from cq_fairing.occ.deviation import (
        JUDGED_FRACTION,
        BatchedCheck,
        _judge,
        face_uv_grid,
        reference_samples,
    )

    name, pick, tol = REAL_FACES[label]
    face, report = _real_faired(real, name, pick, tol)
    surfaces = face_to_surface(face)[0], report.surface
    reference = reference_samples(face, face_uv_grid(face, 40), surface=surfaces[0])
    check = BatchedCheck(face, report.face, surfaces, reference)
    deviation = check.deviation()
    measured = check.walk.taken().size
    uv, points, _ = reference
    faired_points = surface_derivatives(surfaces[1], uv[:, 0], uv[:, 1], 0)[(0, 0)]
    every = []
    for target_face, target, source_face, start in (
            (report.face, surfaces[1], face, points),
            (face, surfaces[0], report.face, faired_points)):
        s, t, distance = closest_points_surface_restarted(target, start, uv[:, 0], uv[:, 1])
        projected = surface_derivatives(target, s, t, 0)[(0, 0)]
        _judge(target_face, source_face, uv, np.column_stack([s, t]), start, distance,
               projected, target.size)
        every.append(distance)
    assert deviation["max"] == max(d.max() for d in every)
    passed_over = check.parametric[check.walk.rest()]
    assert np.all(passed_over <= JUDGED_FRACTION * deviation["max"] * (1 + 1e-9))
    if label == "IEA main face":     # a projection keeps the parametrization: few to measure
        assert measured < 0.25 * uv.shape[0]
    for key, whole in zip(("distance", "distance_back"), every):
        np.testing.assert_allclose(deviation[key], whole, rtol=0, atol=1e-6 * tol)
    copied = pickle.loads(pickle.dumps(deviation))
    assert type(copied) is dict and set(copied) == set(deviation)
    np.testing.assert_array_equal(copied["distance"], deviation["distance"])


def test_surfaces_at_hand_measure_as_the_faces_read_again(real):
    """The core surfaces passed in (the source's, and the faired one as built into the
    face) give the samples and distances that reading both faces again gives, bit for
    bit."""
    from cq_fairing.occ import face_to_surface

    name, pick, tol = REAL_FACES["testtoler strip"]
    face, report = _real_faired(real, name, pick, tol)
    read = sample_face_deviation(face, report.face, density=20)
    given = sample_face_deviation(face, report.face, density=20,
                                  surfaces=(face_to_surface(face)[0], report.surface))
    for key in ("points", "faired_points", "normals", "distance", "distance_back", "signed"):
        np.testing.assert_array_equal(given[key], read[key])
    assert given["max"] == read["max"] > 0.0


def test_core_surfaces_that_are_not_the_faces_fall_back_to_occt(real):
    """Surfaces that are not the faces' own (shifted by 1e-3) are caught by OCCT's judge:
    every sample is then measured by OCCT alone (its points, Newton projections and
    refinement), and the maximum is the batched one's."""
    from dataclasses import replace

    from cq_fairing.occ import face_to_surface
    from cq_fairing.occ.deviation import (
        _by_occt,
        _points_and_normals,
        deviation_on_grid,
        face_uv_grid,
        reference_samples,
    )

    name, pick, tol = REAL_FACES["IEA main face"]
    face, report = _real_faired(real, name, pick, tol)
    grid = face_uv_grid(face, 25)
    right = deviation_on_grid(face, report.face, grid)
    original, _ = face_to_surface(face)
    shifted = replace(report.surface, poles=report.surface.poles + 1e-3)
    wrong = deviation_on_grid(face, report.face, grid, surfaces=(original, shifted))
    uv, _, _ = reference_samples(face, grid)
    occt_points, _ = _points_and_normals(face, uv)
    _, _, (by_occt, _), (back, _) = _by_occt(face, report.face, uv, occt_points, False)
    np.testing.assert_array_equal(wrong["points"], occt_points)
    np.testing.assert_array_equal(wrong["distance"], by_occt)
    np.testing.assert_array_equal(wrong["distance_back"], back)
    assert wrong["max"] == pytest.approx(right["max"], abs=1e-6 * tol)


def test_exceeds_decides_the_tolerance_and_the_check_goes_on_from_it(real):
    """A testtoler strip faired onto 8 x 4 poles (``n=(5, 1)``) leaves the face by far.
    At tolerances from a quarter of the full check's maximum up to above it, ``exceeds``
    says whether the full check's maximum (both ways, OCCT judging) is above the
    tolerance, just below it too; the full check that goes on from the samples
    ``exceeds`` measured finds the maximum of a fresh one.  A check seeded with the feet
    of another net's check (``seeds``: its Newton runs start there where nearer, its
    walk bounded by the distance at the start) finds the same maximum.  OCCT's own global
    projection, both ways, finds it too (on the way back: the faired face reaches beyond
    the original)."""
    from cq_fairing.occ import face_to_surface, fair_face
    from cq_fairing.occ.deviation import (
        BatchedCheck,
        deviation_on_grid,
        face_uv_grid,
        reference_samples,
    )
    from tests.occ.helpers import faces_of

    face = next(f for f in faces_of(real("testtoler.brep"))
                if face_to_surface(f)[0].shape[0] > 100)
    report = fair_face(face, n=(5, 1), details=False)
    surfaces = face_to_surface(face)[0], report.surface
    reference = reference_samples(face, face_uv_grid(face, 40, classify=False),
                                  surface=surfaces[0])
    full = deviation_on_grid(face, report.face, None, reference=reference, surfaces=surfaces)
    largest = full["max"]
    shares = (0.25, 0.5, 0.9, 0.99, 1.5)
    verdicts = {share: BatchedCheck(face, report.face, surfaces, reference).exceeds(share * largest)
                for share in shares}
    assert verdicts == {share: share < 1.0 for share in shares}
    for share in (0.5, 1.5):
        check = BatchedCheck(face, report.face, surfaces, reference)
        check.exceeds(share * largest)
        assert check.deviation()["max"] == pytest.approx(largest, rel=1e-12)
    other = fair_face(face, n=(7, 1), details=False)
    before = BatchedCheck(face, other.face, (surfaces[0], other.surface), reference)
    before.deviation()
    seeded = BatchedCheck(face, report.face, surfaces, reference, seeds=before.seeds())
    assert np.all(np.maximum(*(way.bound for way in seeded.ways)) <= seeded.parametric)
    assert seeded.deviation()["max"] == pytest.approx(largest, rel=1e-9)
    occt = np.r_[global_distance(full["points"], report.face),
                 global_distance(full["faired_points"], face)]
    assert occt[np.isfinite(occt)].max() == pytest.approx(largest, rel=1e-9)
