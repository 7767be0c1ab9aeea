"""The nets ``cq_fairing.occ.fair_face`` gives, with its defaults, on the faces the
FreeCAD tests compare the workbench's Tolerance mode with (``tests/data/face_references.npz``).

FreeCAD's Python has no OCP, so the command line's side is stored: the main suite checks
that the file is still what ``fair_face`` gives (``tests/occ/test_face_references.py``),
and the headless FreeCAD test that the workbench gives the same nets
(``tests/freecad/app/test_same_as_cli.py``).  After a change of the face search,
regenerate it with the Python that has cadquery (the main suite's), from the
repository root::

    python -m tests.freecad.face_references

The faces: every face of ``fuselage.brep`` at 2.5 mm, the 50 x 80 noisy face of the
workbench tests (:func:`noisy_blade_net`) at 0.05 mm, a 20 x 30 rational one
(:func:`rational_blade_net`) at 0.05 mm, and the IEA blade's main face (its spanwise
spans graded 74 to 1) at 0.12 m; the settings (:data:`SETTINGS`): the defaults on
the fuselage, the noisy face and the blade face, ``method="adaptive"`` on the fuselage,
``method="energy"`` on all three (it keeps the rational face with its reason),
``method="adaptive", borders="free"`` and ``borders="free"`` on the noisy face, and
``grading="uniform"`` on the blade face.  The fuselage's faces and the blade face have
neighbours in their models, where neither the workbench's feature nor ``cq-fairing
fair`` polishes the wavelet search's net
(:func:`~cq_fairing.core.joint_projection.plain_target_options`): their wavelet
references are ``fair_face`` with ``objective="compact"`` (:data:`NEIGHBOURED`).  A case is named
``"<setting>/<face>"`` (``"energy/fuselage/3"``, ``"wavelet/noisy"``).  This module
imports numpy only; :func:`computed` imports the OCP layer.
"""

from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]
REFERENCES = REPO / "tests" / "data" / "face_references.npz"
FUSELAGE = ("fuselage.brep", 2.5)
NOISY = ((50, 80), 0.05)
RATIONAL = ((20, 30), 0.05)
#: The IEA blade's second face (``Face2``) and its tolerance (m).
BLADE = ("IEA_15MW_CFD.stp", 1, 0.12)
#: The faces with neighbours in their models.
NEIGHBOURED = ("fuselage", "blade")
#: ``{setting: (options of fair_face and of the workbench's make_fairing, faces)}``.
SETTINGS = {"wavelet": ({}, ("fuselage", "noisy", "blade")),
            "adaptive": ({"method": "adaptive"}, ("fuselage",)),
            "energy": ({"method": "energy"}, ("fuselage", "noisy", "rational")),
            "adaptive-free": ({"method": "adaptive", "borders": "free"}, ("noisy",)),
            "wavelet-free": ({"borders": "free"}, ("noisy",)),
            "wavelet-uniform": ({"grading": "uniform"}, ("blade",))}


def noisy_blade_net(n_u=50, n_v=80, noise=0.02, seed=3):
    """A bicubic blade-like net (``n_u x n_v`` poles, mm) with seeded noise, the truth,
    and the knots of both (clamped, uniform).

    Returns
    -------
    noisy, truth : ndarray, shape (n_u, n_v, 3)
    u_knots, v_knots : ndarray
        Full clamped knot vectors on [0, 1].
    """
    u = np.linspace(0.0, 1.0, n_u)[:, None]
    v = np.linspace(0.0, 1.0, n_v)[None, :]
    x = 100.0 * u + 0 * v
    y = 300.0 * v + 0 * u
    z = 20.0 * np.sin(np.pi * u) * (1.0 - 0.5 * v) + 5.0 * np.cos(2 * np.pi * v) * u
    truth = np.stack([x, y, z], axis=2)
    rng = np.random.default_rng(seed)
    noisy = truth.copy()
    noisy[..., 2] += noise * rng.standard_normal(truth.shape[:2])
    return noisy, truth, _clamped_knots(n_u), _clamped_knots(n_v)


def rational_blade_net(n_u=20, n_v=30):
    """The noisy blade net of :func:`noisy_blade_net` with weights
    :math:`1 + 0.2 \\sin(\\pi u) \\sin(\\pi v)` on its parameter grid.

    Returns
    -------
    poles : ndarray, shape (n_u, n_v, 3)
    weights : ndarray, shape (n_u, n_v)
    u_knots, v_knots : ndarray
    """
    noisy, _, u_knots, v_knots = noisy_blade_net(n_u, n_v)
    u, v = np.linspace(0.0, 1.0, n_u)[:, None], np.linspace(0.0, 1.0, n_v)[None, :]
    return noisy, 1.0 + 0.2 * np.sin(np.pi * u) * np.sin(np.pi * v), u_knots, v_knots


def _clamped_knots(poles, degree=3):
    inner = np.linspace(0.0, 1.0, poles - degree + 1)
    return np.concatenate([[0.0] * degree, inner, [1.0] * degree])


def load():
    """``{case: {field: value}}`` from :data:`REFERENCES`.

    Fields: ``source`` (the face's poles), ``status`` (``"faired"``, ``"unchanged"``,
    ``"skipped-rational"`` or ``"tolerance-not-met"``), ``message`` (why it is kept, ``""`` when faired),
    ``poles``, ``u_knots``, ``v_knots`` (the net the face ends with: the source's where
    kept), ``max_deviation`` (OCCT's check of the faired face; the best deviation found
    where the tolerance is not met; 0 where unchanged).
    """
    out = {}
    with np.load(REFERENCES) as data:
        for key in data.files:
            case, name = key.rsplit(":", 1)
            value = data[key]
            out.setdefault(case, {})[name] = str(value) if value.dtype.kind == "U" else value
    return out


def setting(case):
    """``(options, tol)`` of ``case``: the options of its setting and its face's
    tolerance."""
    name, face = case.split("/", 1)
    return SETTINGS[name][0], {"noisy": NOISY[1], "rational": RATIONAL[1],
                               "blade": BLADE[2]}.get(face, FUSELAGE[1])


def computed():
    """The cases as ``fair_face`` (the options of :data:`SETTINGS`, the tolerance above)
    gives them now."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    from cq_fairing.core.geometry import make_surface
    from cq_fairing.occ import read_shape
    from cq_fairing.occ.builders import surface_to_natural_face
    from cq_fairing.occ.convert import indexed_faces

    explorer = TopExp_Explorer(read_shape(REPO / "tests" / "data" / FUSELAGE[0]), TopAbs_FACE)
    faces = {}
    while explorer.More():
        faces[f"fuselage/{len(faces)}"] = TopoDS.Face_s(explorer.Current())
        explorer.Next()
    noisy, _, u_knots, v_knots = noisy_blade_net(*NOISY[0])
    faces["noisy"] = surface_to_natural_face(make_surface(noisy, u_knots, v_knots, (3, 3)))
    poles, weights, u_knots, v_knots = rational_blade_net(*RATIONAL[0])
    faces["rational"] = surface_to_natural_face(
        make_surface(poles, u_knots, v_knots, (3, 3), weights=weights))
    faces["blade"] = indexed_faces(read_shape(REPO / "examples" / "data" / BLADE[0]))[BLADE[1]]
    out = {}
    for name, (_, kinds) in SETTINGS.items():
        for key, face in faces.items():
            if key.split("/")[0] in kinds:
                case = f"{name}/{key}"
                options, tol = setting(case)
                if key.split("/")[0] in NEIGHBOURED and options.get("method", "wavelet") == \
                        "wavelet":
                    options = {**options, "objective": "compact"}
                out[case] = _outcome(face, options, tol)
    return out


def _outcome(face, options, tol):
    """The fields of :func:`load` of ``fair_face(face, tol=tol, **options)``."""
    from cq_fairing.errors import ToleranceNotMetError
    from cq_fairing.occ import face_to_surface, fair_face

    source = face_to_surface(face)[0]
    try:
        report = fair_face(face, tol=tol, **options)
    except ToleranceNotMetError as exc:
        status, message, surface, deviation = ("tolerance-not-met", str(exc), source,
                                               exc.best_deviation)
    else:
        status, message = report.status, report.message
        deviation = 0.0 if report.max_deviation is None else report.max_deviation
        surface = report.surface if report.surface is not None else source
    return {"source": source.poles, "status": status, "message": message,
            "poles": surface.poles, "u_knots": surface.u_knots, "v_knots": surface.v_knots,
            "max_deviation": np.float64(deviation)}


def main():
    arrays = {f"{case}:{name}": np.asarray(value) for case, fields in computed().items()
              for name, value in fields.items()}
    np.savez_compressed(REFERENCES, **arrays)
    print(f"wrote {REFERENCES.relative_to(REPO)}: {len(arrays)} arrays")


if __name__ == "__main__":
    main()
