r"""Which samples of a parameter grid lie on a trimmed face: OCCT's answer, asked only
where a polygon of the trim cannot give it.

``Part.Face.isPartOfDomain(u, v)`` classifies one parameter pair per call, building
OCCT's classifier each time (about 0.5 ms on a trimmed face of linkrods: a minute for a
tolerance search's grids).  The trim's p-curves, sampled at :data:`SAMPLES` points per
edge, form a polygon in the parameter plane; a grid row :math:`v = v_j` crosses it at
the parameters :math:`u^*_k` where a segment straddles :math:`v_j` (half-open:
:math:`\min(v_a, v_b) \le v_j < \max(v_a, v_b)`), and a sample :math:`(u_i, v_j)` is
inside when an odd number of the :math:`u^*_k` lie below :math:`u_i` (even-odd rule).
OCCT answers instead

* on a row crossed an odd number of times (the polygon does not close along it: a
  degenerated edge without a p-curve);
* within :math:`\beta` of the polygon, :math:`\beta = \max(4\,\delta, 10^{-5}\,D)`,
  :math:`\delta` the largest distance between a p-curve and its chord at the midpoints
  of the samples and :math:`D` the diagonal of the face's parameter box: there the
  polygon may stand on the other side of the curve than OCCT's classifier with its
  tolerance.

A face on a periodic surface, or with a seam (an edge used twice), is asked sample by
sample: its p-curves need not lie in one period of the grid.
"""

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["on_face", "seams", "SAMPLES"]

SAMPLES = 257          # p-curve samples per edge (the polygon's vertices)
BAND_FACTOR = 4.0      # the band around the polygon, in chord deviations
BAND_FLOOR = 1e-5      # ... at least this share of the parameter box's diagonal


def on_face(face, u, v):
    """``(len(u), len(v))`` booleans: :math:`(u_i, v_j)` on ``face`` by OCCT's
    ``isPartOfDomain`` (module notes: asked only where the trim's polygon cannot say)."""
    u, v = np.asarray(u, float), np.asarray(v, float)
    polygon = _polygon(face)
    if polygon is None:
        return _asked(face, u, v, np.ones((len(u), len(v)), bool))
    segments, band = polygon
    inside, unsure = _even_odd(segments, u, v)
    unsure |= _near(segments, band, u, v)
    inside[unsure] = _asked(face, u, v, unsure)[unsure]
    return inside


def seams(face):
    """The edges ``face``'s wires use twice (the seams of a periodic surface;
    ``face.Edges`` lists each once)."""
    seen, twice = {}, []
    for edge in (e for wire in face.Wires for e in wire.SubShapes):
        bucket = seen.setdefault(edge.hashCode(), [])
        if any(e.isSame(edge) for e in bucket):
            twice.append(edge)
        else:
            bucket.append(edge)
    return twice


def _asked(face, u, v, which):
    """OCCT's answer at the grid samples ``which`` (False elsewhere)."""
    out = np.zeros((len(u), len(v)), bool)
    for i, j in zip(*np.nonzero(which)):
        out[i, j] = face.isPartOfDomain(float(u[i]), float(v[j]))
    return out


def _polygon(face):
    """``(segments (s, 2, 2), band)`` of the trim's p-curves, or ``None`` where the face
    must be asked sample by sample (module notes)."""
    surface = face.Surface
    if surface.isUPeriodic() or surface.isVPeriodic():
        return None
    if seams(face):
        return None
    segments, deviation = [], 0.0
    for edge in face.Edges:
        found = face.curveOnSurface(edge)
        if found is None:
            if edge.Degenerated:
                continue    # the rows it leaves open are crossed an odd number of times
            return None
        curve, first, last = found[0], found[1], found[2]
        t = np.linspace(first, last, 2 * SAMPLES - 1)
        points = np.array([(p.x, p.y) for p in (curve.value(float(x)) for x in t)])
        nodes, middles = points[::2], points[1::2]
        chords = 0.5 * (nodes[:-1] + nodes[1:])
        deviation = max(deviation, float(np.linalg.norm(middles - chords, axis=1).max()))
        segments.append(np.stack([nodes[:-1], nodes[1:]], axis=1))
    if not segments:
        return None
    u0, u1, v0, v1 = face.ParameterRange
    band = max(BAND_FACTOR * deviation, BAND_FLOOR * float(np.hypot(u1 - u0, v1 - v0)))
    return np.concatenate(segments), band


def _even_odd(segments, u, v):
    """``(inside, unsure)`` on the grid by the even-odd rule along each row; a row
    crossed an odd number of times is all unsure."""
    a, b = segments[:, 0], segments[:, 1]
    inside = np.zeros((len(u), len(v)), bool)
    unsure = np.zeros_like(inside)
    for j, height in enumerate(v):
        straddle = (np.minimum(a[:, 1], b[:, 1]) <= height) & (
            height < np.maximum(a[:, 1], b[:, 1]))
        if not straddle.any():
            continue
        pa, pb = a[straddle], b[straddle]
        crossings = np.sort(pa[:, 0] + (height - pa[:, 1]) * (pb[:, 0] - pa[:, 0])
                            / (pb[:, 1] - pa[:, 1]))
        if crossings.size % 2:
            unsure[:, j] = True
            continue
        inside[:, j] = np.searchsorted(crossings, u, side="right") % 2 == 1
    return inside, unsure


def _near(segments, band, u, v):
    """Grid samples within ``band`` of the polygon (the tree of both ends of every
    segment, the segments' longest half length added)."""
    vertices = segments.reshape(-1, 2)
    reach = band + 0.5 * float(np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1).max())
    uu, vv = np.meshgrid(u, v, indexing="ij")
    distance, _ = cKDTree(vertices).query(np.column_stack([uu.ravel(), vv.ravel()]),
                                          distance_upper_bound=reach)
    return np.isfinite(distance).reshape(len(u), len(v))
