r"""Deviation maps and curvature maps: numbers, pyvista meshes (VTP) and PNG images.

Two kinds of map show what fairing did to a surface:

* **Deviation map**: the distance from each sample of the original surface to the
  faired surface, coloured from green (0) through yellow to red (the largest
  deviation), as in the figures of Ji et al. (2014).  The signed deviation is the
  same distance with the sign of :math:`(x_\text{faired} - x) \cdot n`.
* **Curvature maps**: the mean curvature :math:`H` and the Gaussian curvature
  :math:`K` of the surface before and after fairing, side by side with one colour
  range, so a calmer colour field shows the surface got fairer.

The numbers come from the core's one curvature implementation
(:func:`~cq_fairing.core.fairness.curvatures_from_derivatives`):
:func:`surface_curvature` is :func:`~cq_fairing.core.fairness.grid_curvatures` and
:func:`fairness_measures` is :func:`~cq_fairing.core.fairness.box_fairness`;
pyvista is imported inside the functions that build meshes or render.  Rendering is
off-screen (``Plotter(off_screen=True)``), which works without a display through
the EGL (or OSMesa) render window of the vtk wheel.  Every file is written to a
temporary name in the target folder and renamed when complete, so a failure never
leaves a half-written map behind.
"""

from contextlib import contextmanager

import numpy as np

from .core.fairness import box_fairness as fairness_measures
from .core.fairness import grid_curvatures as surface_curvature
from .errors import InvalidInputError, OutputPathError
from .report import atomic_output

__all__ = [
    "surface_curvature", "fairness_measures", "deviation_statistics", "deviation_mesh",
    "curvature_mesh", "save_mesh", "render_deviation_map", "render_curvature_maps",
    "deviation_lookup_table", "DEVIATION_COLORS",
]

#: Colour stops of the deviation scale: green at 0, yellow half way, red at the maximum.
DEVIATION_COLORS = ((0, 170, 0), (255, 225, 0), (215, 0, 0))
#: Colour stops of the signed curvature scale: blue (negative), white (0), red (positive).
CURVATURE_COLORS = ((40, 70, 200), (245, 245, 245), (200, 30, 30))


# -- numbers ------------------------------------------------------------------------------
def uv_grid(box, density):
    """Uniform parameters over a UV box ``((u0, u1), (v0, v1))``, ``density`` per side."""
    (u0, u1), (v0, v1) = box
    count = int(density)
    if count < 3:
        raise InvalidInputError(f"density must be at least 3 samples per side, got {density!r}.")
    return np.linspace(u0, u1, count), np.linspace(v0, v1, count)


def deviation_statistics(distance):
    """Max, mean and RMS of a deviation sample (NaNs ignored)."""
    d = np.abs(np.asarray(distance, dtype=float))
    d = d[np.isfinite(d)]
    if d.size == 0:
        raise InvalidInputError("the deviation sample is empty (no finite distances).")
    return {"max": float(d.max()), "mean": float(d.mean()),
            "rms": float(np.sqrt(np.mean(d ** 2))), "samples": int(d.size)}


# -- meshes -------------------------------------------------------------------------------
def _pyvista():
    import pyvista as pv

    return pv


def _grid_or_cloud(points, uv=None):
    """A surface mesh (PolyData) from a (n_u, n_v, 3) grid or scattered (N, 3) samples.

    Scattered samples (a trimmed face sampled inside its boundary) are triangulated by
    a 2-D Delaunay triangulation of their ``uv`` parameters.
    """
    pv = _pyvista()
    points = np.asarray(points, dtype=float)
    if points.ndim == 3:
        nu, nv, _ = points.shape
        # StructuredGrid wants Fortran (x fastest) ordering: point (i, j) at i + nu * j
        flat = points.transpose(1, 0, 2).reshape(-1, 3)
        grid = pv.StructuredGrid()
        grid.points = flat
        grid.dimensions = (nu, nv, 1)
        return grid.extract_surface(algorithm="dataset_surface").triangulate(), "F"
    if uv is None:
        raise InvalidInputError("scattered deviation samples need their uv parameters.")
    uv = np.asarray(uv, dtype=float).reshape(-1, 2)
    flat = pv.PolyData(np.c_[uv, np.zeros(len(uv))]).delaunay_2d()
    mesh = pv.PolyData(points.reshape(-1, 3), flat.faces)
    return mesh, "C"


def _point_values(values, order):
    values = np.asarray(values, dtype=float)
    if values.ndim == 2 and order == "F":
        return values.T.reshape(-1)
    return values.reshape(-1)


def deviation_mesh(samples, face_index=None):
    """A pyvista PolyData of one face's deviation sample.

    Parameters
    ----------
    samples : dict
        ``points`` ((n_u, n_v, 3) grid or (N, 3)), ``distance`` (true distance to the
        faired surface, same leading shape), optional ``signed`` and ``uv``, as
        returned by ``cq_fairing.occ.sample_face_deviation``.
    face_index : int, optional
        Stored as the point array ``face`` (so merged meshes keep their faces apart).

    Returns
    -------
    pyvista.PolyData
        Point data ``deviation`` (>= 0) and ``signed_deviation``.
    """
    mesh, order = _grid_or_cloud(samples["points"], samples.get("uv"))
    distance = np.abs(_point_values(samples["distance"], order))
    signed = samples.get("signed")
    mesh.point_data["deviation"] = distance
    mesh.point_data["signed_deviation"] = (distance if signed is None
                                           else _point_values(signed, order))
    if face_index is not None:
        mesh.point_data["face"] = np.full(mesh.n_points, int(face_index), dtype=np.int32)
    return mesh


def curvature_mesh(surface, box=None, density=80):
    """A PolyData of the surface on a grid with point data ``mean_curvature``/``gaussian_curvature``."""
    u, v = uv_grid(surface.domain if box is None else box, density)
    curv = surface_curvature(surface, u, v)
    mesh, order = _grid_or_cloud(curv["points"])
    mesh.point_data["mean_curvature"] = _point_values(curv["mean"], order)
    mesh.point_data["gaussian_curvature"] = _point_values(curv["gaussian"], order)
    return mesh


def save_mesh(meshes, path, *, force=False):
    """Write one mesh or several (merged) to a VTP file, atomically.

    Raises
    ------
    OutputPathError
        If ``path`` does not end in ``.vtp``, exists (without ``force``) or cannot be
        written.
    """
    pv = _pyvista()
    if not str(path).lower().endswith(".vtp"):
        raise OutputPathError(f"a mesh file must end in .vtp, got {str(path)!r}.")
    meshes = [meshes] if isinstance(meshes, pv.DataSet) else list(meshes)
    merged = meshes[0] if len(meshes) == 1 else pv.merge(meshes, merge_points=False)
    merged = merged.extract_surface(algorithm="dataset_surface") \
        if not isinstance(merged, pv.PolyData) else merged
    with atomic_output(path, force=force) as tmp:
        merged.save(tmp, binary=True)
    return path


# -- colours ------------------------------------------------------------------------------
def _ramp(stops, n=256):
    stops = np.asarray(stops, dtype=float)
    x = np.linspace(0, 1, len(stops))
    t = np.linspace(0, 1, n)
    rgb = np.stack([np.interp(t, x, stops[:, i]) for i in range(3)], axis=1)
    return np.c_[rgb, np.full(n, 255.0)].astype(np.uint8)


def deviation_lookup_table(maximum, stops=DEVIATION_COLORS):
    """A pyvista LookupTable from green (0) through yellow to red (``maximum``)."""
    pv = _pyvista()
    lut = pv.LookupTable()
    lut.values = _ramp(stops)
    lut.scalar_range = (0.0, max(float(maximum), 1e-300))
    return lut


@contextmanager
def _quiet_vtk():
    """Silence vtk's stderr warnings (e.g. the X probe before the EGL fallback)."""
    import vtk

    vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_ERROR)
    try:
        yield
    finally:
        vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_INFO)


def _bar(title, **extra):
    return dict(title=title, vertical=True, position_x=0.84, position_y=0.1, width=0.07,
                height=0.8, fmt="%.3g", n_labels=5, title_font_size=14,
                label_font_size=12, color="black", **extra)


def render_deviation_map(meshes, path, *, tolerance=None, units="mm", title=None,
                         window_size=(1200, 900), force=False):
    """Render deviation meshes off-screen to a PNG with a colour bar, atomically.

    Parameters
    ----------
    meshes : pyvista.PolyData or list of them
        From :func:`deviation_mesh` (point data ``deviation``).
    path : str or Path
        Output ``.png``.
    tolerance : float, optional
        Shown in the title next to the maximum.
    units : str
        Length unit for the colour bar and title.

    Returns
    -------
    dict
        ``max``, ``mean``, ``rms`` of the deviation over all meshes.
    """
    pv = _pyvista()
    meshes = [meshes] if isinstance(meshes, pv.DataSet) else list(meshes)
    _check_png(path)
    stats = deviation_statistics(np.concatenate([m.point_data["deviation"] for m in meshes]))
    lut = deviation_lookup_table(stats["max"])
    if title is None:
        title = "Deviation: faired vs original"
    subtitle = f"max {stats['max']:.4g} {units}, RMS {stats['rms']:.3g} {units}"
    if tolerance is not None:
        subtitle += f", tolerance {tolerance:.4g} {units}"
    with _quiet_vtk():
        plotter = pv.Plotter(off_screen=True, window_size=list(window_size))
        try:
            plotter.set_background("white")
            for i, mesh in enumerate(meshes):
                plotter.add_mesh(mesh, scalars="deviation", cmap=lut, clim=lut.scalar_range,
                                 show_scalar_bar=(i == 0), smooth_shading=True,
                                 scalar_bar_args=_bar(f"deviation [{units}]"))
            plotter.add_text(f"{title}\n{subtitle}", font_size=12, color="black",
                             position="upper_left")
            plotter.view_isometric()
            plotter.reset_camera()
            _screenshot(plotter, path, force)
        finally:
            plotter.close()
    return stats


def _check_png(path):
    if not str(path).lower().endswith(".png"):
        raise OutputPathError(f"an image file must end in .png, got {str(path)!r}.")


def _screenshot(plotter, path, force):
    with atomic_output(path, force=force) as tmp:
        plotter.screenshot(str(tmp))


def _symmetric_limit(values, percentile=98.0):
    """A colour limit covering ``percentile`` % of ``|values|`` (spikes are clipped)."""
    finite = np.abs(values[np.isfinite(values)])
    if finite.size == 0:
        return 1.0
    limit = float(np.percentile(finite, percentile))
    return limit if limit > 0 else max(float(finite.max()), 1e-300)


def render_curvature_maps(before, after, path, *, box=None, density=80, title=None,
                          units="mm", window_size=(1400, 1100), force=False):
    r"""Mean and Gaussian curvature before and after fairing, side by side, as a PNG.

    Rows: mean curvature :math:`H`, Gaussian curvature :math:`K`; columns: before,
    after.  Each row uses one symmetric colour range, taken from the *before*
    surface (98th percentile of :math:`|H|` or :math:`|K|`), so the two columns
    compare directly; blue is negative, white zero, red positive.

    Parameters
    ----------
    before, after : BSplineSurface
    box : ((u0, u1), (v0, v1)), optional
        Parameter box to show (a trimmed face's UV bounds); default ``before.domain``.

    Returns
    -------
    dict
        ``mean_limit``, ``gaussian_limit`` (colour ranges) and the fairness measures
        ``before`` and ``after`` (see :func:`fairness_measures`).
    """
    pv = _pyvista()
    _check_png(path)
    box = before.domain if box is None else box
    meshes = [curvature_mesh(s, box, density) for s in (before, after)]
    limits = {name: _symmetric_limit(meshes[0].point_data[name])
              for name in ("mean_curvature", "gaussian_curvature")}
    lut = _ramp(CURVATURE_COLORS)
    labels = {"mean_curvature": f"H [1/{units}]", "gaussian_curvature": f"K [1/{units}²]"}
    with _quiet_vtk():
        plotter = pv.Plotter(off_screen=True, shape=(2, 2), window_size=list(window_size),
                             border=False)
        try:
            plotter.set_background("white")
            for row, name in enumerate(("mean_curvature", "gaussian_curvature")):
                for col, (mesh, label) in enumerate(zip(meshes, ("before", "after"))):
                    plotter.subplot(row, col)
                    table = pv.LookupTable()
                    table.values = lut
                    table.scalar_range = (-limits[name], limits[name])
                    plotter.add_mesh(mesh.copy(), scalars=name, cmap=table,
                                     clim=table.scalar_range, smooth_shading=True,
                                     scalar_bar_args=_bar(f"{labels[name]} {label}"))
                    heading = ("Mean" if row == 0 else "Gaussian") + f" curvature, {label}"
                    if title and row == 0 and col == 0:
                        heading = f"{title}\n{heading}"
                    plotter.add_text(heading, font_size=11, color="black",
                                     position="upper_left")
                    plotter.view_isometric()
            plotter.link_views()
            plotter.reset_camera()
            _screenshot(plotter, path, force)
        finally:
            plotter.close()
    return {"mean_limit": limits["mean_curvature"],
            "gaussian_limit": limits["gaussian_curvature"],
            "before": fairness_measures(before, box),
            "after": fairness_measures(after, box)}
