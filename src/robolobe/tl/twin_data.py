"""Modal datasets and measured FRFs from the digital twin (simulated campaigns).

How the twin's modes become the seed's "5 modes per direction"
---------------------------------------------------------------
The twin has one mode per joint (6). Per driving-point direction ``d`` the
dataset keeps the **5 lowest modes by frequency** (rank order, the same five
physical modes in every direction; mode 6 lies far above the 0-40 Hz band).
A mode is *seen* at ``d`` when an identification could see it there, the
rule of :class:`robolobe.modal.posture.IdentifySettings`: its resonance lies
in the analysis band and the peak of its term, ``1 / (2 zeta k_d)``, is at
least ``visibility_min`` (0.03) of the largest ``|H_dd|`` in the band.
A mode not seen is missing (NaN) in that direction, as in an identified
``modal.csv``.

Identification noise (``noise=True``) multiplies each value by a log-normal
factor with the scatter that simulated identification reaches (docs/references.md
section 4: f within 0.2 %, damping within 2-7 %, driving-point k within
2.5-4.5 %, 90th percentiles): relative standard deviations 0.1 %, 3 % and
2 %. With ``noise=False`` the dataset holds the twin's exact values.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import dir_index
from robolobe.errors import InputError
from robolobe.tl.dataset import ModalDataset

__all__ = [
    "IdentificationNoise",
    "measured_frfs",
    "twin_modal_dataset",
    "twin_modal_values",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class IdentificationNoise:
    """Relative scatter (standard deviation of the log) of identified values."""

    f: float = 0.001
    zeta: float = 0.03
    k: float = 0.02


def twin_modal_values(
    twin: Any,
    q_rad: ArrayLike,
    *,
    directions: Sequence[str] = ("xx", "yy"),
    n_modes: int = 5,
    visibility_min: float = 0.03,
    band_hz: tuple[float, float] = (4.0, 40.0),
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Exact modal values of the twin and whether each is seen at its direction.

    Parameters
    ----------
    twin : robolobe.twin.model.Twin
    q_rad : array_like, shape (n, 6)
    directions, n_modes, visibility_min, band_hz
        See the module docstring.

    Returns
    -------
    y : ndarray, shape (n, n_dir, n_modes, 3)
        Frequency [Hz], damping ratio, modal stiffness [N/m] (``inf`` where
        the mode does not move the TCP along d).
    seen : ndarray of bool, shape (n, n_dir, n_modes)
    """
    q = np.asarray(q_rad, dtype=float)
    modes = twin.modes(q)
    if modes.n_modes < n_modes:
        raise InputError(f"n_modes: the twin has only {modes.n_modes} modes, asked {n_modes}")
    # the twin's modes on the driving points (raises on any other direction)
    y = modes.parameters(directions).stacked()[:, :, :n_modes]
    f = modes.f_hz[:, :n_modes]
    z = modes.zeta[:, :n_modes]
    freq = np.arange(band_hz[0], band_hz[1] + 1e-9, 0.25)
    h = twin.receptance(q, freq, method="modal")
    seen = np.empty(y.shape[:3], dtype=bool)
    for j, d in enumerate(directions):
        a = dir_index(d)[0]
        peak = np.abs(h[:, :, a, a]).max(axis=1)  # (n,)
        with np.errstate(divide="ignore"):
            term = 1.0 / (2.0 * z * y[:, j, :, 2])
        in_band = (f >= band_hz[0]) & (f <= band_hz[1])
        seen[:, j] = in_band & (term >= visibility_min * peak[:, None])
    return y, seen


def twin_modal_dataset(
    twin: Any,
    posture_ids: Sequence[str],
    q_rad: ArrayLike,
    *,
    directions: Sequence[str] = ("xx", "yy"),
    n_modes: int = 5,
    visibility_min: float = 0.03,
    noise: IdentificationNoise | None = IdentificationNoise(),
    rng: np.random.Generator | None = None,
) -> ModalDataset:
    """An identified-like modal dataset of the twin (module docstring).

    Parameters
    ----------
    twin : robolobe.twin.model.Twin
    posture_ids : sequence of str, length n
    q_rad : array_like, shape (n, 6)
    directions, n_modes, visibility_min
        See :func:`twin_modal_values`.
    noise : IdentificationNoise or None
        Identification scatter; None for exact values.
    rng : numpy.random.Generator
        Needed with ``noise``.

    Returns
    -------
    ModalDataset
        NaN where a mode is not seen.
    """
    y, seen = twin_modal_values(
        twin, q_rad, directions=directions, n_modes=n_modes, visibility_min=visibility_min
    )
    if noise is not None:
        if rng is None:
            raise InputError("rng: a numpy Generator is needed to add identification noise")
        sig = np.array([noise.f, noise.zeta, noise.k])
        y = y * np.exp(rng.standard_normal(y.shape) * sig)
    y = np.where(seen[..., None], y, np.nan)
    return ModalDataset(tuple(posture_ids), np.asarray(q_rad, dtype=float), tuple(directions), y)


def measured_frfs(
    twin: Any,
    posture_ids: Sequence[str],
    q_rad: ArrayLike,
    *,
    robot: str,
    rng: np.random.Generator,
    directions: Sequence[str] = ("xx", "yy"),
    fmax_hz: float = 40.0,
) -> tuple[FloatArray, NDArray[np.complex128], float]:
    """Driving-point FRFs of simulated hammer tests (the seed's test settings).

    Returns
    -------
    freq_hz : ndarray, shape (n_freq,)
    H : ndarray, shape (n, n_dir, n_freq), complex
        H1 receptance [m/N].
    window_decay_per_s : float
        ``-ln(window_end) / duration_s`` of the test's exponential window.
    """
    from robolobe.twin.campaign import simulate_campaign

    camp = simulate_campaign(
        twin.receptance,
        robot,
        list(posture_ids),
        np.asarray(q_rad, dtype=float),
        rng=rng,
        dirs=tuple(directions),
        fmax_hz=fmax_hz,
    )
    freq = np.asarray(camp.frfs[0].freq_hz, dtype=float)
    out = np.empty((len(posture_ids), len(directions), freq.size), dtype=complex)
    for i, pf in enumerate(camp.frfs):
        for j, d in enumerate(directions):
            a = dir_index(d)[0]
            out[i, j] = pf.H[:, a, a]
    return freq, out, camp.test.decay_per_s
