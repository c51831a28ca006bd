"""Shared fixtures: one EGL context for the whole session (objects of two contexts
interfere), a seeded rng.  No GL here for cpu_prep tests: they never request `gl`."""
import os

import numpy as np
import pytest
from hypothesis import settings

# No per-example deadline (first calls compile numba kernels and shaders); CI replays the
# same examples every run (derandomize) so a red build is reproducible.
settings.register_profile("lab", deadline=None)
settings.register_profile("ci", deadline=None, derandomize=True)
settings.load_profile("ci" if os.environ.get("CI") else "lab")


@pytest.fixture(scope="session")
def gl():
    from app.pipeline import gl as glmod
    from app.errors import UserError
    try:
        return glmod.context()
    except UserError as exc:   # a missing GL is a failure, not a skip: CI must have it
        pytest.fail(f"no GL context: {exc}")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
