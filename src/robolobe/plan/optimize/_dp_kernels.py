"""Compiled (numba) dynamic program of the schedule search (:func:`._search._search`).

The recursion of the numpy path, ``v_b = cost_b + window_min(v_{b-1})``, with
the windowed minimum by a monotone queue (the rate windows' ends never move
back as the speed rises) instead of a sparse table: the same minima, the
same additions, so the same values bit for bit.

Import only after :func:`robolobe._jit.available`; caching: :mod:`robolobe._jit`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from robolobe._jit import njit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]


@njit()
def _dp(
    a_blk: FloatArray,
    length: FloatArray,
    inv_n: FloatArray,
    sf_d: FloatArray,
    ok: BoolArray,
    lo: IntArray,
    hi: IntArray,
    vals: FloatArray,
) -> FloatArray:
    """Final values (D, J); with ``vals`` of shape (kb, J) (D == 1) every block's too."""
    kb, nj = a_blk.shape
    nd = sf_d.shape[0]
    keep = vals.shape[0] == kb
    out = np.empty((nd, nj))
    v = np.empty(nj)
    w = np.empty(nj)
    dq = np.empty(nj, np.int64)
    for d in range(nd):
        sf = sf_d[d]
        for j in range(nj):
            feas = a_blk[0, j] >= sf and ok[d, j]
            v[j] = length[0] * inv_n[j] if feas else np.inf
        if keep:
            vals[0, :] = v
        for b in range(1, kb):
            # window minimum of v over [lo[j], hi[j]] (both non-decreasing in j)
            head = 0
            tail = 0
            r = -1
            for j in range(nj):
                while r < hi[b - 1, j]:
                    r += 1
                    while tail > head and v[dq[tail - 1]] >= v[r]:
                        tail -= 1
                    dq[tail] = r
                    tail += 1
                while dq[head] < lo[b - 1, j]:
                    head += 1
                w[j] = v[dq[head]]
            lb = length[b]
            for j in range(nj):
                feas = a_blk[b, j] >= sf and ok[d, j]
                c = lb * inv_n[j] if feas else np.inf
                v[j] = c + w[j]
            if keep:
                vals[b, :] = v
        out[d, :] = v
    return out


def monotone(lo: IntArray, hi: IntArray) -> bool:
    """Whether every window lies on the grid, is not empty and its ends rise with the speed.

    (What the kernel's queue needs; it does not check indices.)
    """
    nj = lo.shape[-1]
    return bool(
        np.all(np.diff(lo, axis=-1) >= 0)
        and np.all(np.diff(hi, axis=-1) >= 0)
        and np.all(lo <= hi)
        and np.all(lo >= 0)
        and np.all(hi < nj)
    )


def dp(
    a_blk: FloatArray,
    length: FloatArray,
    inv_n: FloatArray,
    sf_d: FloatArray,
    ok: BoolArray,
    lo: IntArray,
    hi: IntArray,
    *,
    keep: bool = False,
) -> tuple[FloatArray, FloatArray | None]:
    """The search's dynamic program over blocks for a ladder of depths.

    Parameters
    ----------
    a_blk : ndarray, shape (kb, J)
        Block minimum of the limit on the speed grid [m].
    length : ndarray, shape (kb,)
        Cutting length per block [m].
    inv_n : ndarray, shape (J,)
        Time per metre at each grid speed [s/m].
    sf_d : ndarray, shape (D,)
        Safety factor times each depth [m].
    ok : ndarray of bool, shape (D, J)
        Speeds allowed at each depth (range and power).
    lo, hi : ndarray of int, shape (kb - 1, J)
        Grid index range that may precede each speed between blocks b and b + 1
        (:func:`robolobe.plan.optimize._common._rate_windows`; :func:`monotone`).
    keep : bool
        Also return every block's values (needs D == 1).

    Returns
    -------
    v : ndarray, shape (D, J)
        Least cutting time to the end of the last block at each speed [s].
    vals : ndarray, shape (kb, J), or None
        With ``keep``, the values after each block.
    """
    kb, nj = a_blk.shape
    vals = np.empty((kb, nj)) if keep else np.empty((0, nj))
    out = _dp(
        np.ascontiguousarray(a_blk, dtype=np.float64),
        np.ascontiguousarray(length, dtype=np.float64),
        np.ascontiguousarray(inv_n, dtype=np.float64),
        np.ascontiguousarray(sf_d, dtype=np.float64),
        np.ascontiguousarray(ok, dtype=np.bool_),
        np.ascontiguousarray(lo, dtype=np.int64).reshape(-1, nj),
        np.ascontiguousarray(hi, dtype=np.int64).reshape(-1, nj),
        vals,
    )
    return out, (vals if keep else None)
