"""Pole refinement: the variable-projection residual and Jacobian (issue 17)."""

from __future__ import annotations

import numpy as np

from robolobe.modal.refine import _Projection, refine_poles

from ._systems import add_noise, make_system


def _problem(proportional: bool, noise: float = 0.01):
    sysm = make_system(4)
    f = np.arange(2.0, 46.0, 0.25)
    rng = np.random.default_rng(0)
    H = add_noise(sysm.H(f), noise, rng).reshape(f.size, -1)
    roll = 1.0 / (1.0 + (4.0 / f) ** 2)
    w = roll[:, None] / np.sqrt(np.mean(np.abs(H) ** 2, axis=0))[None, :]
    if not proportional:
        w = w * (1.0 - 0.3 * rng.random(w.shape))  # coherence-like, per FRF
    y = np.concatenate([H.real, H.imag], axis=0)
    w2 = np.concatenate([w, w], axis=0) ** 2
    lam = sysm.poles[sysm.f_hz < 46] * (1 + 0.002 + 0.001j)
    return f, y, w2, lam, sysm


def test_shared_normal_matrix_equals_the_per_frf_solve() -> None:
    """Proportional weights: one normal matrix for all FRFs gives the per-FRF residual and
    Jacobian."""
    f, y, w2, lam, _ = _problem(proportional=True)
    shared = _Projection(f, y, w2, True, True)
    assert shared.sw0 is not None
    per_frf = _Projection(f, y, w2, True, True)
    per_frf.sw0 = None  # force the general path
    owner = np.concatenate([np.arange(lam.size)] * 2)
    dlam = np.concatenate([lam, 0.01j * lam])
    r1, r2 = shared.resid(lam), per_frf.resid(lam)
    np.testing.assert_allclose(r1, r2, rtol=1e-9, atol=1e-9 * np.max(np.abs(r2)))
    j1, j2 = shared.jac(lam, owner, dlam), per_frf.jac(lam, owner, dlam)
    np.testing.assert_allclose(j1, j2, rtol=1e-9, atol=1e-9 * np.max(np.abs(j2)))
    f2, y2, w22, *_ = _problem(proportional=False)
    assert _Projection(f2, y2, w22, True, True).sw0 is None


def test_jacobian_matches_finite_differences_of_the_residual() -> None:
    """Kaufman's Jacobian against central differences of the residual (both weight kinds)
    at the true poles of noise-free FRFs, where the term it drops (~ the residual) is
    small: the derivative columns, their weighting and projection are right."""
    for proportional in (True, False):
        f, y, w2, _, sysm = _problem(proportional, noise=0.0)
        lam = sysm.poles[sysm.f_hz < 46]
        proj = _Projection(f, y, w2, True, True)
        owner = np.arange(lam.size)
        J = proj.jac(lam, owner, lam.copy())  # d lam / d ln(w) at fixed damping ratio
        h = 1e-6
        fd = np.stack(
            [
                (
                    proj.resid(lam * np.exp(h * (owner == j)))
                    - proj.resid(lam * np.exp(-h * (owner == j)))
                )
                / (2 * h)
                for j in range(lam.size)
            ],
            axis=1,
        )
        err = np.linalg.norm(J - fd, axis=0) / np.linalg.norm(fd, axis=0)
        assert np.all(err < 0.02), err


def test_refinement_moves_offset_poles_to_the_true_ones() -> None:
    f, y, w2, _, sysm = _problem(proportional=True, noise=0.0)
    n = f.size
    H = (y[:n] + 1j * y[n:]).reshape(n, 3, 3)
    w = np.sqrt(w2[:n]).reshape(n, 3, 3)
    true = sysm.poles[sysm.f_hz < 46]
    res = refine_poles(f, H, true * (1.002 + 0.001j), weights=w)
    assert res.success
    assert res.cost < 0.01 * res.cost_start
    assert not res.at_bound.any()
    # modes at 60 and 95 Hz are outside the model (residual terms): not exact
    np.testing.assert_allclose(np.abs(res.poles), np.abs(true), rtol=5e-4)
    np.testing.assert_allclose(-res.poles.real / np.abs(res.poles), sysm.zeta[:6], rtol=0.01)


def test_too_few_residuals_return_the_start_poles_flagged() -> None:
    f = np.array([5.0, 6.0])
    lam = np.array([-1 + 30j, -1 + 40j, -1 + 50j])
    H = (1 / (2j * np.pi * f[:, None] - lam[None])).sum(axis=1)
    res = refine_poles(f, H, lam, lower=False, upper=False)  # 4 residuals, 6 parameters
    assert not res.success
    assert res.at_bound.all()
    np.testing.assert_array_equal(res.poles, lam)
