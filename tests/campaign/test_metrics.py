"""FRAC, NRMSE (seed eqs. 5-6) and MAC: closed forms and hand-computed values."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.campaign.metrics import frac, mac, mac_matrix, nrmse


def test_frac_hand_values() -> None:
    hm = np.array([1 + 1j, 2 - 1j, -1 + 0.5j])
    hp = np.array([1 + 0j, 2 + 0j, -1 + 0j])
    num = abs(np.sum(hp * np.conj(hm))) ** 2
    den = np.sum(abs(hp) ** 2) * np.sum(abs(hm) ** 2)
    assert frac(hp, hm) == pytest.approx(num / den, rel=1e-14)
    # hand value: sum hp conj(hm) = (1-1j)+(4+2j)+(1+0.5j) = 6+1.5j -> 38.25; 6 * 8.25 = 49.5
    assert frac(hp, hm) == pytest.approx(38.25 / 49.5, rel=1e-14)


def test_frac_invariant_to_complex_scale_and_bounded() -> None:
    rng = np.random.default_rng(1)
    h = rng.normal(size=(4, 50)) + 1j * rng.normal(size=(4, 50))
    assert np.allclose(frac(h * (3 - 2j), h), 1.0)
    g = rng.normal(size=(4, 50)) + 1j * rng.normal(size=(4, 50))
    v = frac(g, h)
    assert v.shape == (4,)
    assert np.all((v >= 0) & (v <= 1))


def test_nrmse_hand_values_and_axis() -> None:
    hm = np.array([3 + 4j, 0 + 1j])  # |hm| = 5, 1
    hp = np.array([4 + 0j, 0 + 0j])  # |hp| = 4, 0
    assert nrmse(hp, hm) == pytest.approx(np.sqrt(2.0) / np.sqrt(26.0), rel=1e-14)
    # magnitude only: a phase error costs nothing
    assert nrmse(hm * 1j, hm) == pytest.approx(0.0, abs=1e-15)
    stacked = np.stack([hm, hm])
    np.testing.assert_allclose(nrmse(stacked.T * 2, stacked.T, axis=0), [1.0, 1.0])


def test_nan_and_zero_give_nan() -> None:
    assert np.isnan(frac(np.zeros(3), np.ones(3)))
    assert np.isnan(nrmse(np.ones(3), np.zeros(3)))
    assert np.isnan(frac(np.array([1.0, np.nan]), np.ones(2)))
    assert np.isnan(nrmse(np.array([1.0, np.nan]), np.ones(2)))


def test_mac() -> None:
    a = np.array([1.0, 0.0, 0.0])
    b = np.array([1.0, 1.0, 0.0])
    assert mac(a, b) == pytest.approx(0.5)
    assert mac(a, 2j * a) == pytest.approx(1.0)
    m = mac_matrix(np.eye(3), np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 5.0]]))
    np.testing.assert_allclose(m, [[0.5, 0.0], [0.5, 0.0], [0.0, 1.0]])
