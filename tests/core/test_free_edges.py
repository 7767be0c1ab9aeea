"""Free edges matched into joins (cq_fairing.core.free_edges) against a naive matching
that tries every pair, and on boundaries whose matching is known by construction."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from cq_fairing.core.free_edges import EDGE_PROBES, EDGE_SHARE, match_free_edges, probe_length

FRACTIONS = np.linspace(0.0, 1.0, EDGE_PROBES)


def _to_polyline(point, polyline):
    """Distance from ``point`` to the polyline through ``polyline`` (K, 3)."""
    a, b = polyline[:-1], polyline[1:]
    t = np.clip(np.einsum("ij,ij->i", point - a, b - a)
                / np.maximum(np.einsum("ij,ij->i", b - a, b - a), 1e-300), 0.0, 1.0)
    return float(np.linalg.norm(a + t[:, None] * (b - a) - point, axis=1).min())


def _along(probes):
    """The callback: the largest distance from edge i's inner probes to edge j's
    polyline."""
    def along(i, j):
        return max(_to_polyline(p, probes[j]) for p in probes[i][1:-1])
    return along


def naive(faces, probes, tolerances, lengths, coincidence, along):
    """Every pair of edges of different faces, both ways round: the limit, the ends, the
    probes at equal fractions, else the projections; then closest first, each edge once."""
    candidates = []
    for i in range(len(faces)):
        for j in range(i + 1, len(faces)):
            if faces[i] == faces[j]:
                continue
            limit = max(min(coincidence, EDGE_SHARE * min(lengths[i], lengths[j])),
                        tolerances[i], tolerances[j])
            for opposed in (False, True):
                other = probes[j][::-1] if opposed else probes[j]
                distances = np.linalg.norm(probes[i] - other, axis=1)
                ends = max(distances[0], distances[-1])
                if ends > limit:
                    continue
                worst = distances.max()
                if worst > limit:
                    worst = max(ends, along(i, j), along(j, i))
                if worst <= limit:
                    candidates.append((worst, i, j, opposed))
    taken, pairs = set(), []
    for _, i, j, opposed in sorted(candidates):
        if not {i, j} & taken:
            taken |= {i, j}
            pairs.append((i, j, opposed))
    return pairs


def _boundary(rng, start, scale):
    """A curved boundary: its points at ``FRACTIONS`` and a denser sampling."""
    bend = rng.normal(0.0, 0.2 * scale, 3)
    direction = rng.normal(0.0, scale, 3)

    def at(s):
        s = np.asarray(s)[:, None]
        return start + s * direction + 4.0 * s * (1.0 - s) * bend
    return at


@st.composite
def loose_edges(draw):
    """Boundaries, each given as two free edges of different faces (one maybe reversed,
    reparametrized, or moved off by up to 3 times the coincidence), plus lone edges."""
    seed = draw(st.integers(0, 2**32 - 1))
    count = draw(st.integers(1, 12))
    rng = np.random.default_rng(seed)
    coincidence = 1e-3
    faces, probes = [], []
    for k in range(count):
        at = _boundary(rng, rng.uniform(-1.0, 1.0, 3) * draw(st.sampled_from([0.0, 1.0])),
                       draw(st.sampled_from([0.05, 1.0])))
        copies = draw(st.integers(1, 3))
        for c in range(copies):
            fractions = FRACTIONS if draw(st.booleans()) else FRACTIONS ** 1.3
            points = at(fractions) + rng.normal(0.0, draw(st.sampled_from(
                [0.0, 0.1, 0.5, 3.0])) * coincidence, (EDGE_PROBES, 3))
            probes.append(points[::-1] if draw(st.booleans()) else points)
            faces.append(draw(st.integers(0, 2 * count)) if c else 2 * count + 1 + k)
    tolerances = [draw(st.sampled_from([1e-7, 1e-4, 2e-3])) for _ in faces]
    return faces, np.array(probes), tolerances, coincidence


@settings(max_examples=150, deadline=None)
@given(loose_edges())
def test_matches_as_every_pair_tried(case):
    faces, probes, tolerances, coincidence = case
    lengths = [probe_length(p) for p in probes]
    got = match_free_edges(faces, probes, tolerances, lengths, coincidence, _along(probes))
    assert got == naive(faces, probes, tolerances, lengths, coincidence, _along(probes))
    used = [k for i, j, _ in got for k in (i, j)]
    assert len(used) == len(set(used)) and all(faces[i] != faces[j] for i, j, _ in got)


def test_the_interior_boundaries_of_a_split_square_are_matched():
    """A unit square cut into a 3 x 3 grid of loose cells: every interior boundary (12)
    is one join, of the two cells it separates, opposed where the cells run their edges
    the other way round; the 12 outer edges stay free."""
    faces, probes, truth = [], [], {}
    for cx in range(3):
        for cy in range(3):
            corners = [(cx, cy), (cx + 1, cy), (cx + 1, cy + 1), (cx, cy + 1)]
            for a, b in zip(corners, corners[1:] + corners[:1]):
                start, end = np.array([*a, 0.0]) / 3, np.array([*b, 0.0]) / 3
                faces.append(3 * cx + cy)
                probes.append(start + FRACTIONS[:, None] * (end - start))
                truth.setdefault(frozenset((a, b)), []).append(len(faces) - 1)
    probes = np.array(probes)
    lengths = [probe_length(p) for p in probes]
    got = match_free_edges(faces, probes, [1e-7] * len(faces), lengths, 1e-4,
                           _along(probes))
    interior = {tuple(sorted(edges)) for edges in truth.values() if len(edges) == 2}
    assert len(interior) == 12 and {(i, j) for i, j, _ in got} == interior
    assert all(opposed for _, _, opposed in got)  # counter-clockwise cells meet reversed


def _matched(faces, probes, coincidence=1e-4, along=None):
    probes = np.array(probes)
    return match_free_edges(faces, probes, [1e-7] * len(faces),
                            [probe_length(p) for p in probes], coincidence,
                            along or _along(probes))


LINE = np.array([[s, 0.0, 0.0] for s in FRACTIONS])


def test_reparametrized_edges_match_through_the_callback():
    """Edge 1 runs back along edge 0 at other fractions (3e-5 off): its probes at equal
    fractions are far apart, so both projections are asked for, and the edges match,
    opposed."""
    slid = np.array([[s ** 2, 3e-5, 0.0] for s in FRACTIONS])[::-1]
    asked = []

    def along(i, j):
        asked.append((i, j))
        return _along(np.array([LINE, slid]))(i, j)

    assert _matched([0, 1], [LINE, slid], along=along) == [(0, 1, True)]
    assert sorted(asked) == [(0, 1), (1, 0)]


def test_the_closest_edge_wins_and_a_face_never_joins_itself():
    near, far = LINE + [0.0, 2e-5, 0.0], LINE + [0.0, 0.0, 5e-5]
    assert _matched([0, 1, 2], [LINE, far, near]) == [(0, 2, False)]
    assert _matched([0, 0], [LINE, near]) == []
    assert _matched([0, 1], [LINE, LINE + [0.0, 2e-4, 0.0]]) == []


def test_a_short_edge_is_not_joined_across_a_share_of_its_length():
    """Edges 1e-3 long: 2e-5 apart is more than EDGE_SHARE of their length (within the
    coincidence 1e-4), 5e-6 is not."""
    short = LINE * 1e-3
    assert EDGE_SHARE * 1e-3 < 2e-5 < 1e-4
    assert _matched([0, 1], [short, short + [0.0, 2e-5, 0.0]]) == []
    assert _matched([0, 1], [short, short + [0.0, 5e-6, 0.0]]) == [(0, 1, False)]
