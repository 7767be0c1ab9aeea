"""Naive, dense, obviously-correct reference implementations for the core tests.

Basis functions come from scipy's BSpline (not from cq_fairing), integrals from
high-order Gauss-Legendre on every merged knot interval, solves are dense.
"""

import numpy as np
import scipy.linalg as la
from scipy.interpolate import BSpline


def basis_matrix(knots, degree, x, nu=0):
    """Dense (len(x), k) matrix of basis functions (scipy BSpline, one per column)."""
    k = len(knots) - degree - 1
    out = np.empty((len(x), k))
    for i in range(k):
        c = np.zeros(k)
        c[i] = 1.0
        out[:, i] = BSpline(knots, c, degree, extrapolate=False)(x, nu)
    # BSpline(extrapolate=False) gives nan exactly at the right end: use the limit
    right = np.isclose(x, knots[-1])
    if np.any(right):
        for i in range(k):
            c = np.zeros(k)
            c[i] = 1.0
            out[right, i] = BSpline(knots, c, degree)(x[right] - 1e-14 * (knots[-1] - knots[0]), nu)
    return np.nan_to_num(out)


def dense_gram(knots_a, deg_a, knots_b, deg_b, nu=0, points=12):
    """<N^a_i, N^b_j> by 12-point Gauss per merged interval (exact for degree <= 23)."""
    merged = np.union1d(knots_a, knots_b)
    gx, gw = np.polynomial.legendre.leggauss(points)
    xs, ws = [], []
    for a, b in zip(merged[:-1], merged[1:]):
        if b - a <= 1e-15:
            continue
        xs.append(0.5 * (a + b) + 0.5 * (b - a) * gx)
        ws.append(0.5 * (b - a) * gw)
    x, w = np.concatenate(xs), np.concatenate(ws)
    Ba = basis_matrix(knots_a, deg_a, x, nu)
    Bb = basis_matrix(knots_b, deg_b, x, nu)
    return Ba.T @ (w[:, None] * Bb)


def dense_coarse(src_knots, src_deg, tgt_knots, tgt_deg, coefficients):
    """C_n = G_nn^{-1} G_nS C_S with dense matrices."""
    g_nn = dense_gram(tgt_knots, tgt_deg, tgt_knots, tgt_deg)
    g_ns = dense_gram(tgt_knots, tgt_deg, src_knots, src_deg)
    return la.solve(g_nn, g_ns @ coefficients, assume_a="pos")


def quasi_uniform_knots(n, degree=3):
    return np.concatenate([np.zeros(degree), np.linspace(0, 1, n + 1), np.ones(degree)])


def random_clamped_knots(rng, k, degree):
    inner = np.sort(rng.uniform(0.02, 0.98, k - degree - 1))
    return np.concatenate([np.zeros(degree + 1), inner, np.ones(degree + 1)])


def trapezoid(y, x):
    """The trapezoidal rule: np.trapezoid on numpy >= 2, np.trapz on FreeCAD's numpy 1.24."""
    return (np.trapezoid if hasattr(np, "trapezoid") else np.trapz)(y, x)
