"""Worker-pool helpers of the identification (kept light: a worker imports only this
module and :mod:`robolobe.modal.posture`, not pandas or the campaign code)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe._threads import one_blas_thread
from robolobe.modal.posture import PostureModal, identify_posture, refit_posture

__all__ = ["identify_item", "map_chunks", "refit_item"]


def identify_item(a: tuple[Any, ...]) -> PostureModal:
    """:func:`identify_posture` of ``(posture_id, freq_hz, H, coherence, settings)``."""
    pid, f, h, coh, s = a
    return identify_posture(f, h, coherence=coh, settings=s, posture_id=pid)


def refit_item(a: tuple[PostureModal, NDArray[np.complex128]]) -> PostureModal:
    """:func:`refit_posture` of ``(posture, extra_poles)``."""
    return refit_posture(a[0], a[1])


def _run_chunk(fn: Callable[[Any], PostureModal], part: Sequence[Any]) -> list[PostureModal]:
    """``[fn(x) for x in part]`` with one BLAS thread (in a worker process)."""
    with one_blas_thread():
        return [fn(x) for x in part]


def map_chunks(
    fn: Callable[[Any], PostureModal],
    items: Sequence[Any],
    n_jobs: int,
    progress: Callable[[int], None] | None = None,
    chunk: int = 8,
) -> list[PostureModal]:
    """``[fn(x) for x in items]``, in chunks over joblib workers (one BLAS thread each).

    Parameters
    ----------
    fn : callable
        A module-level function (workers import it by name).
    items : sequence
        Its arguments, one per call.
    n_jobs : int
        Workers (1: in this process; -1: all cores).
    progress : callable, optional
        Called with the number of items just finished.
    chunk : int
        Items per task.
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

    results: list[PostureModal] = []
    # each task carries only its own chunk (a closure over ``items`` would send the
    # whole campaign to the workers with every chunk)
    gen = Parallel(n_jobs=n_jobs, return_as="generator")(
        delayed(_run_chunk)(fn, items[a : a + chunk]) for a in range(0, n, chunk)
    )
    for part in gen:
        results.extend(part)
        if progress is not None:
            progress(len(part))
    return results
