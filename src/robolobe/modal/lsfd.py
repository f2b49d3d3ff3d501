"""Least-squares frequency-domain (LSFD) estimation of residues with residual terms.

With the poles fixed, every FRF is linear in its residues and residual terms:

    H(w) = sum_r [ R_r / (s - lambda_r) + conj(R_r) / (s - conj(lambda_r)) ]
           + U + L2 / s^2 + L1 / s,        s = i w

``U`` (upper residual) stands for modes above the band, ``L2`` and ``L1``
(lower residuals) for modes below it and for the low-frequency distortion
that an exponential window applied to measured acceleration leaves after
conversion to receptance. All unknowns are complex, estimated as pairs of
real numbers by weighted linear least squares; one small normal-equation
solve per FRF, batched over FRFs (no loop over frequencies).

Modal stiffness of mode ``r`` at driving point ``d`` (docs/references.md: modal identification):
``k_r,d = 1 / Re( 2 i w_d R_r,dd / w_r^2 )`` (:func:`modal_stiffness`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["LSFDResult", "lsfd", "modal_stiffness", "residue_basis"]


@dataclass(frozen=True)
class LSFDResult:
    """Residues and residual terms of a set of FRFs.

    Attributes
    ----------
    poles : ndarray of complex, shape (n_modes,)
        Poles used (upper half plane), rad/s.
    residues : ndarray of complex, shape (n_modes, *frf_shape)
        Residue of each mode in each FRF, (FRF unit) rad/s.
    upper, lower2, lower1 : ndarray of complex, shape frf_shape
        Residual terms ``U``, ``L2`` (times ``1/s^2``) and ``L1`` (times ``1/s``).
    rel_residual : ndarray of float, shape frf_shape
        Weighted residual norm over weighted data norm per FRF.
    residue_std : ndarray of float, shape (n_modes, *frf_shape)
        Standard deviation of each residue (``sqrt(var Re + var Im)``), from the
        normal matrix and the residual variance (weights taken as inverse noise
        standard deviation up to a common factor), the latter taken as the
        larger of the band average and the average over the lines within 10 %
        of the mode's frequency; NaN if unknown.
    """

    poles: NDArray[np.complex128]
    residues: NDArray[np.complex128]
    upper: NDArray[np.complex128]
    lower2: NDArray[np.complex128]
    lower1: NDArray[np.complex128]
    rel_residual: NDArray[np.float64]
    residue_std: NDArray[np.float64] | None = None

    def synthesize(self, freq_hz: ArrayLike, *, residuals: bool = True) -> NDArray[np.complex128]:
        """FRFs of the fitted model, shape (n_freq, *frf_shape)."""
        f = np.asarray(freq_hz, dtype=float)
        basis = residue_basis(f, self.poles, lower=residuals, upper=residuals)
        coef = _pack(self, residuals)
        flat = coef.reshape(coef.shape[0], -1)
        return np.asarray(basis @ flat, dtype=np.complex128).reshape(
            f.size, *self.residues.shape[1:]
        )

    def mode_peak(self) -> NDArray[np.float64]:
        """Peak ``|R_r| / |Re lambda_r|`` of each mode's term, shape (n_modes, *frf_shape)."""
        sigma = np.abs(self.poles.real).reshape((-1,) + (1,) * (self.residues.ndim - 1))
        return np.asarray(np.abs(self.residues) / sigma)


def _pack(res: LSFDResult, residuals: bool) -> NDArray[np.complex128]:
    """Complex coefficients in basis order (a_r, b_r per mode, then U, L2, L1 as re/im)."""
    R = res.residues
    n = R.shape[0]
    rest = R.shape[1:]
    parts = [np.stack([R.real, R.imag], axis=1).reshape(2 * n, *rest)]
    if residuals:
        for c in (res.upper, res.lower2, res.lower1):
            parts.append(np.stack([c.real, c.imag], axis=0))
    return np.concatenate(parts, axis=0).astype(complex)


def residue_basis(
    freq_hz: ArrayLike,
    poles: ArrayLike,
    *,
    lower: bool = True,
    upper: bool = True,
) -> NDArray[np.complex128]:
    """Complex basis of the LSFD model for real unknowns.

    Columns: for each mode ``r`` the pair ``g_r + g_r*`` and ``i (g_r - g_r*)``
    with ``g_r = 1 / (s - lambda_r)`` (multiplying Re R_r and Im R_r), then
    ``1, i`` (upper residual), ``1/s^2, i/s^2`` and ``1/s, i/s`` (lower).

    Returns
    -------
    ndarray of complex, shape (n_freq, 2 n_modes [+ 2] [+ 4])
    """
    s = 2j * np.pi * np.asarray(freq_hz, dtype=float)
    lam = np.asarray(poles, dtype=complex)
    g = 1.0 / (s[:, None] - lam[None, :])
    gc = 1.0 / (s[:, None] - np.conj(lam)[None, :])
    cols = np.stack([g + gc, 1j * (g - gc)], axis=2).reshape(s.size, 2 * lam.size)
    extra = []
    if upper:
        extra += [np.ones_like(s), 1j * np.ones_like(s)]
    if lower:
        with np.errstate(divide="ignore", invalid="ignore"):
            extra += [1.0 / s**2, 1j / s**2, 1.0 / s, 1j / s]
    if extra:
        cols = np.concatenate([cols, np.stack(extra, axis=1)], axis=1)
    return np.asarray(cols, dtype=np.complex128)


def lsfd(
    freq_hz: ArrayLike,
    H: ArrayLike,
    poles: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    lower: bool = True,
    upper: bool = True,
) -> LSFDResult:
    """Residues and residual terms of FRFs for fixed poles.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies of the fitting band, Hz (> 0 when ``lower``).
    H : array_like of complex, shape (n_freq, ...)
        FRFs; NaN entries are ignored (zero weight).
    poles : array_like of complex, shape (n_modes,)
        Poles, upper half plane, rad/s.
    weights : array_like, shape (n_freq, ...), optional
        Weight of each line (inverse noise standard deviation); default 1.
    lower, upper : bool
        Include lower (``L2/s^2 + L1/s``) and upper (``U``) residuals.

    Returns
    -------
    LSFDResult
    """
    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex)
    if h.shape[0] != f.size:
        raise InputError(f"H: expected {f.size} frequency lines first, found {h.shape}", "lsfd")
    if lower and np.any(f <= 0):
        raise InputError("freq_hz: lower residuals need frequencies > 0", "lsfd")
    lam = np.asarray(poles, dtype=complex).reshape(-1)
    rest = h.shape[1:]
    hf = h.reshape(f.size, -1)
    if weights is None:
        w = np.ones(hf.shape)
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=float), h.shape).reshape(f.size, -1)
    good = np.isfinite(hf) & np.isfinite(w)
    w = np.where(good, w, 0.0)
    hf = np.where(good, hf, 0.0)
    basis = residue_basis(f, lam, lower=lower, upper=upper)  # (F, P)
    n_p = basis.shape[1]
    # real-stacked weighted normal equations, batched over FRFs k
    br = np.concatenate([basis.real, basis.imag], axis=0)  # (2F, P)
    w2 = np.concatenate([w, w], axis=0) ** 2  # (2F, K)
    y = np.concatenate([hf.real, hf.imag], axis=0)  # (2F, K)
    scale = np.sqrt(np.einsum("fp,fk->kp", br**2, w2))  # column scaling per FRF
    scale = np.where(scale > 0, scale, 1.0)  # FRFs without data: solution 0, std NaN
    bw = w2.T[:, :, None] * br[None]  # (K, 2F, P)
    A = np.matmul(bw.transpose(0, 2, 1), br) / (scale[:, :, None] * scale[:, None, :])
    b = np.einsum("kfp,fk->kp", bw, y) / scale
    A = A + 1e-12 * np.eye(n_p)[None]
    Ainv = np.linalg.inv(A)
    x = np.einsum("kpq,kq->kp", Ainv, b) / scale  # (K, P)
    fit = br @ x.T  # (2F, K)
    n_eq = np.count_nonzero(w2 > 0, axis=0)
    chi2 = np.sum(w2 * (fit - y) ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = np.sqrt(chi2 / np.sum(w2 * y**2, axis=0))
        s2 = chi2 / np.maximum(n_eq - n_p, 1)  # residual variance (weighted units)
    var = s2[:, None] * np.einsum("kpp->kp", Ainv) / scale**2  # (K, P)
    nm = lam.size
    R = (x[:, 0 : 2 * nm : 2] + 1j * x[:, 1 : 2 * nm : 2]).T  # (n_modes, K)
    R_std = np.sqrt(var[:, 0 : 2 * nm : 2] + var[:, 1 : 2 * nm : 2]).T  # (n_modes, K)
    if nm:
        # Noise is rarely white over the band (hammer receptance: ~1/w^2 at low
        # frequency): scale each mode's variance by the residual variance of the
        # lines near it (within 10 % of its frequency) over the band average.
        fr = np.abs(lam) / (2 * np.pi)
        near = np.abs(f[:, None] - fr[None, :]) <= 0.1 * fr[None, :]  # (F, n_modes)
        near2 = np.concatenate([near, near], axis=0).astype(float)  # (2F, n_modes)
        res2 = w2 * (fit - y) ** 2  # (2F, K)
        live = (w2 > 0).astype(float)
        with np.errstate(invalid="ignore", divide="ignore"):
            local = (near2.T @ res2) / (near2.T @ live)  # (n_modes, K)
            ratio = local / (chi2 / np.maximum(n_eq, 1))[None, :]
        ratio = np.where(np.isfinite(ratio), np.maximum(ratio, 1.0), 1.0)
        R_std = R_std * np.sqrt(ratio)
    k0 = 2 * nm
    zero = np.zeros(x.shape[0], complex)
    U = x[:, k0] + 1j * x[:, k0 + 1] if upper else zero
    k1 = k0 + (2 if upper else 0)
    L2 = x[:, k1] + 1j * x[:, k1 + 1] if lower else zero
    L1 = x[:, k1 + 2] + 1j * x[:, k1 + 3] if lower else zero
    return LSFDResult(
        poles=lam.astype(np.complex128),
        residues=R.reshape(nm, *rest).astype(np.complex128),
        upper=np.asarray(U).reshape(rest).astype(np.complex128),
        lower2=np.asarray(L2).reshape(rest).astype(np.complex128),
        lower1=np.asarray(L1).reshape(rest).astype(np.complex128),
        rel_residual=np.asarray(rel, dtype=float).reshape(rest),
        residue_std=np.asarray(R_std, dtype=float).reshape(nm, *rest),
    )


def modal_stiffness(poles: ArrayLike, residues: ArrayLike) -> NDArray[np.float64]:
    """Driving-point modal stiffness ``1 / Re(2 i w_d R_r / w_r^2)``, N/m for R in m/N rad/s.

    A real (proportionally damped) mode has ``R_r = w_r^2 / (2 i w_d k_r)``,
    a residue at -90 deg, and both ``1 / Re(2 i w_d R_r / w_r^2)`` and the
    older ``Re(w_r^2 / (2 i w_d R_r))`` give ``k_r``. A complex mode (close
    modes of a non-proportionally damped robot, e.g. a heavily damped wrist)
    has its residue far from -90 deg; its real-mode term is then the
    projection of ``R_r`` on the real-mode direction (the compliance
    ``1/k_r`` of the symmetric, resonant part of the term; the rest is an
    antisymmetric term that a close neighbour's cancels). The older form
    divides by ``|R_r|^2`` instead and makes such a mode up to
    ``1 / sin^2(phase)`` too flexible (370 x at a phase of 177 deg, a
    synthesized FRF several times the measured one).

    Parameters
    ----------
    poles : array_like of complex, shape (n_modes,)
    residues : array_like of complex, shape (n_modes, ...)
        Driving-point residues.

    Returns
    -------
    ndarray of float, same shape as ``residues``
        Signed: negative where the projection is (a transfer FRF, reversed
        polarity); ``inf`` for a residue at 0 or 180 deg.
    """
    lam = np.asarray(poles, dtype=complex)
    R = np.asarray(residues, dtype=complex)
    sh = (-1,) + (1,) * (R.ndim - 1)
    wr2 = (np.abs(lam) ** 2).reshape(sh)
    wd = lam.imag.reshape(sh)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(1.0 / (2j * wd * R / wr2).real, dtype=float)
