"""Shared fixtures for tests/robots."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.robots import Robot, load_robot


@pytest.fixture(scope="session", params=["A", "B", "C"])
def builtin(request: pytest.FixtureRequest) -> Robot:
    """Each built-in robot in turn."""
    return load_robot(request.param)


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)
