"""The residual on noise-dominated points (cross FRFs far above the modes)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from robolobe.diagnose.noise import roughness_sigma
from robolobe.diagnose.observations import Observations
from robolobe.diagnose.residuals import (
    NOISY_SIGMA,
    _ratio_residual,
    deviance_per_record,
    residual_vector,
)


def _with_noise_only_channel(toy: SimpleNamespace, level: float) -> tuple[Observations, np.ndarray]:
    """Toy driving points plus an xy channel holding only noise of absolute ``level`` [m/N]."""
    obs = toy.obs(())
    rng = np.random.default_rng(5)
    H = np.array(obs.H)
    noise = level * (rng.standard_normal(H.shape[:2]) + 1j * rng.standard_normal(H.shape[:2]))
    H[:, :, 0, 1] = noise
    s = roughness_sigma(obs.freq_hz, H, floor=1e-3)
    out = Observations(obs.record_ids, obs.group, obs.q_rad, obs.freq_hz, H, s, source="toy")
    return out, toy.model((), out)


def test_a_true_model_below_the_noise_scores_at_the_noise(toy: SimpleNamespace) -> None:
    # the true xy receptance is 0 (the toy is uncoupled): 1e-12 stands for "far below"
    obs, H = _with_noise_only_channel(toy, 1e-9)
    assert np.nanmedian(obs.sigma[:, :, 0, 1]) > NOISY_SIGMA  # the roughness sees pure noise
    H[:, :, 0, 1] = 1e-12
    dev, count = deviance_per_record(H, obs)
    # a log residual would score log(1e3) / sigma ~ 7-10 deviations on half the points
    assert np.sqrt(dev.sum() / count.sum()) < 1.5
    r = residual_vector(H, obs)
    assert np.sqrt(np.mean(r**2)) < 1.5


def test_a_model_above_a_noise_only_recording_still_misses(toy: SimpleNamespace) -> None:
    obs, H = _with_noise_only_channel(toy, 1e-9)
    H_ok = H.copy()
    H_ok[:, :, 0, 1] = 1e-12
    H_bad = H.copy()
    H_bad[:, :, 0, 1] = 1e-7  # 100 x the recorded level: a signal the data do not hold
    d_ok, _ = deviance_per_record(H_ok, obs)
    d_bad, _ = deviance_per_record(H_bad, obs)
    assert d_bad.sum() > 20 * d_ok.sum()


def test_clean_points_keep_the_log_residual(toy: SimpleNamespace) -> None:
    obs = toy.obs(())
    H = toy.model((), obs) * np.exp(0.5)  # every level 65 % high
    r = residual_vector(H, obs)
    m = r.size // 2
    assert np.all(obs.inv_sigma_measured > 1.0 / NOISY_SIGMA)
    np.testing.assert_allclose(r[:m], 0.5 * obs.inv_sigma_measured, rtol=0.2)


def test_the_log_residual_is_the_complex_log_with_its_caps() -> None:
    # the residual takes log|z| + i atan2 for speed; reference: numpy's complex log, with
    # the documented caps written out here (real part clipped to +-20, NaN -> 20 + i pi)
    rng = np.random.default_rng(3)
    z = (rng.standard_normal(20000) + 1j * rng.standard_normal(20000)) * np.exp(
        rng.uniform(-12.0, 12.0, 20000)
    )
    axis = np.array([-1.0 + 0.0j, complex(-1.0, -0.0), 1e-30 + 0j, 1e30 - 1e-30j, 1j, -2j])
    special = np.array([np.nan + 0j, complex(np.inf, 0.0), complex(-np.inf, 0.0), 0j])
    ratio = np.concatenate([z, axis, special])
    got = _ratio_residual(ratio, np.zeros(ratio.size, dtype=bool))
    ref = np.log(np.concatenate([z, axis]))
    n = ref.size
    np.testing.assert_allclose(got[:n].real, np.clip(ref.real, -20.0, 20.0), rtol=0, atol=1e-13)
    np.testing.assert_allclose(got[:n].imag, ref.imag, rtol=0, atol=1e-13)
    assert got[n - 6].imag == np.pi  # the branch cut of log: -1 + 0j
    assert got[n - 5].imag == -np.pi  # -1 - 0j
    np.testing.assert_array_equal(got[n:].real, [20.0, 20.0, 20.0, -20.0])
    np.testing.assert_array_equal(got[n : n + 3].imag, [np.pi, 0.0, np.pi])
    # the noisy form is the linear difference, capped
    lin = _ratio_residual(ratio[:n], np.ones(n, dtype=bool))
    np.testing.assert_allclose(
        lin,
        np.clip((ratio[:n] - 1).real, -20, 20) + 1j * np.clip((ratio[:n] - 1).imag, -20, 20),
        rtol=1e-15,
    )
