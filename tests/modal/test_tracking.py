"""Mode tracking across postures: order-preserving alignment with gaps, spectral neighbours."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.tracking import (
    TrackingSettings,
    _align,
    spectral_distances,
    track_modes,
)


def _family(n: int, seed: int = 0):  # type: ignore[no-untyped-def]
    """n postures along a path; 4 mode families whose frequencies drift by up to 25 %."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n)
    base = np.array([6.0, 9.0, 14.0, 25.0])
    f = base[None] * (1 + 0.25 * np.sin(2 * t[:, None] + np.arange(4)))
    z = np.full((n, 4), 0.02) * (1 + 0.1 * rng.normal(size=(n, 4)))
    shapes = np.stack([np.eye(3)[[0, 1, 2, 0]] + 0.1] * n)
    q = np.zeros((n, 6))
    q[:, 1] = t
    order = rng.permutation(n)  # postures in shuffled order
    return f[order], z[order], shapes[order], q[order], order


def test_families_tracked_consistently_with_a_hidden_mode() -> None:
    f, z, u, q, _ = _family(15)
    F = [x.copy() for x in f]
    Z = [x.copy() for x in z]
    U = [x.copy() for x in u]
    # posture 4 misses family 1 (hidden at every driving point)
    F[4], Z[4], U[4] = np.delete(F[4], 1), np.delete(Z[4], 1), np.delete(U[4], 1, axis=0)
    tr = track_modes(F, Z, U, [False] * 15, q)
    assert tr.n_tracks == 4
    ref = tr.labels[0]
    for p in range(15):
        expect = np.delete(ref, 1) if p == 4 else ref
        np.testing.assert_array_equal(tr.labels[p], expect)
    assert tr.mode_of(4, int(ref[1])) is None
    assert len(tr.members(int(ref[0]))) == 15
    assert sorted(tr.order.tolist()) == list(range(15))
    assert (tr.parent == -1).sum() == 1


def test_free_assignment_option_and_new_track_for_outlier() -> None:
    f, z, u, q, _ = _family(6, seed=1)
    F = [x.copy() for x in f]
    F[2] = np.append(F[2], 39.0)  # an extra mode in one posture only
    Z = [np.append(x, 0.02) if i == 2 else x for i, x in enumerate(z)]
    U = [np.vstack([x, [[0.3, 0.3, 0.3]]]) if i == 2 else x for i, x in enumerate(u)]
    for order_preserving in (True, False):
        tr = track_modes(
            F, Z, U, [True] * 6, q, settings=TrackingSettings(order_preserving=order_preserving)
        )
        assert tr.n_tracks == 5
        assert tr.labels[2][-1] not in tr.labels[0]


def test_align_is_order_preserving_with_gaps() -> None:
    cost = np.array([[0.0, 5.0, 9.0], [5.0, 9.0, 0.5]])  # mode 1 pairs with track 2, track 1 gap
    assert _align(cost, gap=4.0, big=1e6) == [(0, 0), (1, 2)]
    big = np.full((2, 2), 1e6)
    assert _align(big, gap=4.0, big=1e6) == []


def test_spectral_distance_and_validation() -> None:
    d = spectral_distances([np.array([5.0, 10.0]), np.array([5.0, 10.0]), np.array([6.0, 12.0])])
    assert d[0, 1] == pytest.approx(0.0)
    assert d[0, 2] == pytest.approx(2 * np.log(1.2))
    assert np.allclose(d, d.T)
    with pytest.raises(InputError, match="postures"):
        track_modes([np.ones(2)], [np.ones(2)], [np.ones((2, 3))], [True], np.zeros((2, 6)))
    with pytest.raises(InputError, match="gate"):
        TrackingSettings(gate=0)
