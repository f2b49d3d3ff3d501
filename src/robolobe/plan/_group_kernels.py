"""Compiled (numba) leader clustering of waypoint dynamics (lobes.group_dynamics).

The leaders are taken in path order (each the centred leader of the first row
not yet grouped, :func:`robolobe.plan.lobes._centred`), each taking every row
not yet grouped within ``radius`` in the max norm, as the cKDTree loop of
:func:`robolobe.plan.lobes._leaders_tree` does (the same comparisons,
``max |f_j - f_lead| <= radius`` in floating point, so the same groups); the
candidates of a leader come from a window of the rows sorted by one feature
instead of a tree.

Import only after :func:`robolobe._jit.available`; caching: :mod:`robolobe._jit`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from robolobe._jit import njit

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@njit()
def _leaders(
    f: FloatArray, col: int, order: IntArray, key: FloatArray, radius: float, label: IntArray
) -> IntArray:
    """Leader clustering of the rows of ``f`` (m, F) in row order.

    ``order`` sorts the rows by feature ``col`` and ``key`` is that column
    sorted; ``label`` (m,) is filled with each row's leader number. Returns
    the leaders' rows.
    """
    m, nf = f.shape
    leaders = np.empty(m, np.int64)
    n_lead = 0
    for first in range(m):
        if label[first] >= 0:
            continue
        # the centred leader (lobes._centred): the last of the rows following ``first``
        # not yet grouped and within the radius of it
        lead = first
        while lead + 1 < m and label[lead + 1] < 0:
            near = True
            for c in range(nf):
                if abs(f[lead + 1, c] - f[first, c]) > radius:
                    near = False
                    break
            if not near:
                break
            lead += 1
        x = f[lead, col]
        # a window twice as wide as the radius (a superset whatever the rounding of
        # x +- radius); the exact test below decides
        lo = np.searchsorted(key, x - 2.0 * radius, side="left")
        hi = np.searchsorted(key, x + 2.0 * radius, side="right")
        for t in range(lo, hi):
            j = order[t]
            if label[j] >= 0:
                continue
            near = True
            for c in range(nf):
                if abs(f[j, c] - f[lead, c]) > radius:
                    near = False
                    break
            if near:
                label[j] = n_lead
        leaders[n_lead] = lead
        n_lead += 1
    return leaders[:n_lead].copy()


def leaders(f: FloatArray, radius: float) -> tuple[IntArray, IntArray]:
    """Leader clustering in the max norm (rows in path order).

    Parameters
    ----------
    f : ndarray, shape (m, F)
        Scaled features, one row per distinct model, in path order.
    radius : float
        Largest max-norm distance of a member from its leader.

    Returns
    -------
    label : ndarray of int, shape (m,)
        Group of each row (groups numbered in the order of their leaders).
    lead : ndarray of int, shape (n_groups,)
        Row of each group's leader.
    """
    x = np.ascontiguousarray(f, dtype=np.float64)
    label = np.full(x.shape[0], -1, np.int64)
    if x.shape[0] == 0:
        return label, np.zeros(0, np.int64)
    col = int(np.argmax(np.ptp(x, axis=0))) if x.shape[1] else 0
    if x.shape[1] == 0:
        x = np.zeros((x.shape[0], 1))
    order = np.argsort(x[:, col], kind="stable").astype(np.int64)
    key = np.ascontiguousarray(x[order, col])
    lead = _leaders(x, col, order, key, float(radius), label)
    return label, np.asarray(lead, np.int64)
