"""Freed heap memory given back to the operating system between the stages of a long plan.

glibc keeps memory a program frees for its next allocations; blocks above
its mmap threshold go straight back, but the threshold rises to the size of
each large block freed (up to 32 MiB), so the arrays of a long path (8 MB a
column at a million waypoints) come from the heap, and what the heap keeps
after a stage adds to the next stage's peak. :func:`release_free_memory`
(``malloc_trim``) returns the heap's free pages at a stage boundary: the
resident memory is then what is alive, plus partly used pages.

Elsewhere than glibc (musl, macOS, Windows) it does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import sys
from collections.abc import Callable

#: Waypoints from which a plan releases free memory between its stages (below it the
#: few milliseconds of a trim are not worth it: the heap is small).
RELEASE_MIN_ROWS = 100_000


@functools.cache
def _trim() -> Callable[[int], int] | None:
    if not sys.platform.startswith("linux"):
        return None
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        fn = libc.malloc_trim
    except (OSError, AttributeError):  # not glibc
        return None
    fn.argtypes = [ctypes.c_size_t]
    fn.restype = ctypes.c_int
    return fn


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
