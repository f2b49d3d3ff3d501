"""The project's worker pool: a map over joblib processes, one BLAS thread each.

Identification (per posture) and diagnosis (per candidate model) both fan
independent fits out over worker processes; this is the one place that
does it. Imports no robolobe package besides :mod:`robolobe._threads`, so
every layer may use it and a worker stays light.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from robolobe._threads import one_blas_thread

__all__ = ["MAX_WORKERS", "map_chunks"]

#: Most worker processes a command starts (a larger number is a typing slip:
#: ``--workers 2**64``); fewer are started where there is less work.
MAX_WORKERS = 256

T = TypeVar("T")


def _run_part(fn: Callable[[Any], T], part: Sequence[Any]) -> list[T]:
    """``[fn(x) for x in part]`` with one BLAS thread (in a worker process)."""
    with one_blas_thread():
        return [fn(x) for x in part]


def map_chunks(
    fn: Callable[[Any], T],
    items: Sequence[Any],
    n_jobs: int,
    *,
    chunk: int = 8,
    parts: int | None = None,
    progress: Callable[[int], None] | None = None,
) -> list[T]:
    """``[fn(x) for x in items]``, in order, over joblib worker processes.

    Each task carries only its own items (and one copy of what ``fn`` holds,
    e.g. a :func:`functools.partial`'s arguments) and runs with one BLAS
    thread. The calls are independent, so the result is that of one process.

    Parameters
    ----------
    fn : callable
        A picklable function of one item (module-level, or a partial of one).
    items : sequence
        Its arguments, one per call.
    n_jobs : int
        Worker processes (1: in this process, as do fewer than 4 items; -1:
        all cores).
    chunk : int
        Consecutive items per task (when ``parts`` is None).
    parts : int, optional
        Deal the items round-robin into this many tasks instead, so that
        costly items next to each other go to different workers.
    progress : callable, optional
        Called with the number of items just finished.

    Returns
    -------
    list
        ``fn(x)`` per item, in the order of ``items``.
    """
    n = len(items)
    if n_jobs == 1 or n < 4:
        out = []
        for x in items:
            out.append(fn(x))
            if progress is not None:
                progress(1)
        return out
    from joblib import Parallel, delayed

    if parts is None:
        index = [list(range(a, min(a + chunk, n))) for a in range(0, n, chunk)]
    else:
        k = max(1, min(n, int(parts)))
        index = [list(range(i, n, k)) for i in range(k)]
    results: list[Any] = [None] * n
    gen = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_run_part)(fn, [items[j] for j in idx]) for idx in index
    )
    for idx, got in zip(index, gen, strict=True):
        for j, r in zip(idx, got, strict=True):
            results[j] = r
        if progress is not None:
            progress(len(idx))
    return results
