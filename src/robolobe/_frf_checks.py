"""Plausibility of measured FRF values, shared by every reader of measured data.

One corrupted number (a 1e300, a NaN) ruins every fit of its posture, so
the campaign readers (CSV, UFF 58) and identification refuse it with its
place. This module sits below every package (it knows only numpy), so
``twin`` and ``modal`` both use it without knowing each other.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MODAL_K_MIN_N_PER_M",
    "RECEPTANCE_MAX",
    "SPIKE_RATIO",
    "STRUCTURE_RECEPTANCE_MAX",
    "frf_value_problem",
    "receptance_scale_problem",
]

#: Largest plausible receptance magnitude [m/N]: 1 N moving a point by a kilometre.
RECEPTANCE_MAX = 1e3
#: Softest modal stiffness [N/m] of a machining structure (10 N/mm): the twins'
#: lowest robot mode over the shipped test designs is 1.2e5 N/m, a long 3 mm end
#: mill about 5e4 N/m. A stiffness written in N/mm reads 1000 times softer.
MODAL_K_MIN_N_PER_M = 1.0e4
#: Largest median receptance magnitude [m/N] over a robot's measured band:
#: 1 / :data:`MODAL_K_MIN_N_PER_M` (the median of a structure no softer stays
#: below its static compliance: the peaks are few lines). Robot B's simulated
#: campaigns have a median of 8e-7 m/N; a receptance in mm/N reads 1000 times larger.
STRUCTURE_RECEPTANCE_MAX = 1.0 / MODAL_K_MIN_N_PER_M
#: A line this many times the FRF's median magnitude is a corrupted value, not a peak.
SPIKE_RATIO = 1e8


def receptance_scale_problem(values: ArrayLike) -> str | None:
    """Why a set of FRFs cannot be a robot's receptance in m/N (a unit slip), or None.

    Parameters
    ----------
    values : array_like of complex
        All receptance lines [m/N] of a campaign (NaN: not measured).

    Returns
    -------
    str or None
        The median magnitude and what it means, when it exceeds
        :data:`STRUCTURE_RECEPTANCE_MAX`.
    """
    mag = np.abs(np.asarray(values, dtype=complex).reshape(-1))
    mag = mag[np.isfinite(mag) & (mag > 0)]
    if mag.size == 0:
        return None
    med = float(np.median(mag))
    if med <= STRUCTURE_RECEPTANCE_MAX:
        return None
    return (
        f"median receptance |H| = {med:.3g} m/N, a structure softer than "
        f"{1e-3 / med:.3g} N/mm; expected m/N (at most {STRUCTURE_RECEPTANCE_MAX:g} m/N): "
        "a file in mm/N?"
    )


def frf_value_problem(values: ArrayLike) -> tuple[int, str] | None:
    """First implausible value of one FRF (receptance, m/N), or None.

    Non-finite values, magnitudes above :data:`RECEPTANCE_MAX` and spikes more
    than :data:`SPIKE_RATIO` times the FRF's median magnitude (a corrupted
    number: one such value ruins every fit of the posture).

    Parameters
    ----------
    values : array_like of complex, shape (n,)

    Returns
    -------
    (index, reason) or None
    """
    v = np.asarray(values, dtype=complex).reshape(-1)
    bad = ~np.isfinite(v)
    if bad.any():
        i = int(np.argmax(bad))
        return i, f"expected a finite value, found {v[i]}"
    mag = np.abs(v)
    if v.size and float(mag.max()) > RECEPTANCE_MAX:
        i = int(np.argmax(mag))
        return i, (
            f"implausible receptance |H| = {mag[i]:.3g} m/N (above {RECEPTANCE_MAX:g} m/N); "
            "a corrupted number or wrong units"
        )
    nz = mag[mag > 0]
    if nz.size >= 8:
        med = float(np.median(nz))
        ratio = mag / med
        if float(ratio.max()) > SPIKE_RATIO:
            i = int(np.argmax(ratio))
            return i, (
                f"implausible value |H| = {mag[i]:.3g}, {ratio[i]:.2g} times the median "
                f"{med:.3g} of this FRF; a corrupted number"
            )
    return None
