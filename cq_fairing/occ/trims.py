"""A face's trim as a :class:`~cq_fairing.core.regions.TrimRegion`: OCCT's p-curves and classifier.

Each wire is walked in order (``BRepTools_WireExplorer``, which orients every edge as
the wire runs); each edge's p-curve on the face (``BRep_Tool::CurveOnSurface``, the
right one of a seam's two for the edge's orientation) is discretised within a
deflection (chords split until each one's curve midpoint is within it) and the pieces
are chained into one
closed polyline per wire.  Where consecutive p-curves do not meet (files from other
systems join their edges within their tolerances), the chain bridges the gap, and the
accuracy handed to the region grows by the largest gap.  Samples near the polylines are
classified by OCCT's own ``BRepTopAdaptor_FClass2d`` (inside or on).
"""

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.BRepTools import BRepTools, BRepTools_WireExplorer
from OCP.BRepTopAdaptor import BRepTopAdaptor_FClass2d
from OCP.gp import gp_Pnt2d
from OCP.TopAbs import TopAbs_IN, TopAbs_ON, TopAbs_REVERSED, TopAbs_WIRE
from OCP.TopExp import TopExp_Explorer
from OCP.TopoDS import TopoDS

from ..core.regions import TrimRegion
from .pcurves import pcurve_points

__all__ = ["face_region", "trim_region", "classify"]

DEFLECTION = 1e-5  # of the UV box's larger side: the polylines' distance to the p-curves
#: Samples: below, asking OCCT about each costs about as much as the polygon or less
#: (the impeller's faces of about 2000 samples: twice less; linkrods' of about 3000:
#: 3.5 times more).
SMALL_GRID = 2500


def trim_region(face):
    """The face's :class:`~cq_fairing.core.regions.TrimRegion` (samples on its trim).

    Returns
    -------
    TrimRegion or None
        ``None`` when a wire has an edge without a p-curve on the face (no polygon can
        be trusted); callers then classify every sample with :func:`classify`.
    """
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    deflection = DEFLECTION * max(u1 - u0, v1 - v0)
    loops, gap = [], 0.0
    explorer = TopExp_Explorer(face, TopAbs_WIRE)
    while explorer.More():
        pieces = _wire_pieces(face, TopoDS.Wire_s(explorer.Current()), deflection)
        if pieces is None:
            return None
        loops.append(np.concatenate(pieces))
        gap = max(gap, _largest_gap(pieces))
        explorer.Next()
    if not loops:
        return None
    return TrimRegion(loops, lambda u, v: _classify_points(face, u, v), deflection + gap)


def face_region(face):
    """``region(u, v)``: which grid samples lie on the face (inside its trim or on it).

    Grids of ``SMALL_GRID`` samples or more that increase in both directions get the
    :func:`trim_region`'s answer (built on first use: the same answers as
    :func:`classify`, about a tenth of OCCT's calls on the impeller's faces); smaller
    grids, or faces with no trusted polygon, OCCT's classifier sample by sample.
    """
    built = []

    def on_face(u, v):
        u, v = np.asarray(u, dtype=float), np.asarray(v, dtype=float)
        if u.size * v.size < SMALL_GRID or np.any(np.diff(u) <= 0) or np.any(np.diff(v) <= 0):
            return classify(face, u, v)
        if not built:
            built.append(trim_region(face))
        return classify(face, u, v) if built[0] is None else built[0](u, v)

    return on_face


def classify(face, u, v):
    """OCCT's classification of every grid sample ``(u_i, v_j)`` (inside or on)."""
    uu, vv = np.meshgrid(u, v, indexing="ij")
    return _classify_points(face, uu.ravel(), vv.ravel()).reshape(uu.shape)


def _classify_points(face, u, v):
    classifier = BRepTopAdaptor_FClass2d(face, 1e-9)
    return np.array([classifier.Perform(gp_Pnt2d(float(a), float(b))) in (TopAbs_IN, TopAbs_ON)
                     for a, b in zip(u, v)], dtype=bool)


def _wire_pieces(face, wire, deflection):
    """Each edge's p-curve as points in the wire's running direction, or ``None``."""
    pieces = []
    edges = BRepTools_WireExplorer(wire, face)
    while edges.More():
        edge = edges.Current()
        curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
        if curve is None:
            return None
        first, last = BRep_Tool.Range_s(edge, face)
        points = _discretised(curve, first, last, deflection)
        pieces.append(points[::-1] if edge.Orientation() == TopAbs_REVERSED else points)
        edges.Next()
    return pieces or None


def _discretised(curve, first, last, deflection, rounds=16):
    """Points of ``curve`` on ``[first, last]`` whose chords stay within ``deflection``.

    Starting from 33 equally spaced parameters, every chord whose curve midpoint lies
    farther than ``deflection`` from the chord's midpoint is split at that parameter,
    until none does (OCCT's ``GCPnts_QuasiUniformDeflection`` returned a single chord for
    a curved p-curve of linkrods.step, 0.0045 from its midpoint).
    """
    values = pcurve_points(curve)
    params = np.linspace(first, last, 33)
    points = values(params)
    for _ in range(rounds):
        middle = 0.5 * (params[:-1] + params[1:])
        off = np.linalg.norm(values(middle) - 0.5 * (points[:-1] + points[1:]), axis=1)
        split = off > deflection
        if not split.any():
            break
        params = np.sort(np.concatenate([params, middle[split]]))
        points = values(params)
    return points


def _largest_gap(pieces):
    """Largest distance from one piece's end to the next one's start (cyclically)."""
    ends = np.array([piece[-1] for piece in pieces])
    starts = np.array([piece[0] for piece in pieces[1:] + pieces[:1]])
    return float(np.linalg.norm(ends - starts, axis=1).max())
