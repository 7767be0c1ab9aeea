"""Congruent faces (cq_fairing.occ.congruence): moved or mirrored copies of one face."""

import numpy as np
import pytest
from OCP.BRep import BRep_Tool
from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_Transform
from OCP.gp import gp_Ax1, gp_Dir, gp_Pnt, gp_Trsf, gp_Vec
from OCP.TopoDS import TopoDS

from cq_fairing.occ import face_to_surface
from cq_fairing.occ.congruence import compose, congruence_classes, inverse
from cq_fairing.occ.convert import indexed_faces


def _poles(face):
    return face_to_surface(face)[0].poles


def _moved(poles, matrix):
    return poles @ matrix[:, :3].T + matrix[:, 3]


def test_the_testtoler_shell_is_28_mirrored_pairs(real):
    faces = indexed_faces(real("testtoler.brep"))
    classes, motions = congruence_classes(faces)
    assert len(set(classes)) == 28
    for c in set(classes):
        first, second = [k for k, value in enumerate(classes) if value == c]
        matrix = compose(motions[second], inverse(motions[first]))
        assert np.linalg.det(matrix[:, :3]) == pytest.approx(-1.0, abs=1e-12)
        a, b = _poles(faces[first]), _poles(faces[second])
        size = np.ptp(a.reshape(-1, 3), axis=0).max()
        np.testing.assert_allclose(_moved(a, matrix), b, atol=1e-9 * size)


def _copy(face, trsf):
    return TopoDS.Face_s(BRepBuilderAPI_Transform(face, trsf, True).Shape())


def test_a_rotated_copy_is_found_with_its_motion(real):
    """A copy made with new geometry (not a new location of the same TShape): the same
    class, and the motion found is the rotation and translation applied."""
    face = indexed_faces(real("testtoler.brep"))[44]
    trsf = gp_Trsf()
    trsf.SetRotation(gp_Ax1(gp_Pnt(1, 2, 3), gp_Dir(1, 1, 0)), 0.7)
    moved = gp_Trsf()
    moved.SetTranslation(gp_Vec(5, -4, 30))
    trsf = moved.Multiplied(trsf)
    copy = _copy(face, trsf)
    classes, motions = congruence_classes([face, copy])
    assert classes[0] == classes[1]
    expected = np.array([[trsf.Value(r, c) for c in range(1, 5)] for r in range(1, 4)])
    np.testing.assert_allclose(compose(motions[1], inverse(motions[0])), expected, atol=1e-9)


def test_another_trim_of_the_same_surface_is_another_class(real):
    face = indexed_faces(real("testtoler.brep"))[44]
    surface = BRep_Tool.Surface_s(face)
    u0, u1, v0, v1 = surface.Bounds()
    whole, again = (BRepBuilderAPI_MakeFace(surface, u0, u1, v0, v1, 1e-7).Face()
                    for _ in range(2))
    part = BRepBuilderAPI_MakeFace(surface, u0, 0.5 * (u0 + u1), v0, v1, 1e-7).Face()
    assert not whole.IsSame(again)  # two faces, one surface and trim: one class
    classes, _ = congruence_classes([whole, part, again])
    assert classes[0] == classes[2] != classes[1]
