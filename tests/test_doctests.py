"""Every example in a docstring of the library runs and prints what it shows.

The docs site renders these docstrings (``mkdocs.yml``), so an example that
drifts from the code is a documentation bug; this runs them all.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import numpy as np
import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
MODULES = sorted(
    ".".join(p.relative_to(SRC).with_suffix("").parts).removesuffix(".__init__")
    for p in (SRC / "robolobe").rglob("*.py")
    if ">>> " in p.read_text(encoding="utf-8")
)


def test_the_library_has_examples() -> None:
    assert len(MODULES) >= 4, MODULES


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name: str) -> None:
    module = importlib.import_module(name)
    with np.printoptions(legacy="1.25"):
        result = doctest.testmod(
            module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE
        )
    assert result.attempted > 0, f"{name}: examples found by grep but none collected"
    assert result.failed == 0, f"{name}: {result.failed} of {result.attempted} examples failed"
