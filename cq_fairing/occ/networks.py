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
closed.  Each moved face is then checked against its own face by OCCT, both ways; if one
is over its tolerance the network is solved again with :data:`SHRINK` times the
tolerances, :data:`RETRIES` times at most (its forms and samples prepared once,
:class:`~cq_fairing.core.network.PatchNetwork`), and otherwise left as it was.  The faces
nearest their tolerance by the network's own samples are checked first, and the first
one over ends the check: testtoler's first network (22 faces at tol 0.01) is then
refused after one OCCT measure instead of 22.
"""

from dataclasses import dataclass

from ..core.geometry import collapsed_kept
from ..core.joins import BorderJoin
from ..core.network import PatchNetwork, network_joinable

__all__ = ["fair_networks", "NetworkFairing", "RETRIES", "SHRINK"]

RETRIES = 2
SHRINK = 0.7


@dataclass(frozen=True)
class NetworkFairing:
    """One network of faces faired by energy.

    Attributes
    ----------
    moved : list of int
        The faces faired.
    kept : list of int
        The faces of the network that kept their surfaces (they have other joins).
    joins : list of Join
        The joins held closed (G0, and G1 where smooth).
    smoothing : float
        The energy weight :math:`\\lambda` reached.
    """

    moved: list
    kept: list
    joins: list
    smoothing: float


def fair_networks(job, adjacency, readable, joins, reversed_, continuity):
    """Fair the unchanged faces among ``joins`` as networks; install the moved faces.

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
    adjacency : Adjacency
        Every join of the model.
    readable : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    joins : list of Join
        Whole-side joins between faces of ``readable``.
    reversed_ : callable
        ``reversed_(join)``: the two faces' along-parameters run opposite ways.
    continuity : {"G0", "G1"}

    Returns
    -------
    list of NetworkFairing
    """
    unchanged = {f for f in readable if job.reports[f].status == "unchanged"
                 and job.tol.get(f) is not None}
    links = [j for j in joins if set(j.faces) <= unchanged and
             network_joinable(readable[j.faces[0]], j.sides[0].side, readable[j.faces[1]],
                              j.sides[1].side, reversed_(j))]
    linked = {id(j) for j in links}
    out = []
    for component in _components(links):
        moving = {f for f in component
                  if all(id(j) in linked for j in adjacency.joins_of(f))}
        if moving:
            done = _fair_component(job, readable, sorted(component), moving,
                                   [j for j in links if set(j.faces) <= component],
                                   reversed_, continuity)
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


def _fair_component(job, readable, faces, moving, links, reversed_, continuity):
    position = {face: k for k, face in enumerate(faces)}
    core_joins = [BorderJoin(position[a.face], a.side, position[b.face], b.side,
                             reversed_(j), j.kind == "smooth")
                  for j in links for a, b in [j.sides]]
    kept = [position[f] for f in faces if f not in moving]
    tols = [job.tol[f] for f in faces]
    network = PatchNetwork([readable[f] for f in faces], core_joins, continuity)
    for _ in range(RETRIES + 1):
        result = network.fair(tols, kept=kept)
        moved = {f for f in moving if position[f] not in result.kept}
        if not moved:
            return None
        # the faces nearest their tolerance by the network's own samples first
        nearest = sorted(moved, key=lambda f: -result.deviations[position[f]] / job.tol[f])
        checked = _checked(job, readable, [(f, result.surfaces[position[f]]) for f in nearest])
        if checked is not None:
            _install(job, checked, readable, len(faces))
            return NetworkFairing(sorted(moved), sorted(set(faces) - moved), links,
                                  result.smoothing)
        tols = [SHRINK * t for t in tols]
    return None


def _checked(job, readable, surfaces):
    """``{face: job.measured(face, surface)}`` over ``surfaces`` (``[(face, surface)]``)
    if OCCT finds every face within its tolerance, else ``None``: the first face over
    ends the check (the network is then solved again, whatever the others measure)."""
    checked = {}
    for face, surface in surfaces:
        checked[face] = job.measured(face, collapsed_kept(readable[face], surface))
        if checked[face][2]["max"] > job.tol[face]:
            return None
    return checked


def _install(job, checked, readable, size):
    message = (f"faired with its network of {size} faces by thin-plate energy across their "
               "joins (its net was already at its coarsest)")
    for index, measured in checked.items():
        job.faired(index, measured, message, readable[index].shape)
