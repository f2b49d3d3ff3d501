"""One BLAS thread for code that does many small linear-algebra calls.

Fits with many small matrices (identification per posture, twin calibration,
diagnosis, semi-discretization) run slower with a multi-threaded BLAS: each
call pays the threads' start-up, and on a busy machine OpenBLAS's spinning
threads compete with the other processes (measured: one twin calibration of
robot B 0.26 s with one thread, 5.3 s with two at load 5). This module
imports no robolobe package, so every layer may use it.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from typing import Any, ParamSpec, TypeVar

__all__ = ["each_on_threads", "one_blas_thread", "with_one_blas_thread"]

P = ParamSpec("P")
T = TypeVar("T")


def one_blas_thread() -> AbstractContextManager[Any]:
    """Context manager limiting BLAS (OpenBLAS, MKL, ...) to one thread inside it."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def with_one_blas_thread(fn: Callable[P, T]) -> Callable[P, T]:
    """Decorator: run ``fn`` with BLAS limited to one thread (:func:`one_blas_thread`)."""

    @functools.wraps(fn)
    def inner(*args: P.args, **kwargs: P.kwargs) -> T:
        with one_blas_thread():
            return fn(*args, **kwargs)

    return inner


def each_on_threads(fn: Callable[[T], object], items: Sequence[T], threads: int) -> None:
    """``fn(item)`` for every item, on up to ``threads`` threads with one BLAS thread each
    (:func:`one_blas_thread`), or in turn where one thread or one item.

    For work split into blocks that write disjoint parts of a result (numpy and
    the compiled kernels release the GIL): the same values on any thread count.
    An exception in ``fn`` is raised here.
    """
    if threads > 1 and len(items) > 1:
        from concurrent.futures import ThreadPoolExecutor

        with one_blas_thread(), ThreadPoolExecutor(threads) as ex:
            list(ex.map(fn, items))
    else:
        for item in items:
            fn(item)
