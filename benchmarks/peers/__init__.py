"""Peer fitters for benchmarks/bench_peers.py: each returns a core BSplineCurve/BSplineSurface.

Every wrapper takes the same inputs (points, the source geometry, tol) and searches its own
setting until the input points lie within ``tol`` of the result (closest-point distance,
:func:`benchmarks.peers.measure.points_to_curve` / ``points_to_surface``).
"""
