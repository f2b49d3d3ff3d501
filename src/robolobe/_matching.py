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
    A problem whose rows each have one strictly least admissible cost, in
    distinct columns, is solved by those minima without the assignment (its
    one optimum: the same pairs); most problems of a calibration near its
    fit are such.
    """
    c = np.asarray(cost, dtype=np.float64)
    if c.ndim < 2:
        raise InputError(f"cost: expected shape (..., n_a, n_b), found {c.shape}")
    batch = c.shape[:-2]
    flat = c.reshape(int(np.prod(batch, dtype=np.intp)), *c.shape[-2:])
    easy, col, active = _row_minima(flat, gate)
    # the easy problems at once: every row that has a partner takes its least-cost one
    b0, i0 = np.nonzero(easy[:, None] & active)
    b_parts, i_parts, j_parts = [b0], [i0], [col[b0, i0]]
    for b in np.flatnonzero(~easy):
        i, j = _assign(flat[b], gate)
        b_parts.append(np.full(i.size, b, dtype=np.intp))
        i_parts.append(i)
        j_parts.append(j)
    bb, ii, jj = (np.concatenate(p).astype(np.intp) for p in (b_parts, i_parts, j_parts))
    order = np.argsort(bb, kind="stable")  # by problem, each one's rows rising
    bb, ii, jj = bb[order], ii[order], jj[order]
    idx = np.unravel_index(bb, batch) if batch else ()
    return tuple(np.asarray(a, dtype=np.intp) for a in (*idx, ii, jj))


def _row_minima(
    flat: NDArray[np.float64], gate: float
) -> tuple[NDArray[np.bool_], IntArray, NDArray[np.bool_]]:
    """Problems solved by their row minima, and each row's least-cost column.

    A problem whose rows with an admissible pair each have one strictly least
    admissible cost (by more than rounding), all in different columns, has
    that pairing as its one optimum (every such row is paired, each at the
    least cost it can have): :func:`_assign` would return it. These are most
    problems of a fit near its solution; the others go to :func:`_assign`.

    Parameters
    ----------
    flat : ndarray, shape (n_problems, n_a, n_b)
    gate : float

    Returns
    -------
    easy : ndarray of bool, shape (n_problems,)
    col : ndarray of int, shape (n_problems, n_a)
        Least-cost admissible column of each row (meaningless where a row has none).
    active : ndarray of bool, shape (n_problems, n_a)
        Rows with an admissible pair.

    Raises
    ------
    InputError
        Admissible costs so large that :func:`_assign` could not order them.
    """
    n_p, n_a, n_b = flat.shape
    if n_p == 0 or n_a == 0 or n_b == 0:
        none = np.zeros((n_p, n_a), dtype=bool)
        return np.zeros(n_p, dtype=bool), np.zeros((n_p, n_a), dtype=np.intp), none
    ok = np.isfinite(flat) & (flat <= gate)
    masked = np.where(ok, flat, np.inf)
    any_ok = ok.any(axis=(-2, -1))
    with np.errstate(invalid="ignore", over="ignore"):
        lo = np.where(any_ok, masked.min(axis=(-2, -1)), 0.0)
        hi = np.where(any_ok, np.where(ok, flat, -np.inf).max(axis=(-2, -1)), 0.0)
        big = hi + (hi - lo + 1.0) * (min(n_a, n_b) + 1)
    if not np.all(np.isfinite(big)):
        bad = float(hi[~np.isfinite(big)][0])
        raise InputError(f"cost: expected admissible costs of magnitude < 1e300, found {bad:.3g}")
    col = np.argmin(masked, axis=-1)  # (n_p, n_a)
    least = np.take_along_axis(masked, col[..., None], axis=-1)[..., 0]
    second = np.partition(masked, 1, axis=-1)[..., 1] if n_b > 1 else np.full((n_p, n_a), np.inf)
    active: NDArray[np.bool_] = np.asarray(ok.any(axis=-1))  # (n_p, n_a)
    # a margin far above the rounding of the assignment's sums (costs and big)
    margin = 1e-9 * (np.abs(big) + np.abs(lo) + 1.0)
    with np.errstate(invalid="ignore"):  # inf - inf in rows without a partner
        strict = ~active | (second - least > margin[:, None])
    # least-cost columns all different (a row without a partner takes part in no pair)
    key = np.where(active, col, -1 - np.arange(n_a))
    distinct = (np.diff(np.sort(key, axis=-1), axis=-1) != 0).all(axis=-1)
    easy: NDArray[np.bool_] = np.asarray(strict.all(axis=-1) & distinct)
    return easy, np.asarray(col, dtype=np.intp), active
