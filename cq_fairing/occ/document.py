"""STEP product structure, names, colours and layers kept through fairing (OCCT's XDE).

A STEP file from a CAD system is more than its geometry: an assembly of products, each
placed once or many times, with names on products and instances, colours on parts and
on single faces, and layers.  :func:`read_step_model` reads all of it into an XDE
document (``STEPCAFControl_Reader`` into a ``TDocStd_Document``) and flattens the
geometry to one shape (``XCAFDoc_ShapeTool::GetOneShape``), the shape every other part
of cq-fairing sees: the same faces, in the same order, as ``STEPControl_Reader`` gives.

The flat shape shares its ``TopoDS_TShape`` objects with the document's labels: a part
placed three times appears three times in the flat shape (three locations) over one
set of faces.  Fairing *in place* (``fair_shape(..., in_place=True)``) puts the new
surfaces into those very faces, so every label of the document (product, instance,
coloured face) sees the faired geometry, and :func:`document_step_bytes` writes the
document back with ``STEPCAFControl_Writer``: the same products, instances, names,
colours and layers, around faired faces.

Validation properties (a product's area, volume and centroid stored in the file) are
not read: written back they would describe the geometry before fairing.
"""

from dataclasses import dataclass, replace

from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
from OCP.IFSelect import IFSelect_ReturnStatus
from OCP.STEPCAFControl import STEPCAFControl_Reader, STEPCAFControl_Writer
from OCP.STEPControl import STEPControl_AsIs
from OCP.TCollection import TCollection_ExtendedString
from OCP.TDataStd import TDataStd_Name
from OCP.TDF import TDF_Label, TDF_LabelSequence
from OCP.TDocStd import TDocStd_Document
from OCP.TNaming import TNaming_Builder
from OCP.TopAbs import TopAbs_FACE
from OCP.TopExp import TopExp, TopExp_Explorer
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS_Shape
from OCP.TopTools import TopTools_IndexedMapOfShape
from OCP.XCAFDoc import XCAFDoc_DocumentTool, XCAFDoc_ShapeTool

from ..errors import FileFormatError, InvalidOutputError

__all__ = ["Model", "read_step_model", "document_step_bytes"]


@dataclass(frozen=True)
class Model:
    """A model read from a file: its flat shape and, for STEP, its XDE document.

    Attributes
    ----------
    shape : TopoDS_Shape
        All the geometry as one shape (a compound when there are several roots).
    document : TDocStd_Document or None
        The STEP file's products, instances, names, colours and layers, sharing their
        faces with ``shape``; ``None`` for IGES and BREP files.
    """

    shape: TopoDS_Shape
    document: TDocStd_Document = None

    def converted(self):
        """The model with every face a B-spline (``BRepBuilderAPI_NurbsConvert``, exact).

        With a document, each part is converted on its own label and its coloured or
        named faces are moved to their converted faces, so the document still describes
        the flat shape.
        """
        if self.document is None:
            return replace(self, shape=BRepBuilderAPI_NurbsConvert(self.shape, True).Shape())
        tool = _shape_tool(self.document)
        for label in _part_labels(tool):
            _convert_part(tool, label)
        tool.UpdateAssemblies()
        return replace(self, shape=tool.GetOneShape())

    def contents(self):
        """What the document carries besides geometry, as counts (empty without one).

        Returns
        -------
        dict
            ``products`` (parts and assemblies), ``instances`` (placements of a product
            in an assembly), ``colours`` and ``layers`` (distinct ones defined).
        """
        if self.document is None:
            return {}
        main = self.document.Main()
        tool = _shape_tool(self.document)
        products = [XCAFDoc_ShapeTool.NbComponents_s(label) for label in _labels(tool.GetShapes)]
        colours = _labels(XCAFDoc_DocumentTool.ColorTool_s(main).GetColors)
        layers = _labels(XCAFDoc_DocumentTool.LayerTool_s(main).GetLayerLabels)
        return {"products": len(products), "instances": sum(products),
                "colours": sum(1 for _ in colours), "layers": sum(1 for _ in layers)}

    def face_parts(self):
        """Where each face sits in the product structure, by name.

        Returns
        -------
        list of str or None
            For each face of ``shape`` (:func:`~cq_fairing.occ.convert.indexed_faces`
            order) the names from the top product down to the placed part, joined by
            ``/`` (``"rotor/blade_1"``: instance names where the file gives them, else
            the product's); ``None`` for every face without a document.
        """
        faces = TopTools_IndexedMapOfShape()
        TopExp.MapShapes_s(self.shape, TopAbs_FACE, faces)
        owners = [None] * faces.Extent()
        if self.document is not None:
            for label in _labels(_shape_tool(self.document).GetFreeShapes):
                _name_faces(label, TopLoc_Location(), [_name(label)], faces, owners)
        return owners


def read_step_model(path):
    """Read a STEP file into an XDE document and its flat shape.

    Returns
    -------
    Model
        ``shape`` is ``None`` (or null) when the file transfers no geometry.

    Raises
    ------
    FileFormatError
        The file is not readable STEP.
    """
    document = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    reader = STEPCAFControl_Reader()
    for set_mode in (reader.SetNameMode, reader.SetColorMode, reader.SetLayerMode):
        set_mode(True)
    reader.SetPropsMode(False)  # area/volume/centroid of the unfaired geometry
    status = reader.ReadFile(str(path))
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise FileFormatError(
            f"'{path}' is not a readable STEP file (reader status {status.name}); "
            "it may be corrupt or truncated."
        )
    reader.Transfer(document)
    return Model(_shape_tool(document).GetOneShape(), document)


def document_step_bytes(document):
    """The STEP file of ``document`` as bytes: products, instances, names, colours, layers.

    Raises
    ------
    InvalidOutputError
        The transfer or the writing failed.
    """
    writer = STEPCAFControl_Writer()
    for set_mode in (writer.SetNameMode, writer.SetColorMode, writer.SetLayerMode):
        set_mode(True)
    writer.SetPropsMode(False)
    if not writer.Transfer(document, STEPControl_AsIs):
        raise InvalidOutputError("STEP transfer of the model's document failed; nothing was "
                                 "written.")
    return written_step(writer)


def written_step(writer):
    """What an OCCT STEP ``writer`` holding its transfer writes, as bytes.

    Raises
    ------
    InvalidOutputError
        The writing failed.
    """
    import io

    stream = io.BytesIO()
    status = writer.WriteStream(stream)
    if status != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise InvalidOutputError(
            f"writing the STEP data failed (status {status.name}); nothing was written.")
    return stream.getvalue()


def _shape_tool(document):
    return XCAFDoc_DocumentTool.ShapeTool_s(document.Main())


def _labels(getter):
    """Yield the labels a ``getter(TDF_LabelSequence)`` fills.

    OCP hands out references into the sequence, not copies: a label kept after the
    sequence is freed points at freed memory.  The generator keeps the sequence alive
    for as long as the iteration runs; use each label inside it.
    """
    labels = TDF_LabelSequence()
    getter(labels)
    for i in range(1, labels.Length() + 1):
        yield labels.Value(i)


def _part_labels(tool):
    """Yield the top-level labels holding geometry (not assemblies: those place parts)."""
    for label in _labels(tool.GetShapes):
        if not XCAFDoc_ShapeTool.IsAssembly_s(label):
            yield label


def _name(label):
    """The label's ``TDataStd_Name``, or ``None``."""
    if not label.IsAttribute(TDataStd_Name.GetID_s()):
        return None
    attribute = TDataStd_Name()
    label.FindAttribute(TDataStd_Name.GetID_s(), attribute)
    return attribute.Get().ToExtString()


def _instance_name(component, part):
    """A component's own name, or its part's when the reader only made one up
    (``"=>[0:1:1:2]"``, a reference to the part's label)."""
    name = _name(component)
    return _name(part) if name is None or name.startswith("=>") else name


def _name_faces(label, location, path, faces, owners):
    """Write ``"/".join(path)`` into ``owners`` for the faces of the part at ``label``
    placed at ``location``; assemblies recurse into their components."""
    if not XCAFDoc_ShapeTool.IsAssembly_s(label):
        placed = XCAFDoc_ShapeTool.GetShape_s(label).Moved(location)
        explorer = TopExp_Explorer(placed, TopAbs_FACE)
        while explorer.More():
            index = faces.FindIndex(explorer.Current())
            if index:
                owners[index - 1] = "/".join(name or "?" for name in path)
            explorer.Next()
        return
    for component in _labels(lambda seq: XCAFDoc_ShapeTool.GetComponents_s(label, seq, False)):
        part = TDF_Label()
        XCAFDoc_ShapeTool.GetReferredShape_s(component, part)
        _name_faces(part, location.Multiplied(XCAFDoc_ShapeTool.GetLocation_s(component)),
                    path + [_instance_name(component, part)], faces, owners)


def _convert_part(tool, label):
    """NURBS-convert one part's shape on its label, its sub-shape labels moved along."""
    part = XCAFDoc_ShapeTool.GetShape_s(label)
    converter = BRepBuilderAPI_NurbsConvert(part, True)
    for sub in _labels(lambda labels: XCAFDoc_ShapeTool.GetSubShapes_s(label, labels)):
        converted = converter.ModifiedShape(XCAFDoc_ShapeTool.GetShape_s(sub))
        # the builder clears the label's shape when it is made: look the shape up first
        TNaming_Builder(sub).Generated(converted)
    tool.SetShape(label, converter.Shape())
