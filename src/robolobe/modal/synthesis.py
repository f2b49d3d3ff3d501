"""FRF synthesis from modal parameters.

Two forms:

- modal-stiffness form (docs/guide/modal.md, docs/guide/physics.md), one direction::

      H(w) = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)

- pole-residue form (what LSFD estimates), with complex-conjugate pairs and
  optional lower (``LR / (i w)^2``... written as ``-LR / w^2``) and upper
  (constant ``UR``) residual terms::

      H(w) = sum_r [ R_r / (i w - lambda_r) + conj(R_r) / (i w - conj(lambda_r)) ]
             + UR - LR / w^2

  with ``lambda_r = -zeta_r w_r + i w_r sqrt(1 - zeta_r^2)``.

For a lightly damped mode the two agree when
``R_r = w_r^2 / (2 i w_d k_r)`` (docs/references.md: modal identification).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._modal_frf import modal_stiffness_frf

__all__ = [
    "modal_to_poles",
    "poles_to_modal",
    "synthesize_frf",
    "synthesize_pole_residue",
]


def synthesize_frf(
    f_hz: ArrayLike,
    zeta: ArrayLike,
    k_N_per_m: ArrayLike,
    freq_hz: ArrayLike,
    *,
    window_decay_per_s: float = 0.0,
    ignore_nan: bool = False,
) -> NDArray[np.complex128]:
    """Receptance from natural frequencies, damping ratios and modal stiffnesses.

    The modal-stiffness form, computed by the project's one kernel
    (:func:`robolobe._modal_frf.modal_stiffness_frf`, also behind
    :func:`robolobe.twin.frf.modal_receptance`).

    Parameters
    ----------
    f_hz : array_like, shape (..., n_modes)
        Natural frequencies, Hz.
    zeta : array_like, shape (..., n_modes)
        Damping ratios (fractions).
    k_N_per_m : array_like, shape (..., n_modes)
        Modal stiffnesses at the direction, N/m (negative allowed for cross
        directions).
    freq_hz : array_like, shape (n_freq,)
        Frequencies at which to evaluate, Hz.
    window_decay_per_s : float, default 0
        Decay rate of an exponential window, 1/s: the FRF as the windowed
        measurement shows it (every pole moved left by it, residues kept).
    ignore_nan : bool, default False
        If True, modes whose ``f_hz``, ``zeta`` or ``k_N_per_m`` is NaN
        (absent modes) contribute nothing; otherwise NaN propagates.

    Returns
    -------
    numpy.ndarray of complex, shape (..., n_freq)
        Receptance, m/N. The leading shape is the broadcast of the three
        parameter arrays without their last axis.
    """
    return modal_stiffness_frf(
        f_hz,
        zeta,
        k_N_per_m,
        freq_hz,
        window_decay_per_s=float(window_decay_per_s),
        ignore_nan=ignore_nan,
    )


def modal_to_poles(f_hz: ArrayLike, zeta: ArrayLike) -> NDArray[np.complex128]:
    """Poles ``lambda_r = -zeta w_r + i w_r sqrt(1 - zeta^2)``, rad/s, same shape as input."""
    wr = 2.0 * np.pi * np.asarray(f_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    return np.asarray(-z * wr + 1j * wr * np.sqrt(1.0 - z**2), dtype=np.complex128)


def poles_to_modal(
    poles: ArrayLike,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Natural frequency (Hz) and damping ratio of poles (upper half plane), rad/s.

    Returns
    -------
    f_hz, zeta : numpy.ndarray, same shape as ``poles``
        ``w_r = |lambda|``, ``zeta = -Re(lambda) / |lambda|``.
    """
    lam = np.asarray(poles, dtype=complex)
    wr = np.abs(lam)
    with np.errstate(invalid="ignore", divide="ignore"):
        z = -lam.real / wr
    return wr / (2.0 * np.pi), z


def synthesize_pole_residue(
    poles: ArrayLike,
    residues: ArrayLike,
    freq_hz: ArrayLike,
    *,
    lower: ArrayLike | None = None,
    upper: ArrayLike | None = None,
) -> NDArray[np.complex128]:
    """FRF from poles and residues (complex-conjugate pairs) plus residual terms.

    Parameters
    ----------
    poles : array_like of complex, shape (n_modes,)
        Poles in the upper half plane, rad/s.
    residues : array_like of complex, shape (..., n_modes)
        Residues, (m/N) rad/s.
    freq_hz : array_like, shape (n_freq,)
        Frequencies, Hz.
    lower, upper : array_like, shape (...), optional
        Lower residual (mass line ``-LR / w^2``, LR in 1/kg) and upper
        residual (constant, m/N); complex allowed.

    Returns
    -------
    numpy.ndarray of complex, shape (..., n_freq)
    """
    lam = np.asarray(poles, dtype=complex)
    R = np.asarray(residues, dtype=complex)
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    s = 1j * w
    basis = 1.0 / (s[:, None] - lam[None, :])  # (n_freq, n_modes)
    basis_c = 1.0 / (s[:, None] - np.conj(lam)[None, :])
    H = R @ basis.T + np.conj(R) @ basis_c.T
    if upper is not None:
        H = H + np.asarray(upper)[..., None]
    if lower is not None:
        with np.errstate(divide="ignore"):
            H = H - np.asarray(lower)[..., None] / w**2
    return np.asarray(H, dtype=np.complex128)
