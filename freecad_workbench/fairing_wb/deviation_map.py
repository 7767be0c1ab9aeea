"""Deviation and curvature maps: coloured analysis meshes (App level, no GUI import).

A map is a ``Mesh::FeaturePython`` sampled on the faired (or source) faces of a Fairing
feature.  Its proxy :class:`AnalysisMap` stores one value per mesh vertex
(``Values``) and one colour per vertex (``VertexColors``, an ``App::PropertyColorList``
that FreeCAD's mesh view provider uses when ``Coloring`` is on).  Maps never touch the
faired model: they only read it.
"""

import FreeCAD
import Mesh
import numpy as np

import cq_fairing as cf

from . import analysis, conversion, feature, preferences

__all__ = ["AnalysisMap", "make_map", "KINDS", "ramp", "find_maps", "covered",
           "maps_on"]

KINDS = ("Deviation", "MeanCurvature", "GaussianCurvature")
WHICH = ("Faired", "Source")
TYPE = "Fairing::AnalysisMap"

PROPERTIES = (
    ("App::PropertyLink", "Fairing", "Map", "The Fairing feature analysed"),
    ("App::PropertyEnumeration", "Kind", "Map", "Deviation, MeanCurvature or GaussianCurvature"),
    ("App::PropertyEnumeration", "Which", "Map", "Curvature of the Faired or the Source faces"),
    ("App::PropertyInteger", "Samples", "Map", "Samples per direction and face"),
    ("App::PropertyVector", "Offset", "Map", "Shift of the map (side-by-side comparison)"),
    ("App::PropertyFloat", "RangeMin", "Map", "Lower end of the colour ramp (auto if equal)"),
    ("App::PropertyFloat", "RangeMax", "Map", "Upper end of the colour ramp (auto if equal)"),
    ("App::PropertyFloatList", "Values", "Result", "One value per mesh vertex"),
    ("App::PropertyColorList", "VertexColors", "Result", "One colour per mesh vertex"),
    ("App::PropertyFloat", "Minimum", "Result", "Smallest value"),
    ("App::PropertyFloat", "Maximum", "Result", "Largest value"),
    ("App::PropertyString", "Unit", "Result", "Unit of the values"),
)
UNITS = {"Deviation": "mm", "MeanCurvature": "1/mm", "GaussianCurvature": "1/mm^2"}


def ramp(values, low, high, colors=None):
    """Colours interpolated from ``colors[0]`` (at ``low``) to ``colors[1]`` (at ``high``).

    Returns a list of float RGB tuples (FreeCAD needs floats).
    """
    c0, c1 = np.array(colors or preferences.colors())
    span = high - low if high > low else 1.0
    t = np.clip((np.asarray(values, dtype=float) - low) / span, 0.0, 1.0)[:, None]
    return [tuple(map(float, c)) for c in (1 - t) * c0 + t * c1]


def _grid_mesh(points, values, inside=None):
    """Triangles of a (n, n, 3) sample grid; returns (Mesh.Mesh, per-vertex values).

    With ``inside`` (n, n booleans: the sample lies on the trimmed face) only triangles
    whose three vertices are inside are kept, and only the vertices they use (values
    renumbered with them), so the map covers the face's trim, not its parameter box.
    """
    n_u, n_v = points.shape[:2]
    index = np.arange(n_u * n_v).reshape(n_u, n_v)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    triangles = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]])
    points, values = points.reshape(-1, 3), values.ravel()
    if inside is not None:
        triangles = triangles[inside.ravel()[triangles].all(axis=1)]
        used, triangles = np.unique(triangles, return_inverse=True)
        triangles = triangles.reshape(-1, 3)
        points, values = points[used], values[used]
    vertices = [FreeCAD.Vector(*p) for p in points.tolist()]
    # (Vectors, index tuples) keeps the vertex order; plain float tuples crash 0.20.2.
    mesh = Mesh.Mesh((vertices, [tuple(t) for t in triangles.tolist()]))
    return mesh, values


def _face_samples(obj, source_face, faired_face, count):
    """(points, values, inside) of one face pair for the map's Kind/Which; ``inside``
    marks the samples on the source face's trim (same parameters on both faces) where
    the value is defined (curvature is not at a singular point)."""
    source = conversion.surface_from_face(source_face)
    faired = conversion.surface_from_face(faired_face)
    uv_range = conversion.uv_range(source_face, source)
    inside = conversion.FaceDomain(source_face).inside(
        *analysis.sample_parameters(uv_range, count))
    if obj.Kind == "Deviation":
        return (*analysis.two_sided_deviation(source, faired, uv_range, count), inside)
    surface = faired if obj.Which == "Faired" else source
    kind = "gaussian" if obj.Kind == "GaussianCurvature" else "mean"
    points, values = analysis.curvature(surface, uv_range, count, kind)
    defined = np.isfinite(values)
    return points, np.where(defined, values, 0.0), inside & defined


def _pairs(source_faces, faired_faces):
    """Match each faired face to its source face (nearest bounding-box centre).

    Sewing may reorder the faces of a multi-face Fairing; a faired face stays within the
    tolerance of its source, so the nearest centre identifies it.
    """
    left = list(source_faces)
    for faired in faired_faces:
        centre = faired.BoundBox.Center
        best = min(left, key=lambda f: (f.BoundBox.Center - centre).Length)
        left.remove(best)
        yield best, faired


class AnalysisMap:
    """Proxy of a deviation / curvature map."""

    Type = TYPE

    def __init__(self, obj):
        obj.Proxy = self
        self.Type = TYPE
        self._add_properties(obj)

    def _add_properties(self, obj):
        for kind, name, group, tip in PROPERTIES:
            if name not in obj.PropertiesList:
                obj.addProperty(kind, name, group, tip)
                if name == "Kind":
                    obj.Kind = list(KINDS)
                elif name == "Which":
                    obj.Which = list(WHICH)
                elif name == "Samples":
                    obj.Samples = preferences.sample_density()
        for name in ("Values", "VertexColors", "Minimum", "Maximum", "Unit"):
            obj.setEditorMode(name, 1)

    def onDocumentRestored(self, obj):
        self._add_properties(obj)

    def execute(self, obj):
        fairing = obj.Fairing
        source, subs = fairing.Source
        merged, values = Mesh.Mesh(), []
        faces = [s for s in subs if s.startswith("Face")]
        if not faces or not fairing.Shape.Faces:
            raise cf.InvalidInputError(
                f"{fairing.Label} has no faired faces (edges only or failed); deviation and "
                "curvature maps are drawn on faces.")
        for source_face, faired_face in _pairs([source.Shape.getElement(f) for f in faces],
                                               fairing.Shape.Faces):
            mesh, v = _grid_mesh(*_face_samples(obj, source_face, faired_face, obj.Samples))
            merged.addMesh(mesh)
            values.extend(v.tolist())
        values = np.asarray(values)
        if obj.Kind == "Deviation":
            values = np.abs(values)
        shown = values if obj.Kind == "Deviation" else values[np.isfinite(values)]
        obj.Minimum, obj.Maximum = float(shown.min()), float(shown.max())
        low, high = self.range(obj)
        merged.translate(*obj.Offset)
        obj.Mesh = merged
        obj.Values = values.tolist()
        obj.VertexColors = ramp(values, low, high)
        obj.Unit = UNITS[obj.Kind]

    @staticmethod
    def range(obj):
        """The colour ramp's ``(low, high)``: [0, max] for deviation, else min..max."""
        if obj.RangeMax > obj.RangeMin:
            return obj.RangeMin, obj.RangeMax
        if obj.Kind == "Deviation":
            return 0.0, obj.Maximum
        return obj.Minimum, obj.Maximum

    def __getstate__(self):
        return {"Type": self.Type}

    def __setstate__(self, state):
        self.Type = (state or {}).get("Type", TYPE)

    dumps = __getstate__
    loads = __setstate__


def _on_faces(link, source, subs):
    """Whether a ``(object, [sub names])`` link names one of the faces ``subs`` of
    ``source``."""
    return bool(link) and link[0].Name == source.Name and bool(set(link[1]) & set(subs))


def covered(obj):
    """Objects whose faces lie where the map ``obj`` is drawn (hidden while it shows, or
    their faces would show through it in patches): its fairing, the fairing's source and
    every other fairing of one of the same faces.  None for a map moved aside
    (``Offset``)."""
    if obj.Offset.Length > 0 or obj.Fairing is None or not obj.Fairing.Source:
        return []
    source, subs = obj.Fairing.Source
    return [source] + [o for o in obj.Document.Objects
                       if getattr(getattr(o, "Proxy", None), "Type", None) == feature.TYPE
                       and _on_faces(o.Source, source, subs)]


def maps_on(source, subs):
    """Maps drawn on the faces ``subs`` of ``source``: those of any fairing of one of
    them, except maps moved aside (``Offset``)."""
    return [m for m in source.Document.Objects
            if getattr(getattr(m, "Proxy", None), "Type", None) == TYPE
            and m.Offset.Length == 0 and m.Fairing is not None
            and _on_faces(m.Fairing.Source, source, subs)]


def find_maps(fairing, kind=None):
    """Maps of a Fairing feature in its document (optionally of one Kind)."""
    return [o for o in fairing.Document.Objects
            if getattr(getattr(o, "Proxy", None), "Type", None) == TYPE
            and o.Fairing == fairing and (kind is None or o.Kind == kind)]


def make_map(fairing, kind="Deviation", which="Faired", name=None):
    """Create a map object of ``fairing`` (not yet recomputed)."""
    doc = fairing.Document
    obj = doc.addObject("Mesh::FeaturePython", name or f"{kind}Map")
    AnalysisMap(obj)
    obj.Fairing, obj.Kind, obj.Which = fairing, kind, which
    obj.Label = f"{kind} {which if kind != 'Deviation' else ''} of {fairing.Label}".replace(
        "  ", " ")
    if FreeCAD.GuiUp:
        from . import view_provider

        view_provider.ViewProviderMap(obj.ViewObject)
    return obj


def make_curvature_maps(fairing, kind="MeanCurvature"):
    """Two curvature maps, faired (in place) and source (shifted aside), same colour range."""
    faired = make_map(fairing, kind, "Faired")
    source = make_map(fairing, kind, "Source")
    box = fairing.Shape.BoundBox
    shift = FreeCAD.Vector(1.2 * box.XLength, 0, 0) if box.XLength >= box.YLength else \
        FreeCAD.Vector(0, 1.2 * box.YLength, 0)
    source.Offset = shift
    return faired, source


def share_range(maps):
    """Give recomputed maps one common colour range (comparable colours)."""
    low = min(m.Minimum for m in maps)
    high = max(m.Maximum for m in maps)
    for m in maps:
        m.RangeMin, m.RangeMax = low, high
