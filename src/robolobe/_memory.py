"""Freed heap memory given back to the operating system between the stages of a long plan.

glibc keeps memory a program frees for its next allocations; blocks above
its mmap threshold go straight back, but the threshold rises to the size of
each large block freed (up to 32 MiB), so the arrays of a long path (8 MB a
column at a million waypoints) come from the heap, and what the heap keeps
after a stage adds to the next stage's peak. :func:`release_free_memory`
(``malloc_trim``) returns the heap's free pages at a stage boundary: the
resident memory is then what is alive, plus partly used pages.

Trimming returns only whole free pages: the blocks a long path's read and
engagement free between the arrays that stay (the waypoint table, the
stock) leave the heap fragmented, measured ~200 MB resident beyond what is
alive after a 1e6-waypoint plan, even trimmed. :func:`large_blocks_mapped`
sets glibc's mmap threshold (``mallopt(M_MMAP_THRESHOLD)``) to
:data:`MAPPED_FROM_BYTES` for a long plan's stages that make few large blocks
(read, the schedule, the table, the outputs), so that their large arrays are
mapped and go back when freed; the engagement, mode and lobe stages make and
free many large blocks (mapping them costs fresh zeroed pages: ~15 % more CPU
measured with the low threshold throughout, +2.3 % as set here) and run with
the heap (:data:`HEAP_UP_TO_BYTES`). 1e6-waypoint plan (``pipeline.plan_path``,
load 4-5, side by side): peak 1.89 -> 1.75e9 bytes.

Elsewhere than glibc (musl, macOS, Windows) it does nothing.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import functools
import sys
from collections.abc import Callable, Iterator

#: Waypoints from which a plan releases free memory between its stages (below it the
#: few milliseconds of a trim are not worth it: the heap is small).
RELEASE_MIN_ROWS = 100_000


#: Blocks from this size on are mapped inside :func:`large_blocks_mapped` (a column of a
#: long path: 8 MB at a million waypoints; below it, the heap).
MAPPED_FROM_BYTES = 4 << 20

#: The mmap threshold set for stages that run with the heap (and after): glibc's
#: highest dynamic threshold on 64-bit systems, where it settles once large blocks
#: have been freed.
HEAP_UP_TO_BYTES = 32 << 20

_M_MMAP_THRESHOLD = -3  # glibc's mallopt parameter

#: The threshold set last by :func:`large_blocks_mapped` (None: glibc's own).
_threshold: list[int | None] = [None]


@functools.cache
def _libc() -> ctypes.CDLL | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        libc.malloc_trim.argtypes = [ctypes.c_size_t]
        libc.malloc_trim.restype = ctypes.c_int
        libc.mallopt.argtypes = [ctypes.c_int, ctypes.c_int]
        libc.mallopt.restype = ctypes.c_int
    except (OSError, AttributeError):  # not glibc
        return None
    return libc


def _trim() -> Callable[[int], int] | None:
    libc = _libc()
    return None if libc is None else libc.malloc_trim


@contextlib.contextmanager
def large_blocks_mapped(on: bool = True) -> Iterator[None]:
    """Large blocks mapped (``on``) or from the heap (not ``on``) inside; the setting
    before is restored on leaving (glibc's own dynamic threshold: :data:`HEAP_UP_TO_BYTES`).

    Results do not change: only where glibc takes a block from. Contexts nest (a
    long plan's lobe stage runs with the heap inside a plan that maps). The
    threshold is the process's: plans on several threads at once may run a stage
    with the other one's setting (memory placement only).

    Parameters
    ----------
    on : bool
        Map blocks from :data:`MAPPED_FROM_BYTES` on; False: the heap up to
        :data:`HEAP_UP_TO_BYTES`.
    """
    libc = _libc()
    before = _threshold[0]  # None: glibc's own (dynamic) threshold
    want = MAPPED_FROM_BYTES if on else HEAP_UP_TO_BYTES
    change = libc is not None and want != before and (on or before is not None)
    if change:
        assert libc is not None
        libc.mallopt(_M_MMAP_THRESHOLD, want)
        _threshold[0] = want
    try:
        yield
    finally:
        if change:
            assert libc is not None
            # glibc's own cannot be set again: its highest value stands for it
            libc.mallopt(_M_MMAP_THRESHOLD, before if before is not None else HEAP_UP_TO_BYTES)
            _threshold[0] = before


def release_free_memory(rows: int | None = None) -> bool:
    """Give the heap's free pages back to the operating system (glibc ``malloc_trim(0)``).

    Nothing alive is touched: only memory already freed is returned, so
    results do not change; the next allocations may take a little longer
    (fresh pages).

    Parameters
    ----------
    rows : int, optional
        The size of the work (waypoints); below :data:`RELEASE_MIN_ROWS`
        nothing is done.

    Returns
    -------
    bool
        Whether memory was returned (False: nothing to return, too small a
        job, or not glibc).
    """
    if rows is not None and rows < RELEASE_MIN_ROWS:
        return False
    fn = _trim()
    return bool(fn(0)) if fn is not None else False
