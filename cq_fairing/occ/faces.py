r"""Fair one OCP face: :func:`fair_face` and its :class:`FaceFairReport`.

Pipeline: classify the face; convert it to NURBS on request; take its net
(:func:`~cq_fairing.occ.face_to_surface`); hand it to the core's face search
(:func:`cq_fairing.core.face_search.search_face`, the same search the FreeCAD
workbench runs) with OCCT's pieces: the face's UV samples classified inside its trim,
and OCCT's two-sided check of each candidate put under the face's own trim
(:func:`~cq_fairing.occ.surface_to_face`, :class:`~cq_fairing.occ.deviation.BatchedCheck`).
The search chooses the target (explicit ``n`` or the fewest poles within ``tol``,
:mod:`cq_fairing.core.scale_search`, the core's :func:`cq_fairing.fair_surface`), or
with ``method="adaptive"`` lets the core choose non-uniform targets within ``tol``
(:mod:`cq_fairing.core.adaptive`).

Special cases handled, not refused:

* **rational** faces are faired in homogeneous coordinates :math:`(w P, w)`; if a
  weight of the result is not positive, a non-rational least-squares approximation in
  the same spline spaces is faired instead and ``message`` says so.  The adaptive
  method projects :math:`(w P, w)` too and refuses candidates with a weight
  :math:`\le 0` (no polish: :mod:`cq_fairing.core.adaptive`, note 6).  Energy fairing
  keeps the net and fairs polynomial surfaces only: a rational face gets status
  ``'skipped-rational'`` and is left unchanged;
* **periodic** directions are faired on the unperiodized (clamped) net and the first
  and last rows are tied to their mean afterwards, so the surface stays closed (G0 at
  the seam; tangent continuity across the seam is not enforced);
* **trimmed** faces keep their wires and UV pcurves (same parameter domain);
* ``boundary="fixed"`` keeps the border rows of the source net (``"wavelet"`` and
  ``"adaptive"``; the energy method keeps them by itself): the faired surface is
  projected back into the source spaces (L2, exact when the spaces are nested) and its
  border rows are replaced by the source's, so the natural boundary curves do not
  move (the result has as many poles as the source: fairer, not lighter).
"""

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from OCP.Bnd import Bnd_Box
from OCP.BRepBndLib import BRepBndLib
from OCP.BRepBuilderAPI import BRepBuilderAPI_NurbsConvert
from OCP.TopoDS import TopoDS, TopoDS_Face

from ..core.face_search import face_attempts, face_finisher, sample_counts, search_face, uv_window
from ..core.options import check_face_options, renamed_value
from ..core.results import SurfaceFairResult
from ..errors import UnsupportedGeometryError
from .builders import face_uv_box, surface_to_natural_face
from .convert import FaceInfo, as_face, face_info, face_to_surface, surface_to_face
from .deviation import BatchedCheck, face_uv_grid, reference_samples
from .trims import face_region

if TYPE_CHECKING:
    import cadquery

__all__ = ["fair_face", "FaceFairReport", "default_tolerance"]

STATUSES = ("faired", "unchanged", "skipped-not-bspline", "skipped-rational",
            "skipped-not-selected", "tolerance-not-met", "failed")


@dataclass(eq=False)
class FaceFairReport:
    """What happened to one face.

    Attributes
    ----------
    face : TopoDS_Face
        The faired face, or the original one when it was not faired.
    status : str
        ``'faired'``, ``'unchanged'`` (nothing to reduce), ``'skipped-not-bspline'``,
        ``'skipped-rational'`` (``method="energy"``), ``'skipped-not-selected'``,
        ``'tolerance-not-met'`` or ``'failed'``.
    message : str
        One line for the user (empty when there is nothing to say).
    result : SurfaceFairResult or None
        The core result (faired net, details) when faired.
    info : FaceInfo or None
    poles_before, poles_after : (int, int) or None
        Poles per direction of the source net and of the faired net.
    max_deviation : float or None
        Largest true distance (``GeomAPI_ProjectPointOnSurf``) from samples of the
        original face to the faired surface.
    tolerance : float or None
        The tolerance asked for (``None`` with explicit ``n``).
    seconds : float
        Wall time spent on this face.
    deviation : dict or None
        The full :func:`~cq_fairing.occ.sample_face_deviation` samples.
    original : TopoDS_Face or None
        The input face.
    surface : BSplineSurface or None
        The faired surface under ``face`` (after seam tying / border fixing).
    index : int or None
        Position in the shape (set by ``fair_shape``).
    """

    face: object
    status: str
    message: str = ""
    result: SurfaceFairResult = None
    info: FaceInfo = None
    poles_before: tuple = None
    poles_after: tuple = None
    max_deviation: float = None
    tolerance: float = None
    seconds: float = 0.0
    deviation: dict = field(default=None, repr=False)
    original: object = field(default=None, repr=False)
    surface: object = field(default=None, repr=False)
    index: int = None

    @property
    def faired(self):
        return self.status == "faired"


def default_tolerance(shape):
    """Default tolerance: 1e-3 of the bounding-box diagonal of ``shape`` (model units)."""
    box = Bnd_Box()
    BRepBndLib.Add_s(shape, box, False)
    x0, y0, z0, x1, y1, z1 = box.Get()
    return 1e-3 * float(np.linalg.norm([x1 - x0, y1 - y0, z1 - z0]))


def fair_face(face: "TopoDS_Face | cadquery.Face", *, tol: float | None = None,
              n: tuple[int | None, int | None] | None = None,
              method: Literal["wavelet", "adaptive", "energy"] = "wavelet",
              objective: Literal["auto", "compact", "faithful", "fair"] = "auto",
              convert: bool = False, boundary: Literal["free", "fixed"] = "free",
              target_degree: int | tuple[int, int] | None = None,
              density: int | tuple[int, int] | None = None, details: bool = True,
              search: Literal["local", "guaranteed", "linear", "polyfit"] = "local",
              borders: Literal["auto", "free", "pinned"] = "auto",
              grading: Literal["auto", "spans", "uniform"] = "auto") -> FaceFairReport:
    r"""Fair one face and put the result under the face's own trim.

    Parameters
    ----------
    face : TopoDS_Face or cadquery.Face
        Not modified.
    tol : float, optional
        Largest allowed distance (model units) between original and faired face; the
        fewest poles within it are searched.  Default (with ``n`` also ``None``):
        1e-3 of the face's bounding-box diagonal.
    n : (int or None, int or None) or int, optional
        Explicit target scales (knot spans) per direction, passed to
        :func:`cq_fairing.fair_surface`; ``None`` keeps a direction.
    method : {"wavelet", "adaptive", "energy"}
        ``"wavelet"``: multiresolution (ARWFA/DWFA) fairing onto quasi-uniform targets
        (on a face whose spans are graded, the bisections on its samples also try
        targets graded like them, the fewer poles winning:
        :mod:`cq_fairing.core.face_search`).
        ``"adaptive"``: the same exact L2 projection onto u and v targets whose knots
        follow the error (``cq_fairing.fair_surface(method="adaptive")``), usually
        fewer poles at the same ``tol``.  ``"energy"``: Eck-Hadenfeld local thin-plate
        energy fairing that keeps the net, each pole within ``tol`` of its place
        (``cq_fairing.fair_surface(method="energy")``), so the same-parameter distance,
        and with it the true distance, stays within ``tol``.  ``"adaptive"`` and
        ``"energy"`` need ``tol`` (or the default) and refuse ``n`` and ``search``;
        ``"energy"`` also refuses ``target_degree`` and ``boundary="fixed"``.  The
        options' names, values and defaults: :mod:`cq_fairing.core.options`.
        ``"wavelet"`` and ``"adaptive"`` fair rational faces in homogeneous coordinates
        (``"adaptive"`` without its polish); ``"energy"`` fairs polynomial faces only
        (rational ones: ``'skipped-rational'``).
    objective : {"auto", "compact", "faithful", "fair"}
        ``method="wavelet"`` with ``tol``: ``"auto"`` (default) and ``"fair"`` polish the
        fewest-poles net with the largest curvature-variation penalty within ``tol`` (the
        same poles, a fairer net; :func:`~cq_fairing.core.face_search.search_face`),
        ``"compact"`` keeps the plain projection.  ``method="adaptive"``: ``"compact"``
        (``"auto"``): the fewest poles within ``tol``;
        ``"faithful"``: stop where the residual reaches the net's estimated noise level
        (more poles, closer to the noise-free shape), within ``tol``; ``"fair"``: the
        fairest of the compact net and that net with up to two more spans per direction,
        pinned borders given up for a free-border net with half the energy or less
        (:func:`cq_fairing.core.adaptive.fair_surface_adaptive`).
    convert : bool, optional
        Convert a non-B-spline face to NURBS (``BRepBuilderAPI_NurbsConvert``, exact)
        instead of skipping it.
    boundary : {"free", "fixed"}
        ``"fixed"`` puts the source's border rows of poles back after the fit (see module
        notes); refused with ``method="energy"``, which keeps the border ring anyway.
    target_degree : int or (int, int), optional
        Default ``min(3, source degree)`` per direction; refused with
        ``method="energy"``, which keeps the degree.
    density : int or (int, int), optional
        UV samples per direction for the deviation check; default
        ``clip(2 k + 1, 20, 400)`` for ``k`` poles in that direction.
    details : bool, optional
        Compute the wavelet details (``report.result``) with the core after the local
        search, which does not; ``False`` skips that step (``result`` is then ``None``)
        and is faster on large nets.  The core's searches and the adaptive and energy
        methods return their core result, details included, at no extra cost.
    search : {"local", "guaranteed", "linear", "polyfit"}
        How the ``method="wavelet"`` target is found with ``tol``.  ``"local"``:
        bisection on the face's own samples (inside the trim) with the distance to the
        faired tangent planes (:mod:`cq_fairing.core.scale_search`); the others:
        ``cq_fairing.fair_surface(tol=..., search=...)``, the core's accuracy control
        with that step rule, measured in the face's UV box.  Either way OCCT's
        projection checks the result; if it fails, the local search runs again with the
        parametric distance, an upper bound of the true distance.  Refused with ``n``
        (no search runs) and with the other methods.  ``"core"`` is the old spelling of
        ``"guaranteed"`` (a ``DeprecationWarning``, for one release).
    borders : {"auto", "free", "pinned"}
        ``method="wavelet"`` or ``"adaptive"``: the border rows of the target while it
        is fitted.  ``"pinned"``: corners kept, each border row the projection of the
        source's border curve on its own
        (:mod:`cq_fairing.core.target_projections`); ``"free"``: the plain projection;
        ``"auto"``: both, the fewer poles winning (the report's message says when the
        pinned ones won; with ``n`` the plain projection).  A free projection moves the
        face's boundary along the surface where the source's parametric speed changes
        within a target span (the noisy 50 x 80 blade at 0.05 mm: 38 x 65 poles free,
        12 x 15 pinned).  For the adaptive method see
        :func:`cq_fairing.core.adaptive.fair_surface_adaptive`; there ``"free"`` is
        often a faster search.  Independent of ``boundary``, which restores the source's
        border rows afterwards.
    grading : {"auto", "spans", "uniform"}
        ``method="wavelet"`` with ``tol``: the targets of the bisections on the face's
        samples.  ``"auto"``: quasi-uniform ones, where the face's knot spans are
        graded ones graded like them, with pinned borders ones refined towards them
        (:func:`~cq_fairing.core.plans.end_graded_space`), and where those keep more
        than a quarter of the face's poles, ones graded by the error (the adaptive
        method's compact fit, with free borders unless ``borders="pinned"``); the fewest
        poles win (the report's message says when graded ones won); ``"spans"``:
        quasi-uniform ones and those graded like the face's spans; ``"uniform"``:
        quasi-uniform ones only.

    Returns
    -------
    FaceFairReport

    Raises
    ------
    InvalidInputError, InvalidToleranceError, InvalidTargetError
        Bad arguments, or an option the chosen method or ``n`` does not use
        (:func:`cq_fairing.core.options.check_face_options`).
    ToleranceNotMetError
        No target keeps the face within ``tol`` (checked with OCCT's projection).
    """
    start = time.perf_counter()
    face = as_face(face)
    search = renamed_value("fair_face", "search", search)
    check_face_options(tol, n, method, boundary, objective, borders, search, target_degree,
                       grading)
    info = face_info(face)
    if not info.is_bspline:
        if not convert:
            return FaceFairReport(face, "skipped-not-bspline", (
                f"{info.surface_type} face left unchanged; pass convert=True to convert "
                "it to NURBS and fair it."), info=info, original=face,
                seconds=time.perf_counter() - start)
        face = TopoDS.Face_s(BRepBuilderAPI_NurbsConvert(face, True).Shape())
    if tol is None and n is None:
        tol = default_tolerance(face)
    attempts = face_attempts(tol, search, method, objective, borders)
    try:
        report = _fair_bspline(face, tol, n, boundary, target_degree, density, details,
                               attempts, grading, borders, objective)
    except UnsupportedGeometryError as exc:  # energy: weights, a degree-1 direction
        if method != "energy":
            raise
        report = _not_for_energy(face, info, tol, exc)
    report.original = face
    report.seconds = time.perf_counter() - start
    return report


def _not_for_energy(face, info, tol, refusal):
    """Report of a face the energy method does not fair: rational faces (also those
    ``convert=True`` made rational, a cylinder's) are ``'skipped-rational'``; any other
    refusal of the core (a face with a degree-1 direction) leaves the face
    ``'unchanged'``; both say the core's reason, as the workbench does."""
    status = "skipped-rational" if face_info(face).rational else "unchanged"
    return FaceFairReport(face, status, str(refusal), info=info, tolerance=tol)


def _fair_bspline(face, tol, n, boundary, target_degree, density, details, attempts,
                  grading, borders, objective):
    """The core's face search (:func:`~cq_fairing.core.face_search.search_face`) with
    OCCT's pieces: the face's samples (classified inside its trim), its finisher and
    OCCT's two-sided check (:class:`_OcctCheck`)."""
    surface, info = face_to_surface(face)
    notes = []
    if info.unperiodized:
        notes.append(f"periodic in {'/'.join(info.unperiodized)}: faired the unperiodized "
                     "net with first/last rows tied (closed, G0 at the seam)")
    if boundary == "fixed" and info.trimmed:
        notes.append("boundary='fixed' keeps the surface's border rows; this trimmed face's "
                     "edges lie inside the surface, so they may still move")
    grid = face_uv_grid(face, density or sample_counts(surface), classify=info.trimmed)
    check = _OcctCheck(face, surface, grid, info.trimmed)
    outcome = search_face(
        surface, tol, grid, face_finisher(surface, info.unperiodized, boundary == "fixed"),
        check, n=n, target_degree=target_degree, attempts=attempts, exceeds=check.exceeds,
        region=face_region(face) if info.trimmed else None,
        window=uv_window(_uv_box(face), surface) if info.trimmed else None,
        details=details, judge="OCCT", grading=grading, borders=borders,
        objective=objective)
    if outcome.status == "unchanged":
        return FaceFairReport(face, "unchanged", outcome.message, info=info,
                              poles_before=surface.shape, poles_after=surface.shape,
                              max_deviation=0.0, tolerance=tol)
    new_face, deviation = check.measured(outcome.surface)
    return FaceFairReport(
        new_face, "faired", "; ".join(notes + list(outcome.notes)), result=outcome.result,
        info=info, poles_before=surface.shape, poles_after=outcome.surface.shape,
        max_deviation=deviation["max"], tolerance=tol, deviation=deviation,
        surface=outcome.surface)


def _uv_box(face):
    """The face's UV box as ``(u0, u1, v0, v1)``."""
    (u0, u1), (v0, v1) = face_uv_box(face)
    return u0, u1, v0, v1


class _OcctCheck:
    """OCCT's two-sided check of the candidates of one face, the ``check`` and
    ``exceeds`` of :func:`~cq_fairing.core.face_search.search_face`.

    Each candidate is measured by one :class:`~cq_fairing.occ.deviation.BatchedCheck`
    on the search grid plus the centres of its cells (:func:`_check_samples`: the check
    sees between the samples): ``exceeds`` measures only what decides ``tol`` (stopping
    at the first judged value above it), and the full check goes on from the samples it
    measured.  Each candidate's check starts its Newton runs from the foot points the
    last candidate's check found, where those are nearer (``seeds`` of
    :class:`~cq_fairing.occ.deviation.BatchedCheck`).  OCCT's judge there evaluates the
    candidate on a natural face of its surface (the samples lie inside the trim, and the
    trimmed face has the same surface); the accepted candidate alone is put under the
    face's trim (:func:`~cq_fairing.occ.surface_to_face`), which costs more than its
    check on a face with many trim edges (settling each vertex's tolerance).
    """

    def __init__(self, face, surface, grid, trimmed):
        self.face, self.surface, self.grid, self.trimmed = face, surface, grid, trimmed
        self._reference = None
        self._checks, self._deviations = {}, {}
        self._last = None

    def _check(self, faired):
        """The candidate's :class:`~cq_fairing.occ.deviation.BatchedCheck`, seeded with
        the foot points of the last candidate checked."""
        key = id(faired)
        if key not in self._checks:   # the candidate is kept with its check: ids stay unique
            seeds = None if self._last is None else self._last.seeds()
            self._checks[key] = (faired, BatchedCheck(
                self.face, surface_to_natural_face(faired), (self.surface, faired),
                self._samples(), seeds))
        self._last = self._checks[key][1]
        return self._last

    def _samples(self):
        if self._reference is None:
            self._reference = _check_samples(self.face, self.grid, self.trimmed,
                                             self.surface)
        return self._reference

    def exceeds(self, faired, tol):
        """True when the check of ``faired`` is certain to exceed ``tol``."""
        return self._check(faired).exceeds(tol)

    def __call__(self, faired):
        """OCCT's two-sided maximum distance of ``faired`` under the face's trim."""
        deviation = self._check(faired).deviation()
        self._deviations[id(faired)] = deviation
        return deviation["max"]

    def measured(self, faired):
        """``(face under the face's trim, deviation)`` of a candidate already checked."""
        return surface_to_face(faired, self.face), self._deviations[id(faired)]


def _check_samples(face, grid, trimmed, surface):
    """Search grid plus the centres of its cells: the OCCT check sees between samples."""
    u, v, _ = grid
    cu, cv = 0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1])
    inside = face_region(face)(cu, cv) if trimmed else np.ones((cu.size, cv.size), dtype=bool)
    return reference_samples(face, grid, (cu, cv, inside), surface=surface)
