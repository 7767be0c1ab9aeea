"""Scriptable entry points: :func:`make_fairing` (the feature) and :func:`fair_face` /
:func:`fair_edge` (one shape, no document), used by the feature, the task panel's
Preview and the Levels command.

Every command of the workbench echoes a :func:`make_fairing` call to the Python console,
so what a user clicks can be replayed in a macro::

    import fairing_wb.make
    fairing_wb.make.make_fairing((App.ActiveDocument.Blade, ["Face2"]), tolerance=0.05)
    App.ActiveDocument.recompute()
"""

import importlib.util
import inspect
import time
from dataclasses import dataclass, replace

import FreeCAD
import numpy as np
import Part

import cq_fairing as cf
from cq_fairing.core.face_search import (
    face_attempts,
    face_finisher,
    sample_counts,
    search_face,
    uv_window,
)
from cq_fairing.core.joint_projection import (
    joined_faces,
    model_grading,
    plain_target_options,
    unholdable,
)
from cq_fairing.core.network_fairing import kept_sentence
from cq_fairing.core.options import (
    BORDERS,  # "auto" first: the enumeration's default
    GRADINGS,  # "auto" first: the default
    JOIN_CONTINUITY,
    MEASURES,  # "geometric" first: the default
    OBJECTIVES,  # "auto" first: the default
    check_applies,
)
from cq_fairing.core.options import FACE_SEARCHES as SEARCHES  # "local" first: the default
from cq_fairing.core.plans import largest_resolved_scale

from . import analysis, conversion
from .joins import (
    JOINS,
    HeldJoins,
    JoinReport,
    check_joins,
    face_neighbours,
    find_joins,
    hold_joins,
    measure_joins,
)
from .pinned import pin_faces

__all__ = ["make_fairing", "fair_face", "fair_edge", "fair_elements", "named_elements",
           "neighbour_faces", "fair_shapes", "error_sentence",
           "FairedShape", "FairedShapes", "MODES", "METHODS",
           "OBJECTIVES", "BORDERS", "GRADINGS", "BOUNDARIES", "SEARCHES", "MEASURES",
           "JOINS"]

MODES = ("Tolerance", "Target")
METHODS = ("wavelet", "energy", "adaptive")
BOUNDARIES = ("free", "corners", "edges")
DEVIATION_SAMPLES = 30
# why a face at its coarsest that no network moved is kept (Status)
COARSEST = ("its net is already at its coarsest (nothing to remove) and no network of "
            "faces at their coarsest moved it")


@dataclass(frozen=True)
class FairedShape:
    """Outcome of fairing one face or edge.

    Attributes
    ----------
    shape : Part.Face or Part.Edge
    poles_before, poles_after : tuple of int
        ``(k_u, k_v)`` for a face, ``(k,)`` for an edge.
    max_deviation : float
        Largest closest-point distance between faired and source surface, both ways
        (model units, mm): in Tolerance mode the value of the check that accepted the
        net (:func:`searched_face`: the face's samples and the centres of their cells),
        in Target mode at ``DEVIATION_SAMPLES`` squared samples of each on the face
        (``analysis.two_sided_deviation``, as the deviation map).
    seconds : float
        Wall time of conversion + fairing + rebuild.
    note : str
        Why the element was kept as it is, or what its search did beyond the plain case
        (``""`` when it was plainly faired); :func:`fair_shapes` puts the element's name
        in front.
    surface : cq_fairing.BSplineSurface or None
        The faired surface of a faired face, the source's of a face its search kept
        unchanged (``None`` for an edge or a face kept for its tolerance or its joins).
    """

    shape: object
    poles_before: tuple
    poles_after: tuple
    max_deviation: float
    seconds: float
    note: str = ""
    surface: object = None


class FairedShapes(list):
    """The :class:`FairedShape` of each element, in order (a list), and ``joins``: the
    :class:`~fairing_wb.joins.JoinReport` of the faces faired together (``None`` for one
    face without neighbours)."""

    def __init__(self, results, joins=None):
        super().__init__(results)
        self.joins = joins


def _check_tolerance(tolerance):
    if tolerance is None or not np.isfinite(tolerance) or tolerance <= 0:
        raise cf.InvalidToleranceError(
            f"the tolerance must be a positive distance in mm, got {tolerance!r}; "
            "enter a value such as 0.05 mm.")
    return float(tolerance)


def _core_keywords(method, objective="auto", tolerance=None, borders=None,
                   grading="auto"):
    """Keyword arguments of the core selecting ``method``, ``objective`` and, for a
    surface, ``borders`` (``None`` for a curve); ``grading`` is validated with them
    (:func:`_check_method_options`).

    ``energy`` keeps the net and ``adaptive`` chooses its (non-uniform) targets itself:
    both need a tolerance, so target mode is refused in plain words.  ``objective``
    belongs to ``adaptive`` (and to the wavelet method's tolerance search, which
    :func:`searched_face` runs): ``compact`` (``auto``) spends the tolerance on the fewest poles,
    ``faithful`` stops at the smallest net whose residual is down to the source's
    estimated noise (discrepancy principle, ``cq_fairing.core.fidelity``), ``fair``
    keeps the fairest of the compact net and that net with up to two more spans per
    direction.  So do
    ``borders``: the target's border rows (``cq_fairing.core.adaptive``; the wavelet
    method's tolerance search takes them in :func:`searched_face`).
    """
    if method not in METHODS:
        raise cf.InvalidInputError(f"method must be one of {METHODS}, got {method!r}.")
    if borders is not None and borders not in BORDERS:
        raise cf.InvalidInputError(f"borders must be one of {BORDERS}, got {borders!r}.")
    _check_method_options(method, objective, borders, tolerance is not None, grading)
    if method == "wavelet":
        return {}
    if tolerance is None:
        what = ("keeps the control points" if method == "energy"
                else "chooses the control points itself")
        raise cf.InvalidInputError(
            f"the {method} method {what} and needs tolerance mode (a tolerance in mm); set "
            "Mode to Tolerance, or choose the wavelet method for target control points.")
    if "method" not in inspect.signature(cf.fair_surface).parameters:
        raise cf.InvalidInputError(
            f"the installed cq_fairing core has no {method} fairing yet (fair_surface has no "
            "'method' argument); choose the wavelet method.")
    if method == "adaptive":
        return {"method": method, "objective": objective,
                **({} if borders is None else {"borders": borders})}
    return {"method": method}


def borders_apply(method, by_tolerance):
    """True where the ``borders`` option applies: the adaptive method, and the wavelet
    method's tolerance search (:func:`searched_face`)."""
    return method == "adaptive" or method == "wavelet" and by_tolerance


def _check_method_options(method, objective, borders, by_tolerance=True, grading="auto"):
    """``objective`` ``faithful`` needs the adaptive method and ``fair`` the adaptive
    method or the wavelet method's tolerance search (:func:`borders_apply`, whose
    winner it polishes), as ``borders`` does; ``auto`` and ``compact`` are the plain
    result of every other method and mode.  ``grading`` (one of :data:`GRADINGS`) needs
    the wavelet method's tolerance search."""
    if grading not in GRADINGS:
        raise cf.InvalidInputError(f"grading must be one of {GRADINGS}, got {grading!r}.")
    if objective not in OBJECTIVES:
        raise cf.InvalidInputError(
            f"objective must be one of {OBJECTIVES}, got {objective!r}.")
    if objective == "faithful" and method != "adaptive" or objective == "fair" and \
            not borders_apply(method, by_tolerance):
        where = ("the adaptive method only" if objective == "faithful" else
                 "the adaptive method and the wavelet method in Tolerance mode only")
        raise cf.InvalidInputError(
            f"objective {objective!r} applies to {where}, got method {method!r} in "
            f"{'tolerance' if by_tolerance else 'target'} mode; choose such a method and "
            "mode, or objective 'auto'.")
    if not borders_apply(method, by_tolerance) and borders not in (None, "auto"):
        raise cf.InvalidInputError(
            f"borders {borders!r} applies to the adaptive method and to the wavelet "
            f"method's tolerance search only, got method {method!r} in "
            f"{'tolerance' if by_tolerance else 'target'} mode; choose Tolerance mode with "
            "the wavelet or adaptive method, or borders 'auto'.")
    if not (method == "wavelet" and by_tolerance) and grading not in (None, "auto"):
        raise cf.InvalidInputError(
            f"grading {grading!r} applies to the wavelet method's tolerance search only, got "
            f"method {method!r} in {'tolerance' if by_tolerance else 'target'} mode; choose "
            "Tolerance mode with the wavelet method, or grading 'auto'.")


def _require_accuracy_control():
    if importlib.util.find_spec("cq_fairing.core.accuracy") is None:
        raise cf.InvalidInputError(
            "tolerance mode needs cq_fairing's accuracy control (cq_fairing.core.accuracy), "
            "which this installation lacks; use explicit target control points instead.")


def _target_spans(target, source_poles, degrees, what):
    """Control-point counts -> knot spans (n = poles - target degree), validated."""
    target = tuple(target)
    if len(target) != len(source_poles) or not all(
            isinstance(t, (int, np.integer)) and not isinstance(t, bool) for t in target):
        raise cf.InvalidTargetError(
            f"the target of a {what} is {len(source_poles)} integer control-point count(s), "
            f"got {target!r}.")
    spans = []
    for t, k, p in zip(target, source_poles, degrees):
        degree = min(3, p)
        if not degree + 1 <= t <= k:
            raise cf.InvalidTargetError(
                f"a target of {t} control points is out of range: the {what} has {k}; "
                f"choose between {degree + 1} and {k}.")
        spans.append(t - degree)
    return tuple(spans)


def _faired_row(poles, source_space, target_space):
    """A boundary pole row faired into ``target_space`` (unchanged if it is the source's)."""
    if target_space.same_as(source_space):
        return poles
    return cf.fair_curve(poles, target_space.n_spans, knots=source_space.knots,
                         degree=source_space.degree, target_degree=target_space.degree).poles


def _fix_boundary(source, faired, boundary):
    """Pin corners, or replace the boundary pole rows by the faired boundary curves.

    For clamped nets the boundary curves of a surface are the curves of its first/last
    pole rows and columns, so ``"edges"`` fairs each source boundary curve into the
    target space of its direction (1-D L2-best fit), then pins the corners.  Two faces
    sharing an edge with the same parametrisation and target then share the faired edge.
    """
    if boundary == "free":
        return faired
    src, net = source.poles, faired.poles.copy()
    if boundary == "edges":
        for i in (0, -1):
            net[i] = _faired_row(src[i], source.v_space, faired.v_space)
            net[:, i] = _faired_row(src[:, i], source.u_space, faired.u_space)
    for i in (0, -1):
        for j in (0, -1):
            net[i, j] = src[i, j]
    return cf.BSplineSurface(net, faired.u_knots, faired.v_knots, faired.u_degree,
                             faired.v_degree, faired.weights)


def _ends_coincide(geometry, axis):
    """True when the first and last pole rows along ``axis`` coincide (with their weights)
    within ``1e-9`` of the net's size: a closed (e.g. formerly periodic) direction."""
    rows = np.moveaxis(geometry.homogeneous(), axis, 0)
    size = np.ptp(geometry.poles.reshape(-1, geometry.poles.shape[-1]), axis=0).max()
    return bool(np.abs(rows[0] - rows[-1]).max() <= 1e-9 * max(size, 1.0))


def _tie_ends(geometry, axis):
    r"""First and last pole rows along ``axis`` set to their mean in homogeneous
    coordinates, :math:`P_0 = P_{k-1} = (P_0 + P_{k-1})/2` with :math:`P = (w x, w)`:
    a clamped curve or surface passes through its end rows, so it closes again."""
    rows = np.moveaxis(geometry.homogeneous(), axis, 0).copy()
    rows[0] = rows[-1] = 0.5 * (rows[0] + rows[-1])
    hom = np.moveaxis(rows, 0, axis)
    weights = hom[..., -1]
    return replace(geometry, poles=hom[..., :-1] / weights[..., None],
                   weights=None if geometry.weights is None else weights)


def _closed_like(source, faired):
    """``faired`` closed in each direction where ``source`` is closed (periodic sources
    are clamped copies whose end rows coincide); fairing each direction on its own
    opens such a seam by a fraction of the tolerance."""
    for axis in range(faired.poles.ndim - 1):
        if _ends_coincide(source, axis):
            faired = _tie_ends(faired, axis)
    return faired


def _check_boundary(source, boundary):
    """``boundary`` is known; ``edges`` needs a polynomial face.

    The border rows of a rational face would be faired with their weights, and the
    corner weights shared by two border curves would then disagree (each curve is only
    defined up to a scale of its weights), so the edges are refused rather than left as
    they are.
    """
    if boundary not in BOUNDARIES:
        raise cf.InvalidInputError(f"boundary must be one of {BOUNDARIES}, got {boundary!r}.")
    if boundary == "edges" and source.weights is not None:
        raise cf.UnsupportedGeometryError(
            "boundary 'edges' fairs the border curves of polynomial faces only and this face "
            "is rational (its control points have weights); choose boundary 'corners' or "
            "'free' for it.")


def _check_search(search, measure, method="wavelet"):
    """``search`` is one of :data:`SEARCHES` and ``measure`` one of :data:`MEASURES`;
    both belong to the wavelet method's search and are refused, other than their
    defaults, with another method (the core's
    :func:`~cq_fairing.core.options.check_applies`, as the command line refuses them);
    ``measure`` is that of the core's searches and is refused, other than its default,
    with ``"local"``, which measures on the face's own samples."""
    if search not in SEARCHES or measure not in MEASURES:
        raise cf.InvalidInputError(
            f"search must be one of {SEARCHES} and measure one of {MEASURES}, got "
            f"{search!r} and {measure!r}.")
    check_applies(method, (("search", search), ("measure", measure)),
                  {"search": SEARCHES[0], "measure": MEASURES[0]})
    if search == "local" and measure != MEASURES[0]:
        core = ", ".join(repr(s) for s in SEARCHES[1:])
        raise cf.InvalidInputError(
            f"measure {measure!r} applies to the core's searches ({core}) only, got search "
            "'local', which bisects on the face's own samples and checks each candidate "
            f"both ways; choose one of {core} for search, or measure {MEASURES[0]!r}.")


def _curve_search_keywords(search, measure, method):
    """The core's ``search`` and ``measure`` keywords of an edge, validated
    (:func:`_check_search`); none for the adaptive and energy methods, which do not use
    them (the core refuses them there), nor for ``"local"``: an edge has no face
    samples, and the core's own search (its default) fairs it."""
    _check_search(search, measure, method)
    if method != "wavelet" or search == "local":
        return {}
    return {"search": search, "measure": measure}


def _target_net(source, target):
    """The wavelet projection of a core surface onto ``target`` control points ``(u, v)``
    (Target mode); a count equal to the source's keeps that direction as it is."""
    n = _target_spans(target, source.shape, (source.u_degree, source.v_degree), "face")
    n = tuple(None if t == k else m for t, k, m in zip(target, source.shape, n))
    return cf.fair_surface(source.poles, n, u_knots=source.u_knots, v_knots=source.v_knots,
                           degree=(source.u_degree, source.v_degree), weights=source.weights)


def searched_face(face, source, tolerance, search="local", measure=MEASURES[0],
                  method="wavelet", objective="auto", borders="auto", domain=None,
                  grading="auto"):
    r"""The tolerance search of ``face`` (whose net is ``source``) by ``method``: the
    core's :func:`~cq_fairing.core.face_search.search_face` with the attempts of
    :func:`~cq_fairing.core.face_search.face_attempts`, the search ``cq-fairing`` and
    :func:`cq_fairing.occ.fair_face` run, with the workbench's pieces.

    * the samples: a grid of :func:`~cq_fairing.core.face_search.sample_counts` over the
      face's UV box (``face.ParameterRange``, clipped to the surface's domain) with the
      mask of those on the face (:meth:`conversion.FaceDomain.inside`);
    * the face for the core's searches: its UV box as their ``window``
      (:func:`~cq_fairing.core.face_search.uv_window`) and, for the adaptive method, the
      samples on the face as its ``region`` (:meth:`conversion.FaceDomain.region`);
    * the check: :class:`analysis.SampledDeviation`, two-sided, on the grid and the
      centres of its cells that lie on the face, with its cheap lower bound as the
      pre-filter;
    * the finisher: :func:`~cq_fairing.core.face_search.face_finisher` (closed and
      periodic seams tied, collapsed borders kept).

    ``domain``: the :class:`conversion.FaceDomain` of ``face`` where already read (its
    trim is read from OCCT once for all the masks).  ``grading`` and ``borders``: the
    bisections' targets, and ``objective`` their winner's polish, as
    :func:`cq_fairing.occ.fair_face`'s options of those names.

    Returns
    -------
    (cq_fairing.core.face_search.FaceOutcome, analysis.SampledDeviation)
        The outcome and the check that judged it.

    Raises
    ------
    cq_fairing.ToleranceNotMetError
        No candidate passes the check.
    """
    (a, b), (c, d) = source.domain
    u0, u1, v0, v1 = face.ParameterRange
    domain = conversion.FaceDomain(face) if domain is None else domain
    nu, nv = sample_counts(source)
    u, v = np.clip(np.linspace(u0, u1, nu), a, b), np.clip(np.linspace(v0, v1, nv), c, d)
    grid = (u, v, domain.inside(u, v))
    cu, cv = 0.5 * (u[1:] + u[:-1]), 0.5 * (v[1:] + v[:-1])
    check = analysis.SampledDeviation(
        source, (grid, (cu, cv, domain.inside(cu, cv))))
    outcome = search_face(
        source, tolerance, grid, face_finisher(source, conversion.periodic_directions(face)),
        check, attempts=face_attempts(tolerance, search, method, objective, borders, measure),
        exceeds=check.exceeds, region=domain.region(),
        window=uv_window(conversion.uv_range(face, source), source), details=False,
        judge="the workbench", grading=grading, borders=borders, objective=objective)
    return outcome, check


def fair_face(face, tolerance=None, target=None, method="wavelet", boundary="free",
              search="local", measure=MEASURES[0], objective="auto", borders="auto",
              domain=None, grading="auto"):
    r"""Fair one B-spline face; returns a :class:`FairedShape` (no document involved).

    Parameters
    ----------
    face : Part.Face
    tolerance : float, optional
        Largest allowed deviation in mm (tolerance mode).
    target : (int, int), optional
        Control points (u, v) of the result (target mode).
    method : {"wavelet", "energy", "adaptive"}
        ``wavelet``: quasi-uniform targets (ARWFA/DWFA); ``energy``: thin-plate fairing that
        keeps the net; ``adaptive``: exact L2 projection onto targets whose knots follow
        the error, usually far fewer poles at the same tolerance (rational faces in
        homogeneous coordinates, without the energy polish).
        ``energy`` and ``adaptive`` need ``tolerance``.  In Tolerance mode every method
        runs the command line's face search (:func:`searched_face`).
    boundary : {"free", "corners", "edges"}
        ``free``: L2-best surface, the boundary may move within the tolerance;
        ``corners``: the four corner points stay; ``edges``: boundary curves are the
        faired source boundary curves with pinned corners (polynomial faces only).
    search : {"local", "guaranteed", "linear", "polyfit"}
        The wavelet method's tolerance search, as ``cq-fairing``'s and
        :func:`cq_fairing.occ.fair_face`'s (:func:`searched_face`): ``local`` bisects on
        the face's own samples (inside its trim); the others are the core's search with
        that step rule (``linear``: ARWFA's hypothesis iteration, a few evaluations;
        ``guaranteed``: the fewest poles in total, slower; ``polyfit``), measured in the
        face's UV box.  Either way each candidate is checked both ways on the face's
        samples, and if it fails the local search runs again with the parametric
        distance, an upper bound of the true distance.
    measure : {"geometric", "parametric"}
        The distance the core's searches bound (``geometric``: closest points, the
        default of every layer; ``parametric``: same parameters, an upper bound of it);
        refused, other than ``geometric``, with ``search="local"``.
    objective : {"auto", "compact", "faithful", "fair"}
        ``method="wavelet"`` in tolerance mode: ``auto`` and ``fair`` polish the
        search's fewest-poles net with the largest curvature-variation penalty within
        ``tolerance`` (same poles, fairer), ``compact`` keeps the plain projection, as
        :func:`cq_fairing.occ.fair_face`.  ``method="adaptive"``: ``compact`` (``auto``)
        is the fewest poles within ``tolerance``;
        ``faithful`` the smallest net whose residual variance is down to the source's
        estimated noise, :math:`\|r\|^2/(N-k) \le (1+\delta)^2\hat\sigma^2`
        (falls back to ``compact`` if that net exceeds ``tolerance``); ``fair`` the
        least curvature-variation energy among the compact net and that net with up to
        two more spans per direction.
    borders : {"auto", "free", "pinned"}
        The border rows of the target, with ``method="adaptive"`` and in tolerance mode
        with ``"wavelet"`` (:func:`borders_apply`).  ``auto`` pins them (corners kept,
        each edge fitted to its own border curve) where that gives fewer poles; ``free``
        is the plain projection; ``pinned`` always pins.  The wavelet search on the 50 x
        80 test face: 12 x 15 poles pinned, 38 x 65 free; the adaptive method's free
        borders are often a much faster search on a face whose pinned net slides along
        it (19 x 21 poles in about 1.6 s instead of 11 x 11 in about 11 s).
    domain : conversion.FaceDomain, optional
        That of ``face`` where already read (none: read here).
    grading : {"auto", "spans", "uniform"}
        The wavelet method's bisections on the face's samples (Tolerance mode) try
        quasi-uniform targets and, on a face whose knot spans are graded, targets graded
        like them (``spans``), with ``auto`` also targets graded by the error where
        those keep many control points, or quasi-uniform ones only (``uniform``; in a
        model ``auto`` is ``spans``, and a face that shares a held join with another
        searches quasi-uniform ones, :func:`fair_shapes`), as
        :func:`cq_fairing.occ.fair_face`; the feature's ``Grading``.

    Raises
    ------
    cq_fairing.FairingError
        Any user error (non-B-spline face, rational face with boundary ``edges``, bad
        tolerance or target, target mode with ``energy``/``adaptive``,
        unmet tolerance, a trim that cannot be rebuilt).
    """
    start = time.perf_counter()
    source = conversion.surface_from_face(face)
    _check_boundary(source, boundary)
    _check_search(search, measure, method)
    if (tolerance is None) == (target is None):
        raise cf.InvalidInputError(
            "give either a tolerance (mm) or target control points (u, v), not both/neither.")
    _core_keywords(method, objective, tolerance, borders, grading)
    note = ""
    domain = conversion.FaceDomain(face) if domain is None else domain
    if tolerance is not None:
        outcome, check = searched_face(face, source, _check_tolerance(tolerance), search,
                                       measure, method, objective, borders, domain,
                                       grading)
        faired, deviation, note = outcome.surface, outcome.deviation, _outcome_note(outcome)
        if boundary != "free":
            faired = _closed_like(source, _fix_boundary(source, faired, boundary))
            deviation = check(faired)
    else:
        faired = _closed_like(source, _fix_boundary(source, _target_net(source, target).surface,
                                                    boundary))
        deviation = face_deviation(face, source, faired, domain)
    if tolerance is not None and boundary != "free" and deviation > tolerance:
        raise cf.ToleranceNotMetError(
            f"boundary handling '{boundary}' moved the face {deviation:.4g} mm from the "
            f"source, more than the tolerance {tolerance:.4g} mm; use boundary 'free' or a "
            "larger tolerance.", tolerance=tolerance, best_deviation=deviation)
    if tolerance is not None and outcome.status == "unchanged":
        shape = face.copy()   # nothing to fair: the source face itself, not a rebuild
    else:
        shape = conversion.face_on_surface(conversion.part_surface(faired), face, domain)
    return FairedShape(shape, tuple(source.shape), tuple(faired.shape), deviation,
                       time.perf_counter() - start, note, faired)


def _outcome_note(outcome):
    """The note of a face's search outcome (:func:`searched_face`): why it is kept, or
    what the search did beyond the plain case; ``""`` for a plainly faired face."""
    if outcome.status == "unchanged":
        return f"kept unchanged: {outcome.message}"
    return f"faired: {'; '.join(outcome.notes)}" if outcome.notes else ""


def face_deviation(face, source, faired, domain=None):
    """Largest two-sided deviation (``analysis.two_sided_deviation``) between ``source``
    and ``faired`` at ``DEVIATION_SAMPLES`` squared samples of ``face``'s UV box that lie
    on the face (inside its trim; a trim too thin to hold a sample falls back on its UV
    box).  ``domain``: the :class:`conversion.FaceDomain` of ``face`` where already
    read."""
    uv_range = conversion.uv_range(face, source)
    both = np.abs(analysis.two_sided_deviation(source, faired, uv_range, DEVIATION_SAMPLES)[1])
    domain = conversion.FaceDomain(face) if domain is None else domain
    inside = domain.inside(*analysis.sample_parameters(uv_range, DEVIATION_SAMPLES))
    return float((both[inside] if inside.any() else both).max())


def fair_edge(edge, tolerance=None, target=None, method="wavelet", search="local",
              measure=MEASURES[0], objective="auto"):
    """Fair one B-spline edge; returns a :class:`FairedShape` (poles as ``(k,)``).

    The arguments are those of :func:`fair_face` with one target count; the adaptive
    method also fairs rational curves.  An edge has no face samples: with ``search``
    ``"local"`` (the default) the core's own tolerance search fairs it, with its
    defaults, and its net is not polished (``objective`` ``fair`` is refused with the
    wavelet method).
    """
    start = time.perf_counter()
    source = conversion.curve_from_edge(edge)
    if (tolerance is None) == (target is None):
        raise cf.InvalidInputError(
            "give either a tolerance (mm) or a target control-point count, not both/neither.")
    if method == "wavelet" and objective == "fair":
        raise cf.InvalidInputError(
            "objective 'fair' polishes the wavelet net of a face; an edge's is not "
            "polished: choose objective 'auto' or the adaptive method for edges.")
    # the core's default for curves chooses its own fit: the wavelet method is named
    keywords = {"method": "wavelet", **_core_keywords(method, objective, tolerance)}
    common = dict(knots=source.knots, degree=source.degree, weights=source.weights, **keywords)
    if tolerance is not None:
        _require_accuracy_control()
        result = cf.fair_curve(source.poles, tol=_check_tolerance(tolerance), **common,
                               **_curve_search_keywords(search, measure, method))
    else:
        target = (target,) if np.ndim(target) == 0 else tuple(target)[:1]
        (n,) = _target_spans(target, (source.n_poles,), (source.degree,), "curve")
        result = cf.fair_curve(source.poles, n, **common)
    curve = _closed_like(source, result.curve)
    first, last = edge.ParameterRange
    low, high = source.domain
    t = np.linspace(max(first, low), min(last, high), 200)
    deviation = float(np.linalg.norm(source.evaluate(t) - curve.evaluate(t), axis=1).max())
    shape = conversion.part_curve(curve).toShape(first, last)
    return FairedShape(shape, (source.n_poles,), (curve.n_poles,), deviation,
                       time.perf_counter() - start)


def _existing(obj, sub):
    """The face or edge ``sub`` (``"Face3"``, ``"Edge5"``) of ``obj``'s shape.

    Raises
    ------
    cq_fairing.InvalidInputError
        If the shape has no such element (e.g. its shape changed since it was linked).
    """
    kind = "Face" if sub.startswith("Face") else "Edge"
    elements = obj.Shape.Faces if kind == "Face" else obj.Shape.Edges
    index = sub[len(kind):]
    if not index.isdigit() or not 1 <= int(index) <= len(elements):
        raise cf.InvalidInputError(
            f"{obj.Label} has no {sub}, it has {len(elements)} {kind.lower()}s (its shape "
            "changed since it was linked?); link existing faces or edges as the Source.")
    return elements[int(index) - 1]


def _element(obj, sub):
    """:func:`_existing`, which must be a B-spline face or edge.

    Raises
    ------
    cq_fairing.UnsupportedGeometryError
        If the element is not a B-spline face or edge.
    """
    element = _existing(obj, sub)
    face = sub.startswith("Face")
    geometry = element.Surface if face else element.Curve
    if not isinstance(geometry, Part.BSplineSurface if face else Part.BSplineCurve):
        raise cf.UnsupportedGeometryError(
            f"{sub} of {obj.Label} is a {type(geometry).__name__}, not a B-spline "
            f"{'face' if face else 'edge'}; fairing applies to freeform (B-spline) geometry "
            f"only, so remove {sub} from the selection.")
    return element


def _clamped_target(target, face):
    """One target for several faces: each direction of ``face`` gets at most its own
    control points, and at most the finest quasi-uniform scale its knots resolve (a
    face with clustered knots cannot be projected onto a finer target)."""
    source = conversion.surface_from_face(face)
    clamped = []
    for count, space in zip(target, (source.u_space, source.v_space)):
        degree = min(3, space.degree)
        count = min(count, space.dimension)
        if degree < count < space.dimension:
            resolved = largest_resolved_scale(space, degree, "auto", count - degree)
            count = resolved + degree if resolved else count
        clamped.append(count)
    return tuple(clamped)


def fair_elements(obj, subs, settings, face_settings, joins="smooth", angle_tolerance=1.0):
    """Fair the faces and edges ``subs`` of ``obj`` (feature and task panel).

    Parameters
    ----------
    obj : App.DocumentObject
    subs : list of str
        ``"Face2"``, ``"Edge5"``, ...
    settings : dict
        Keyword arguments of :func:`fair_face` and :func:`fair_edge` (``tolerance``,
        ``target`` as ``(u, v)`` or ``None``, ``method``, ``search``, ``measure``,
        ``objective``).
    face_settings : dict
        Those of faces only: ``boundary``, ``borders``.
    joins, angle_tolerance
        How the faces stay together along their joins, see :func:`fair_shapes`.

    Returns
    -------
    FairedShapes
        One per element, in the order of ``subs`` (see :func:`fair_shapes`).
    """
    return fair_shapes(named_elements(obj, subs), settings, face_settings, joins=joins,
                       angle_tolerance=angle_tolerance,
                       neighbours=neighbour_faces(obj, subs))


def named_elements(obj, subs):
    """``[(sub, Part.Face or Part.Edge)]`` of ``obj``, checked (:func:`_element`); read in
    the thread that owns the document, before :func:`fair_shapes` runs elsewhere."""
    return [(sub, _element(obj, sub)) for sub in subs]


def neighbour_faces(obj, subs):
    """``[(sub, Part.Face)]``: the faces of ``obj``'s shape, any surface, that share a
    non-degenerated edge with a face of ``subs``, or have a free edge that is one
    boundary with one of its free edges (loose faces), and are not among ``subs``
    (:func:`joins.face_neighbours`), in the shape's order; read in the thread that owns
    the document, as :func:`named_elements`."""
    faces = obj.Shape.Faces
    chosen = {int(sub[len("Face"):]) - 1 for sub in subs if sub.startswith("Face")}
    return [(f"Face{k + 1}", faces[k]) for k in sorted(face_neighbours(faces, chosen))]


def fair_shapes(named, settings, face_settings, progress=None, joins="smooth",
                angle_tolerance=1.0, neighbours=()):
    """Fair the shapes ``named`` (``[(sub, face or edge)]``, from :func:`named_elements`); no
    document access, so it may run in a worker thread.

    With several faces in target mode, each face is clamped to its own control-point
    counts.  In tolerance mode a face with no coarser net within the tolerance is kept as
    it is (:func:`_kept`), with the reason, as ``cq-fairing fair`` keeps it: one face or
    several, the others are faired.  So is a B-spline face the energy method refuses (a
    rational one, one with a degree-1 direction), with the core's reason, and, among
    several faces, one whose result cannot be built (:func:`_unsupported`).  A face with
    nothing to fair is the source face itself.  ``settings`` and ``face_settings`` as in
    :func:`fair_elements`.

    Several faces of one shape, or one face with neighbours, are faired alone first; in
    tolerance mode and with ``joins`` other than ``"free"`` they are then faired again
    together along the edges they share (:func:`fairing_wb.joins.hold_joins`, as
    ``cq-fairing fair`` does): the patch grids that form whole parts of the shape as one
    surface each, the other faces projected together, and the faces already at their
    coarsest together by energy; closed to round-off, and smooth across the joins that
    were smooth in the source.  Their joins are measured either way.  The
    ``neighbours``, faces of the same shape not faired, take part as fixed faces: a
    faired face's join with one stays as the source has it.

    Parameters
    ----------
    progress : callable, optional
        ``progress(done, total)`` before each element and after the last; an exception it
        raises stops the fairing there (an element being faired runs to its end).
    joins : {"smooth", "closed", "free"}
        ``smooth``: joins closed, and smooth where the source is (normal angle below
        ``angle_tolerance``); ``closed``: joins closed; ``free``: each face alone (its
        joins may open by up to about twice the tolerance).
    angle_tolerance : float
        Degrees: a join whose source normals differ by less all along it is smooth,
        else a crease (kept a crease).
    neighbours : sequence of (str, Part.Face)
        The faces of the shape that meet a face of ``named`` along a join and are not
        faired (:func:`neighbour_faces`); none: only the joins among ``named``.

    Returns
    -------
    FairedShapes
        One per element, in the order of ``named``, with the joins' report.
    """
    check_joins(joins, angle_tolerance)
    target = settings["target"]
    results = []
    domains = {sub: conversion.FaceDomain(element) for sub, element in named
               if sub.startswith("Face")}   # each trim read once: fairing, checks, rebuilds
    start = time.perf_counter()
    found, faces = _joins_of(named, angle_tolerance, neighbours)
    searched = (settings["tolerance"] is not None and found is not None
                and settings["method"] == "wavelet")
    held = joins != "free" and searched
    # faces that meet another face are not polished and, with their joins held, search
    # quasi-uniform, free-border targets, as cq-fairing fair's (the joint projection
    # shares their knots and sets their borders)
    plain = {faces[f] for f in joined_faces(found.joins) if f < len(faces)} if searched \
        else set()
    for done, (sub, element) in enumerate(named):
        if progress is not None:
            progress(done, len(named))
        if sub.startswith("Face"):
            own = target if target is None or len(named) == 1 else _clamped_target(target,
                                                                                   element)
            try:
                result = fair_face(element, **{**settings, "target": own,
                                               **_plain(face_settings, done in plain,
                                                        found is not None, settings, held)},
                                   domain=domains[sub])
                results.append(replace(result, note=f"{sub} {result.note}")
                               if result.note else result)
            except cf.ToleranceNotMetError as error:
                results.append(_kept(element, sub, error))
            except cf.UnsupportedGeometryError as error:
                results.append(_unsupported(element, sub, error, settings["method"],
                                            len(named) > 1))
        else:
            own = None if target is None else target[0]
            results.append(fair_edge(element, **{**settings, "target": own}))
    if progress is not None:
        progress(len(named), len(named))
    return _joined(named, results, settings, joins, list(neighbours), domains,
                   (found, faces, start))


def _joins_of(named, angle_tolerance, neighbours):
    """``(found, faces)``: the joins (:func:`find_joins`) of the faces of ``named``
    among themselves and with their ``neighbours``, and the positions in ``named`` of
    those faces; ``found`` is ``None`` for one face without neighbours, or none."""
    faces = [k for k, (sub, _) in enumerate(named) if sub.startswith("Face")]
    if not faces or (len(faces) == 1 and not neighbours):
        return None, faces
    return find_joins([named[k][1] for k in faces], angle_tolerance,
                      neighbours=[face for _, face in neighbours]), faces


def _joined(named, results, settings, joins, neighbours, domains, joins_found):
    """``results`` with the joins of the faces of ``named``, among themselves and with
    their ``neighbours`` (fixed), held (:func:`_hold`) and measured, as
    :class:`FairedShapes`; ``domains``: ``{sub: conversion.FaceDomain}`` of the faces
    of ``named``; ``joins_found``: ``(found, faces)`` of :func:`_joins_of` and the
    ``time.perf_counter()`` at which it started (the joins' time counts from there)."""
    tolerance = settings["tolerance"]
    found, faces, start = joins_found
    if found is None:
        return FairedShapes(results)
    elements = [named[k] for k in faces] + neighbours
    alone = [results[k] for k in faces]
    faired, outcome = alone, HeldJoins({}, {}, [], [], [])
    if joins != "free" and tolerance is not None and found.joins:
        faired, outcome = _hold(found, elements, alone, tolerance, joins, settings["method"],
                                [domains.get(sub) or conversion.FaceDomain(face)
                                 for sub, face in elements])
    out = list(results)
    for k, result in zip(faces, faired):
        out[k] = result
    surfaces = {**found.sources,
                **{i: r.surface for i, r in enumerate(faired) if r.surface is not None}}
    report = JoinReport(found, measure_joins(found, surfaces), outcome.held,
                        time.perf_counter() - start, outcome.grids, outcome.networks)
    return FairedShapes(out, report)


def _hold(found, elements, alone, tolerance, joins, method, domains):
    """The faces faired ``alone`` faired again together (:func:`joins.hold_joins`):
    ``(results, HeldJoins)``.  A face with a join across its surface
    (:func:`~cq_fairing.core.joint_projection.unholdable`) is first projected alone with
    its joins pinned to its source (:func:`fairing_wb.pinned.pin_faces`), and then
    stands for the others as a face kept; one the pins cannot hold is kept, with the
    command line's reason.  A face solved is measured by :func:`face_deviation`
    and must stay within ``tolerance``; a face kept as it was says why: its joins hold
    it over the tolerance, its pinned sides leave it nothing to fair, or it was
    already at its coarsest (:func:`_nothing_faired`) and no network moved it (with the
    network's reason where one kept it:
    :func:`~cq_fairing.core.network_fairing.kept_sentence`).
    ``elements`` are the faces faired then their neighbours (fixed: no tolerance, no
    target); ``domains`` their :class:`conversion.FaceDomain`, in the same order."""
    faired = list(alone)
    moved = {i for i, r in enumerate(alone) if r.surface is not None}
    stuck = unholdable(found.joins, found.readable, moved, moved)
    measured = {}

    def check(face, surface):
        measured[face] = face_deviation(elements[face][1], found.sources[face], surface,
                                        domains[face])
        return measured[face]

    pins = pin_faces(found, elements, stuck, {i: alone[i].surface for i in stuck}, tolerance,
                     JOIN_CONTINUITY[joins], method, check)
    for i in stuck:
        faired[i] = (_installed(alone[i], elements[i], domains[i], pins.surfaces[i],
                                measured[i], f"{elements[i][0]} {pins.notes[i]}")
                     if i in pins.surfaces else _kept_as_is(elements[i], pins.notes[i]))
    coarsest = {i for i in moved - set(stuck)
                if _nothing_faired(found.sources[i], alone[i].surface, method)}
    outcome = hold_joins(found, {i: r.surface for i, r in enumerate(faired)
                                 if r.surface is not None and i not in coarsest | set(stuck)},
                         coarsest | (set(stuck) - set(pins.surfaces)),
                         dict.fromkeys(range(len(alone)), tolerance), check, joins, method,
                         pinned=set(pins.surfaces))
    for i, surface in outcome.surfaces.items():
        faired[i] = _installed(alone[i], elements[i], domains[i], surface, measured[i])
    for i, deviation in outcome.kept.items():
        faired[i] = _kept_by_joins(elements[i], deviation, tolerance)
    for i in coarsest - set(outcome.surfaces):
        faired[i] = _kept_as_is(elements[i], COARSEST)
    for network in outcome.networks:   # a network's reason is the most specific
        for i, reason in network.reasons.items():
            alone = "" if i in coarsest else " (Joins=free fairs it alone)"
            faired[i] = _kept_as_is(elements[i], kept_sentence(
                reason, lambda face: elements[face][0]) + alone)
    return faired, outcome


def _installed(result, element, domain, surface, deviation, note=""):
    """``result`` (the face ``element`` faired alone, ``domain`` its
    :class:`conversion.FaceDomain`) with ``surface`` solved with its joins held, at
    ``deviation``, under the face's trim."""
    shape = conversion.face_on_surface(conversion.part_surface(surface), element[1], domain)
    return replace(result, shape=shape, poles_after=tuple(surface.shape),
                   max_deviation=deviation, note=note, surface=surface)


def _nothing_faired(source, surface, method):
    """True when a face's own fairing gave back its source's net: ``surface`` on the
    source's spaces, by the wavelet or adaptive method (their targets are then the
    source's own spaces, the L2 projection onto them the identity; the energy method
    keeps the spaces and moves the poles)."""
    return (method != "energy" and surface.u_space.same_as(source.u_space)
            and surface.v_space.same_as(source.v_space))


def _plain(face_settings, joined, several, settings, held):
    """``face_settings`` of a face; in a model (``several``: more than one face, or
    neighbours) its grading is
    :func:`~cq_fairing.core.joint_projection.model_grading`'s for the ``settings``,
    and one ``joined`` to another takes the options of
    :func:`~cq_fairing.core.joint_projection.plain_target_options` (not polished, and
    with its joins ``held`` quasi-uniform, free-border targets: :func:`fair_shapes`)."""
    grading = face_settings.get("grading", "auto")
    own = {**face_settings, "grading": model_grading(grading, several, settings["method"],
                                                     settings["tolerance"] is not None)}
    if not joined:
        return own
    return {**own, **plain_target_options(grading, face_settings.get("borders", "auto"),
                                          settings.get("objective", "auto"), held)}


def _kept_by_joins(element, why, tolerance):
    """:class:`FairedShape` of a face kept as it is for its joins: ``why`` is the
    deviation it stays at with its joins held (over ``tolerance``; ``inf``: weights not
    all positive), ``None`` where its pinned joins leave it no net smaller than its
    source's, or the reason itself (``joins.TURNED``)."""
    if why is None:
        text = "its joins, held where the source has them, leave no net smaller than the " \
               "source's"
    elif isinstance(why, str):
        text = why
    elif np.isfinite(why):
        text = (f"with its joins held closed it stays {why:.4g} mm from its source, over "
                f"{tolerance:.4g} mm; its neighbours close onto it")
    else:
        text = "with its joins held closed its weights are not all positive"
    return _kept_as_is(element, text)


def _kept_as_is(element, why):
    """:class:`FairedShape` of the face ``element`` (``(sub, Part.Face)``) left as it is:
    same poles, deviation 0, and ``why`` in its note."""
    sub, face = element
    poles = tuple(conversion.surface_from_face(face).shape)
    return FairedShape(face.copy(), poles, poles, 0.0, 0.0, f"{sub} kept unchanged: {why}")


def _kept(face, sub, error):
    """:class:`FairedShape` of a face left as it is because ``error`` (a
    :class:`cq_fairing.ToleranceNotMetError`) found no coarser net within the tolerance
    (:func:`_kept_as_is`)."""
    return _kept_as_is((sub, face), f"no coarser net within {error.tolerance:.4g} mm "
                                    f"(best found {error.best_deviation:.4g} mm)")


def _unsupported(face, sub, error, method, several):
    """:class:`FairedShape` of a B-spline face that cannot be faired as asked (``error``):
    one the energy method refuses (its weights, a degree-1 direction), or, among several
    faces, one whose result cannot be built (a trim that does not rebuild), left as it is
    with the reason, as ``cq-fairing fair`` leaves it; any other ``error`` (a face that is
    no B-spline, a single face) is raised again."""
    if not isinstance(face.Surface, Part.BSplineSurface) or not (method == "energy"
                                                                  or several):
        raise error
    return _kept_as_is((sub, face), " ".join(str(error).split()))


def error_sentence(error):
    """The one-line sentence shown for ``error`` (``Status``, the panels' error label).

    A user error (:class:`cq_fairing.FairingError`) says itself what was expected, what
    came and what to do; any other failure is named with that advice.
    """
    if isinstance(error, cf.FairingError):
        return " ".join(str(error).split())
    what = " ".join(f"{type(error).__name__}: {error}".split())
    return (f"the fairing failed unexpectedly ({what}); check the Source's faces "
            "(Part > Check geometry) or try other settings, and report it if it persists.")


def _source_link(source):
    """Normalise ``source`` to ``(object, [subelement names])``."""
    if isinstance(source, (tuple, list)) and len(source) == 2:
        obj, subs = source
        subs = [subs] if isinstance(subs, str) else list(subs)
    else:
        obj = source
        subs = [f"Face{i + 1}" for i, f in enumerate(obj.Shape.Faces)
                if type(f.Surface).__name__ == "BSplineSurface"]
    if not subs or not all(s.startswith(("Face", "Edge")) for s in subs):
        raise cf.InvalidInputError(
            f"select B-spline faces or edges of one object to fair, got {subs!r} of "
            f"{getattr(obj, 'Label', obj)!r}.")
    for sub in subs:
        _existing(obj, sub)
    return obj, subs


def make_fairing(source, tolerance=None, target=None, method="wavelet", boundary="free",
                 search="local", measure=MEASURES[0], objective="auto", name="Fairing",
                 doc=None, borders="auto", joins="smooth", angle_tolerance=1.0,
                 grading="auto"):
    """Create a parametric Fairing feature (``Part::FeaturePython``) in the document.

    Parameters
    ----------
    source : DocumentObject or (DocumentObject, [sub names])
        The object and its faces (``"Face2"``) or edges (``"Edge5"``); an object alone
        means all its B-spline faces.
    tolerance : float, optional
        Largest allowed deviation in mm.  When neither ``tolerance`` nor ``target`` is
        given, the preference "DefaultTolerance" is used (0 there means 1e-3 of the
        source's bounding-box diagonal).
    target : int or (int, int), optional
        Control points of the result; selects target mode.
    method : {"wavelet", "energy", "adaptive"}
    boundary : {"free", "corners", "edges"}
    search, measure : str
        Accuracy control of tolerance mode, see :func:`fair_face`.
    objective, borders, grading : str
        See :func:`fair_face`.
    joins : {"smooth", "closed", "free"}
        How several faces of the source, or one face and its neighbours, stay together
        along the edges they share, see :func:`fair_shapes`.
    angle_tolerance : float
        Degrees: the smooth/crease threshold of the joins.

    Returns
    -------
    App.DocumentObject
        Not yet recomputed; the source object is hidden, not deleted.
    """
    from . import feature, preferences

    if tolerance is not None and target is not None:
        raise cf.InvalidInputError(
            f"give either a tolerance (mm) or target control points, not both; got "
            f"tolerance {tolerance!r} and target {target!r}.")
    _check_method_options(method, objective, borders, target is None, grading)
    _check_search(search, measure, method)
    check_joins(joins, angle_tolerance)
    obj_source, subs = _source_link(source)
    doc = doc or obj_source.Document
    obj = doc.addObject("Part::FeaturePython", name)
    feature.Fairing(obj)
    obj.Source = (obj_source, subs)
    if target is not None:
        target = (target, target) if np.ndim(target) == 0 else tuple(target)
        obj.Mode = "Target"
        obj.TargetU, obj.TargetV = int(target[0]), int(target[-1])
    else:
        obj.Mode = "Tolerance"
        first = _existing(obj_source, subs[0])
        if subs[0].startswith("Face") and hasattr(first.Surface, "NbUPoles"):
            obj.TargetU, obj.TargetV = first.Surface.NbUPoles, first.Surface.NbVPoles
        obj.Tolerance = (tolerance if tolerance is not None
                         else preferences.default_tolerance(obj_source.Shape))
    obj.Method, obj.Boundary, obj.Search, obj.Measure = method, boundary, search, measure
    obj.Objective, obj.Borders, obj.Grading = objective, borders, grading
    obj.Joins, obj.AngleTolerance = joins, angle_tolerance
    obj_source.Visibility = False  # App-level property: undo shows the source again
    if FreeCAD.GuiUp:
        from . import view_provider

        view_provider.ViewProviderFairing(obj.ViewObject)
    return obj
