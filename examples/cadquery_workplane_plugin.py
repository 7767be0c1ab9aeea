"""``Workplane.fair``: fair a noisy B-spline face made in CadQuery, and the bundled blade.

Run:  python examples/cadquery_workplane_plugin.py

1. A bicubic face whose control net is a wavy sheet with noise is extruded to a solid,
   and its B-spline faces are faired through the plugin: the solid stays one valid
   closed solid.
2. The blade faces are selected with a CadQuery selector and faired in place.
"""

from pathlib import Path

import cadquery as cq
import numpy as np

from cq_fairing.cadquery_plugin import register

HERE = Path(__file__).resolve().parent


def noisy_sheet(n=(60, 40), noise=0.05, seed=1):
    """A bicubic B-spline face whose control net is a wavy sheet plus random noise."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    from cq_fairing import make_surface
    from cq_fairing.occ.convert import to_geom_surface

    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0.0, 100.0, n[0]), np.linspace(0.0, 60.0, n[1]),
                       indexing="ij")
    z = 5.0 * np.sin(x / 20.0) * np.cos(y / 15.0) + noise * rng.standard_normal(x.shape)
    surface = make_surface(np.stack([x, y, z], axis=2))
    return cq.Face(BRepBuilderAPI_MakeFace(to_geom_surface(surface), 1e-7).Face())


def main():
    register()
    sheet = noisy_sheet()
    solid = cq.Workplane().add(cq.Solid.extrudeLinear(sheet, cq.Vector(0, 0, 2.0)))
    faired = solid.faces("%BSPLINE").fair(tol=0.1)
    report, = faired.fair_report
    for face in report.faces:
        if face.faired:
            print(f"sheet face {face.index}: {face.poles_before} -> {face.poles_after} poles, "
                  f"max deviation {face.max_deviation:.4f}")
    print("solid valid:", faired.val().isValid())

    blade = cq.importers.importStep(str(HERE / "data" / "IEA_15MW_CFD.stp"))
    out = blade.faces("%BSPLINE").fair(tol=0.01)
    for face in out.fair_report:
        print(f"blade face: {face.status}, {face.poles_before} -> {face.poles_after}")


if __name__ == "__main__":
    main()
