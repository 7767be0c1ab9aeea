r"""Fair the faces that nothing can be removed from together, each checked by OCCT.

The core fairs the faces left unchanged that meet along whole sides as networks, by
thin-plate energy across their joins
(:func:`~cq_fairing.core.network_fairing.fair_networks`); here every moved face is
measured against its own face by OCCT, both ways
(:meth:`~cq_fairing.occ.shapes._Job.measured`), and installed in its report.
"""

from ..core.network_fairing import fair_networks as fair_core_networks
from ..core.network_fairing import kept_sentence

__all__ = ["fair_networks"]


def fair_networks(job, adjacency, readable, reversed_, continuity, refaired=frozenset()):
    """Fair the unchanged faces of ``readable``, and those of ``refaired``, as networks
    across their joins (:func:`~cq_fairing.core.network_fairing.fair_networks`); install
    the moved faces, and give the faces a network kept its reason
    (:attr:`~cq_fairing.core.network_fairing.NetworkFairing.reasons`).

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
    adjacency : Adjacency
        Every join of the model.
    readable : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    reversed_ : callable
        ``reversed_(join)``: the two faces' along-parameters run opposite ways.
    continuity : {"G0", "G1", "G2"}
    refaired : set of int
        Faces faired alone that the networks may fair again, from their sources (the
        energy method's faces: their nets are their sources').

    Returns
    -------
    list of NetworkFairing
    """
    movable = {f for f in readable if job.reports[f].status == "unchanged"} | set(refaired)
    measured = {}

    def check(face, surface):
        measured[face] = job.measured(face, surface, readable[face])
        return measured[face][2]["max"]

    networks = fair_core_networks(readable, movable, adjacency.joins, job.tol,
                                  check, continuity=continuity, reversed_=reversed_)
    for network in networks:
        message = (f"faired with its network of {len(network.moved) + len(network.kept)} "
                   "faces by thin-plate energy across their joins")
        for face in network.moved:
            why = "" if face in refaired else " (its net was already at its coarsest)"
            job.faired(face, measured[face], message + why, readable[face].shape)
        for face, reason in network.reasons.items():
            alone = " (joins='free' fairs it alone)" if face in refaired else ""
            job.reports[face] = job.kept(face, "unchanged", kept_sentence(reason) + alone)
    return networks
