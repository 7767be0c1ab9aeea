"""The options of :func:`~cq_fairing.core.fairing.fair_curve` and
:func:`~cq_fairing.core.fairing.fair_surface` that choose the method, validated once.

An option that does not apply to the chosen method, or to an explicit target scale, is
refused with a message that says which option to drop or what to add.
"""

import numpy as np

from ..errors import InvalidInputError

__all__ = ["METHODS", "OBJECTIVES", "BORDERS", "tolerance_method", "check_search_options",
           "checked_objective", "check_borders", "checked_target_degree"]


METHODS = ("wavelet", "adaptive", "energy")


def tolerance_method(method, objective, n, tol, borders="auto", window=None):
    """Validate ``method`` (and ``objective``, ``borders``, which belong to the adaptive
    method, and ``window``, which belongs to the tolerance searches); the tolerance-only
    methods need ``tol``, no ``n``."""
    if method not in METHODS:
        raise InvalidInputError(f"method must be one of {METHODS}, got {method!r}.")
    for name, value, default in (("objective", objective, "compact"), ("borders", borders, "auto")):
        if method != "adaptive" and value != default:
            raise InvalidInputError(
                f"{name}={value!r} applies to method='adaptive' only, got method={method!r}; "
                f"add method='adaptive' or drop {name}.")
    if method == "energy" and window is not None:
        raise InvalidInputError(
            f"window applies to the tolerance searches of method='wavelet' and 'adaptive', "
            f"got window={window!r} with method='energy', which moves every pole within "
            "tol; drop window or use another method.")
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


def _listed(words):
    """``"a"``, ``"a and b"``, ``"a, b and c"``."""
    return " and ".join(filter(None, (", ".join(words[:-1]), words[-1])))


def _differs(value, default):
    """True when an option's value is not its default (``None``: any value given)."""
    if default is None:
        return value is not None
    return not (np.ndim(value) == 0 and value == default)


#: Border rows of an adaptive surface target (``"auto"`` first: the default).
BORDERS = ("auto", "free", "pinned")
#: What an adaptive fit spends the tolerance on.
OBJECTIVES = ("compact", "faithful", "fair")


def checked_objective(value):
    """The adaptive ``objective``, refused unless one of :data:`OBJECTIVES`."""
    if value not in OBJECTIVES:
        raise InvalidInputError(
            f"objective must be one of {OBJECTIVES}, got {value!r}: 'compact' for the fewest "
            "poles within tol, 'faithful' to stop where the residual reaches the noise, "
            "'fair' for the fairest of the compact net and a few slightly larger ones.")
    return value


def check_borders(value):
    """Refuse a ``borders`` value of the adaptive surface fit that is not one of :data:`BORDERS`."""
    if value not in BORDERS:
        raise InvalidInputError(f"borders must be one of {BORDERS}, got {value!r}.")


def checked_target_degree(value, source_degree):
    """The target degree of an adaptive fit: ``value``, or ``min(3, source_degree)`` if None."""
    if value is None:
        return min(3, source_degree)
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise InvalidInputError(f"target_degree must be an integer >= 1, got {value!r}.")
    return int(value)
