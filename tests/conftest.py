"""Shared test settings: a deterministic hypothesis profile for CI, data paths, the real
models read once per test run."""

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", derandomize=True, max_examples=60, deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("dev", max_examples=30, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else os.environ.get("HYPOTHESIS_PROFILE", "dev"))

REPO = Path(__file__).resolve().parent.parent
DATA = REPO / "tests" / "data"
EXAMPLE_DATA = REPO / "examples" / "data"


def data_path(name):
    """Path of the bundled model ``name``: ``tests/data/<name>`` (sources and licences in
    ``tests/data/SOURCES.md``), or ``examples/data/<name>`` for the example's IEA blade."""
    return EXAMPLE_DATA / name if name == "IEA_15MW_CFD.stp" else DATA / name


@pytest.fixture(scope="session")
def real():
    """``real(name) -> TopoDS_Shape`` for a bundled model (:func:`data_path`; cached, OCP
    is imported only by tests that use it)."""
    from cq_fairing.occ import read_shape

    cache = {}

    def load(name):
        if name not in cache:
            cache[name] = read_shape(data_path(name))
        return cache[name]

    return load
