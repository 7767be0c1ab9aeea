"""The CadQuery plugin on real models: Workplane.fair, fair_face, fair_shape."""

import cadquery as cq
import numpy as np
import pytest

from cq_fairing.cadquery_plugin import fair_face, fair_shape, register
from cq_fairing.errors import InvalidInputError
from tests.conftest import data_path
from tests.occ.helpers import volume


@pytest.fixture(scope="module")
def linkrods():
    return cq.importers.importStep(str(data_path("linkrods.step")))


def test_workplane_fair_on_selected_bspline_faces_rebuilds_the_solid(linkrods):
    register()
    selected = linkrods.faces("%BSPLINE")
    assert selected.size() == 18
    out = selected.fair(tol=5e-3, joins="free")   # held, its joins keep every face
    assert isinstance(out, cq.Workplane) and out is not selected
    solid = out.val()
    assert isinstance(solid, cq.Solid) and solid.isValid()
    assert len(solid.Faces()) == 37
    assert solid.Volume() == pytest.approx(linkrods.val().Volume(), rel=5e-3)
    report, = out.fair_report
    assert report.valid and sum(r.faired for r in report.faces) >= 12
    # the input Workplane is untouched
    assert linkrods.val().isValid() and len(linkrods.val().Faces()) == 37


def test_workplane_fair_whole_solid_and_free_faces():
    register()
    blade = cq.importers.importStep(str(data_path("IEA_15MW_CFD.stp")))
    faces = blade.faces()
    out = faces.fair(tol=0.01)
    assert out.size() == 3
    assert all(isinstance(f, cq.Face) and f.isValid() for f in out.vals())
    assert [r.status for r in out.fair_report].count("faired") == 2


def test_fair_face_and_fair_shape_return_cadquery_objects(linkrods):
    shape = linkrods.val()
    bspline = [f for f in shape.Faces() if f.geomType() == "BSPLINE"]
    out, result = fair_shape(shape, tol=5e-3, faces=bspline[:4], return_report=True)
    assert isinstance(out, cq.Solid) and out.isValid()
    assert volume(out.wrapped) == pytest.approx(volume(shape.wrapped), rel=5e-3)
    assert sum(r.status == "skipped-not-selected" for r in result.faces) == 33
    face, report = fair_face(bspline[3], tol=5e-3, return_report=True)
    assert isinstance(face, cq.Face) and face.isValid()
    assert report.max_deviation <= 5e-3
    planar = [f for f in shape.Faces() if f.geomType() == "PLANE"][0]
    assert fair_face(planar) is planar
    with pytest.raises(InvalidInputError):
        fair_face(shape)
    with pytest.raises(InvalidInputError):
        fair_shape("solid")


def test_workplane_fair_passes_method_objective_and_workers():
    """Faithful and compact give different nets on the noisy blade: the options arrive."""
    from cq_fairing.core.examples import blade_surface
    from cq_fairing.occ.builders import surface_to_natural_face

    register()
    face = cq.Face(surface_to_natural_face(blade_surface(shape=(20, 30)).surface))
    options = dict(tol=0.1, method="adaptive", objective="faithful")
    free = cq.Workplane().add(face).fair(**options)
    report, = free.fair_report
    assert report.status == "faired"
    whole = cq.Workplane().add(cq.Compound.makeCompound([face])).fair(
        **options, jobs=2, face_timeout=120)
    result, = whole.fair_report
    assert result.faces[0].poles_after == report.poles_after
    compact = fair_face(face, tol=0.1, method="adaptive", return_report=True)[1]
    assert compact.poles_after != report.poles_after
    with pytest.raises(InvalidInputError, match="face_timeout"):
        cq.Workplane().add(face).fair(**options, face_timeout=120)


def test_workplane_fair_with_energy_keeps_the_net():
    """method='energy' arrives through Workplane.fair: the noisy blade keeps its 20 x 30
    net, each pole moved by at most tol."""
    import numpy as np

    from cq_fairing.core.examples import blade_surface
    from cq_fairing.occ import face_to_surface
    from cq_fairing.occ.builders import surface_to_natural_face

    register()
    face = cq.Face(surface_to_natural_face(blade_surface(shape=(20, 30)).surface))
    out = cq.Workplane().add(face).fair(tol=0.05, method="energy")
    report, = out.fair_report
    assert report.status == "faired"
    assert report.poles_before == report.poles_after == (22, 32)
    moved = face_to_surface(out.val().wrapped)[0].poles - face_to_surface(face.wrapped)[0].poles
    assert 0 < np.linalg.norm(moved, axis=-1).max() <= 0.05 * (1 + 1e-12)


def test_face_selections_that_are_not_lists_of_indices_are_refused(linkrods):
    shape = linkrods.val()
    for faces, fragment in ((0, "list of face indices"), ([1.5], "integer face indices"),
                            ([True], "integer face indices")):
        with pytest.raises(InvalidInputError, match=fragment):
            fair_shape(shape, tol=5e-3, faces=faces)


@pytest.mark.parametrize("select, held", [
    (lambda part: part.edges(), "12 Edge objects with no face;"),
    (lambda part: part.vertices(">Z"), "4 Vertex objects with no face;"),
    (lambda part: part.wires(">Z"), "1 Wire object with no face;"),
    (lambda part: cq.Workplane().add(cq.Compound.makeCompound(part.edges().vals())),
     "1 Compound object with no face;"),
])
def test_workplane_fair_refuses_objects_without_faces(select, held):
    """Edges and vertices on the stack came back as they were, with empty reports, as if
    faired; now the refusal names them, what fair takes and what to select instead."""
    register()
    with pytest.raises(InvalidInputError) as info:
        select(cq.Workplane().box(1, 1, 1)).fair(tol=0.01)
    message = str(info.value)
    assert type(info.value) is InvalidInputError
    assert message.startswith("Workplane.fair fairs faces and the shells, solids and "
                              "compounds that hold them, but the stack holds " + held)
    assert message.endswith("select faces with .faces(...) or a solid with .solids() (or fair "
                            "the part itself), then call .fair().")


def test_workplane_fair_refuses_a_stack_mixing_faces_and_edges_whole(linkrods):
    register()
    mixed = linkrods.faces("%BSPLINE").add(linkrods.edges("%LINE"))
    with pytest.raises(InvalidInputError) as info:
        mixed.fair(tol=5e-3)
    edges = len(linkrods.edges("%LINE").vals())
    assert edges > 1
    assert f"holds {edges} Edge objects with no face (and 18 objects with faces: a mixed " \
           "stack is refused whole);" in str(info.value)


def _noisy_face():
    from tests.reliability.test_occ_inputs import bspline_surface, face_of

    return cq.Face(face_of(bspline_surface(16, 14, wiggle=0.01, seed=0)))


def test_the_old_search_value_warns_at_the_plugin_callers_line():
    """``search="core"`` through the plugin: the warning points here, not into the
    plugin (Python shows a DeprecationWarning by default only where it is attributed to
    the caller's code), and the result is the new spelling's."""
    register()
    face = _noisy_face()
    _, new = fair_face(face, tol=0.01, search="guaranteed", return_report=True)
    with pytest.warns(DeprecationWarning) as caught:
        _, old = fair_face(face, tol=0.01, search="core", return_report=True)
    with pytest.warns(DeprecationWarning) as caught_wp:
        wp = cq.Workplane().add(face).fair(tol=0.01, search="core")
    for record in (*caught, *caught_wp):
        assert record.filename == __file__ and "use search='guaranteed'" in str(record.message)
    assert len(caught) == len(caught_wp) == 1
    assert new.status == "faired" and np.prod(new.poles_after) < np.prod(new.poles_before)
    for report in (old, wp.fair_report[0]):
        np.testing.assert_array_equal(report.surface.poles, new.surface.poles)


def test_an_option_the_method_does_not_use_is_refused_through_the_plugin():
    register()
    with pytest.raises(InvalidInputError, match="target_degree=2 applies to method="):
        cq.Workplane().add(_noisy_face()).fair(tol=0.01, method="energy", target_degree=2)
