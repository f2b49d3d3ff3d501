"""Whole-suite test settings: the ``serial`` tests never run beside others.

The README's test command runs the suite on every core with pytest-xdist
(``-n 2 -m "... and not serial"``), then the tests marked ``serial`` in one
plain process. A ``serial`` test that an xdist worker is asked to run fails
at once instead of measuring, or timing out, beside another test's processes.
"""

from __future__ import annotations

import os

import pytest


def pytest_runtest_setup(item: pytest.Item) -> None:
    worker = os.environ.get("PYTEST_XDIST_WORKER")
    if worker and item.get_closest_marker("serial") is not None:
        pytest.fail(
            f"{item.nodeid} is marked serial but runs in xdist worker {worker} beside other "
            'tests: select it with -m serial in a run without -n, and add "and not serial" '
            "to the parallel run's -m (the README's test command does both)",
            pytrace=False,
        )
