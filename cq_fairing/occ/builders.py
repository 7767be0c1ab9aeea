"""New OCCT shapes from core curves and surfaces (no source face to copy a trim from).

Used by ``cq-fairing points``: an interpolated-and-faired curve becomes an edge, a
surface becomes a face on its natural bounds.
"""

import numpy as np
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace
from OCP.Geom import Geom_BSplineCurve
from OCP.gp import gp_Pnt
from OCP.TColgp import TColgp_Array1OfPnt
from OCP.TColStd import TColStd_Array1OfReal

from ..core.geometry import BSplineCurve
from ..errors import InvalidInputError, InvalidOutputError, NumericalError
from .convert import _distinct, to_geom_surface

__all__ = ["curve_to_edge", "surface_to_natural_face", "face_uv_box", "write_edge"]


def curve_to_edge(curve):
    """A ``TopoDS_Edge`` on a ``Geom_BSplineCurve`` built from a core curve (3-D poles).

    Raises
    ------
    InvalidInputError
        The curve is not a core :class:`~cq_fairing.BSplineCurve` with 3-D poles.
    NumericalError
        OCCT could not build the edge.
    """
    if not isinstance(curve, BSplineCurve) or curve.poles.shape[1] != 3:
        raise InvalidInputError("curve must be a cq_fairing.BSplineCurve with 3-D poles.")
    poles = TColgp_Array1OfPnt(1, curve.n_poles)
    for i, (x, y, z) in enumerate(curve.poles, start=1):
        poles.SetValue(i, gp_Pnt(float(x), float(y), float(z)))
    knots, mults = _distinct(curve.knots)
    if curve.weights is None:
        geom = Geom_BSplineCurve(poles, knots, mults, curve.degree, False)
    else:
        weights = TColStd_Array1OfReal(1, curve.n_poles)
        for i, w in enumerate(np.asarray(curve.weights, dtype=float), start=1):
            weights.SetValue(i, float(w))
        geom = Geom_BSplineCurve(poles, weights, knots, mults, curve.degree, False)
    maker = BRepBuilderAPI_MakeEdge(geom)
    if not maker.IsDone():
        raise NumericalError("OCCT could not build an edge on the faired curve.")
    return maker.Edge()


def surface_to_natural_face(surface):
    """A ``TopoDS_Face`` on the whole parameter domain of a core surface."""
    maker = BRepBuilderAPI_MakeFace(to_geom_surface(surface), 1e-7)
    if not maker.IsDone():
        raise NumericalError("OCCT could not build a face on the faired surface.")
    return maker.Face()


def face_uv_box(face):
    """``((u0, u1), (v0, v1))``: the parameter box of a (possibly trimmed) face."""
    from OCP.BRepTools import BRepTools

    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    return (u0, u1), (v0, v1)


def write_edge(edge, path, *, force=False, input_path=None):
    """Write a curve-only model (one edge) to STEP or BREP, atomically, and read it back.

    :func:`~cq_fairing.occ.write_shape` validates models by their faces; a faired point
    curve has none, so this writer checks the edge count of the read-back instead.

    Raises
    ------
    OutputPathError
        See :func:`cq_fairing.report.check_output_path`.
    InvalidOutputError
        OCCT could not write the edge, or the written file does not read back with one
        edge (nothing is written).
    """
    from OCP.BRep import BRep_Builder
    from OCP.BRepTools import BRepTools
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader, STEPControl_Writer
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS_Shape

    from ..report import atomic_output, check_output_path
    from .io import quiet_occt

    check_output_path(path, force=force, inputs=() if input_path is None else (input_path,))
    step = str(path).lower().endswith((".step", ".stp"))
    with atomic_output(path, force=force) as tmp, quiet_occt():
        if step:
            writer = STEPControl_Writer()
            writer.Transfer(edge, STEPControl_AsIs)
            if writer.Write(str(tmp)) != IFSelect_RetDone:
                raise InvalidOutputError(f"OCCT could not write {path}; nothing was written.")
            reader = STEPControl_Reader()
            reader.ReadFile(str(tmp))
            reader.TransferRoots()
            back = reader.OneShape()
        else:
            BRepTools.Write_s(edge, str(tmp))
            back = TopoDS_Shape()
            BRepTools.Read_s(back, str(tmp), BRep_Builder())
        explorer, edges = TopExp_Explorer(back, TopAbs_EDGE), 0
        while explorer.More():
            edges += 1
            explorer.Next()
        if edges < 1:
            raise InvalidOutputError(
                f"{path} did not read back with the faired curve; nothing was written.")
    return path
