"""One vocabulary: the options of fair_curve / fair_surface, their old spellings, and the
refusal of an option the chosen method does not use."""

import inspect
import warnings

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.core import options
from tests.core.test_accuracy import noisy_poles


def _net():
    """A 12 x 10 bicubic net with a ripple (the tolerance search has work to do)."""
    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1, 10), indexing="ij")
    ripple = 0.01 * np.sin(17 * u) * np.cos(13 * v)
    return np.stack([u, v, 0.2 * u * v + ripple], axis=-1)


CURVE = noisy_poles(40, 0.01, 3)


def _fair(kind, **options):
    """Fair the curve or the net within 0.02; ``method`` default ``"wavelet"``, the method
    of the tolerance-search options."""
    call = cf.fair_curve if kind == "curve" else cf.fair_surface
    return call(CURVE if kind == "curve" else _net(), tol=0.02,
                **{"method": "wavelet", **options})


def _silent(call):
    """``call()`` with every warning an error: the canonical spellings warn of nothing."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return call()


@pytest.mark.parametrize("kind", ["curve", "surface"])
@pytest.mark.parametrize("old, new, value", [("strategy", "search", "linear"),
                                             ("deviation", "measure", "parametric")])
def test_an_old_spelling_warns_and_gives_the_new_spellings_result(kind, old, new, value):
    expected = _silent(lambda: _fair(kind, **{new: value}))
    default = _fair(kind)
    with pytest.warns(DeprecationWarning) as caught:
        result = _fair(kind, **{old: value})
    warning, = caught
    assert f"'{old}' is deprecated, use '{new}'" in str(warning.message)
    assert warning.filename == __file__          # it points at the caller
    np.testing.assert_array_equal(result.poles, expected.poles)
    assert result.n == expected.n and result.max_deviation == expected.max_deviation
    # the option does something here, so the equality above compares real choices
    if value == "linear":
        assert [r.n for r in result.table] != [r.n for r in default.table]


def test_the_old_value_of_an_option_and_its_new_name_together_are_refused():
    with pytest.raises(cf.InvalidInputError, match="strategy is the old spelling of search"):
        cf.fair_curve(CURVE, tol=0.02, strategy="linear", search="polyfit")


def test_an_unknown_keyword_is_a_type_error_as_python_says_it():
    with pytest.raises(TypeError, match="fair_surface\\(\\) got an unexpected keyword "
                                        "argument 'stratgy'"):
        cf.fair_surface(_net(), tol=0.02, stratgy="linear")


def test_an_old_spelling_with_a_method_that_does_not_use_it_keeps_its_old_effect():
    """Ignored for one release, as before, and the warning says so; the new spelling is
    refused there."""
    plain = cf.fair_curve(CURVE, tol=0.02, method="adaptive")
    with pytest.warns(DeprecationWarning, match="with method='adaptive' it has no effect"):
        old = cf.fair_curve(CURVE, tol=0.02, method="adaptive", strategy="linear")
    np.testing.assert_array_equal(old.poles, plain.poles)
    with pytest.raises(cf.InvalidInputError, match="search='linear' applies to "
                                                   "method='wavelet' only"):
        cf.fair_curve(CURVE, tol=0.02, method="adaptive", search="linear")


@pytest.mark.parametrize("method, option, value", [
    ("adaptive", "search", "linear"), ("energy", "search", "polyfit"),
    ("adaptive", "measure", "parametric"), ("energy", "measure", "parametric"),
    ("adaptive", "schedule", "direct"), ("energy", "schedule", "hybrid"),
    ("adaptive", "order", 3), ("energy", "target_degree", 2),
])
def test_an_option_the_method_does_not_use_is_refused(method, option, value):
    """These were ignored silently: the caller believed they did something."""
    kinds = ("curve",) if option == "order" else ("curve", "surface")  # a surface: no order
    for kind in kinds:
        with pytest.raises(cf.InvalidInputError) as info:
            _fair(kind, method=method, **{option: value})
        message = str(info.value)
        assert message.startswith(f"{option}={value!r} applies to method=")
        assert f"got method={method!r}, which " in message
        assert message.endswith(f"or drop {option}.")


def test_fair_surface_has_no_order():
    with pytest.raises(TypeError, match="unexpected keyword argument 'order'"):
        cf.fair_surface(_net(), tol=0.02, order=3)


def test_order_needs_the_polyfit_search():
    with pytest.raises(cf.InvalidInputError, match="order=3 with search='guaranteed'; add "
                                                   "search='polyfit' or drop order"):
        cf.fair_curve(CURVE, tol=0.02, method="wavelet", order=3)
    result = _silent(lambda: cf.fair_curve(CURVE, tol=0.02, method="wavelet", search="polyfit",
                                           order=3))
    assert result.max_deviation <= 0.02


def test_options_at_their_defaults_pass_with_every_method():
    """A default value is no request: spelling it out is never refused."""
    for method in options.CURVE_METHODS:
        kwargs = dict(search="guaranteed", measure="geometric", schedule="auto",
                      target_degree=None)
        result = _silent(lambda: cf.fair_curve(CURVE, tol=0.02, method=method, **kwargs))
        assert result.max_deviation <= 0.02


@pytest.mark.parametrize("function, defaults", [(cf.fair_curve, options.CURVE_DEFAULTS),
                                                (cf.fair_surface, options.DEFAULTS)])
def test_the_signatures_take_their_defaults_from_the_options_module(function, defaults):
    parameters = inspect.signature(function).parameters
    shared = [name for name in defaults if name in parameters]
    assert {"method", "objective", "search", "measure", "schedule"} <= set(shared)
    for name in shared:
        assert parameters[name].default == defaults[name], name
    assert not set(options.RENAMED) & set(parameters)     # old spellings only through **renamed
    for name in options.APPLIES:
        assert name in options.DEFAULTS


@pytest.mark.parametrize("joins, angle_tol, match", [
    ("sealed", 1.0, "joins must be one of"), ("G2", 1.0, "joins must be one of"),
    (None, 1.0, "joins must be one of"), ("smooth", 0, "angle_tol"),
    ("smooth", 90, "angle_tol"), ("smooth", float("nan"), "angle_tol"),
    ("smooth", True, "angle_tol"), ("smooth", "1", "angle_tol")])
def test_join_options_are_refused_with_the_values_that_would_do(joins, angle_tol, match):
    from cq_fairing.core.options import check_joins

    with pytest.raises(cf.InvalidInputError, match=match) as info:
        check_joins(joins, angle_tol)
    assert "curvature" in str(info.value) or "e.g. 1.0" in str(info.value)


def test_each_join_option_but_free_names_the_continuity_it_holds():
    from cq_fairing.core.joins import CONTINUITIES
    from cq_fairing.core.options import JOIN_CONTINUITY, JOINS, check_joins

    for joins in JOINS:
        check_joins(joins, 1.0)
    assert set(JOIN_CONTINUITY) == set(JOINS) - {"free"}
    assert set(JOIN_CONTINUITY.values()) == set(CONTINUITIES)


def test_the_objective_of_a_face_applies_to_the_wavelet_search_and_the_adaptive_method():
    """``objective`` ``"auto"`` (the default) is ``"compact"`` to the adaptive method;
    an occ face's wavelet search takes ``"auto"``, ``"compact"`` and ``"fair"`` with a
    tolerance, refuses ``"faithful"`` (the adaptive method's stopping rule), and refuses
    any objective but the default with explicit scales ``n``, where nothing is
    searched; the energy method takes none but the default."""
    assert options.DEFAULTS["objective"] == options.OBJECTIVES[0] == "auto"
    assert options.checked_objective("auto") == "compact"
    assert options.checked_objective("fair") == "fair"
    for objective in ("auto", "compact", "fair"):
        options.check_face_options(0.1, None, "wavelet", "free", objective)
    for objective in options.OBJECTIVES:
        options.check_face_options(0.1, None, "adaptive", "free", objective)
    with pytest.raises(cf.InvalidInputError, match="objective='faithful' .* applies to "
                                                   "method='adaptive' only, got "
                                                   "method='wavelet'"):
        options.check_face_options(0.1, None, "wavelet", "free", "faithful")
    with pytest.raises(cf.InvalidInputError, match="objective applies to the tolerance search"):
        options.check_face_options(None, (4, 4), "wavelet", "free", "fair")
    with pytest.raises(cf.InvalidInputError, match="objective='fair' applies to method="):
        options.check_face_options(0.1, None, "energy", "free", "fair")
    options.check_face_options(None, (4, 4), "wavelet", "free", "auto")
