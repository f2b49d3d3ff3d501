"""FRF synthesis: against a direct 2-DOF solve and between the two forms."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from robolobe.modal.synthesis import (
    modal_to_poles,
    poles_to_modal,
    synthesize_frf,
    synthesize_pole_residue,
)


def test_single_mode_closed_form() -> None:
    f = np.linspace(0.0, 40.0, 161)
    H = synthesize_frf([10.0], [0.02], [2e5], f)
    assert H.shape == (161,)
    assert H[0] == pytest.approx(1.0 / 2e5)  # static compliance 1/k
    i = np.argmin(abs(f - 10.0))
    assert H[i] == pytest.approx(1.0 / (2j * 0.02 * 2e5))  # at resonance: 1/(2 i zeta k)


def test_matches_proportionally_damped_2dof() -> None:
    """H_11 of M x'' + C x' + K x = F with C = a M + b K equals the modal sum."""
    M = np.diag([2.0, 1.0])
    K = np.array([[3e5, -1e5], [-1e5, 1e5]])
    a, b = 0.5, 2e-4
    C = a * M + b * K
    lam, V = scipy.linalg.eigh(K, M)  # mass-normalised V
    wr = np.sqrt(lam)
    zeta = (a / wr + b * wr) / 2
    k = wr**2 / V[0] ** 2  # k_r = w_r^2 / u_r^2 (DESIGN.md)
    f = np.linspace(0.5, 80, 300)
    w = 2 * np.pi * f
    direct = np.array([np.linalg.inv(K - x**2 * M + 1j * x * C)[0, 0] for x in w])
    np.testing.assert_allclose(synthesize_frf(wr / 2 / np.pi, zeta, k, f), direct, rtol=1e-10)


def test_broadcast_and_nan_modes() -> None:
    f = np.linspace(1, 40, 50)
    fn = np.array([[8.0, 20.0], [9.0, np.nan]])
    z = np.full((2, 2), 0.01)
    k = np.full((2, 2), 1e6)
    H = synthesize_frf(fn, z, k, f, ignore_nan=True)
    assert H.shape == (2, 50)
    np.testing.assert_allclose(H[1], synthesize_frf([9.0], [0.01], [1e6], f))
    assert np.isnan(synthesize_frf(fn, z, k, f)[1]).all()


def test_pole_residue_form_agrees() -> None:
    fn, zeta, k = (
        np.array([7.0, 7.4, 30.0]),
        np.array([0.002, 0.05, 0.03]),
        np.array([3e5, 1e6, 2e6]),
    )
    lam = modal_to_poles(fn, zeta)
    wd = lam.imag
    R = (2 * np.pi * fn) ** 2 / (2j * wd * k)
    f = np.linspace(0.25, 40, 157)
    Hp = synthesize_pole_residue(lam, R, f)
    Hm = synthesize_frf(fn, zeta, k, f)
    # identical up to the small non-proportional term the pair adds: (R + R*) = 0 exactly here
    np.testing.assert_allclose(Hp, Hm, rtol=1e-12)
    f2, z2 = poles_to_modal(lam)
    np.testing.assert_allclose(f2, fn)
    np.testing.assert_allclose(z2, zeta)
    # residual terms
    H2 = synthesize_pole_residue(lam, R, f, lower=2.0, upper=1e-7)
    np.testing.assert_allclose(H2 - Hp, 1e-7 - 2.0 / (2 * np.pi * f) ** 2)


def test_window_decay_moves_poles_and_keeps_residues() -> None:
    """The windowed modal form equals the pole-residue form with every pole moved left."""
    from robolobe.twin.frf import modal_receptance

    fn = np.array([7.3, 12.1, 19.4])
    zeta = np.array([0.03, 0.05, 0.02])
    k = np.array([2e6, 5e6, -8e6])
    f = np.linspace(0.5, 40.0, 400)
    a = 0.75  # the seed's 4 s records windowed to 5 %
    lam = modal_to_poles(fn, zeta)
    residue = (2 * np.pi * fn) ** 2 / (2j * lam.imag * k)
    expect = synthesize_pole_residue(lam - a, residue, f)
    got = synthesize_frf(fn, zeta, k, f, window_decay_per_s=a)
    np.testing.assert_allclose(got, expect, rtol=1e-10)
    assert np.max(np.abs(got - synthesize_frf(fn, zeta, k, f))) > 0.05 * np.max(np.abs(got))
    # the twin's validated wrapper is the same kernel
    kpos = np.abs(k)
    np.testing.assert_array_equal(
        modal_receptance(fn, zeta, kpos, f), synthesize_frf(fn, zeta, kpos, f)
    )
