r"""Energy fairing of a network of patches: fair across the joins, each patch in its own
parametrization.

Patches that are already at their coarsest (a bicubic patch of one span) leave a
projection nothing to remove, and patches whose parametrizations do not match across
their joins cannot be merged into one smooth surface without sliding along it.  Such a
network is faired as a whole by the thin-plate energy of every patch in its own
parameters, under the joins' constraints (Eck and Hadenfeld's energy fairing, with the
tolerance as its bound):

.. math:: \min_{C} \sum_f (C_f - P_f)^T M_f (C_f - P_f) + \lambda\, s_f\, C_f^T H_f C_f
          \quad\text{subject to}\quad A C = 0,

with :math:`M_f = G_u\otimes G_v` the patch's L2 Gram matrix (so the first term is
:math:`\iint |T_f - S_f|^2`), :math:`H_f = G''_u\otimes G_v + 2 G'_u\otimes G'_v +
G_u\otimes G''_v` its thin-plate energy, :math:`s_f = \mathrm{tr} M_f / \mathrm{tr} H_f`
the scale that makes one :math:`\lambda` mean the same on patches of any size, and
:math:`A` the joins:

* **G0**: the two border rows of a join are one row, pole for pole (the patches share
  their knots and degree along the join);
* **G1** at smooth joins: the cross rows mirror each other,
  :math:`w_{a,i} + \mu w_{b,i} = 0`, :math:`w = c_{inner} - c_{border}`, with one
  :math:`\mu` per join (the geometric mean of the source's length ratios), which makes
  the tangent planes agree along the whole join
  (:mod:`cq_fairing.core.joins`, step 5).  A row that would close a cycle of rows (around
  a vertex) is left out.

The borders move with the patches: the energy runs across the joins.  :math:`\lambda`
is the largest (bisection on its logarithm) for which every patch stays within the
tolerance of its source by the same-parameter distance on :data:`SAMPLES` x
:data:`SAMPLES` points, an upper bound of the true distance.  One regularised KKT
system, one factorization per :math:`\lambda` for x, y and z.

This module imports numpy and scipy only.
"""

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import InvalidInputError
from .geometry import BSplineSurface, folded
from .gram import gram_matrix
from .joins import UnionFind, mirror_ratio, turned_patches
from .patch_grid import insert_knot

__all__ = ["NetworkResult", "fair_network", "network_joinable"]

SAMPLES = 9          # same-parameter samples per patch and direction
KKT_EPS = 1e-12      # regularisation of the constraint block (relative)
HELD = -1            # the class of every kept pole in the constraints' union-find
LAMBDA_RANGE = (1e-8, 1e4)
BISECTIONS = 10
KNOT_TOLERANCE = 1e-9


@dataclass(frozen=True)
class NetworkResult:
    """Outcome of :func:`fair_network`.

    Attributes
    ----------
    surfaces : list of BSplineSurface
        The faired patches, each on its source's spaces with a one-span direction's
        span halved (kept ones: the source).
    smoothing : float
        The :math:`\\lambda` used (0 when even the constrained projection alone is over
        the tolerance somewhere: then ``surfaces`` are the sources).
    deviations : numpy.ndarray
        Each patch's largest same-parameter distance from its source on the samples.
    g1_rows : int
        Mirrored-row constraints imposed.
    kept : set of int
        The patches that kept their surfaces: those asked for, and those the joins would
        hold out of their tolerance even without energy (they then constrain their
        neighbours instead).
    """

    surfaces: list
    smoothing: float
    deviations: np.ndarray
    g1_rows: int
    kept: set


def network_joinable(a, side_a, b, side_b, reversed_):
    """True when the two patches share degree and normalised knots along the join, so
    their border rows can be one row pole for pole."""
    space_a = a.v_space if side_a[0] == "u" else a.u_space
    space_b = b.v_space if side_b[0] == "u" else b.u_space
    if space_a.degree != space_b.degree or space_a.dimension != space_b.dimension:
        return False
    ka, kb = (_unit(space_a.knots), _unit(space_b.knots))
    if reversed_:
        kb = 1.0 - kb[::-1]
    return bool(np.abs(ka - kb).max() <= KNOT_TOLERANCE)


def _unit(knots):
    return (knots - knots[0]) / (knots[-1] - knots[0])


def fair_network(patches, joins, tol, *, kept=(), continuity="G1"):
    """Fair a network of patches jointly by thin-plate energy within ``tol``.

    Parameters
    ----------
    patches : sequence of BSplineSurface
        Polynomial patches; each is faired on its own spaces.
    joins : sequence of BorderJoin
        Whole-side joins with :func:`network_joinable` sides; each side in one join.
    tol : float or sequence of float
        Largest same-parameter distance from its source, per patch or for all.
    kept : collection of int, optional
        Patches that do not move: their borders constrain their neighbours.
    continuity : {"G0", "G1"}

    Returns
    -------
    NetworkResult

    Raises
    ------
    InvalidInputError
        Rational patches, joins whose sides do not match, an unknown ``continuity``.
    """
    sources, joins, tols = _checked(patches, joins, tol, continuity)
    patches = [_refined(p) for p in sources]
    samples = [_Probe(s, p) for s, p in zip(sources, patches)]
    kept = set(kept)
    for _ in range(len(patches)):
        result = _smoothest(patches, sources, samples, joins, tols, kept, continuity)
        moved = set(range(len(patches))) - result.kept
        turned = (turned_patches(result.surfaces, sources, joins, moved)
                  if continuity == "G1" else set())
        if not turned:
            return result
        kept |= turned   # their joins would turn more than the source's: keep them
    return result


def _smoothest(patches, sources, samples, joins, tols, kept, continuity):
    """The largest energy weight within the tolerances, the patches that the joins alone
    hold out of their tolerance kept."""
    kept = set(kept)
    for _ in range(len(patches)):
        system = _System(patches, kept)
        constraints, g1_rows = _constraints(system, joins, continuity)
        solve = _solver(system, constraints, sources, samples, kept)
        best = solve(0.0)
        over = {f for f in range(len(patches)) if best[1][f] > tols[f]} - kept
        if not over:
            break
        kept |= over     # the joins hold these too far: they constrain their neighbours
    if len(kept) == len(patches):
        return NetworkResult(list(sources), 0.0, np.zeros(len(patches)), g1_rows, kept)
    lo, hi, lam = np.log(LAMBDA_RANGE[0]), np.log(LAMBDA_RANGE[1]), 0.0
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        trial = solve(float(np.exp(mid)))
        if np.all(trial[1] <= tols):
            best, lam, lo = trial, float(np.exp(mid)), mid
        else:
            hi = mid
    surfaces = [sources[f] if f in kept else s for f, s in enumerate(best[0])]
    return NetworkResult(surfaces, lam, best[1], g1_rows, kept)


def _refined(patch):
    """The patch with every span of a one-span direction halved (knot insertion: the
    same surface).  The cross rows of a one-span patch all end at a corner, where the
    mirrored rows of the patches around the vertex close cycles: halved, its middle
    rows are free of them."""
    knots = {}
    net = patch.poles
    for axis, space in enumerate((patch.u_space, patch.v_space)):
        t = space.knots
        if space.breakpoints.size == 2:
            moved = np.moveaxis(net, axis, 0)
            t, moved = insert_knot(t, space.degree, moved, 0.5 * (t[0] + t[-1]))
            net = np.moveaxis(moved, 0, axis)
        knots[axis] = t
    return BSplineSurface(np.ascontiguousarray(net), knots[0], knots[1], patch.u_degree,
                          patch.v_degree)


def _solver(system, constraints, patches, samples, kept):
    """``solve(lam) -> (surfaces, deviation per patch)``."""
    def solve(lam):
        surfaces = system.surfaces(system.solve(lam, constraints))
        deviation = np.array([0.0 if f in kept else samples[f].distance(surfaces[f])
                              for f in range(len(patches))])
        return surfaces, deviation
    return solve


def _checked(patches, joins, tol, continuity):
    if continuity not in ("G0", "G1"):
        raise InvalidInputError(
            f"continuity must be 'G0' or 'G1', got {continuity!r}.")
    patches, joins = list(patches), list(joins)
    for i, patch in enumerate(patches):
        if not isinstance(patch, BSplineSurface) or patch.is_rational:
            raise InvalidInputError(
                f"patch {i} must be a polynomial BSplineSurface; fair rational patches "
                "alone.")
    for join in joins:
        if not network_joinable(patches[join.a], join.side_a, patches[join.b], join.side_b,
                                join.reversed):
            raise InvalidInputError(
                f"patches {join.a} and {join.b} differ in degree or knots along their join "
                f"({join.side_a}/{join.side_b}); leave the join out or refine one patch.")
    tols = np.broadcast_to(np.asarray(tol, dtype=float), (len(patches),))
    return patches, joins, tols


class _System:
    """Every patch's poles numbered together, with the L2 and energy forms."""

    def __init__(self, patches, kept):
        self.patches, self.kept = patches, kept
        self.offsets = np.cumsum([0] + [p.shape[0] * p.shape[1] for p in patches])
        mass, energy, scale = [], [], []
        for patch in patches:
            g = [[gram_matrix(s, nu=nu) for nu in (0, 1, 2)] for s in (patch.u_space,
                                                                      patch.v_space)]
            m = sp.kron(g[0][0], g[1][0])
            h = sp.kron(g[0][2], g[1][0]) + 2 * sp.kron(g[0][1], g[1][1]) + \
                sp.kron(g[0][0], g[1][2])
            mass.append(m)
            energy.append(h)
            scale.append(m.diagonal().sum() / max(h.diagonal().sum(), 1e-300))
        self.mass = sp.block_diag(mass, format="csr")
        self.energy = sp.block_diag([s * h for s, h in zip(scale, energy)], format="csr")
        self.source = np.concatenate([p.poles.reshape(-1, 3) for p in patches])
        fixed = np.zeros(self.offsets[-1], dtype=bool)
        for f in kept:
            fixed[self.offsets[f]:self.offsets[f + 1]] = True
        self.fixed = fixed

    def index(self, patch, i, j):
        return int(self.offsets[patch] + i * self.patches[patch].shape[1] + j)

    def solve(self, lam, constraints):
        r"""Poles of all patches: the KKT system
        :math:`\begin{bmatrix}M + \lambda H & A^T\\ A & -\varepsilon I\end{bmatrix}`,
        kept poles held by identity rows."""
        free = ~self.fixed
        q = (self.mass + lam * self.energy).tocsr()
        a = constraints
        if self.fixed.any():
            held = sp.identity(len(free), format="csr")[np.flatnonzero(self.fixed)]
            a = sp.vstack([a, held], format="csr") if a.shape[0] else held
        rhs_c = np.zeros((a.shape[0], 3))
        if self.fixed.any():
            rhs_c[-int(self.fixed.sum()):] = self.source[self.fixed]
        scale = float(q.diagonal().mean())
        kkt = sp.bmat([[q, scale * a.T], [scale * a, -KKT_EPS * scale *
                                         sp.identity(a.shape[0])]], format="csc")
        rhs = np.concatenate([self.mass @ self.source, scale * rhs_c])
        return spla.splu(kkt).solve(rhs)[: len(free)]

    def surfaces(self, poles):
        out = []
        for f, patch in enumerate(self.patches):
            net = poles[self.offsets[f]:self.offsets[f + 1]].reshape(patch.poles.shape)
            out.append(BSplineSurface(net, patch.u_knots, patch.v_knots, patch.u_degree,
                                      patch.v_degree))
        return out


def _border_rows(patch, side):
    """``(border, inner)`` pole index pairs ``(i, j)`` along ``side`` in the order of its
    along-parameter."""
    ku, kv = patch.shape
    end, inner = (0, 1) if side[1] == "0" else (-1, -2)
    if side[0] == "u":
        e, n = end % ku, inner % ku
        return [((e, k), (n, k)) for k in range(kv)]
    e, n = end % kv, inner % kv
    return [((k, e), (k, n)) for k in range(ku)]


def _constraints(system, joins, continuity):
    """The sparse constraint rows (G0 pole identities, G1 mirrored rows) and the number
    of G1 rows.

    A row that would tie two poles already tied (through other rows, or both held by
    kept patches) is left out: it could only repeat or contradict the others."""
    rows, cols, vals = [], [], []
    g0 = UnionFind()   # G0 identifications of poles, then (cycles) of their classes

    def row(entries):
        r = rows[-1] + 1 if rows else 0
        for c, v in entries:
            rows.append(r)
            cols.append(c)
            vals.append(v)

    for index in np.flatnonzero(system.fixed):
        g0.tie(HELD, int(index))      # the kept patches' poles: one held class
    sides = []
    for join in joins:
        ra = _border_rows(system.patches[join.a], join.side_a)
        rb = _border_rows(system.patches[join.b], join.side_b)
        if join.reversed:
            rb = rb[::-1]
        sides.append((join, ra, rb))
        for (pa, _), (pb, _) in zip(ra, rb):
            ia, ib = system.index(join.a, *pa), system.index(join.b, *pb)
            if g0.tie(ia, ib) is None:
                row([(ia, 1.0), (ib, -1.0)])
    g1 = 0
    if continuity == "G1":
        cycles = UnionFind()
        for join, ra, rb in sides:
            if not join.smooth:
                continue
            a, b = system.patches[join.a], system.patches[join.b]
            mu = mirror_ratio(np.array([a.poles[q] - a.poles[p] for p, q in ra]),
                              np.array([b.poles[q] - b.poles[p] for p, q in rb]))
            for (pa, qa), (pb, qb) in zip(ra, rb):
                ia, na = system.index(join.a, *pa), system.index(join.a, *qa)
                ib, nb = system.index(join.b, *pb), system.index(join.b, *qb)
                if cycles.tie(g0.find(na)[0], g0.find(nb)[0]) is None:
                    row([(na, 1.0), (ia, -1.0), (nb, mu), (ib, -mu)])
                    g1 += 1
    count = rows[-1] + 1 if rows else 0
    matrix = sp.csr_matrix((vals, (rows, cols)), shape=(count, int(system.offsets[-1])))
    return matrix, g1


class _Probe:
    """A patch's samples (at least :data:`SAMPLES` per direction, three per span), its
    source's points and normals there, and the refined spaces' basis values, so that a
    candidate net costs a few small products."""

    def __init__(self, source, refined):
        self.u, self.v = (np.unique(np.concatenate(
            [np.linspace(a, b, 3) for a, b in zip(space.breakpoints[:-1],
                                                   space.breakpoints[1:])]
            + [np.linspace(*space.domain, SAMPLES)]))
            for space in (source.u_space, source.v_space))
        self.bases = [[space.collocation(x, nu).toarray() for nu in (0, 1)]
                      for space, x in ((refined.u_space, self.u), (refined.v_space, self.v))]
        self.points, self.normal = self._evaluate(refined.poles)

    def _evaluate(self, poles):
        (bu, du), (bv, dv) = self.bases
        along_u = np.tensordot(bu, poles, axes=(1, 0))
        points = np.einsum("ijd,kj->ikd", along_u, bv)
        su = np.einsum("ia,abd,jb->ijd", du, poles, bv)
        sv = np.einsum("ijd,kj->ikd", along_u, dv)
        return points, np.cross(su, sv)

    def distance(self, surface):
        """Largest same-parameter distance from the source; infinite where the surface
        folds over (:func:`~cq_fairing.core.geometry.folded`)."""
        points, normal = self._evaluate(surface.poles)
        if folded(normal, self.normal).any():
            return np.inf
        return float(np.linalg.norm(points - self.points, axis=-1).max())
