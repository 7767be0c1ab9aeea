r"""Energy fairing of a network of patches: fair across the joins, each patch in its own
parametrization.

Patches that are already at their coarsest (a bicubic patch of one span) leave a
projection nothing to remove, and patches whose parametrizations do not match across
their joins cannot be merged into one smooth surface without sliding along it.  Such a
network is faired as a whole by the thin-plate energy of every patch in its own
parameters, under the joins' constraints (Eck and Hadenfeld's energy fairing, with the
tolerance as its bound):

.. math:: \min_{C} \sum_f (C_f - P_f)^T M_f (C_f - P_f) + \lambda_f\, s_f\, C_f^T H_f C_f
          \quad\text{subject to}\quad A C = k,

with :math:`M_f = G_u\otimes G_v` the patch's L2 Gram matrix (so the first term is
:math:`\iint |T_f - S_f|^2`), :math:`H_f = G''_u\otimes G_v + 2 G'_u\otimes G'_v +
G_u\otimes G''_v` its thin-plate energy, :math:`s_f = \mathrm{tr} M_f / \mathrm{tr} H_f`
the scale that makes one :math:`\lambda_f` mean the same on patches of any size, and
:math:`A` the joins (:math:`k = 0` but on the rows of a join that keeps the source's
kink):

* **G0**: the two border rows of a join are one row, pole for pole (the patches share
  their knots and degree along the join);
* **G1** at smooth joins: the cross rows mirror each other,
  :math:`w_{a,i} + \mu w_{b,i} = 0`, :math:`w = c_{inner} - c_{border}`, with one
  :math:`\mu` per join (the geometric mean of the source's length ratios), which makes
  the tangent planes agree along the whole join
  (:mod:`cq_fairing.core.joins`, step 5).  Where every smooth join of the network is
  tangent in the sources already (within :data:`~cq_fairing.core.joins.ANGLE_SLACK`),
  one ratio per join would only bend patches that meet well: the joins are held closed
  first, and the mirrored rows come in on those that then turn more than the slack
  beyond the source (:meth:`PatchNetwork.fair`).
* **Source kinks.**  Where the mirrored rows would hold a patch over its tolerance (or
  fold it), the smooth joins of that patch along which they would move the source's
  inner poles by more than its tolerance (:func:`_kinks`) keep the source's kink
  instead: their rows hold the source's residual, :math:`w_{a,i} + \mu w_{b,i} =
  w^0_{a,i} + \mu w^0_{b,i}`, so that the join turns as the source's does (checked as
  every smooth join is); a patch the joins still hold over its tolerance is kept.
* **C2 across cuts** of one surface into pieces (:func:`_curvature_rows`).
* **Vertices.**  Around a vertex the rows next to it tie the patches' twist poles in a
  cycle, singular where the ratios' product is 1 (the vertex enclosure condition); a
  row that would close a cycle of rows is left out.  At a *crossing* (four moving
  patches, four smooth joins) opposite joins share one ratio and the mirrored rows at
  the vertex make its two lines of edges straight, so the cycle closes as in one
  surface cut into four and the row left out holds by itself (:func:`_straightened`).
  At any other vertex of three or more patches where the rows at the vertex itself
  would make an edge collinear with two others, or where the source's edges are not
  straight through it, those rows are replaced by the vertex's tangent plane, which
  holds the first pole of every edge (:func:`_plane_rows`; these rows act on the three
  coordinates together).  Around an odd number of patches the rows that close the
  cycle would determine the twist poles; held, they make the patches wavier across
  their joins, so they are left out there too.
* **Open vertices.**  Where the kept patches' corners do not meet in the source to
  round-off (farther apart than :data:`SPREAD` times the network's size), the other
  patches' corners there keep their source points (:func:`_split_vertices`): closed onto
  one kept corner, a patch would open its join to the other by their distance, and the
  edge between them would need a larger tolerance than the source's.

A planar source is kept: it has no curvature to fair, and the energy could only bend it
out of its plane (:func:`_planar`).

The borders move with the patches: the energy runs across the joins.  The patches that
share no unknown (joined only through kept patches) are independent parts of the
system, each with its own :math:`\lambda`: the largest (bisection on its logarithm) for
which every patch of the part stays within the tolerance of its source by the
same-parameter distance on :data:`SAMPLES` x :data:`SAMPLES` points, an upper bound of
the true distance, so that one patch held close by its joins does not hold back the
energy of the others.  Within a part each patch's weight :math:`\lambda_f` is then
raised from the part's as far as the part stays within its tolerances
(:func:`_bisected`): a patch near its tolerance holds back its own energy, not its
neighbours'.

The G0 rows and the kept patches' poles are identities, eliminated exactly (one unknown
per class of tied poles); the G1 rows remain in one regularised KKT system, the same for
x, y and z and factorized once per set of weights; the tangent-plane rows, the only
ones that couple the coordinates, come in exactly by their Schur complement.

This module imports numpy and scipy only.
"""

from collections import Counter
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components

from ..errors import InvalidInputError
from .geometry import BSplineSurface, folded
from .gram import gram_matrix
from .joins import JoinTurns, UnionFind, mean_normal, mirror_ratio, shared_basis, tied_in_order
from .patch_grid import insert_knot
from .spaces import SplineSpace

__all__ = ["NetworkResult", "PatchNetwork", "fair_network", "network_joinable"]

SAMPLES = 9          # same-parameter samples per patch and direction
KKT_EPS = 1e-12      # regularisation of the constraint block (relative)
RHS_BLOCK = 8        # right-hand sides per triangular solve (:func:`_solved`)
LAMBDA_RANGE = (1e-8, 1e4)
BISECTIONS = 10
KNOT_TOLERANCE = 1e-9
SPREAD = 1e-9       # x the network's size (round-off): kept corners farther apart leave
                    # their vertex open
STRAIGHT = 0.1      # relative residual of a source's rows at a vertex for its lines to stay
PLANAR = 1e-9       # x a patch's size (round-off): poles this close to one plane are planar


@dataclass(frozen=True)
class NetworkResult:
    """Outcome of :func:`fair_network`.

    Attributes
    ----------
    surfaces : list of BSplineSurface
        The faired patches, each on its source's spaces with a one-span direction's
        span halved (kept ones: the source).
    smoothing : float
        The smallest energy weight :math:`\\lambda_f` of the moved patches (0 when even
        the constrained projection alone is over the tolerance somewhere: then
        ``surfaces`` are the sources).
    deviations : numpy.ndarray
        Each patch's largest same-parameter distance from its source on the samples.
    g1_rows : int
        Mirrored-row constraints imposed (with the C2 rows across cuts).
    kept : set of int
        The patches that kept their surfaces: those asked for, the planar ones, those
        the joins would hold out of their tolerance even without energy (their source
        kinks kept where that helps), and one patch of each smooth
        join that would turn more than the source's even held (:func:`_covering`; it
        then constrains its neighbours instead, and the join is checked again).
    reasons : dict
        Why the network kept each patch it was not asked to keep: ``("tolerance", d)``,
        the joins alone hold it ``d`` from its source (the same-parameter distance on
        the samples, the energy at zero; infinite where it folds), ``("turned",
        joins)``, the indices of its smooth joins that would turn, or ``("planar",)``:
        its source is planar (:func:`_planar`).
    kinked : set of int
        The smooth joins that keep the source's kink instead of being made tangent
        (:func:`_kinks`).
    """

    surfaces: list
    smoothing: float
    deviations: np.ndarray
    g1_rows: int
    kept: set
    reasons: dict = field(default_factory=dict)
    kinked: set = field(default_factory=set)


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
    return PatchNetwork(patches, joins, continuity).fair(tol, kept=kept)


class PatchNetwork:
    """A network of patches prepared for :meth:`fair` (:func:`fair_network`): its forms,
    samples, joins' rows and vertices (:class:`_Vertices`), which depend neither on the
    tolerance nor on the patches kept, built once for any number of tolerances and of
    kept patches.

    Parameters
    ----------
    patches, joins, continuity
        As in :func:`fair_network`.

    Raises
    ------
    InvalidInputError
        Rational patches, joins whose sides do not match, an unknown ``continuity``.
    """

    def __init__(self, patches, joins, continuity="G1"):
        self.sources, self.joins = _checked(patches, joins, continuity)
        self.continuity = continuity
        self.forms = _Forms([_refined(p) for p in self.sources])
        self.probes = _Probes(self.sources, self.forms.patches)
        self.spread = SPREAD * _diagonal(self.forms.source)
        self.sides = _join_sides(self.forms, self.joins)
        self.vertices = _Vertices(self.forms, self.sides)
        self.turns = JoinTurns(self.sources, self.joins) if continuity == "G1" else None

    @property
    def refined(self):
        """The sources on the spaces the patches are solved on (each one-span direction's
        span halved: :func:`_refined`), the same surfaces."""
        return self.forms.patches

    def fair(self, tol, *, kept=()):
        """:func:`fair_network` of the prepared network within ``tol`` (per patch or for
        all), the patches ``kept`` held.

        Returns
        -------
        NetworkResult
        """
        sources = self.sources
        tols = np.broadcast_to(np.asarray(tol, dtype=float), (len(sources),))
        planar = {f for f, source in enumerate(sources) if _planar(source)} - set(kept)
        kept = set(kept) | planar
        turned_by = {}   # patch: the joins that turned it
        # tangent sources: closed joins first, mirrored rows where they then turn
        held = set() if self.turns is not None and self.turns.tangent() else None
        kinked = set()
        for _ in range(len(sources) + len(self.joins)):
            result = _smoothest(self, tols, kept, held, kinked)
            if self.turns is None:
                break
            moved = set(range(len(sources))) - result.kept
            turned = self.turns.turned_joins(result.surfaces, moved)
            if held is not None and turned - held:
                held |= turned
                continue
            if not turned:
                break
            # these joins would turn more than the source's even held: keep one patch
            # of each, and let the other close onto it (checked again)
            for patch, joins in _covering(self.joins, turned, moved).items():
                turned_by.setdefault(patch, []).extend(joins)
            kept |= set(turned_by)
        turned_reasons = {p: ("turned", joins) for p, joins in turned_by.items()}
        return replace(result, reasons={**dict.fromkeys(planar, ("planar",)),
                                        **turned_reasons, **result.reasons},
                       kinked=kinked)


def _covering(joins, turned, moved):
    """``{patch: [join, ...]}``: patches of ``moved`` that cover the ``turned`` joins
    (indices into ``joins``), one per join, greedily: the patch on most of the joins not
    covered yet first (the lower index on a tie).  Kept, each holds its neighbours'
    side of the joins it covers, which then close onto it; keeping both patches of every
    turned join would keep, round after round, the neighbours of the neighbours."""
    open_ = set(turned)
    out = {}
    while open_:
        on = {}
        for k in sorted(open_):
            for patch in {joins[k].a, joins[k].b} & moved:
                on.setdefault(patch, []).append(k)
        patch = max(sorted(on), key=lambda p: len(on[p]))
        out[patch] = on[patch]
        open_ -= set(on[patch])
    return out


def _smoothest(network, tols, kept, held, kinked):
    """The largest energy weights within the tolerances (:func:`_bisected`), the patches
    that the joins alone hold out of their tolerance kept once the joins that put them
    there keep their source kinks (``kinked``, a set of join indices, updated:
    :func:`_kinks`)."""
    sources = network.sources
    kept = set(kept)
    count = len(sources)
    reasons = {}
    for _ in range(count + len(network.sides)):
        system = _System(network.forms, kept, network.sides, network.continuity,
                         network.spread, network.vertices, held, kinked)
        solve = _solver(system, network.probes, kept)
        best = solve(0.0)
        over = {f for f in range(count) if best[1][f] > tols[f]} - kept
        if not over:
            break
        bent = _kinks(network, over, tols, held, kinked) if network.turns is not None \
            else set()
        kinked |= bent
        over -= {p for k in bent for p in (network.joins[k].a, network.joins[k].b)}
        reasons.update({f: ("tolerance", float(best[1][f])) for f in over})
        kept |= over     # the joins hold these too far: they constrain their neighbours
    if len(kept) == count:
        return NetworkResult(list(sources), 0.0, np.zeros(count), system.g1_rows, kept,
                             reasons)
    part = system.patch_components
    members = [np.flatnonzero(part == c) for c in range(part.max() + 1)]
    weights = np.zeros(count)
    surfaces, deviations = list(best[0]), best[1].copy()
    lo = np.full(count, np.log(LAMBDA_RANGE[0]))
    for whole in (True, False):     # each part's weight, then each patch's from it
        hi = np.full(count, np.log(LAMBDA_RANGE[1]))
        _bisected(solve, members, tols, (lo, hi), (weights, surfaces, deviations), whole)
    surfaces = [sources[f] if f in kept else s for f, s in enumerate(surfaces)]
    return NetworkResult(surfaces, float(weights[np.concatenate(members)].min()),
                         deviations, system.g1_rows, kept, reasons)


def _bisected(solve, members, tols, bounds, state, whole):
    """:data:`BISECTIONS` steps of bisection on every moving patch's log energy weight
    between ``bounds`` (``(lo, hi)`` per patch, updated), the parts ``members`` (the
    system's independent parts) at once.  A trial that holds every patch of a part
    within its tolerance is taken for the part (``state``: ``(weights, surfaces,
    deviations)`` per patch, updated) and raises its patches' lower ends; one that does
    not lowers the upper ends of all the part's patches (``whole``: one weight per
    part) or of those over their tolerance only (each patch's weight raised as far as
    its part stays within its tolerances).  The state holds one solve per part."""
    lo, hi = bounds
    weights, surfaces, deviations = state
    moving = np.concatenate(members)
    for _ in range(BISECTIONS):
        mid = 0.5 * (lo + hi)
        trial = np.zeros_like(weights)
        trial[moving] = np.exp(mid[moving])
        solved, distances = solve(trial)
        for group in members:
            over = group[distances[group] > tols[group]]
            if over.size == 0:
                weights[group], lo[group] = trial[group], mid[group]
                deviations[group] = distances[group]
                for f in group:
                    surfaces[f] = solved[f]
            else:
                failed = group if whole else over
                hi[failed] = mid[failed]


def _kinks(network, over, tols, held, kinked):
    r"""The smooth joins with mirrored rows (all, or those ``held``; not cuts, not in
    ``kinked``) of the patches ``over`` their tolerance along which the mirrored rows
    would move the source's inner poles by more than the tolerance of such a patch:
    :math:`|w^0_{a,i} + \mu w^0_{b,i}| / (1 + \mu)` (the smallest equal move of the two
    inner poles that makes the rows mirror) above it at some pole.  Those joins then
    keep the source's kink instead (:func:`_constraints`)."""
    source = network.forms.source
    out = set()
    for k, (join, border_a, inner_a, border_b, inner_b, mu) in enumerate(network.sides):
        patches = {join.a, join.b} & over
        if (not join.smooth or join.cut or k in kinked or not patches
                or (held is not None and k not in held)):
            continue
        residual = source[inner_a] - source[border_a] + mu * (source[inner_b] - source[border_b])
        if np.linalg.norm(residual, axis=1).max() / (1.0 + mu) > min(tols[p] for p in patches):
            out.add(k)
    return out


def _planar(patch):
    """True when the poles of ``patch`` lie within :data:`PLANAR` times their size of
    one plane (through their centroid, normal to their direction of least spread)."""
    poles = patch.poles.reshape(-1, 3)
    centred = poles - poles.mean(axis=0)
    normal = np.linalg.svd(centred, full_matrices=False)[2][-1]
    return float(np.abs(centred @ normal).max()) <= PLANAR * _diagonal(poles)


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


def _solver(system, probes, kept):
    """``solve(lam) -> (surfaces, deviation per patch)``."""
    def solve(lam):
        surfaces = system.surfaces(system.solve(lam))
        return surfaces, probes.distances(surfaces, kept)
    return solve


def _checked(patches, joins, continuity):
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
    return patches, joins


class _Forms:
    """Every patch's poles numbered together, with the block-diagonal L2 form and scaled
    thin-plate energy (:math:`M_f` and :math:`s_f H_f`); the same whichever patches are
    kept, so built once per network, from Gram matrices computed once per distinct
    normalised knot vector (:func:`_scaled_grams`)."""

    def __init__(self, patches):
        self.patches = patches
        self.offsets = np.cumsum([0] + [p.shape[0] * p.shape[1] for p in patches])
        unit, entries = {}, ([], [])
        for offset, p in zip(self.offsets, patches):
            forms = _patch_forms(*(_scaled_grams(space, unit)
                                   for space in (p.u_space, p.v_space)))
            for collected, (rows, columns, values) in zip(entries, forms):
                collected.append((rows + offset, columns + offset, values))
        size = int(self.offsets[-1])
        self.mass, self.energy = (
            sp.csr_matrix((np.concatenate([v for _, _, v in collected]),
                           (np.concatenate([r for r, _, _ in collected]),
                            np.concatenate([c for _, c, _ in collected]))), shape=(size, size))
            for collected in entries)
        self.source = np.concatenate([p.poles.reshape(-1, 3) for p in patches])


def _scaled_grams(space, unit):
    r"""The Gram matrices :math:`G, G', G''` of ``space`` (its basis functions and their
    first and second derivatives): those of its knots mapped onto :math:`[0, 1]`
    (cached in ``unit``) times :math:`h`, :math:`1/h` and :math:`1/h^3`, :math:`h` the
    domain's width; as ``(rows, columns, values)`` of their entries."""
    lo, hi = space.domain
    width = hi - lo
    normalised = np.round((space.knots - lo) / width, 12)
    key = (space.degree, normalised.tobytes())
    if key not in unit:
        on_unit = SplineSpace.from_knots(normalised, space.degree)
        unit[key] = [gram_matrix(on_unit, nu=nu).tocoo() for nu in (0, 1, 2)]
    return [(g.row, g.col, g.data * scale, g.shape[0])
            for g, scale in zip(unit[key], (width, 1.0 / width, 1.0 / width ** 3))]


def _patch_forms(u_grams, v_grams):
    r"""``(M, s H)`` of a patch whose directions have the Gram matrices ``u_grams`` and
    ``v_grams`` (:func:`_scaled_grams`), as ``(rows, columns, values)`` of their entries
    (duplicates to be summed): its L2 Gram matrix :math:`G_u\otimes G_v` and its
    thin-plate energy :math:`H = G''_u\otimes G_v + 2 G'_u\otimes G'_v + G_u\otimes
    G''_v` scaled by :math:`s = \mathrm{tr} M / \mathrm{tr} H` (the trace of a Kronecker
    product is the product of the traces)."""
    traces = [[values[rows == columns].sum() for rows, columns, values, _ in g]
              for g in (u_grams, v_grams)]
    (tu, tv) = traces
    scale = tu[0] * tv[0] / max(tu[2] * tv[0] + 2 * tu[1] * tv[1] + tu[0] * tv[2], 1e-300)
    energy = [_kron_entries(u_grams[i], v_grams[j], factor * scale)
              for i, j, factor in ((2, 0, 1.0), (1, 1, 2.0), (0, 2, 1.0))]
    return _kron_entries(u_grams[0], v_grams[0], 1.0), tuple(
        np.concatenate(parts) for parts in zip(*energy))


def _kron_entries(a, b, factor):
    """``(rows, columns, values)`` of ``factor`` times the Kronecker product of the
    matrices ``a`` and ``b``, each ``(rows, columns, values, size)`` of its entries."""
    (ra, ca, va, _), (rb, cb, vb, size) = a, b
    return ((ra[:, None] * size + rb).ravel(), (ca[:, None] * size + cb).ravel(),
            (factor * va[:, None] * vb).ravel())


class _System:
    r"""The network's poles under its joins, the kept patches' poles held.

    The G0 rows and the holding of the kept poles are identities: they are eliminated.
    The poles tied by G0 rows form classes; a class tied to a kept pole takes that
    pole's source position (a constant), every other class is one unknown, so that the
    poles are :math:`C = P z + h` (:math:`P` a 0/1 matrix, :math:`h` the held
    positions), per coordinate.  The G1 rows remain as constraints :math:`A C = k`, per
    coordinate (:math:`k` the source's residuals on the rows of the joins ``kinked``, 0
    elsewhere), and the vertices' tangent planes as :math:`R\,\mathrm{vec}(C) = 0`
    over the three coordinates together (:func:`_constraints`, :func:`_plane_rows`)."""

    def __init__(self, forms, kept, sides, continuity, spread, vertices, held=None,
                 kinked=frozenset()):
        self.patches = forms.patches
        self.offsets, self.mass, self.energy = forms.offsets, forms.mass, forms.energy
        self.source = forms.source
        fixed = np.zeros(self.offsets[-1], dtype=bool)
        for f in kept:
            fixed[self.offsets[f]:self.offsets[f + 1]] = True
        split = _split_vertices(self.source, fixed, spread, vertices.groups)
        fixed[split] = True
        self.fixed = fixed
        ties, mirrored, kinks, planes, self.g1_rows = _constraints(
            self, sides, continuity, split, vertices, held, kinked)
        self.basis, self.held = self._eliminated(ties)
        self.owner = np.repeat(np.arange(len(self.patches)), np.diff(self.offsets))
        self.kkt, self.rhs = self._kkt(mirrored, kinks)
        self.coupling = self._coupling(planes)
        self.diagonals = [form.diagonal() for form in (self.mass, self.energy)]
        self.patch_components = self._components()

    def _components(self):
        """The independent parts of the system, from the components of the unknowns in
        the graph of the KKT matrix and the tangent-plane rows (patches joined only
        through kept ones share no unknown): the component of each patch (-1 for a patch
        without unknowns)."""
        unknowns = self.basis.shape[1]
        graph = abs(self.kkt[0]) + abs(self.kkt[1]) + abs(self.kkt[2])
        plane_rows = self.coupling[0]
        if plane_rows.shape[0]:
            tied = abs(plane_rows).T @ abs(plane_rows)
            graph = graph + sp.block_diag([tied, sp.csc_matrix(
                (graph.shape[0] - unknowns, graph.shape[0] - unknowns))])
        _, label = connected_components(graph, directed=False)
        _, label = np.unique(label[:unknowns], return_inverse=True)
        per_patch = np.full(len(self.patches), -1)
        rows, columns = self.basis.nonzero()
        per_patch[self.owner[rows]] = label[columns]
        return per_patch

    def _eliminated(self, ties):
        """``(P, h)`` of the classes of poles tied by the G0 rows ``ties`` (pairs of pole
        indices, a forest: each joins two classes, at most one kept pole per class):
        :func:`~cq_fairing.core.joins.shared_basis`."""
        return shared_basis(ties, np.where(self.fixed[:, None], self.source, np.nan))

    def _kkt(self, mirrored, kinks):
        r"""The parts :math:`K_M, K_H, K_A` of the per-coordinate KKT matrix
        :math:`K_M + K_\Lambda + s K_A` (:meth:`solve`; :math:`K_H` its energy unweighted, for
        :meth:`_components`) and the parts :math:`b_M, s b_A` of its right-hand sides,
        one column per coordinate:

        .. math:: K_M = \begin{bmatrix}P^T M P & 0\\ 0 & 0\end{bmatrix},\;
                  K_H = \begin{bmatrix}P^T H P & 0\\ 0 & 0\end{bmatrix},\;
                  K_A = \begin{bmatrix}0 & B^T\\ B & -\varepsilon I\end{bmatrix},

        :math:`B = A P`, :math:`b_M = P^T M (C_0 - h)`, :math:`b_A = k - A h`
        (:math:`C_0` the sources' poles, :math:`k` the rows' right-hand sides:
        ``kinks``, the source's residual on the rows of a join that keeps its kink, 0
        elsewhere; :math:`\varepsilon` = :data:`KKT_EPS`)."""
        b = (mirrored @ self.basis).tocsc()
        unknowns, rows = self.basis.shape[1], b.shape[0]
        empty = sp.csc_matrix((rows, rows))
        parts = [sp.block_diag([self.basis.T @ form @ self.basis, empty], format="csc")
                 for form in (self.mass, self.energy)]
        parts.append(sp.bmat([[sp.csc_matrix((unknowns, unknowns)), b.T],
                              [b, -KKT_EPS * sp.identity(rows)]], format="csc")
                     if rows else sp.csc_matrix((unknowns, unknowns)))
        rhs = [self.basis.T @ (self.mass @ (self.source - self.held)),
               kinks - mirrored @ self.held]
        return parts, rhs

    def _coupling(self, planes):
        r"""The tangent-plane rows :math:`R = [\,\mathrm{diag}(n_1) D\;\;
        \mathrm{diag}(n_2) D\;\;\mathrm{diag}(n_3) D\,]` (:func:`_plane_rows`) on the
        unknowns: ``(G, E, N, p)``, :math:`G = D P` (sparse), :math:`E =
        \begin{bmatrix}G^T\\ 0\end{bmatrix}` (dense, on the rows of the per-coordinate
        KKT system), :math:`N = [n_1\;n_2\;n_3]` the rows' normals (r, 3) and
        :math:`p = -R\,\mathrm{vec}(h)`."""
        difference, normals = planes
        plane_rows = (difference @ self.basis).tocsr()
        plane_columns = np.zeros((self.kkt[2].shape[0], plane_rows.shape[0]))
        plane_columns[:plane_rows.shape[1]] = plane_rows.T.toarray()
        plane_rhs = -np.einsum("rd,rd->r", normals, difference @ self.held)
        return plane_rows, plane_columns, normals, plane_rhs

    def solve(self, lam):
        r"""Poles of all patches, :math:`P z + h`, from the KKT system of the three
        coordinates, :math:`x_d = (z_d, \mu_d)` for :math:`d = 1, 2, 3` and the tangent
        planes' multipliers :math:`\nu`:

        .. math:: K x_d + s E\,\mathrm{diag}(n_d)\,\nu = f_d,\qquad
                  s \sum_d \mathrm{diag}(n_d) E^T x_d - \varepsilon s\,\nu = s p,

        :math:`K = K_M + K_\Lambda + s K_A`, the same for x, y and z, and :math:`f_d`
        column :math:`d` of :math:`[b_M + b_\Lambda;\; s b_A]` (:meth:`_kkt`), with the
        weighted energy :math:`K_\Lambda = \begin{bmatrix}P^T \Lambda H P & 0\\ 0 &
        0\end{bmatrix}` and :math:`b_\Lambda = -P^T \Lambda H h`, :math:`\Lambda` the
        diagonal of each pole's patch's weight :math:`\lambda_f` (``lam``: one for all
        or one per patch; :math:`H` is block-diagonal by patch, so :math:`\Lambda H =
        \sum_f \lambda_f H_f`);
        :math:`s` the mean diagonal of :math:`M + \max\lambda_f\, H`, which scales the
        constraint rows like the rest; :math:`E, n_d, p` the tangent-plane rows
        (:meth:`_coupling`).  Only :math:`K` is factorized; the plane rows, which couple
        the coordinates, come in exactly by their Schur complement, :math:`W = K^{-1}E`:

        .. math:: \bigl(\varepsilon I + s\,(E^T W)\circ N N^T\bigr)\,\nu =
                  \sum_d n_d \circ E^T K^{-1} f_d - p,\qquad
                  x_d = K^{-1} \bigl(f_d - s E\,(n_d \circ \nu)\bigr)

        (:math:`E` has two entries per column: :math:`E\,(n_d \circ \nu)` is a sparse
        product, and one more solve on three columns gives the :math:`x_d`)."""
        unknowns = self.basis.shape[1]
        if unknowns == 0:
            return self.held
        lam = np.broadcast_to(np.asarray(lam, dtype=float), (len(self.patches),))
        scale = float(np.mean(self.diagonals[0] + lam.max() * self.diagonals[1]))
        weighted = self.basis.T @ (sp.diags(lam[self.owner]) @ self.energy)   # P^T Lambda H
        rows = self.kkt[0].shape[0] - unknowns
        energy = sp.block_diag([weighted @ self.basis, sp.csc_matrix((rows, rows))])
        lu = spla.splu((self.kkt[0] + energy + scale * self.kkt[2]).tocsc())
        plane_rows, plane_columns, normals, plane_rhs = self.coupling
        rhs = np.vstack([self.rhs[0] - weighted @ self.held, scale * self.rhs[1]])
        solved = _solved(lu, np.hstack([rhs, plane_columns]))
        x, w = solved[:, :3], solved[:, 3:]
        if plane_rhs.size:
            schur = (KKT_EPS * np.identity(plane_rhs.size)
                     + scale * (plane_rows @ w[:unknowns]) * (normals @ normals.T))
            nu = sla.solve(schur, np.einsum("rd,rd->r", normals,
                                                  plane_rows @ x[:unknowns]) - plane_rhs)
            pushed = np.zeros_like(x)
            pushed[:unknowns] = plane_rows.T @ (normals * nu[:, None])
            x = x - scale * _solved(lu, pushed)
        return self.basis @ x[:unknowns] + self.held

    def surfaces(self, poles):
        out = []
        for f, patch in enumerate(self.patches):
            net = poles[self.offsets[f]:self.offsets[f + 1]].reshape(patch.poles.shape)
            out.append(BSplineSurface(net, patch.u_knots, patch.v_knots, patch.u_degree,
                                      patch.v_degree))
        return out


def _solved(lu, columns):
    """``lu.solve`` of ``columns``, :data:`RHS_BLOCK` at a time.  On many right-hand
    sides SuperLU's solve runs BLAS-3 kernels large enough for OpenBLAS to thread them,
    and threads that wait for a core on a loaded machine make it tens of times slower;
    a few columns at a time cost about the same on an idle machine."""
    return np.hstack([lu.solve(columns[:, start:start + RHS_BLOCK])
                      for start in range(0, columns.shape[1], RHS_BLOCK)])


def _join_sides(forms, joins):
    """Per join: ``(join, border_a, inner_a, border_b, inner_b, mu)``, the indices of the
    border poles and of the inner poles next to them on both sides, in the order of side
    a's along-parameter, and the join's mirror ratio from the sources' cross rows."""
    out = []
    for join in joins:
        border_a, inner_a = _side_rows(forms, join.a, join.side_a)
        border_b, inner_b = _side_rows(forms, join.b, join.side_b)
        if join.reversed:
            border_b, inner_b = border_b[::-1], inner_b[::-1]
        source = forms.source
        mu = mirror_ratio(source[inner_a] - source[border_a], source[inner_b] - source[border_b])
        out.append((join, border_a, inner_a, border_b, inner_b, mu))
    return out


def _side_rows(forms, patch, side, count=2):
    """The indices of the poles along ``side`` of ``patch`` and of the ``count - 1`` rows
    next to them inside (``forms``: a :class:`_Forms` or :class:`_System`), each in the
    order of its along-parameter."""
    ku, kv = forms.patches[patch].shape
    index = forms.offsets[patch] + np.arange(ku * kv).reshape(ku, kv)
    if side[0] == "v":
        index = index.T
    return [index[k if side[1] == "0" else -1 - k] for k in range(count)]


class _Vertices:
    """The network's vertices and what about them does not depend on the kept patches,
    found once per network.

    Attributes
    ----------
    poles : UnionFind
        The border poles tied by the joins (pole indices): a set of corners is one
        vertex of the network, a set of other border poles one pole of a shared border.
    corners : dict
        ``{vertex: [(corner, edge_u, edge_v)]}`` of every corner on a join
        (:func:`_corners`).
    groups : list of numpy.ndarray
        The poles of each vertex at the ends of the joins (:func:`_split_vertices`).
    along : list of list
        Per join, the vertex of each border pole of its side ``a``.
    sizes : collections.Counter
        ``{vertex: number of border poles tied there}``.
    pairs : numpy.ndarray
        (m, 2): the border poles the joins tie pole for pole, join after join.
    rows : _Rows
        The rows the joins may constrain the network with, in the order
        :func:`_constraints` takes them (:func:`_join_rows`).
    fans, crossings : dict
        The vertices that are fans (:func:`_fans`) while at most one of their patches
        is kept (:meth:`fans_among`), and crossings (:func:`_crossings`) while none is
        (:meth:`crossings_among`).
    normals : dict
        ``{corner: unit normal or None}`` of the sources at the fans' corners
        (:func:`_source_normal`).
    """

    def __init__(self, forms, sides):
        self.pairs = np.array([pair for _, border_a, _, border_b, _, _ in sides
                               for pair in zip(border_a.tolist(), border_b.tolist())],
                              dtype=int).reshape(-1, 2)
        self.poles = UnionFind()
        for a, b in self.pairs.tolist():
            self.poles.tie(a, b)
        self.corners = {}
        for corner in _corners(forms):
            if corner[0] in self.poles.parent:
                self.corners.setdefault(self.root(corner[0]), []).append(corner)
        ends = {int(x) for _, border_a, _, border_b, _, _ in sides
                for x in (border_a[0], border_a[-1], border_b[0], border_b[-1])}
        self.groups = [poles for poles in (np.array([key for key, _ in group])
                                           for group in self.poles.members().values())
                       if poles[0] in ends]
        self.along = [[self.root(a) for a in side[1].tolist()] for side in sides]
        self.sizes = Counter(self.root(pole) for pole in list(self.poles.parent))
        self.rows = _join_rows(sides, self.along, {k: _curvature_rows(forms, side[0], self)
                                                   for k, side in enumerate(sides)
                                                   if side[0].cut})
        self.fans = _fans(forms.source, sides, self)
        self.crossings = _crossings(sides, self)
        self.normals = {c: _source_normal(forms.source, c)
                        for corners in self.fans.values() for c in corners}

    def root(self, pole):
        """The vertex of a border pole (its class's root)."""
        return self.poles.find(pole)[0]

    def fans_among(self, fixed):
        """The fans at which at most one patch is kept (``fixed``: the held poles; an
        edge from the vertex is held with its patch): around two kept patches whose
        tangent planes differ there no one plane can be held, and their mirrored rows
        hold the others."""
        return {root: corners for root, corners in self.fans.items()
                if sum(bool(fixed[c[1]]) for c in corners) <= 1}

    def crossings_among(self, fixed, fans):
        """The crossings that are no fan (``fans``) and at which no corner is held
        (``fixed``)."""
        return {root: pairs for root, pairs in self.crossings.items()
                if root not in fans and not any(fixed[c[0]] for c in self.corners[root])}


def _split_vertices(source, fixed, spread, groups):
    """The poles of the vertices (``groups``: each vertex's poles) whose kept corners lie
    more than ``spread`` apart (a source whose vertex is open): the other patches'
    corners there are held at their own source points and tied to none, so that each
    join at the vertex keeps its source's gap there (closed onto one kept corner, a
    patch would open its join to the other by their distance)."""
    out = []
    for poles in groups:
        kept = source[poles[fixed[poles]]]
        if len(kept) > 1 and np.linalg.norm(kept - kept.mean(axis=0), axis=1).max() > 0.5 * spread:
            out.extend(poles.tolist())
    return np.array(out, dtype=int)


def _constraints(system, sides, continuity, split, vertices, held=None, kinked=()):
    """The G0 pole identities (pairs of pole indices), the sparse G1 mirrored rows and
    the C2 rows across cuts of one surface (per coordinate; across a cut with any
    ``continuity``: :func:`_curvature_rows`), their right-hand sides (rows, 3: on the
    rows of the joins ``kinked`` the sources' values, which keep the source's kink
    there, 0 elsewhere), the vertices' tangent-plane rows (over the three coordinates:
    :func:`_plane_rows`) and the number of those rows per coordinate.

    The kept patches' poles are one held class; the joins' border poles are tied pair
    after pair (``vertices.pairs``, those of the ``split`` vertices left out), each pair
    that joins two classes not joined yet being a G0 identity (so that a class holds
    one kept pole at most: :func:`~cq_fairing.core.joins.tied_in_order`).  A row
    (``vertices.rows``, in order) that would tie two classes already tied (through the
    rows before it, or both held by kept patches) is left out the same way: it could
    only repeat or contradict the others.  At a fan vertex (:func:`_fans`) the mirrored
    rows at the vertex itself are left out too: there they would make the edges from the
    vertex collinear in pairs, which three or five edges cannot be; its edges' first
    poles are held in one tangent plane instead (:func:`_plane_rows`)."""
    size = int(system.offsets[-1])
    fixed = np.flatnonzero(system.fixed)
    apart = np.zeros(size + 1, dtype=bool)
    apart[split] = True
    pairs = vertices.pairs[~apart[vertices.pairs].any(axis=1)]
    held_pairs = np.column_stack([np.full(fixed.size, size), fixed])   # node size: held
    tied = tied_in_order(np.vstack([held_pairs, pairs]), size + 1)
    ties = pairs[tied[tied >= fixed.size] - fixed.size]
    forest = np.vstack([held_pairs, pairs])[tied]
    graph = sp.coo_matrix((np.ones(len(forest)), (forest[:, 0], forest[:, 1])),
                          shape=(size + 1, size + 1))
    classes, label = connected_components(graph, directed=False)
    fans, ratios = {}, [side[-1] for side in sides]
    mirrored = {k for k, side in enumerate(sides) if side[0].smooth and continuity == "G1"
                and (held is None or k in held)}
    if mirrored:
        ends = {vertices.along[k][e] for k in mirrored for e in (0, -1)}
        fans = {root: corners for root, corners in vertices.fans_among(system.fixed).items()
                if root in ends}
        ratios = _straightened(sides, vertices.crossings_among(system.fixed, fans))
    rows = vertices.rows
    active = np.array([join.cut or k in mirrored for k, (join, *_) in enumerate(sides)],
                      dtype=bool)
    taken = np.flatnonzero(active[rows.side] & ~np.isin(rows.vertex, list(fans)))
    taken = taken[tied_in_order(label[rows.ends[taken]], classes)]
    values, mirror = rows.values[taken], rows.mirror[taken]
    values[mirror, 2:4] *= np.asarray(ratios)[rows.side[taken][mirror], None]   # mu
    used = values != 0.0
    matrix = sp.csr_matrix((values[used], (np.nonzero(used)[0], rows.columns[taken][used])),
                           shape=(len(taken), size))
    kinks = np.isin(rows.side[taken], list(kinked))[:, None] * (matrix @ system.source)
    return (ties, matrix, kinks, _plane_rows(system, fans, vertices.normals, label),
            len(taken))


class _Rows(NamedTuple):
    r"""Rows the joins of a network may constrain it with (:func:`_join_rows`), one per
    entry, each over six poles at most (``columns``; ``values`` 0 where fewer).

    Attributes
    ----------
    side : numpy.ndarray
        The join of each row.
    vertex : numpy.ndarray
        A mirrored row's vertex (its border poles' class), -1 for a C2 row.
    mirror : numpy.ndarray
        True for a mirrored row, :math:`w_a + \mu w_b = 0` over
        ``(inner_a, border_a, inner_b, border_b)`` with ``values`` (1, -1, 1, -1): its
        join's :math:`\mu` multiplies the last two.
    ends : numpy.ndarray
        (n, 2): the two poles whose classes the row ties (the inner poles of a mirrored
        row, the second rows' poles of a C2 row).
    columns, values : numpy.ndarray
        (n, 6): the row's poles and coefficients.
    """

    side: np.ndarray
    vertex: np.ndarray
    mirror: np.ndarray
    ends: np.ndarray
    columns: np.ndarray
    values: np.ndarray


def _join_rows(sides, along, cut_rows):
    """The :class:`_Rows` of the joins ``sides`` (:func:`_join_sides`), join after join:
    its mirrored rows (``along``: the vertex of each of side a's border poles), then its
    C2 rows (``cut_rows``: ``{join: [(columns, values)]}``, :func:`_curvature_rows`)."""
    entries = []    # (side, vertex, mirror, ends, columns, values)
    for k, (_, border_a, inner_a, border_b, inner_b, _) in enumerate(sides):
        for root, ia, na, ib, nb in zip(along[k], *(
                x.tolist() for x in (border_a, inner_a, border_b, inner_b))):
            entries.append((k, root, True, (na, nb), (na, ia, nb, ib, 0, 0),
                            (1.0, -1.0, 1.0, -1.0, 0.0, 0.0)))
        for poles, values in cut_rows.get(k, ()):
            entries.append((k, -1, False, (poles[2], poles[5]), poles, values))
    side, vertex, mirror, ends, columns, values = (list(x) for x in zip(*entries)) \
        if entries else ([],) * 6
    return _Rows(np.array(side, dtype=int), np.array(vertex, dtype=int),
                 np.array(mirror, dtype=bool), np.array(ends, dtype=int).reshape(-1, 2),
                 np.array(columns, dtype=int).reshape(-1, 6),
                 np.array(values, dtype=float).reshape(-1, 6))


def _curvature_rows(forms, join, vertices):
    r"""Rows that hold two pieces of one surface C2 across their cut (``join.cut``): the
    second cross derivatives at the cut agree,

    .. math:: \sum_{k<3} a_k P^a_k - \sum_{k<3} b_k P^b_k = 0

    per pole along the cut (:math:`P_0` the border row, :math:`P_1, P_2` the rows inside,
    :math:`a_k, b_k` the second derivatives of the cross basis functions at the cut).
    Where the cut ends at a vertex with other patches (a T-junction, ``vertices``: a
    :class:`_Vertices`) the row there is left out: it would also tie the borders of the
    two patches beside the cut's end, which the vertex's rows hold.  Each row:
    ``(columns, values)`` of six entries, the second rows' poles at columns 2 and 5."""
    weights = []
    for patch, side in ((join.a, join.side_a), (join.b, join.side_b)):
        space = forms.patches[patch].u_space if side[0] == "u" else forms.patches[patch].v_space
        end = space.domain[0 if side[1] == "0" else 1]
        second = space.collocation(np.array([end]), 2).toarray()[0]
        weights.append(second[:3] if side[1] == "0" else second[::-1][:3])
    values = tuple(weights[0]) + tuple(-weights[1])
    lines_a = _side_rows(forms, join.a, join.side_a, 3)
    lines_b = _side_rows(forms, join.b, join.side_b, 3)
    if join.reversed:
        lines_b = [line[::-1] for line in lines_b]
    count = len(lines_a[0])
    return [([int(line[i]) for line in lines_a] + [int(line[i]) for line in lines_b], values)
            for i in range(count)
            if i not in (0, count - 1) or vertices.sizes[vertices.root(int(lines_a[0][i]))] <= 2]


def _diagonal(points):
    """The bounding-box diagonal of ``points``."""
    return float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))


def _corners(forms):
    """``(corner, edge_u, edge_v)`` pole indices of every patch corner: the corner pole
    and its neighbours along u and along v."""
    out = []
    for f, patch in enumerate(forms.patches):
        ku, kv = patch.shape
        index = forms.offsets[f] + np.arange(ku * kv).reshape(ku, kv)
        for i, j in ((0, 0), (0, -1), (-1, 0), (-1, -1)):
            out.append((int(index[i, j]), int(index[1 if i == 0 else -2, j]),
                        int(index[i, 1 if j == 0 else -2])))
    return out


def _fans(source, sides, vertices):
    """``{vertex: [(corner, edge_u, edge_v)]}``: the vertices of three or more patches
    (:class:`_Vertices`) whose mirrored rows at the vertex itself would make one edge
    from it collinear with two others (around three or five patches, along a fan of
    three or more joins), or that the source does not follow (its edges from the vertex
    further than :data:`STRAIGHT` from the rows), where no crease ends.  Where each edge
    is made collinear with one other at most (two patches, an L of three, a crossing of
    four) and the source's edges are nearly so, the rows are lines through the vertex
    and stay.  (A fan is one while at most one of its patches is kept:
    :meth:`_Vertices.fans_among`.)"""
    creased, links, bent = set(), {}, set()
    for join, border_a, inner_a, border_b, inner_b, mu in sides:
        for i in (0, -1):
            root = vertices.root(int(border_a[i]))
            if not join.smooth:
                creased.add(root)
                continue
            pair = frozenset(vertices.root(int(x[i])) for x in (inner_a, inner_b))
            links.setdefault(root, set()).add(pair)
            wa, wb = source[inner_a[i]] - source[border_a[i]], source[inner_b[i]] - source[border_b[i]]
            if np.linalg.norm(wa + mu * wb) > STRAIGHT * np.linalg.norm(wa):
                bent.add(root)
    out = {}
    for root, corners in vertices.corners.items():
        degree = {}
        for pair in links.get(root, ()):
            for node in pair:
                degree[node] = degree.get(node, 0) + 1
        lines = max(degree.values(), default=0) < 2 and root not in bent
        if len(corners) >= 3 and not lines and root not in creased:
            out[root] = corners
    return out


def _crossings(sides, vertices):
    """``{vertex: [(join, opposite join, same)]}``: the crossings (four patches, four
    smooth joins, each patch in two of them), with each join's opposite one (no patch in
    common) and whether their sides ``a`` are neighbours (so that the two mirror ratios
    are one, not one and its inverse).  (A crossing is one while none of its patches
    is kept and it is no fan: :meth:`_Vertices.crossings_among`.)"""
    ends = {}
    for k, (_, border_a, *_rest) in enumerate(sides):
        for index in (border_a[0], border_a[-1]):
            ends.setdefault(vertices.root(int(index)), []).append(k)
    out = {}
    for root, corners in vertices.corners.items():
        around = ends.get(root, [])
        pairs = [{sides[k][0].a, sides[k][0].b} for k in around]
        members = [p for pair in pairs for p in pair]
        if (len(corners) != 4 or len(around) != 4 or not all(sides[k][0].smooth for k in around)
                or any(members.count(p) != 2 for p in members)):
            continue
        out[root] = [(k, o, {sides[k][0].a, sides[o][0].a} in pairs)
                     for k in around for o in around if not pairs[around.index(k)]
                     & pairs[around.index(o)]]
    return out


def _straightened(sides, crossings):
    """Per side, its mirror ratio, with the joins opposite each other at a crossing given
    one ratio (the geometric mean over each line of joins through crossings, inverted
    where their sides ``a`` lie on opposite sides of the line; the mean of its cuts' where
    the line holds a cut of one surface, whose ratio is exact): the mirrored rows at the
    vertex then make its two lines of edges straight, and the cycle of rows around it
    closes, as in one surface cut into four (:mod:`cq_fairing.core.joins`, step 6)."""
    lines = UnionFind()
    for crossing in crossings.values():
        for k, o, same in crossing:
            lines.tie(k, o, parity=not same)
    ratios = [side[-1] for side in sides]
    for group in lines.members().values():
        cuts = [(k, flip) for k, flip in group if sides[k][0].cut]
        mean = np.mean([-np.log(ratios[k]) if flip else np.log(ratios[k])
                        for k, flip in cuts or group])
        for k, flip in group:
            ratios[k] = float(np.exp(-mean if flip else mean))
    return ratios


def _plane_rows(system, fans, normals, label):
    r"""Rows :math:`n\cdot(e - c) = 0` over the three coordinates: the first pole
    :math:`e` of every edge from a fan vertex :math:`c` in the plane of the vertex
    normal :math:`n` (the mean unit normal of the sources' corners there, ``normals``,
    signs aligned; a kept patch's own where one is kept), so that the patches around it share one
    tangent plane at the vertex.  Per pair of pole classes (``label``: each pole's
    class, the held class that of the last entry) one row; none between held poles.

    Returns
    -------
    difference : scipy.sparse.csr_matrix
        :math:`D` (r, poles): per row +1 at :math:`e`, -1 at :math:`c`.
    normals : numpy.ndarray
        :math:`N` (r, 3): per row its :math:`n`; the rows are
        :math:`R = [\,\mathrm{diag}(N_{:,0}) D\;\;\mathrm{diag}(N_{:,1}) D\;\;
        \mathrm{diag}(N_{:,2}) D\,]` on the coordinates' poles one after the other.
    """
    size = int(system.offsets[-1])
    held = label[size]
    pairs, directions, seen = [], [], set()
    for root, corners in fans.items():
        kept = [c for c in corners if system.fixed[c[1]]]     # a kept patch's corner
        normal = mean_normal([normals[c] for c in kept[:1] or corners])
        if normal is None:
            continue
        for corner, *edges in corners:
            for edge in edges:
                key = (label[edge], root)
                if key in seen or key[0] == held:
                    continue
                seen.add(key)
                pairs.append((edge, corner))
                directions.append(normal)
    pairs = np.array(pairs, dtype=int).reshape(-1, 2)
    difference = sp.csr_matrix((np.tile([1.0, -1.0], len(pairs)),
                                (np.repeat(np.arange(len(pairs)), 2), pairs.ravel())),
                               shape=(len(pairs), size))
    return difference, np.array(directions, dtype=float).reshape(-1, 3)


def _source_normal(source, corner):
    """Unit normal of a source patch at a corner, :math:`(e_u - c)\times(e_v - c)` from
    its poles (``None`` where it vanishes)."""
    c, eu, ev = (source[i] for i in corner)
    n = np.cross(eu - c, ev - c)
    length = np.linalg.norm(n)
    scale = max(np.linalg.norm(eu - c) * np.linalg.norm(ev - c), 1e-300)
    return n / length if length > 1e-9 * scale else None


class _Probes:
    """Every patch's samples (at least :data:`SAMPLES` per direction, three per span), its
    source's points and normals there, and the refined spaces' basis values, so that a
    candidate network costs a few small products: the patches with as many samples and
    poles in each direction are evaluated together, each with its own bases."""

    def __init__(self, sources, refined):
        self.groups, spaces = {}, {}
        for f, (source, patch) in enumerate(zip(sources, refined)):
            key = (source.u_space.key, source.v_space.key, patch.u_space.key, patch.v_space.key)
            if key not in spaces:
                spaces[key] = _sample_bases(source, patch)
            shape = tuple(b.shape for b in spaces[key][0::2])
            self.groups.setdefault(shape, []).append((f, key))
        self.bases, self.points, self.normals = {}, {}, {}
        for shape, members in self.groups.items():
            self.bases[shape] = [np.stack([spaces[key][k] for _, key in members])
                                 for k in range(4)]
            self.points[shape], self.normals[shape] = self._evaluate(
                shape, np.stack([refined[f].poles for f, _ in members]), slice(None))

    def _evaluate(self, shape, poles, rows):
        """Points and unnormalised normals of the nets ``poles`` (g, k_u, k_v, 3) of the
        members ``rows`` of the group ``shape``, at their samples: (g, n_u, n_v, 3)
        each."""
        bu, du, bv, dv = (b[rows] for b in self.bases[shape])
        g, ku, kv, d = poles.shape
        flat = poles.reshape(g, ku, kv * d)
        # (g, n_u, k_v, d) -> (g, n_u, d, k_v) @ (g, 1, k_v, n_v) -> (g, n_u, n_v, d)
        along_u, slope_u = ((b @ flat).reshape(g, -1, kv, d).swapaxes(2, 3) for b in (bu, du))
        across_v, slope_v = (b.swapaxes(1, 2)[:, None] for b in (bv, dv))
        points = (along_u @ across_v).swapaxes(2, 3)
        su = (slope_u @ across_v).swapaxes(2, 3)
        sv = (along_u @ slope_v).swapaxes(2, 3)
        return points, np.cross(su, sv)

    def distances(self, surfaces, kept):
        """Each patch's largest same-parameter distance from its source (0 for ``kept``);
        infinite where the surface folds over (:func:`~cq_fairing.core.geometry.folded`)."""
        out = np.zeros(len(surfaces))
        for shape, members in self.groups.items():
            rows = [q for q, (f, _) in enumerate(members) if f not in kept]
            if not rows:
                continue
            points, normals = self._evaluate(
                shape, np.stack([surfaces[members[q][0]].poles for q in rows]), rows)
            distance = np.linalg.norm(points - self.points[shape][rows], axis=-1).max(axis=(1, 2))
            reference = self.normals[shape][rows]
            # a surface can only fold where its normals point away from the source's
            apart = (np.einsum("gijd,gijd->gij", normals, reference) < 0.0).any(axis=(1, 2))
            for k in np.flatnonzero(apart):
                if folded(normals[k], reference[k]).any():
                    distance[k] = np.inf
            out[[members[q][0] for q in rows]] = distance
        return out


def _sample_bases(source, refined):
    """``[B_u, B_u', B_v, B_v']``: the refined spaces' basis values and first derivatives
    at the samples of ``source``'s spaces (at least :data:`SAMPLES` per direction, three
    per span)."""
    samples = (np.unique(np.concatenate(
        [np.linspace(a, b, 3) for a, b in zip(space.breakpoints[:-1], space.breakpoints[1:])]
        + [np.linspace(*space.domain, SAMPLES)]))
        for space in (source.u_space, source.v_space))
    return [space.collocation(x, nu).toarray()
            for space, x in zip((refined.u_space, refined.v_space), samples) for nu in (0, 1)]
