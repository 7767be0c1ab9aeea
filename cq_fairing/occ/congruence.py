r"""Faces that are one face moved or mirrored: fair one, move the result to the others.

Fairing commutes with isometries :math:`x \mapsto Q x + t` (:math:`Q` orthogonal, a
reflection included): the L2 projections act on the poles linearly and per coordinate,
the knots and weights do not move, and every distance the searches and checks measure is
kept.  So two B-spline faces with the same degrees, knots, weights and UV trim whose
poles satisfy :math:`P'_{ij} = Q P_{ij} + t` get faired nets with the same relation, and
the same deviations.  A part placed several times (one ``TShape``, several locations)
is the case every CAD model has; a mirrored pair (left and right) is the other: the
testtoler shell is 28 of them.

:func:`congruence_classes` groups the faces and gives each one the affine map from its
class's first face.
"""

import numpy as np
from OCP.BRep import BRep_Tool
from OCP.TopAbs import TopAbs_EDGE
from OCP.TopExp import TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS
from OCP.TopTools import TopTools_IndexedMapOfShape
from scipy.spatial import cKDTree

from ..errors import FairingError
from .convert import face_to_surface, is_occt_error

RELATIVE_MATCH = 1e-9  # of the net's (or UV box's) size: poles and trims that coincide
TRIM_SAMPLES = 9  # per pcurve, to compare two faces' trims in UV

__all__ = ["congruence_classes", "compose", "inverse"]


def congruence_classes(faces):
    """Class of each face and the affine map from its class's first face to it.

    Parameters
    ----------
    faces : list of TopoDS_Face

    Returns
    -------
    classes : list of int
        Faces of one class are one face moved rigidly or mirrored: the same ``TShape``
        at another location, or B-spline faces whose unlocated nets and UV trims match
        under an isometry (poles within ``RELATIVE_MATCH`` of the net's size after the
        best orthogonal fit, trims within ``RELATIVE_MATCH`` of the UV box).
    motions : list of ndarray, shape (3, 4)
        ``[A | t]`` taking the class's first face to this one (``det A = -1`` for a
        mirror image).
    """
    shapes = TopTools_IndexedMapOfShape()
    tshape = [shapes.Add(face.Located(TopLoc_Location())) - 1 for face in faces]
    unlocated = [TopoDS.Face_s(shapes.FindKey(k + 1)) for k in range(shapes.Extent())]
    family, to_family = _mirrored_shapes(unlocated)
    classes, motions = [], []
    for face, k in zip(faces, tshape):
        classes.append(family[k])
        motions.append(compose(_affine(face.Location().Transformation()), to_family[k]))
    return classes, motions


def _mirrored_shapes(faces):
    """For each unlocated face, the index of the first face congruent to it and the map
    from that face to it."""
    identity = np.hstack([np.eye(3), np.zeros((3, 1))])
    family, motion = list(range(len(faces))), [identity] * len(faces)
    keys = [_signature(face) for face in faces]
    leaders = {}
    for k, key in enumerate(keys):
        if key is None:
            continue
        for leader in leaders.get(key[0], []):
            found = _isometry(keys[leader][1], key[1])
            if found is not None and _same_trim(keys[leader][2], key[2]):
                family[k], motion[k] = leader, found
                break
        else:
            leaders.setdefault(key[0], []).append(k)
    return family, motion


def _signature(face):
    """``(hashable key, poles (N, 3), UV trim samples)`` of a B-spline face, else None."""
    try:
        surface, _ = face_to_surface(face)
    except Exception as exc:  # not a readable B-spline face: its own class, faired alone
        if isinstance(exc, FairingError) or is_occt_error(exc):
            return None
        raise
    weights = None if surface.weights is None else surface.weights.tobytes()
    key = (surface.poles.shape, surface.u_degree, surface.v_degree,
           surface.u_knots.tobytes(), surface.v_knots.tobytes(), weights)
    return key, surface.poles.reshape(-1, 3), _trim_samples(face)


def _isometry(a, b):
    r"""``[Q | t]`` with :math:`b \approx Q a + t`, :math:`Q` orthogonal (the
    orthogonal Procrustes solution, reflections allowed), if it fits to
    ``RELATIVE_MATCH`` of the net's size; else ``None``."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((b - cb).T @ (a - ca))
    q = u @ vt
    size = max(np.ptp(a, axis=0).max(), 1e-300)
    if np.abs((a - ca) @ q.T - (b - cb)).max() > RELATIVE_MATCH * size:
        return None
    return np.hstack([q, (cb - q @ ca)[:, None]])


def _trim_samples(face):
    """Points of every pcurve of ``face`` in UV (TRIM_SAMPLES each), shape (N, 2)."""
    points = []
    explorer = TopExp_Explorer(face, TopAbs_EDGE)
    while explorer.More():
        edge = TopoDS.Edge_s(explorer.Current())
        curve = BRep_Tool.CurveOnSurface_s(edge, face, 0.0, 0.0)
        if curve is not None:
            first, last = BRep_Tool.Range_s(edge, face)
            for t in np.linspace(first, last, TRIM_SAMPLES):
                p = curve.Value(float(t))
                points.append((p.X(), p.Y()))
        explorer.Next()
    return np.array(points).reshape(-1, 2)


def _same_trim(a, b):
    """True when the trim samples coincide as sets (order and direction free)."""
    if a.shape != b.shape or a.size == 0:
        return a.shape == b.shape
    size = max(np.ptp(a, axis=0).max(), 1e-300)
    limit = RELATIVE_MATCH * size
    return cKDTree(b).query(a)[0].max() <= limit and cKDTree(a).query(b)[0].max() <= limit


def _affine(trsf):
    """The 3 x 4 matrix ``[A | t]`` of a ``gp_Trsf`` (x -> A x + t)."""
    return np.array([[trsf.Value(row, col) for col in range(1, 5)] for row in range(1, 4)])


def compose(outer, inner):
    """``outer`` after ``inner``, both 3 x 4 affine maps ``[A | t]``."""
    return np.hstack([outer[:, :3] @ inner[:, :3],
                      (outer[:, :3] @ inner[:, 3] + outer[:, 3])[:, None]])


def inverse(matrix):
    """The inverse of a 3 x 4 affine map ``[A | t]``."""
    inverted = np.linalg.inv(matrix[:, :3])
    return np.hstack([inverted, (-inverted @ matrix[:, 3])[:, None]])
