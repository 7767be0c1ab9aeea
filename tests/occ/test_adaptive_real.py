"""The adaptive surface search on real faces (OCCT reads the files; the fit is the core's)."""

import numpy as np

from cq_fairing.core.adaptive import fair_surface_adaptive
from cq_fairing.core.geometry import extent
from cq_fairing.core.polish import _constrained_stages, largest_penalty
from cq_fairing.core.surface_fit import _SurfaceFit
from cq_fairing.occ import face_to_surface
from cq_fairing.occ.convert import indexed_faces


def _longest_face(shape):
    surfaces = [face_to_surface(face)[0] for face in indexed_faces(shape)]
    return max(surfaces, key=lambda s: s.poles.shape[0] * s.poles.shape[1])


def test_a_diverging_reweighting_ends_its_stage_at_once(real):
    """On the testtoler strip (degree 5, 138 x 21 poles; tol 1e-4 of its size) the
    compact bicubic net with pinned borders is polished with lambda ~10; the first
    constrained stage's reweighting diverges (its largest deviation 6.7 tol, then 19.8 tol
    after the first reweighting).  The stage ends at that second round instead of
    spending all REWEIGHTS rounds, and nothing is kept."""
    source = _longest_face(real("testtoler.brep"))
    tol = 1e-4 * extent(source.poles)
    result = fair_surface_adaptive(source, tol)
    assert dict(result.table)["borders"] == "pinned"
    spaces = (result.surface.u_space, result.surface.v_space)
    fit = _SurfaceFit(source, 0.99 * tol, (3, 3), 8, 400_000, "pinned")
    (faired, _, _), lam = largest_penalty(lambda x: fit.trial(*spaces, x), fit.tol,
                                          fit.trial(*spaces), steps=8)
    assert lam > 1.0
    before = fit.evaluations
    assert _constrained_stages(fit, spaces, faired, lam) == []
    assert fit.evaluations - before == 2
    assert np.isfinite(result.max_deviation) and result.max_deviation <= tol
