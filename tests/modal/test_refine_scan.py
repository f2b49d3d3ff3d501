"""Pole refinement against a dense scan of its cost: it does not stop short of the optimum.

The diagnosis's local fits once stopped on a null value (a delay of 0): a
finite-difference step relative to ``|z|`` vanishes at ``z = 0``. The
refinement's parameters are ``ln w_r`` and ``ln zeta_r`` (never near 0 for
a mode in the band with ``zeta <= zeta_max``), its default Jacobian is
analytic, and the residues and residual terms are solved linearly; this
test checks the outcome on cases where a stop at a near-zero value would
show: a start at the damping floor (a pole on the imaginary axis), a light
and a heavy mode, upper residual exactly zero in the truth. The reference
is a dense scan of the weighted misfit over frequency and log-damping with
its own linear solve (numpy QR), written for this test.
"""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.modal.refine import refine_poles

F_HZ = np.arange(2.0, 60.0, 0.25)
S = 2j * np.pi * F_HZ


def _pole(f_hz: float, zeta: float) -> complex:
    w = 2 * np.pi * f_hz
    return complex(-zeta * w, w * np.sqrt(1 - zeta**2))


def _recording(f_hz: float, zeta: float, seed: int) -> np.ndarray:
    """Three FRFs of one mode, a lower residual (modes below the band), no upper
    residual, 1 % complex noise; shape (n_freq, 3)."""
    rng = np.random.default_rng(seed)
    lam = _pole(f_hz, zeta)
    R = np.array([1e-3 + 2e-4j, -5e-4 + 1e-4j, 3e-4j])
    H = R[None] / (S[:, None] - lam) + np.conj(R)[None] / (S[:, None] - np.conj(lam))
    H = H + np.array([3e-4, -1e-4, 2e-4])[None] / S[:, None] ** 2
    scale = 0.01 * np.mean(np.abs(H), axis=0)
    return H + scale * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))


def _scan_costs(H: np.ndarray, f_grid: np.ndarray, lnz_grid: np.ndarray) -> np.ndarray:
    """0.5 * squared misfit after the best residues and residual terms, per grid point."""
    ff, lz = np.meshgrid(f_grid, lnz_grid, indexing="ij")
    z = np.exp(lz.ravel())
    w = 2 * np.pi * ff.ravel()
    lam = -z * w + 1j * w * np.sqrt(1 - z**2)  # (G,)
    g = 1.0 / (S[None, :] - lam[:, None])  # (G, F)
    gc = 1.0 / (S[None, :] - np.conj(lam)[:, None])
    one = np.ones_like(S)
    fixed = [one, 1j * one, 1 / S**2, 1j / S**2, 1 / S, 1j / S]
    cols = [g + gc, 1j * (g - gc)] + [np.broadcast_to(c, g.shape) for c in fixed]
    B = np.stack(cols, axis=2)  # (G, F, 8): real unknowns
    Br = np.concatenate([B.real, B.imag], axis=1)  # (G, 2F, 8)
    y = np.concatenate([H.real, H.imag], axis=0)  # (2F, 3)
    Q, _ = np.linalg.qr(Br)
    r = y[None] - Q @ (np.transpose(Q, (0, 2, 1)) @ y[None])
    return (0.5 * np.sum(r**2, axis=(1, 2))).reshape(ff.shape)


def _dense_scan(H: np.ndarray, f0: float) -> tuple[float, float, float, float, float]:
    """Minimum of the misfit over f in +-3 % of f0 and zeta in 1e-4..0.3, by three
    nested 41x41 grids (each 1/20 of the span of the one before, around its minimum).

    Returns (cost, f_hz, ln_zeta, f step, ln_zeta step) of the finest grid.
    """
    f_lo, f_hi = 0.97 * f0, 1.03 * f0
    z_lo, z_hi = np.log(1e-4), np.log(0.3)
    for _ in range(3):
        fg, zg = np.linspace(f_lo, f_hi, 41), np.linspace(z_lo, z_hi, 41)
        c = _scan_costs(H, fg, zg)
        i, j = np.unravel_index(int(np.argmin(c)), c.shape)
        df, dz = fg[1] - fg[0], zg[1] - zg[0]
        f_lo, f_hi = fg[i] - 1.0 * df, fg[i] + 1.0 * df
        z_lo, z_hi = zg[j] - 1.0 * dz, zg[j] + 1.0 * dz
    return float(c[i, j]), float(fg[i]), float(zg[j]), float(df), float(dz)


CASES = [
    # (true f, true zeta, start f, start zeta): 0 = a pole on the imaginary axis
    (18.0, 0.005, 18.1, 0.0),
    (18.0, 0.03, 17.9, 0.0),
    (18.0, 0.03, 18.2, 1e-3),
    (25.0, 0.2, 24.5, 0.02),
    (25.0, 0.2, 25.3, 0.28),
]


@pytest.mark.parametrize("jacobian", ["analytic", "fd"])
@pytest.mark.parametrize(("f_true", "z_true", "f_start", "z_start"), CASES)
def test_refinement_reaches_the_dense_scan_minimum(
    jacobian: str, f_true: float, z_true: float, f_start: float, z_start: float
) -> None:
    H = _recording(f_true, z_true, seed=int(100 * f_true + 1000 * z_true))
    res = refine_poles(F_HZ, H, [_pole(f_start, z_start)], jacobian=jacobian)
    assert res.success
    assert not res.at_bound.any()
    c_scan, f_scan, lnz_scan, df, dz = _dense_scan(H, f_true)
    f_ref = abs(res.poles[0]) / (2 * np.pi)
    lnz_ref = np.log(-res.poles[0].real / abs(res.poles[0]))
    # no worse than the scan's best grid point, and at that minimum
    assert res.cost <= c_scan * (1 + 1e-6)
    assert abs(f_ref - f_scan) <= df
    assert abs(lnz_ref - lnz_scan) <= dz
    # the scan's minimum is the recording's mode (1 % noise), not a bound
    assert abs(f_scan / f_true - 1) < 2e-3
    assert abs(lnz_scan - np.log(z_true)) < 0.1
