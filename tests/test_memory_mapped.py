"""Large blocks mapped inside :func:`robolobe._memory.large_blocks_mapped` (glibc only)."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from robolobe import _memory


def _rss() -> int:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


glibc = pytest.mark.skipif(
    not sys.platform.startswith("linux") or _memory._libc() is None, reason="glibc only"
)


_FRESH = """
import os, numpy as np
from robolobe import _memory
def rss():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
n = (6 << 20) // 8  # above MAPPED_FROM_BYTES, below HEAP_UP_TO_BYTES
assert _memory.MAPPED_FROM_BYTES < n * 8 < _memory.HEAP_UP_TO_BYTES
with _memory.large_blocks_mapped(), _memory.large_blocks_mapped({on}):  # as in a long plan
    keep = np.ones(1000)
    a = np.ones(n)
    after_a = np.ones(1000)  # a live block above it on the heap: no trim at the top
    before = rss()
    del a
    print(before - rss())
"""


@glibc
@pytest.mark.parametrize("on", [True, False])
def test_a_large_block_freed_inside_goes_back_at_once(on):
    """Mapped: a 6 MB block freed is returned at once; from the heap (the setting of the
    lobe stages) it is kept for the next blocks. A fresh process: a free block already on
    the heap would be reused before any mapping."""
    import subprocess

    out = subprocess.run(
        [sys.executable, "-c", _FRESH.format(on=on)], capture_output=True, text=True, check=True
    )
    dropped = int(out.stdout.split()[-1])
    if on:
        assert dropped >= 5 << 20
    else:
        assert dropped < 1 << 20


@glibc
def test_contexts_nest_and_restore():
    assert _memory._threshold[0] is None
    with _memory.large_blocks_mapped():
        assert _memory._threshold[0] == _memory.MAPPED_FROM_BYTES
        with _memory.large_blocks_mapped(False):
            assert _memory._threshold[0] == _memory.HEAP_UP_TO_BYTES
        assert _memory._threshold[0] == _memory.MAPPED_FROM_BYTES
    assert _memory._threshold[0] is None
    with _memory.large_blocks_mapped(False):  # nothing to set: glibc's own stays
        assert _memory._threshold[0] is None


def test_long_path_by_rows_or_program_size(tmp_path):
    import pandas as pd

    from robolobe.plan.pipeline import _long_path

    assert _long_path(pd.DataFrame({"x": np.zeros(_memory.RELEASE_MIN_ROWS)}))
    assert not _long_path(pd.DataFrame({"x": np.zeros(10)}))
    small = tmp_path / "a.nc"
    small.write_text("G1 X1 Y1 F100\n")
    assert not _long_path(small)
    assert not _long_path(tmp_path / "missing.nc")  # refused later, when read
