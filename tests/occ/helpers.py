"""Independent OCCT measurements used by the OCP layer tests (no cq_fairing code)."""

import numpy as np
from OCP.BRep import BRep_Builder, BRep_Tool
from OCP.BRepAdaptor import BRepAdaptor_Curve, BRepAdaptor_Surface
from OCP.BRepGProp import BRepGProp
from OCP.BRepTools import BRepTools
from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
from OCP.GProp import GProp_GProps
from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_FORWARD, TopAbs_VERTEX
from OCP.TopExp import TopExp
from OCP.TopoDS import TopoDS, TopoDS_Compound, TopoDS_Shape
from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape, TopTools_IndexedMapOfShape


def faces_of(shape):
    return _sub_shapes(shape, TopAbs_FACE, TopoDS.Face_s)


def edges_of(shape):
    return _sub_shapes(shape, TopAbs_EDGE, TopoDS.Edge_s)


def _sub_shapes(shape, kind, cast):
    """The distinct sub-shapes of ``kind`` in ``TopExp`` map order, cast by ``cast``."""
    shapes = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, kind, shapes)
    return [cast(shapes.FindKey(i)) for i in range(1, shapes.Extent() + 1)]


def uv_box_grid(face, nu=7, nv=9):
    """A grid over the face's UV box, clipped to the surface's own bounds."""
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    s0, s1, t0, t1 = BRep_Tool.Surface_s(face).Bounds()
    return np.clip(np.linspace(u0, u1, nu), s0, s1), np.clip(np.linspace(v0, v1, nv), t0, t1)


def occ_points(face, u, v):
    """``BRepAdaptor_Surface`` values on the grid u x v, shape (len(u), len(v), 3)."""
    adaptor = BRepAdaptor_Surface(face)
    out = np.empty((len(u), len(v), 3))
    for i, a in enumerate(u):
        for j, b in enumerate(v):
            p = adaptor.Value(float(a), float(b))
            out[i, j] = (p.X(), p.Y(), p.Z())
    return out


def global_distance(points, face):
    """``GeomAPI_ProjectPointOnSurf`` distance of each point to the face's surface.

    Returns the smallest orthogonal-projection distance, or inf where OCCT finds none.
    """
    surface = BRep_Tool.Surface_s(face)
    s0, s1, t0, t1 = surface.Bounds()
    projector = GeomAPI_ProjectPointOnSurf()
    projector.Init(surface, s0, s1, t0, t1)
    from OCP.gp import gp_Pnt

    out = np.full(len(points), np.inf)
    for k, (x, y, z) in enumerate(points):
        projector.Perform(gp_Pnt(float(x), float(y), float(z)))
        if projector.NbPoints():
            out[k] = projector.LowerDistance()
    return out


def volume(shape):
    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(shape, props)
    return props.Mass()


def area(shape):
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(shape, props)
    return props.Mass()


def compound(*shapes):
    """A ``TopoDS_Compound`` of ``shapes`` (loose faces, no shared edges)."""
    out, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(out)
    for shape in shapes:
        builder.Add(out, shape)
    return out


def three_faces_on_one_edge():
    """Three planar faces sharing one edge (0, 0, 0)-(1, 0, 0), at 0, 2 and 4 radians
    around it: ``(faces, the shared edge)``."""
    import math

    from OCP.BRepBuilderAPI import (
        BRepBuilderAPI_MakeEdge,
        BRepBuilderAPI_MakeFace,
        BRepBuilderAPI_MakeVertex,
        BRepBuilderAPI_MakeWire,
    )
    from OCP.gp import gp_Pnt

    v0, v1 = (BRepBuilderAPI_MakeVertex(gp_Pnt(x, 0, 0)).Vertex() for x in (0.0, 1.0))
    spine = BRepBuilderAPI_MakeEdge(v0, v1).Edge()
    faces = []
    for angle in (0.0, 2.0, 4.0):
        c, s = math.cos(angle), math.sin(angle)
        w2, w3 = (BRepBuilderAPI_MakeVertex(p).Vertex() for p in (gp_Pnt(1, c, s), gp_Pnt(0, c, s)))
        wire = BRepBuilderAPI_MakeWire()
        for edge in (spine, BRepBuilderAPI_MakeEdge(v1, w2).Edge(),
                     BRepBuilderAPI_MakeEdge(w2, w3).Edge(), BRepBuilderAPI_MakeEdge(w3, v0).Edge()):
            wire.Add(edge)
        faces.append(BRepBuilderAPI_MakeFace(wire.Wire(), True).Face())
    return faces, spine


def vertices_of(shape):
    return _sub_shapes(shape, TopAbs_VERTEX, TopoDS.Vertex_s)


def tolerances(shapes):
    """``BRep_Tool::Tolerance`` of each edge or vertex in ``shapes``."""
    return np.array([BRep_Tool.Tolerance_s(s) for s in shapes])


def vertex_reaches(shape):
    """For each vertex of ``shape`` (``vertices_of`` order): the largest distance from
    its point to the end at it of every curve of every edge at it, by OCCT's adaptors:
    ``BRepAdaptor_Curve(edge)`` (the 3-D curve; none for a degenerated edge) and
    ``BRepAdaptor_Curve(edge, face)`` (the pcurve on the face's surface) for each face
    of the edge, with the edge reversed too on a seam (its second pcurve)."""
    faces_at, edges_at = (TopTools_IndexedDataMapOfShapeListOfShape() for _ in range(2))
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, faces_at)
    TopExp.MapShapesAndUniqueAncestors_s(shape, TopAbs_VERTEX, TopAbs_EDGE, edges_at)
    reaches = []
    for vertex in vertices_of(shape):
        ends = []
        for edge in edges_at.FindFromKey(vertex):
            edge = TopoDS.Edge_s(edge.Oriented(TopAbs_FORWARD))
            curves = [] if BRep_Tool.Degenerated_s(edge) else [BRepAdaptor_Curve(edge)]
            for face in faces_at.FindFromKey(edge):
                face = TopoDS.Face_s(face)
                curves.append(BRepAdaptor_Curve(edge, face))
                if BRep_Tool.IsClosed_s(edge, face):
                    curves.append(BRepAdaptor_Curve(TopoDS.Edge_s(edge.Reversed()), face))
            for curve in curves:
                if TopExp.FirstVertex_s(edge).IsSame(vertex):
                    ends.append(curve.Value(curve.FirstParameter()))
                if TopExp.LastVertex_s(edge).IsSame(vertex):
                    ends.append(curve.Value(curve.LastParameter()))
        point = BRep_Tool.Pnt_s(vertex)
        reaches.append(max(point.Distance(end) for end in ends))
    return np.array(reaches)


def brep_round_trip(shape, path):
    """``shape`` written to the BREP text file ``path`` and read back."""
    BRepTools.Write_s(shape, str(path))
    back = TopoDS_Shape()
    BRepTools.Read_s(back, str(path), BRep_Builder())
    return back
