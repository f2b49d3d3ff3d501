"""Simulated hammer tests against analytic modal models (REFERENCES.md sections 1, 4)."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.twin.hammer import (
    HammerTestSettings,
    correct_window_damping,
    detect_double_hits,
    half_sine_spectrum,
    simulate_hammer_test,
)

# A 3-DOF modal model: H(w) = sum_r phi_r phi_r^T / (k_r (1 - (w/w_r)^2 + 2 i zeta_r w/w_r)).
FN = np.array([8.0, 15.0, 27.0])
ZETA = np.array([0.03, 0.04, 0.02])
K = np.array([1.0e6, 2.0e6, 3.0e6])
PHI = np.array([[1.0, 0.3, 0.1], [0.2, 1.0, -0.4], [0.1, 0.5, 1.0]])

QUIET = HammerTestSettings(force_noise_n=0.0, accel_noise_m_per_s2=0.0)


def modal_receptance(
    f_hz: np.ndarray, fn: np.ndarray = FN, zeta: np.ndarray = ZETA, k: np.ndarray = K
) -> np.ndarray:
    """(n, 3, 3) receptance [m/N] of a proportionally damped modal model."""
    r = np.asarray(f_hz, dtype=float)[:, None] / fn
    den = k * (1 - r**2 + 2j * zeta * r)
    return np.einsum("im,jm,nm->nij", PHI, PHI, 1 / den)


def sdof(fn: float, zeta: float, k: float = 1e6):
    """Callable: 1-DOF receptance in xx only."""

    def h(f_hz: np.ndarray) -> np.ndarray:
        r = np.asarray(f_hz) / fn
        out = np.zeros((r.size, 3, 3), complex)
        out[:, 0, 0] = 1 / (k * (1 - r**2 + 2j * zeta * r))
        return out

    return h


def fit_sdof_decay(f_hz: np.ndarray, h: np.ndarray) -> tuple[float, float]:
    """Least-squares 1-DOF fit H (k - m w^2 + i c w) = 1 -> (decay c / 2m [1/s], w_n [rad/s])."""
    w = 2 * np.pi * f_hz
    a = np.stack([h, -(w**2) * h, 1j * w * h], axis=1)
    a_ri = np.concatenate([a.real, a.imag])
    b = np.concatenate([np.ones(w.size), np.zeros(w.size)])
    k, m, c = np.linalg.lstsq(a_ri, b, rcond=None)[0]
    return c / (2 * m), np.sqrt(k / m)


def test_grid_is_seed_grid():
    s = HammerTestSettings()
    f = s.freq_hz
    assert f.size == 2049
    assert f[0] == 0.0
    assert f[-1] == 512.0
    np.testing.assert_allclose(np.diff(f), 0.25)
    assert s.fine_freq_hz.size == 16 * 4096 // 2 + 1
    res = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(0), settings=QUIET)
    np.testing.assert_array_equal(res.freq_hz, f)
    assert res.H1.shape == (2049, 3, 3)
    assert res.coherence.shape == (2049, 3, 3)
    assert res.double_hit_ratio.shape == (3, 5)


def test_half_sine_spectrum_closed_form():
    # Numerical Fourier integral of sin(pi t / tau) on [0, tau] (midpoint rule, 20000 points).
    tau = 0.002
    t = (np.arange(20000) + 0.5) * tau / 20000
    f = np.array([0.0, 100.0, 250.0, 1 / (2 * tau), 700.0])
    num = np.sin(np.pi * t / tau) @ np.exp(-2j * np.pi * np.outer(t, f)) * (tau / 20000)
    np.testing.assert_allclose(half_sine_spectrum(f, tau), num, rtol=1e-7, atol=1e-12)
    assert half_sine_spectrum(0.0, tau) == pytest.approx(2 * tau / np.pi)


def test_noise_free_long_record_recovers_receptance():
    # No window, no noise, 8 s record: the response has decayed (sigma >= 1.5 1/s),
    # so H1 equals the receptance up to truncation / wrap-around (< 1 % near resonances).
    s = QUIET.replace(window_end=1.0, duration_s=8.0, settle_factor=8)
    res = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(1), settings=s)
    exact = modal_receptance(res.freq_hz)
    for fr in FN:
        band = np.abs(res.freq_hz - fr) <= 2.0
        err = np.abs(res.H1[band] - exact[band]) / np.abs(exact[band]).max()
        assert err.max() < 0.01, (fr, err.max())
    # Over the analysis band 2-40 Hz the error stays small too.
    band = (res.freq_hz >= 2) & (res.freq_hz <= 40)
    rel = np.abs(res.H1[band] - exact[band]).max() / np.abs(exact[band]).max()
    assert rel < 0.01
    # H1 and H2 agree without noise, coherence ~1 on coupled directions.
    np.testing.assert_allclose(res.H2[band], res.H1[band], rtol=1e-4)
    assert res.coherence[band].min() > 0.999


def test_coherence_drops_with_noise():
    quiet = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(2), settings=QUIET)
    loud_s = HammerTestSettings(force_noise_n=2.0, accel_noise_m_per_s2=0.05)
    loud = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(2), settings=loud_s)
    band = (quiet.freq_hz >= 2) & (quiet.freq_hz <= 40)
    diag = np.arange(3)
    c_quiet = quiet.coherence[band][:, diag, diag]
    c_loud = loud.coherence[band][:, diag, diag]
    assert c_quiet.min() > 0.999
    assert np.median(c_loud) < np.median(c_quiet) - 0.05
    assert np.all((loud.coherence >= 0) & (loud.coherence <= 1))
    # With noise H1 <= H2 in magnitude (noise on the response biases H2 up, on force H1 down).
    assert np.all(np.abs(loud.H1[band]) <= np.abs(loud.H2[band]) * (1 + 1e-9))
    # At resonances the default noise keeps the coherence high (seed practice: >= 0.9).
    dflt = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(2))
    for r, fr in enumerate(FN):
        k = np.argmin(np.abs(dflt.freq_hz - fr))
        assert dflt.coherence[k, r, r] > 0.95


def test_snr_setting_orders_coherence():
    def median_coh(snr: float) -> float:
        s = HammerTestSettings(snr_db=snr)
        res = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(3), settings=s)
        band = (res.freq_hz >= 2) & (res.freq_hz <= 40)
        return float(np.median(res.coherence[band]))

    assert median_coh(60.0) > median_coh(20.0) > median_coh(0.0)


def test_double_hits_detected_and_rejected():
    # Clean hits: ratio ~0.002 or less (REFERENCES.md section 4).
    clean = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(4))
    assert clean.double_hit_ratio.max() < 0.01
    assert clean.used.all()
    assert not clean.double_hits.any()
    # Every impact a double hit with a second hit of 10-30 %: all flagged.
    s = HammerTestSettings(double_hit_probability=1.0, double_hit_ratio=(0.1, 0.3))
    dbl = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(4), settings=s)
    assert dbl.double_hits.all()
    assert np.all((dbl.double_hit_ratio > 0.07) & (dbl.double_hit_ratio < 0.4))
    # Half of the impacts double: flagged ones are left out of the averages.
    s = HammerTestSettings(double_hit_probability=0.5, double_hit_ratio=(0.1, 0.3))
    mix = simulate_hammer_test(modal_receptance, rng=np.random.default_rng(5), settings=s)
    assert mix.double_hits.any()
    assert (~mix.double_hits).any()
    partly = mix.double_hits.any(axis=-1) & ~mix.double_hits.all(axis=-1)
    np.testing.assert_array_equal(mix.used[partly], ~mix.double_hits[partly])


def test_detect_double_hits_on_synthetic_records():
    fs, n = 1024.0, 512
    x = np.zeros((2, n))
    x[:, 20] = 300.0
    x[:, 21] = 200.0
    x[1, 40] = 30.0  # second hit 20 ms later, 10 %
    r = detect_double_hits(x, sample_rate_hz=fs, pulse_width_s=0.002)
    assert r[0] == 0.0
    assert r[1] == pytest.approx(0.1)


@pytest.mark.parametrize("window_end", [0.05, 0.01])
def test_window_adds_known_decay_on_sdof(window_end):
    # 1-DOF, 10 Hz, zeta 0.5 % (sigma = 0.314 1/s): a 4 s record truncates it, the
    # exponential window adds -ln(w_end)/T to the decay (REFERENCES.md section 4).
    fn, zeta = 10.0, 0.005
    s = QUIET.replace(window_end=window_end)
    res = simulate_hammer_test(sdof(fn, zeta), rng=np.random.default_rng(6), settings=s, excite="x")
    assert res.window_decay_per_s == pytest.approx(-np.log(window_end) / 4.0)
    band = (res.freq_hz > 5) & (res.freq_hz < 15)
    decay, wn = fit_sdof_decay(res.freq_hz[band], res.H1[band, 0, 0])
    true_decay = zeta * 2 * np.pi * fn
    assert decay == pytest.approx(true_decay + res.window_decay_per_s, rel=0.01)
    f_c, z_c = correct_window_damping(wn / (2 * np.pi), decay / wn, res.window_decay_per_s)
    assert f_c == pytest.approx(fn, rel=1e-3)
    assert z_c == pytest.approx(zeta, rel=0.05)
    # Without the correction the damping is off by far more.
    assert decay / wn > 3 * zeta


def test_no_window_leaks_on_light_damping():
    # The same 1-DOF without the window: the 4 s record truncates the decay (leakage),
    # and the identified decay is biased (here by more than 3 %).
    s = QUIET.replace(window_end=1.0)
    res = simulate_hammer_test(
        sdof(10.0, 0.005), rng=np.random.default_rng(6), settings=s, excite="x"
    )
    band = (res.freq_hz > 5) & (res.freq_hz < 15)
    decay, _ = fit_sdof_decay(res.freq_hz[band], res.H1[band, 0, 0])
    assert abs(decay / (0.005 * 2 * np.pi * 10) - 1) > 0.03


def test_correct_window_damping_inverts_the_shift():
    fn, zeta, d = np.array([7.0, 20.0]), np.array([0.01, 0.03]), 0.75
    wn = 2 * np.pi * fn
    wd = wn * np.sqrt(1 - zeta**2)
    s_est = zeta * wn + d
    wn_est = np.sqrt(wd**2 + s_est**2)
    f_c, z_c = correct_window_damping(wn_est / (2 * np.pi), s_est / wn_est, d)
    np.testing.assert_allclose(f_c, fn, rtol=1e-12)
    np.testing.assert_allclose(z_c, zeta, rtol=1e-12)


def test_batch_reproducible_and_independent_of_chunking():
    s = HammerTestSettings(double_hit_probability=0.3, settle_factor=4)
    h = np.stack([modal_receptance(s.fine_freq_hz, fn=FN * x) for x in (1.0, 1.1, 0.9)])
    a = simulate_hammer_test(h, rng=np.random.default_rng(7), settings=s)
    b = simulate_hammer_test(h, rng=np.random.default_rng(7), settings=s)
    np.testing.assert_array_equal(a.H1, b.H1)
    assert a.H1.shape == (3, 2049, 3, 3)
    # Posture 0 alone from the same seed: children are spawned per posture, so the
    # result of one posture does not depend on the others simulated with it.
    single = simulate_hammer_test(h[:1], rng=np.random.default_rng(7), settings=s)
    np.testing.assert_array_equal(single.H1[0], a.H1[0])
    c = simulate_hammer_test(h, rng=np.random.default_rng(8), settings=s)
    assert not np.allclose(c.H1, a.H1)


def test_excite_subset_leaves_other_columns_nan():
    res = simulate_hammer_test(
        modal_receptance, rng=np.random.default_rng(9), settings=QUIET, excite="z"
    )
    assert res.excited == ("z",)
    assert res.dirs == {"xz", "yz", "zz"}
    assert np.isnan(res.H1[:, :, :2]).all()
    assert np.isfinite(res.H1[:, :, 2]).all()


def test_bad_inputs():
    with pytest.raises(InputError, match="window_end"):
        HammerTestSettings(window_end=0.0)
    for w in (1e-300, 1e-9, 9.9e-4):  # the window would set the records' decay itself
        with pytest.raises(InputError, match="window_end"):
            HammerTestSettings(window_end=w)
    HammerTestSettings(window_end=1e-3)
    with pytest.raises(InputError, match="impacts"):
        HammerTestSettings(impacts=0)
    with pytest.raises(InputError, match="shape"):
        simulate_hammer_test(np.zeros((10, 3, 3)), rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="excitation"):
        simulate_hammer_test(modal_receptance, rng=np.random.default_rng(0), excite="xw")
    with pytest.raises(InputError, match="Generator"):
        simulate_hammer_test(modal_receptance, rng=0)  # type: ignore[arg-type]
