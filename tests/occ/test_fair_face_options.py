"""fair_face / fair_shape options: the canonical spellings, the old ones, and the refusal
of an option the chosen method does not use."""

import inspect
import warnings

import numpy as np
import pytest

from cq_fairing.core import options
from cq_fairing.errors import InvalidInputError
from cq_fairing.occ import fair_face, fair_shape
from tests.reliability.test_occ_inputs import bspline_surface, face_of

TOL = 0.01


@pytest.fixture(scope="module")
def face():
    """A 16 x 14 bicubic face with a little noise: every method fairs it."""
    return face_of(bspline_surface(16, 14, wiggle=0.01, seed=0))


def test_the_old_search_value_core_warns_and_gives_the_guaranteed_search(face):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        new = fair_face(face, tol=TOL, search="guaranteed", details=False)
    with pytest.warns(DeprecationWarning) as caught:
        old = fair_face(face, tol=TOL, search="core", details=False)
    warning, = caught
    assert "search='core' is deprecated, use search='guaranteed'" in str(warning.message)
    assert warning.filename == __file__
    assert old.status == new.status == "faired"
    np.testing.assert_array_equal(old.surface.poles, new.surface.poles)
    assert old.max_deviation == new.max_deviation


def test_a_core_step_rule_runs_the_cores_search_with_it(face):
    """``search="linear"`` reaches the core's search (its table differs from the
    guaranteed one) and the face is within tol by OCCT's measure."""
    linear = fair_face(face, tol=TOL, search="linear")
    guaranteed = fair_face(face, tol=TOL, search="guaranteed")
    assert linear.status == guaranteed.status == "faired"
    assert linear.max_deviation <= TOL and guaranteed.max_deviation <= TOL
    assert [r.n for r in linear.result.table] != [r.n for r in guaranteed.result.table]


@pytest.mark.parametrize("method, option, value, why", [
    ("adaptive", "search", "guaranteed", "chooses its knots itself"),
    ("energy", "search", "local", None),            # the default: no request
    ("energy", "search", "linear", "keeps the control points"),
    ("energy", "target_degree", 2, "keeps the control points, the degree"),
    ("energy", "boundary", "fixed", "the border ring"),
    ("energy", "borders", "pinned", "keeps the control points"),
    ("adaptive", "grading", "uniform", "chooses its knots itself"),
    ("energy", "grading", "uniform", "keeps the control points"),
])
def test_fair_face_refuses_an_option_its_method_does_not_use(face, method, option, value, why):
    if why is None:
        report = fair_face(face, tol=TOL, method=method, **{option: value})
        assert report.status == "faired"
        return
    with pytest.raises(InvalidInputError) as info:
        fair_face(face, tol=TOL, method=method, **{option: value})
    message = str(info.value)
    assert message.startswith(f"{option}={value!r} applies to method=")
    assert f"got method={method!r}, which" in message and why in message
    assert message.endswith(f"or drop {option}.")


def test_grading_is_refused_with_an_explicit_scale_and_outside_its_values(face):
    with pytest.raises(InvalidInputError, match="grading applies to the tolerance search"):
        fair_face(face, n=(5, 5), grading="uniform")
    with pytest.raises(InvalidInputError, match=r"grading must be one of \('auto', 'spans', 'uniform'\)"):
        fair_face(face, tol=TOL, grading="graded")
    with pytest.raises(InvalidInputError, match="grading must be one of"):
        fair_shape(face, tol=TOL, grading="source")


def test_fair_shape_refuses_what_fair_face_refuses_before_any_work(face):
    with pytest.raises(InvalidInputError, match="target_degree=3 applies to method="):
        fair_shape(face, tol=TOL, method="energy", target_degree=3)
    with pytest.raises(InvalidInputError, match="boundary='fixed' applies to method="):
        fair_shape(face, tol=TOL, method="energy", boundary="fixed")


def test_fair_shape_refuses_max_gap_with_an_explicit_scale(face):
    """No face is faired again with explicit n, so max_gap would do nothing."""
    with pytest.raises(InvalidInputError) as info:
        fair_shape(face, n=(8, 8), max_gap=0.01)
    message = str(info.value)
    assert message.startswith("max_gap applies to faces faired with a tolerance")
    assert "max_gap=0.01 with n=(8, 8)" in message and message.endswith("instead of n.")
    assert fair_shape(face, n=(8, 8)).faces[0].poles_after == (11, 11)


def test_fair_shape_refuses_worker_options_with_an_engine(face):
    """An engine replaces the worker processes that jobs and face_timeout configure."""
    class Unreached:
        """An engine the refusal comes before: calling it fails the test."""

        def run(self, tasks, done):
            raise AssertionError("the options were not checked before the faces ran")

        def close(self):
            raise AssertionError("fair_shape closes no engine of the caller's")

    for workers in (dict(jobs=2), dict(face_timeout=30.0)):
        with pytest.raises(InvalidInputError, match="configure the worker processes that "
                                                    "engine replaces"):
            fair_shape(face, tol=TOL, engine=Unreached(), **workers)


def test_the_occ_signatures_take_their_defaults_from_the_options_module():
    from cq_fairing import cadquery_plugin

    for function in (fair_face, fair_shape):
        parameters = inspect.signature(function).parameters
        for name in ("method", "objective", "borders", "boundary", "target_degree"):
            assert parameters[name].default == options.DEFAULTS[name], (function, name)
    for function in (cadquery_plugin.fair_face, cadquery_plugin.fair_shape,
                     cadquery_plugin.fair):
        parameters = inspect.signature(function).parameters
        for name in ("method", "objective"):
            assert parameters[name].default == options.DEFAULTS[name], (function, name)
    assert inspect.signature(fair_face).parameters["search"].default == "local"
    for function in (fair_face, fair_shape):
        assert inspect.signature(function).parameters["grading"].default == \
            options.GRADINGS[0] == "auto"
    assert options.FACE_SEARCHES[0] == "local"
