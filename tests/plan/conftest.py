"""Shared fixtures of the plan tests."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

DATA = Path(__file__).parent / "data"


def example(name: str) -> Path:
    """A bundled example file (src/robolobe/data/examples)."""
    return Path(str(resources.files("robolobe.data").joinpath("examples", name)))


@pytest.fixture
def data_dir() -> Path:
    return DATA
