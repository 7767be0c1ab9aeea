"""The stored command-line nets the FreeCAD tests compare the workbench with
(``tests/data/face_references.npz``) are what ``cq_fairing.occ.fair_face`` gives now.

If this fails after a change of the face search, regenerate the file
(``python -m tests.freecad.face_references``) and run the FreeCAD suite: the workbench
must follow (``tests/freecad/app/test_same_as_cli.py``).
"""

import numpy as np
import pytest

from tests.freecad import face_references

STORED = face_references.load()
NOW = face_references.computed()


def test_the_same_cases():
    """Every setting is stored, and the cases cover a faired face, a face kept for
    nothing to fair, one kept for its tolerance and a rational face energy skips."""
    assert sorted(STORED) == sorted(NOW)
    assert {case.split("/")[0] for case in STORED} == set(face_references.SETTINGS)
    assert {STORED[case]["status"] for case in STORED} == {
        "faired", "unchanged", "tolerance-not-met", "skipped-rational"}


@pytest.mark.parametrize("case", sorted(STORED))
def test_stored_net_is_fair_faces(case):
    stored, now = STORED[case], NOW[case]
    size = float(np.ptp(now["source"].reshape(-1, 3), axis=0).max())
    assert stored["status"] == now["status"]
    assert stored["message"] == now["message"]
    assert np.array_equal(stored["source"], now["source"])
    assert stored["poles"].shape == now["poles"].shape
    # the adaptive method's knots come out of an iterative placement: numpy/scipy builds
    # place them up to ~1e-11 apart (the FreeCAD comparison allows 1e-9 for the same reason)
    for axis in ("u_knots", "v_knots"):
        assert np.abs(stored[axis] - now[axis]).max() <= 1e-9 * np.ptp(stored[axis])
    assert np.abs(stored["poles"] - now["poles"]).max() <= 1e-9 * size
    assert float(stored["max_deviation"]) == pytest.approx(float(now["max_deviation"]),
                                                           rel=1e-6)
