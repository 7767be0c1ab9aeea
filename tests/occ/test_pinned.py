"""fair_shape fairs a face whose joins run across its surface with every join pinned to its
source (cq_fairing.occ.pinned), or keeps it and says why: real models, the joins measured
by their own projection (cq_fairing.occ.adjacency) and the faces by OCCT."""

import re

import pytest

from cq_fairing.core.joins import ANGLE_SLACK
from cq_fairing.core.pinned_faces import FOLD
from cq_fairing.core.pinned_projection import GAP
from cq_fairing.occ.shapes import fair_shape

TRIMMED = (242, 264, 274)    # impeller faces (0-based) with a join across their surface
# their pinned nets (u, v); tests/freecad/app/test_pinned.py holds the workbench to them
PINNED_POLES = {242: (5, 4), 264: (5, 4), 274: (4, 3)}


@pytest.fixture(scope="module")
def impeller_runs(real):
    shape = real("impeller.igs")
    return {joins: fair_shape(shape, tol=0.2, faces=TRIMMED, joins=joins)
            for joins in ("smooth", "free")}


def test_trimmed_faces_are_faired_with_their_joins_pinned(impeller_runs):
    """Each face is faired within its tolerance (OCCT's two-sided check); every join of
    theirs is held, opens at most 1e-7 of the model's size beyond the source's gap, and
    a smooth one turns at most ANGLE_SLACK beyond the source's angle, sample for
    sample; faired alone, the same faces open their joins far wider."""
    result = impeller_runs["smooth"]
    size = result.joins.adjacency.size
    assert result.valid
    for index in TRIMMED:
        report = result.faces[index]
        assert report.faired and "pinned to its source" in report.message
        assert report.max_deviation <= 0.2
        assert tuple(report.poles_after) == PINNED_POLES[index]
        assert report.poles_after[0] * report.poles_after[1] < \
            report.poles_before[0] * report.poles_before[1]
    rows = [r for r in result.joins.rows() if {f - 1 for f in r["faces"]} & set(TRIMMED)]
    assert rows and all(r["held"] for r in rows)
    assert all(r["gap"] <= r["source_gap"] + GAP * size for r in rows)
    assert all(r["angle_excess"] <= ANGLE_SLACK for r in rows if r["kind"] == "smooth")
    alone = [r for r in impeller_runs["free"].joins.rows()
             if {f - 1 for f in r["faces"]} & set(TRIMMED)]
    assert max(r["gap"] - r["source_gap"] for r in alone) > 1e3 * GAP * size


def test_faces_the_pins_cannot_hold_are_kept_with_the_figures(real):
    """linkrods' trimmed faces run their joins along their sources' finest spans: pinned
    there to 1e-7 of the model's size, no target smaller than the source's net holds them
    (each stays 1e-5 or more off after two span halvings, or needs the source's net).
    They are kept as they were, their reports name their joins and say how far the pins
    missed, and no join opens.  Their rational targets fold where the pins ask more than
    they can give (weights through zero): the report says so, never "turn 180 deg"."""
    result = fair_shape(real("linkrods.step"), tol=0.01)
    kept = [r for r in result.faces if r.status == "unchanged" and "run across" in r.message]
    assert len(kept) >= 18 and result.valid
    assert all("its joins with faces [" in r.message for r in kept)
    assert sum("would still open" in r.message for r in kept) >= 14
    turns = [float(t) for r in kept for t in re.findall(r"turn ([-+.e0-9]+) deg", r.message)]
    assert all(t <= FOLD for t in turns)
    assert any("fold (its normal turns by up to" in r.message for r in kept)
    assert result.joins.summary()["max_gap_opened"] <= 1e-9
