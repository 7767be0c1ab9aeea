r"""Fairness measures of curves and surfaces: curvature, energies, wiggles.

Curvature :math:`\kappa = |C'\times C''|/|C'|^3` and torsion
:math:`\tau = (C'\times C'')\cdot C'''/|C'\times C''|^2` along curves; principal, mean
and Gaussian curvature of surfaces from the fundamental forms; the bending energies

.. math::  E_C = \int |C''(t)|^2\,dt, \qquad
           E_S = \iint |S_{uu}|^2 + 2|S_{uv}|^2 + |S_{vv}|^2 \,du\,dv

computed exactly from Gram matrices of derivatives (:func:`~cq_fairing.core.gram.gram_matrix`
with ``nu = 2``, tensor products for surfaces; polynomial geometry); the number of
curvature extrema and of inflections (wiggle count) and
:math:`\int (d\kappa/ds)^2\,ds` along curves.
"""


import numpy as np

from ..errors import InvalidInputError
from .evaluation import _unwrap, curve_derivatives, sample_parameters, surface_derivatives
from .geometry import BSplineCurve, BSplineSurface
from .gram import gram_matrix, quadrature_rule


# -- fairness -----------------------------------------------------------------------------------
def _as3(x):
    """Points or vectors with 3 coordinates along the last axis (planar ones in z = 0)."""
    if x.shape[-1] == 3:
        return x
    return np.concatenate([x, np.zeros(x.shape[:-1] + (3 - x.shape[-1],))], axis=-1)


def curve_curvature(curve, u):
    r"""Curvature :math:`\kappa` and torsion :math:`\tau` at parameters ``u``.

    .. math:: \kappa = \frac{|C'\times C''|}{|C'|^3}, \qquad
              \tau = \frac{(C'\times C'')\cdot C'''}{|C'\times C''|^2}

    (``tau`` is 0 where ``kappa`` vanishes and for planar curves).

    Returns
    -------
    kappa, tau : ndarray, shape (len(u),)
    """
    d = curve_derivatives(curve, u, 3)
    d1, d2, d3 = (_as3(x) for x in d[1:4])
    cross = np.cross(d1, d2)
    cn2 = np.einsum("qd,qd->q", cross, cross)
    speed = np.linalg.norm(d1, axis=1)
    kappa = np.sqrt(cn2) / np.maximum(speed, 1e-300) ** 3
    small = cn2 <= 1e-24 * np.maximum(speed, 1e-300) ** 6
    tau = np.where(small, 0.0, np.einsum("qd,qd->q", cross, d3) / np.where(small, 1.0, cn2))
    return kappa, tau


def _curvature_rate(curve, u):
    r""":math:`d\kappa/dt` and the speed :math:`|C'|` at ``u``."""
    d = curve_derivatives(curve, u, 3)
    d1, d2, d3 = (_as3(x) for x in d[1:4])
    cross = np.cross(d1, d2)
    cn = np.maximum(np.linalg.norm(cross, axis=1), 1e-300)
    speed = np.maximum(np.linalg.norm(d1, axis=1), 1e-300)
    dcross = np.cross(d1, d3)
    rate = (np.einsum("qd,qd->q", cross, dcross) / (cn * speed ** 3)
            - 3.0 * cn * np.einsum("qd,qd->q", d1, d2) / speed ** 5)
    return rate, speed


def curvature_derivative_energy(curve, points_per_span=8):
    r""":math:`\int (d\kappa/ds)^2\, ds = \int (d\kappa/dt)^2 / |C'|\, dt`.

    Gauss-Legendre with ``points_per_span`` nodes per knot span (the integrand is
    rational, so this is a quadrature, accurate to the rounding for smooth spans).
    """
    nodes, weights = quadrature_rule(curve.space.breakpoints, points_per_span)
    rate, speed = _curvature_rate(curve, nodes)
    return float(np.sum(weights * rate ** 2 / speed))


def curvatures_from_derivatives(su, sv, suu, suv, svv):
    r"""Principal, mean and Gaussian curvature from the partial derivatives of a surface.

    With the first fundamental form :math:`E = S_u\cdot S_u`, :math:`F = S_u\cdot S_v`,
    :math:`G = S_v\cdot S_v`, the unit normal :math:`n = S_u\times S_v/|S_u\times S_v|`
    and the second fundamental form :math:`L = S_{uu}\cdot n`, :math:`M = S_{uv}\cdot n`,
    :math:`N = S_{vv}\cdot n`:

    .. math::
        K = \frac{LN - M^2}{EG - F^2}, \qquad H = \frac{EN - 2FM + GL}{2(EG - F^2)},
        \qquad \kappa_{1,2} = H \pm \sqrt{H^2 - K}

    (the sign of :math:`H` follows the normal :math:`S_u \times S_v`).

    Parameters
    ----------
    su, sv, suu, suv, svv : ndarray, shape (..., d)
        Derivatives at the same points, ``d`` = 2 or 3 (planar surfaces lie in z = 0).

    Returns
    -------
    dict
        ``k1``, ``k2``, ``mean``, ``gaussian`` and ``area_element``
        (:math:`\sqrt{EG - F^2}`), each of shape (...).  Where the surface is singular
        (:math:`|S_u\times S_v|` below 1e-14 of its largest value) the curvatures are NaN.
    """
    su, sv, suu, suv, svv = (_as3(np.asarray(x, dtype=float)) for x in (su, sv, suu, suv, svv))
    cross = np.cross(su, sv)
    norm = np.linalg.norm(cross, axis=-1)
    e_, f_, g_ = (np.einsum("...i,...i", a, b) for a, b in ((su, su), (su, sv), (sv, sv)))
    det = e_ * g_ - f_ ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        n = cross / norm[..., None]
        l_, m_, n_ = (np.einsum("...i,...i", a, n) for a in (suu, suv, svv))
        gaussian = (l_ * n_ - m_ ** 2) / det
        mean = (e_ * n_ - 2 * f_ * m_ + g_ * l_) / (2 * det)
    singular = norm <= 1e-14 * max(1.0, float(np.nanmax(norm, initial=0.0)))
    mean[singular] = np.nan
    gaussian[singular] = np.nan
    root = np.sqrt(np.maximum(mean * mean - gaussian, 0.0))
    return {"k1": mean + root, "k2": mean - root, "mean": mean, "gaussian": gaussian,
            "area_element": np.sqrt(np.maximum(det, 0.0))}


def surface_curvatures(surface, u, v):
    r"""Principal, mean and Gaussian curvature at points ``(u_i, v_i)``.

    See :func:`curvatures_from_derivatives` (NaN at singular points).

    Returns
    -------
    dict with ``k1``, ``k2``, ``mean``, ``gaussian`` : ndarray, shape (len(u),)
    """
    s = surface_derivatives(surface, u, v, 2)
    c = curvatures_from_derivatives(*(s[key] for key in ((1, 0), (0, 1), (2, 0), (1, 1), (0, 2))))
    return {key: c[key] for key in ("k1", "k2", "mean", "gaussian")}


def grid_curvatures(surface, u, v):
    r"""Mean and Gaussian curvature of a surface on the grid ``u x v``.

    Parameters
    ----------
    surface : BSplineSurface
        Any object with ``evaluate_grid(u, v, nu, nv) -> (len(u), len(v), 3)``.
    u, v : array_like, shape (n_u,), (n_v,)
        Parameters inside the surface's domain.

    Returns
    -------
    dict
        ``points`` (n_u, n_v, 3); ``mean``, ``gaussian`` and ``area_element`` (n_u, n_v)
        as in :func:`curvatures_from_derivatives` (NaN where the surface is singular).
    """
    def d(a, b):
        return surface.evaluate_grid(u, v, a, b)

    c = curvatures_from_derivatives(d(1, 0), d(0, 1), d(2, 0), d(1, 1), d(0, 2))
    return {"points": d(0, 0), "mean": c["mean"], "gaussian": c["gaussian"],
            "area_element": c["area_element"]}


def box_fairness(surface, box=None, density=60):
    r"""Fairness of a surface over a UV box: bending energy, curvature range, wiggles.

    * ``bending_energy``: the thin-plate energy
      :math:`\iint |S_{uu}|^2 + 2|S_{uv}|^2 + |S_{vv}|^2 \,du\,dv` by the midpoint
      rule on a ``density x density`` grid over the box (a parametric measure; compare a
      face with itself before and after; :func:`bending_energy` integrates the whole
      domain exactly).
    * ``mean_curvature_range``, ``gaussian_curvature_range``: ``(min, max)`` of
      :math:`H` and :math:`K` on the grid (NaN at singular points ignored).
    * ``wiggles``: sign changes of :math:`H` along the iso-lines of both directions,
      averaged per iso-line, values below 1e-6 of the largest :math:`|H|` counting as
      no sign (a calm surface has few; noise adds many).

    Parameters
    ----------
    surface : BSplineSurface
    box : ((u0, u1), (v0, v1)), optional
        Defaults to the surface's domain (pass a trimmed face's UV bounds).
    density : int
        Samples per side.

    Returns
    -------
    dict of float / (float, float)
    """
    box = surface.domain if box is None else box
    (u0, u1), (v0, v1) = box
    # midpoints keep away from the boundary, where curvature of noisy data is wildest
    u = u0 + (np.arange(density) + 0.5) * (u1 - u0) / density
    v = v0 + (np.arange(density) + 0.5) * (v1 - v0) / density
    second = [surface.evaluate_grid(u, v, a, b) for a, b in ((2, 0), (1, 1), (0, 2))]
    density_sq = sum(w * np.einsum("...i,...i", s, s) for w, s in zip((1, 2, 1), second))
    energy = float(density_sq.mean() * (u1 - u0) * (v1 - v0))
    curv = grid_curvatures(surface, u, v)
    mean, gauss = curv["mean"], curv["gaussian"]
    return {
        "bending_energy": energy,
        "mean_curvature_range": _finite_range(mean),
        "gaussian_curvature_range": _finite_range(gauss),
        "wiggles": _iso_line_sign_changes(mean),
    }


def _finite_range(values):
    finite = values[np.isfinite(values)]
    if finite.size == 0:
        return (float("nan"), float("nan"))
    return (float(finite.min()), float(finite.max()))


def _iso_line_sign_changes(values, rel=1e-6):
    """Mean count of sign changes per iso-line of a grid (rows and columns), values up to
    ``rel`` times the largest ``|value|`` (and NaN) counting as no sign."""
    threshold = rel * np.nanmax(np.abs(values), initial=0.0)
    lines = values.shape[0] + values.shape[1]
    total = count_sign_changes(values, threshold) + count_sign_changes(values.T, threshold)
    return total / lines if lines else 0.0


def bending_energy(geometry):
    r"""Exact bending energy of a polynomial curve or surface (Gram matrices of derivatives).

    Curve: :math:`\int|C''|^2 = \sum_d c_d^T G^{(2)} c_d`.  Surface:
    :math:`\sum_d \operatorname{tr}(P_d^T G^{(2)}_u P_d G^{(0)}_v) +
    2\operatorname{tr}(P_d^T G^{(1)}_u P_d G^{(1)}_v) +
    \operatorname{tr}(P_d^T G^{(0)}_u P_d G^{(2)}_v)` with :math:`G^{(\nu)}` the Gram
    matrices of :math:`\nu`-th derivatives.  Rational geometry is integrated by
    Gauss-Legendre quadrature instead (8 nodes per span and direction).
    """
    if isinstance(geometry, BSplineCurve):
        if geometry.is_rational:
            nodes, w = quadrature_rule(geometry.space.breakpoints, 8)
            d2 = curve_derivatives(geometry, nodes, 2)[2]
            return float(np.sum(w * np.einsum("qd,qd->q", d2, d2)))
        g = gram_matrix(geometry.space, nu=2)
        P = geometry.poles
        return float(np.sum(P * (g @ P)))
    if isinstance(geometry, BSplineSurface):
        if geometry.is_rational:
            return _rational_surface_energy(geometry)
        P = geometry.poles
        total = 0.0
        for a, b, w in ((2, 0, 1.0), (1, 1, 2.0), (0, 2, 1.0)):
            gu = gram_matrix(geometry.u_space, nu=a)
            gv = gram_matrix(geometry.v_space, nu=b)
            for d in range(P.shape[2]):
                X = P[:, :, d]
                total += w * float(np.sum(X * (gu @ (gv @ X.T).T)))
        return total
    raise InvalidInputError(f"expected a BSplineCurve or BSplineSurface, got {type(geometry).__name__}.")


def _rational_surface_energy(surface):
    nu_, wu = quadrature_rule(surface.u_space.breakpoints, 8)
    nv_, wv = quadrature_rule(surface.v_space.breakpoints, 8)
    uu, vv = np.meshgrid(nu_, nv_, indexing="ij")
    s = surface_derivatives(surface, uu.ravel(), vv.ravel(), 2)
    dens = sum(c * np.einsum("qd,qd->q", s[k], s[k]) for k, c in (((2, 0), 1), ((1, 1), 2), ((0, 2), 1)))
    return float(np.sum(dens.reshape(uu.shape) * wu[:, None] * wv[None, :]))


def count_sign_changes(values, threshold=0.0):
    """Number of sign changes along the last axis, ignoring ``|values| <= threshold``.

    Returns an int for 1-D input and the sum over rows otherwise.
    """
    x = np.atleast_2d(np.asarray(values, dtype=float))
    total = 0
    for row in x:
        s = np.sign(row[np.abs(row) > threshold])
        total += int(np.count_nonzero(s[1:] != s[:-1]))
    return total


def count_extrema(values, rel_threshold=1e-6):
    """Number of interior local extrema along the last axis (summed over rows).

    Steps smaller than ``rel_threshold`` times the row's range are ignored (rounding
    noise on flat stretches).
    """
    x = np.atleast_2d(np.asarray(values, dtype=float))
    total = 0
    for row in x:
        span = float(row.max() - row.min())
        total += count_sign_changes(np.diff(row), rel_threshold * span)
    return total


def curve_wiggles(curve, per_span=8, reference=None):
    r"""Curvature extrema and inflections of a curve at dense samples.

    Inflections count sign changes of :math:`(C'\times C'')\cdot b`, ``b`` the mean
    binormal (the signed curvature for planar curves).  Samples are ``per_span`` per
    span of ``reference`` (default the curve itself; pass the source to compare a
    faired curve on the same samples).

    Returns
    -------
    dict with ``curvature_extrema`` and ``inflections`` (int)
    """
    u = sample_parameters((reference or curve).space, per_span=per_span)
    kappa, _ = curve_curvature(curve, u)
    d = curve_derivatives(curve, u, 2)
    cross = np.cross(_as3(d[1]), _as3(d[2]))
    b = cross.sum(axis=0)
    b = b / max(np.linalg.norm(b), 1e-300)
    signed = cross @ b
    scale = np.abs(signed).max() if signed.size else 0.0
    return {"curvature_extrema": count_extrema(kappa),
            "inflections": count_sign_changes(signed, 1e-9 * scale)}


def surface_wiggles(surface, per_span=4, reference=None):
    r"""Curvature extrema and normal-curvature sign changes along iso-parameter lines.

    Iso-lines sit at the breakpoints of ``reference`` (default the surface itself;
    pass the source to compare a faired surface on the same lines); along each the
    curvature of the iso-curve and the sign of its normal curvature
    :math:`S_{ww}\cdot n` are sampled ``per_span`` times per span of ``reference``.

    Returns
    -------
    dict with ``curvature_extrema`` and ``inflections`` (int, summed over all iso-lines)
    """
    ref = reference or surface
    u = sample_parameters(ref.u_space, per_span=per_span)
    v = sample_parameters(ref.v_space, per_span=per_span)
    u_lines, v_lines = ref.u_space.breakpoints, ref.v_space.breakpoints
    extrema = inflections = 0
    for fixed, moving, along in ((u_lines, v, "v"), (v_lines, u, "u")):
        if along == "v":
            uu, vv = np.meshgrid(fixed, moving, indexing="ij")
            k1, k2 = (0, 1), (0, 2)
        else:
            vv, uu = np.meshgrid(fixed, moving, indexing="ij")
            k1, k2 = (1, 0), (2, 0)
        s = surface_derivatives(surface, uu.ravel(), vv.ravel(), 2)
        d1, d2 = _as3(s[k1]), _as3(s[k2])
        n = np.cross(_as3(s[(1, 0)]), _as3(s[(0, 1)]))
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        speed = np.maximum(np.linalg.norm(d1, axis=1), 1e-300)
        kappa = (np.linalg.norm(np.cross(d1, d2), axis=1) / speed ** 3).reshape(uu.shape)
        normal_k = (np.einsum("qd,qd->q", d2, n) / speed ** 2).reshape(uu.shape)
        extrema += count_extrema(kappa)
        inflections += count_sign_changes(normal_k, 1e-9 * np.abs(normal_k).max())
    return {"curvature_extrema": int(extrema), "inflections": int(inflections)}


def _curve_fairness(curve, reference):
    u = sample_parameters(reference.space, per_span=8)
    kappa, tau = curve_curvature(curve, u)
    out = {"bending_energy": bending_energy(curve),
           "curvature_min": float(kappa.min()), "curvature_max": float(kappa.max()),
           "torsion_max_abs": float(np.abs(tau).max()),
           "curvature_derivative_energy": curvature_derivative_energy(curve)}
    out.update(curve_wiggles(curve, reference=reference))
    return out


def _surface_fairness(surface, reference):
    u = sample_parameters(reference.u_space, per_span=4)
    v = sample_parameters(reference.v_space, per_span=4)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    c = surface_curvatures(surface, uu.ravel(), vv.ravel())
    out = {"bending_energy": bending_energy(surface),
           "gaussian_min": float(np.nanmin(c["gaussian"])),
           "gaussian_max": float(np.nanmax(c["gaussian"])),
           "mean_abs_max": float(np.nanmax(np.abs(c["mean"]))),
           "principal_abs_max": float(np.nanmax(np.abs([c["k1"], c["k2"]])))}
    out.update(surface_wiggles(surface, reference=reference))
    return out


def fairness_summary(source, faired=None):
    """Fairness figures before and after: ``{name: {"before": x, "after": y}}``.

    Curves: bending energy, curvature min/max, largest torsion, curvature-derivative
    energy, curvature extrema and inflections.  Surfaces: bending energy, Gaussian
    curvature range, largest mean and principal curvature, iso-line wiggles.
    Both are sampled at the same parameters (those of the source), so the counts
    compare like with like.
    """
    source, faired, kind = _unwrap(source, faired)
    measure = _curve_fairness if kind == "curve" else _surface_fairness
    before, after = measure(source, source), measure(faired, source)
    return {key: {"before": before[key], "after": after[key]} for key in before}
