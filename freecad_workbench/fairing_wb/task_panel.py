"""Task panels: Fair Surface / Fair Curve (create or edit a Fairing) and Levels (GUI only).

Widgets carry objectNames (``fairing_tolerance``, ``fairing_mode``, ``fairing_target_u``,
``fairing_target_v``, ``fairing_method``, ``fairing_objective``, ``fairing_borders``,
``fairing_grading``, ``fairing_boundary``, ``fairing_search``, ``fairing_measure``, ``fairing_preview``,
``fairing_progress``, ``fairing_cancel``, ``fairing_figures``, ``fairing_error``,
``fairing_faces``, ``fairing_level``) so scripts and GUI tests can find them with
``Gui.getMainWindow().findChild``.

Preview fairs in a worker thread (:class:`PreviewJob`): the GUI stays live, a busy bar
and "Cancel preview" show until the figures come.  OK fairs in the GUI thread, since it
changes the document.
"""

import threading

import FreeCADGui
import Part

from . import deviation_map, icon_path, make, preferences, undo
from .qt import QtCore, QtGui, QtWidgets

__all__ = ["FairSurfacePanel", "LevelsPanel", "PreviewJob", "selection_link", "make_call"]

POLL_MS = 50  # how often the panel looks whether a preview has finished


def selection_link(kind="Face"):
    """``(object, [sub names])`` of the selection's B-spline faces/edges (first object
    with any), else ``None``: the commands are disabled for other geometry."""
    for sel in FreeCADGui.Selection.getSelectionEx():
        subs = [name for name, element in zip(sel.SubElementNames, sel.SubObjects)
                if name.startswith(kind) and _is_bspline(element)]
        if subs:
            return sel.Object, subs
    return None


def _is_bspline(element):
    geometry = getattr(element, "Surface", None) or getattr(element, "Curve", None)
    return isinstance(geometry, (Part.BSplineSurface, Part.BSplineCurve))


def make_call(link, settings, face, joins=None):
    """The scriptable ``make_fairing(...)`` line for a source link, settings, face
    settings (``boundary``, ``borders``, ``grading``: those two named only where they
    apply) and join settings (``joins``, ``angle_tolerance``, named only where they
    differ from the defaults)."""
    obj, subs = link
    args = [f"(App.ActiveDocument.getObject({obj.Name!r}), {subs!r})"]
    if settings["target"] is not None:
        args.append(f"target={tuple(settings['target'])!r}")
    elif settings["method"] == "adaptive":  # search and measure do not apply
        args += [f"tolerance={settings['tolerance']!r}",
                 f"objective={settings['objective']!r}", f"borders={face['borders']!r}"]
    elif settings["method"] == "energy":    # nor here
        args.append(f"tolerance={settings['tolerance']!r}")
    else:
        args += [f"tolerance={settings['tolerance']!r}", f"search={settings['search']!r}",
                 f"measure={settings['measure']!r}", f"borders={face['borders']!r}",
                 f"grading={face.get('grading', 'auto')!r}"]
    args += [f"method={settings['method']!r}", f"boundary={face['boundary']!r}"]
    defaults = {"joins": make.JOINS[0], "angle_tolerance": 1.0}
    args += [f"{key}={value!r}" for key, value in (joins or {}).items() if value != defaults[key]]
    return f"fairing_wb.make.make_fairing({', '.join(args)})"


class PreviewJob:
    """:func:`make.fair_shapes` in a worker thread, stoppable between elements.

    The elements are read from the document before (in the GUI thread); the worker only
    computes.  ``results`` or ``error`` hold the outcome once ``thread`` has ended.
    """

    def __init__(self, named, settings, face_settings, join_settings):
        self.stop = threading.Event()
        self.results = self.error = None
        self.done, self.total = 0, len(named)
        self.thread = threading.Thread(
            target=self._run, args=(named, settings, face_settings, join_settings), daemon=True)
        self.thread.start()

    def _run(self, named, settings, face_settings, join_settings):
        try:
            self.results = make.fair_shapes(named, settings, face_settings, self._step,
                                            **join_settings)
        except Exception as error:  # reported by the panel
            self.error = error

    def _step(self, done, total):
        if self.stop.is_set():
            raise PreviewCancelled(f"preview cancelled after {done} of {total} elements")
        self.done = done

    def stage(self):
        """Progress text: which element is being faired."""
        return f"fairing {min(self.done + 1, self.total)} of {self.total}..."


class PreviewCancelled(Exception):
    """Raised in the worker thread when Cancel stopped a preview."""


def _row(layout, text, widget, name):
    widget.setObjectName(name)
    layout.addRow(text, widget)
    return widget


class FairSurfacePanel:
    """Tolerance, mode, target, method, objective, borders, boundary, figures; Preview /
    OK / Cancel.

    Objective and borders are enabled for the adaptive method and for the wavelet
    method in Tolerance mode; grading, search and measure for the
    wavelet method in tolerance mode (the adaptive method checks the true distance itself,
    energy keeps the net).
    """

    def __init__(self, link=None, fairing=None, kind="Face"):
        self.fairing = fairing
        self.link = tuple(fairing.Source) if fairing is not None else link
        self.kind = "Edge" if self.link and self.link[1][0].startswith("Edge") else kind
        self.form = self._build()
        self._load()

    # -- widgets -------------------------------------------------------------------------
    def _build(self):
        form = QtWidgets.QWidget()
        form.setObjectName("FairingTaskPanel")
        form.setWindowTitle("Fair curve" if self.kind == "Edge" else "Fair surface")
        form.setWindowIcon(QtGui.QIcon(icon_path(
            "Fairing_FairCurve" if self.kind == "Edge" else "Fairing_FairSurface")))
        layout = QtWidgets.QFormLayout(form)
        self.faces = _row(layout, "Source:", QtWidgets.QListWidget(), "fairing_faces")
        self.faces.setMaximumHeight(70)
        self.mode = _row(layout, "Mode:", QtWidgets.QComboBox(), "fairing_mode")
        self.mode.addItems(["Tolerance", "Target control points"])
        # parented to the form at once: an unparented widget of a temporary UiLoader can
        # be deleted under Python before it reaches the layout ("Internal C++ object
        # already deleted"; the panel then failed to open, now and then, in CI)
        loader = FreeCADGui.UiLoader()
        spin = loader.createWidget("Gui::QuantitySpinBox", form)
        self.tolerance = _row(layout, "Tolerance:", spin, "fairing_tolerance")
        self.tolerance.setProperty("unit", "mm")
        self.tolerance.setProperty("minimum", 1e-6)
        self.tolerance.setProperty("decimals", 4)
        self.target_u = _row(layout, "Target poles u:", QtWidgets.QSpinBox(), "fairing_target_u")
        self.target_v = _row(layout, "Target poles v:", QtWidgets.QSpinBox(), "fairing_target_v")
        for box in (self.target_u, self.target_v):
            box.setRange(2, 100000)
        self.target_v.setVisible(self.kind == "Face")
        self.method = _row(layout, "Method:", QtWidgets.QComboBox(), "fairing_method")
        self.method.addItems(list(make.METHODS))
        self.method.setToolTip("adaptive: knots follow the error, fewer control points "
                               "(tolerance mode, polynomial faces; slower)")
        self.objective = _row(layout, "Objective:", QtWidgets.QComboBox(), "fairing_objective")
        self.objective.addItems(list(make.OBJECTIVES))
        self.objective.setToolTip("wavelet (Tolerance mode): auto or fair = the fewest "
                                  "control points, polished with the largest fairing "
                                  "penalty within the tolerance; compact = not polished. "
                                  "adaptive: auto or compact = fewest control points "
                                  "within the tolerance; faithful: stop where the residual "
                                  "reaches the noise; fair: the fairest of the compact net "
                                  "and a few more spans")
        self.borders = _row(layout, "Borders:", QtWidgets.QComboBox(), "fairing_borders")
        self.borders.addItems(list(make.BORDERS))
        self.borders.setToolTip("wavelet (Tolerance mode) and adaptive: auto = borders "
                                "pinned to the face's border curves where that gives fewer "
                                "control points; free = plain projection; pinned = always")
        self.grading = _row(layout, "Grading:", QtWidgets.QComboBox(), "fairing_grading")
        self.grading.addItems(list(make.GRADINGS))
        self.grading.setToolTip("wavelet, Tolerance mode: auto = also targets graded like "
                                "the face's knot spans, targets refined towards pinned "
                                "borders, and where quasi-uniform ones keep "
                                "more than a quarter of its control points targets graded "
                                "by the error (the adaptive method's knots); the fewest "
                                "control points win (several faces: spans); spans = "
                                "quasi-uniform and span-graded targets; uniform = "
                                "quasi-uniform targets only")
        self.boundary = _row(layout, "Boundary:", QtWidgets.QComboBox(), "fairing_boundary")
        self.boundary.addItems(list(make.BOUNDARIES))
        self.boundary.setEnabled(self.kind == "Face")
        self.search = _row(layout, "Search:", QtWidgets.QComboBox(), "fairing_search")
        self.search.addItems(list(make.SEARCHES))
        self.search.setToolTip("local: the command line's search, on the face's own samples; "
                               "guaranteed: the core's, fewest control points; linear: fast "
                               "linear-hypothesis iteration (ARWFA); polyfit")
        self.measure = _row(layout, "Measure:", QtWidgets.QComboBox(), "fairing_measure")
        self.measure.addItems(list(make.MEASURES))
        self.joins = _row(layout, "Joins:", QtWidgets.QComboBox(), "fairing_joins")
        self.joins.addItems(list(make.JOINS))
        self.joins.setToolTip("Joins with the other faces of the shape: smooth (held "
                              "closed, and smooth where the source is), closed, or free "
                              "(each face alone)")
        self.preview = _row(layout, "", QtWidgets.QPushButton("Preview"), "fairing_preview")
        self.preview.clicked.connect(self.on_preview)
        self.progress = _row(layout, "", QtWidgets.QProgressBar(), "fairing_progress")
        self.progress.setRange(0, 0)  # busy: one element's time is not known ahead
        self.progress.setTextVisible(True)
        self.cancel = _row(layout, "", QtWidgets.QPushButton("Cancel preview"),
                           "fairing_cancel")
        self.cancel.clicked.connect(self.on_cancel)
        self.timer = QtCore.QTimer(form)
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self._poll)
        self.job = None
        self._busy(False)
        self.figures = _row(layout, "", QtWidgets.QLabel("Press Preview for figures."),
                            "fairing_figures")
        self.figures.setWordWrap(True)
        self.error = _row(layout, "", QtWidgets.QLabel(""), "fairing_error")
        self.error.setStyleSheet("color: #b00000")
        self.error.setWordWrap(True)
        self.mode.currentIndexChanged.connect(self._mode_changed)
        self.method.currentIndexChanged.connect(self._mode_changed)
        self.search.currentIndexChanged.connect(self._mode_changed)
        return form

    def _load(self):
        obj, subs = self.link
        self.faces.addItems([f"{obj.Label}.{s}" for s in subs])
        first = obj.Shape.getElement(subs[0])
        geometry = first.Surface if self.kind == "Face" else first.Curve
        if self.kind == "Face":
            self.target_u.setValue(max(4, geometry.NbUPoles // 2))
            self.target_v.setValue(max(4, geometry.NbVPoles // 2))
        else:
            self.target_u.setValue(max(4, geometry.NbPoles // 2))
        self.tolerance.setProperty("rawValue", preferences.default_tolerance(obj.Shape))
        if self.fairing is not None:
            f = self.fairing
            self.mode.setCurrentIndex(0 if f.Mode == "Tolerance" else 1)
            self.tolerance.setProperty("rawValue", f.Tolerance.Value)
            self.target_u.setValue(f.TargetU)
            self.target_v.setValue(f.TargetV)
            self.method.setCurrentText(f.Method)
            self.objective.setCurrentText(f.Objective)
            self.borders.setCurrentText(f.Borders)
            self.grading.setCurrentText(f.Grading)
            self.boundary.setCurrentText(f.Boundary)
            self.search.setCurrentText(f.Search)
            self.measure.setCurrentText(f.Measure)
            self.joins.setCurrentText(f.Joins)
        self.joins.setEnabled(self.kind == "Face")
        self._mode_changed()

    def _mode_changed(self, *_):
        by_tolerance = self.mode.currentIndex() == 0
        wavelet = self.method.currentText() == "wavelet"
        self.tolerance.setEnabled(by_tolerance)
        self.objective.setEnabled(self._objective_applies())
        self.borders.setEnabled(make.borders_apply(self.method.currentText(), by_tolerance)
                                and self.kind == "Face")
        self.grading.setEnabled(by_tolerance and wavelet and self.kind == "Face")
        self.search.setEnabled(by_tolerance and wavelet)
        self.measure.setEnabled(by_tolerance and wavelet and not self._local())
        self.target_u.setEnabled(not by_tolerance)
        self.target_v.setEnabled(not by_tolerance)

    def _objective_applies(self):
        """Objective: the adaptive method, and the wavelet method's tolerance search of a
        face (whose net it polishes)."""
        method = self.method.currentText()
        return method == "adaptive" or (make.borders_apply(method, self.mode.currentIndex() == 0)
                                        and self.kind == "Face")

    def _local(self):
        """True when the local search is chosen: ``Measure`` belongs to the core's."""
        return self.search.currentText() == "local"

    # -- values ----------------------------------------------------------------------------
    def settings(self):
        """Keyword arguments of :func:`make.fair_face` (without ``boundary``); ``measure``
        is the default with the local search, which does not use it."""
        method = self.method.currentText()
        wavelet = method == "wavelet"
        measure = make.MEASURES[0] if self._local() or not wavelet else \
            self.measure.currentText()
        common = {"method": method,
                  "search": self.search.currentText() if wavelet else make.SEARCHES[0],
                  "measure": measure,
                  "objective": self.objective.currentText() if self._objective_applies()
                  else make.OBJECTIVES[0]}
        if self.mode.currentIndex() == 0:
            return {"tolerance": float(self.tolerance.property("rawValue")), "target": None,
                    **common}
        return {"tolerance": None, "target": (self.target_u.value(), self.target_v.value()),
                **common}

    def face_settings(self):
        """Keyword arguments of :func:`make.fair_face` that edges do not take: ``boundary``,
        and ``borders`` and ``grading`` where they apply (:func:`make.borders_apply`;
        ``grading``: the wavelet method in Tolerance mode)."""
        by_tolerance = self.mode.currentIndex() == 0
        applies = make.borders_apply(self.method.currentText(), by_tolerance)
        graded = by_tolerance and self.method.currentText() == "wavelet"
        return {"boundary": self.boundary.currentText(),
                "borders": self.borders.currentText() if applies else "auto",
                "grading": self.grading.currentText() if graded else "auto"}

    def join_settings(self):
        """Keyword arguments of :func:`make.fair_shapes` for the joins (the feature's
        angle tolerance is kept when it is edited)."""
        angle = self.fairing.AngleTolerance.Value if self.fairing is not None else 1.0
        return {"joins": self.joins.currentText(), "angle_tolerance": angle}

    def run(self):
        """Fair every selected face/edge; returns the :class:`make.FairedShapes`."""
        obj, subs = self.link
        return make.fair_elements(obj, subs, self.settings(), self.face_settings(),
                                  **self.join_settings())

    def on_preview(self):
        """Start fairing in a worker thread (the GUI stays live; a busy bar and Cancel
        show); the figures appear when it ends (:meth:`_poll`)."""
        if self.job is not None:
            return
        self.error.setText("")
        try:
            named = make.named_elements(*self.link)
            neighbours = make.neighbour_faces(*self.link)
        except Exception as error:  # a slot: anything uncaught would be lost
            self._show_error(error)
            return
        self.job = PreviewJob(named, self.settings(), self.face_settings(),
                              {**self.join_settings(), "neighbours": neighbours})
        self.figures.setText("")
        self._busy(True)
        self.timer.start()

    def _poll(self):
        """Show the finished job's figures or error (timer slot)."""
        job = self.job
        if job is None:
            return
        if job.thread.is_alive():
            self.progress.setFormat(job.stage())
            return
        self._end_job()
        if job.error is not None:
            self._show_error(job.error)
        else:
            self._show(job.results)

    def on_cancel(self):
        """Stop the preview: its result is dropped; the worker stops before the next
        element (one being faired runs to its end in the background)."""
        if self.job is not None:
            self.job.stop.set()
            self._end_job()
            self.figures.setText("Preview cancelled.")

    def _end_job(self):
        self.timer.stop()
        self.job = None
        self._busy(False)

    def _busy(self, busy):
        self.progress.setVisible(busy)
        self.cancel.setVisible(busy)
        self.preview.setEnabled(not busy)

    def preview_now(self):
        """Fair in this thread (OK needs the result before it changes the document);
        shows and returns the results, or None after showing the error."""
        self.on_cancel()
        self.error.setText("")
        try:
            results = self.run()
        except Exception as error:  # called from a slot: anything uncaught would be lost
            self._show_error(error)
            return None
        self._show(results)
        return results

    def _show(self, results):
        lines = [f"{' x '.join(map(str, r.poles_before))} -> "
                 f"{' x '.join(map(str, r.poles_after))} control points\n"
                 f"max deviation {r.max_deviation:.4g} mm, time {1000 * r.seconds:.0f} ms"
                 for r in results]
        if results.joins is not None:
            lines.append(results.joins.line())
        self.figures.setText("\n".join(lines))

    def _show_error(self, error):
        self.figures.setText("")
        self.error.setText(make.error_sentence(error))

    # -- OK / Cancel ---------------------------------------------------------------------
    def accept(self):
        """Create (or change) the feature in one undo step; on failure undo it, say why in
        the panel and keep it open."""
        if self.preview_now() is None:
            return False
        s, face = self.settings(), self.face_settings()
        doc = self.link[0].Document
        before = {o.Name for o in doc.Objects}
        try:
            with undo.transaction(doc, "Fair surface" if self.fairing is None else
                                  "Edit fairing"):
                if self.fairing is None:
                    FreeCADGui.doCommand("import fairing_wb.make")
                    FreeCADGui.doCommand(
                        f"fairing = {make_call(self.link, s, face, self.join_settings())}")
                else:
                    FreeCADGui.doCommand(
                        f"fairing = App.ActiveDocument.getObject({self.fairing.Name!r})")
                    self._echo_properties(s, face)
                FreeCADGui.doCommand("App.ActiveDocument.recompute()")
                made = [o for o in doc.Objects if o.Name not in before]
                undo.require_valid(made or [self.fairing])
        except Exception as error:  # a slot: anything uncaught would be lost
            self.error.setText(make.error_sentence(error))
            return False
        self._close()
        return True

    def _echo_properties(self, s, face):
        if s["target"] is None:
            FreeCADGui.doCommand(
                f"fairing.Mode = 'Tolerance'; fairing.Tolerance = {s['tolerance']!r}")
        else:
            FreeCADGui.doCommand(f"fairing.Mode = 'Target'; fairing.TargetU, fairing.TargetV = "
                                 f"{s['target'][0]}, {s['target'][1]}")
        FreeCADGui.doCommand(
            f"fairing.Method = {s['method']!r}; fairing.Objective = {s['objective']!r}; "
            f"fairing.Borders = {face['borders']!r}; fairing.Grading = {face['grading']!r}; "
            f"fairing.Boundary = {face['boundary']!r}; "
            f"fairing.Search = {s['search']!r}; fairing.Measure = {s['measure']!r}; "
            f"fairing.Joins = {self.joins.currentText()!r}")

    def reject(self):
        self.on_cancel()
        self._close()
        return True

    def _close(self):
        if self.fairing is not None:
            FreeCADGui.ActiveDocument.resetEdit()
        else:
            FreeCADGui.Control.closeDialog()

    def getStandardButtons(self):
        return int(QtWidgets.QDialogButtonBox.Ok | QtWidgets.QDialogButtonBox.Cancel)


def level_targets(surface, count=8):
    """Control-point targets from the source down to the coarsest cubic net (halving)."""
    ku, kv = surface.NbUPoles, surface.NbVPoles
    du, dv = min(3, surface.UDegree), min(3, surface.VDegree)
    targets = [(ku, kv)]
    while len(targets) < count:
        u, v = targets[-1]
        nxt = (max(du + 1, du + (u - du) // 2), max(dv + 1, dv + (v - dv) // 2))
        if nxt == targets[-1]:
            break
        targets.append(nxt)
    return targets[1:]


class LevelsPanel:
    """Step through the multiresolution scales of one face with a slider.

    The shown level is a temporary ``Part::Feature`` (``FairingLevelPreview``) replaced
    on each step; OK turns the chosen level into a parametric Fairing (target mode),
    Cancel removes the preview.  Nothing changes the source.
    """

    def __init__(self, link):
        self.link = link
        obj, subs = link
        self.face = obj.Shape.getElement(subs[0])
        self.targets = level_targets(self.face.Surface)
        self.preview = None
        self.form = QtWidgets.QWidget()
        self.form.setObjectName("FairingLevelsPanel")
        self.form.setWindowTitle("Multiresolution levels")
        layout = QtWidgets.QVBoxLayout(self.form)
        self.slider = QtWidgets.QSlider(QtCore.Qt.Horizontal)
        self.slider.setObjectName("fairing_level")
        self.slider.setRange(0, len(self.targets) - 1)
        self.label = QtWidgets.QLabel("")
        self.label.setObjectName("fairing_figures")
        self.error = QtWidgets.QLabel("")
        self.error.setObjectName("fairing_error")
        for widget in (QtWidgets.QLabel("Scale (fine -> coarse):"), self.slider, self.label,
                       self.error):
            layout.addWidget(widget)
        self.slider.valueChanged.connect(self.show_level)
        self.show_level(0)

    def show_level(self, index):
        target = self.targets[index]
        try:
            result = make.fair_face(self.face, target=target)
        except Exception as error:  # a slot: anything uncaught would be lost
            self.error.setText(make.error_sentence(error))
            return
        self.error.setText("")
        doc = self.link[0].Document
        if self.preview is None or self.preview.Document is None:
            self.preview = doc.addObject("Part::Feature", "FairingLevelPreview")
            self.preview.ViewObject.ShapeColor = (0.35, 0.6, 0.95)
            self.link[0].ViewObject.Visibility = False
            for shown in deviation_map.maps_on(*self.link):  # drawn where the preview is
                shown.ViewObject.Visibility = False
        self.preview.Shape = result.shape
        self.label.setText(f"level {index + 1}/{len(self.targets)}: "
                           f"{target[0]} x {target[1]} control points, "
                           f"max deviation {result.max_deviation:.4g} mm")
        doc.recompute()

    def _remove_preview(self):
        if self.preview is not None:
            self.preview.Document.removeObject(self.preview.Name)
            self.preview = None
        self.link[0].ViewObject.Visibility = True

    def accept(self):
        target = self.targets[self.slider.value()]
        self._remove_preview()
        doc = self.link[0].Document
        call = make_call(self.link, {"target": target, "tolerance": None, "method": "wavelet",
                                     "search": make.SEARCHES[0], "measure": make.MEASURES[0],
                                     "objective": make.OBJECTIVES[0]},
                         {"boundary": "free", "borders": "auto", "grading": "auto"})
        before = {o.Name for o in doc.Objects}
        try:
            with undo.transaction(doc, "Fairing level"):
                FreeCADGui.doCommand("import fairing_wb.make")
                FreeCADGui.doCommand(f"fairing = {call}")
                FreeCADGui.doCommand("App.ActiveDocument.recompute()")
                undo.require_valid([o for o in doc.Objects if o.Name not in before])
        except Exception as error:  # a slot: anything uncaught would be lost
            self.error.setText(make.error_sentence(error))
            return False
        FreeCADGui.Control.closeDialog()
        return True

    def reject(self):
        self._remove_preview()
        FreeCADGui.Control.closeDialog()
        return True
