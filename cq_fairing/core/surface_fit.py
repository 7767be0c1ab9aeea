"""One adaptive surface fit: the deviations and final checks of the candidate nets of
:func:`~cq_fairing.core.adaptive_surface.fair_surface_adaptive`
(:mod:`cq_fairing.core.adaptive`, notes 4 and 5), projected by
:class:`~cq_fairing.core.target_projections.TargetProjections`.
"""

from functools import cached_property

import numpy as np

from .adaptive_knots import _refined
from .evaluation import sample_parameters
from .geometry import fewest_spans
from .probes import SurfaceProbe
from .target_projections import TargetProjections

FINAL_MIN_PER_SPAN = 8  # the final surface check never samples coarser than deviation() does


SCREEN_STRIDE = 4    # a verdict-only trial looks at every 4th search sample first ...


SCREEN_SAMPLES = 16  # ... and the true distance at its 16 largest bounds


# -- surfaces -------------------------------------------------------------------------------------
class _SurfaceFit(TargetProjections):
    """Exact tensor projections of one source surface, with their deviation on a grid."""

    def __init__(self, surface, tol, degrees, per_span, max_samples, borders="free",
                 region=None, edges=None):
        super().__init__(surface, borders)
        self.tol, self.degrees = tol, degrees
        self.region = region
        u, v = _grid((surface,), per_span, edges)
        while u.size * v.size > max_samples and per_span > 1:
            per_span -= 1
            u, v = _grid((surface,), per_span, edges)
        self._uv = (u, v)
        self._span_starts = (np.searchsorted(u, surface.u_space.breakpoints[:-1]),
                             np.searchsorted(v, surface.v_space.breakpoints[:-1]))
        self.lowest = fewest_spans(surface)
        self.evaluations = 0
        self._refused = {}   # screened_trial's refusals, by candidate

    @cached_property
    def probe(self):
        """The search grid's :class:`~cq_fairing.core.measures.SurfaceProbe`, built on
        first use (a faithful fit that passes never measures on it)."""
        return SurfaceProbe(self.surface, uv=self._uv, keep_feet=True, region=self.region)

    @cached_property
    def coarse_probe(self):
        """Every ``SCREEN_STRIDE``-th search sample per direction, starting Newton from
        the search probe's last feet and keeping none of its own
        (:meth:`screened_trial`)."""
        u, v = self._uv
        probe = SurfaceProbe(self.surface, uv=(u[::SCREEN_STRIDE], v[::SCREEN_STRIDE]),
                             region=self.region)
        probe.adopt_feet(self.probe)
        return probe

    def errors(self, faired):
        """Per-sample deviation grid: true distance where the bound exceeds part of tol."""
        self.evaluations += 1
        other, bound = self.probe.bound(faired)
        flat = _refined(bound.ravel(),
                        lambda idx: self.probe.true_distance(faired, other, idx, tol=self.tol),
                        self.tol)
        return flat.reshape(bound.shape)

    def span_max(self, values):
        """Largest of the search-grid ``values`` in each source span pair (a sample on a
        breakpoint counts for the span to its right), shape (n_su, n_sv)."""
        along_u = np.maximum.reduceat(values, self._span_starts[0], axis=0)
        return np.maximum.reduceat(along_u, self._span_starts[1], axis=1)

    @property
    def span_shape(self):
        return self._span_starts[0].size, self._span_starts[1].size

    def trial(self, tu, tv, lam=0.0, weights=None, edge_lam=None):
        """``(faired, per-sample deviation on the search grid, its max)``."""
        return self._measured(self._faired(tu, tv, lam, weights, edge_lam))

    def _faired(self, tu, tv, lam=0.0, weights=None, edge_lam=None):
        """The candidate surface: :meth:`project` onto ``tu x tv``."""
        return self.geometry((tu, tv), self.project(tu, tv, lam, weights, edge_lam))

    def inadmissible(self, faired):
        """True for a candidate that fails whatever its samples say: a rational one with a
        weight ``<= 0`` (it may pass through infinity between samples), or one with fewer
        spans along a closed direction than :func:`~cq_fairing.core.geometry.fewest_spans`
        (it cannot close as a valid face)."""
        spans = (faired.u_space.n_spans, faired.v_space.n_spans)
        return (any(n < low for n, low in zip(spans, self.lowest))
                or self.rational and not np.all(faired.weights > 0))

    def _measured(self, faired):
        if self.inadmissible(faired):
            # its samples say nothing about where the error is: all get twice the
            # tolerance, which keeps the knot density as it is (as for curves)
            self.evaluations += 1
            return faired, np.full((self.probe.u.size, self.probe.v.size), 2 * self.tol), np.inf
        values = self.errors(faired)
        return faired, values, float(values.max())

    def screened_trial(self, tu, tv, lam=0.0):
        """:meth:`trial` for a search that reads only the verdict of a failing candidate
        (the count bisections of the starts, the polish's bisection on lambda).

        The candidate is first measured on the coarse grid (:attr:`coarse_probe`): the
        true distance at its ``SCREEN_SAMPLES`` largest same-parameter bounds above tol.
        If one exceeds tol the candidate fails, and ``(faired, None, e)`` comes back with
        that distance ``e``, a lower bound of its maximum; the search grid is not
        measured and keeps its feet.  Otherwise the full :meth:`trial` follows.  A
        failing trial measured in full costs two to three passing ones on the IEA face
        (its largest bounds all stay above tol, so each runs Newton from both starts to
        convergence); half the trials of its starts fail.

        A refusal changes nothing the next measurement starts from, so it is kept and
        given again when a search asks for the same candidate (a count scan below a
        bisection, the second axis start repeating the first's second direction).
        """
        key = (tu.key, tv.key, lam, self.pinned)
        if key in self._refused:
            return self._refused[key]
        faired = self._faired(tu, tv, lam)
        excess = np.inf if self.inadmissible(faired) else self._coarse_excess(faired)
        if excess is not None:
            self.evaluations += 1
            self._refused[key] = (faired, None, excess)
            return self._refused[key]
        return self._measured(faired)

    def _coarse_excess(self, faired):
        """A true distance above tol among the ``SCREEN_SAMPLES`` largest bounds of the
        coarse grid, or ``None``."""
        probe = self.coarse_probe
        other, bound = probe.bound(faired)
        flat = bound.ravel()
        above = np.flatnonzero(flat > self.tol)
        if above.size == 0:
            return None
        largest = above[np.argsort(flat[above])[::-1][:SCREEN_SAMPLES]]
        exact = probe.true_distance(faired, other, largest, window=0, tol=self.tol,
                                    verdict=True).max()
        return float(exact) if exact > self.tol else None


def _final_check(surface, per_span, max_samples, region=None, edges=None):
    """``check(faired)``: the exact two-sided maximum at ``per_span`` samples per span of
    the merged breakpoints of source and result, halved while the source's grid would
    exceed ``max_samples`` but never below the 8 per span of
    :func:`~cq_fairing.core.measures.deviation`, so a result is never accepted at a coarser
    density than the public measure reports (a 312 x 323 terrain was checked at 3 per span
    and passed at 23.06 where 8 per span find 23.44 > tol 23.11)."""
    spans = surface.u_space.n_spans, surface.v_space.n_spans
    while per_span > FINAL_MIN_PER_SPAN and \
            (spans[0] * per_span + 1) * (spans[1] * per_span + 1) > max_samples:
        per_span //= 2
    per_span = max(per_span, FINAL_MIN_PER_SPAN)

    def check(faired, search=None):
        uv = _grid((surface, faired), per_span, edges)
        probe = SurfaceProbe(surface, uv=uv, hold_grid=False, region=region)
        if search is not None:
            probe.adopt_feet(search)
        return probe.max_deviation(faired)[0]

    return check


def _grid(surfaces, per_span, edges=None):
    """Sample axes: ``per_span`` per span of the merged breakpoints of ``surfaces``, and
    the parameters ``edges`` ``(u values, v values)`` if given."""
    u = sample_parameters(*(s.u_space for s in surfaces), per_span=per_span)
    v = sample_parameters(*(s.v_space for s in surfaces), per_span=per_span)
    if edges is None:
        return u, v
    return np.union1d(u, edges[0]), np.union1d(v, edges[1])
