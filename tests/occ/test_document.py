"""STEP assemblies through fairing: products, instances, names, colours and layers kept.

The input is a real STEP assembly written by OCCT's own XDE writer: a product "rotor"
placing one freeform part "blade" three times (instances "blade_0".."blade_2"), the
part red, one of its B-spline faces green and on layer "SKIN".  The output is read
back here with OCCT's XDE reader directly (no cq_fairing code) and compared.
"""

import json
import re

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.gp import gp, gp_Pnt, gp_Trsf, gp_Vec
from OCP.Quantity import Quantity_Color, Quantity_TOC_RGB
from OCP.STEPCAFControl import STEPCAFControl_Reader, STEPCAFControl_Writer
from OCP.STEPControl import STEPControl_AsIs, STEPControl_Reader
from OCP.TCollection import TCollection_ExtendedString
from OCP.TDataStd import TDataStd_Name
from OCP.TDF import TDF_LabelSequence
from OCP.TDocStd import TDocStd_Document
from OCP.TopLoc import TopLoc_Location
from OCP.TopoDS import TopoDS
from OCP.XCAFDoc import (
    XCAFDoc_ColorTool,
    XCAFDoc_ColorType,
    XCAFDoc_DocumentTool,
    XCAFDoc_ShapeTool,
)

from cq_fairing.cli import main
from cq_fairing.errors import InvalidInputError
from cq_fairing.occ import fair_shape, read_shape
from cq_fairing.occ.io import read_model, write_model
from tests.conftest import data_path
from tests.occ.helpers import area, faces_of

RED, GREEN = (0.8, 0.1, 0.1), (0.1, 0.8, 0.1)
SHIFT = 30.0  # y offset between the instances


def _blade():
    """A lofted solid between two wavy profiles: two of its faces are B-splines."""
    import cadquery as cq

    def profile(z, ys, back):
        points = list(zip(np.linspace(0, 40, len(ys)), ys))
        return (cq.Workplane("XY").workplane(offset=z).spline(points)
                .lineTo(40, back).lineTo(0, back).close().wires().val())

    return cq.Solid.makeLoft([profile(0, [0, 1.3, -0.7, 0.4, 0, 0.6, -0.2, 0], -10),
                              profile(15, [0.5, -1.1, 1.2, -0.3, 0.2, -0.5, 0.3, 0.1], -12)]).wrapped


def _bspline_face(shape):
    return next(f for f in faces_of(shape)
                if BRep_Tool.Surface_s(f).DynamicType().Name() == "Geom_BSplineSurface"
                and BRep_Tool.Surface_s(f).NbUPoles() > 4)


def _name(label, text):
    TDataStd_Name.Set_s(label, TCollection_ExtendedString(text))


def _placement(shift, degrees):
    """A turn about z by ``degrees``, then a shift along y."""
    move, turn = gp_Trsf(), gp_Trsf()
    move.SetTranslation(gp_Vec(0, shift, 0))
    turn.SetRotation(gp.OZ_s(), np.radians(degrees))
    move.Multiply(turn)
    return move


def _write_step(document, path):
    writer = STEPCAFControl_Writer()
    writer.SetNameMode(True)
    writer.SetColorMode(True)
    writer.SetLayerMode(True)
    writer.Transfer(document, STEPControl_AsIs)
    writer.Write(str(path))
    return path


@pytest.fixture(scope="module")
def rotor_step(tmp_path_factory):
    """The rotor assembly as a STEP file."""
    document = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    main_label = document.Main()
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(main_label)
    colours = XCAFDoc_DocumentTool.ColorTool_s(main_label)
    layers = XCAFDoc_DocumentTool.LayerTool_s(main_label)
    blade = _blade()
    rotor = shapes.NewShape()
    _name(rotor, "rotor")
    part = shapes.AddShape(blade, False)
    _name(part, "blade")
    colours.SetColor(part, Quantity_Color(*RED, Quantity_TOC_RGB), XCAFDoc_ColorType.XCAFDoc_ColorSurf)
    skin = shapes.AddSubShape(part, _bspline_face(blade))
    colours.SetColor(skin, Quantity_Color(*GREEN, Quantity_TOC_RGB), XCAFDoc_ColorType.XCAFDoc_ColorSurf)
    layers.SetLayer(skin, TCollection_ExtendedString("SKIN"))
    for i in range(3):  # placements turned by 0, 60 and 120 degrees about z, and shifted
        placement = TopLoc_Location(_placement(SHIFT * i, 60.0 * i))
        _name(shapes.AddComponent(rotor, part, placement), f"blade_{i}")
    shapes.UpdateAssemblies()
    return _write_step(document, tmp_path_factory.mktemp("rotor") / "rotor.step")


NESTED = {"machine/stage_0/blade_0": [(0, 0)], "machine/stage_0/blade_1": [(SHIFT, 45)],
          "machine/stage_1/blade_0": [(0, 90), (0, 0)],
          "machine/stage_1/blade_1": [(0, 90), (SHIFT, 45)]}  # placements, outermost first


@pytest.fixture(scope="module")
def machine_step(tmp_path_factory):
    """Two stages ("machine" places the assembly "rotor" twice, turned by 90 degrees),
    each placing the part "blade" twice: four placements, two levels deep."""
    document = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    shapes = XCAFDoc_DocumentTool.ShapeTool_s(document.Main())
    part = shapes.AddShape(_blade(), False)
    _name(part, "blade")
    rotor, machine = shapes.NewShape(), shapes.NewShape()
    _name(rotor, "rotor")
    _name(machine, "machine")
    for i in range(2):
        placement = TopLoc_Location(_placement(SHIFT * i, 45.0 * i))
        _name(shapes.AddComponent(rotor, part, placement), f"blade_{i}")
        _name(shapes.AddComponent(machine, rotor, TopLoc_Location(_placement(0, 90.0 * i))),
              f"stage_{i}")
    shapes.UpdateAssemblies()
    return _write_step(document, tmp_path_factory.mktemp("machine") / "machine.step")


class _ReadBack:
    """An XDE document read with OCCT's reader, and what the tests ask of it."""

    def __init__(self, path):
        self.document = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
        reader = STEPCAFControl_Reader()
        for set_mode in (reader.SetNameMode, reader.SetColorMode, reader.SetLayerMode):
            set_mode(True)
        reader.ReadFile(str(path))
        reader.Transfer(self.document)
        main_label = self.document.Main()
        self.shapes = XCAFDoc_DocumentTool.ShapeTool_s(main_label)
        self.colours = XCAFDoc_DocumentTool.ColorTool_s(main_label)
        self.layers = XCAFDoc_DocumentTool.LayerTool_s(main_label)

    @staticmethod
    def labels(getter, *args):
        """The labels ``getter(*args, sequence)`` fills, and the sequence: OCP returns
        references into it, so the caller keeps it alive while using the labels."""
        sequence = TDF_LabelSequence()
        getter(*args, sequence)
        return [sequence.Value(i) for i in range(1, sequence.Length() + 1)], sequence

    def part(self):
        """The one top-level label that is not an assembly, and its sequence."""
        labels, sequence = self.labels(self.shapes.GetShapes)
        parts = [label for label in labels if not XCAFDoc_ShapeTool.IsAssembly_s(label)]
        assert len(parts) == 1
        return parts[0], sequence

    def colour(self, label):
        colour = Quantity_Color()
        if not XCAFDoc_ColorTool.GetColor_s(label, XCAFDoc_ColorType.XCAFDoc_ColorSurf, colour):
            return None
        return np.array([colour.Red(), colour.Green(), colour.Blue()])

    def layer_names(self, label):
        names = self.layers.GetLayers(label)
        return [names.Value(i).ToExtString() for i in range(1, names.Length() + 1)]


def _poles(face):
    surface = BRep_Tool.Surface_s(face)
    return np.array([[(p.X(), p.Y(), p.Z()) for p in row] for row in
                     [[surface.Pole(i, j) for j in range(1, surface.NbVPoles() + 1)]
                      for i in range(1, surface.NbUPoles() + 1)]])


def _face_pole_counts(shape):
    return [(BRep_Tool.Surface_s(f).NbUPoles(), BRep_Tool.Surface_s(f).NbVPoles())
            if BRep_Tool.Surface_s(f).DynamicType().Name() == "Geom_BSplineSurface" else None
            for f in faces_of(shape)]


@pytest.mark.parametrize("name", ["IEA_15MW_CFD.stp", "linkrods.step"])
def test_read_model_gives_the_plain_readers_faces_in_its_order(name, rotor_step):
    for path in (data_path(name), rotor_step):
        plain = STEPControl_Reader()
        plain.ReadFile(str(path))
        plain.TransferRoots()
        expected = [area(f) for f in faces_of(plain.OneShape())]
        got = [area(f) for f in faces_of(read_model(path).shape)]
        assert got == pytest.approx(expected, rel=1e-12, abs=1e-12)


def _step_names(text):
    """Product names, and instance names with the product definition each places, read
    from the STEP text itself."""
    products = re.findall(r"PRODUCT\('([^']*)'", text)
    instances = re.findall(r"NEXT_ASSEMBLY_USAGE_OCCURRENCE\('[^']*','([^']*)','[^']*',#\d+,(#\d+)", text)
    return sorted(products), sorted(instances)


def test_fairing_a_step_assembly_keeps_products_instances_names_colours_layers(rotor_step, tmp_path):
    out, report = tmp_path / "faired.step", tmp_path / "report.json"
    assert main(["fair", str(rotor_step), "-o", str(out), "--tol", "0.05",
                 "--report", str(report)]) == 0
    products, instances = _step_names(out.read_text())
    assert products == ["blade", "rotor"]
    assert [name for name, _ in instances] == ["blade_0", "blade_1", "blade_2"]
    assert len({placed for _, placed in instances}) == 1  # one part, placed three times
    assert out.read_text().count("B_SPLINE_SURFACE_WITH_KNOTS") == 3  # its faces written once
    written = json.loads(report.read_text())
    assert written["kept"] == {"products": 2, "instances": 3, "colours": 2, "layers": 1}
    parts = [face["part"] for face in written["faces"]]
    assert parts == read_model(rotor_step).face_parts()
    assert sorted(set(parts)) == ["rotor/blade_0", "rotor/blade_1", "rotor/blade_2"]


def test_the_coloured_face_is_the_faired_one_and_keeps_colour_and_layer(rotor_step, tmp_path):
    """Each border of the skin meets a plane or a flat strip: with its joins held it is kept
    as it is (the next test), so it is faired alone here."""
    out = tmp_path / "faired.step"
    assert main(["fair", str(rotor_step), "-o", str(out), "--tol", "0.05",
                 "--joins", "free"]) == 0
    source_skin = _bspline_face(read_shape(rotor_step))
    back = _ReadBack(out)
    part, _alive = back.part()
    assert np.allclose(back.colour(part), RED, atol=1e-6)
    subs, _alive_too = back.labels(XCAFDoc_ShapeTool.GetSubShapes_s, part)
    assert len(subs) == 1
    sub = subs[0]
    assert np.allclose(back.colour(sub), GREEN, atol=1e-6)
    assert back.layer_names(sub) == ["SKIN"]
    skin = TopoDS.Face_s(XCAFDoc_ShapeTool.GetShape_s(sub))
    source_poles, faired_poles = _poles(source_skin), _poles(skin)
    assert faired_poles.shape[0] < source_poles.shape[0]  # the coloured face was faired
    assert area(skin) == pytest.approx(area(source_skin), rel=1e-3)


def test_a_skin_whose_every_border_is_held_is_kept_with_its_reason(rotor_step):
    result = fair_shape(read_shape(rotor_step), tol=0.05)
    skins = [r for r in result.faces if r.poles_before and r.poles_before[0] == 16]
    assert len(skins) == 3
    assert all(r.status == "unchanged" and "held where the source has them" in r.message
               for r in skins)
    assert result.joins.summary()["max_gap_opened"] <= 1e-12


def test_the_document_gets_the_same_surfaces_as_a_plain_fair(rotor_step, tmp_path):
    """Fairing in place on the document = fairing a copy of the plain shape, face by face."""
    out = tmp_path / "faired.step"
    assert main(["fair", str(rotor_step), "-o", str(out), "--tol", "0.05"]) == 0
    plain = fair_shape(read_shape(rotor_step), tol=0.05).shape
    written = read_shape(out)
    assert _face_pole_counts(written) == _face_pole_counts(plain)
    for a, b in zip(faces_of(written), faces_of(plain)):
        if _face_pole_counts(a)[0] is not None:
            assert np.allclose(_poles(a), _poles(b), atol=1e-9)


def test_convert_keeps_the_document_and_leaves_only_bspline_faces(rotor_step, tmp_path):
    out = tmp_path / "converted.step"
    assert main(["fair", str(rotor_step), "-o", str(out), "--tol", "0.05", "--convert"]) == 0
    assert all(count is not None for count in _face_pole_counts(read_shape(out)))
    products, instances = _step_names(out.read_text())
    assert products == ["blade", "rotor"] and len(instances) == 3
    back = _ReadBack(out)
    part, _alive = back.part()
    subs, _alive_too = back.labels(XCAFDoc_ShapeTool.GetSubShapes_s, part)
    assert np.allclose(back.colour(subs[0]), GREEN, atol=1e-6)
    assert back.layer_names(subs[0]) == ["SKIN"]


def test_in_place_returns_the_input_and_reports_keep_the_original_faces(rotor_step):
    shape = read_shape(rotor_step)
    before = _face_pole_counts(shape)
    source_poles = [_poles(f) if c else None for f, c in zip(faces_of(shape), before)]
    result = fair_shape(shape, tol=0.05, in_place=True, joins="free")  # the skin is faired
    assert result.shape.IsSame(shape) and result.valid
    after = _face_pole_counts(shape)
    faired = [r for r in result.faces if r.faired]
    assert faired and all(after[r.index] != before[r.index] for r in faired
                          if r.poles_after != r.poles_before)
    for r in faired:
        assert np.array_equal(_poles(r.original), source_poles[r.index])
        assert r.face.IsSame(faces_of(shape)[r.index])
    with pytest.raises(InvalidInputError, match="convert"):
        fair_shape(shape, tol=0.05, in_place=True, convert=True)


def test_write_model_honours_the_unit_with_a_document(rotor_step, tmp_path):
    model = read_model(rotor_step)
    write_model(model, tmp_path / "inch.step", unit="INCH")
    text = (tmp_path / "inch.step").read_text()
    assert "INCH" in text
    expected = [area(f) for f in faces_of(model.shape)]
    assert [area(f) for f in faces_of(read_shape(tmp_path / "inch.step"))] == pytest.approx(
        expected, rel=1e-9)


def test_brep_output_of_a_step_assembly_is_geometry_only(rotor_step, tmp_path):
    out, report = tmp_path / "faired.brep", tmp_path / "report.json"
    assert main(["fair", str(rotor_step), "-o", str(out), "--tol", "0.05",
                 "--report", str(report)]) == 0
    assert json.loads(report.read_text())["kept"] is None
    assert len(faces_of(read_shape(out))) == 18


def test_a_part_placed_three_times_is_faired_once_and_moved_to_each_placement(rotor_step):
    """Each placement (turned and shifted) gets the surface that fairing its face on its
    own gives (not polished: in the part it meets other faces), and the deviation
    samples of that fit."""
    from cq_fairing.occ import fair_face

    shape = read_shape(rotor_step)
    result = fair_shape(shape, tol=0.05, joins="free")  # reuse is face by face
    faired = [r for r in result.faces if r.faired]
    placed = [r for r in faired if "another placement" in r.message]
    assert len(placed) == 2 * (len(faired) // 3) and all(r.seconds == 0.0 for r in placed)
    for r in placed:
        alone = fair_face(faces_of(shape)[r.index], tol=0.05, objective="compact")
        assert alone.surface.poles.shape == r.surface.poles.shape
        assert np.allclose(alone.surface.poles, r.surface.poles, atol=1e-9)
        assert r.max_deviation == pytest.approx(alone.max_deviation, rel=1e-6)
        assert np.allclose(_poles(r.face), r.surface.poles, atol=1e-12)
        for key in ("points", "faired_points", "normals", "distance"):
            assert np.allclose(r.deviation[key], alone.deviation[key], atol=1e-9)


def _centre(faces):
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    for face in faces:
        BRepGProp.SurfaceProperties_s(face, props)
    centre = props.CentreOfMass()
    return np.array([centre.X(), centre.Y(), centre.Z()])


def test_face_parts_name_each_placement_of_a_nested_assembly(machine_step):
    """Each face is named by its placement path, and the faces named so sit where that
    chain of placements puts the part."""
    model = read_model(machine_step)
    owners = model.face_parts()
    faces = faces_of(model.shape)
    assert sorted(set(owners)) == sorted(NESTED)
    blade_centre = _centre(faces_of(_blade()))
    for path, chain in NESTED.items():
        mine = [f for f, owner in zip(faces, owners) if owner == path]
        assert len(mine) == len(faces_of(_blade()))
        expected = gp_Trsf()
        for shift, degrees in chain:
            expected.Multiply(_placement(shift, degrees))
        point = gp_Pnt(*blade_centre).Transformed(expected)
        assert np.allclose(_centre(mine), [point.X(), point.Y(), point.Z()], atol=1e-6)
    assert read_model(data_path("testtoler.brep")).face_parts() == [None] * 56


def test_the_terminal_table_names_the_placement_of_each_face(machine_step, tmp_path, capsys):
    assert main(["fair", str(machine_step), "-o", str(tmp_path / "out.step"), "--tol", "0.05"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[-2:] == ["status", "part"]
    assert lines[-1].startswith("joins: ")
    rows = [line.split() for line in lines[2:-2]]
    assert [row[-1] for row in rows] == read_model(machine_step).face_parts()


def test_inspect_names_the_placement_of_each_face(machine_step, capsys):
    assert main(["inspect", str(machine_step)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "model: 3 products, 4 instances, 0 colours, 0 layers"
    assert lines[1].split()[-1] == "part"
    rows = [line.split() for line in lines[2:-1]]
    assert [row[-1] for row in rows] == read_model(machine_step).face_parts()
