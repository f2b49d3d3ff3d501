"""The one mode-matching routine against an exhaustive search, batching, gating."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from robolobe._matching import match_modes
from robolobe.errors import InputError


def _best_by_enumeration(cost: np.ndarray, gate: float) -> tuple[int, float]:
    """Most admissible pairs, then least total cost, over every partial one-to-one pairing."""
    n_a, n_b = cost.shape
    ok = np.isfinite(cost) & (cost <= gate)
    best = (0, 0.0)
    for k in range(1, min(n_a, n_b) + 1):
        for rows in itertools.combinations(range(n_a), k):
            for cols in itertools.permutations(range(n_b), k):
                if not all(ok[r, c] for r, c in zip(rows, cols, strict=True)):
                    continue
                total = float(sum(cost[r, c] for r, c in zip(rows, cols, strict=True)))
                if k > best[0] or (k == best[0] and total < best[1]):
                    best = (k, total)
    return best


@pytest.mark.parametrize("shape", [(3, 4), (4, 3), (4, 4), (2, 5)])
def test_equals_exhaustive_search_with_forbidden_pairs_and_gate(shape: tuple[int, int]) -> None:
    rng = np.random.default_rng(sum(shape))
    for trial in range(25):
        cost = rng.exponential(1.0, shape)
        cost[rng.random(shape) < 0.3] = np.inf
        if trial % 3 == 0:
            cost[rng.integers(shape[0])] = np.nan  # an absent mode
        gate = [np.inf, 1.5, 0.7][trial % 3]
        rows, cols = match_modes(cost, gate=gate)
        n_best, total_best = _best_by_enumeration(cost, gate)
        assert rows.size == n_best
        assert float(cost[rows, cols].sum()) == pytest.approx(total_best, abs=1e-12)
        assert np.all(cost[rows, cols] <= gate)
        assert len(set(rows.tolist())) == rows.size
        assert len(set(cols.tolist())) == cols.size
        assert np.all(np.diff(rows) > 0)


def test_more_pairs_win_over_a_lower_total() -> None:
    # pairing (0, 0) alone costs 0.1; (0, 1) + (1, 0) cost 2.0 but pair both modes
    cost = np.array([[0.1, 1.0], [1.0, np.inf]])
    rows, cols = match_modes(cost)
    assert rows.tolist() == [0, 1]
    assert cols.tolist() == [1, 0]


def test_batch_equals_one_problem_at_a_time() -> None:
    rng = np.random.default_rng(4)
    cost = rng.exponential(1.0, (3, 2, 4, 5))
    cost[rng.random(cost.shape) < 0.2] = np.inf
    got = match_modes(cost, gate=2.0)
    assert len(got) == 4
    want: list[tuple[int, ...]] = []
    for i in range(3):
        for j in range(2):
            r, c = match_modes(cost[i, j], gate=2.0)
            want += [(i, j, int(a), int(b)) for a, b in zip(r, c, strict=True)]
    assert list(zip(*(g.tolist() for g in got), strict=True)) == want


def test_empty_and_wrong_inputs() -> None:
    rows, cols = match_modes(np.zeros((0, 3)))
    assert rows.size == cols.size == 0
    rows, cols = match_modes(np.full((2, 2), np.inf))
    assert rows.size == 0
    with pytest.raises(InputError, match="cost"):
        match_modes(np.ones(3))


def test_row_minima_shortcut_gives_the_assignment() -> None:
    """Batches where most problems are solved by their rows' least costs (the shortcut) and
    some are not (ties, two rows wanting one column, near-ties, absent rows): each problem's
    pairs are those of scipy's assignment on the gated matrix (written for the test)."""
    from scipy.optimize import linear_sum_assignment

    rng = np.random.default_rng(11)
    for trial in range(40):
        n_a, n_b = int(rng.integers(2, 7)), int(rng.integers(2, 9))
        cost = rng.exponential(1.0, (20, n_a, n_b))
        cost[rng.random(cost.shape) < 0.15] = np.inf
        cost[rng.random(cost.shape[:2]) < 0.1] = np.nan  # absent modes
        if trial % 4 == 1:
            cost = np.round(cost, 1)  # ties
        if trial % 4 == 2:
            cost[:5, :, 1] = cost[:5, :, 0] * (1.0 + 1e-14)  # near-ties
        if trial % 4 == 3:
            cost[:, :, -1] = 0.5  # one column the best of many rows
        gate = [np.inf, 1.2][trial % 2]
        got = match_modes(cost, gate=gate)
        for b in range(20):
            c = cost[b]
            ok = np.isfinite(c) & (c <= gate)
            mine = got[0] == b
            rows, cols = got[1][mine], got[2][mine]
            if not ok.any():
                assert rows.size == 0
                continue
            big = c[ok].max() + (np.ptp(c[ok]) + 1.0) * (min(c.shape) + 1)
            r, k = linear_sum_assignment(np.where(ok, c, big))
            keep = ok[r, k]
            assert rows.size == int(keep.sum())
            # the same number of pairs and the same total: ties may pick other partners
            assert float(c[rows, cols].sum()) == pytest.approx(float(c[r, k][keep].sum()))
            col = np.where(ok, c, np.inf).argmin(axis=1)
            least = np.sort(np.where(ok, c, np.inf), axis=1)
            unique = ok.any(axis=1)
            strict = least[unique, 1] - least[unique, 0] > 1e-6 if c.shape[1] > 1 else True
            if np.all(strict) and len(set(col[unique])) == unique.sum():
                # one optimum: every row with a partner at its least cost
                assert rows.tolist() == np.flatnonzero(unique).tolist()
                assert cols.tolist() == col[unique].tolist()


def test_huge_costs_are_refused_in_a_batch() -> None:
    cost = np.ones((3, 2, 2))
    cost[2, 0, 0] = 1e308
    with pytest.raises(InputError, match="1e300"):
        match_modes(cost)
