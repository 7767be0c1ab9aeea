"""CadQuery front end: ``fair_face``/``fair_shape`` on cadquery objects and ``Workplane.fair``.

Usage::

    import cadquery as cq
    from cq_fairing.cadquery_plugin import register, fair_shape

    register()                                   # adds Workplane.fair
    part = cq.importers.importStep("blade.step")
    faired = part.fair(tol=0.05)                 # every B-spline face of the solids
    one = part.faces(">Z").fair(n=(None, 12))    # selected faces, solid rebuilt
    lean = part.fair(tol=0.05, method="adaptive", objective="faithful", jobs=2)

The options, their names, values and defaults are those of
:mod:`cq_fairing.core.options`, checked there once (by :func:`cq_fairing.occ.fair_face`
and :func:`cq_fairing.occ.fair_shape`); old spellings warn at the caller's line.

Following CadQuery's plugin convention the method is a plain function attached to
``cq.Workplane``; it returns a new Workplane (``newObject``) and never changes the
objects on the stack.  The numbers behind each result (deviation, poles before/after,
status per face) are on ``Workplane.fair_report`` of the returned Workplane.
"""

from collections import Counter

import cadquery as cq

from .core.options import renamed_value
from .errors import InvalidInputError
from .occ import fair_face as _fair_face
from .occ import fair_shape as _fair_shape
from .occ.convert import indexed_faces

__all__ = ["register", "fair_face", "fair_shape", "fair"]


def fair_face(face, *, tol=None, n=None, method="wavelet", objective="auto",
              return_report=False, **options):
    """Fair a ``cq.Face`` (see :func:`cq_fairing.occ.fair_face` for the options).

    ``method`` ``"wavelet"`` (``objective`` ``"auto"`` or ``"fair"``: polished,
    ``"compact"``: the plain projection), ``"adaptive"`` (``objective`` ``"compact"``
    (``"auto"``), ``"faithful"`` or ``"fair"``) or ``"energy"`` (keeps the net); other
    options as in :func:`cq_fairing.occ.fair_face`.

    Returns
    -------
    cq.Face, or (cq.Face, FaceFairReport) with ``return_report=True``
        The original face object when it was not faired (see ``report.status``).
    """
    if not isinstance(face, cq.Face):
        raise InvalidInputError(f"face must be a cadquery Face, got {type(face).__name__}.")
    _renamed_search(options, "cadquery_plugin.fair_face")
    report = _fair_face(face.wrapped, tol=tol, n=n, method=method, objective=objective,
                        **options)
    out = cq.Face(report.face) if report.faired else face
    return (out, report) if return_report else out


def fair_shape(shape, *, tol=None, n=None, method="wavelet", objective="auto", faces=None,
               jobs=1, face_timeout=None, return_report=False, **options):
    """Fair the B-spline faces of a ``cq.Shape`` (Solid, Shell, Compound...).

    ``faces`` may hold indices or ``cq.Face`` objects of ``shape``.  ``method``,
    ``objective``, ``jobs`` (worker processes) and ``face_timeout`` (seconds per face)
    and the other options as in :func:`cq_fairing.occ.fair_shape`.

    Returns
    -------
    cq.Shape (same kind), or (cq.Shape, ShapeFairResult) with ``return_report=True``
    """
    if not isinstance(shape, cq.Shape):
        raise InvalidInputError(f"shape must be a cadquery Shape, got {type(shape).__name__}.")
    result = _fair_shape(shape.wrapped, tol=tol, n=n, method=method, objective=objective,
                         faces=_face_indices(shape, faces), jobs=jobs,
                         face_timeout=face_timeout, **options)
    out = cq.Shape.cast(result.shape)
    return (out, result) if return_report else out


def _renamed_search(options, function):
    """Replace an old ``search`` value in ``options`` (in place), warning at the line that
    called ``function``, the plugin's public function that called this."""
    if "search" in options:
        options["search"] = renamed_value(function, "search", options["search"], stacklevel=4)


def _face_indices(shape, faces):
    if faces is None:
        return None
    if isinstance(faces, cq.Face) or not hasattr(faces, "__iter__"):
        raise InvalidInputError(
            f"faces must be a list of face indices or cq.Face objects, got {faces!r}.")
    all_faces = indexed_faces(shape.wrapped)
    out = []
    for item in faces:
        if isinstance(item, cq.Face):
            match = [i for i, f in enumerate(all_faces) if f.IsSame(item.wrapped)]
            if not match:
                raise InvalidInputError("a selected face does not belong to the shape.")
            out.append(match[0])
        else:
            out.append(item)
    return out


def fair(self, tol=None, n=None, method="wavelet", objective="auto", jobs=1,
         face_timeout=None, **options):
    """``Workplane.fair``: fair the selected faces or solids; returns a new Workplane.

    * Faces selected from a solid (``.faces(...)``): the solid is rebuilt with those
      faces faired (it stays one closed solid) and pushed on the new stack.
    * Solids, shells or compounds on the stack: each is faired whole.
    * Free faces: each is faired alone, in this process (``jobs`` does not apply;
      ``face_timeout`` is refused, since no worker runs them).
    * Nothing selected: the first solid found on the chain.
    * Edges, wires, vertices and compounds without faces hold nothing to fair: they are
      refused (``InvalidInputError`` naming them), also on a stack mixed with faces or
      solids, so a selection that went wrong (``.edges()`` for ``.faces()``) is never
      half faired with the rest passed through as if faired.

    ``method``, ``objective``, ``jobs``, ``face_timeout`` and the other options as in
    :func:`fair_shape`.

    Raises
    ------
    InvalidInputError
        An object on the stack holds no face, or bad options (see :func:`fair_shape`).
    """
    _renamed_search(options, "Workplane.fair")
    objects = [o for o in self.objects if isinstance(o, cq.Shape)]
    if not objects:
        objects = [self.findSolid()]
    _check_faces_on_stack(objects)
    faces = [o for o in objects if isinstance(o, cq.Face)]
    parent = _parent_solid(self) if faces and len(faces) == len(objects) else None
    reports = []
    options = dict(options, tol=tol, n=n, method=method, objective=objective,
                   return_report=True)
    workers = dict(jobs=jobs, face_timeout=face_timeout)
    if parent is not None:
        shape, report = fair_shape(parent, faces=faces, **workers, **options)
        results, reports = [shape], [report]
    else:
        if face_timeout is not None and faces:
            raise InvalidInputError(
                f"face_timeout={face_timeout!r} applies to faces of a solid, shell or "
                "compound (faired in worker processes); free faces are faired in this "
                "process. Select the faces from their solid, or drop face_timeout.")
        results = []
        for obj in objects:
            if isinstance(obj, cq.Face):
                out, report = fair_face(obj, **options)
            else:
                out, report = fair_shape(obj, **workers, **options)
            results.append(out)
            reports.append(report)
    new = self.newObject(results)
    new.fair_report = reports
    return new


def _check_faces_on_stack(objects):
    """Refuse the objects on the stack that hold no face (edges, wires, vertices...)."""
    idle = Counter(type(o).__name__ for o in objects if not o.Faces())
    if not idle:
        return
    kinds = [f"{count} {name} object{'s' if count > 1 else ''}" for name, count in idle.items()]
    what = " and ".join(filter(None, (", ".join(kinds[:-1]), kinds[-1])))
    rest = len(objects) - sum(idle.values())
    besides = (f" (and {rest} object{'s' if rest > 1 else ''} with faces: a mixed stack is "
               "refused whole)" if rest else "")
    raise InvalidInputError(
        f"Workplane.fair fairs faces and the shells, solids and compounds that hold them, "
        f"but the stack holds {what} with no face{besides}; select faces with "
        ".faces(...) or a solid with .solids() (or fair the part itself), then call .fair().")


def _parent_solid(workplane):
    """The solid the selected faces came from, or None (free faces)."""
    try:
        solid = workplane.findSolid(searchStack=False, searchParents=True)
    except ValueError:
        return None
    if isinstance(solid, cq.Compound) and len(solid.Solids()) == 1:
        solid = solid.Solids()[0]
    owned = indexed_faces(solid.wrapped)
    for face in workplane.objects:
        if not any(f.IsSame(face.wrapped) for f in owned):
            return None
    return solid


def register():
    """Attach :func:`fair` to ``cadquery.Workplane`` as ``Workplane.fair`` (idempotent)."""
    cq.Workplane.fair = fair
    return fair
