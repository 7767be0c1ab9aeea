"""Shared fixtures of the OCP layer tests: the real models, read once per session."""

import pytest

from tests.conftest import REAL_DATA



@pytest.fixture(scope="session")
def real():
    """``real(name) -> TopoDS_Shape`` for a file of ``/work/shared/data/real`` (cached)."""
    from cq_fairing.occ import read_shape

    cache = {}

    def load(name):
        if name not in cache:
            cache[name] = read_shape(REAL_DATA / name)
        return cache[name]

    return load
