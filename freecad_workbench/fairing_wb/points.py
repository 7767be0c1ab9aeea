"""Points to surface / curve: ``x y z`` files through :func:`cq_fairing.read_xyz`.

The file's order decides what the points are:

* one run of points without jumps -> a curve (:func:`cq_fairing.interpolate_points`,
  N points give N + 2 poles);
* rows of equal length, separated by jumps (a scan-line grid) -> a surface
  (:func:`cq_fairing.interpolate_grid`);
* anything else is a scattered cloud.  It is refused with a message unless
  ``resample=(n_u, n_v)`` is given; then it is resampled as a height field over its
  best-fit (PCA) plane: linear interpolation on the Delaunay triangulation, cells outside
  the cloud's convex hull take the nearest point's height (their count is reported).

A jump is a step longer than 4 times the median step between consecutive points.  The
classification is :func:`cq_fairing.classify_points`, the resampling
:func:`cq_fairing.resample_height_field` (both in the core, shared with the command
line).
"""

import FreeCAD

import cq_fairing as cf

from . import conversion

__all__ = ["classify", "resample_height_field", "shape_from_points", "make_points_shape"]

classify = cf.classify_points
resample_height_field = cf.resample_height_field


def shape_from_points(points, resample=None):
    """A Part face or edge through the points and a one-line description.

    Raises
    ------
    cq_fairing.InvalidInputError
        For a scattered cloud without ``resample``.
    """
    kind, grid_shape = classify(points)
    if kind == "curve":
        curve = cf.interpolate_points(points, "chord")
        return conversion.part_curve(curve).toShape(), (
            f"{points.shape[0]} points in one run -> interpolating curve with "
            f"{curve.n_poles} poles")
    if kind == "grid":
        surface = cf.interpolate_grid(points.reshape(*grid_shape, 3))
        return conversion.part_surface(surface).toShape(), (
            f"{grid_shape[0]} x {grid_shape[1]} point grid -> interpolating surface with "
            f"{surface.shape[0]} x {surface.shape[1]} poles")
    if resample is None:
        raise cf.InvalidInputError(
            f"the {points.shape[0]} points are not an ordered grid (rows of equal length "
            "separated by a jump) nor a single run, so they cannot be interpolated as they "
            "are; resample them onto a grid (resample=(40, 40): a height field over their "
            "best-fit plane) or supply the points row by row.")
    grid, outside = resample_height_field(points, resample)
    surface = cf.interpolate_grid(grid)
    return conversion.part_surface(surface).toShape(), (
        f"{points.shape[0]} scattered points resampled to a {resample[0]} x {resample[1]} "
        f"grid ({outside} cells outside the cloud took the nearest height) -> surface with "
        f"{surface.shape[0]} x {surface.shape[1]} poles")


def make_points_shape(path, resample=None, doc=None, name="PointsShape"):
    """Read an ``x y z`` file and add the interpolating surface/curve as a Part::Feature.

    Returns
    -------
    (App.DocumentObject, str)
        The new object (its ``Label2`` holds the description) and the description.
    """
    points = cf.read_xyz(path)
    shape, message = shape_from_points(points, None if resample is None else tuple(resample))
    doc = doc or FreeCAD.ActiveDocument or FreeCAD.newDocument()
    obj = doc.addObject("Part::Feature", name)
    obj.Shape = shape
    obj.Label2 = message
    return obj, message
