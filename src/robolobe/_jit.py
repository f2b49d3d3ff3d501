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
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

__all__ = ["available", "cache_enabled", "njit"]

_STATE: dict[str, bool] = {}


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


def cache_enabled() -> bool:
    """False once a kernel had to be compiled without an on-disk cache."""
    return _STATE.get("cache", True)


def njit(*, parallel: bool = False) -> Callable[[Callable[..., Any]], Any]:
    """``numba.njit(cache=True, nogil=True)``, falling back to no cache if none is writable.

    ``error_model="numpy"``: a float division by zero gives inf/nan as in
    numpy (the reference paths) instead of raising, without a test per division.
    """
    import numba

    opts: dict[str, Any] = {"parallel": parallel, "nogil": True, "error_model": "numpy"}

    def deco(fn: Callable[..., Any]) -> Any:
        try:
            return numba.njit(cache=True, **opts)(fn)
        except RuntimeError:  # "cannot cache function ...: no locator available"
            _STATE["cache"] = False
            return numba.njit(cache=False, **opts)(fn)

    return deco
