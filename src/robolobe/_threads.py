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
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import Any, ParamSpec, TypeVar

__all__ = ["one_blas_thread", "with_one_blas_thread"]

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
