r"""Vertices moved to the middle of the curve ends they must cover.

A vertex of tolerance :math:`t` at the point :math:`V` is valid when every curve of
every edge at it ends within :math:`t`: each 3-D curve :math:`C` at the end the vertex
bounds, :math:`|C(t_0) - V| \le t`, and each pcurve :math:`c` on its surface,
:math:`|S(c(t_0)) - V| \le t` (what ``BRepLib::UpdateTolerances`` covers, and
``BRepCheck_Vertex`` for the 3-D curves).  A faired face moves its corners; the edges
finished on it end together again (the joins are closed), but away from the old
:math:`V`.  The smallest tolerance that covers those ends belongs to the centre of
their smallest enclosing ball (:func:`~cq_fairing.core.enclosing.smallest_enclosing_ball`),
not to :math:`V`: :func:`covering_point` gives the better of the two.
"""

import numpy as np
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.gp import gp_Pnt
from OCP.TopAbs import TopAbs_FORWARD, TopAbs_REVERSED
from OCP.TopoDS import TopoDS_Iterator

from ..core.enclosing import smallest_enclosing_ball

__all__ = ["curve_ends", "reach", "covering_point", "move_vertex", "vertex_point", "members"]


def curve_ends(vertex, edges):
    r"""The points every curve of ``edges`` has at ``vertex``, in global coordinates.

    Each edge's curve representations as stored (``BRep_TEdge::Curves``, with the
    edge's and the representation's locations): a 3-D curve at the end the vertex
    bounds (none for a degenerated edge) and each pcurve on its surface there, both
    pcurves of a seam.  An edge that starts and ends at the vertex gives both ends.

    Returns
    -------
    ndarray, shape (k, 3), or None
        ``None`` where the vertex lies inside an edge (``INTERNAL``/``EXTERNAL``) or
        carries parameters of its own (point representations), whose points are not
        curve ends, or where the edges have no curves.
    """
    if vertex.TShape().Points().Size():
        return None
    ends = []
    for edge in edges:
        sides = _sides(vertex, edge)
        if sides is None:
            return None
        for representation in members(edge.TShape().Curves()):
            ends += _representation_ends(representation, edge.Location(), sides)
    return np.array(ends) if ends else None


def members(items):
    """The members of an OCCT list (``NCollection_List``), taken from the front of a
    copy: Python's iteration over OCP's lists costs about 85 us a member, this 1 us."""
    rest, out = type(items)(), []
    rest.Assign(items)
    while rest.Size():
        out.append(rest.First())
        rest.RemoveFirst()
    return out


def _sides(vertex, edge):
    """``(at_first, at_last)``: which ends of ``edge`` the vertex bounds, or ``None``
    for a vertex inside it."""
    first = last = False
    children = TopoDS_Iterator(edge.Oriented(TopAbs_FORWARD))
    while children.More():
        child = children.Value()
        if child.IsSame(vertex):
            if child.Orientation() not in (TopAbs_FORWARD, TopAbs_REVERSED):
                return None
            first |= child.Orientation() == TopAbs_FORWARD
            last |= child.Orientation() == TopAbs_REVERSED
        children.Next()
    return first, last


def _representation_ends(representation, edge_location, sides):
    """The points of one curve representation at the ends in ``sides`` (none for a
    polygon, a regularity or a degenerated edge's empty 3-D curve)."""
    evaluators = _evaluators(representation)
    if not evaluators:
        return []
    placement = edge_location.Multiplied(representation.Location()).Transformation()
    params = [t for t, side in zip((representation.First(), representation.Last()), sides)
              if side]
    return [_xyz(evaluate(t).Transformed(placement)) for evaluate in evaluators for t in params]


def _evaluators(representation):
    """``t -> gp_Pnt`` for each curve of the representation: its 3-D curve, or each of
    its pcurves (two on a seam) on its surface."""
    if representation.IsCurve3D():
        curve = representation.Curve3D()
        return [] if curve is None else [curve.Value]
    if not representation.IsCurveOnSurface():
        return []
    surface = representation.Surface()
    pcurves = [representation.PCurve()]
    if representation.IsCurveOnClosedSurface():
        pcurves.append(representation.PCurve2())
    return [lambda t, pcurve=pcurve: surface.Value(*_uv(pcurve.Value(t))) for pcurve in pcurves]


def _uv(point):
    return point.X(), point.Y()


def _xyz(point):
    return (point.X(), point.Y(), point.Z())


def vertex_point(vertex):
    """The vertex's point in global coordinates, as an array."""
    return np.array(_xyz(BRep_Tool.Pnt_s(vertex)))


def reach(point, ends):
    r""":math:`\max_i |q_i - p|`: the tolerance a vertex at ``point`` needs to cover
    ``ends``."""
    return float(np.linalg.norm(np.asarray(ends) - point, axis=1).max())


def covering_point(point, ends):
    """The better of ``point`` and the centre of the smallest ball enclosing ``ends``:
    ``(centre, radius)`` where the radius is below :func:`reach` from ``point``, else
    ``(point, reach)``."""
    centre, radius = smallest_enclosing_ball(ends)
    own = reach(point, ends)
    return (centre, radius) if radius < own else (np.asarray(point, dtype=float), own)


def move_vertex(vertex, point):
    """Put ``vertex`` at ``point`` (global coordinates; its tolerance is left as is)."""
    BRep_Builder().UpdateVertex(vertex, gp_Pnt(*map(float, point)), 0.0)
