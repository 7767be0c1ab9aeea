r"""Free edges of loose faces matched into joins by their geometry: :func:`match_free_edges`.

A compound of loose faces (an IGES file's faces, never sewn) has no shared edges: where
two faces meet, each has its own *free* edge (used by that face only).  Two free edges
:math:`a` and :math:`b` of different faces are one boundary when, with their probes
:math:`p^a_k, p^b_k` (:data:`EDGE_PROBES` points at the fractions
:math:`s_k = k / (K - 1)` of each edge's parameter range, from its start to its end),

1. their end points coincide, in the same order (:math:`|p^a_0 - p^b_0|` and
   :math:`|p^a_{K-1} - p^b_{K-1}|`) or in reverse order (``opposed``: :math:`b`'s probes
   taken from its end, :math:`p^b_{K-1-k}`), within the limit

   .. math:: \ell = \max(\min(c, \sigma \min(L_a, L_b)), \tau_a, \tau_b)

   (:math:`c` the coincidence distance, :math:`L` the edges' lengths, :math:`\tau` their
   tolerances, :math:`\sigma` = :data:`EDGE_SHARE`: small faces of a large model are not
   joined across gaps of their own size), and
2. their probes lie within :math:`\ell` of each other: at the same fractions,
   :math:`\max_k |p^a_k - p^b_k|` (reversed when ``opposed``), or else, for edges
   parametrized differently, by projection onto the other edge's curve (the backend's
   callback), the larger of the two ways and of the end distances.

That largest distance ranks the candidates; they are taken closest first, each edge
once (a greedy assignment).  Candidate pairs come from a KD-tree of the end points
(each edge a point :math:`(p_0, p_{K-1})` in :math:`\mathbb{R}^6`, searched within
:math:`\sqrt 2 \max(c, \max_e \tau_e)`, at least every limit, in both orders).  Two free edges of one face
(an unsewn seam) are never matched; nor are partial overlaps (one long edge against two
short ones): the end points must meet.
"""

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["COINCIDENCE", "EDGE_PROBES", "EDGE_SHARE", "match_free_edges", "probe_length"]

COINCIDENCE = 1e-4        # default coincidence distance, relative to the model's size
EDGE_PROBES = 5           # probes per free edge, uniform in its parameter
EDGE_SHARE = 1e-2         # the limit is at most this share of the shorter edge's length


def match_free_edges(faces, probes, tolerances, lengths, coincidence, distance_along):
    """Pairs of coincident free edges (module doc), closest first, each edge once.

    Parameters
    ----------
    faces : array_like of int
        ``(n,)``: the face owning each free edge.
    probes : array_like of float
        ``(n, K, 3)``: each edge's points at ``K`` uniform fractions of its parameter
        range, its start first (``K`` = :data:`EDGE_PROBES` in the backends).
    tolerances : array_like of float
        ``(n,)``: the edges' tolerances.
    lengths : array_like of float
        ``(n,)``: the edges' lengths (the backends give :func:`probe_length`).
    coincidence : float
        The coincidence distance :math:`c`.
    distance_along : callable
        ``distance_along(i, j) -> float``: the largest distance from edge ``i``'s inner
        probes to edge ``j``'s curve (``inf`` when it cannot be measured); asked only for
        candidates whose probes do not coincide at the same fractions.

    Returns
    -------
    list of tuple
        ``(i, j, opposed)`` with ``i < j`` edge positions, in the order taken (the
        closest first); ``opposed``: the edges run in opposite directions.
    """
    faces = np.asarray(faces)
    probes = np.asarray(probes, dtype=float).reshape(len(faces), -1, 3)
    tolerances = np.asarray(tolerances, dtype=float)
    lengths = np.asarray(lengths, dtype=float)
    if len(faces) < 2:
        return []
    ends = np.concatenate([probes[:, 0], probes[:, -1]], axis=1)
    swapped = np.concatenate([ends[:, 3:], ends[:, :3]], axis=1)
    radius = max(coincidence, float(tolerances.max()))
    tree = cKDTree(ends)
    candidates = []
    for opposed, queries in ((False, ends), (True, swapped)):
        for i, near in enumerate(tree.query_ball_point(queries, np.sqrt(2.0) * radius)):
            for j in near:
                if i < j and faces[i] != faces[j]:
                    limit = max(min(coincidence, EDGE_SHARE * min(lengths[i], lengths[j])),
                                tolerances[i], tolerances[j])
                    distance = _coincident(probes[i], probes[j], opposed, limit,
                                           lambda i=i, j=j: (distance_along(i, j),
                                                             distance_along(j, i)))
                    if distance is not None:
                        candidates.append((distance, i, j, opposed))
    return _closest_first(candidates)


def probe_length(probes):
    """The length of the polyline through an edge's ``probes`` ``(K, 3)``: the edge's
    length as :func:`match_free_edges` takes it."""
    return float(np.linalg.norm(np.diff(probes, axis=0), axis=1).sum())


def _coincident(a, b, opposed, limit, along):
    """The largest distance between the probes ``a`` and ``b`` (``(K, 3)`` each, ``b``
    reversed when ``opposed``) when it is within ``limit``, else ``None``: the ends
    first, then the probes at the same fractions, then ``along()`` (the two ways'
    projections onto the other curve) with the ends."""
    other = b[::-1] if opposed else b
    ends = max(np.linalg.norm(a[0] - other[0]), np.linalg.norm(a[-1] - other[-1]))
    if ends > limit:
        return None
    direct = float(np.linalg.norm(a - other, axis=1).max())
    if direct <= limit:
        return direct
    projected = max(ends, *along())
    return projected if projected <= limit else None


def _closest_first(candidates):
    """The greedy assignment: ``candidates`` ``(distance, i, j, opposed)`` taken in
    increasing order, each edge once, as ``(i, j, opposed)``."""
    taken, pairs = set(), []
    for _distance, i, j, opposed in sorted(set(candidates)):
        if i in taken or j in taken:
            continue
        taken.update((i, j))
        pairs.append((i, j, opposed))
    return pairs
