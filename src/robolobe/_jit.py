"""numba, imported on demand, with an on-disk cache that degrades gracefully.

The compiled kernels (:mod:`robolobe.sld._kernels`, :mod:`robolobe.robots._ik_kernels`)
are decorated with :func:`njit`. Caching: numba writes the compiled code
beside the source (``__pycache__``) or, where that is read-only, in the user
cache directory (``NUMBA_CACHE_DIR`` overrides both). A fresh install or a CI
run compiles each kernel once on its first call (seconds); later processes
load it from the cache (milliseconds). Where no cache location is writable the
kernels are compiled in every process instead (slower start, same results).

``ROBOLOBE_NO_JIT=1`` (or numba missing) makes :func:`available` False: callers
then take their numpy reference path.

Size dispatch (:func:`use_compiled`): numba's start-up in a fresh process
(importing it, ~0.25 s CPU, and its first dispatch loading the target's
registries and the cached kernel, ~0.3 s CPU; measured on the 2-core
development machine) costs more than a small plan's whole work on the numpy
paths, so each kernel runs compiled only from a measured size on, and below
it numba is not even imported. Once one kernel module is loaded the next
pays only its own cache load (~10-30 ms), hence a second, smaller threshold
per kernel for a process where numba has started.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

__all__ = ["available", "cache_enabled", "njit", "started", "use_compiled"]

_STATE: dict[str, bool] = {}
#: The numpy paths' work so far in this process, as a fraction of numba's start-up.
_SPENT = [0.0]


def available() -> bool:
    """Whether compiled kernels may be used (numba importable and not disabled)."""
    if "ok" not in _STATE:
        if os.environ.get("ROBOLOBE_NO_JIT", "").strip() not in ("", "0"):
            _STATE["ok"] = False
        else:
            # The parallel kernels run short regions, tens per plan; OpenMP's default
            # of spinning idle threads after each (numba's 'omp' layer) cost ~8 ms CPU
            # per call, more than many a call's work. Idle threads sleep instead
            # (unless the user chose otherwise); set before numba starts its threads.
            os.environ.setdefault("OMP_WAIT_POLICY", "passive")
            try:
                import numba  # noqa: F401
            except ImportError:
                _STATE["ok"] = False
            else:
                _STATE["ok"] = True
    return _STATE["ok"]


def started() -> bool:
    """Whether a compiled kernel module was loaded in this process (numba's start-up paid)."""
    return _STATE.get("started", False)


def use_compiled(work: float, *, cold: float, warm: float) -> bool:
    """Whether a kernel with ``work`` units runs compiled (numba imported only if so).

    Parameters
    ----------
    work : float
        The call's size in the kernel's own unit (its threshold's comment
        says which).
    cold, warm : float
        The measured crossovers: the size from which the compiled kernel,
        numba's start-up in this process included, beats the numpy path
        (``cold``), and from which it does so where numba has started
        already (:func:`started`: only the kernel's cache load left, ``warm``;
        the smaller of the two applies there).

    Returns
    -------
    bool
        True where ``work`` reaches the threshold that applies and numba is
        :func:`available`; False without importing numba below it, unless the
        numpy paths taken so far in this process (each ``work / cold`` of the
        start-up) add up to the start-up: then True from this call on.
    """
    if started():
        return work >= min(warm, cold) and available()
    if work < cold:
        # the numpy path, its cost counted against numba's start-up (``work / cold``
        # of it): once the numpy paths of this process have cost about as much as the
        # start-up would (many small calls: a test run, a batch), numba starts, so a
        # process never pays more than about twice the better of the two
        spent = _SPENT[0] + max(work, 0.0) / cold
        if spent < 1.0:
            _SPENT[0] = spent
            return False
    return available()


def cache_enabled() -> bool:
    """False once a kernel had to be compiled without an on-disk cache."""
    return _STATE.get("cache", True)


def njit(*, parallel: bool = False) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(cache=True, nogil=True)``, falling back to no cache if none is writable.

    ``error_model="numpy"``: a float division by zero gives inf/nan as in
    numpy (the reference paths) instead of raising, without a test per division.
    """
    import numba

    _STATE["started"] = True  # a kernel module is being loaded: numba's start-up paid
    opts: dict[str, Any] = {"parallel": parallel, "nogil": True, "error_model": "numpy"}

    def deco(fn: Callable[..., Any]) -> Any:
        try:
            return numba.njit(cache=True, **opts)(fn)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            _STATE["cache"] = False
            return numba.njit(cache=False, **opts)(fn)

    return deco
