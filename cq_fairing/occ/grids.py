r"""Fair the patch grids of a model as single surfaces, each piece checked by OCCT.

The core finds the blocks of patches that form whole parts of the model, merges each
into one surface, fairs it and cuts it back at the original joins
(:func:`~cq_fairing.core.grid_fairing.fair_grids`); here every piece is measured against
its own face by OCCT, both ways (:meth:`~cq_fairing.occ.shapes._Job.measured`), and the
pieces of the blocks that pass are installed in the faces' reports.
"""

from ..core.grid_fairing import fair_grids as fair_core_grids

__all__ = ["fair_grids"]


def fair_grids(job, adjacency, readable, joins, reversed_, merge_gap):
    """Fair every grid block among ``joins`` that stands alone as one surface
    (:func:`~cq_fairing.core.grid_fairing.fair_grids`); install the pieces.

    Parameters
    ----------
    job : cq_fairing.occ.shapes._Job
        After its first pass; the reports of the faces of every block faired here are
        replaced by the pieces' reports.
    adjacency : Adjacency
        Every join of the model.
    readable : dict
        ``{face: source BSplineSurface}`` of the polynomial faces that may be joined.
    joins : list of Join
        Whole-side joins between faces of ``readable``; the smooth ones may be crossed.
    reversed_ : callable
        ``reversed_(join)``: whether the two faces' along-parameters run opposite ways.
    merge_gap : callable
        ``merge_gap(tol)``: the largest distance between border poles merged into one.

    Returns
    -------
    list of GridFairing
    """
    measured = {}

    def check(face, surface):
        measured[face] = job.measured(face, surface, readable[face])
        return measured[face][2]["max"]

    grids = fair_core_grids(readable, adjacency.joins, joins, job.tol, check,
                            target_degree=job.options["target_degree"], reversed_=reversed_,
                            merge_gap=merge_gap)
    for grid in grids:
        members = ", ".join(str(f + 1) for f in grid.faces)
        message = (f"faired as one surface with faces {members} ({grid.shape[0]} x "
                   f"{grid.shape[1]} patch grid)")
        for face in grid.faces:
            job.faired(face, measured[face], message, readable[face].shape)
    return grids
