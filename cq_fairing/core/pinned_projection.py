r"""Projection of a face onto its target with its joins pinned to its source.

A trimmed face meets its neighbours along edges that run across its surface, where no
border row of poles can be shared or pinned (:func:`~cq_fairing.core.joint_projection.unholdable`).
Such a face is held by linear equality constraints in its L2 projection instead: with
:math:`S` its source, :math:`T = \sum_{ij} N_i(u) M_j(v) C_{ij}` its target and
:math:`(u_k, v_k)` samples of the p-curves of its join edges,

.. math::
    \min_C \|T - S\|_{L^2}^2 \quad\text{subject to}\quad
    T(u_k, v_k) = S(u_k, v_k), \qquad
    n_k\cdot T_u(u_k, v_k) = n_k\cdot T_v(u_k, v_k) = 0 \ \text{(smooth joins)},

:math:`n_k` the source's unit normal there (so :math:`n_k\cdot S_u = n_k\cdot S_v = 0`:
the target keeps the source's tangent plane).  The objective is the core's exact
projection (:mod:`cq_fairing.core.projection`): its normal equations
:math:`(G_u\otimes G_v)\,C = E_u C_S E_v^T` per coordinate, :math:`G = \langle\Phi|\Phi\rangle`
of the target, :math:`E = \langle\Phi|\Phi_S\rangle`, in coordinates centred on the
source's poles.  A rational source is solved in homogeneous coordinates
:math:`(X, w) = (w (x - c), w)`, where both conditions stay linear: a point is pinned
to the source's homogeneous point, :math:`X = w_S (S - c)` and :math:`w = w_S` (four
rows: then :math:`T = S`), and
:math:`n\cdot T_u = 0 \iff n\cdot X_u - n\cdot(S - c)\,w_u = 0`.  Between the
samples the weights are free: where the rows are more than the target can meet, the
compromise may take them through zero, and the target folds (its normals turn by up to
180 degrees against the source's); :func:`pin_face` measures that as the angle.

Each row is scaled so that its residual is a length: a point row by :math:`1/w_S`, a
tangent row by :math:`\ell / (w_S |S_u|)`, whose residual is then the tilt of
:math:`T_u` out of the source's tangent plane (radians) times the lever :math:`\ell`.
The rows act on all coordinates at once, one regularised KKT system
(:func:`~cq_fairing.core.joins.kkt_solve`): where the rows are dependent or more than the
target can meet (samples closer than its spans resolve), its small regularisation makes
it the least-squares compromise on the rows, and the projection in what they leave free;
:data:`KKT_STEPS` refinements against the unregularised system then hold the rows that
can be met to round-off.

:func:`pin_face` chooses the samples from the target's spans each edge crosses
(the target's degree + 1 per cell of its span grid crossed, at most :data:`CAP` per
edge), solves, and measures the
result where the rows are not imposed: at :data:`DENSE` times the samples, the largest
:math:`|T - S|` and the largest angle between the normals of :math:`T` and :math:`S` on
the smooth edges.  Where either is over its budget the target's spans are halved, at
most :data:`~cq_fairing.core.joint_projection.REFINEMENTS` times.

This module imports numpy and scipy only (and the core).
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .evaluation import surface_derivatives
from .geometry import BSplineSurface, collapsed_kept
from .gram import gram_matrix, sandwiched
from .joins import DEGENERATE, kkt_solve
from .joint_projection import REFINEMENTS, refined_targets
from .results import _centred_coefficients
from .robustness import LocalFrame

__all__ = ["PinnedEdge", "PinnedFace", "project_pinned", "pin_face", "pin_deviation",
           "edge_samples", "GAP", "CAP", "DENSE", "PROBES"]

GAP = 1e-7        # a pinned join may open this x the model's size beyond the source's gap
CAP = 400         # constraint samples per edge at most
DENSE = 10        # measuring samples per constraint sample
PROBES = 1025     # p-curve samples that count the target spans an edge crosses
KKT_STEPS = 6     # refinements of the KKT solve against the unregularised system


@dataclass(frozen=True)
class PinnedEdge:
    """One join edge of a face, as its p-curve.

    Attributes
    ----------
    uv : callable
        ``uv(t)`` for ``t`` (n,) in ``[0, 1]`` (the edge from its start to its end):
        the p-curve's points (n, 2) in the surface's parameters.
    smooth : bool
        The join is smooth: the target keeps the source's tangent plane along it.
    """

    uv: object
    smooth: bool


@dataclass(frozen=True)
class PinnedFace:
    """Outcome of :func:`pin_face`.

    Attributes
    ----------
    surface : BSplineSurface
        The last solve (``None`` where its target's net grew to the source's size).
    refined : int
        Span halvings of the target it took.
    gap : float
        Largest :math:`|T - S|` along the edges, at the measuring samples.
    angle : float
        Largest angle (degrees) between the normals of :math:`T` and :math:`S` along the
        smooth edges.
    met : bool
        ``gap`` and ``angle`` are within their budgets.
    """

    surface: BSplineSurface
    refined: int
    gap: float
    angle: float
    met: bool


def project_pinned(source, target, uv, smooth, lever=1.0):
    r"""The target's poles nearest ``source`` in :math:`L^2` with the samples pinned.

    Parameters
    ----------
    source : BSplineSurface
        Polynomial or rational.
    target : (SplineSpace, SplineSpace)
        On the source's domain.
    uv : numpy.ndarray
        ``(n, 2)`` samples (clipped to the domain); ``n`` may be 0.
    smooth : numpy.ndarray of bool
        ``(n,)``: the samples that also pin the tangent plane (none where the source's
        normal is not defined: :math:`|S_u\times S_v|` below
        :data:`~cq_fairing.core.joins.DEGENERATE` times its largest over the samples).
    lever : float, optional
        The length :math:`\ell` that turns a tangent row's residual (radians) into a
        length (module notes).

    Returns
    -------
    BSplineSurface
        On ``target``, rational where the source is; with no samples the plain L2
        projection.
    """
    frame = LocalFrame.around(source.poles)
    centre = frame.centre
    net = _centred_coefficients(source, centre)
    gram, moments = _projection(source, target, net)
    uv = _clipped(source, np.asarray(uv, float).reshape(-1, 2))
    rows, rhs = _rows(source, target, frame, uv, np.asarray(smooth, bool), lever)
    if rows.shape[0]:
        solution = kkt_solve(gram, rows, moments.reshape(-1, 1), rhs.reshape(-1, 1),
                             KKT_STEPS)
    else:
        solution = spla.splu(sp.csc_matrix(gram)).solve(moments.reshape(-1, 1))
    coefficients = solution.reshape(net.shape[2], *(s.dimension for s in target))
    return _surface(np.moveaxis(coefficients, 0, -1), target, centre, source.is_rational)


def _projection(source, target, net):
    r""":math:`A = I_d\otimes G_u\otimes G_v` and :math:`b` (coordinate-major: all poles
    of the first coordinate first)."""
    tu, tv = target
    block = sp.kron(gram_matrix(tu), gram_matrix(tv), format="csr")
    eu = gram_matrix(tu, source.u_space).toarray()
    ev = gram_matrix(tv, source.v_space).toarray()
    moments = np.moveaxis(sandwiched(eu, net, ev), -1, 0)
    return sp.block_diag([block] * net.shape[2], format="csr"), moments.ravel()


def _clipped(source, uv):
    (u0, u1), (v0, v1) = source.domain
    return np.column_stack([np.clip(uv[:, 0], u0, u1), np.clip(uv[:, 1], v0, v1)])


def _rows(source, target, frame, uv, smooth, lever):
    r"""The constraint rows :math:`C` (sparse, over the coordinate-major unknowns) and
    their right-hand side :math:`d`, each row scaled to a length (module notes)."""
    tu, tv = target
    dimension = 4 if source.is_rational else 3
    count = tu.dimension * tv.dimension
    if not len(uv):
        return sp.csr_matrix((0, dimension * count)), np.zeros(0)
    bu, bv = tu.basis_values(uv[:, 0], 1), tv.basis_values(uv[:, 1], 1)
    point = _products(bu[0], bv[0])
    along = (_products(bu[1], bv[0]), _products(bu[0], bv[1]))
    d = surface_derivatives(source, uv[:, 0], uv[:, 1], 1)
    s, su, sv = d[(0, 0)] - frame.centre, d[(1, 0)], d[(0, 1)]
    weight = _source_weights(source, uv)
    blocks, rhs = [], []
    for k in range(dimension):       # (X, w) = (w_S (S - c), w_S), or P = S - c
        coefficients = [point if j == k else None for j in range(dimension)]
        reach = 1.0 if k < 3 else frame.scale
        blocks.append(_scaled(coefficients, reach / weight))
        rhs.append(reach * (s[:, k] if k < 3 else np.ones(len(uv))))
    normal = np.cross(su, sv)
    length = np.linalg.norm(normal, axis=1)
    tangent = smooth & (length > DEGENERATE * length.max(initial=0.0))
    n = normal[tangent] / length[tangent, None]
    for basis, derivative in zip(along, (su, sv)):   # n.X_d - n.(S - c) w_d = 0
        basis = basis[tangent]
        coefficients = [basis.multiply(n[:, k:k + 1]) for k in range(3)]
        if source.is_rational:
            coefficients.append(basis.multiply(-np.sum(n * s[tangent], axis=1)[:, None]))
        speed = np.linalg.norm(derivative[tangent], axis=1)
        blocks.append(_scaled(coefficients, lever / (weight[tangent] * speed)))
        rhs.append(np.zeros(int(tangent.sum())))
    return sp.vstack(blocks, format="csr"), np.concatenate(rhs)


def _products(bu, bv):
    """Row-wise tensor products ``(n, ku kv)`` of the u and v basis rows, sparse."""
    return sp.csr_matrix(np.einsum("ni,nj->nij", bu, bv).reshape(len(bu), -1))


def _scaled(coefficients, scale):
    """One block of rows over the coordinates (``None``: no coefficient there), each row
    times ``scale``."""
    count = next(c for c in coefficients if c is not None).shape
    parts = [sp.csr_matrix(count) if c is None else sp.csr_matrix(c) for c in coefficients]
    return sp.diags(scale) @ sp.hstack(parts, format="csr")


def _source_weights(source, uv):
    """The source's weight function at ``uv`` (1 for a polynomial source)."""
    if not source.is_rational:
        return np.ones(len(uv))
    w = source.u_space.collocation(uv[:, 0]) @ source.weights
    return np.einsum("nj,nj->n", w, source.v_space.collocation(uv[:, 1]).toarray())


def _surface(coefficients, target, centre, rational):
    tu, tv = target
    if rational:
        w = coefficients[..., -1]
        poles = coefficients[..., :-1] / np.where(w == 0, 1.0, w)[..., None] + centre
        return BSplineSurface(poles, tu.knots, tv.knots, tu.degree, tv.degree, w)
    return BSplineSurface(coefficients + centre, tu.knots, tv.knots, tu.degree, tv.degree)


def edge_samples(edge, target, cap=CAP):
    """Parameters ``t`` (uniform on ``[0, 1]``) of the constraint samples along ``edge``:
    the target's degree + 1 per cell of the target's span grid the p-curve
    crosses (counted at :data:`PROBES` points), at most ``cap``."""
    uv = np.asarray(edge.uv(np.linspace(0.0, 1.0, PROBES)), float)
    cells = [np.searchsorted(s.breakpoints[1:-1], np.clip(uv[:, a], *s.domain), side="right")
             for a, s in enumerate(target)]
    crossed = 1 + np.count_nonzero((np.diff(cells[0]) != 0) | (np.diff(cells[1]) != 0))
    degree = max(s.degree for s in target)
    return np.linspace(0.0, 1.0, min(cap, (degree + 1) * crossed))


def pin_deviation(surface, source, uv, smooth):
    """``(gap, angle)``: the largest :math:`|T - S|` at ``uv`` (n, 2) and the largest
    angle (degrees) between the two normals at the samples of ``smooth`` where the
    source's normal is defined (:data:`~cq_fairing.core.joins.DEGENERATE`)."""
    uv = _clipped(source, np.asarray(uv, float).reshape(-1, 2))
    if not len(uv):
        return 0.0, 0.0
    ds, dt = (surface_derivatives(s, uv[:, 0], uv[:, 1], 1) for s in (source, surface))
    gap = float(np.linalg.norm(dt[(0, 0)] - ds[(0, 0)], axis=1).max())
    ns, nt = (np.cross(d[(1, 0)], d[(0, 1)]) for d in (ds, dt))
    length = np.linalg.norm(ns, axis=1)
    keep = np.asarray(smooth, bool) & (length > DEGENERATE * length.max(initial=0.0))
    if not keep.any():
        return gap, 0.0
    ns, nt = ns[keep], nt[keep]
    angles = np.degrees(np.arctan2(np.linalg.norm(np.cross(ns, nt), axis=1),
                                   np.einsum("nk,nk->n", ns, nt)))
    return gap, float(angles.max())


def pin_face(source, target, edges, gap, angle, refinements=REFINEMENTS):
    """Project ``source`` onto ``target`` with ``edges`` pinned (:func:`project_pinned`),
    measured at :data:`DENSE` times the constraint samples; the target's spans halved
    where the gap or the angle is over its budget, ``refinements`` times at most.

    Parameters
    ----------
    source : BSplineSurface
    target : (SplineSpace, SplineSpace)
        The face's own target (its tolerance search), on the source's domain.
    edges : sequence of PinnedEdge
    gap : float
        Largest :math:`|T - S|` allowed along the edges (model units).
    angle : float
        Largest normal angle (degrees) allowed along the smooth edges; with ``gap`` it
        sets the tangent rows' lever :math:`\\ell = ` ``gap`` / ``angle`` (radians).
    refinements : int, optional

    Returns
    -------
    PinnedFace
        The surface has the source's collapsed border rows put back on their points
        (:func:`~cq_fairing.core.geometry.collapsed_kept`).
    """
    lever = gap / np.radians(angle)
    for refined in range(refinements + 1):
        spaces = refined_targets(target, refined)
        if np.prod([s.dimension for s in spaces]) >= np.prod(source.shape):
            return PinnedFace(None, refined, np.inf, np.inf, False)
        pinned, measured = _samples(edges, spaces)
        surface = collapsed_kept(source, project_pinned(source, spaces, *pinned, lever))
        got_gap, got_angle = pin_deviation(surface, source, *measured)
        if got_gap <= gap and got_angle <= angle:
            break
    return PinnedFace(surface, refined, got_gap, got_angle,
                      got_gap <= gap and got_angle <= angle)


def _samples(edges, spaces):
    """``((uv, smooth), (uv, smooth))``: the constraint samples of every edge, and the
    measuring ones (:data:`DENSE` times as many)."""
    pinned, measured = [], []
    for edge in edges:
        t = edge_samples(edge, spaces)
        dense = np.linspace(0.0, 1.0, DENSE * (len(t) - 1) + 1)
        for out, ts in ((pinned, t), (measured, dense)):
            out.append((np.asarray(edge.uv(ts), float), np.full(len(ts), edge.smooth)))
    return tuple((np.concatenate([uv for uv, _ in part]).reshape(-1, 2),
                  np.concatenate([s for _, s in part]).astype(bool))
                 for part in (pinned, measured))
