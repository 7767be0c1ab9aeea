r"""The fairing options: one name, one meaning, one set of values and one default each,
validated once at the public boundary of every layer.

:func:`~cq_fairing.core.fairing.fair_curve`, :func:`~cq_fairing.core.fairing.fair_surface`,
:func:`cq_fairing.occ.fair_face`, :func:`cq_fairing.occ.fair_shape`, the ``cq-fairing``
command line and the CadQuery plugin take their option names, values and checks from
here.  An option that does not apply to the chosen method (or to an explicit target
scale) is refused with a message naming what was given, why it does not apply and what
to do; it is never ignored.

The options
-----------
``method`` : {"wavelet", "adaptive", "energy"}, default "wavelet"; curves also "auto", their default
    How the geometry is faired: the projection onto quasi-uniform targets, onto targets
    whose knots follow the error, or Eck-Hadenfeld energy fairing that keeps the poles.
    ``"auto"`` (:func:`~cq_fairing.core.fairing.fair_curve` only, see below) chooses
    among the adaptive fits per curve and reports its choice.
``tol`` : positive length (model units)
    Largest allowed deviation.  The occ layer's default is 1e-3 of the bounding-box
    diagonal.  ``"adaptive"`` and ``"energy"`` need it.
``n`` : int, or a pair of int or None
    Target scale: knot **spans** per direction (``poles = n + target_degree``), the
    index of the space :math:`V_n`.  ``"wavelet"`` only, instead of ``tol``.  The command
    line's ``--target NU NV`` gives **poles** and is converted to ``n``.
``target_degree`` : int >= 1, or a pair, default ``min(3, source degree)``
    Degree of the faired geometry.  ``"wavelet"`` and ``"adaptive"`` (``"energy"`` keeps
    the degree); with ``"auto"`` the one degree it fits at (default: it chooses).
``objective`` : {"auto", "compact", "faithful", "fair"}, default "auto"
    What a fit spends ``tol`` on beyond the fewest poles.  ``"adaptive"``: ``"compact"``
    (``"auto"``) the fewest poles, ``"faithful"`` a residual down to the noise, ``"fair"``
    the fairest of the compact net and a few slightly larger ones.  ``"wavelet"`` occ
    faces (the tolerance search on the face's samples): ``"auto"`` and ``"fair"`` polish
    the fewest-poles net with the largest curvature-variation penalty within ``tol``,
    ``"compact"`` keeps the plain projection
    (:func:`~cq_fairing.core.face_search.search_face`); in a model a face that meets
    another face is not polished
    (:func:`~cq_fairing.core.joint_projection.plain_target_options`).
``borders`` : {"auto", "free", "pinned"}, default "auto"
    The border rows of the **target** while it is fitted: ``"pinned"`` keeps the
    corners and projects each edge on its own
    (:mod:`~cq_fairing.core.target_projections`), ``"free"`` is the plain projection,
    ``"auto"`` pins where that gives fewer poles.  ``"adaptive"`` surfaces, and
    ``"wavelet"`` occ faces (the bisections on the face's samples, and explicit ``n``,
    where ``"auto"`` is the plain projection).  In a model a face that shares a held
    join with another face searches free borders: the joint projection sets its
    borders.
``boundary`` : {"free", "fixed"}, default "free"
    Occ faces only: ``"fixed"`` puts the **source's** border rows back into the faired
    net after the fit, so the natural boundary curves do not move.  ``"wavelet"`` and
    ``"adaptive"`` (``"energy"`` keeps the border ring of the net anyway).
``search`` : {"guaranteed", "linear", "polyfit"}, faces also "local"
    How the uniform tolerance search (``"wavelet"`` with ``tol``) finds the target scale:
    the core's step rules (:mod:`cq_fairing.core.accuracy`), or, for a face (occ layer,
    command line, workbench: one search, :mod:`cq_fairing.core.face_search`),
    ``"local"``: bisection on the face's own samples inside its trim
    (:mod:`cq_fairing.core.scale_search`).  Default ``"guaranteed"`` in the core, ``"local"``
    for faces.
``grading`` : {"auto", "spans", "uniform"}, default "auto"
    Occ faces only: the targets of the bisections on a face's samples (``"wavelet"``
    with ``tol``).  ``"spans"``: quasi-uniform targets and, on a face whose knot spans
    are graded, targets graded like them (:func:`~cq_fairing.core.plans.graded_space`);
    the fewest poles win.  ``"auto"``: those, with borders pinned to the face's border
    curves targets refined towards the borders
    (:func:`~cq_fairing.core.plans.end_graded_space`), and, in the local search, where
    such a target keeps more than a quarter of the face's poles (and more than 100),
    targets graded by the error: the adaptive method's compact fit, with free borders
    unless ``borders="pinned"`` (:func:`~cq_fairing.core.face_search.search_face`).
    ``"uniform"``: quasi-uniform targets only, the method's own :math:`V_n`.  In a model
    of several faces ``"auto"`` is ``"spans"``
    (:func:`~cq_fairing.core.joint_projection.model_grading`: the nets that win alone
    with fewer poles may open the joins between faces), and a face that shares a held
    join with another face searches quasi-uniform targets, whose knots its neighbours
    share along the join.  Refused with ``n``.  The command line's ``--grading``, the
    workbench's ``Grading``.
``order`` : int 2 .. 6, default 6
    Degree of the least-squares fit of ``search="polyfit"``; only with it.
``measure`` : {"geometric", "parametric"}, default "geometric"
    The distance the core's tolerance search bounds: closest-point or same-parameter.
    ``"wavelet"`` with ``tol`` in the core.  A face's core step rules bound the default
    (occ layer, command line) or the workbench's ``Measure`` (same values and default,
    refused other than the default with ``"local"``, which does not use it).
``schedule`` : {"auto", "direct", "hybrid"}, default "auto"
    Spaces the core's projection visits (:mod:`cq_fairing.core.schedule`).  ``"wavelet"``.
``joins`` : {"smooth", "closed", "free", "curvature"}, default "smooth"
    Models (occ shapes, the workbench): how faces that meet hold their joins.
    ``"smooth"``: closed, and one tangent plane across the joins that were smooth in the
    source (G1); ``"curvature"``: also the normal curvature across the smooth joins
    whose source was curvature-continuous (G2); ``"closed"``: closed only (G0);
    ``"free"``: each face faired alone.  ``angle_tol`` (degrees, default 1) is the source
    normal angle below which a join counts as smooth.
``window`` : (u0, u1, v0, v1), default the whole domain
    Parameter box the deviation is measured in (a trimmed face's UV box); core surfaces,
    ``tol`` with ``"wavelet"`` or ``"adaptive"``.

The curves' default: ``method="auto"``
--------------------------------------
With ``tol`` (and no ``n``) :func:`~cq_fairing.core.fairing.fair_curve` fairs by the
rule below (:func:`~cq_fairing.core.auto_curve.fair_curve_auto`); with ``n`` it is the
wavelet projection onto :math:`V_n`, the one method that takes a target scale.

1. **Budget.**  The compact adaptive fit (``method="adaptive"``) at ``target_degree``,
   default ``min(3, source degree)``, sets the pole budget ``B``.  If it does not meet
   ``tol`` (a source that only uniform targets reach, e.g. a quintic Bezier at degree
   3), the answer is the wavelet tolerance search, as ``method="wavelet"``.
2. **Degrees.**  Without ``target_degree``, a polynomial source of degree >= 3 is also
   fitted at degrees 5 and 7: a smooth shape needs fewer poles at a higher degree, and
   these are the odd degrees ``2k - 1`` whose interpolating splines minimise
   :math:`\int (f^{(k)})^2`, ``k = 3`` (the order of :math:`d\kappa/ds`) and ``4``.
   A rational source and one of degree 1 or 2 keep their degree: weights and low
   degrees are exact geometry (conics, polygons).
3. **Noise.**  At each degree the ``"faithful"`` fit (:mod:`~cq_fairing.core.fidelity`:
   the smallest target whose residual is down to the source's estimated noise) is a
   candidate when it meets ``tol`` at that size, i.e. when the noise, not the tolerance,
   sets its size.  If some candidate has at most ``B`` poles, removing the noise costs
   no poles, and the candidate with the fewest poles is the answer (ties: the least
   :math:`\int (d\kappa/ds)^2 ds`).  It keeps the noise-free shape instead of spending
   the tolerance on bending it (seed curve at 0.02: degree 7, 57 poles against
   ``B = 71``, 0.0023 from the noise-free truth against 0.019).
4. **Otherwise** (a clean source, or a tolerance the noise does not reach) the compact
   fit with the fewest poles over the degrees, ties by the same fairness measure (the
   eq. 15 curve without noise at 0.02: degree 7, 47 poles against ``B = 67``).

The result reports its choice as ``FairResult.choice``: the explicit options
(``method``, ``objective``, ``target_degree``) that give the same curve.
``method="wavelet"`` is the seed's uniform ARWFA search, unchanged; surfaces, faces and
shapes keep ``"wavelet"`` as their default.

Choice of names
---------------
``search`` is the tolerance search in every layer (the workbench's property of that name
has the same values and, for faces, the same default ``"local"``; the core called it
``strategy``, the occ layer's ``"core"`` is the core's default rule ``"guaranteed"``).
``measure`` names which distance is measured (the core called it ``deviation``, which
names the measured value everywhere else: ``max_deviation``,
``FaceFairReport.deviation``).  ``borders`` and ``boundary`` are two options, not two
spellings: ``borders`` shapes the adaptive target during the fit,
``boundary`` restores the source's rows after any fit.  Old spellings
(:data:`RENAMED`, :data:`RENAMED_VALUES`) keep working for one release with a
:class:`DeprecationWarning` naming the new one.
"""

import warnings

import numpy as np

from ..errors import InvalidInputError, InvalidToleranceError

__all__ = ["METHODS", "CURVE_METHODS", "OBJECTIVES", "BORDERS", "BOUNDARIES", "SEARCHES",
           "FACE_SEARCHES", "GRADINGS", "MEASURES", "SCHEDULES", "JOINS", "JOIN_CONTINUITY",
           "DEFAULTS", "CURVE_DEFAULTS", "APPLIES", "FACE_APPLIES", "FACE_VALUE_APPLIES",
           "METHOD_DOES", "RENAMED",
           "RENAMED_VALUES",
           "curve_method", "tolerance_method", "check_applies", "check_search_options",
           "checked_choice", "check_joins", "checked_objective", "check_borders",
           "checked_target_degree", "checked_order", "check_order",
           "renamed_keywords", "renamed_value", "check_face_options", "face_applies"]

#: How the geometry is faired (``"wavelet"`` first: the default of surfaces and faces).
METHODS = ("wavelet", "adaptive", "energy")
#: How a curve is faired (``"auto"`` first: the default of curves).
CURVE_METHODS = ("auto",) + METHODS
#: What an adaptive fit spends the tolerance on.
OBJECTIVES = ("auto", "compact", "faithful", "fair")
#: Border rows of an adaptive surface target (``"auto"`` first: the default).
BORDERS = ("auto", "free", "pinned")
#: The source's border rows of an occ face after the fit.
BOUNDARIES = ("free", "fixed")
#: Step rules of the core's uniform tolerance search.
SEARCHES = ("guaranteed", "linear", "polyfit")
#: Tolerance searches of an occ face: its own samples, or the core's with a step rule.
FACE_SEARCHES = ("local",) + SEARCHES
#: Targets of an occ face's bisections (``"auto"`` first: the default).
GRADINGS = ("auto", "spans", "uniform")
#: The distance the core's tolerance search bounds.
MEASURES = ("geometric", "parametric")
#: Spaces visited by the core's projection.
SCHEDULES = ("auto", "direct", "hybrid")
#: How a model's faces hold their joins (``"smooth"`` first: the default).
JOINS = ("smooth", "closed", "free", "curvature")
#: The continuity the joint projection holds for each of :data:`JOINS` but ``"free"``.
JOIN_CONTINUITY = {"smooth": "G1", "curvature": "G2", "closed": "G0"}

#: Default of each option (``search`` of an occ face: ``"local"``).
DEFAULTS = {"method": "wavelet", "objective": "auto", "borders": "auto",
            "boundary": "free", "search": "guaranteed", "order": 6, "measure": "geometric",
            "schedule": "auto", "window": None, "target_degree": None, "grading": "auto"}

_FACE_DEFAULTS = {**DEFAULTS, "search": "local"}
#: Default of each option of :func:`~cq_fairing.core.fairing.fair_curve`.
CURVE_DEFAULTS = {**DEFAULTS, "method": "auto"}

#: The methods each method-specific option applies to.
APPLIES = {"objective": ("adaptive",), "borders": ("adaptive",),
           "target_degree": ("auto", "wavelet", "adaptive"),
           "boundary": ("wavelet", "adaptive"),
           "window": ("wavelet", "adaptive"), "search": ("wavelet",), "grading": ("wavelet",),
           "order": ("wavelet",), "measure": ("wavelet",), "schedule": ("wavelet",)}
#: :data:`APPLIES` of an occ face: its wavelet search also pins borders and polishes.
FACE_APPLIES = {**APPLIES, "borders": ("wavelet", "adaptive"),
                "objective": ("wavelet", "adaptive")}
#: Values of an occ face's option that apply to fewer methods than the option does
#: (``objective="faithful"``: the adaptive method's stopping rule).
FACE_VALUE_APPLIES = {("objective", "faithful"): ("adaptive",)}

#: What each method does that makes the other methods' options meaningless for it.
METHOD_DOES = {"auto": "chooses the adaptive fit per curve",
               "wavelet": "projects onto quasi-uniform targets",
               "adaptive": "chooses its knots itself and checks the true distance",
               "energy": "keeps the control points, the degree and the border ring and "
                         "moves each pole within tol"}

#: Old keyword -> canonical keyword (accepted for one release, with a warning).
RENAMED = {"strategy": "search", "deviation": "measure"}
#: (keyword, old value) -> canonical value (accepted for one release, with a warning).
RENAMED_VALUES = {("search", "core"): "guaranteed"}


# -- names ---------------------------------------------------------------------------------
def renamed_keywords(function, old, method, **current):
    """The canonical options of a call, with the old spellings in ``old`` folded in.

    An old spelling keeps its old behaviour for one release: given with a ``method`` that
    does not use the option (:data:`APPLIES`), it is ignored, as it was, and its warning
    says so (the canonical spelling is refused there).

    Parameters
    ----------
    function : str
        The public function's name, for the messages.
    old : dict
        The call's keywords beyond its signature (its ``**old``).
    method : str
        The call's method.
    **current
        The canonical options of the call as given (or defaulted).

    Returns
    -------
    dict
        ``current``, with each old spelling's value under its canonical name (unless
        ignored).

    Raises
    ------
    TypeError
        A keyword that is neither an option nor an old spelling (as Python says it).
    InvalidInputError
        An old spelling given together with its canonical name.

    Warns
    -----
    DeprecationWarning
        Per old spelling used, naming the new one; it points at the public function's
        caller.
    """
    out = dict(current)
    for name, value in old.items():
        new = RENAMED.get(name)
        if new not in current:
            raise TypeError(f"{function}() got an unexpected keyword argument {name!r}")
        if _differs(current[new], DEFAULTS[new]):
            raise InvalidInputError(
                f"{name} is the old spelling of {new}; got {name}={value!r} and "
                f"{new}={current[new]!r}: give {new} only.")
        applies = method in APPLIES[new]
        effect = "" if applies else (
            f"; with method={method!r} it has no effect ({new} is refused there): drop it")
        warnings.warn(f"{function}(): '{name}' is deprecated, use '{new}' (same values); "
                      f"'{name}' goes in the next release{effect}.", DeprecationWarning,
                      stacklevel=3)
        if applies:
            out[new] = value
    return out


def renamed_value(function, name, value, stacklevel=3):
    """``value`` of option ``name``, an old value (:data:`RENAMED_VALUES`) replaced by
    the new one with a :class:`DeprecationWarning` pointing at the public function's
    caller (``stacklevel`` frames up: 3 when the public function calls this directly)."""
    new = RENAMED_VALUES.get((name, value)) if isinstance(value, str) else None
    if new is None:
        return value
    warnings.warn(f"{function}(): {name}={value!r} is deprecated, use {name}={new!r} "
                  "(the same search); the old value goes in the next release.",
                  DeprecationWarning, stacklevel=stacklevel)
    return new


# -- values --------------------------------------------------------------------------------
def checked_choice(name, value, choices):
    """``value``, refused unless one of ``choices``."""
    if not isinstance(value, str) or value not in choices:
        raise InvalidInputError(f"{name} must be one of {choices}, got {value!r}.")
    return value


def check_joins(joins, angle_tol):
    """Refuse a ``joins`` not in :data:`JOINS` and an ``angle_tol`` that is not an angle
    strictly between 0 and 90 degrees."""
    if not isinstance(joins, str) or joins not in JOINS:
        raise InvalidInputError(
            f"joins must be one of {JOINS}, got {joins!r}; 'smooth' (default) keeps joins "
            "closed and smooth, 'curvature' also their curvature, 'closed' closed, 'free' "
            "fairs each face alone.")
    if (isinstance(angle_tol, bool) or not isinstance(angle_tol, (int, float, np.integer,
                                                                  np.floating))
            or not np.isfinite(angle_tol) or not 0 < angle_tol < 90):
        raise InvalidInputError(
            f"the angle tolerance must be an angle in degrees between 0 and 90 (angle_tol, "
            f"the workbench's AngleTolerance), got {angle_tol!r}; e.g. 1.0 for 'smooth below "
            "one degree'.")


def checked_objective(value):
    """The adaptive method's ``objective`` (``"auto"`` is ``"compact"``), refused unless
    one of :data:`OBJECTIVES`."""
    if value not in OBJECTIVES:
        raise InvalidInputError(
            f"objective must be one of {OBJECTIVES}, got {value!r}: 'auto' (default) for "
            "each method's best, 'compact' for the fewest poles within tol, 'faithful' to "
            "stop where the residual reaches the noise, 'fair' for the fairest within tol.")
    return "compact" if value == "auto" else value


def check_borders(value):
    """Refuse a ``borders`` value of the adaptive surface fit that is not one of :data:`BORDERS`."""
    checked_choice("borders", value, BORDERS)


def checked_order(order):
    """``order``, refused unless an integer 2 .. 6."""
    if isinstance(order, bool) or not isinstance(order, (int, np.integer)) or not 2 <= order <= 6:
        raise InvalidInputError(
            f"order (degree of the least-squares fit of search='polyfit') must be an "
            f"integer from 2 to 6, got {order!r}.")
    return order


def check_order(order, search):
    """``order`` is an integer 2 .. 6 and, when not the default, comes with ``search="polyfit"``."""
    if checked_order(order) != DEFAULTS["order"] and search != "polyfit":
        raise InvalidInputError(
            f"order is the degree of the least-squares fit of search='polyfit', got "
            f"order={order!r} with search={search!r}; add search='polyfit' or drop order.")


def checked_target_degree(value, source_degree):
    """The target degree of an adaptive fit: ``value``, or ``min(3, source_degree)`` if None."""
    if value is None:
        return min(3, source_degree)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidInputError(f"target_degree must be an integer >= 1, got {value!r}.")
    return int(value)


def _checked_tol(tol):
    if isinstance(tol, bool) or not isinstance(tol, (int, float, np.floating, np.integer)) \
            or not np.isfinite(tol) or tol <= 0:
        raise InvalidToleranceError(
            f"tol must be a positive finite length in model units, got {tol!r}.")


# -- which option goes with which method ---------------------------------------------------
def check_applies(method, options, defaults=DEFAULTS, methods=METHODS, applies=APPLIES):
    """Refuse the method-specific options (:data:`APPLIES`) that ``method`` does not use.

    Parameters
    ----------
    method : str
        One of ``methods``.
    options : iterable of (str, object)
        ``(name, value)`` of each method-specific option of the call; a value equal to
        the option's default is no request and passes.
    defaults : dict
        The defaults of the calling layer (:data:`DEFAULTS`, an occ face's ``search``:
        ``"local"``).
    methods : tuple of str
        The methods of the calling layer (:data:`METHODS`; curves:
        :data:`CURVE_METHODS`); the message names only those.
    applies : dict
        :data:`APPLIES`, or an occ face's (``borders`` also with ``"wavelet"``).

    Raises
    ------
    InvalidInputError
        Naming the option and its value, what ``method`` does instead, and what to do.
    """
    for name, value in options:
        allowed = [m for m in applies[name] if m in methods]
        if method in allowed or not _differs(value, defaults[name]):
            continue
        listed = " or ".join(repr(m) for m in allowed)
        raise InvalidInputError(
            f"{name}={value!r} applies to method={listed} only, got method={method!r}, "
            f"which {METHOD_DOES[method]}; add method={allowed[-1]!r} or drop {name}.")


def face_applies(name, value):
    """The methods an occ face's option ``name`` applies to with ``value``
    (:data:`FACE_VALUE_APPLIES`, else :data:`FACE_APPLIES`)."""
    narrower = FACE_VALUE_APPLIES.get((name, value)) if isinstance(value, str) else None
    return narrower or FACE_APPLIES[name]


def curve_method(method, n, tol):
    """The method :func:`~cq_fairing.core.fairing.fair_curve` runs: ``method``, one of
    :data:`CURVE_METHODS`; ``"auto"`` is the wavelet method unless ``tol`` comes without
    ``n`` (a target scale is the wavelet projection's; neither or both are refused
    there)."""
    checked_choice("method", method, CURVE_METHODS)
    if method == "auto" and (tol is None or n is not None):
        return "wavelet"
    return method


def tolerance_method(method, objective, n, tol, borders="auto", window=None, methods=METHODS):
    """Validate ``method`` (one of ``methods``) with the options the core's two entry
    points share: ``objective`` and ``borders`` belong to the adaptive method, ``window``
    to the tolerance searches; the tolerance-only methods need ``tol``, no ``n``."""
    checked_choice("method", method, methods)
    check_applies(method, (("objective", objective), ("borders", borders), ("window", window)),
                  methods=methods)
    if method != "wavelet" and (n is not None or tol is None):
        what = ("keeps the control points" if method == "energy"
                else "chooses the target itself")
        raise InvalidInputError(
            f"method={method!r} {what} and needs tol (the largest allowed deviation) and "
            f"no n; got n={n!r}, tol={tol!r}.")
    return method


def check_search_options(n, tol, options):
    """Refuse tolerance-search options given with an explicit target scale.

    The options of the tolerance search (``tol=...``) choose how the target is searched;
    with ``n`` (and no ``tol``) nothing is searched, so a non-default value would be
    ignored silently.  Called once at each public boundary (:func:`fair_curve`,
    :func:`fair_surface`, :func:`cq_fairing.occ.fair_face`).

    Parameters
    ----------
    n, tol : object
        The call's target scale and tolerance (``None`` when not given).
    options : iterable of (str, object, object)
        ``(name, value, default)`` of each tolerance-search option of the call.

    Raises
    ------
    InvalidInputError
        If ``n`` is given without ``tol`` and some option is not at its default.
    """
    given = [(name, value) for name, value, default in options if _differs(value, default)]
    if not given or n is None or tol is not None:
        return
    names = _listed([name for name, _ in given])
    values = ", ".join(f"{name}={value!r}" for name, value in given)
    verb = "applies" if len(given) == 1 else "apply"
    raise InvalidInputError(
        f"{names} {verb} to the tolerance search (tol=...), which does not run with an "
        f"explicit target scale n: got {values} with n={n!r}; drop {names} or give tol "
        "instead of n.")


def check_face_options(tol, n, method, boundary, objective="auto", borders="auto",
                       search="local", target_degree=None, grading="auto"):
    """Validate the options of an occ face (:func:`cq_fairing.occ.fair_face`, and
    :func:`cq_fairing.occ.fair_shape` for each of its faces) once.

    ``tol`` and ``n`` exclude each other (both ``None``: the default tolerance); the
    values are checked against :data:`METHODS`, :data:`OBJECTIVES`, :data:`BORDERS`,
    :data:`BOUNDARIES`, :data:`FACE_SEARCHES` and :data:`GRADINGS`; ``objective``,
    ``borders``, ``boundary``, ``target_degree``, ``search`` (an occ face's default:
    ``"local"``) and ``grading`` are refused with a method that does not use them
    (:func:`check_applies` with :data:`FACE_APPLIES`); ``"adaptive"`` and ``"energy"``
    refuse ``n``; ``search``, ``grading`` and ``objective`` are refused with ``n``
    (:func:`check_search_options`; ``borders="pinned"`` pins explicit scales), and
    ``objective="faithful"`` with ``"wavelet"`` (a residual down to the noise is the
    adaptive method's stopping rule).
    """
    if tol is not None and n is not None:
        raise InvalidInputError(f"give at most one of tol and n, got tol={tol!r}, n={n!r}.")
    if tol is not None:
        _checked_tol(tol)
    checked_choice("method", method, METHODS)
    checked_objective(objective)
    for name, value, choices in (("borders", borders, BORDERS),
                                 ("boundary", boundary, BOUNDARIES),
                                 ("search", search, FACE_SEARCHES),
                                 ("grading", grading, GRADINGS)):
        checked_choice(name, value, choices)
    check_applies(method, (("objective", objective), ("borders", borders),
                           ("boundary", boundary), ("target_degree", target_degree),
                           ("search", search), ("grading", grading)), _FACE_DEFAULTS,
                  applies=FACE_APPLIES)
    if method != "wavelet" and n is not None:
        what = ("chooses the target itself" if method == "adaptive"
                else "keeps the control points")
        raise InvalidInputError(
            f"method={method!r} {what} and needs tol, not n; got n={n!r}. "
            "Give tol, or use method='wavelet' for explicit scales.")
    if ("objective", objective) in FACE_VALUE_APPLIES and \
            method not in face_applies("objective", objective):
        raise InvalidInputError(
            "objective='faithful' (stop where the residual reaches the noise) applies to "
            f"method='adaptive' only, got method={method!r}: use method='adaptive', or "
            "objective 'auto', 'compact' or 'fair'.")
    check_search_options(n, tol, (("search", search, "local"), ("grading", grading, "auto"),
                                  ("objective", objective, "auto")))


def _listed(words):
    """``"a"``, ``"a and b"``, ``"a, b and c"``."""
    return " and ".join(filter(None, (", ".join(words[:-1]), words[-1])))


def _differs(value, default):
    """True when an option's value is not its default (``None``: any value given)."""
    if default is None:
        return value is not None
    return not (np.ndim(value) == 0 and value == default)
