r"""Fair the faces that nothing can be removed from together, by energy across their joins.

A face already at its coarsest (a bicubic patch of one span, a net whose target is its
own space) is left unchanged by its own search, and the joint projection keeps it as
it is.  A model made of such patches (a shell of 4 x 4 patches) is faired by
:func:`~cq_fairing.core.network.fair_network` instead: the thin-plate energy of all of
them, each in its own parametrization, under the joins' G0 and G1 constraints, within
each face's tolerance.  The borders move with the faces, so the fairing runs across
the joins.

The network is the faces left unchanged that meet along whole sides with the same
knots (:func:`~cq_fairing.core.network.network_joinable`), across joins whose faces lie
within ``SOURCE_GAP`` times the tolerance of each other
(:func:`~cq_fairing.core.joint_projection.border_joins`).
A member with any other join (to a faired face, a partial or trimmed side, other knots)
keeps its surface and constrains its neighbours, so every join of a moved face is held
closed.  Each moved face is then checked against its own face by the backend's two-sided
measure (``check``); if one is over its tolerance the network is solved again with
:data:`SHRINK` times the tolerances, :data:`RETRIES` times at most (its forms and
samples prepared once, :class:`~cq_fairing.core.network.PatchNetwork`), and otherwise
left as it was.  The faces nearest their tolerance by the network's own samples are
checked first, and the first one over ends the check: testtoler's first network (22
faces at tol 0.01) is then refused after one measure instead of 22.

This module imports numpy only (and the core).
"""

from dataclasses import dataclass

from .geometry import collapsed_kept
from .joins import BorderJoin
from .joint_projection import runs_reversed
from .network import PatchNetwork, network_joinable

__all__ = ["fair_networks", "NetworkFairing", "RETRIES", "SHRINK"]

RETRIES = 2
SHRINK = 0.7


@dataclass(frozen=True)
class NetworkFairing:
    r"""One network of faces faired by energy.

    Attributes
    ----------
    moved : list of int
        The faces faired.
    kept : list of int
        The faces of the network that kept their surfaces (they have other joins).
    joins : list of Join
        The joins held closed (G0, and G1 where smooth).
    smoothing : float
        The energy weight :math:`\lambda` reached.
    surfaces : dict
        ``{face: BSplineSurface}`` of the moved faces, as checked.
    """

    moved: list
    kept: list
    joins: list
    smoothing: float
    surfaces: dict


def fair_networks(sources, unchanged, joins, border, tolerances, check, *,
                  continuity="G1", reversed_=runs_reversed):
    """Fair the ``unchanged`` faces among ``border`` as networks.

    Parameters
    ----------
    sources : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    unchanged : collection of int
        The faces left as their sources, that may be faired here.
    joins : sequence of Join
        Every join of the model: a face with a join outside the network keeps its surface.
    border : sequence of Join
        Whole-side joins between faces of ``sources``.
    tolerances : dict
        ``{face: tol}`` of the faces that may move (a face without one is left out).
    check : callable
        ``check(face, surface) -> float``: the face's two-sided deviation from its source
        with ``surface`` under its trim (the backend's measure); the surfaces checked have
        the source's collapsed border rows put back
        (:func:`~cq_fairing.core.geometry.collapsed_kept`).
    continuity : {"G0", "G1", "G2"}
        The model's continuity (:data:`~cq_fairing.core.options.JOIN_CONTINUITY`); the
        energy network holds G1 for ``"G2"`` too (its faces are at their coarsest: no
        three rows across to spare for the curvature).
    reversed_ : callable, optional
        ``reversed_(join)``: the two faces' along-parameters run opposite ways.

    Returns
    -------
    list of NetworkFairing
        The networks whose every moved face is within its tolerance.
    """
    unchanged = {f for f in sources if f in unchanged and tolerances.get(f) is not None}
    links = [j for j in border if set(j.faces) <= unchanged and
             network_joinable(sources[j.faces[0]], j.sides[0].side, sources[j.faces[1]],
                              j.sides[1].side, reversed_(j))]
    linked = {id(j) for j in links}
    out = []
    for component in _components(links):
        moving = {f for f in component
                  if all(id(j) in linked for j in joins if f in j.faces)}
        if moving:
            done = _fair_component(sources, sorted(component), moving,
                                   [j for j in links if set(j.faces) <= component],
                                   tolerances, check, reversed_,
                                   "G0" if continuity == "G0" else "G1")
            if done is not None:
                out.append(done)
    return out


def _components(links):
    """The face sets connected by ``links``."""
    neighbours = {}
    for join in links:
        a, b = join.faces
        neighbours.setdefault(a, set()).add(b)
        neighbours.setdefault(b, set()).add(a)
    seen, out = set(), []
    for start in neighbours:
        if start in seen:
            continue
        stack, part = [start], set()
        while stack:
            face = stack.pop()
            if face not in part:
                part.add(face)
                stack.extend(neighbours[face] - part)
        seen |= part
        out.append(part)
    return out


def _fair_component(sources, faces, moving, links, tolerances, check, reversed_,
                    continuity):
    """Solve one network, retried at smaller tolerances while a moved face misses its
    own: its :class:`NetworkFairing`, or ``None``."""
    position = {face: k for k, face in enumerate(faces)}
    core_joins = [BorderJoin(position[a.face], a.side, position[b.face], b.side,
                             reversed_(j), j.kind == "smooth")
                  for j in links for a, b in [j.sides]]
    kept = [position[f] for f in faces if f not in moving]
    tols = [tolerances[f] for f in faces]
    network = PatchNetwork([sources[f] for f in faces], core_joins, continuity)
    for _ in range(RETRIES + 1):
        result = network.fair(tols, kept=kept)
        moved = {f for f in moving if position[f] not in result.kept}
        if not moved:
            return None
        # the faces nearest their tolerance by the network's own samples first
        nearest = sorted(moved, key=lambda f: -result.deviations[position[f]] / tolerances[f])
        surfaces = {f: collapsed_kept(sources[f], result.surfaces[position[f]])
                    for f in nearest}
        if all(check(f, surfaces[f]) <= tolerances[f] for f in nearest):
            return NetworkFairing(sorted(moved), sorted(set(faces) - moved), links,
                                  result.smoothing, dict(sorted(surfaces.items())))
        tols = [SHRINK * t for t in tols]
    return None
