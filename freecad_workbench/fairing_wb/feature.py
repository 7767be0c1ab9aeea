"""The parametric Fairing feature (App level, no GUI import).

A ``Part::FeaturePython`` whose proxy :class:`Fairing` fairs the linked B-spline faces
or edges of its ``Source`` on every recompute.  Its properties are declared once in
:data:`PROPERTIES`; :meth:`Fairing.onDocumentRestored` adds any property missing from an
older document and extends enumerations saved with fewer choices (migration).  The
proxy's module path ``fairing_wb.feature`` is frozen: saved documents refer to it.
"""

import Part

import cq_fairing as cf

from . import conversion, make

__all__ = ["Fairing", "PROPERTIES", "TYPE"]

TYPE = "Fairing::SurfaceFairing"
VERSION = 8  # 2: Method "adaptive" and the Objective property; 3: the Borders property;
# 4: the Joins and AngleTolerance properties; 5: Search "local", the default; 6: Measure
# "geometric", the default; 7: the Grading property; 8: Objective "auto", the default,
# which polishes the wavelet net (a feature saved before keeps its saved "compact": its
# net stays as it was saved)

# (type, name, group, tooltip, read-only)
PROPERTIES = (
    ("App::PropertyLinkSub", "Source", "Fairing", "Faces or edges to fair", False),
    ("App::PropertyEnumeration", "Mode", "Fairing",
     "Tolerance: fewest control points within Tolerance; Target: TargetU x TargetV", False),
    ("App::PropertyLength", "Tolerance", "Fairing",
     "Largest allowed deviation from the source", False),
    ("App::PropertyInteger", "TargetU", "Fairing", "Control points in u (Target mode)", False),
    ("App::PropertyInteger", "TargetV", "Fairing", "Control points in v (Target mode)", False),
    ("App::PropertyEnumeration", "Method", "Fairing",
     "wavelet (ARWFA/DWFA), energy (keeps the net) or adaptive (knots follow the error, "
     "fewer control points; Tolerance mode, polynomial faces)", False),
    ("App::PropertyEnumeration", "Objective", "Fairing",
     "wavelet method in Tolerance mode: auto or fair (the fewest control points, polished "
     "with the largest fairing penalty within Tolerance) or compact (not polished); "
     "adaptive method: auto or compact (fewest control points within Tolerance), "
     "faithful (stop where the residual reaches the source's estimated noise) or fair "
     "(the fairest of the compact net and up to two more spans per direction)", False),
    ("App::PropertyEnumeration", "Borders", "Fairing",
     "adaptive method, and wavelet in Tolerance mode: auto (borders pinned to the face's "
     "border curves where that gives fewer control points), free (plain projection) or "
     "pinned", False),
    ("App::PropertyEnumeration", "Grading", "Fairing",
     "wavelet method in Tolerance mode: auto (targets graded like a face's knot spans "
     "too, and by the error where quasi-uniform ones keep more than a quarter of the "
     "control points, and refined towards pinned borders; the fewest win; several "
     "faces: spans), spans (quasi-uniform and span-graded targets) or uniform "
     "(quasi-uniform targets only)", False),
    ("App::PropertyEnumeration", "Boundary", "Fairing",
     "free: boundary may move; corners: corners stay; edges: faired boundary curves", False),
    ("App::PropertyEnumeration", "Joins", "Fairing",
     "Faces of a shape with neighbours or with each other: smooth (joins held closed, and "
     "smooth where the source is), closed (joins held closed) or free (each face alone; joins may open)", False),
    ("App::PropertyAngle", "AngleTolerance", "Fairing",
     "A join whose source normals differ by less than this all along it is smooth, "
     "else a crease", False),
    ("App::PropertyEnumeration", "Search", "Fairing",
     "Tolerance search of the wavelet method: local (the command line's: bisection on the "
     "face's own samples), or the core's search with a step rule: guaranteed (fewest "
     "poles), linear (fast, the linear-hypothesis iteration of ARWFA), polyfit; every "
     "candidate is checked both ways on the face", False),
    ("App::PropertyEnumeration", "Measure", "Fairing",
     "Deviation bounded by the core's searches (guaranteed, linear, polyfit; local: "
     "geometric only): geometric (closest points) or parametric (same parameters, an "
     "upper bound)", False),
    ("App::PropertyString", "PolesBefore", "Figures", "Control points of the source", True),
    ("App::PropertyString", "PolesAfter", "Figures", "Control points of the result", True),
    ("App::PropertyLength", "MaxDeviation", "Figures",
     "Largest closest-point distance between faired and source face, both ways", True),
    ("App::PropertyFloat", "FairingTime", "Figures", "Seconds of the last recompute", True),
    ("App::PropertyString", "Status", "Figures", "Outcome of the last recompute", True),
)
ENUMERATIONS = {"Mode": make.MODES, "Method": make.METHODS, "Objective": make.OBJECTIVES,
                "Borders": make.BORDERS, "Grading": make.GRADINGS, "Boundary": make.BOUNDARIES,
                "Search": make.SEARCHES,
                "Measure": make.MEASURES, "Joins": make.JOINS}

# Values of newly added properties other than FreeCAD's zero (saved values are kept).
DEFAULTS = {"Tolerance": 0.01, "AngleTolerance": 1.0}
CLOSED = 1e-7  # relative to the size: joins closer than this are sewn as they are


def _sewn_closed(shapes, joins):
    """The faired faces sewn into one valid shell of them all when every join among them
    (``joins``, a :class:`~fairing_wb.joins.JoinReport`, whose faces after the faired ones
    are their fixed neighbours) is closed within :data:`CLOSED` times the size, else
    ``None`` (sewing may also leave a face loose, out of the shell).  The sewn edges lie
    on both faces to within their gaps, so their tolerances stay at the faces' own (no
    source edge is put back on a moved face)."""
    if joins is None:
        return None
    compound = Part.makeCompound(shapes)
    reach = CLOSED * compound.BoundBox.DiagonalLength
    among = [row["gap"] for row in joins.rows() if max(row["faces"]) <= len(compound.Faces)]
    if not among or max(among) > reach:
        return None
    sewn = compound.copy()
    sewn.sewShape(reach)
    if sewn.isValid() and [len(shell.Faces) for shell in sewn.Shells] == [len(shapes)]:
        return sewn.Shells[0]
    return None


def _sewn(compound, deviation):
    """Sew faired faces whose borders meet within twice the deviation (valid result only).

    Each face is faired on its own, so shared borders may open by up to about twice the
    deviation; sewing rejoins them into shells.  The sewing tolerance is capped at 1 % of
    the compound's size; if sewing does not give a valid shape the compound is kept.
    """
    if not compound.Faces:
        return compound
    diagonal = compound.BoundBox.DiagonalLength
    sewn = compound.copy()
    sewn.sewShape(min(max(2.0 * deviation, 1e-7 * diagonal), 1e-2 * diagonal))
    return sewn if sewn.isValid() and len(sewn.Faces) == len(compound.Faces) else compound


def _shell_on_source_edges(source, subs, results):
    """The faired faces on the source's own shared edges as one valid shell, else ``None``.

    Each faired face keeps its parameter domain, so it can be bounded by the edges of a
    copy of its source face (:func:`conversion.face_on_edges`): neighbours share those
    edges, their splits and their vertices, and need no sewing.  An edge then lies within
    its tolerance of both faired faces; the tolerance may grow to twice the largest
    deviation (two faces each within the deviation of the source), at least the source's
    largest tolerance, at most 1 % of the size.
    """
    if not all(sub.startswith("Face") for sub in subs):
        return None
    copy = source.Shape.copy()  # the source's topology, never modified in place
    diagonal = copy.BoundBox.DiagonalLength
    deviation = max(r.max_deviation for r in results)
    tolerance = min(max(2.0 * deviation, copy.getTolerance(1), 1e-7 * diagonal),
                    1e-2 * diagonal)
    try:
        faces = [conversion.face_on_edges(r.shape.Surface, copy.getElement(sub), tolerance)
                 for sub, r in zip(subs, results)]
        shell = Part.Shell(faces)
        if not shell.isValid():
            shell.fix(1e-7, 1e-7, tolerance)
    except Part.OCCError:
        return None  # e.g. a face the fixer turned into something else: sew instead
    if shell.isValid() and len(shell.Faces) == len(faces) and len(shell.Shells) <= 1:
        return shell
    return None


class Fairing:
    """Proxy of the Fairing feature."""

    Type = TYPE

    def __init__(self, obj):
        obj.Proxy = self
        self.Type = TYPE
        self.Version = VERSION
        self._add_properties(obj)

    def _add_properties(self, obj):
        for kind, name, group, tip, read_only in PROPERTIES:
            if name in obj.PropertiesList:
                continue
            obj.addProperty(kind, name, group, tip)
            if name in ENUMERATIONS:
                setattr(obj, name, list(ENUMERATIONS[name]))
            if name in DEFAULTS:
                setattr(obj, name, DEFAULTS[name])
            if read_only:
                obj.setEditorMode(name, 1)

    @staticmethod
    def _extend_enumerations(obj):
        """Give enumerations saved with fewer choices the current ones.

        Version 1 saved Method without ``adaptive``, versions up to 4 Search without
        ``local``; FreeCAD keeps the chosen value (by name), which is still among the
        choices.
        """
        for name, values in ENUMERATIONS.items():
            if obj.getEnumerationsOfProperty(name) != list(values):
                setattr(obj, name, list(values))

    def onDocumentRestored(self, obj):
        """Migrate older documents: add missing properties, extend enumerations, give a
        local search the default ``Measure`` (:meth:`_measure_of_local`), and a document
        without ``Objective`` (saved before version 2) the ``compact`` its wavelet net
        was (the default ``auto`` polishes it); a saved ``Objective`` is kept."""
        had_objective = "Objective" in obj.PropertiesList
        self._add_properties(obj)
        self._extend_enumerations(obj)
        if not had_objective:
            obj.Objective = "compact"
        if getattr(self, "Version", 1) < 6:
            self._measure_of_local(obj)
        self.Type, self.Version = TYPE, VERSION

    @staticmethod
    def _measure_of_local(obj):
        """Before version 6 ``Measure``'s default was ``parametric``, the one value the
        local search, which does not use it, took; now that is the default,
        ``geometric``.  A local search's ``parametric`` becomes ``geometric`` (its net
        is the same); a core search keeps its ``Measure``."""
        if obj.Search == "local" and obj.Measure == "parametric":
            obj.Measure = make.MEASURES[0]

    def execute(self, obj):
        """Fair every linked face/edge; any failure sets ``Status`` (one sentence) and
        fails the object."""
        try:
            shape, results = self._fair(obj)
        except Exception as error:
            obj.Status = f"Error: {make.error_sentence(error)}"
            raise
        obj.Shape = shape
        obj.PolesBefore = "; ".join(" x ".join(map(str, r.poles_before)) for r in results)
        obj.PolesAfter = "; ".join(" x ".join(map(str, r.poles_after)) for r in results)
        obj.MaxDeviation = max(r.max_deviation for r in results)
        joins = [] if results.joins is None else [results.joins]
        obj.FairingTime = sum(r.seconds for r in results) + sum(j.seconds for j in joins)
        obj.Status = "; ".join(["OK"] + [r.note for r in results if r.note]
                               + [j.line() for j in joins])

    @staticmethod
    def settings(obj):
        """Keyword arguments of :func:`make.fair_face` from the properties.

        ``Objective`` applies to the adaptive method and to the wavelet method in
        Tolerance mode (:func:`make.borders_apply`) and is ``auto`` otherwise,
        ``Search`` and ``Measure`` to the wavelet method only, likewise; ``Measure``
        other than ``geometric`` with ``Search`` ``local`` is refused by
        :func:`make.fair_face` (the recompute fails, ``Status`` says why).
        """
        applies = make.borders_apply(obj.Method, obj.Mode == "Tolerance")
        objective = obj.Objective if applies else make.OBJECTIVES[0]
        wavelet = obj.Method == "wavelet"
        common = {"method": obj.Method,
                  "search": obj.Search if wavelet else make.SEARCHES[0],
                  "measure": obj.Measure if wavelet else make.MEASURES[0],
                  "objective": objective}
        if obj.Mode == "Tolerance":
            return {"tolerance": obj.Tolerance.Value, "target": None, **common}
        return {"tolerance": None, "target": (obj.TargetU, obj.TargetV), **common}

    @staticmethod
    def join_settings(obj):
        """Keyword arguments of :func:`make.fair_shapes` for the joins: ``joins``,
        ``angle_tolerance`` (degrees)."""
        return {"joins": obj.Joins, "angle_tolerance": obj.AngleTolerance.Value}

    @staticmethod
    def face_settings(obj):
        """Keyword arguments of :func:`make.fair_face` that faces have and edges do not:
        ``boundary``, and ``borders`` and ``grading`` where they apply
        (:func:`make.borders_apply`: the adaptive method, the wavelet method in
        tolerance mode; ``grading``: the wavelet method in tolerance mode; ``"auto"``
        otherwise)."""
        by_tolerance = obj.Mode == "Tolerance"
        applies = make.borders_apply(obj.Method, by_tolerance)
        graded = obj.Method == "wavelet" and by_tolerance
        return {"boundary": obj.Boundary, "borders": obj.Borders if applies else "auto",
                "grading": obj.Grading if graded else "auto"}

    def _fair(self, obj):
        if obj.Source is None:
            raise cf.InvalidInputError("the Fairing has no Source; link faces or edges.")
        source, subs = obj.Source
        results = make.fair_elements(source, subs, self.settings(obj), self.face_settings(obj),
                                     **self.join_settings(obj))
        shapes = [r.shape for r in results]
        if len(shapes) == 1:
            return shapes[0], results
        shell = (_sewn_closed(shapes, results.joins)
                 or _shell_on_source_edges(source, subs, results))
        if shell is not None:
            return shell, results
        return _sewn(Part.makeCompound(shapes), max(r.max_deviation for r in results)), results

    def __getstate__(self):
        return {"Type": self.Type, "Version": getattr(self, "Version", VERSION)}

    def __setstate__(self, state):
        if state:
            self.Type = state.get("Type", TYPE)
            self.Version = state.get("Version", VERSION)

    dumps = __getstate__
    loads = __setstate__
