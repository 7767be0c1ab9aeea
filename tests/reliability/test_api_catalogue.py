"""The bad-input catalogue of the public API (RELIABILITY.md, table 1).

Every case names the typed exception and a fragment of its one-line message; all run
with ``warnings.simplefilter("error")`` so a numpy/scipy warning counts as a failure.
Cases marked ``xfail(strict=True)`` are product defects listed in RELIABILITY.md
(section "Defects"); they turn into failures the day the product is fixed, so the
mark gets removed.
"""

import importlib
import re
import warnings

import numpy as np
import pytest

import cq_fairing as cf
from cq_fairing.errors import (
    FairingError,
    InvalidInputError,
    InvalidTargetError,
    InvalidToleranceError,
    NumericalError,
    ToleranceNotMetError,
    UnsupportedGeometryError,
)

RNG = np.random.default_rng(7)
P = RNG.normal(size=(20, 3))            # 20 poles, cubic: n in 1..17
NET = RNG.normal(size=(10, 12, 3))      # 10 x 12 poles, bicubic: n_u <= 7, n_v <= 9
KNOTS = cf.SplineSpace.quasi_uniform(17, 3).knots


def _with(array, index, value):
    out = np.array(array, dtype=float)
    out[index] = value
    return out


def _knots(change):
    t = KNOTS.copy()
    change(t)
    return t


def _repeat(t):
    t[5:9] = t[5]          # interior multiplicity 4 > degree 3


def _decrease(t):
    t[6] = t[8] + 0.01


def _defect(reason):
    return pytest.mark.xfail(strict=True, reason=reason)


# (id, call, exception, message fragment)
CASES = [
    # tolerances
    ("tol=0", lambda: cf.fair_curve(P, tol=0.0), InvalidToleranceError, "positive finite"),
    ("tol<0", lambda: cf.fair_curve(P, tol=-1e-3), InvalidToleranceError, "positive finite"),
    ("tol=nan", lambda: cf.fair_curve(P, tol=float("nan")), InvalidToleranceError, "nan"),
    ("tol=inf", lambda: cf.fair_curve(P, tol=float("inf")), InvalidToleranceError, "inf"),
    ("tol='0.1'", lambda: cf.fair_curve(P, tol="0.1"), InvalidToleranceError, "positive number"),
    ("tol=True", lambda: cf.fair_curve(P, tol=True), InvalidToleranceError, "positive number"),
    ("surface tol=0", lambda: cf.fair_surface(NET, tol=0.0), InvalidToleranceError,
     "positive finite"),
    ("surface tol=nan", lambda: cf.fair_surface(NET, tol=np.nan), InvalidToleranceError, "nan"),
    ("surface tol=-inf", lambda: cf.fair_surface(NET, tol=-np.inf), InvalidToleranceError, "inf"),
    ("n and tol", lambda: cf.fair_curve(P, 5, tol=0.1), InvalidInputError, "exactly one"),
    ("neither n nor tol", lambda: cf.fair_curve(P), InvalidInputError, "exactly one"),
    # target sizes
    ("n=0", lambda: cf.fair_curve(P, 0), InvalidTargetError, "between 1 and 17"),
    ("n<0", lambda: cf.fair_curve(P, -3), InvalidTargetError, "between 1 and 17"),
    ("n above source", lambda: cf.fair_curve(P, 18), InvalidTargetError, "between 1 and 17"),
    ("n=2.5", lambda: cf.fair_curve(P, 2.5), InvalidTargetError, "integer"),
    ("n=True", lambda: cf.fair_curve(P, True), InvalidTargetError, "integer"),
    ("surface n_u above", lambda: cf.fair_surface(NET, (8, 3)), InvalidTargetError,
     "between 1 and 7"),
    ("surface n_v=0", lambda: cf.fair_surface(NET, (3, 0)), InvalidTargetError,
     "between 1 and 9"),
    ("surface n triple", lambda: cf.fair_surface(NET, (3, 3, 3)), InvalidInputError, "pair"),
    ("target degree too high for n", lambda: cf.fair_curve(P, 3, target_degree=19),
     InvalidTargetError, "between 1 and 1"),
    # poles
    ("NaN pole", lambda: cf.fair_curve(_with(P, (3, 1), np.nan), 5), InvalidInputError,
     r"NaN or inf \(first at index \(3, 1\)\)"),
    ("inf pole", lambda: cf.fair_curve(_with(P, (4, 0), np.inf), 5), InvalidInputError,
     "NaN or inf"),
    ("NaN pole in net", lambda: cf.fair_surface(_with(NET, (2, 3, 0), np.nan), (3, 3)),
     InvalidInputError, r"index \(2, 3, 0\)"),
    ("-inf pole, tol mode", lambda: cf.fair_surface(_with(NET, (0, 0, 2), -np.inf), tol=1.0),
     InvalidInputError, "NaN or inf"),
    ("1-D poles", lambda: cf.fair_curve(np.ones(20), 5), InvalidInputError, r"shape \(k, d\)"),
    ("0 coordinates", lambda: cf.fair_curve(np.ones((20, 0)), 5), InvalidInputError,
     "1 to 4 coordinates"),
    ("5 coordinates", lambda: cf.fair_curve(np.ones((20, 5)), 5), InvalidInputError,
     "1 to 4 coordinates"),
    ("no poles", lambda: cf.fair_curve(np.zeros((0, 3)), 1), InvalidInputError, "at least 4"),
    ("3 poles cubic", lambda: cf.fair_curve(P[:3], 1), InvalidInputError, "at least 4"),
    ("strings", lambda: cf.fair_curve([["a", "b", "c"]] * 10, 5), InvalidInputError, "numeric"),
    ("ragged list", lambda: cf.fair_curve([[1, 2, 3], [1, 2]] * 5, 5), InvalidInputError,
     "numeric"),
    ("curve net to fair_surface", lambda: cf.fair_surface(P, (3, 3)), InvalidInputError,
     r"shape \(k_u, k_v, d\)"),
    ("net 1xN", lambda: cf.fair_surface(NET[:1], (1, 3)), InvalidInputError, "at least 4"),
    ("net 2x2", lambda: cf.fair_surface(NET[:2, :2], (1, 1)), InvalidInputError, "at least 4"),
    # weights
    ("zero weight", lambda: cf.fair_curve(P, 5, weights=_with(np.ones(20), 2, 0.0)),
     InvalidInputError, "finite and positive"),
    ("negative weight", lambda: cf.fair_surface(NET, (3, 3), weights=_with(np.ones((10, 12)),
                                                                            (1, 1), -2.0)),
     InvalidInputError, "finite and positive"),
    ("weights wrong shape", lambda: cf.fair_curve(P, 5, weights=np.ones(19)), InvalidInputError,
     r"shape \(20,\)"),
    ("huge weight ratio 1e12", lambda: cf.fair_surface(
        NET, (3, 3), weights=_with(np.ones((10, 12)), (1, 1), 1e12)), NumericalError,
     "non-positive weights"),
    # knots
    ("knot repeated beyond degree", lambda: cf.fair_curve(P, 5, knots=_knots(_repeat)),
     InvalidInputError, "repeated 4 times"),
    ("knots decreasing", lambda: cf.fair_curve(P, 5, knots=_knots(_decrease)),
     InvalidInputError, "non-decreasing"),
    ("knot NaN", lambda: cf.fair_curve(P, 5, knots=_with(KNOTS, 6, np.nan)),
     InvalidInputError, "NaN or inf"),
    ("unclamped (periodic) knots", lambda: cf.fair_curve(P, 5, knots=np.arange(24.0)),
     InvalidInputError, "clamped"),
    ("knots 2-D", lambda: cf.fair_curve(P, 5, knots=KNOTS[None, :]), InvalidInputError, "1-D"),
    ("empty domain", lambda: cf.fair_curve(P, 5, knots=np.zeros(24)), InvalidInputError,
     "empty"),
    # degrees and options
    ("degree=0", lambda: cf.fair_curve(P, 1, degree=0), InvalidInputError, "degree"),
    ("degree above poles", lambda: cf.fair_curve(P, 1, degree=25), InvalidInputError,
     "at least 26 poles"),
    ("schedule unknown", lambda: cf.fair_curve(P, 5, schedule="fast"), InvalidInputError,
     "schedule"),
    ("search unknown", lambda: cf.fair_curve(P, tol=0.1, search="x"), InvalidInputError,
     "search"),
    ("order=7", lambda: cf.fair_curve(P, tol=0.1, method="wavelet", search="polyfit", order=7),
     InvalidInputError, "order"),
    ("method unknown", lambda: cf.fair_curve(P, 5, method="spline"), InvalidInputError,
     "method"),
    ("energy with n", lambda: cf.fair_curve(P, 5, method="energy"), InvalidInputError,
     "needs tol"),
    # a tolerance that cannot be met: a quintic source, cubic target, tiny tol
    ("tol unreachable", lambda: cf.fair_curve(P, tol=1e-9, degree=5), ToleranceNotMetError,
     "no target within tol"),
    # fixed defects (RELIABILITY.md D2-D6), kept as regular cases
    ("complex poles", lambda: cf.fair_curve(P + 1j, 5), InvalidInputError, "complex|real"),
    ("degree=-1", lambda: cf.fair_curve(P, 1, degree=-1), InvalidInputError, "degree"),
    ("degree=2.5", lambda: cf.fair_curve(P, 1, degree=2.5), InvalidInputError, "degree"),
    ("target_degree=0", lambda: cf.fair_curve(P, 3, target_degree=0), InvalidInputError,
     "target_degree"),
    ("target_degree='x'", lambda: cf.fair_curve(P, 3, target_degree="x"), InvalidInputError,
     "target_degree"),
    ("NaN weight", lambda: cf.fair_curve(P, 5, weights=_with(np.ones(20), 2, np.nan)),
     InvalidInputError, "(?i)nan"),
    ("inf weight", lambda: cf.fair_curve(P, 5, weights=_with(np.ones(20), 2, np.inf)),
     InvalidInputError, "inf"),
    ("net 1xN names the direction", lambda: cf.fair_surface(NET[:1], (1, 3)),
     InvalidInputError, r"surface|\bu\b"),
    # A2-A4, A7 (RELIABILITY.md): degree pairs, numeric and real knots/weights, the
    # supported coordinate range, energy fairing of a degree-1 curve
    ("degree of three values", lambda: cf.fair_surface(NET, (3, 3), degree=(3, 3, 3)),
     InvalidInputError, "pair"),
    ("degree [3]", lambda: cf.fair_surface(NET, (3, 3), degree=[3]), InvalidInputError, "pair"),
    ("adaptive target_degree of three values",
     lambda: cf.fair_surface(NET, tol=1.0, method="adaptive", target_degree=(3, 3, 3)),
     InvalidInputError, "target_degree"),
    ("knots as text", lambda: cf.fair_curve(P, 5, knots="abc"), InvalidInputError,
     "knots must be a numeric array"),
    ("weights as text", lambda: cf.fair_curve(P, 5, weights=["a"] * 20), InvalidInputError,
     "weights must be a numeric array"),
    ("complex knots", lambda: cf.fair_curve(P, 5, knots=KNOTS + 0j), InvalidInputError,
     "complex"),
    ("complex weights", lambda: cf.fair_curve(P, 5, weights=np.ones(20) + 1j),
     InvalidInputError, "complex"),
    ("coordinates beyond 1e50", lambda: cf.fair_curve(P * 1e60, tol=1e58), InvalidInputError,
     "larger units"),
    ("extent below 1e-50", lambda: cf.fair_curve(P * 1e-170, tol=5e-172), InvalidInputError,
     "smaller units"),
    ("energy on a degree-1 curve", lambda: cf.fair_curve(P, tol=0.5, degree=1, method="energy"),
     UnsupportedGeometryError, "degree >= 2.*method='wavelet'"),
]


def _id(case):
    return case.values[0] if hasattr(case, "values") else case[0]


@pytest.mark.parametrize("name, call, error, fragment", CASES, ids=[_id(c) for c in CASES])
def test_bad_input_raises_typed_one_line_error(name, call, error, fragment):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(error, match=fragment) as info:
            call()
    message = str(info.value)
    assert isinstance(info.value, FairingError)
    assert "\n" not in message and 20 < len(message) < 400
    assert "Traceback" not in message


def test_unreachable_tolerance_reports_best_deviation():
    with pytest.raises(ToleranceNotMetError) as info:
        cf.fair_curve(P, tol=1e-9, degree=5)
    assert info.value.tolerance == 1e-9
    assert np.isfinite(info.value.best_deviation) and info.value.best_deviation > 1e-9


def test_messages_only_name_modules_that_exist():
    with pytest.raises(InvalidInputError) as info:
        cf.fair_curve(P, 5, knots=np.arange(24.0))
    for module in re.findall(r"cq_fairing(?:\.\w+)+", str(info.value)):
        importlib.import_module(module)


# -- degenerate but valid nets: they fair, and nothing is NaN ------------------------------
def _finite_result(result):
    geometry = result.curve if hasattr(result, "curve") else result.surface
    assert np.all(np.isfinite(geometry.poles))
    if geometry.weights is not None:
        assert np.all(geometry.weights > 0)


@pytest.mark.parametrize("mode", [dict(n=(3, 3)), dict(tol=1e-3)], ids=["n", "tol"])
@pytest.mark.parametrize("kind", ["coincident", "collapsed-row", "collapsed-both-ends",
                                  "degree-1 2x2", "flat"])
def test_degenerate_nets_fair_without_nan(kind, mode):
    net = NET.copy() if "n" in mode else NET[:7, :6].copy()   # tol mode: smaller, faster
    degree = 3
    if kind == "coincident":
        net[:] = (1.0, 2.0, 3.0)
    elif kind == "collapsed-row":           # a sphere's pole: one row is one point
        net[0] = net[0, 0]
    elif kind == "collapsed-both-ends":
        net[0], net[-1] = net[0, 0], net[-1, 0]
    elif kind == "degree-1 2x2":
        net, degree = net[:2, :2], 1
        mode = dict(n=(1, 1)) if "n" in mode else mode
    else:
        net[..., 2] = 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = cf.fair_surface(net, degree=degree, **mode)
    _finite_result(result)
    if kind == "coincident":
        assert np.allclose(result.poles, (1.0, 2.0, 3.0), atol=1e-12)
    assert np.allclose(result.reconstruct(), net, atol=1e-9 * (1 + np.abs(net).max()))


@pytest.mark.parametrize("method", ["adaptive", "energy"])
@pytest.mark.parametrize("kind", ["coincident", "line", "flat"])
def test_degenerate_nets_fair_by_the_tolerance_methods_without_warnings(kind, method):
    """All poles at one point, on one line, or in a plane: the adaptive method (whose
    polish scales its energy by the net's lengths, zero for a point) and energy fairing
    finish within tol, without overflow warnings from the collapsed closest points."""
    u, v = np.meshgrid(np.linspace(0, 1, 7), np.linspace(0, 1, 6), indexing="ij")
    nets = {"coincident": np.broadcast_to((1.0, 2.0, 3.0), (7, 6, 3)),
            "line": np.stack([u, 0 * v, 0 * u], axis=2),
            "flat": np.stack([u, v, 0 * u], axis=2)}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = cf.fair_surface(nets[kind], tol=1e-3, method=method)
    _finite_result(result)
    assert result.max_deviation <= 1e-3
    if kind == "coincident":
        assert np.allclose(result.poles, (1.0, 2.0, 3.0), atol=1e-12)


def test_tiny_tolerance_returns_the_source_space_with_zero_deviation():
    """tol far below rounding level of the model: the search ends at the source itself."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        result = cf.fair_curve(P * 1e3, tol=1e-300)
    assert result.n == 17 and result.max_deviation <= 1e-300
    assert np.allclose(result.poles, P * 1e3, rtol=0, atol=1e-9)
