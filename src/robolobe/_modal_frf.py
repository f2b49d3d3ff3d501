"""The modal-stiffness FRF kernel, shared by the twin and modal identification.

One formula, one implementation (docs/guide/modal.md, docs/guide/physics.md)::

    H(w) = sum_r (w_r^2 / k_r) / (w_r'^2 - w^2 + 2 i sigma_r' w)

with ``sigma_r' = zeta_r w_r + a`` and ``w_r'^2 = sigma_r'^2 + w_r^2 (1 - zeta_r^2)``:
each pole ``lambda_r`` moved left by the decay ``a`` of an exponential window
with its residue kept (``a = 0``: the plain modal form). Callers validate;
this module imports only robolobe.errors, so every layer may use it.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["modal_stiffness_frf"]


def modal_stiffness_frf(
    f_hz: ArrayLike,
    zeta: ArrayLike,
    k_N_per_m: ArrayLike,
    freq_hz: ArrayLike,
    *,
    window_decay_per_s: float = 0.0,
    ignore_nan: bool = False,
) -> NDArray[np.complex128]:
    """Receptance from natural frequencies, damping ratios and modal stiffnesses.

    Parameters
    ----------
    f_hz, zeta, k_N_per_m : array_like, shape (..., n_modes)
        Natural frequencies [Hz], damping ratios (fraction, < 1) and modal
        stiffnesses [N/m] (``inf``: the mode does not show; negative allowed
        for cross directions). Broadcast together.
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz].
    window_decay_per_s : float
        Decay rate of an exponential window [1/s]; 0 for none.
    ignore_nan : bool
        Modes with a NaN parameter contribute nothing (else NaN propagates).

    Returns
    -------
    ndarray, shape (..., n_freq), complex
        Receptance [m/N].

    Examples
    --------
    At 0 Hz the receptance is the static compliance ``sum(1 / k)``; at a
    natural frequency one mode gives ``-i / (2 zeta k)``:

    >>> h = modal_stiffness_frf([10.0, 30.0], [0.02, 0.05], [1e6, 4e6], [0.0, 10.0])
    >>> round(h[0].real * 1e6, 6)
    1.25
    >>> h1 = modal_stiffness_frf([10.0], [0.02], [1e6], [10.0])[0]
    >>> round(h1.real * 1e6, 6), round(h1.imag * 1e6, 6)
    (0.0, -25.0)
    """
    fn, z, k = np.broadcast_arrays(
        np.asarray(f_hz, dtype=float), np.asarray(zeta, dtype=float), np.asarray(k_N_per_m, float)
    )
    w = 2.0 * np.pi * np.asarray(freq_hz, dtype=float)
    if w.ndim != 1:
        raise InputError(f"freq_hz: expected a 1-D array, found shape {w.shape}")
    wr = 2.0 * np.pi * fn
    with np.errstate(invalid="ignore", divide="ignore"):
        num = wr**2 / k
        if window_decay_per_s:
            sigma = z * wr + window_decay_per_s
            wr2 = sigma**2 + wr**2 * (1.0 - z**2)
        else:
            sigma = z * wr
            wr2 = wr**2
        den = wr2[..., None] - w**2 + 2j * sigma[..., None] * w
        terms = num[..., None] / den  # (..., n_modes, n_freq)
    if ignore_nan:
        bad = ~(np.isfinite(fn) & np.isfinite(z) & ~np.isnan(k))
        terms = np.where(bad[..., None], 0.0, terms)
    return np.asarray(terms.sum(axis=-2), dtype=np.complex128)
