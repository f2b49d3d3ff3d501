"""LSFD residues, residual terms, modal stiffness and refinement on analytic FRFs."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.lsfd import lsfd, modal_stiffness
from robolobe.modal.refine import refine_poles

from ._systems import ModalSystem, add_noise, make_system


def test_exact_residues_with_out_of_band_modes() -> None:
    sysm = make_system(4)
    f = np.arange(8, 185) * 0.25
    inb = sysm.f_hz < 40
    fit = lsfd(f, sysm.H(f), sysm.poles[inb])
    # modes at 60 and 95 Hz are absorbed by the residual terms (upper mostly)
    np.testing.assert_allclose(
        fit.residues, sysm.residues[inb], rtol=2e-3, atol=1e-3 * np.abs(sysm.residues[inb]).max()
    )
    k = modal_stiffness(sysm.poles[inb], np.diagonal(fit.residues, axis1=1, axis2=2)).T
    # where a mode shows at the driving point (peak >= 5 % of the FRF peak) k is within 0.5 %
    peak = np.abs(np.diagonal(sysm.residues[inb], axis1=1, axis2=2)).T / np.abs(
        sysm.poles[inb].real
    )
    hmax = np.max(np.abs(np.diagonal(sysm.H(f), axis1=1, axis2=2)), axis=0)[:, None]
    vis = peak / hmax >= 0.05
    assert vis.sum() >= 6
    np.testing.assert_allclose(k[vis], sysm.k[:, inb][vis], rtol=5e-3)
    model = fit.synthesize(f)
    assert np.max(np.abs(model - sysm.H(f))) < 1e-3 * np.max(np.abs(sysm.H(f)))
    assert np.all(fit.rel_residual < 1e-3)


def test_noise_std_and_nan_lines() -> None:
    sysm = make_system(5)
    f = np.arange(8, 161) * 0.25
    rng = np.random.default_rng(0)
    H = add_noise(sysm.H(f), 0.01, rng)
    H[10:12, 0, 0] = np.nan  # ignored, not propagated
    fit = lsfd(f, H, sysm.poles[:6])
    assert np.all(np.isfinite(fit.residues))
    err = np.abs(fit.residues - sysm.residues[:6])
    # the covariance-based standard deviation is the right order of magnitude
    ratio = np.median(err / fit.residue_std)
    assert 0.2 < ratio < 3.0


def test_modal_stiffness_closed_form() -> None:
    lam = np.array([-0.5 + 60j])
    k0 = 2.0e6
    wr2 = abs(lam[0]) ** 2
    R = wr2 / (2j * lam[0].imag * k0)
    assert modal_stiffness(lam, np.array([R]))[0] == pytest.approx(k0)


def test_modal_stiffness_of_a_complex_mode_is_the_best_real_mode_fit() -> None:
    """A residue far from -90 deg (one of a close pair of complex modes): the stiffness
    is that of the real-mode term closest (least squares over the resonance) to the
    complex term, found here by brute force over k."""
    lam = -0.02 * 70.0 + 70.0j
    wr2, wd = abs(lam) ** 2, lam.imag
    w = np.linspace(wd - 10 * abs(lam.real), wd + 10 * abs(lam.real), 2001)
    s = 1j * w

    def term(r: complex) -> np.ndarray:
        return r / (s - lam) + np.conj(r) / (s - np.conj(lam))

    for phase_deg in (-90.0, -60.0, -150.0, 170.0):
        R = 1e-7 * np.exp(1j * np.radians(phase_deg))
        target = term(R)
        ks = np.geomspace(1e3, 1e10, 20001)
        miss = [np.linalg.norm(term(wr2 / (2j * wd * k)) - target) for k in ks]
        best = ks[int(np.argmin(miss))]
        got = modal_stiffness(np.array([lam]), np.array([R]))[0]
        if phase_deg == 170.0:  # a positive imaginary part: a negative stiffness
            assert got < 0
            continue
        # first order: the conjugate term and the band's edges shift the best by a few %
        assert got == pytest.approx(best, rel=0.05)
        old = (wr2 / (2j * wd * R)).real  # the older form: sin^2(phase) of it
        assert old == pytest.approx(got * np.sin(np.radians(phase_deg)) ** 2, rel=1e-9)


def test_refine_recovers_perturbed_poles() -> None:
    full = make_system(6)
    inb = full.f_hz < 40
    sysm = ModalSystem(full.f_hz[inb], full.zeta[inb], full.u[inb])  # model is exact
    f = np.arange(8, 185) * 0.25
    true = sysm.poles
    start = np.abs(true) * 1.004 * np.exp(1j * np.angle(true))  # 0.4 % off
    start = start.real * 1.3 + 1j * start.imag  # damping 30 % off
    ref = refine_poles(f, sysm.H(f), start)
    assert ref.cost < 1e-6 * ref.cost_start
    np.testing.assert_allclose(np.abs(ref.poles), np.abs(true), rtol=1e-5)
    np.testing.assert_allclose(ref.poles.real, true.real, rtol=1e-3)
    assert not ref.at_bound.any()
    # only some poles free: the fixed ones do not move
    free = np.zeros(true.size, bool)
    free[2] = True
    ref2 = refine_poles(f, sysm.H(f), np.where(free, start, true), free=free)
    np.testing.assert_allclose(ref2.poles, true, rtol=1e-5)


def test_validation() -> None:
    with pytest.raises(InputError, match="frequency lines"):
        lsfd(np.arange(1, 10.0), np.zeros((5, 3)), [1j])
    with pytest.raises(InputError, match="> 0"):
        lsfd(np.arange(0, 10.0), np.zeros((10,)), [1j])
