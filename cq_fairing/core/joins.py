r"""Joint projection of patches that meet along whole borders: joins closed (G0) and
smooth (G1) by construction.

Patches are tensor-product B-spline surfaces.  A *border join* ties side :math:`s_a` of
patch :math:`a` to side :math:`s_b` of patch :math:`b` (sides ``"u0"``, ``"u1"``,
``"v0"``, ``"v1"``: the iso-lines :math:`u = u_{min}`, :math:`u = u_{max}`, ...), their
along-parameters running the same way or reversed.  :func:`fair_patches` projects every
patch onto its target space (the exact L2 projection of the wavelet method) under the
constraints that make the joins hold:

1. **Chords.**  A join ties the along-directions of its two patches; the tied
   ``(patch, axis)`` pairs form classes.  Each class gets one knot vector on
   :math:`[0, 1]`: the union of its members' target knots (normalised, reversed where a
   member runs the other way; knots closer than :data:`SNAP` of the finest member's span
   merged) at the largest member degree :math:`P`.  A kept patch adds its own knots with
   multiplicity :math:`m + P - p`, so that its degree-:math:`p` border lies in the class
   space exactly; where it has at least as many spans as each solved member, its knots
   alone make the class.
2. **Vertices.**  The corners tied by the joins form vertices, each at the mean of its
   corners (a kept patch's corner where there is one).  Where no crease meets a vertex,
   the end tangents of its edges are held in the plane of its mean source normal, so
   the patches around it share a tangent plane there.
3. **Edge ends.**  A join's border curve is the L2 projection onto the class space of
   the first patch's source border (normalised parameter) with its ends held at the
   vertices, :math:`G_{II} x_I = (E c)_I - G_{IE} x_E`,
   :math:`E = \langle\Phi|\Phi_{S}\rangle`, its end tangents in the vertices' planes
   (step 2) and, at a crossing, through it (step 6); next to a kept patch it is that
   patch's border itself (the projection of an element of the space is the element).
   Next to a kept patch the whole curve is held; between two solved patches only its
   ends and the poles next to them (the end tangents), the rest of the border being
   unknowns of step 4.
4. **Patches, projected jointly.**  Every pole of the solved patches is a slot; the held
   slots carry step 3's poles :math:`h`, and each other border pole of a join between
   two solved patches is one unknown shared by both patches, pole for pole: slots
   :math:`= P x + h`, :math:`P` 0/1 (one column per class of tied slots).  The poles
   are the L2 projection of all sources at once,

   .. math:: P^T A P\, x = P^T (b - A h),\qquad
             A = \mathrm{diag}_k(G_{u,k}\otimes G_{v,k}),\quad
             b_k = \mathrm{vec}(E_{u,k} C_k E_{v,k}^T),

   so a shared border is the least-squares compromise of both patches' sources, and
   the two patches have one border curve: G0 to round-off.  Both sources are taken at
   equal normalised parameters along the join: where two faces run along one curve
   with different parametrizations the compromise would cut across it, so such sides
   are pinned (:func:`pinning_patch`), not joined (the caller's rule:
   :func:`~cq_fairing.core.joint_projection.border_joins`).
5. **G1 at smooth joins.**  The cross-boundary rows of the two patches mirror each other
   across the shared border, :math:`w_{a,i} + \mu w_{b,i} = 0` with
   :math:`w = c_{inner} - c_{border}` per pole along the join and :math:`\mu > 0` one
   ratio per join, the geometric mean of the rows' length ratios in the G0 solve.  Both
   patches share the join's knots and degree along it, so with one :math:`\mu` their
   cross derivatives are parallel along the whole join, not only at the poles: the
   tangent planes agree exactly (a ratio that varies from pole to pole would leave them
   apart between the poles: 0.10-0.19 deg on the 2 x 2 example grid).
   The rows :math:`C x = d` act on step 4's unknowns (the shared border and the
   patches' inner rows) and on each coordinate alike: one regularised KKT system,
   :math:`\begin{bmatrix}P^T A P & sC^T\\ sC & -\varepsilon I\end{bmatrix}`, one
   factorization for x, y and z.
   Normal-plane conditions :math:`n_k\cdot\partial_\perp S(t_k) = 0` at Greville
   points, the obvious alternative, leave the tangent planes free between the points
   (several degrees on a curved 2 x 2 grid), and more points collapse the cross rows.
6. **Vertices where joins cross.**  Around an inner vertex the rows next to it close a
   cycle (the twist poles of the patches around it), singular where the ratios'
   product is 1: the vertex enclosure condition of G1 patch complexes.  At a *crossing*
   (four solved patches around the vertex, four smooth joins, each patch in two of
   them: a vertex of a patch grid) the cycle is made consistent, as it is in one
   surface cut into four: the two joins opposite each other share one ratio (the
   geometric mean over each line of joins through crossings), and the two edges of a
   line run straight through the vertex, :math:`(x_a - V) + \mu (x_b - V) = 0` for
   their poles next to it, with the ratio of a join crossing them (its mirrored row at
   the vertex).  These rows enter the edges' projection (step 3, one system over all
   edges), and the tangent planes then agree at the crossing too (to 1e-4 deg, tested).
   At other vertices (three or five patches, a kept patch, a crease) the row that would
   close the cycle is left out, the vertex keeping its tangent plane through its edges
   (step 2); the planes may turn in the spans next to it.

Rational patches are solved in homogeneous coordinates :math:`(w c, w)`: where any
patch is rational, every net is lifted (weights 1 for a polynomial patch), the
projection, the shared borders and the mirrored rows act on four coordinates alike, and
the results are rational.  A shared homogeneous border is one border curve (G0), and
mirrored homogeneous rows make both the numerator's and the weight's cross derivatives
proportional, hence the cross derivatives of the quotient (G1).  The vertices' tangent
planes (step 2) are then not imposed, and the weights are not checked: the caller keeps
a patch whose weights are not all positive.  This module imports numpy and scipy only.
"""

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from ..errors import InvalidInputError
from .banded import BandedSPD
from .evaluation import rational_derivatives
from .geometry import BSplineSurface
from .gram import gram_matrix, sandwiched
from .spaces import SplineSpace

__all__ = ["BorderJoin", "JointPatch", "JointResult", "fair_patches", "join_angles",
           "pinning_patch", "side_parameters", "side_points", "turned_patches", "JoinTurns",
           "mirror_ratio", "UnionFind", "mean_normal", "shared_basis", "tied_in_order",
           "SIDES", "CONTINUITIES", "ANGLE_SLACK", "cross_curvatures",
           "holds_curvature", "CURVATURE_SLACK", "kkt_solve"]

SIDES = ("u0", "u1", "v0", "v1")
CONTINUITIES = ("G0", "G1", "G2")
SNAP = 0.25        # knots of a chord's members closer than this x the finest span merge
KKT_EPS = 1e-12    # regularisation of the joint system's constraint block (relative)
ANGLE_SLACK = 0.05  # degrees a smooth join may turn beyond the source's angle
ANGLE_SAMPLES = 33  # samples along a join for that check
CURVATURE_SLACK = 0.1  # relative curvature jump below which a source join counts as G2
FLAT = 1e-3         # curvature x patch size below which a join counts as flat (G2)
DEGENERATE = 1e-6   # cross speed, relative to its largest, below which a border collapses


@dataclass(frozen=True)
class JointPatch:
    """One patch of :func:`fair_patches`.

    Attributes
    ----------
    source : BSplineSurface
        Polynomial, clamped.
    target : (SplineSpace, SplineSpace) or None
        The patch's own target spaces (from its tolerance search, on the source's
        domain); ``None`` keeps the patch as it is: its borders then constrain its
        neighbours.
    """

    source: BSplineSurface
    target: tuple = None

    @property
    def kept(self):
        return self.target is None

    def space(self, axis):
        """Target space along ``axis`` (0: u, 1: v); the source's for a kept patch."""
        spaces = (self.source.u_space, self.source.v_space) if self.kept else self.target
        return spaces[axis]


@dataclass(frozen=True)
class BorderJoin:
    """Side ``side_a`` of patch ``a`` is side ``side_b`` of patch ``b``.

    Attributes
    ----------
    a, b : int
        Patch indices.
    side_a, side_b : str
        One of :data:`SIDES`.
    reversed : bool
        The along-parameters run opposite ways.
    smooth : bool
        Hold the tangent planes together (G1); otherwise only the border (G0), as at a
        crease.
    curvature : bool
        With ``continuity="G2"``, also the normal curvature across a smooth join (G2);
        ``False`` where the curvature jumps by design (a fillet meeting a plane).
    cut : bool
        The patches are pieces of one surface cut apart along the join, ``a`` before
        ``b`` in its cross parameter: the energy network
        (:mod:`cq_fairing.core.network`) holds them C2 across, as one surface.
    """

    a: int
    side_a: str
    b: int
    side_b: str
    reversed: bool = False
    smooth: bool = True
    curvature: bool = True
    cut: bool = False


@dataclass(frozen=True)
class JointResult:
    """Outcome of :func:`fair_patches`.

    Attributes
    ----------
    surfaces : list of BSplineSurface
        One per patch; a kept patch's source itself.
    joins : list of BorderJoin
        The joins imposed (a join whose chord would tie a direction to its own reverse is
        left out, and so is a join between two kept patches).
    dropped : list of (BorderJoin, str)
        Joins left out, with the reason.
    g1_rows : int
        Cross-row conditions imposed (G1: one per pole along each smooth join; G2: up to
        one more), each for every coordinate.
    curved : list of BorderJoin
        The joins held in G2 (``continuity="G2"``): smooth, ``curvature`` set, and with
        three rows across on each side that no other join's conditions use.
    """

    surfaces: list
    joins: list
    dropped: list
    g1_rows: int = 0
    curved: list = field(default_factory=list)


def fair_patches(patches, joins, *, continuity="G1"):
    """Project patches onto their targets with closed (and smooth) border joins.

    Parameters
    ----------
    patches : sequence of JointPatch
    joins : sequence of BorderJoin
        Each side of a patch in at most one join.
    continuity : {"G0", "G1", "G2"}
        ``"G1"`` also holds the tangent planes together across the smooth joins,
        ``"G2"`` also the normal curvature across those with ``curvature`` set.

    Returns
    -------
    JointResult

    Raises
    ------
    InvalidInputError
        Unknown sides or patch indices, a side in two joins, or an unknown
        ``continuity``.
    """
    patches, joins = _checked(patches, joins, continuity)
    chords, joins, dropped = _chords(patches, joins)
    spaces = _spaces(patches, chords)
    lifted = any(p.source.is_rational for p in patches)
    vertices = _vertices(patches, joins, lifted)
    edges = _edges(patches, joins, spaces, chords, vertices, lifted)
    work = _Patchwork(patches, spaces, joins, _held_rows(patches, edges, _solved_edges(edges)),
                      lifted)
    surfaces, rows, curved = work.surfaces(work.solve()), 0, {}
    if continuity != "G0" and any(j.smooth for j in joins):
        ratios = _mirror_ratios(work, joins, chords, surfaces)
        crossings = _crossings(patches, joins, edges)
        curved = _curved(work, joins, edges, crossings, continuity)
        if crossings:
            ratios = _straightened(ratios, crossings)
            lines = _line_rows(work, joins, crossings, ratios, curved)
            work = _Patchwork(patches, spaces, joins,
                              _held_rows(patches, edges, _solved_edges(edges, lines)), lifted)
        c, d = _condition_rows(work, joins, chords, ratios, curved)
        surfaces, rows = work.surfaces(work.solve(c, d)), c.shape[0]
    return JointResult(surfaces, joins, dropped, rows, [joins[k] for k in sorted(curved)])


def pinning_patch(source, side):
    r"""A kept patch that, joined to ``side`` of a patch faired from ``source``, holds
    that side where the source has it.

    It is the source reflected through its border along ``side`` (for ``"v0"``:
    :math:`R(u, v) = 2 S(u, v_0) - S(u, v)`, poles :math:`2 c_{i0} - c_{ij}`): its border
    is the source's border and its cross derivative the source's, reversed.  Joined by
    :class:`BorderJoin` ``(patch, side, pinning, side)``, the edge is the source's border
    (a kept patch's border is the edge, and its knots enter the class space), and at a
    smooth join the mirrored rows give :math:`w = \mu\, w_{source}`: the faired patch
    keeps the source's border curve and tangent plane along it exactly.  This holds a
    side whose neighbour the joint projection cannot join pole for pole (a neighbour
    parametrized differently, a partial side, an analytic or rational neighbour): the
    join keeps the source's gap and angle.
    """
    if side not in SIDES:
        raise InvalidInputError(f"side must be one of {SIDES}, got {side!r}.")
    net = np.moveaxis(_net(source, source.is_rational), 1 - _along(side), 0)
    border = net[_end(side)]
    scale = _reflection_scale(border[..., -1], net[..., -1]) if source.is_rational else 1.0
    net = np.moveaxis((1.0 + scale) * border - scale * net, 0, 1 - _along(side))
    return JointPatch(_from_net(net, (source.u_space, source.v_space), source.is_rational))


def _reflection_scale(border_weights, weights):
    r"""The largest :math:`s \le 1` keeping the weights :math:`(1 + s) w_0 - s w` of a
    rational source reflected through its border positive (halved for a margin): the
    cross row then mirrors the source's scaled by ``s``, which the mirror ratio absorbs."""
    base = np.broadcast_to(border_weights, weights.shape)
    rise = weights - base
    limits = base[rise > 0] / rise[rise > 0]
    return 1.0 if not len(limits) or limits.min() > 2.0 else 0.5 * float(limits.min())


def side_parameters(surface, side, t):
    """``(u, v)`` grid arguments of the points of ``side`` at the normalised parameters
    ``t`` along it (one of them a single border value)."""
    (u0, u1), (v0, v1) = surface.domain
    if side[0] == "u":
        return [u0 if side[1] == "0" else u1], v0 + (v1 - v0) * np.asarray(t)
    return u0 + (u1 - u0) * np.asarray(t), [v0 if side[1] == "0" else v1]


def join_angles(surfaces, join, t, t_b=None, known=None):
    """Angle (degrees) between the two patches' normals at the normalised parameters
    ``t`` along ``join`` (folded to at most 90: the faces' orientations do not count);
    ``t_b``: side ``b``'s own normalised parameters of those points, where its
    parametrization along the join differs (default: the same ``t``, reversed with the
    join); ``known``: as in :func:`_side_bases`."""
    t = np.asarray(t, dtype=float)
    if t_b is None:
        t_b = 1.0 - t if join.reversed else t
    normals = [_side_normals(surfaces[index], side, along, known)
               for index, side, along in ((join.a, join.side_a, t),
                                          (join.b, join.side_b, np.asarray(t_b, dtype=float)))]
    cos = np.clip(np.abs(np.sum(normals[0] * normals[1], axis=1)), 0.0, 1.0)
    return np.degrees(np.arccos(cos))


def _nearest_along(surfaces, join, t, samples=ANGLE_SAMPLES * 16, known=None):
    """Side ``b``'s normalised parameters of the points of its border nearest to side
    ``a``'s border points at ``t`` (among ``samples`` points of side ``b``): where the
    two sources run along the join at different speeds, equal parameters are different
    places (``known``: as in :func:`_side_bases`)."""
    dense = np.linspace(0.0, 1.0, samples)
    points = [side_points(surfaces[index], side, along, known)
              for index, side, along in ((join.a, join.side_a, np.asarray(t, dtype=float)),
                                         (join.b, join.side_b, dense))]
    nearest = np.argmin(np.linalg.norm(points[0][:, None] - points[1][None], axis=2), axis=1)
    return dense[nearest]


def side_points(surface, side, along, known=None):
    """Points along ``side`` at the normalised parameters ``along`` (``known``: as in
    :func:`_side_bases`)."""
    return _side_derivatives(surface, side, along, 0, known)[(0, 0)]


def _side_normals(surface, side, along, known=None):
    """Unit normals :math:`S_u\times S_v` along ``side`` at the normalised parameters
    ``along`` (``known``: as in :func:`_side_bases`)."""
    d = _side_derivatives(surface, side, along, 1, known)
    n = np.cross(d[(1, 0)], d[(0, 1)])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)


def _side_derivatives(surface, side, along, order, known=None):
    """Partial derivatives ``{(a, b): S_{u^a v^b}}`` up to ``order`` along ``side`` at
    the normalised parameters ``along``: the (homogeneous) net contracted with the side's
    basis values there (:func:`_side_bases`, with ``known``), the quotient rule applied
    for a rational surface (:func:`~cq_fairing.core.evaluation.rational_derivatives`)."""
    across, lengthwise = _side_bases(surface, side, along, order, known)
    net = surface.homogeneous() if surface.is_rational else surface.poles
    if side[0] == "v":
        net = net.swapaxes(0, 1)
    k, m, d = net.shape
    lines = (across[:order + 1] @ net.reshape(k, m * d)).reshape(-1, m, d)
    h = {}
    for total in range(order + 1):
        for cross in range(total, -1, -1):
            key = (cross, total - cross) if side[0] == "u" else (total - cross, cross)
            h[key] = lengthwise[total - cross] @ lines[cross]
    return rational_derivatives(h) if surface.is_rational else h


def _side_bases(surface, side, along, order, known=None):
    """``(across, lengthwise)``: the basis functions of ``surface``'s space across
    ``side`` and their derivatives up to ``order`` at its border, (order + 1, k_across),
    and those of its space along it at the normalised parameters ``along``, (order + 1,
    q, k_along) (:meth:`~cq_fairing.core.spaces.SplineSpace.basis_values`): the same for
    every surface on those spaces, each kept in ``known`` (a dict), when given, for the
    next one."""
    u, v = side_parameters(surface, side, along)
    spaces = ((surface.u_space, u), (surface.v_space, v))
    if side[0] == "v":
        spaces = spaces[::-1]
    out = []
    for space, x in spaces:
        key = (space.key, order, np.asarray(x, dtype=float).tobytes())
        if known is None or key not in known:
            values = space.basis_values(x, order)
            if known is None:
                out.append(values)
                continue
            known[key] = values
        out.append(known[key])
    return out[0][:, 0], out[1]


def cross_curvatures(surfaces, join, t, t_b=None):
    r"""Normal curvatures :math:`\kappa = n\cdot S_{cc} / |S_c|^2` of the two patches of
    ``join`` in their cross directions (:math:`c`), at the normalised parameters ``t``
    along it (``t_b``: side ``b``'s own parameters of those points, as in
    :func:`join_angles`), the second patch's normal turned to the first's:
    ``(kappa_a, kappa_b)``;
    NaN where the cross derivative vanishes (below :data:`DEGENERATE` of its largest
    along the join: a collapsed border).
    The curve that crosses a curvature-continuous (G2) join has one normal curvature
    there, whichever way it runs, so the two agree."""
    out, reference = [], None
    if t_b is None:
        t_b = 1.0 - t if join.reversed else t
    for index, side, along in ((join.a, join.side_a, t), (join.b, join.side_b, t_b)):
        surface = surfaces[index]
        u, v = side_parameters(surface, side, along)
        order = (1, 0) if side[0] == "u" else (0, 1)
        su, sv, cross, second = (surface.evaluate_grid(u, v, *d).reshape(-1, 3) for d in
                                 ((1, 0), (0, 1), order, (2 * order[0], 2 * order[1])))
        normal = np.cross(su, sv)
        normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-300)
        if reference is not None:
            normal *= np.where(np.sum(normal * reference, axis=1) < 0, -1.0, 1.0)[:, None]
        reference = normal
        speed = np.sum(cross * cross, axis=1)
        degenerate = speed <= DEGENERATE ** 2 * speed.max()
        out.append(np.where(degenerate, np.nan,
                            np.sum(normal * second, axis=1) / np.where(degenerate, 1.0, speed)))
    return tuple(out)


def holds_curvature(sources, join):
    """Whether the sources are curvature-continuous across ``join``: the cross normal
    curvatures of its two sides (:func:`cross_curvatures`, :data:`ANGLE_SAMPLES`
    samples) differ nowhere by more than :data:`CURVATURE_SLACK` of the larger curvature
    along it, or both stay below :data:`FLAT` over the larger patch's size (flat); each
    point of side ``a`` against the nearest of side ``b`` (:func:`_nearest_along`)."""
    t = np.linspace(0.0, 1.0, ANGLE_SAMPLES)
    ka, kb = cross_curvatures(sources, join, t, _nearest_along(sources, join, t))
    both = ~(np.isnan(ka) | np.isnan(kb))
    if not both.any():
        return False
    ka, kb = ka[both], kb[both]
    largest = max(np.abs(ka).max(), np.abs(kb).max())
    size = max(sources[join.a].size, sources[join.b].size)
    return bool(largest * size <= FLAT or np.abs(ka - kb).max() <= CURVATURE_SLACK * largest)


class JoinTurns:
    """The sources' normal angles along every smooth join of ``joins``
    (:data:`ANGLE_SAMPLES` samples), measured once, against which faired patches are
    checked (:meth:`turned`); the basis values at the samples are kept per space
    (:func:`_side_bases`): patches faired again and again keep their spaces."""

    def __init__(self, sources, joins):
        self.joins = list(joins)
        self.samples = np.linspace(0.0, 1.0, ANGLE_SAMPLES)
        self._bases = {}
        self.source = {k: join_angles(sources, join, self.samples,
                                      _nearest_along(sources, join, self.samples,
                                                     known=self._bases), known=self._bases)
                       for k, join in enumerate(self.joins) if join.smooth}

    def turned(self, surfaces, moved):
        """The patches of ``moved`` on a smooth join that turns (:meth:`turned_joins`)."""
        return {patch for k in self.turned_joins(surfaces, moved)
                for patch in (self.joins[k].a, self.joins[k].b)} & set(moved)

    def turned_joins(self, surfaces, moved):
        """The indices of the smooth joins with a patch of ``moved`` whose normals turn,
        somewhere along them, more than :data:`ANGLE_SLACK` degrees beyond the sources'
        angle at the same place (the faired patches share their border's
        parametrization, so their angle is measured at equal parameters; the sources' at
        each point of side ``a`` and the nearest point of side ``b``:
        :func:`_nearest_along`)."""
        moved = set(moved)
        return {k for k, angles in self.source.items()
                if {self.joins[k].a, self.joins[k].b} & moved
                and np.max(join_angles(surfaces, self.joins[k], self.samples,
                                       known=self._bases) - angles) > ANGLE_SLACK}

    def tangent(self):
        """True when every smooth join is tangent in the sources within
        :data:`ANGLE_SLACK` degrees."""
        return all(angles.max() <= ANGLE_SLACK for angles in self.source.values())


def turned_patches(surfaces, sources, joins, moved):
    """:meth:`JoinTurns.turned` of ``surfaces`` against ``sources``, measured here."""
    return JoinTurns(sources, joins).turned(surfaces, moved)


# -- input ---------------------------------------------------------------------------------
def _checked(patches, joins, continuity):
    if continuity not in CONTINUITIES:
        raise InvalidInputError(
            f"continuity must be one of {CONTINUITIES}, got {continuity!r}; 'G1' keeps "
            "smooth joins smooth, 'G2' also their curvature, 'G0' only closed.")
    patches, joins = list(patches), list(joins)
    for i, patch in enumerate(patches):
        if not isinstance(patch, JointPatch):
            raise InvalidInputError(f"patch {i} must be a JointPatch, got {type(patch).__name__}.")
    used = set()
    for join in joins:
        for index, side in _join_sides(join):
            if side not in SIDES:
                raise InvalidInputError(f"a join side must be one of {SIDES}, got {side!r}.")
            if not 0 <= index < len(patches):
                raise InvalidInputError(
                    f"join patch index {index} is out of range (0..{len(patches) - 1}).")
            if (index, side) in used:
                raise InvalidInputError(
                    f"side {side} of patch {index} is in two joins; a side meets one "
                    "neighbour (split a non-manifold join before fairing).")
            used.add((index, side))
    return patches, joins


def _along(side):
    """Axis along a side: ``"u0"``/``"u1"`` run along v (1), ``"v0"``/``"v1"`` along u (0)."""
    return 1 if side[0] == "u" else 0


def _end(side):
    """0 for the low side (``"u0"``, ``"v0"``), -1 for the high one."""
    return 0 if side[1] == "0" else -1


def _join_sides(join):
    """``((a, side_a), (b, side_b))``."""
    return (join.a, join.side_a), (join.b, join.side_b)


def _net(surface, lifted):
    """The net the solves work on: the poles, or the homogeneous poles :math:`(w c, w)`
    (weights 1 for a polynomial patch) when some patch is rational."""
    return surface.homogeneous() if lifted else surface.poles


def _from_net(net, spaces, lifted):
    """The surface of ``net`` on ``spaces`` (u, v): rational from homogeneous poles when
    ``lifted`` (weights are not checked here: the caller keeps a patch whose weights are
    not all positive)."""
    poles, weights = (net[..., :-1] / net[..., -1:], net[..., -1]) if lifted else (net, None)
    tu, tv = spaces
    return BSplineSurface(poles, tu.knots, tv.knots, tu.degree, tv.degree, weights)


# -- chords --------------------------------------------------------------------------------
class UnionFind:
    """Union-find whose members carry a parity against their root: a chord member's
    reversal, ignored where only the sets matter."""

    def __init__(self):
        self.parent, self.parity = {}, {}

    def find(self, key):
        """``(root, parity of key against it)``; the path is compressed on the way."""
        self.parent.setdefault(key, key)
        self.parity.setdefault(key, False)
        path, node, parity = [], key, False
        while self.parent[node] != node:
            path.append(node)
            parity ^= self.parity[node]
            node = self.parent[node]
        root, running = node, parity
        for member in path:       # each member's parity against the root, then link it
            own = self.parity[member]
            self.parent[member], self.parity[member] = root, running
            running ^= own
        return root, parity

    def tie(self, a, b, parity=False):
        """Put ``a`` and ``b`` in one set with ``parity`` between them; ``None`` when
        they already were (``True``/``False``: whether with that parity)."""
        (ra, pa), (rb, pb) = self.find(a), self.find(b)
        if ra == rb:
            return (pa ^ pb) == parity
        self.parent[rb], self.parity[rb] = ra, pa ^ pb ^ parity
        return None

    def members(self):
        """``{root: [(key, parity)]}``."""
        groups = {}
        for key in list(self.parent):
            root, parity = self.find(key)
            groups.setdefault(root, []).append((key, parity))
        return groups


def tied_in_order(pairs, size):
    """The positions of the ``pairs`` (of nodes ``0 .. size - 1``, in order) that
    :meth:`UnionFind.tie` taking them one after the other would tie (``None``): each
    that joins two sets not joined by the pairs before it.  They are Kruskal's spanning
    forest with each pair's position as its weight (unique, so the forest is); a pair
    within one node, or repeating an earlier one, joins nothing."""
    pairs = np.asarray(pairs, dtype=int).reshape(-1, 2)
    lo, hi = pairs.min(axis=1), pairs.max(axis=1)
    candidates = np.flatnonzero(lo != hi)
    _, first = np.unique(lo[candidates] * size + hi[candidates], return_index=True)
    candidates = candidates[np.sort(first)]
    weights = sp.coo_matrix((candidates + 1.0, (lo[candidates], hi[candidates])),
                            shape=(size, size))
    return np.sort(minimum_spanning_tree(weights).data.astype(int) - 1)


def _chords(patches, joins):
    """The chords (:class:`UnionFind` of ``(patch, axis)``, parity: reversed) of the
    joins, the joins kept and those dropped with a reason."""
    chords, kept, dropped = UnionFind(), [], []
    for join in joins:
        if patches[join.a].kept and patches[join.b].kept:
            dropped.append((join, "both patches are kept"))
            continue
        a, b = (join.a, _along(join.side_a)), (join.b, _along(join.side_b))
        if chords.tie(a, b, join.reversed) is False:
            dropped.append((join, "its chord would tie a direction to its own reverse"))
            continue
        kept.append(join)
    return chords, kept, dropped


def _spaces(patches, chords):
    """Target spaces ``[(space_u, space_v)]``: each joined direction carries its chord's
    class space, mapped to the patch's domain."""
    spaces = [[p.space(0), p.space(1)] for p in patches]
    for members in chords.members().values():
        if len(members) < 2:
            continue
        unit = _class_space([(patches[i].space(axis), flip, patches[i].kept)
                             for (i, axis), flip in members])
        for (i, axis), flip in members:
            if not patches[i].kept:
                spaces[i][axis] = _mapped(unit, patches[i].space(axis).domain, flip)
    return [tuple(s) for s in spaces]


def _normalised_knots(space, flip):
    lo, hi = space.domain
    t = (space.knots - lo) / (hi - lo)
    return 1.0 - t[::-1] if flip else t


def _class_space(members):
    """One space on [0, 1] holding every member's space (kept members exactly).  Where
    a kept member has at least as many spans as every solved one, the kept members'
    knots alone make the class: the solved members' knots between them would only add
    poles to a direction the kept border already refines."""
    degree = max(space.degree for space, _, _ in members)
    finest = max(space.n_spans for space, _, _ in members)
    spans = {kept: max((s.n_spans for s, _, k in members if k == kept), default=0)
             for kept in (True, False)}
    if spans[True] >= spans[False]:
        members = [m for m in members if m[2]]
    entries = []   # (value, multiplicity, kept)
    for space, flip, kept in members:
        t = _normalised_knots(space, flip)
        values, counts = np.unique(t[space.degree + 1: -space.degree - 1], return_counts=True)
        raise_by = degree - space.degree if kept else 0
        entries += [(v, c + raise_by, kept) for v, c in zip(values, counts)]
    knots = _merged(sorted(entries), SNAP / finest, degree)
    inner = np.repeat([v for v, _ in knots], [m for _, m in knots])
    return SplineSpace(degree, np.concatenate([np.zeros(degree + 1), inner,
                                               np.ones(degree + 1)]))


def _merged(entries, snap, degree):
    """Clusters of knots closer than ``snap`` as single knots: a kept member's knots stay
    where they are (each distinct one), others merge to the cluster's mean and vanish next
    to a kept knot or an end."""
    out, cluster = [], []

    def close():
        kept = {}
        for v, m, k in cluster:
            if k:
                key = round(v, 12)
                kept[key] = max(kept.get(key, 0), m)
        if kept:
            out.extend((v, min(m, degree)) for v, m in sorted(kept.items()))
            return
        v = float(np.mean([v for v, _, _ in cluster]))
        if snap <= v <= 1.0 - snap:
            out.append((v, min(max(m for _, m, _ in cluster), degree)))

    for entry in entries:
        if cluster and entry[0] - cluster[0][0] > snap:
            close()
            cluster = []
        cluster.append(entry)
    if cluster:
        close()
    return out


def _mapped(unit, domain, flip):
    """``unit`` (a space on [0, 1]) on ``domain``, reversed when ``flip``."""
    lo, hi = domain
    t = 1.0 - unit.knots[::-1] if flip else unit.knots
    return SplineSpace(unit.degree, lo + (hi - lo) * t)


# -- vertices and edges --------------------------------------------------------------------
def _side_ends(side):
    """The two corners ``(i_end, j_end)`` of a side in along order."""
    if side[0] == "u":
        return [(_end(side), 0), (_end(side), -1)]
    return [(0, _end(side)), (-1, _end(side))]


def _vertices(patches, joins, lifted):
    """``{(patch, corner): _Vertex}`` of every corner tied by a join.

    The point is the mean of the vertex's corners (a kept patch's corner where there is
    one).  The normal is the mean unit normal of the corners' sources (signs aligned), or
    ``None`` where a crease meets the vertex: the edges' end tangents are held in the
    plane it defines, so that the patches around a smooth vertex share a tangent plane.
    """
    corners, creased = UnionFind(), set()
    for join in joins:
        ends_a = _side_ends(join.side_a)
        ends_b = _side_ends(join.side_b)[::-1] if join.reversed else _side_ends(join.side_b)
        for ca, cb in zip(ends_a, ends_b):
            corners.tie((join.a, ca), (join.b, cb))
            if not join.smooth:
                creased.add((join.a, ca))
    creased_roots = {corners.find(key)[0] for key in creased}
    out = {}
    for root, group in corners.members().items():
        members = [key for key, _ in group]
        kept = [k for k in members if patches[k[0]].kept]
        chosen = kept[:1] or members
        point = np.mean([_net(patches[i].source, lifted)[c] for i, c in chosen], axis=0)
        smooth = root not in creased_roots
        normal = mean_normal([_corner_normal(patches[i].source, c) for i, c in chosen]) \
            if smooth and not lifted else None
        out.update({key: _Vertex(point, normal, root) for key in members})
    return out


class _Vertex(NamedTuple):
    """Where the corners of a vertex meet, the normal of its tangent plane (``None``:
    free) and the vertex's id."""

    point: np.ndarray
    normal: np.ndarray
    root: tuple


def _corner_normal(surface, corner):
    """Unit normal ``S_u x S_v`` of a surface at a corner (``None`` where it vanishes)."""
    (u0, u1), (v0, v1) = surface.domain
    u = [u0 if corner[0] == 0 else u1]
    v = [v0 if corner[1] == 0 else v1]
    n = np.cross(surface.evaluate_grid(u, v, 1, 0)[0, 0], surface.evaluate_grid(u, v, 0, 1)[0, 0])
    length = np.linalg.norm(n)
    return n / length if length > 1e-12 * max(surface.size, 1e-300) else None


def mean_normal(normals):
    """Mean of unit normals with their signs aligned to the first (``None`` if none)."""
    normals = [n for n in normals if n is not None]
    if not normals:
        return None
    total = sum(n if n @ normals[0] >= 0 else -n for n in normals)
    length = np.linalg.norm(total)
    return total / length if length > 0 else None


def _border(surface, net, side):
    """The border curve of a side: (space along, poles of its net)."""
    if side[0] == "u":
        return surface.v_space, net[_end(side)]
    return surface.u_space, net[:, _end(side)]


def _unit_curve(space, poles, flip):
    """A border curve on [0, 1] (reversed when ``flip``)."""
    knots = _normalised_knots(space, flip)
    return SplineSpace(space.degree, knots), (poles[::-1] if flip else poles)


@dataclass(frozen=True)
class _Edge:
    """The border curve problem of one join: its class space on [0, 1] (``unit``), the
    border it projects (``curve``: space and poles, on [0, 1]), its two end points and
    vertex normals and the vertex ids of its ends (``roots``), all in the chord's root
    order; ``flips``: each side's reversal against that order."""

    join: BorderJoin
    unit: SplineSpace
    curve: tuple
    ends: np.ndarray
    normals: list
    roots: tuple
    flips: dict


def _edges(patches, joins, spaces, chords, vertices, lifted):
    """One :class:`_Edge` per join, in the joins' order."""
    out = []
    for join in joins:
        flips = {(i, s): chords.find((i, _along(s)))[1]
                 for i, s in _join_sides(join)}
        unit = _unit_space(spaces, _solved_side(patches, join), flips)
        index, side = (join.b, join.side_b) if patches[join.b].kept else (join.a, join.side_a)
        space, poles = _border(patches[index].source, _net(patches[index].source, lifted), side)
        ends = [vertices[join.a, c] for c in _side_ends(join.side_a)]
        if flips[join.a, join.side_a]:
            ends = ends[::-1]
        out.append(_Edge(join, unit, _unit_curve(space, poles, flips[index, side]),
                         np.array([e.point for e in ends]), [e.normal for e in ends],
                         tuple(e.root for e in ends), flips))
    return out


def _held_rows(patches, edges, poles):
    """``{patch: {side: held border poles in the patch's own along order}}`` of every
    join, from the edges' ``poles`` (root order), NaN where not held: next to a kept
    patch the whole border; between two solved patches the ends (at the vertices) and
    the poles next to them (the end tangents), the other border poles being unknowns
    the two patches share (:class:`_Patchwork`)."""
    held = {}
    for edge, x in zip(edges, poles):
        join = edge.join
        if not (patches[join.a].kept or patches[join.b].kept):
            x = x.copy()
            x[2:-2] = np.nan
        for index, side in _join_sides(join):
            if not patches[index].kept:
                held.setdefault(index, {})[side] = x[::-1] if edge.flips[index, side] else x
    return held


def _solved_side(patches, join):
    """``(patch, side)`` of a join whose patch is solved (not kept)."""
    return (join.b, join.side_b) if patches[join.a].kept else (join.a, join.side_a)


def _unit_space(spaces, solved, flips):
    """The class space of a solved side's chord on [0, 1], in the chord's root order
    (``flips[solved]``: the side's reversal against the root)."""
    index, side = solved
    space = spaces[index][_along(side)]
    return SplineSpace(space.degree, _normalised_knots(space, flips[solved]))


def _solved_edges(edges, lines=()):
    r"""Poles (root order) of every edge: the L2 projection of its border onto its class
    space with both ends held, each end tangent in its vertex's plane
    (:math:`n\cdot(x_1 - x_0) = 0`), and the ``lines`` rows (:func:`_line_rows`) tying
    the end tangents of edges that cross at a vertex.  One system over the interior
    poles of all edges, :math:`\min \sum_e x_e^T G_e x_e - 2 x_e^T m_e`,
    :math:`m_e = \langle\Phi|\Phi_S\rangle c_e`, under those rows (:func:`kkt_solve`);
    without rows each edge is solved on its own."""
    if not edges:
        return []
    dimension = edges[0].ends.shape[1]
    blocks, rhs, offsets, offset = [], [], [], 0
    for edge in edges:
        gram = gram_matrix(edge.unit).toarray()
        space, poles = edge.curve
        moments = gram_matrix(edge.unit, space) @ poles
        blocks.append(gram[1:-1, 1:-1])
        rhs.append(moments[1:-1] - gram[1:-1][:, [0, -1]] @ edge.ends)
        offsets.append(offset)
        offset += max(edge.unit.dimension - 2, 0) * dimension
    rows = _normal_rows(edges, offsets, dimension)
    for line in lines:
        rows += _line_row(edges, offsets, dimension, line)
    if rows:
        free = kkt_solve(sp.kron(sp.block_diag([sp.csr_matrix(b) for b in blocks]),
                                  sp.identity(dimension)),
                          _row_matrix(rows, offset), np.concatenate([r.ravel() for r in rhs]),
                          np.array([value for _, value in rows]))
    else:
        free = np.concatenate([sla.solve(b, r, assume_a="pos").ravel() if b.size else r.ravel()
                               for b, r in zip(blocks, rhs)])
    out = []
    for edge, start in zip(edges, offsets):
        x = np.empty((edge.unit.dimension, dimension))
        x[0], x[-1] = edge.ends
        x[1:-1] = free[start: start + (len(x) - 2) * dimension].reshape(-1, dimension)
        out.append(x)
    return out


def _interior(edges, offsets, dimension, edge, end, k=0):
    """Flat index of the first coordinate of the ``k``-th interior pole from ``end`` of
    edge ``edge`` (``None`` if the edge has fewer interior poles)."""
    count = edges[edge].unit.dimension - 2
    if k >= count:
        return None
    return offsets[edge] + (k if end == 0 else count - 1 - k) * dimension


def _normal_rows(edges, offsets, dimension):
    r"""Rows :math:`n\cdot x_1 = n\cdot x_0` of every end with a vertex normal."""
    rows = []
    for e, edge in enumerate(edges):
        for end, normal in enumerate(edge.normals):
            first = _interior(edges, offsets, dimension, e, end)
            if normal is not None and first is not None:
                rows.append(([(first + c, normal[c]) for c in range(dimension)],
                             float(normal @ edge.ends[end])))
    return rows


def _line_row(edges, offsets, dimension, line):
    r"""Rows (per coordinate) of one condition at a crossing (:func:`_line_rows`):
    :math:`\sum_k \alpha_k x_{a,k} + \sum_k \beta_k x_{b,k} = 0`, :math:`x_{\cdot,k}`
    the k-th pole of an edge from the vertex (the vertex itself for k = 0, known); empty
    where an edge has too few interior poles."""
    (ea, end_a), (eb, end_b), wa, wb = line
    entries = [[] for _ in range(dimension)]
    point = edges[ea].ends[end_a]
    value = -(wa[0] + wb[0]) * point
    for edge, end, weights in ((ea, end_a, wa), (eb, end_b, wb)):
        for k, weight in enumerate(weights[1:]):
            first = _interior(edges, offsets, dimension, edge, end, k)
            if first is None:
                return []
            for c in range(dimension):
                entries[c].append((first + c, weight))
    return [(entries[c], value[c]) for c in range(dimension)]


def _row_matrix(rows, count):
    """Sparse matrix of ``rows`` (``[(entries, value)]``) over ``count`` unknowns."""
    r, c, v = [], [], []
    for k, (entries, _) in enumerate(rows):
        r += [k] * len(entries)
        c += [i for i, _ in entries]
        v += [w for _, w in entries]
    return sp.csr_matrix((v, (r, c)), shape=(len(rows), count))


# -- patch solves --------------------------------------------------------------------------
class _Patchwork:
    r"""The joint projection's unknowns: every pole of the solved patches is a *slot*;
    the held slots (:func:`_held_rows`) carry their values :math:`h`, and the other slots
    of each class tied by the joins (a shared border pole and its twin in the other patch)
    are one unknown: slots :math:`= P x + h` with :math:`P` 0/1.  The projection's
    normal equations over the unknowns are :math:`P^T A P\, x = P^T (b - A h)`,
    :math:`A = \mathrm{diag}_k(G_{u,k}\otimes G_{v,k})`,
    :math:`b_k = \mathrm{vec}(E_{u,k} C_k E_{v,k}^T)`: what the G0 and the joint (G1, G2)
    solves share."""

    def __init__(self, patches, spaces, joins, held, lifted):
        self.patches, self.spaces, self.lifted = patches, spaces, lifted
        self.dimension = 4 if lifted else 3
        self.slots = {}        # patch: slot number of its pole (0, 0); nets row-major
        size = 0
        for index, patch in enumerate(patches):
            if not patch.kept:
                self.slots[index] = size
                size += spaces[index][0].dimension * spaces[index][1].dimension
        values = np.full((size, self.dimension), np.nan)
        for index, sides in held.items():
            for side, row in sides.items():
                known = ~np.isnan(row[:, 0])
                values[self._side_slots(index, side)[known]] = row[known]
        self.basis, self.held = shared_basis(self._ties(joins), values)
        self.count = self.basis.shape[1]
        self.column = np.full(size, -1)
        rows, columns = self.basis.nonzero()
        self.column[rows] = columns
        gram, moments = self._projection()
        self.normal = (self.basis.T @ gram @ self.basis).tocsc()
        self.rhs = self.basis.T @ (moments - gram @ self.held)

    def _side_slots(self, index, side):
        """Slots of a side's poles in the patch's own along order."""
        ku, kv = (s.dimension for s in self.spaces[index])
        grid = self.slots[index] + np.arange(ku * kv).reshape(ku, kv)
        return grid[_end(side)] if side[0] == "u" else grid[:, _end(side)]

    def _ties(self, joins):
        """Pairs of slots one pole apart across each join between two solved patches: a
        side's k-th pole and its twin (the chords give both one space along the join)."""
        pairs = []
        for join in joins:
            if self.patches[join.a].kept or self.patches[join.b].kept:
                continue
            a, b = (self._side_slots(i, s) for i, s in _join_sides(join))
            pairs += zip(a, b[::-1] if join.reversed else b)
        return pairs

    def _projection(self):
        """:math:`A` over the slots and :math:`b` (one column per coordinate); empty
        where every patch is kept."""
        if not self.slots:
            return sp.csr_matrix((0, 0)), np.zeros((0, self.dimension))
        blocks, moments = [], []
        for index in self.slots:
            source, (tu, tv) = self.patches[index].source, self.spaces[index]
            blocks.append(sp.kron(gram_matrix(tu), gram_matrix(tv)))
            moments.append(sandwiched(gram_matrix(tu, source.u_space).toarray(),
                                      _net(source, self.lifted),
                                      gram_matrix(tv, source.v_space).toarray())
                           .reshape(-1, self.dimension))
        return sp.block_diag(blocks, format="csr"), np.concatenate(moments)

    def solve(self, c=None, d=None):
        r"""The unknowns of the projection (:math:`C x = d` rows: :func:`kkt_solve`)."""
        if c is None or not c.shape[0]:
            return spla.splu(self.normal).solve(self.rhs) if self.count else self.rhs
        return kkt_solve(self.normal, c, self.rhs, d)

    def surfaces(self, free):
        """Every patch's surface with the unknowns ``free`` (count, dimension); rational
        where the system is homogeneous."""
        slots = self.basis @ free + self.held
        out = []
        for index, patch in enumerate(self.patches):
            if patch.kept:
                out.append(patch.source)
                continue
            ku, kv = (s.dimension for s in self.spaces[index])
            start = self.slots[index]
            out.append(_from_net(slots[start:start + ku * kv].reshape(ku, kv, -1),
                                 self.spaces[index], self.lifted))
        return out

    def pole(self, index, i, j):
        """``(position, value)`` of pole (i, j) of a solved patch: its unknown's number
        and ``None``, or ``-1`` and a held pole's value."""
        kv = self.spaces[index][1].dimension
        slot = self.slots[index] + (i % self.spaces[index][0].dimension) * kv + j % kv
        k = int(self.column[slot])
        return (k, None) if k >= 0 else (-1, self.held[slot])


def shared_basis(ties, values):
    """``(P, h)``: the classes of slots tied by ``ties`` (pairs of slot indices), each
    one unknown (a column of ``P``, 0/1) unless it holds a held slot (``values`` not NaN
    there, one per class at most): then its slots take that value in ``h``, and the
    slots are :math:`P x + h`."""
    size = values.shape[0]
    pairs = np.array(ties, dtype=int).reshape(-1, 2)
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(size, size))
    count, label = connected_components(graph, directed=False)
    anchor = np.full(count, -1)
    fixed = np.flatnonzero(~np.isnan(values[:, 0]))
    anchor[label[fixed]] = fixed
    held = np.zeros_like(values)
    on_held = anchor[label] >= 0
    held[on_held] = values[anchor[label[on_held]]]
    free = np.flatnonzero(~on_held)
    _, column = np.unique(label[free], return_inverse=True)
    basis = sp.csr_matrix((np.ones(free.size), (free, column)),
                          shape=(size, int(column.max()) + 1 if free.size else 0))
    return basis, held


# -- G1 and G2: conditions on the rows next to a join ----------------------------------
def _cross_rows(work, join, chords, depth=2):
    """Per side of a join: ``(patch, rows)``.  For a solved patch, per pole along the
    join (chord root order), the indices of its first ``depth`` rows from the border
    (border, inner, second inner); for a kept patch those rows themselves, as curves
    projected onto the join's class space (exact: it holds the patch's along space),
    shape ``(depth, poles along, dimension)``."""
    solved = _solved_side(work.patches, join)
    flips = {(i, s): chords.find((i, _along(s)))[1]
             for i, s in _join_sides(join)}
    unit = _unit_space(work.spaces, solved, flips)
    out = []
    for index, side in _join_sides(join):
        flip = flips[index, side]
        rows = (0, 1, 2)[:depth] if side[1] == "0" else (-1, -2, -3)[:depth]
        if work.patches[index].kept:
            out.append((index, _kept_rows(work.patches[index].source, side, unit, flip,
                                          work.lifted, rows)))
            continue
        along = np.arange(unit.dimension)[::-1] if flip else np.arange(unit.dimension)
        out.append((index, [tuple((r, i) if side[0] == "u" else (i, r) for r in rows)
                            for i in along]))
    return out


def _kept_rows(surface, side, unit, flip, lifted, rows):
    """A kept patch's ``rows`` (indices from its border) along ``side``, each projected
    onto ``unit`` (root order; the Gram matrix of ``unit`` factored once, banded:
    :class:`~cq_fairing.core.banded.BandedSPD`)."""
    space = surface.v_space if side[0] == "u" else surface.u_space
    net = _net(surface, lifted) if side[0] == "u" else np.swapaxes(_net(surface, lifted), 0, 1)
    gram = BandedSPD(gram_matrix(unit))
    curves = [_unit_curve(space, net[r], flip) for r in rows]
    cross = gram_matrix(unit, curves[0][0])   # every row is on the same space
    return np.array([gram.solve(cross @ row) for _, row in curves])


def _cross_vectors(work, surfaces, side_rows):
    """The cross row :math:`w = c_{inner} - c_{border}` of one side from ``surfaces``
    (the separate solve)."""
    index, rows = side_rows
    if isinstance(rows, np.ndarray):
        return rows[1] - rows[0]
    net = _net(surfaces[index], work.lifted)
    return np.array([net[q[1]] - net[q[0]] for q in rows])


def mirror_ratio(wa, wb):
    r"""One :math:`\mu` for a join's mirrored rows :math:`w_{a,i} + \mu w_{b,i} = 0`: the
    geometric mean of :math:`|w_{a,i}| / |w_{b,i}|` over the poles along it."""
    mu = np.linalg.norm(wa, axis=1) / np.maximum(np.linalg.norm(wb, axis=1), 1e-300)
    return float(np.exp(np.mean(np.log(np.maximum(mu, 1e-300)))))


def _mirror_ratios(work, joins, chords, surfaces):
    """``{join index: mu}`` of every smooth join, from the cross rows of ``surfaces``
    (the separate solve): :func:`mirror_ratio`."""
    out = {}
    for k, join in enumerate(joins):
        if join.smooth:
            sides = _cross_rows(work, join, chords)
            out[k] = mirror_ratio(*(_cross_vectors(work, surfaces, side) for side in sides))
    return out


def _conditions(work, join, mu, curvature):
    r"""The conditions of a smooth join as weights of the rows next to it, one tuple
    per side (border row first): :math:`\sum_k \alpha_k c_{a,k} + \sum_k \beta_k
    c_{b,k} = 0` at every pole along the join.

    G1: :math:`w_a + \mu w_b = 0`, weights :math:`(-1, 1)` and :math:`(-\mu, \mu)`.
    G2 (``curvature``: the join is in :func:`_curved`) adds the second inward
    derivatives: with the first inward derivative :math:`D_1 = p\,w / h_1` (:math:`h_1`
    the first cross span), G1 reads :math:`D_{1,a} = -\kappa D_{1,b}`,
    :math:`\kappa = \mu h_{1,b} / h_{1,a}`, the parameter scale between the two
    sides; the joined cross curves are then :math:`C^2` in one parameter where
    :math:`D_{2,a} = \kappa^2 D_{2,b}` (:func:`_second_derivative`).  With the first
    condition this holds the normal curvature across the join."""
    out = [((-1.0, 1.0), (-mu, mu))]
    if not curvature:
        return out
    (da, ha), (db, hb) = (_second_derivative(_cross_space(work, index, side), side)
                          for index, side in _join_sides(join))
    kappa = mu * hb / ha
    scale = np.abs(da).max()
    out.append((tuple(da / scale), tuple(-kappa ** 2 * db / scale)))
    return out


def _cross_space(work, index, side):
    """The space across ``side`` of a patch (its target, or its own if kept)."""
    spaces = work.spaces[index] if not work.patches[index].kept else \
        (work.patches[index].source.u_space, work.patches[index].source.v_space)
    return spaces[1 - _along(side)]


def _second_derivative(space, side):
    r"""``(coefficients, h1)``: the second inward derivative at ``side`` as weights of the
    border, inner and second inner rows,
    :math:`D_2 = \frac{p(p-1)}{h_1}\left(\frac{c_2 - c_1}{h_2} - \frac{c_1 - c_0}{h_1}
    \right)` (:math:`h_1, h_2` the distances of the first two interior knots from the
    border, clamped knots), and :math:`h_1`; ``None`` below three rows or degree 2."""
    p, t = space.degree, space.knots
    if p < 2 or space.dimension < 3:
        return None
    h1, h2 = (t[p + 1] - t[p], t[p + 2] - t[p]) if side[1] == "0" else \
        (t[-p - 1] - t[-p - 2], t[-p - 1] - t[-p - 3])
    f = p * (p - 1) / h1
    return np.array([f / h1, -f * (1.0 / h1 + 1.0 / h2), f / h2]), h1


def _condition_rows(work, joins, chords, ratios, curved):
    r"""Rows (per coordinate) of every smooth join's conditions (:func:`_conditions`) at
    every pole along it: the cross rows of both patches mirror each other across the
    shared border (G1), and, at the joins of ``curved`` (:func:`_curved`), their second
    differences match (G2), at the two poles next to an end only where that end is a
    crossing held in G2 all round.  A G1 row that would
    close a cycle of rows around a vertex other than a crossing (module notes, step 6)
    is left out: each row ties its one or two unknown inner poles, a row with one to
    the held poles (a row whose inner poles are all held enters: it fixes only its
    border poles).  Returns the sparse matrix over the unknowns (:class:`_Patchwork`)
    and the right-hand sides ``(rows, dimension)`` from held poles."""
    rows = []
    linked = UnionFind()   # unknown inner poles (and -1, the held ones) tied by a G1 row
    for k, join in enumerate(joins):
        if not join.smooth:
            continue
        conditions = _conditions(work, join, ratios[k], k in curved)
        sides = _cross_rows(work, join, chords, depth=max(len(c[0]) for c in conditions))
        along = next(len(r) for _, r in sides if not isinstance(r, np.ndarray))
        for order, weights in enumerate(conditions):
            for i in range(along):                  # poles along the join
                if order and not ((i >= 2 or curved[k][0]) and (i < along - 2 or curved[k][1])):
                    continue
                entries, inner, known = _condition_row(work, sides, weights, i)
                if entries and (order or not inner
                                or linked.tie(*(inner + [-1])[:2]) is None):
                    rows.append((entries, known))
    return (_row_matrix(rows, work.count),
            np.array([value for _, value in rows]).reshape(-1, work.dimension))


def _condition_row(work, sides, weights, i):
    """Entries over the unknowns, the unknowns among the inner poles (rows from the
    border's next on) and the known right-hand side of one condition at pole ``i``
    along a join."""
    entries, inner, known = [], [], np.zeros(work.dimension)
    for (index, rows), coefficients in zip(sides, weights):
        if isinstance(rows, np.ndarray):       # a kept patch: its rows are known
            known -= np.asarray(coefficients) @ rows[:len(coefficients), i]
            continue
        for k, (pole, c) in enumerate(zip(rows[i], coefficients)):
            position, value = work.pole(index, *pole)
            if position < 0:
                known -= c * value
                continue
            entries.append((position, c))
            if k:
                inner.append(position)
    return entries, inner, known


def kkt_solve(a, c, b, d, steps=0):
    r"""Minimiser of :math:`x^T A x - 2 x^T b` under :math:`C x = d` (``b``, ``d``: one
    column per right-hand side): the regularised KKT system
    :math:`K_\varepsilon = \begin{bmatrix}A & sC^T\\ sC & -\varepsilon I\end{bmatrix}`;
    ``s`` scales the rows to :math:`A`'s diagonal and :math:`\varepsilon = `
    :data:`KKT_EPS` ``s`` lets dependent rows (where mirrored rows meet at a vertex)
    through; rows that no :math:`x` meets all at once get their least-squares
    compromise, at the weight :math:`s / \varepsilon` over the objective.  The rows then
    hold to about :math:`\varepsilon` times the multipliers; each of ``steps`` refines the
    solution against the unregularised system :math:`K_0` with the same factors,
    :math:`z \leftarrow z + K_\varepsilon^{-1}(r - K_0 z)` (the proximal method of
    multipliers: the residual of rows that can be met shrinks by about
    :math:`\varepsilon` relative to the rows' scale each step)."""
    a = sp.csc_matrix(a)
    scale = float(a.diagonal().mean())
    regularised = -KKT_EPS * scale * sp.identity(c.shape[0])
    kkt = sp.bmat([[a, scale * c.T], [scale * c, regularised]], format="csc")
    factors = spla.splu(kkt)
    rhs = np.concatenate([b, scale * d])
    solution = factors.solve(rhs)
    for _ in range(steps):
        unregularised = kkt @ solution - np.concatenate([
            np.zeros_like(b), regularised @ solution[a.shape[0]:]])
        solution += factors.solve(rhs - unregularised)
    return solution[: a.shape[0]]


# -- G1 at crossings: regular inner vertices -----------------------------------------------
def _crossings(patches, joins, edges):
    """Regular inner vertices: four solved patches around a vertex, joined by four smooth
    joins, each patch in two of them.  Per such vertex the list of ``(join, (edge, end),
    (edge, end))``: for each join ``T`` of the four, the end at the vertex of the other
    join of ``T.a`` and of the other join of ``T.b``."""
    at = {}
    for e, edge in enumerate(edges):
        if edge.roots[0] != edge.roots[1]:
            for end, root in enumerate(edge.roots):
                at.setdefault(root, []).append((e, end))
    out = {}
    for root, ends in at.items():
        around = [joins[e] for e, _ in ends]
        members = [p for j in around for p in (j.a, j.b)]
        if (len(ends) != 4 or not all(j.smooth for j in around)
                or any(members.count(p) != 2 or patches[p].kept for p in members)):
            continue
        other = {}
        for (e, end), join in zip(ends, around):
            for p in (join.a, join.b):
                other.setdefault(p, []).append((e, end))
        out[root] = [(e, *(next(x for x in other[p] if x[0] != e) for p in (join.a, join.b)))
                     for (e, _), join in zip(ends, around)]
    return out


def _curved(work, joins, edges, crossings, continuity):
    """``{join: (end 0, end 1)}``: the joins held in G2 (``continuity="G2"``, smooth,
    ``curvature`` set, degree 2 or more across on both sides), less those whose patches
    have too few rows across for the conditions at both their ends (three rows for a
    G2 side, two for G1, one for a border held); per end, whether the G2 conditions
    reach it: where no other join ends there, or at a crossing whose four joins are all
    held in G2 (the conditions close around the vertex).  Next to any other vertex they
    would fight the G1 rows of the join beside it, so they stop two poles short of it."""
    if continuity != "G2":
        return {}
    candidates = {k for k, j in enumerate(joins) if j.smooth and j.curvature and all(
        _second_derivative(_cross_space(work, i, s), s) is not None for i, s in _join_sides(j))}
    need = {}
    for k, join in enumerate(joins):
        for index, side in _join_sides(join):
            need[index, 1 - _along(side), side[1]] = 3 if k in candidates else 2 \
                if join.smooth else 1
    for k in list(candidates):
        if any(not work.patches[i].kept and need.get((i, 1 - _along(s), "0"), 0)
               + need.get((i, 1 - _along(s), "1"), 0) > _cross_space(work, i, s).dimension
               for i, s in _join_sides(joins[k])):
            candidates.discard(k)
    ending = {}
    for edge in edges:
        for root in set(edge.roots):
            ending[root] = ending.get(root, 0) + 1
    open_ = {root for root, count in ending.items() if count == 1} | {
        root for root, entries in crossings.items() if _full(candidates, entries)}
    return {k: tuple(root in open_ for root in edges[k].roots) for k in candidates}



def _straightened(ratios, crossings):
    """``ratios`` with the two joins opposite each other at a crossing given one ratio
    (the geometric mean of their class, oriented): the cross rows at the vertex then
    close around it (module notes, step 5)."""
    lines = UnionFind()
    for crossing in crossings.values():
        for t, (ea, _), (eb, _) in crossing:
            for s, (sa, _), _ in crossing:
                if s not in (t, ea, eb):     # s faces t: its side a is t.a's neighbour
                    lines.tie(t, s, parity=(sa != ea))   # unless it is t.b's
    out = dict(ratios)
    for group in lines.members().values():
        mean = np.mean([-np.log(ratios[k]) if flip else np.log(ratios[k]) for k, flip in group])
        out.update({k: float(np.exp(-mean if flip else mean)) for k, flip in group})
    return out


def _line_rows(work, joins, crossings, ratios, curved):
    """Per crossing and pair of opposite edges, the conditions (:func:`_conditions`) of a
    join crossing them at the vertex, where its rows are those edges' poles:
    ``((edge, end), (edge, end), weights_a, weights_b)``; G2 where the crossing's four
    joins are held in G2 (:func:`_curved`)."""
    out = []
    for crossing in crossings.values():
        seen = set()
        for t, a, b in crossing:
            if frozenset((a[0], b[0])) not in seen:
                seen.add(frozenset((a[0], b[0])))
                out += [(a, b, wa, wb) for wa, wb in
                        _conditions(work, joins[t], ratios[t], _full(curved, crossing))]
    return out


def _full(curved, crossing):
    """Whether the four joins of a crossing are all among ``curved``."""
    return all(t in curved for t, _, _ in crossing)
