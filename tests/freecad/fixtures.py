"""Shared test geometry for the FreeCAD tests (real models and a synthetic noisy face).

Imported by the headless pytest tests and by the GUI script, both inside FreeCAD.
"""

from contextlib import contextmanager
from pathlib import Path

import numpy as np

import FreeCAD
import Part
from face_references import noisy_blade_net, rational_blade_net

REPO = Path(__file__).resolve().parents[2]
REAL = REPO / "tests" / "data"  # bundled models, sources and licences in SOURCES.md there
BLADE = REPO / "examples" / "data" / "IEA_15MW_CFD.stp"
TERRAIN = REAL / "terrain.brep"


@contextmanager
def reopened(doc, path):
    """Save ``doc`` to ``path``, close it, and yield the document opened again from the
    file (closed on exit): what a user's save and reopen does to the features."""
    doc.saveAs(str(path))
    FreeCAD.closeDocument(doc.Name)
    again = FreeCAD.openDocument(str(path))
    try:
        yield again
    finally:
        FreeCAD.closeDocument(again.Name)


def noisy_blade_surface(n_u=50, n_v=80, noise=0.02, seed=3):
    """A bicubic blade-like net (``n_u x n_v`` poles, mm) with seeded noise, and the truth
    (:func:`face_references.noisy_blade_net`).

    Returns
    -------
    (Part.BSplineSurface noisy, Part.BSplineSurface truth)
    """
    noisy, truth, _, _ = noisy_blade_net(n_u, n_v, noise, seed)
    return _part_surface(noisy), _part_surface(truth)


def rational_blade_surface(n_u=20, n_v=30):
    """The rational blade of :func:`face_references.rational_blade_net` as a
    ``Part.BSplineSurface``."""
    poles, weights, _, _ = rational_blade_net(n_u, n_v)
    return _part_surface(poles, weights)


def _part_surface(net, weights=None):
    n_u, n_v = net.shape[:2]
    surface = Part.BSplineSurface()
    uk = list(np.linspace(0, 1, n_u - 2))
    vk = list(np.linspace(0, 1, n_v - 2))
    um = [4] + [1] * (n_u - 4) + [4]
    vm = [4] + [1] * (n_v - 4) + [4]
    poles = [[FreeCAD.Vector(*map(float, p)) for p in row] for row in net]
    if weights is None:
        surface.buildFromPolesMultsKnots(poles, um, vm, uk, vk, False, False, 3, 3)
    else:
        surface.buildFromPolesMultsKnots(poles, um, vm, uk, vk, False, False, 3, 3,
                                         [[float(w) for w in row] for row in weights])
    return surface


def add_shape(doc, shape, name):
    obj = doc.addObject("Part::Feature", name)
    obj.Shape = shape
    return obj


def blade_shape():
    return Part.read(str(BLADE))


def status_ok(obj):
    """The feature is valid and its ``Status`` says "OK", followed only by the notes of
    faces it faired ("Face1 faired: ...") and the joins line: no face kept or failed."""
    head = obj.Status.split("; joins: ")[0]
    notes = head[len("OK; "):] if head.startswith("OK; ") else ""
    return (obj.isValid() and "Invalid" not in obj.State
            and (head == "OK" or bool(notes) and " faired: " in notes.split("; ")[0]
                 and " kept " not in notes and "Error" not in notes))


def sample_distance(faired_face, source_face, count=12):
    """Max FreeCAD ``distToShape`` from faired samples (inside its trim) to the source face."""
    u0, u1, v0, v1 = faired_face.ParameterRange
    surface = faired_face.Surface
    return max(source_face.distToShape(Part.Vertex(surface.value(u, v)))[0]
               for u in np.linspace(u0, u1, count) for v in np.linspace(v0, v1, count)
               if faired_face.isPartOfDomain(u, v))


def shared_edges(shape):
    """``[(edge, face i, face j)]``: the non-degenerated edges of exactly two faces, by
    OCCT's ancestor map."""
    out = []
    for edge in shape.Edges:
        owners = [i for i, f in enumerate(shape.Faces)
                  if any(f.isSame(a) for a in shape.ancestorsOfType(edge, Part.Face))]
        if not edge.Degenerated and len(owners) == 2:
            out.append((edge, *owners))
    return out


def normal_at(face, point):
    u, v = face.Surface.parameter(point)
    return face.normalAt(u, v)


def joins_along(source, faired, count=9):
    """Per shared edge of ``source``: the largest gap (OCCT projection of face i's faired
    points onto face j's faired surface) and the source and faired normal angles
    (degrees, ``Part.Face.normalAt``) at ``count`` interior points."""
    rows = []
    for edge, i, j in shared_edges(source):
        first, last = edge.ParameterRange
        gaps, before, after = [], [], []
        for t in first + (np.arange(count) + 0.5) / count * (last - first):
            point = edge.valueAt(t)
            u, v = source.Faces[i].Surface.parameter(point)
            on_i = faired[i].Surface.value(u, v)
            a, b = faired[j].Surface.parameter(on_i)
            gaps.append((faired[j].Surface.value(a, b) - on_i).Length)
            before.append(np.degrees(normal_at(source.Faces[i], point).getAngle(
                normal_at(source.Faces[j], point))))
            after.append(np.degrees(faired[i].normalAt(u, v).getAngle(
                faired[j].normalAt(a, b))))
        rows.append((max(gaps), np.array(before), np.array(after)))
    return rows
