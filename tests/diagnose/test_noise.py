"""Noise scale estimates (robolobe.diagnose.noise)."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.diagnose.noise import (
    coherence_sigma,
    line_correlation_factor,
    roughness_sigma,
    variance_inflation,
)


def test_coherence_sigma_bendat_piersol() -> None:
    # e = sqrt((1 - g2) / (2 n g2)): g2 = 0.99, n = 5 -> 0.031782
    assert coherence_sigma(0.99, 5, floor=0.0) == pytest.approx(0.0317821, rel=1e-5)
    assert coherence_sigma(1.0, 5) == pytest.approx(0.01)  # the floor
    assert coherence_sigma(1e-9, 5) == pytest.approx(1.0)  # the cap


def test_window_factors_closed_form() -> None:
    assert line_correlation_factor(0.25, 0.0) == 1.0
    assert variance_inflation(0.25, 0.0) == 1.0
    # seed test: a = -ln(0.05)/4 s, lines 0.25 Hz -> b = a/(pi df) = 0.955, pi b = 3.0
    a = -np.log(0.05) / 4.0
    x = 2 * a / (2 * a + 2j * np.pi * np.array([1, 2]) * 0.25)
    want = np.sqrt(6 / (6 - 8 * x[0].real + 2 * x[1].real))
    assert line_correlation_factor(0.25, a) == pytest.approx(want)
    # closed form against the series 1 + 2 sum Re rho_m, Re rho_m = b^2 / (b^2 + m^2)
    b = a / (np.pi * 0.25)
    m = np.arange(1, 200_000)
    series = 1 + 2 * np.sum(b**2 / (b**2 + m**2))
    assert variance_inflation(0.25, a) == pytest.approx(series, rel=1e-4)
    assert variance_inflation(0.25, a) == pytest.approx(3.01, abs=0.01)


def test_roughness_recovers_white_log_noise() -> None:
    rng = np.random.default_rng(1)
    f = np.arange(2.0, 40.0, 0.25)
    w = 2 * np.pi * f
    H0 = 1.0 / (4e6 - 400 * w**2 + 1j * w * 2 * 0.03 * np.sqrt(4e6 * 400))
    s_true = 0.02
    e = s_true * (rng.standard_normal((50, f.size)) + 1j * rng.standard_normal((50, f.size)))
    H = np.full((50, f.size, 3, 3), np.nan + 0j)
    H[:, :, 0, 0] = H0 * np.exp(e)
    s = roughness_sigma(f, H, floor=0.0)
    assert np.isnan(s[:, :, 1, 1]).all()
    assert np.median(s[:, :, 0, 0]) == pytest.approx(s_true, rel=0.1)


def test_roughness_corrects_exponential_window_correlation() -> None:
    # white noise windowed by exp(-a t) over a 4 s record, then FFT: correlated lines
    rng = np.random.default_rng(2)
    fs, T = 256.0, 4.0
    n = int(fs * T)
    t = np.arange(n) / fs
    a = -np.log(0.05) / T
    noise = rng.standard_normal((40, n)) * np.exp(-a * t)
    E = np.fft.rfft(noise, axis=1)
    f = np.fft.rfftfreq(n, 1 / fs)
    band = (f >= 2) & (f <= 40)
    E = E[:, band] / np.sqrt(np.sum(np.exp(-2 * a * t)))  # unit variance per line
    eps = 0.02
    s_true = eps / np.sqrt(2)  # per real/imag part
    H = np.full((40, band.sum(), 3, 3), np.nan + 0j)
    H[:, :, 1, 1] = 1.0 + eps * E
    plain = roughness_sigma(f[band], H, floor=0.0)
    fixed = roughness_sigma(f[band], H, floor=0.0, window_decay_per_s=a)
    assert np.median(plain[:, :, 1, 1]) < 0.8 * s_true  # correlation hides noise
    assert np.median(fixed[:, :, 1, 1]) == pytest.approx(s_true, rel=0.12)


def test_difference_variance_white_and_windowed() -> None:
    from robolobe.diagnose.noise import difference_variance

    assert difference_variance(2, 0.25, 0.0) == pytest.approx(6.0)
    assert difference_variance(4, 0.25, 0.0) == pytest.approx(70.0)
    a = -np.log(0.05) / 4.0
    x = 2 * a / (2 * a + 2j * np.pi * np.array([1, 2]) * 0.25)
    assert difference_variance(2, 0.25, a) == pytest.approx(6 - 8 * x[0].real + 2 * x[1].real)


def test_roughness_is_not_fooled_by_sharp_close_modes() -> None:
    """Three modes (3 % damping) 3 Hz apart at 0.25 Hz lines, true log-noise 0.002.

    The second difference alone reads the peaks' curvature as noise (20x the
    truth here); the curvature guard takes it down to 3x the fourth difference's
    (6x the truth, 1.2x the default 1 % floor).
    """
    rng = np.random.default_rng(3)
    f = np.arange(2.0, 60.0, 0.25)
    w = 2 * np.pi * f
    H0 = sum(
        1.0 / (k * (1 - (w / (2 * np.pi * fr)) ** 2 + 2j * 0.03 * w / (2 * np.pi * fr)))
        for fr, k in ((20.0, 1e6), (23.0, 2e6), (26.0, 1.5e6))
    )
    s_true = 0.002
    e = s_true * (rng.standard_normal((20, f.size)) + 1j * rng.standard_normal((20, f.size)))
    H = np.full((20, f.size, 3, 3), np.nan + 0j)
    H[:, :, 2, 2] = H0 * np.exp(e)
    band = (f > 18) & (f < 28)
    plain = roughness_sigma(f, H, floor=0.0, curvature_guard=0.0)[:, band, 2, 2]
    guarded = roughness_sigma(f, H, floor=0.0)[:, band, 2, 2]
    assert np.median(plain) > 10 * s_true
    assert np.median(guarded) < 0.35 * np.median(plain)
    assert np.median(guarded) < 8 * s_true
    # white noise alone: the guard changes nothing
    flat = np.full((20, f.size, 3, 3), np.nan + 0j)
    flat[:, :, 0, 0] = np.exp(e)
    np.testing.assert_allclose(
        roughness_sigma(f, flat, floor=0.0),
        roughness_sigma(f, flat, floor=0.0, curvature_guard=0.0),
    )
