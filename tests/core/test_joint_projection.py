"""project_jointly on the synthetic 2 x 2 grid, with a naive deviation as the backend's
check: border joins are held pole for pole, a side that cannot be joined is pinned to
its source, and a face that cannot meet its tolerance is kept."""

import numpy as np

from cq_fairing.core.examples import patch_grid
from cq_fairing.core.joint_projection import (
    Join,
    JoinSide,
    border_joins,
    project_jointly,
    unholdable,
)
from cq_fairing.core.spaces import SplineSpace

from .test_joins import _joins_measured

G = np.linspace(0.0, 1.0, 41)
TARGET = SplineSpace.quasi_uniform(4, 3)


def _model(full=True):
    """The grid's patches and its joins as a backend reads them (side 0 of the last one
    covering only part of its side unless ``full``)."""
    grid = patch_grid()
    joins = []
    for k, j in enumerate(grid.joins):
        along_b = (1.0, 0.0) if j.reversed else (0.0, 1.0)
        sides = (JoinSide(j.a, k, j.side_a, (0.0, 1.0), full or k < 3),
                 JoinSide(j.b, k, j.side_b, along_b, True))
        joins.append(Join(sides, "smooth", 1e-7, 0.0))
    return grid, joins


def _check(sources):
    def check(face, surface):
        return float(np.linalg.norm(surface.evaluate_grid(G, G)
                                    - sources[face].evaluate_grid(G, G), axis=2).max())
    return check


def _project(joins, sources, tol=0.05):
    tolerances = dict.fromkeys(sources, tol)
    targets = dict.fromkeys(sources, (TARGET, TARGET))
    border = border_joins(joins, sources, tolerances)
    return border, project_jointly(sources, targets, joins, border, tolerances,
                                   _check(sources))


def test_border_joins_are_held_pole_for_pole():
    grid, joins = _model()
    sources = dict(enumerate(grid.patches))
    border, joint = _project(joins, sources)
    assert border == joins and joint.held == joins and joint.kept == {}
    surfaces = [joint.surfaces[i] for i in range(4)]
    gap, angle = _joins_measured(surfaces, grid.joins)
    assert gap <= 1e-9 * 2.0 and angle < 0.1
    assert all(s.shape == (7, 7) for s in surfaces)


def test_a_partial_side_is_pinned_to_its_source():
    """Patches 0 and 2 alone, their join read as covering only part of patch 0's side:
    not a border join.  Both sides keep their sources' borders and tangent planes, so
    the join stays as closed and smooth as the source, while the rest is faired."""
    grid, joins = _model()
    sources = {0: grid.patches[0], 2: grid.patches[2]}
    a, b = joins[1].sides
    partial = [Join((JoinSide(a.face, a.edge, a.side, a.along, False), b), "smooth", 1e-7, 0.0)]
    border, joint = _project(partial, sources)
    assert border == [] and joint.held == [] and joint.kept == {}
    assert joint.pinned == {partial[0]: {(0, "v1"), (2, "v0")}}
    surfaces = [joint.surfaces.get(i) for i in range(3)]
    gap, angle = _joins_measured(surfaces, grid.joins[1:2])
    source_gap, source_angle = _joins_measured(grid.patches, grid.joins[1:2])
    assert gap <= source_gap + 1e-9 and angle <= source_angle + 1e-5
    assert surfaces[0].shape == surfaces[2].shape == (12, 7)   # faired across the join


def test_a_face_over_its_tolerance_is_kept_and_its_neighbours_close_onto_it():
    grid, joins = _model()
    sources = dict(enumerate(grid.patches))
    tolerances = {0: 1e-6, 1: 0.05, 2: 0.05, 3: 0.05}
    targets = dict.fromkeys(sources, (TARGET, TARGET))
    border = border_joins(joins, sources, tolerances)
    joint = project_jointly(sources, targets, joins, border, tolerances, _check(sources))
    assert list(joint.kept) == [0] and joint.kept[0] > 1e-6
    surfaces = [joint.surfaces.get(i, sources[i]) for i in range(4)]
    assert _joins_measured(surfaces, grid.joins)[0] <= 1e-9 * 2.0


def test_a_join_across_a_face_makes_it_unholdable_unless_both_faces_share_a_surface():
    """An edge off the borders (side None) cannot be held by a border or a pin; a face
    not read as a patch (absent from the sources) neither; two faces cut from one
    surface are held by fairing it once."""
    grid, joins = _model()
    sources = dict(enumerate(grid.patches))
    a, b = joins[1].sides
    across = Join((JoinSide(a.face, a.edge), b), "smooth", 1e-7, 0.0)
    every = {0, 1, 2, 3}
    assert unholdable([across] + joins[2:], sources, every, every) == {0: [2]}
    assert unholdable(joins, {i: sources[i] for i in (0, 1, 2)}, every, every) == {3: [1, 2]}
    assert unholdable([across], sources, {2, 3}, every) == {}
    twins = {0: sources[0], 2: sources[0]}
    assert unholdable([across], twins, {0, 2}, every) == {}
    assert unholdable([across], twins, {0}, {0}) == {0: [2]}     # its twin not selected
