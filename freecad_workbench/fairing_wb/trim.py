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

import functools

import numpy as np
import Part
from scipy.spatial import cKDTree

import cq_fairing as cf

__all__ = ["on_face", "Trim", "seams", "curve_points", "SAMPLES"]

SAMPLES = 257          # p-curve samples per edge (the polygon's vertices)
BAND_FACTOR = 4.0      # the band around the polygon, in chord deviations
BAND_FLOOR = 1e-5      # ... at least this share of the parameter box's diagonal


def on_face(face, u, v):
    """``(len(u), len(v))`` booleans: :math:`(u_i, v_j)` on ``face`` by OCCT's
    ``isPartOfDomain`` (module notes: asked only where the trim's polygon cannot say)."""
    return Trim(face).on_face(u, v)


class Trim:
    """The trim of ``face`` for :func:`on_face` on any number of grids: its polygon
    (module notes) sampled from the p-curves once, at the first grid."""

    def __init__(self, face):
        self.face = face

    @functools.cached_property
    def polygon(self):
        """``(segments, band)`` of the trim, or ``None`` where the face is asked sample
        by sample (:func:`_polygon`)."""
        return _polygon(self.face)

    def on_face(self, u, v):
        """:func:`on_face` of the face at the grid ``(u_i, v_j)``."""
        u, v = np.asarray(u, float), np.asarray(v, float)
        if self.polygon is None:
            return _asked(self.face, u, v, np.ones((len(u), len(v)), bool))
        segments, band = self.polygon
        inside, unsure = _even_odd(segments, u, v)
        unsure |= _near(segments, band, u, v)
        inside[unsure] = _asked(self.face, u, v, unsure)[unsure]
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
        points = curve_points(curve, np.linspace(first, last, 2 * SAMPLES - 1))
        nodes, middles = points[::2], points[1::2]
        chords = 0.5 * (nodes[:-1] + nodes[1:])
        deviation = max(deviation, float(np.linalg.norm(middles - chords, axis=1).max()))
        segments.append(np.stack([nodes[:-1], nodes[1:]], axis=1))
    if not segments:
        return None
    u0, u1, v0, v1 = face.ParameterRange
    band = max(BAND_FACTOR * deviation, BAND_FLOOR * float(np.hypot(u1 - u0, v1 - v0)))
    return np.concatenate(segments), band


def curve_points(curve, t):
    """``(len(t), 2)`` points of the p-curve ``curve`` at parameters ``t``: a
    non-periodic B-spline clamped at both ends and ``t`` in its domain by the core's
    batched evaluation (Part's points to rounding, which moves the polygon far less
    than its band), any other by Part's ``value`` point by point."""
    if isinstance(curve, Part.Geom2d.BSplineCurve2d) and not curve.isPeriodic():
        degree, mults = curve.Degree, curve.getMultiplicities()
        knots = np.repeat(np.asarray(curve.getKnots(), float), mults)
        if (mults[0] == mults[-1] == degree + 1 and knots[0] <= t.min()
                and t.max() <= knots[-1]):
            weights = curve.getWeights() if curve.isRational() else None
            poles = np.array([(p.x, p.y) for p in curve.getPoles()])
            return cf.make_curve(poles, knots, degree, weights).evaluate(t)
    return np.array([(p.x, p.y) for p in (curve.value(float(x)) for x in t)])


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
    r"""Grid samples within ``band`` of the polygon: the distance from a sample
    :math:`p` to a segment :math:`[a, b]` is :math:`|a + t (b - a) - p|` with
    :math:`t = \operatorname{clip}((p - a)\cdot(b - a) / |b - a|^2, 0, 1)`, measured for
    the segments whose midpoints lie within ``band`` plus the segments' longest half
    length (a tree of the midpoints): no other segment can be nearer than ``band``."""
    a, b = segments[:, 0], segments[:, 1]
    reach = band + 0.5 * float(np.linalg.norm(b - a, axis=1).max())
    uu, vv = np.meshgrid(u, v, indexing="ij")
    points = np.column_stack([uu.ravel(), vv.ravel()])
    pairs = cKDTree(points).sparse_distance_matrix(cKDTree(0.5 * (a + b)), reach,
                                                   output_type="ndarray")
    i, k = pairs["i"], pairs["j"]
    along = b[k] - a[k]
    length2 = np.einsum("ij,ij->i", along, along)
    t = np.clip(np.divide(np.einsum("ij,ij->i", points[i] - a[k], along), length2,
                          out=np.zeros_like(length2), where=length2 > 0), 0.0, 1.0)
    distance = np.linalg.norm(a[k] + t[:, None] * along - points[i], axis=1)
    near = np.zeros(points.shape[0], bool)
    near[i[distance <= band]] = True
    return near.reshape(len(u), len(v))
