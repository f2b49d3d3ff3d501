"""Locating the mismatch: map, signatures, mode pairing (toy structure)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from robolobe.diagnose.locate import mismatch_map, pair_modes, recorded_peaks


def test_map_is_at_noise_level_for_the_true_model(toy: SimpleNamespace) -> None:
    obs = toy.obs(())
    mm = mismatch_map(toy.model((), obs), obs)
    assert mm.score.shape == (obs.n, obs.freq_hz.size)
    assert 0.6 < mm.overall < 1.6
    assert {s.direction for s in mm.directions} == {"xx", "yy", "zz"}


def test_delay_shows_as_phase_trend(toy: SimpleNamespace) -> None:
    tau = 0.003
    obs = toy.obs((("delay", tau),))
    mm = mismatch_map(toy.model((), obs), obs)
    for s in mm.directions:
        # Im log(H_nom / H_meas) = +w tau
        assert s.delay_s == pytest.approx(tau, rel=0.05)
        assert abs(s.level_offset) < 0.02
    assert mm.overall > 10


def test_mass_shows_in_the_band_of_the_modes(toy: SimpleNamespace) -> None:
    obs = toy.obs((("mass", 60.0),))
    mm = mismatch_map(toy.model((), obs), obs, band_hz=5.0)
    worst = max(mm.bands, key=lambda b: b.score)
    # toy modes: sqrt(k/m)/2pi with m = 400 (1 + 0.4 sin q1) -> 8..30 Hz
    assert 5.0 <= worst.f_lo_hz <= 30.0
    quiet = [b for b in mm.bands if b.f_lo_hz >= 35.0]
    assert all(b.score < worst.score / 3 for b in quiet)


def test_recorded_peaks_find_the_toy_modes(toy: SimpleNamespace) -> None:
    obs = toy.obs((), sigma=0.005)
    peaks = recorded_peaks(obs)
    m = 400 * (1 + 0.4 * np.sin(obs.q_rad[0, 0]))
    want = np.sort(np.sqrt(np.array([4e6, 6e6, 9e6]) / m) / (2 * np.pi))
    f, z, shape = peaks[0]
    assert f.size == 3
    assert np.allclose(np.sort(f), want, rtol=0.01)
    assert np.allclose(z, 0.03, rtol=0.3)  # half-power width on a 0.25 Hz grid
    assert shape.shape == (3, 3)


def test_pair_modes_pairs_by_frequency_and_shape() -> None:
    rows = pair_modes(
        "P1",
        np.array([10.0, 20.0, 30.0]),
        np.array([0.02, 0.02, 0.02]),
        np.eye(3),
        np.array([9.5, 31.0, 55.0]),
        np.array([0.03, 0.02, 0.01]),
        np.array([[1.0, 0.1, 0], [0, 0.1, 1.0], [0, 1, 0]]),
    )
    status = {(r.status, r.f_nom_hz if r.status != "recorded only" else r.f_meas_hz) for r in rows}
    assert ("paired", 10.0) in status
    assert ("paired", 30.0) in status
    assert ("nominal only", 20.0) in status
    assert ("recorded only", 55.0) in status
    p10 = next(r for r in rows if r.status == "paired" and r.f_nom_hz == 10.0)
    assert p10.df_pct == pytest.approx(-5.0)
    assert p10.dzeta_pct == pytest.approx(50.0)
