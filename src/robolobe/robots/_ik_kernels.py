"""Compiled (numba) nearest-branch continuity along a path.

The loop over waypoints is sequential by nature (each pose takes the valid
solution nearest the previous one); compiled, one waypoint costs a few
hundred nanoseconds instead of tens of microseconds. Same arithmetic as the
numpy reference in :func:`robolobe.robots.ik._continuity_numpy` (tested equal).
Import only after :func:`robolobe._jit.available`; caching: :mod:`robolobe._jit`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robolobe._jit import njit

FloatArray = NDArray[np.float64]

_TWO_PI = 2.0 * math.pi


@njit()
def continuity(
    base: FloatArray,
    count: NDArray[np.int64],
    exists: NDArray[np.bool_],
    wts: FloatArray,
    coeffs: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    tol: float,
    prev: FloatArray,
    out: FloatArray,
    good: NDArray[np.bool_],
    branch: NDArray[np.int64],
) -> None:
    """Nearest valid solution per waypoint, each relative to the previous one.

    Parameters
    ----------
    base, count : ndarray, shape (n, 8, 6)
        Lowest in-limit 2*pi turn [rad] and number of turns per branch and joint.
    exists : ndarray of bool, shape (n, 8)
    wts : ndarray, shape (6,)
        Joint weights of the squared distance.
    coeffs, lo, hi : ndarray, shapes (m, 6), (m,), (m,)
        Linear constraints ``lo - tol <= coeffs @ q <= hi + tol`` [rad].
    prev : ndarray, shape (6,)
        Posture before the first waypoint [rad] (updated in place).
    out : ndarray, shape (n, 6)
        Chosen postures [rad] (NaN where none is valid).
    good : ndarray of bool, shape (n,)
        Whether a valid solution existed; a failing waypoint leaves ``prev``.
    branch : ndarray of int, shape (n,)
        Branch (index along axis 1 of ``base``) of each chosen posture; -1 where none.
    """
    n = base.shape[0]
    nc = coeffs.shape[0]
    cand = np.empty(6)
    best = np.empty(6)
    for i in range(n):
        dbest = np.inf
        found = False
        bbest = -1
        for b in range(base.shape[1]):
            if not exists[i, b]:
                continue
            for j in range(6):
                kmax = max(count[i, b, j] - 1, 0)
                k = np.rint((prev[j] - base[i, b, j]) / _TWO_PI)
                k = min(max(k, 0.0), float(kmax))
                cand[j] = base[i, b, j] + _TWO_PI * k
            valid = True
            for m in range(nc):
                v = 0.0
                for j in range(6):
                    v += cand[j] * coeffs[m, j]
                if not (v >= lo[m] - tol and v <= hi[m] + tol):
                    valid = False
                    break
            if not valid:
                continue
            d = 0.0
            for j in range(6):
                d += wts[j] * (cand[j] - prev[j]) ** 2
            if not found or d < dbest:
                found = True
                dbest = d
                bbest = b
                best[:] = cand
        good[i] = found
        branch[i] = bbest
        if found:
            out[i] = best
            prev[:] = best
        else:
            out[i] = np.nan
