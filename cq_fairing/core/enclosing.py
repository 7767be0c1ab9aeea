r"""The smallest ball enclosing a few points: the centre :math:`c` minimising
:math:`\max_i |p_i - c|` (a point that covers the points with the least radius).

Welzl's algorithm: the smallest ball of a set is fixed by at most :math:`d + 1` points
on its sphere; the points are taken in a fixed pseudo-random order, each one outside
the ball of the points before it goes onto the sphere.  Expected linear time in the
number of points (a few dozen at most here).  The points are shifted to their first
one first, so the arithmetic runs on their offsets, not on large coordinates.
"""

import numpy as np

__all__ = ["smallest_enclosing_ball"]

INSIDE = 1e-12  # relative slack of the "already inside" test (of the offsets' size)


def smallest_enclosing_ball(points):
    r"""Centre and radius of the smallest ball that contains ``points``.

    Parameters
    ----------
    points : array_like, shape (n, d)
        ``n >= 1`` points (``d`` is 3 for model points).

    Returns
    -------
    centre : ndarray, shape (d,)
    radius : float
        :math:`\max_i |p_i - c|`, evaluated at the returned centre as it is (so the
        ball contains every point whatever the round-off of the construction).
    """
    points = np.asarray(points, dtype=float)
    origin = points[0]
    offsets = points - origin
    order = np.random.default_rng(0).permutation(len(offsets))
    slack = INSIDE * max(np.abs(offsets).max(), np.finfo(float).tiny)
    centre = origin + _welzl(offsets[order], [], slack)[0]
    return centre, float(np.linalg.norm(points - centre, axis=1).max())


def _welzl(points, sphere, slack):
    """Smallest ball of ``points`` with every point of ``sphere`` on its sphere, as
    ``(centre, radius)``; the points are added one by one (move-to-front free form)."""
    centre, radius = _ball_through(sphere, points.shape[1])
    if len(sphere) == points.shape[1] + 1:
        return centre, radius
    for i, point in enumerate(points):
        if np.linalg.norm(point - centre) > radius + slack:
            centre, radius = _welzl(points[:i], sphere + [point], slack)
    return centre, radius


def _ball_through(sphere, dimension):
    r"""The smallest ball with the points of ``sphere`` on its sphere: its centre lies in
    their affine hull, :math:`c = q_0 + A^T\lambda` with
    :math:`A A^T \lambda = \tfrac12 \operatorname{diag}(A A^T)`, :math:`A` the rows
    :math:`q_k - q_0` (least squares where the points are affinely dependent).  No
    point: an empty ball (radius -1)."""
    if not sphere:
        return np.zeros(dimension), -1.0
    first = sphere[0]
    if len(sphere) == 1:
        return first, 0.0
    rows = np.array(sphere[1:]) - first
    gram = rows @ rows.T
    weights = np.linalg.lstsq(gram, 0.5 * np.diag(gram), rcond=None)[0]
    centre = first + rows.T @ weights
    return centre, float(max(np.linalg.norm(q - centre) for q in sphere))
