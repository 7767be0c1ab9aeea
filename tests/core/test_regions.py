"""TrimRegion: the even-odd grid classification with exact answers near the polygon.

The true region is an annulus or an ellipse with an elliptic hole, classified exactly
by its equations; the polygon handed to TrimRegion is a coarse, jittered discretisation
of its boundary (within ``accuracy`` of it).  Every grid sample must get the true
answer: far from the boundary through the even-odd rule on the polygon, near it through
the exact classifier, and the test counts how often that classifier was asked.
"""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cq_fairing.core.regions import TrimRegion
from cq_fairing.errors import InvalidInputError


def _ellipse(centre, axes, count, jitter, rng):
    """``count`` points near the ellipse, each moved by up to ``jitter`` along its normal."""
    t = np.sort(rng.uniform(0, 2 * np.pi, count))
    radial = 1.0 + jitter * rng.uniform(-1, 1, count) / min(axes)
    return np.c_[centre[0] + axes[0] * radial * np.cos(t), centre[1] + axes[1] * radial * np.sin(t)]


def _inside(u, v, centre, axes, hole):
    """True region: inside the ellipse, outside the hole (same centre, axes * hole)."""
    r = ((u - centre[0]) / axes[0]) ** 2 + ((v - centre[1]) / axes[1]) ** 2
    return (r <= 1.0) & (r > hole ** 2)


def _polygon_error(polygon, axes, jitter):
    """Twice a bound of the distance between the jittered polygon and the ellipse: the
    vertices' own offset plus the sagitta of the longest chord on the smallest radius
    of curvature (min(axes)^2 / max(axes))."""
    chord = np.linalg.norm(np.roll(polygon, -1, axis=0) - polygon, axis=1).max()
    smallest_radius = min(axes) ** 2 / max(axes)
    return 2 * (jitter * max(axes) / min(axes) + chord ** 2 / (8 * smallest_radius))


@given(seed=st.integers(0, 2 ** 31), n_u=st.integers(2, 60), n_v=st.integers(2, 60),
       hole=st.sampled_from([0.0, 0.4, 0.7]), uneven=st.booleans())
def test_every_sample_gets_the_true_answer(seed, n_u, n_v, hole, uneven):
    rng = np.random.default_rng(seed)
    centre = rng.uniform(0.3, 0.7, 2)
    axes = rng.uniform(0.15, 0.5, 2)
    jitter = 0.002 * min(axes)
    loops = [_ellipse(centre, axes, 300, jitter, rng)]
    if hole:
        loops.append(_ellipse(centre, axes * hole, 300, jitter * hole, rng))
    accuracy = max(_polygon_error(loop, axes * (hole if i else 1.0), jitter * (hole if i else 1.0))
                   for i, loop in enumerate(loops))
    u = np.sort(rng.uniform(0, 1, n_u)) if uneven else np.linspace(0, 1, n_u)
    v = np.sort(rng.uniform(0, 1, n_v)) if uneven else np.linspace(0, 1, n_v)
    u, v = np.unique(u), np.unique(v)
    asked = []

    def exact(a, b):
        asked.append(a.size)
        return _inside(a, b, centre, axes, hole)

    region = TrimRegion(loops, exact, accuracy)
    truth = _inside(*np.meshgrid(u, v, indexing="ij"), centre, axes, hole)
    assert np.array_equal(region(u, v), truth)
    assert sum(asked) <= u.size * v.size


def test_the_exact_classifier_is_asked_near_the_trim_only():
    """A disc on a 400 x 400 grid (polygon within 5e-7 of the circle, accuracy 2e-5):
    every node within the accuracy of the circle is asked, and fewer than 1 % of all."""
    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    asked = []

    def exact(a, b):
        asked.extend(zip(a.tolist(), b.tolist()))
        return (a - 0.5) ** 2 + (b - 0.5) ** 2 <= 0.16

    region = TrimRegion([np.c_[0.5 + 0.4 * np.cos(t), 0.5 + 0.4 * np.sin(t)]], exact, 2e-5)
    grid = np.linspace(0, 1, 400)
    uu, vv = np.meshgrid(grid, grid, indexing="ij")
    radius = np.hypot(uu - 0.5, vv - 0.5)
    assert np.array_equal(region(grid, grid), radius <= 0.4)
    must = {(a, b) for a, b in zip(uu[np.abs(radius - 0.4) <= 2e-5], vv[np.abs(radius - 0.4) <= 2e-5])}
    assert must and must <= set(asked)
    assert len(asked) < 0.01 * grid.size ** 2


def test_vertices_on_rows_and_samples_on_edges():
    """A square whose corners and edges sit on grid nodes: the half-open row rule counts
    a vertex once, and samples on the edges take the exact answer (inside)."""
    square = [[0.25, 0.25], [0.75, 0.25], [0.75, 0.75], [0.25, 0.75]]
    region = TrimRegion([square], lambda a, b: (np.abs(a - 0.5) <= 0.25) & (np.abs(b - 0.5) <= 0.25),
                        0.0)
    grid = np.linspace(0, 1, 9)
    expected = np.zeros((9, 9), dtype=bool)
    expected[2:7, 2:7] = True
    assert np.array_equal(region(grid, grid), expected)


@pytest.mark.parametrize("loops, exact, accuracy, match", [
    ([], lambda a, b: a > 0, 0.0, "at least one loop"),
    ([[[0, 0]]], lambda a, b: a > 0, 0.0, "k >= 2"),
    ([[[0, 0], [1, np.nan]]], lambda a, b: a > 0, 0.0, "finite"),
    ([[[0, 0], [1, 1]]], "inside", 0.0, "exact must be a callable"),
    ([[[0, 0], [1, 1]]], lambda a, b: a > 0, -1.0, "accuracy"),
])
def test_bad_input_is_refused(loops, exact, accuracy, match):
    with pytest.raises(InvalidInputError, match=match):
        TrimRegion(loops, exact, accuracy)


def test_grids_must_increase():
    region = TrimRegion([[[0, 0], [1, 0], [1, 1]]], lambda a, b: a > b, 0.0)
    with pytest.raises(InvalidInputError, match="increasing"):
        region(np.array([0.0, 0.5, 0.5]), np.array([0.0, 1.0]))
