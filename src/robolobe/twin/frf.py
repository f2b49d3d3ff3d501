"""TCP receptance of the flexible-joint model, and FRFs from modal parameters.

:func:`receptance` is the definition of docs/guide/robots.md,
``H(w) = J (K - w^2 M + i w C)^-1 J^T`` [m/N], solved directly (batched over
postures and frequencies). :func:`modal_receptance` is the driving-point
modal form of docs/guide/physics.md / docs/guide/modal.md,
``H(w) = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``, validated
here and computed by the project's one kernel (:mod:`robolobe._modal_frf`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._modal_frf import modal_stiffness_frf
from robolobe.errors import InputError
from robolobe.twin.modes import _system_arrays

__all__ = ["modal_receptance", "receptance"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TWO_PI = 2.0 * np.pi
# complex entries of the (chunk, n_freq, n, n) system matrices solved at once
_CHUNK_ENTRIES = 1 << 21


def _freq(freq_hz: ArrayLike) -> FloatArray:
    f = np.asarray(freq_hz, dtype=np.float64)
    if f.ndim != 1:
        raise InputError(f"freq_hz: expected shape (n_freq,), found {f.shape}")
    if not np.all(np.isfinite(f)) or np.any(f < 0):
        raise InputError("freq_hz: expected finite frequencies >= 0 Hz, found negative/inf/nan")
    return f


def receptance(
    M: ArrayLike, K: ArrayLike, C: ArrayLike, J: ArrayLike, freq_hz: ArrayLike
) -> ComplexArray:
    """TCP receptance ``H(w) = J (K - w^2 M + i w C)^-1 J^T``.

    Parameters
    ----------
    M, K, C : array_like, shape (..., n, n)
        Mass [kg m^2], stiffness [N m/rad] and viscous damping [N m s/rad]
        matrices (joint-space units; extra DOFs in their own SI units).
    J : array_like, shape (..., p, n)
        Translational TCP Jacobian in the TCP frame [m/rad] (p = 3).
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], >= 0.

    Returns
    -------
    ndarray, shape (..., n_freq, p, p), complex
        Receptance [m/N]: entry ``[..., f, a, b]`` is the displacement in
        direction a per unit force in direction b.
    """
    m, k, c, j = _system_arrays(M, K, C, J)
    f = _freq(freq_hz)
    w = _TWO_PI * f
    batch = m.shape[:-2]
    n = m.shape[-1]
    p = j.shape[-2]
    nb = int(np.prod(batch, dtype=np.int64))
    m2, k2, c2, j2 = (a.reshape(nb, *a.shape[-2:]) for a in (m, k, c, j))
    out = np.empty((nb, f.size, p, p), dtype=np.complex128)
    step = max(1, _CHUNK_ENTRIES // max(1, f.size * n * n))
    w2 = (w**2)[:, None, None]
    iw = (1j * w)[:, None, None]
    for start in range(0, nb, step):
        sl = slice(start, min(nb, start + step))
        dyn = k2[sl, None] - w2 * m2[sl, None] + iw * c2[sl, None]  # (b, n_freq, n, n)
        rhs = np.broadcast_to(np.swapaxes(j2[sl], -1, -2)[:, None], (*dyn.shape[:-1], p))
        out[sl] = j2[sl, None] @ np.linalg.solve(dyn, rhs)
    return out.reshape(*batch, f.size, p, p)


def modal_receptance(
    f_hz: ArrayLike, zeta: ArrayLike, k_N_per_m: ArrayLike, freq_hz: ArrayLike
) -> ComplexArray:
    """Driving-point receptance from modal parameters.

    ``H(w) = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``.

    Parameters
    ----------
    f_hz : array_like, shape (..., n_modes)
        Natural frequencies [Hz], > 0.
    zeta : array_like, shape (..., n_modes)
        Damping ratios (fraction), >= 0.
    k_N_per_m : array_like, shape (..., n_modes)
        Modal stiffnesses [N/m], > 0; ``inf`` for a mode that does not show.
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].

    Returns
    -------
    ndarray, shape (..., n_freq), complex
        Receptance [m/N].
    """
    fr = np.asarray(f_hz, dtype=np.float64)
    ze = np.asarray(zeta, dtype=np.float64)
    kk = np.asarray(k_N_per_m, dtype=np.float64)
    try:
        fr, ze, kk = np.broadcast_arrays(fr, ze, kk)
    except ValueError as exc:
        raise InputError(
            f"f_hz, zeta, k_N_per_m: shapes {fr.shape}, {ze.shape}, {kk.shape} do not broadcast"
        ) from exc
    if fr.ndim == 0:
        raise InputError("f_hz: expected shape (..., n_modes), found a scalar")
    if not (np.all(np.isfinite(fr)) and np.all(fr > 0)):
        raise InputError("f_hz: expected finite frequencies > 0 Hz")
    if not (np.all(np.isfinite(ze)) and np.all(ze >= 0)):
        raise InputError("zeta: expected finite damping ratios >= 0")
    if np.any(np.isnan(kk)) or np.any(kk <= 0):
        raise InputError("k_N_per_m: expected modal stiffnesses > 0 N/m (inf allowed)")
    return modal_stiffness_frf(fr, ze, kk, _freq(freq_hz))
