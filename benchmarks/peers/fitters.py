"""The fitters compared by bench_peers.py, all on the same inputs and tolerance.

A :class:`Case` carries the input points (curve: (N, 3); surface: grid (Nu, Nv, 3)) with
their parameters, the source B-spline (the interpolant of the points, or a real face's
surface), and ``tol``.  Point fitters search their own knob (OCCT ``Tol3D``, FITPACK
``s``, geomdl ``ctrlpts_size``, least-squares span count) until every input point lies
within ``tol`` of the fit (closest-point distance); our methods fair the source's net.
Each fitter returns ``(geometry, setting)`` with ``geometry`` a core BSplineCurve /
BSplineSurface.
"""

import dataclasses
from dataclasses import dataclass

import numpy as np
import scipy.interpolate as si
import scipy.sparse.linalg as spla

import cq_fairing as cf
from cq_fairing.core.adaptive import fair_curve_adaptive, fair_surface_adaptive
from cq_fairing.core.geometry import BSplineCurve, BSplineSurface
from cq_fairing.core.spaces import SplineSpace

from .measure import points_to_curve, points_to_surface


@dataclass
class Case:
    name: str
    kind: str            # "curve" or "surface"
    points: np.ndarray   # (N, 3) or (Nu, Nv, 3)
    params: tuple        # (u,) or (u, v) of the points
    source: object       # core BSplineCurve / BSplineSurface
    tol: float
    truth: object = None


def within(case, geometry):
    """Largest closest-point distance of the input points to ``geometry``."""
    pts = case.points.reshape(-1, 3)
    if case.kind == "curve":
        return float(points_to_curve(geometry, pts).max())
    return float(points_to_surface(geometry, pts).max())


def _bisect(lo_fail, hi_pass, ok):
    while hi_pass - lo_fail > 1:
        mid = (lo_fail + hi_pass) // 2
        if ok(mid):
            hi_pass = mid
        else:
            lo_fail = mid
    return hi_pass


# -- OCCT -----------------------------------------------------------------------------------
def _occ_curve(c):
    n = c.NbPoles()
    poles = np.array([[c.Pole(i).X(), c.Pole(i).Y(), c.Pole(i).Z()] for i in range(1, n + 1)])
    knots = np.repeat([c.Knot(i) for i in range(1, c.NbKnots() + 1)],
                      [c.Multiplicity(i) for i in range(1, c.NbKnots() + 1)])
    w = np.array([c.Weight(i) for i in range(1, n + 1)]) if c.IsRational() else None
    return BSplineCurve(poles, knots, c.Degree(), w)


def _occ_surface(s):
    from cq_fairing.occ.convert import _full_knots, _net

    net, w = _net(s)
    return BSplineSurface(net, _full_knots(s, "u"), _full_knots(s, "v"), s.UDegree(),
                          s.VDegree(), w)


def _occ_points(case):
    from OCP.gp import gp_Pnt
    from OCP.TColgp import TColgp_Array1OfPnt, TColgp_Array2OfPnt

    if case.kind == "curve":
        arr = TColgp_Array1OfPnt(1, len(case.points))
        for i, p in enumerate(case.points, 1):
            arr.SetValue(i, gp_Pnt(*map(float, p)))
        return arr
    nu, nv = case.points.shape[:2]
    arr = TColgp_Array2OfPnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            arr.SetValue(i + 1, j + 1, gp_Pnt(*map(float, case.points[i, j])))
    return arr


def occt_fit(case, smoothing=None, tries=6, degmax=8):
    """GeomAPI_PointsToBSpline(Surface): OCCT chooses degree (3..8), poles and knots for Tol3D.

    ``smoothing=(w1, w2, w3)`` uses the variational ``Init`` (length, curvature, torsion
    weights).  ``Tol3D`` starts at ``tol`` and shrinks by 0.7 until the points are within.
    """
    from OCP.GeomAbs import GeomAbs_Shape
    from OCP.GeomAPI import GeomAPI_PointsToBSpline, GeomAPI_PointsToBSplineSurface

    arr = _occ_points(case)
    cls = GeomAPI_PointsToBSpline if case.kind == "curve" else GeomAPI_PointsToBSplineSurface
    tol3d, geom = case.tol, None
    for _ in range(tries):
        api = cls()
        if smoothing is None:
            api.Init(arr, 3, degmax, GeomAbs_Shape.GeomAbs_C2, tol3d)
        else:
            api.Init(arr, *smoothing, 8, GeomAbs_Shape.GeomAbs_C2, tol3d)
        if not api.IsDone():
            raise RuntimeError("OCCT approximation failed")
        geom = _occ_curve(api.Curve()) if case.kind == "curve" else _occ_surface(api.Surface())
        if within(case, geom) <= case.tol:
            break
        tol3d *= 0.7
    return geom, f"Tol3D={tol3d:.3g}"


def occt_variational(case, weights=(1e-2, 1e-4, 1e-6, 1e-8)):
    """Variational smoothing ``Init(points, 0, w, 0, 8, C2, tol)``: the largest curvature
    weight ``w`` of the list whose result keeps the points within tol."""
    geom = None
    for w in weights:
        geom, _ = occt_fit(case, smoothing=(0.0, w, 0.0), tries=1)
        if within(case, geom) <= case.tol:
            return geom, f"W2={w:g}"
    return geom, f"W2={weights[-1]:g} (tol not met)"


# -- scipy FITPACK --------------------------------------------------------------------------
def _core_from_bspline(spl):
    return BSplineCurve(np.asarray(spl.c), np.asarray(spl.t), spl.k)


def fitpack_curve(case, steps=14):
    """make_splprep with the smoothing ``s = f N tol^2``, f bisected on a log scale."""
    x, u = case.points.T, case.params[0]
    n = len(case.points)

    def fit(f):
        spl, _ = si.make_splprep(x, u=u, s=f * n * case.tol ** 2, k=3)
        return _core_from_bspline(spl)

    lo, hi, best = -8.0, 1.0, None
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        g = fit(10.0 ** mid)
        if within(case, g) <= case.tol:
            best, lo = (g, 10.0 ** mid), mid
        else:
            hi = mid
    if best is None:
        best = (fit(0.0), 0.0)
    return best[0], f"s={best[1]:.3g}*N*tol^2"


def _union(*knot_vectors):
    """Merged knot vector keeping the largest multiplicity of every value."""
    values = np.unique(np.concatenate(knot_vectors))
    mult = np.max([[np.count_nonzero(np.isclose(t, x, rtol=0, atol=1e-12)) for x in values]
                   for t in knot_vectors], axis=0)
    return np.repeat(values, mult)


def fitpack_surface(case, steps=12):
    """RectBivariateSpline per coordinate with ``s = f Nu Nv tol^2``; joined on union knots."""
    u, v = case.params
    g = case.points
    nu, nv = g.shape[:2]

    def fit(f):
        splines = [si.RectBivariateSpline(u, v, g[..., c], s=f * nu * nv * case.tol ** 2)
                   for c in range(3)]
        tx = _union(*[s.tck[0] for s in splines])
        ty = _union(*[s.tck[1] for s in splines])
        su, sv = SplineSpace(3, tx), SplineSpace(3, ty)
        gu, gv = su.greville, sv.greville
        vals = np.stack([s(gu, gv) for s in splines], axis=2)
        cu = spla.splu(su.collocation(gu).tocsc())
        cv = spla.splu(sv.collocation(gv).tocsc())
        x = cu.solve(vals.reshape(len(gu), -1)).reshape(len(gu), len(gv), 3)
        y = cv.solve(np.swapaxes(x, 0, 1).reshape(len(gv), -1)).reshape(len(gv), len(gu), 3)
        return BSplineSurface(np.swapaxes(y, 0, 1), tx, ty, 3, 3)

    lo, hi, best = -8.0, 1.0, None
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        s = fit(10.0 ** mid)
        if within(case, s) <= case.tol:
            best, lo = (s, 10.0 ** mid), mid
        else:
            hi = mid
    if best is None:
        best = (fit(0.0), 0.0)
    return best[0], f"s={best[1]:.3g}*N*tol^2"


GEOMDL_CAP = 256  # geomdl is pure Python: its ctrlpts search starts at most here


# -- geomdl ---------------------------------------------------------------------------------
def geomdl_fit(case):
    """fitting.approximate_curve / approximate_surface, ctrlpts_size bisected."""
    from geomdl import fitting

    if case.kind == "curve":
        pts = case.points.tolist()

        def fit(n):
            c = fitting.approximate_curve(pts, 3, ctrlpts_size=n)
            return BSplineCurve(np.array(c.ctrlpts), np.array(c.knotvector), 3)

        cache = {}

        def ok(n):
            cache[n] = fit(n)
            return within(case, cache[n]) <= case.tol

        top = min(len(pts) - 1, GEOMDL_CAP)
        n = _bisect(3, top, ok) if ok(top) else top
        return cache.get(n) or fit(n), f"ctrlpts={n}"
    nu, nv = case.points.shape[:2]
    flat = case.points.reshape(-1, 3).tolist()

    def fit_s(k):
        a = max(4, round(k * (nu - 1) / max(nu, nv)))
        b = max(4, round(k * (nv - 1) / max(nu, nv)))
        s = fitting.approximate_surface(flat, nu, nv, 3, 3, ctrlpts_size_u=a, ctrlpts_size_v=b)
        net = np.array(s.ctrlpts).reshape(a, b, 3)
        return BSplineSurface(net, np.array(s.knotvector_u), np.array(s.knotvector_v), 3, 3)

    cache = {}

    def ok_s(k):
        cache[k] = fit_s(k)
        return within(case, cache[k]) <= case.tol

    top = min(max(nu, nv) - 1, GEOMDL_CAP // 4)
    k = _bisect(4, top, ok_s) if ok_s(top) else top
    return cache.get(k) or fit_s(k), f"k={k}"


# -- plain least squares on uniform knots --------------------------------------------------------
def lsq_uniform(case):
    """Least-squares cubic on quasi-uniform knots at the points' parameters, span count bisected."""
    if case.kind == "curve":
        u = case.params[0]

        def fit(n):
            space = SplineSpace.quasi_uniform(n, 3, (u[0], u[-1]))
            a = space.collocation(u)
            poles = spla.spsolve((a.T @ a).tocsc(), a.T @ case.points)
            return BSplineCurve(np.asarray(poles), space.knots, 3)

        top = len(u) // 2  # well inside Schoenberg-Whitney; higher counts are ill-conditioned
    else:
        u, v = case.params
        nu, nv = case.points.shape[:2]

        def fit(k):
            a = max(1, round(k * (nu - 3) / max(nu, nv)))
            b = max(1, round(k * (nv - 3) / max(nu, nv)))
            su = SplineSpace.quasi_uniform(a, 3, (u[0], u[-1]))
            sv = SplineSpace.quasi_uniform(b, 3, (v[0], v[-1]))
            au, av = su.collocation(u), sv.collocation(v)
            x = spla.spsolve((au.T @ au).tocsc(), au.T @ case.points.reshape(nu, -1))
            x = np.asarray(x).reshape(su.dimension, nv, 3)
            y = spla.spsolve((av.T @ av).tocsc(), av.T @ np.swapaxes(x, 0, 1).reshape(nv, -1))
            y = np.asarray(y).reshape(sv.dimension, su.dimension, 3)
            return BSplineSurface(np.swapaxes(y, 0, 1), su.knots, sv.knots, 3, 3)

        top = max(nu, nv) // 2
    cache = {}

    def ok(n):
        cache[n] = fit(n)
        return within(case, cache[n]) <= case.tol

    n = _bisect(0, top, ok) if ok(top) else top
    return cache[n], f"n={n}"


# -- ours ------------------------------------------------------------------------------------------
def wavelet_uniform(case):
    s = case.source
    if case.kind == "curve":
        r = cf.fair_curve(s.poles, tol=case.tol, knots=s.knots, degree=s.degree, weights=s.weights,
                          method="wavelet")
        return r.curve, f"n={r.n}"
    r = cf.fair_surface(s.poles, tol=case.tol, u_knots=s.u_knots, v_knots=s.v_knots,
                        degree=(s.u_degree, s.v_degree), weights=s.weights)
    return r.surface, f"n={r.n}"


def default(case):
    """The core's default with only ``tol`` given (curves: the chosen fit, named)."""
    s = case.source
    if case.kind == "curve":
        r = cf.fair_curve(s.poles, tol=case.tol, knots=s.knots, degree=s.degree,
                          weights=s.weights)
        chosen = " ".join(str(value) for value in r.choice.values())
        return r.curve, f"{chosen} n={r.n}"
    r = cf.fair_surface(s.poles, tol=case.tol, u_knots=s.u_knots, v_knots=s.v_knots,
                        degree=(s.u_degree, s.v_degree), weights=s.weights)
    return r.surface, f"n={r.n}"


def wavelet_adaptive(case, degree=None, objective="compact", borders=None):
    # a fresh source object per run: its evaluation caches (Taylor form, extent) are part
    # of the work, as they are for a user fairing a face once
    source = dataclasses.replace(case.source)
    if case.kind == "curve":
        r = fair_curve_adaptive(source, case.tol, target_degree=degree, objective=objective)
    else:
        r = fair_surface_adaptive(source, case.tol, target_degree=degree,
                                  objective=objective, borders=borders or "auto")
    table = dict(r.table)
    noise = f" noise={table['noise']:.2g}" if "noise" in table else ""
    border = f" {table['borders']}" if "borders" in table else ""
    weight = (f" span weight<={table['span weight']:.2g}"
              if table.get("span weight", 1.0) > 1.0 else "")
    return (r.curve if case.kind == "curve" else r.surface,
            f"n={r.n} lambda={table['lambda']:.2g}{weight}{noise}{border}")


def energy(case):
    s = case.source
    if case.kind == "curve":
        r = cf.fair_curve(s.poles, tol=case.tol, knots=s.knots, degree=s.degree,
                          weights=s.weights, method="energy")
        return r.curve, f"steps={r.evaluations}"
    r = cf.fair_surface(s.poles, tol=case.tol, u_knots=s.u_knots, v_knots=s.v_knots,
                        degree=(s.u_degree, s.v_degree), weights=s.weights, method="energy")
    return r.surface, f"sweeps={r.evaluations}"


METHODS = {
    "OCCT PointsToBSpline": occt_fit,
    "OCCT PointsToBSpline p3": lambda case: occt_fit(case, degmax=3),
    "OCCT variational": lambda case: occt_variational(case),
    "scipy FITPACK": lambda case: (fitpack_curve if case.kind == "curve" else fitpack_surface)(case),
    "geomdl approximate": geomdl_fit,
    "LSQ uniform": lsq_uniform,
    "ours energy (EH)": energy,
    "ours default": default,
    "ours wavelet uniform": wavelet_uniform,
    "ours wavelet adaptive": wavelet_adaptive,
    "ours wavelet adaptive free": lambda case: wavelet_adaptive(case, borders="free"),
    "ours wavelet adaptive p5": lambda case: wavelet_adaptive(case, degree=5),
    "ours wavelet faithful p5": lambda case: wavelet_adaptive(case, 5, "faithful"),
    "ours wavelet faithful p7": lambda case: wavelet_adaptive(case, 7, "faithful"),
    "ours wavelet fair": lambda case: wavelet_adaptive(case, objective="fair"),
    "ours wavelet fair p5": lambda case: wavelet_adaptive(case, 5, "fair"),
}
