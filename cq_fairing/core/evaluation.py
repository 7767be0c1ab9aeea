r"""Geometry at sample parameters: the dense samples the measures share, derivatives of
curves and surfaces (rational ones by the quotient rule), and the pair of geometries a
measure compares.
"""


import numpy as np

from ..errors import InvalidInputError
from .geometry import BSplineCurve, BSplineSurface
from .spaces import basis_functions, find_spans, require_in_domain


# -- samples and evaluation ---------------------------------------------------------------
def within_box(u, v, bounds):
    """Sample axes ``u``, ``v`` restricted to ``bounds`` ``((u0, u1), (v0, v1))``, whose
    ends become samples; unchanged for ``bounds=None``."""
    if bounds is None:
        return u, v
    return tuple(np.unique(np.concatenate([[low], x[(x > low) & (x < high)], [high]]))
                 for x, (low, high) in zip((u, v), bounds))


def sample_parameters(*spaces, per_span=8):
    """Dense parameters: ``per_span`` per span of the merged breakpoints, ends included.

    Parameters
    ----------
    *spaces : SplineSpace
        One or more spaces on the same domain; their breakpoints are merged, so the
        samples are at least ``per_span`` per span of the finer space.
    per_span : int, optional
        Samples per span (``>= 1``); every breakpoint is a sample.

    Returns
    -------
    ndarray, shape (spans * per_span + 1,)
    """
    if isinstance(per_span, bool) or not isinstance(per_span, (int, np.integer)) or per_span < 1:
        raise InvalidInputError(f"per_span must be an integer >= 1, got {per_span!r}.")
    b = np.unique(np.concatenate([s.breakpoints for s in spaces]))
    frac = np.arange(per_span) / per_span
    inner = (b[:-1, None] + (b[1:] - b[:-1])[:, None] * frac[None, :]).ravel()
    return np.append(inner, b[-1])


def curve_derivatives(curve, u, order):
    """Points and derivatives ``[C, C', ..., C^(order)]`` at ``u`` (rational allowed).

    Returns
    -------
    list of ndarray, each shape (len(u), d)
    """
    u = np.asarray(u, dtype=float).ravel()
    space = curve.space
    coeffs = curve.homogeneous() if curve.is_rational else curve.poles
    spans = find_spans(space, u)
    basis = basis_functions(space, u, spans, order)
    idx = spans[:, None] - space.degree + np.arange(space.degree + 1)[None, :]
    local = coeffs[idx]
    h = [np.einsum("qj,qjd->qd", basis[k], local) for k in range(order + 1)]
    if not curve.is_rational:
        return h
    return _rational_curve(h)


def _rational_curve(h):
    """Quotient rule for ``x = X / w`` (The NURBS Book, eq. 4.8) on homogeneous derivatives."""
    from math import comb

    w = [hk[:, -1:] for hk in h]
    out = []
    for k in range(len(h)):
        val = h[k][:, :-1].copy()
        for i in range(1, k + 1):
            val -= comb(k, i) * w[i] * out[k - i]
        out.append(val / w[0])
    return out


def surface_derivatives(surface, u, v, order):
    """Partial derivatives ``{(a, b): S_{u^a v^b}}`` with ``a + b <= order`` at points (u_i, v_i).

    Evaluated from the surface's Taylor form (:attr:`BSplineSurface.taylor`), the
    quotient rule applied for a rational surface.

    Returns
    -------
    dict of ndarray, each shape (len(u), d)
    """
    u = np.asarray(u, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    require_in_domain(surface.u_space, u)
    require_in_domain(surface.v_space, v)
    return _derivatives_in_domain(surface, u, v, order)


def _derivatives_in_domain(surface, u, v, order):
    """:func:`surface_derivatives` at 1-d float parameters known to lie in the domain (the
    clamped iterates of :func:`closest_points_surface`): no check."""
    h = surface.taylor.derivatives_in_domain(u, v, order)
    return rational_derivatives(h) if surface.is_rational else h


def rational_derivatives(h):
    """Partial derivatives ``{(a, b): S_{u^a v^b}}`` of :math:`S = X / w` from those of
    the homogeneous surface, ``h`` (``{(a, b): (X, w)}``, ``w`` the last coordinate, the
    lower orders first), by the quotient rule (The NURBS Book, eq. 4.20)."""
    from math import comb

    w = {key: val[:, -1:] for key, val in h.items()}
    out = {}
    for a, b in h:
        val = h[(a, b)][:, :-1].copy()
        for i in range(a + 1):
            for j in range(b + 1):
                if i or j:
                    val -= comb(a, i) * comb(b, j) * w[(i, j)] * out[(a - i, b - j)]
        out[(a, b)] = val / w[(0, 0)]
    return out


# -- public deviation ----------------------------------------------------------------------------
def _unwrap(source, faired):
    """Accept (source, faired) geometries or a fair result as ``source``."""
    if faired is None and hasattr(source, "source"):
        faired = source.curve if hasattr(source, "curve") else source.surface
        source = source.source
    if isinstance(source, BSplineCurve) and isinstance(faired, BSplineCurve):
        return source, faired, "curve"
    if isinstance(source, BSplineSurface) and isinstance(faired, BSplineSurface):
        return source, faired, "surface"
    raise InvalidInputError(
        "expected two BSplineCurve or two BSplineSurface objects (or one fair result), "
        f"got {type(source).__name__} and {type(faired).__name__}."
    )


def _check_domains(a, b):
    da = np.ravel(a.domain) if hasattr(a, "u_space") else np.array(a.domain)
    db = np.ravel(b.domain) if hasattr(b, "u_space") else np.array(b.domain)
    if np.abs(da - db).max() > 1e-12 * max(1.0, np.abs(da).max()):
        raise InvalidInputError(
            f"both geometries must share the parameter domain, got {tuple(da)} and {tuple(db)}."
        )
