"""The face search every backend runs (:mod:`cq_fairing.core.face_search`), with a check
built here from the core's closest points (a backend's two-sided distance on the face's
samples): the winner is within the tolerance by an independent dense measure, the
attempts run in their order and a failing check moves on to the next, a pre-filtered
candidate is measured only when all fail, the coarsest and identity cases are kept, and
the finisher keeps closed and collapsed borders."""

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.core.closest_points import closest_points_surface_restarted
from cq_fairing.core.face_search import (
    ERROR_GRADED_NOTE,
    ERROR_GRADED_SHARE,
    GRADING_NOTES,
    MARGIN,
    PINNED_NOTE,
    POLISH_NOTE,
    CoreSearch,
    face_attempts,
    face_finisher,
    sample_counts,
    search_face,
)
from cq_fairing.core.fairness import fairness_summary
from cq_fairing.core.plans import end_graded_space
from cq_fairing.core.target_projections import TargetProjections

TOL = 0.05


def _noisy(n_u=30, n_v=40, seed=3):
    """A bicubic 30 x 40 net with seeded noise of 0.02 over a smooth bump (mm)."""
    u, v = np.meshgrid(np.linspace(0, 1, n_u), np.linspace(0, 1, n_v), indexing="ij")
    z = 20.0 * np.sin(np.pi * u) * (1.0 - 0.5 * v) + 5.0 * np.cos(2 * np.pi * v) * u
    z += 0.02 * np.random.default_rng(seed).standard_normal(u.shape)
    return cf.make_surface(np.stack([100.0 * u, 300.0 * v, z], axis=-1), degree=(3, 3))


def _grid(surface, counts=None):
    (u0, u1), (v0, v1) = surface.domain
    nu, nv = counts or sample_counts(surface)
    u, v = np.linspace(u0, u1, nu), np.linspace(v0, v1, nv)
    return u, v, np.ones((nu, nv), dtype=bool)


class TwoSided:
    """Two-sided distance on the grid's samples, each way by the core's restarted Newton
    projection, with a log of the candidates it measured."""

    def __init__(self, source, grid):
        u, v, _ = grid
        uu, vv = np.meshgrid(u, v, indexing="ij")
        self.source, self.u, self.v = source, uu.ravel(), vv.ravel()
        self.points = source.evaluate_grid(u, v).reshape(-1, 3)
        self.grid, self.log = grid, []

    def __call__(self, faired):
        there = closest_points_surface_restarted(faired, self.points, self.u, self.v)[2]
        back_points = faired.evaluate_grid(*self.grid[:2]).reshape(-1, 3)
        back = closest_points_surface_restarted(self.source, back_points, self.u, self.v)[2]
        self.log.append((faired.shape, float(max(there.max(), back.max()))))
        return self.log[-1][1]


def _dense_two_sided(source, faired, count=97):
    """Independent check: the same two-sided distance on a finer grid than the search's."""
    return TwoSided(source, _grid(source, (count, count)))(faired)


def test_the_winner_is_within_tol_by_a_denser_measure_and_has_fewer_poles():
    source = _noisy()
    grid = _grid(source)
    check = TwoSided(source, grid)
    outcome = search_face(source, TOL, grid, face_finisher(source), check, borders="free",
                          grading="uniform", objective="compact")
    assert outcome.status == "faired" and outcome.notes == ()
    assert outcome.deviation == check.log[-1][1] <= TOL
    assert outcome.surface.shape[0] * outcome.surface.shape[1] < 30 * 40
    assert _dense_two_sided(source, outcome.surface) <= TOL * 1.02
    assert outcome.result is not None
    assert outcome.result.surface is outcome.surface


@pytest.mark.parametrize("borders", ["free", "pinned"])
def test_the_winner_is_polished_at_the_same_poles_fairer_and_within_tol(borders):
    """By default the winner is polished: the penalised projection onto the same target
    spaces, with the same borders (pinned ones keep the source's corners), within tol
    by a denser measure, with less thin-plate
    bending energy than the plain projection (``objective="compact"``) by the core's
    quadrature (:func:`~cq_fairing.core.fairness.fairness_summary`); the note gives the
    penalty, and the projection with that penalty is the net."""
    source = _noisy()
    grid = _grid(source)
    plain = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                        borders=borders, grading="uniform", objective="compact")
    check = TwoSided(source, grid)
    polished = search_face(source, TOL, grid, face_finisher(source), check,
                           borders=borders, grading="uniform")
    note = polished.notes[-1]
    assert note.startswith(POLISH_NOTE) and not any(POLISH_NOTE in n for n in plain.notes)
    for a, b in ((polished.surface.u_space, plain.surface.u_space),
                 (polished.surface.v_space, plain.surface.v_space)):
        assert a.same_as(b)
    assert polished.deviation == check.log[-1][1] <= TOL
    assert _dense_two_sided(source, polished.surface) <= TOL * 1.02
    bending = [fairness_summary(source, s)["bending_energy"]["after"]
               for s in (polished.surface, plain.surface)]
    assert bending[0] < bending[1]
    lam = float(note.split()[-1])
    again = TargetProjections(source, borders).projected(polished.surface.u_space,
                                                         polished.surface.v_space, lam)
    scale = np.abs(source.poles).max()
    assert np.abs(again.poles - polished.surface.poles).max() < 1e-3 * scale
    if borders == "pinned":
        for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
            assert np.array_equal(polished.surface.poles[i, j], source.poles[i, j])


def test_a_failing_check_moves_on_to_the_next_attempt():
    """A check that refuses everything sees the attempts in order (local bisection, core
    search, parametric bisection at MARGIN * tol, then at tol; one candidate each with
    quasi-uniform, free-border targets only) and the error names the judge and the best value it measured."""
    source = _noisy()
    grid = _grid(source)
    measured = TwoSided(source, grid)

    def strict(faired):
        return measured(faired) + 1.0   # never within TOL

    with pytest.raises(cf.ToleranceNotMetError, match="by the judge's measure") as error:
        search_face(source, TOL, grid, face_finisher(source), strict, judge="the judge",
                    borders="free", grading="uniform")
    assert len(measured.log) == 4
    assert error.value.best_deviation == pytest.approx(min(d for _, d in measured.log) + 1.0)


def test_error_graded_targets_where_uniform_ones_keep_many_poles():
    """With free borders the uniform targets of the noisy net keep more than a quarter
    of its poles.  By default the search then tries the adaptive method's targets,
    whose knots follow the error: they win with fewer poles (the note says so), their
    net is the core's adaptive fit at tol, and a denser measure keeps it within tol.
    With ``grading="uniform"`` the search keeps to quasi-uniform targets."""
    source = _noisy()
    grid = _grid(source)
    uniform = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                          borders="free", grading="uniform", objective="compact")
    poles = uniform.surface.shape[0] * uniform.surface.shape[1]
    assert poles > ERROR_GRADED_SHARE * 30 * 40 and uniform.notes == ()
    check = TwoSided(source, grid)
    outcome = search_face(source, TOL, grid, face_finisher(source), check, borders="free")
    assert outcome.notes == (ERROR_GRADED_NOTE,)
    assert outcome.surface.shape[0] * outcome.surface.shape[1] < poles
    assert outcome.deviation == check.log[-1][1] <= TOL
    adaptive = cf.fair_surface(source.poles, tol=TOL, u_knots=source.u_knots,
                               v_knots=source.v_knots, degree=(3, 3), method="adaptive",
                               borders="free")
    np.testing.assert_array_equal(outcome.surface.poles, adaptive.surface.poles)
    assert not all(s.is_quasi_uniform for s in (outcome.surface.u_space,
                                                outcome.surface.v_space))
    assert _dense_two_sided(source, outcome.surface) <= TOL * 1.02


def test_a_prefiltered_candidate_is_measured_only_when_every_attempt_fails():
    source = _noisy()
    grid = _grid(source)
    check = TwoSided(source, grid)
    seen = []

    def first_fails(faired, tol):
        seen.append(faired.shape)
        return len(seen) == 1

    outcome = search_face(source, TOL, grid, face_finisher(source), check,
                          exceeds=first_fails, borders="free")
    assert outcome.status == "faired" and len(seen) == 2 and len(check.log) == 1
    check.log.clear()
    with pytest.raises(cf.ToleranceNotMetError, match="by the backend's measure"):
        search_face(source, TOL, grid, face_finisher(source), check,
                    exceeds=lambda faired, tol: True, borders="free")
    assert len(check.log) == 4   # measured after all failed, for the best deviation


def _held_end_projection(space, source_space, coefficients):
    """Independent dense computation of a border row with its ends kept: least squares
    of the target curve against the source curve on a fine Gauss grid."""
    x, w = np.polynomial.legendre.leggauss(12)
    breaks = np.union1d(space.breakpoints, source_space.breakpoints)
    t = np.concatenate([0.5 * (b - a) * x + 0.5 * (a + b) for a, b in zip(breaks, breaks[1:])])
    weights = np.concatenate([0.5 * (b - a) * w for a, b in zip(breaks, breaks[1:])])
    target = space.collocation(t).toarray()
    values = source_space.collocation(t).toarray() @ coefficients
    root = np.sqrt(weights)[:, None]
    rest = values - target[:, [0, -1]] @ coefficients[[0, -1]]
    inner = np.linalg.lstsq(root * target[:, 1:-1], root * rest, rcond=None)[0]
    return np.vstack([coefficients[:1], inner, coefficients[-1:]])


def test_pinned_borders_win_where_the_free_projection_moves_the_corners():
    """The noisy net's poles are evenly spaced on clamped uniform knots, so its
    parametric speed changes within the end spans and the plain projection moves the
    corners along the surface: borders pinned to the source's border curves meet the
    tolerance with fewer poles.  The winner (not polished) is within tol by a denser
    measure, keeps the source's corners exactly, and its border rows are the
    projections of the source's border curves with their ends kept, computed here by
    dense least squares."""
    source = _noisy()
    grid = _grid(source)
    free = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                       borders="free", objective="compact")
    outcome = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                          objective="compact")
    assert PINNED_NOTE in outcome.notes
    poles = outcome.surface.poles
    assert poles.shape[0] * poles.shape[1] < free.surface.poles.shape[0] * \
        free.surface.poles.shape[1]
    assert _dense_two_sided(source, outcome.surface) <= TOL * 1.02
    for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
        assert np.array_equal(poles[i, j], source.poles[i, j])
    scale = np.abs(source.poles).max()
    su, sv, tu, tv = (source.u_space, source.v_space, outcome.surface.u_space,
                      outcome.surface.v_space)
    for j in (0, -1):
        assert np.allclose(poles[:, j], _held_end_projection(tu, su, source.poles[:, j]),
                           rtol=0, atol=1e-9 * scale)
    for i in (0, -1):
        assert np.allclose(poles[i], _held_end_projection(tv, sv, source.poles[i]),
                           rtol=0, atol=1e-9 * scale)
    pinned = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                         borders="pinned", objective="compact")
    assert pinned.surface.shape == outcome.surface.shape


def test_pinned_borders_have_targets_refined_towards_them():
    """A pinned projection's error gathers next to the borders: on the noisy net, targets
    refined towards them (:func:`~cq_fairing.core.plans.end_graded_space`) keep fewer
    poles than quasi-uniform ones with the same pinned borders, within tol by a denser
    measure, and the note says so; ``grading="uniform"`` keeps to quasi-uniform ones."""
    source = _noisy()
    grid = _grid(source)
    uniform = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                          borders="pinned", grading="uniform", objective="compact")
    graded = search_face(source, TOL, grid, face_finisher(source), TwoSided(source, grid),
                         borders="pinned", grading="auto", objective="compact")
    assert uniform.notes == (PINNED_NOTE,)
    assert uniform.surface.u_space.is_quasi_uniform and uniform.surface.v_space.is_quasi_uniform
    assert graded.notes == (GRADING_NOTES["ends"], PINNED_NOTE)
    n_u, n_v = (space.n_spans for space in (graded.surface.u_space, graded.surface.v_space))
    assert graded.surface.u_space.same_as(end_graded_space(n_u, 3, source.u_space.domain))
    assert graded.surface.v_space.same_as(end_graded_space(n_v, 3, source.v_space.domain))
    assert np.prod(graded.surface.shape) < np.prod(uniform.surface.shape)
    assert _dense_two_sided(source, graded.surface) <= TOL * 1.02


def test_the_candidates_of_one_attempt_are_checked_fewest_poles_first():
    """Each target family's bisection gives a candidate; a candidate the check refuses
    hands over to the attempt's next one, in increasing pole count, before the next
    attempt runs."""
    source = _noisy()
    grid = _grid(source)
    check = TwoSided(source, grid)
    seen = []

    def record(faired, tol):
        seen.append(faired.shape[0] * faired.shape[1])
        return len(seen) == 1   # the first candidate is refused

    outcome = search_face(source, TOL, grid, face_finisher(source), check, exceeds=record)
    assert len(seen) >= 2 and seen[0] <= seen[1]   # the first attempt's pinned and free
    assert check.log[0][0][0] * check.log[0][0][1] == seen[1]   # checked after the refusal
    assert outcome.deviation == check.log[-1][1] <= TOL


def test_explicit_scales_take_pinned_borders_on_request():
    """With ``n`` the default is the plain projection; ``borders="pinned"`` pins it."""
    source = _noisy()
    grid = _grid(source)
    plain = search_face(source, None, grid, face_finisher(source), TwoSided(source, grid),
                        n=(6, 8))
    pinned = search_face(source, None, grid, face_finisher(source), TwoSided(source, grid),
                         n=(6, 8), borders="pinned")
    assert plain.notes == () and pinned.notes == (PINNED_NOTE,)
    assert plain.surface.shape == pinned.surface.shape == (9, 11)
    assert not np.array_equal(plain.surface.poles[0, 0], source.poles[0, 0])
    assert np.array_equal(pinned.surface.poles[0, 0], source.poles[0, 0])
    assert pinned.deviation < plain.deviation


def test_attempts_of_each_search():
    assert face_attempts(None) == [(None, None)]
    local = face_attempts(TOL)
    assert [c for c, _ in local] == ["normal", CoreSearch("guaranteed"), "parametric",
                                     "parametric"]
    assert [g for _, g in local] == [MARGIN * TOL] * 3 + [TOL]
    linear = face_attempts(TOL, "linear", measure="parametric")
    assert linear[0] == (CoreSearch("linear", "parametric"), MARGIN * TOL)
    assert face_attempts(TOL, "local", measure="parametric") == local


def test_the_coarsest_net_and_the_source_space_are_kept():
    """A 4 x 4 bicubic net: its only cubic target is its own space (kept, as the identity);
    asked for degree 4 it has no admissible target at all (kept, at its coarsest)."""
    bump = cf.make_surface(_noisy().poles[::9, ::13][:4, :4], degree=(3, 3))
    grid = _grid(bump)
    check = TwoSided(bump, grid)
    outcome = search_face(bump, TOL, grid, face_finisher(bump), check)
    assert outcome.status == "unchanged" and "source space itself" in outcome.message
    assert outcome.surface is bump and outcome.deviation == 0.0 and check.log == []
    outcome = search_face(bump, TOL, grid, face_finisher(bump), check, target_degree=4)
    assert outcome.status == "unchanged" and "at its coarsest" in outcome.message


def test_the_finisher_ties_a_closed_seam_and_keeps_a_collapsed_border():
    angle = np.linspace(0, 2 * np.pi, 12)[:, None]
    height = np.linspace(0, 1, 8)[None, :]
    radius = np.sin(np.pi * height / 2)          # row 0 collapses onto the axis
    poles = np.stack(np.broadcast_arrays(radius * np.cos(angle), radius * np.sin(angle),
                                         height), axis=-1)
    source = cf.make_surface(poles, degree=(3, 3))
    moved = cf.make_surface(poles + 0.01 * np.random.default_rng(1).normal(size=poles.shape),
                            degree=(3, 3))
    finished = face_finisher(source)(moved)
    assert np.array_equal(finished.poles[0], finished.poles[-1])
    assert np.abs(finished.poles[:, 0] - poles[0, 0]).max() == 0.0
    untouched = face_finisher(_noisy())(moved)
    assert not np.array_equal(untouched.poles[0], untouched.poles[-1])
