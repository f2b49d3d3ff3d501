"""Plausibility of measured FRF values, shared by every reader of measured data.

One corrupted number (a 1e300, a NaN) ruins every fit of its posture, so
the campaign readers (CSV, UFF 58) and identification refuse it with its
place. This module sits below every package (it knows only numpy), so
``twin`` and ``modal`` both use it without knowing each other.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["RECEPTANCE_MAX", "SPIKE_RATIO", "frf_value_problem"]

#: Largest plausible receptance magnitude [m/N]: 1 N moving a point by a kilometre.
RECEPTANCE_MAX = 1e3
#: A line this many times the FRF's median magnitude is a corrupted value, not a peak.
SPIKE_RATIO = 1e8


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
