"""The example patch models faired by the core's functions called directly: the references
that whole-model fairings (``cq_fairing.occ.fair_shape``, the FreeCAD workbench) are
compared with, face by face.  Imports the core only, so that FreeCAD's Python can use it.
"""

import numpy as np

from cq_fairing.core.examples import patch_grid, patch_network
from cq_fairing.core.grid_fairing import fair_merged, source_merge_gap
from cq_fairing.core.network import fair_network
from cq_fairing.core.patch_grid import merge_grid, oriented, split_grid


def grid_pieces(tol):
    """The 2 x 2 :func:`~cq_fairing.core.examples.patch_grid` merged (its cells laid out
    by hand from the example's construction: patch 1 runs backwards in u, patch 3 has u
    along y), faired as one surface within ``tol`` and cut back: each patch's piece, in
    the patch's own directions, in the example's patch order."""
    p = patch_grid().patches
    merged = merge_grid([[p[0], p[2]], [oriented(p[1], flip_u=True), oriented(p[3], swap=True)]],
                        tol=source_merge_gap(tol))
    pieces = split_grid(merged, fair_merged(merged, tol))
    return [pieces[0][0], oriented(pieces[1][0], flip_u=True), pieces[0][1],
            oriented(pieces[1][1], swap=True)]


def network_surfaces(tol):
    """The three patches of :func:`~cq_fairing.core.examples.patch_network` faired together
    by energy within ``tol``, G1 across their two joins, in the example's patch order."""
    example = patch_network()
    return fair_network(example.patches, example.joins, tol, continuity="G1").surfaces


def matching(nets, patches):
    """``order[k]``: the index in ``patches`` of the patch whose poles are ``nets[k]`` (a
    model's faces come in its own order), to round-off of the poles' extent."""
    order = [int(np.argmin([np.inf if p.poles.shape != net.shape
                            else np.abs(p.poles - net).max() for p in patches]))
             for net in nets]
    extent = np.ptp(np.concatenate([p.poles.reshape(-1, 3) for p in patches]), axis=0).max()
    assert sorted(order) == list(range(len(patches)))
    assert all(np.abs(patches[k].poles - net).max() <= 1e-12 * extent
               for k, net in zip(order, nets))
    return order
