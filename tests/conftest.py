"""Shared test settings: a deterministic hypothesis profile for CI, data paths, the real
models read once per session."""

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
REAL_DATA = REPO.parent / "shared" / "data" / "real"


@pytest.fixture(scope="session")
def real():
    """``real(name) -> TopoDS_Shape`` for a file of ``/work/shared/data/real`` (cached;
    OCP is imported only by tests that use it)."""
    from cq_fairing.occ import read_shape

    cache = {}

    def load(name):
        if name not in cache:
            cache[name] = read_shape(REAL_DATA / name)
        return cache[name]

    return load
