"""Pairing two lists of modes: the project's one assignment routine.

Every place that pairs modes of two lists (identified modes with a twin's,
a posture's modes with the tracks of its neighbour, estimated modes with
true ones) builds its own cost matrix (what makes two modes alike is its
own business: frequency, modal stiffness, damping, shape) and hands it to
:func:`match_modes`, which solves the linear sum assignment (Hungarian
method, :func:`scipy.optimize.linear_sum_assignment`) with gating:

* a pair is *admissible* when its cost is finite and at most ``gate``;
  ``+inf`` or ``nan`` mark a pair (or a whole absent row) as forbidden;
* among all one-to-one pairings the routine takes the one with the most
  admissible pairs and, among those, the least total cost of them
  (forbidden pairs cost a constant larger than any difference of admissible
  totals); unpaired modes are those left without an admissible partner.

This module imports no robolobe package (only :mod:`robolobe.errors`), so every
layer may use it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import linear_sum_assignment

from robolobe.errors import InputError

__all__ = ["match_modes"]

IntArray = NDArray[np.intp]


def _assign(cost: NDArray[np.float64], gate: float) -> tuple[IntArray, IntArray]:
    ok = np.isfinite(cost) & (cost <= gate)
    if not ok.any():
        empty = np.zeros(0, dtype=np.intp)
        return empty, empty
    vals = cost[ok]
    lo, hi = float(vals.min()), float(vals.max())
    # one forbidden pair costs more than any two admissible pairings differ
    big = hi + (hi - lo + 1.0) * (min(cost.shape) + 1)
    if not np.isfinite(big):
        raise InputError(f"cost: expected admissible costs of magnitude < 1e300, found {hi:.3g}")
    rows, cols = linear_sum_assignment(np.where(ok, cost, big))
    keep = ok[rows, cols]
    return np.asarray(rows[keep], dtype=np.intp), np.asarray(cols[keep], dtype=np.intp)


def match_modes(cost: ArrayLike, *, gate: float = np.inf) -> tuple[IntArray, ...]:
    """Pair the modes of two lists by least total cost (gated linear sum assignment).

    Parameters
    ----------
    cost : array_like, shape (..., n_a, n_b)
        ``cost[..., i, j]``: cost of pairing mode i of the first list with
        mode j of the second (any units; lower is more alike). ``+inf`` or
        ``nan`` forbid a pair. Leading dimensions are a batch of independent
        problems (e.g. postures and directions).
    gate : float
        Largest admissible cost of a pair (default: no gate).

    Returns
    -------
    tuple of ndarray of int
        ``(*batch_index, i, j)`` of the admissible pairs, one array per
        dimension of ``cost`` (as :func:`numpy.nonzero`), ordered by batch
        index and then by ``i``. For a 2-D ``cost``: ``(i, j)``.

    Notes
    -----
    The pairing has the most admissible pairs possible and, among those,
    the least sum of their costs; every mode takes part in at most one pair.
    """
    c = np.asarray(cost, dtype=np.float64)
    if c.ndim < 2:
        raise InputError(f"cost: expected shape (..., n_a, n_b), found {c.shape}")
    batch = c.shape[:-2]
    flat = c.reshape(int(np.prod(batch, dtype=np.intp)), *c.shape[-2:])
    out: list[list[IntArray]] = [[] for _ in range(c.ndim)]
    for b in range(flat.shape[0]):
        i, j = _assign(flat[b], gate)
        idx = np.unravel_index(np.full(i.size, b, dtype=np.intp), batch) if batch else ()
        for d, a in enumerate((*idx, i, j)):
            out[d].append(np.asarray(a, dtype=np.intp))
    return tuple(np.concatenate(parts) if parts else np.zeros(0, dtype=np.intp) for parts in out)
