"""OCP / CadQuery adapter: faces and shapes in and out of the numerical core.

Everything that touches OCCT lives in this package (OCCT's 1-based arrays, knot
multiplicities, periodic knot vectors, locations, ``IsDone`` checks); the core never
sees it.  ``import cq_fairing`` does not import this package.
"""

from .convert import FaceInfo, face_info, face_to_surface, list_faces, surface_to_face
from .deviation import sample_face_deviation
from .document import Model
from .faces import FaceFairReport, default_tolerance, fair_face
from .io import read_model, read_shape, write_model, write_shape
from .shapes import ShapeFairResult, fair_shape

__all__ = ["read_shape", "write_shape", "read_model", "write_model", "Model", "face_to_surface",
           "surface_to_face", "fair_face", "fair_shape", "list_faces", "face_info", "FaceInfo", "FaceFairReport",
           "ShapeFairResult", "sample_face_deviation", "default_tolerance"]
