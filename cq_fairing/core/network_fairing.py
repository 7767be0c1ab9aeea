r"""Fair the faces that nothing can be removed from together, by energy across their joins.

A face already at its coarsest (a bicubic patch of one span, a net whose target is its
own space) is left unchanged by its own search, and the joint projection keeps it as
it is.  A model made of such patches (a shell of 4 x 4 patches) is faired by
:func:`~cq_fairing.core.network.fair_network` instead: the thin-plate energy of all of
them, each in its own parametrization, under the joins' G0 and G1 constraints, within
each face's tolerance.  The borders move with the faces, so the fairing runs across
the joins.

The network is the faces left unchanged that meet along their borders, laid out as
pieces that meet side to side (:func:`~cq_fairing.core.network_pieces.lay_out_pieces`:
a face with a T-junction on a side is cut there, and the cut runs on across its
neighbours), joined where their borders share degree and knots and lie within
``SOURCE_GAP`` times the tolerance of each other.  A piece along any other join (to a
faired face, a trimmed side, other knots) keeps its surface and constrains its
neighbours, so every join of a moved face is held closed.  Each moved face, its pieces
put back together, is then checked against its own face by the backend's two-sided
measure (``check``); if one is over its tolerance the network is solved again with
:data:`SHRINK` times the tolerances, :data:`RETRIES` times at most (its forms and
samples prepared once, :class:`~cq_fairing.core.network.PatchNetwork`), and otherwise
left as it was.  The faces nearest their tolerance by the network's own samples are
checked first, and the first one over ends the check, so that a solve with a face over
its tolerance costs a few measures, not one per face.

This module imports numpy only (and the core).
"""

from dataclasses import dataclass, field, replace

import numpy as np

from .geometry import collapsed_kept
from .joins import ANGLE_SLACK
from .joint_projection import runs_reversed
from .network import PatchNetwork
from .network_pieces import lay_out_pieces

__all__ = ["fair_networks", "kept_reasons", "kept_sentence", "NetworkFairing", "RETRIES", "SHRINK", "UNMOVED"]

RETRIES = 2
SHRINK = 0.7
# why the energy method keeps a face with joins: what the backends' reports say
UNMOVED = ("no network of faces moved it (its joins would hold it over its tolerance or "
           "turn more than the source's, or no network can fair across them), and energy "
           "fairs a face alone only with its borders free")


@dataclass(frozen=True)
class NetworkFairing:
    r"""One network of faces faired by energy.

    Attributes
    ----------
    moved : list of int
        The faces faired.
    kept : list of int
        The faces of the network that kept their surfaces.
    joins : list of Join
        The joins held closed (G0, and G1 where smooth, or turning as the source's where
        tangency would hold a face over its tolerance).
    smoothing : float
        The smallest energy weight :math:`\lambda_f` reached by the network's moved
        pieces (:func:`~cq_fairing.core.network.fair_network`).
    surfaces : dict
        ``{face: BSplineSurface}`` of the moved faces, as checked.
    reasons : dict
        ``{face: reason}``: why the network kept each face of :attr:`kept` that the
        solve kept (the joins alone hold it over its tolerance, a smooth join of it
        would turn more than the source's, or it is planar; :func:`kept_reasons`, worded by
        :func:`kept_sentence`); a face kept because all its pieces lie along joins the
        network does not fair across has none.
    """

    moved: list
    kept: list
    joins: list
    smoothing: float
    surfaces: dict
    reasons: dict = field(default_factory=dict)


def fair_networks(sources, movable, joins, tolerances, check, *, continuity="G1",
                  reversed_=runs_reversed):
    """Fair the ``movable`` faces as networks across their joins.

    Parameters
    ----------
    sources : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    movable : collection of int
        The faces that may be faired here, from their sources (those left as their
        sources by fairing alone, or faired alone by energy, which keeps the nets).
    joins : sequence of Join
        Every join of the model: those between two of the faces along their borders are
        faired across (:func:`~cq_fairing.core.network_pieces.lay_out_pieces`, which cuts
        the faces at T-junctions); the pieces along any other join keep their surfaces.
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
        The networks whose every moved face is within its tolerance, and those whose
        joins alone keep every face (no face moved, each with its reason).
    """
    faces = {f for f in sources if f in movable and tolerances.get(f) is not None}
    layout = lay_out_pieces(sources, faces, joins, tolerances, reversed_)
    out = []
    for component in _components(layout.joins):
        if component - layout.held:
            done = _fair_component(layout, sources, sorted(component), tolerances, check,
                                   "G0" if continuity == "G0" else "G1")
            if done is not None:
                out.append(done)
    return out


def kept_reasons(pieces_of, reasons, tols, join_faces):
    """``{face: reason}`` of the faces whose pieces the network's solve kept
    (:attr:`~cq_fairing.core.network.NetworkResult.reasons`): ``("tolerance", d, tol)``,
    the worst distance ``d`` a piece's joins alone hold it at, over the tolerance ``tol``
    it was solved to (infinite where it folds), else ``("turned", faces)``, the other
    faces across the smooth joins that would turn (empty where the join runs between
    its own pieces), else ``("planar",)``, the face is planar.  :func:`kept_sentence`
    words it.

    Parameters
    ----------
    pieces_of : dict
        ``{face: [piece, ...]}`` of the faces kept, pieces indexed as the network's.
    reasons : dict
        The network's ``{piece: ("tolerance", d), ("turned", [join, ...]) or
        ("planar",)}``.
    tols : sequence of float
        The tolerance each piece was solved to.
    join_faces : sequence of (int, int)
        The two faces of each of the network's joins.
    """
    out = {}
    for face, own in pieces_of.items():
        why = [reasons[k] + (tols[k],) for k in own if k in reasons]
        over = [(w[1], w[2]) for w in why if w[0] == "tolerance"]
        turned = [w[1] for w in why if w[0] == "turned"]
        if over:
            out[face] = ("tolerance", *max(over))
        elif turned:
            out[face] = ("turned", sorted({other for joins in turned for join in joins
                                           for other in join_faces[join] if other != face}))
        elif why:
            out[face] = ("planar",)
    return out


def kept_sentence(reason, name=lambda face: f"face {face + 1}"):
    """The report's sentence for a face a network kept (:func:`kept_reasons`),
    ``name(face)`` naming its neighbours."""
    if reason[0] == "tolerance":
        _, distance, tol = reason
        what = (f"stays {distance:.3g} from its source at the network's samples, over the "
                f"{tol:g} it was solved to" if np.isfinite(distance) else
                "folds over itself (its normal turns against the source's)")
        return (f"with its network's joins held it {what}; kept as it was, and its "
                "neighbours close onto it")
    if reason[0] == "planar":
        return ("planar: energy fairing could only bend it out of its plane; kept as it "
                "was, and its neighbours close onto it")
    where = (f"with {', '.join(name(face) for face in reason[1])}" if reason[1]
             else "between its own pieces")
    return (f"with its network's joins held its smooth joins ({where}) would turn more "
            f"than the source's angle + {ANGLE_SLACK:g} deg; kept as it was, and its "
            "neighbours close onto it")


def _components(joins):
    """The piece sets connected by ``joins``."""
    neighbours = {}
    for join in joins:
        neighbours.setdefault(join.a, set()).add(join.b)
        neighbours.setdefault(join.b, set()).add(join.a)
    seen, out = set(), []
    for start in neighbours:
        if start in seen:
            continue
        stack, part = [start], set()
        while stack:
            piece = stack.pop()
            if piece not in part:
                part.add(piece)
                stack.extend(neighbours[piece] - part)
        seen |= part
        out.append(part)
    return out


def _fair_component(layout, sources, pieces, tolerances, check, continuity):
    """Solve one network of pieces, retried at smaller tolerances while a moved face
    misses its own: its :class:`NetworkFairing` (with no face moved where the joins
    alone hold or turn every face, each kept with its reason), or ``None`` when the
    retries run out."""
    position = {piece: k for k, piece in enumerate(pieces)}
    linked = [k for k, j in enumerate(layout.joins) if j.a in position]
    core_joins = [replace(j, a=position[j.a], b=position[j.b])
                  for j in (layout.joins[k] for k in linked)]
    owner = [layout.faces[p] for p in pieces]
    kept = [k for k, p in enumerate(pieces) if p in layout.held]
    tols = [tolerances[f] for f in owner]
    network = PatchNetwork([layout.pieces[p] for p in pieces], core_joins, continuity)
    faces = sorted(set(owner))
    for _ in range(RETRIES + 1):
        result = network.fair(tols, kept=kept)
        moved = sorted({owner[k] for k in range(len(pieces)) if k not in result.kept})
        kept_faces = sorted(set(faces) - set(moved))
        reasons = kept_reasons({f: [k for k in range(len(pieces)) if owner[k] == f]
                                for f in kept_faces}, result.reasons, tols,
                               [(layout.faces[layout.joins[k].a], layout.faces[layout.joins[k].b])
                                for k in linked])
        if not moved:   # the faces' reasons still tell why
            return NetworkFairing([], kept_faces, [], result.smoothing, {}, reasons)
        # a kept piece of a moved face on the refined spaces of the moved ones, so that
        # the face's net does not depend on which of its pieces moved
        solved = {p: network.refined[k] if k in result.kept else result.surfaces[k]
                  for k, p in enumerate(pieces)}
        surfaces = {f: collapsed_kept(sources[f], layout.face_surface(f, solved))
                    for f in moved}
        # the faces nearest their tolerance by the network's own samples first
        worst = {f: max(result.deviations[k] for k in range(len(pieces)) if owner[k] == f)
                 for f in moved}
        nearest = sorted(moved, key=lambda f: -worst[f] / tolerances[f])
        if all(check(f, surfaces[f]) <= tolerances[f] for f in nearest):
            return NetworkFairing(moved, kept_faces, layout.joins_held(set(linked)),
                                  result.smoothing, dict(sorted(surfaces.items())), reasons)
        tols = [SHRINK * t for t in tols]
    return None
