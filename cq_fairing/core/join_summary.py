"""The joins of a faired model in numbers and in one line, worded alike in every layer.

Each backend measures its joins (the OCP layer with OCCT, the workbench with FreeCAD's
Part module) into rows, one dict per join with ``kind`` (``"smooth"`` or ``"crease"``),
``held`` (closed by construction), ``source_gap``, ``gap``, ``source_angle``, ``angle``
(degrees) and ``angle_excess`` (the largest of faired minus source angle at one sample);
:func:`summarize` and :func:`summary_line` turn them into the figures and the line that
the command line, the reports and the workbench's ``Status`` show.  This module imports
nothing outside the standard library.
"""

__all__ = ["summarize", "summary_line"]


def summarize(rows, **counts):
    """Counts and extremes of ``rows``: ``joins``, ``held``, ``max_gap``,
    ``max_gap_opened`` (faired minus source gap), ``smooth``, ``max_smooth_angle`` and its
    ``source_max_smooth_angle``, ``max_angle_excess`` over the smooth joins, ``creases``;
    ``counts`` (e.g. ``non_manifold``, ``point_contacts``, ``grids``, ``grid_faces``,
    ``network_faces``, ``curved``) are added as given."""
    smooth = [r for r in rows if r["kind"] == "smooth"]
    return dict(
        joins=len(rows), held=sum(r["held"] for r in rows),
        max_gap=max((r["gap"] for r in rows), default=0.0),
        max_gap_opened=max((r["gap"] - r["source_gap"] for r in rows), default=0.0),
        smooth=len(smooth),
        max_smooth_angle=max((r["angle"] for r in smooth), default=0.0),
        source_max_smooth_angle=max((r["source_angle"] for r in smooth), default=0.0),
        max_angle_excess=max((r["angle_excess"] for r in smooth), default=0.0),
        creases=len(rows) - len(smooth), **counts)


def summary_line(summary):
    """:func:`summarize`'s figures as one line, e.g. ``joins: 14 (12 held closed), max gap
    2e-12; 12 smooth, max angle 0.01 deg (source 0); 2 creases``; joins held
    curvature-continuous, patch grids, faces faired together by energy, non-manifold
    edges and point contacts are named after it when there are any."""
    s = summary
    parts = [f"joins: {s['joins']} ({s['held']} held closed), max gap {s['max_gap']:.2g}",
             f"{s['smooth']} smooth, max angle {s['max_smooth_angle']:.2g} deg (source "
             f"{s['source_max_smooth_angle']:.2g})", f"{s['creases']} creases"] \
        if s["joins"] else ["joins: none"]
    if s.get("curved"):
        parts.append(f"G2 across {s['curved']} (short of vertices where other joins meet)")
    if s.get("grids"):
        parts.append(f"{len(s['grids'])} patch grids ({s['grid_faces']} faces) faired as "
                     "one surface each")
    if s.get("network_faces"):
        parts.append(f"{s['network_faces']} faces at their coarsest faired together")
    if s.get("non_manifold"):
        parts.append(f"{s['non_manifold']} non-manifold edges (not joined)")
    if s.get("point_contacts"):
        parts.append(f"{s['point_contacts']} point contacts (not joined)")
    return "; ".join(parts)
