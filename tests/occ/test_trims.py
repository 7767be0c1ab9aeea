"""A face's trim region: OCCT's own answers, and the adaptive method measured on the face.

``classify`` asks OCCT's ``BRepTopAdaptor_FClass2d`` sample by sample; ``face_region``
must give exactly its answers on real trimmed faces (IGES, STEP and BREP files from
other systems; testtoler's and the ring's faces are untrimmed), including linkrods face 31, whose curved p-curve OCCT's own
quasi-uniform deflection sampler returned as a single chord.
"""

import numpy as np
import pytest
from OCP.BRepTools import BRepTools

from cq_fairing.core.adaptive import fair_surface_adaptive
from cq_fairing.occ import default_tolerance, face_to_surface, fair_face, list_faces
from cq_fairing.occ.convert import indexed_faces
from cq_fairing.occ.deviation import sample_face_deviation
from cq_fairing.occ.trims import SMALL_GRID, classify, face_region, trim_region


def _trimmed(shape, limit=None):
    faces = [(info, face) for info, face in zip(list_faces(shape), indexed_faces(shape))
             if info.trimmed]
    return faces[:limit]


@pytest.mark.parametrize("name, limit", [("linkrods.step", None), ("impeller.igs", 12),
                                         ("IEA_15MW_CFD.stp", None)])
def test_face_region_gives_occts_answers_on_real_trimmed_faces(real, name, limit):
    trimmed = _trimmed(real(name), limit)
    assert trimmed
    for info, face in trimmed:
        u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
        region = trim_region(face)
        for count in ((57, 43), (31, 70)):
            u, v = np.linspace(u0, u1, count[0]), np.linspace(v0, v1, count[1])
            assert np.array_equal(region(u, v), classify(face, u, v)), info.index


def test_face_region_uses_the_polygon_on_large_grids_only(real):
    """Below SMALL_GRID samples OCCT answers each; above, the trim region does, with
    OCCT's answers."""
    _, face = _trimmed(real("impeller.igs"))[0]
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    on_face = face_region(face)
    small = np.linspace(u0, u1, 40), np.linspace(v0, v1, 30)
    large = np.linspace(u0, u1, 90), np.linspace(v0, v1, 80)
    assert small[0].size * small[1].size < SMALL_GRID <= large[0].size * large[1].size
    assert np.array_equal(on_face(*small), classify(face, *small))
    assert np.array_equal(on_face(*large), classify(face, *large))


def test_a_grid_that_repeats_a_parameter_is_classified_by_occt(real):
    _, face = _trimmed(real("linkrods.step"))[0]
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    u = np.r_[u0, np.linspace(u0, u1, 20)]
    v = np.linspace(v0, v1, 15)
    assert np.array_equal(face_region(face)(u, v), classify(face, u, v))
    assert trim_region(face) is not None


def _blade_trimmed_to_its_half(real):
    """An impeller blade (17 x 13 bicubic, polynomial) whose trim covers 57 % of its surface."""
    shape = real("impeller.igs")
    for info, face in _trimmed(shape):
        if (info.n_poles_u, info.n_poles_v) == (17, 13) and not info.rational:
            return face, 0.1 * default_tolerance(shape)
    raise LookupError("no trimmed 17 x 13 blade in impeller.igs")


def test_adaptive_fairs_a_trimmed_face_on_its_trim_only(real):
    """Measured on the trim, the adaptive net is smaller than the one that fits the whole
    surface, and OCCT's closest-point deviation on the face stays within tol."""
    face, tol = _blade_trimmed_to_its_half(real)
    report = fair_face(face, tol=tol, method="adaptive")
    assert report.status == "faired"
    whole = fair_surface_adaptive(face_to_surface(face)[0], tol)
    assert np.prod(report.poles_after) < np.prod(whole.surface.shape)
    samples = sample_face_deviation(face, report.face, density=60)
    assert samples["max"] <= tol
