"""Shared fixtures: one EGL context for the whole session (objects of two contexts
interfere), a seeded rng.  No GL here for cpu_prep tests: they never request `gl`."""
import numpy as np
import pytest


@pytest.fixture(scope="session")
def gl():
    from app import gl as glmod
    from app.errors import UserError
    try:
        return glmod.context()
    except UserError as exc:   # a missing GL is a failure, not a skip: CI must have it
        pytest.fail(f"no GL context: {exc}")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
