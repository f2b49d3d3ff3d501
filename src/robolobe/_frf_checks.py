"""Plausibility of measured FRF values, shared by every reader of measured data.

One corrupted number (a 1e300, a NaN) ruins every fit of its posture, so
the campaign readers (CSV, UFF 58) and identification refuse it with its
place. The same orders of magnitude bound modal stiffness: the robot's, and
a tool mode's against what a tool of its size can be
(:func:`tool_mode_k_floor`). This module sits below every package (it knows
only numpy), so ``twin``, ``modal`` and ``plan`` use it without knowing each other.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "MODAL_K_MIN_N_PER_M",
    "RECEPTANCE_MAX",
    "SPIKE_RATIO",
    "STRUCTURE_RECEPTANCE_MAX",
    "TOOL_MOUNT_K_MIN_N_PER_M",
    "frf_value_problem",
    "receptance_scale_problem",
    "tool_mode_k_floor",
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

#: Young's modulus [Pa] and density [kg/m^3] of steel, the softest and lightest
#: material of an end mill's shank (carbide: about 600 GPa and 14,500 kg/m^3).
TOOL_E_PA = 2.1e11
TOOL_RHO_KG_PER_M3 = 7850.0
#: Diameter of the round bar that stands for a fluted cutter, as a share of its
#: nominal diameter (the usual equivalent of the fluted section).
TOOL_BAR_DIAMETER_SHARE = 0.8
#: Softest mount [N/m] (spindle, holder, bracket) a tool mode can sit on: no
#: softer than the robot arm itself (its softest mode over the shipped designs
#: is 1.2e5 N/m).
TOOL_MOUNT_K_MIN_N_PER_M = 1.0e5
#: Lightest tip-normalised modal mass of a tool mode, as a share of the bar's
#: mass: every bending mode of a uniform cantilever has a quarter of the beam's
#: mass (int phi^2 = L phi(L)^2 / 4), and a rigid tilt of the bar about any
#: pivot no less (exactly 1/4 at a pivot L/3 from the clamp); half of that for a
#: necked tool and the fit's error.
TOOL_MODAL_MASS_SHARE = 1.0 / 8.0


def tool_mode_k_floor(f_hz: float, diameter_m: float, stickout_m: float) -> tuple[float, str]:
    """Softest plausible modal stiffness of a tool-point mode, and the bound that sets it.

    A tool mode's tip compliance is at most the static compliance of the tool
    point (modal compliances of a driving point add up to it), which is at most
    a steel bar of ``0.8 diameter_m`` clamped at ``stickout_m``
    (``k = 3 E I / L^3``) in series with the softest mount
    (:data:`TOOL_MOUNT_K_MIN_N_PER_M`); and its modal mass ``k / (2 pi f)^2``
    is at least :data:`TOOL_MODAL_MASS_SHARE` of that bar's mass. A stiffness
    written in N/mm (1000 times too soft) falls below one of them for every
    tool mode of 1e7-1e8 N/m.

    Parameters
    ----------
    f_hz : float
        The mode's natural frequency [Hz].
    diameter_m, stickout_m : float
        The cutter's nominal diameter and stick-out from the holder [m].

    Returns
    -------
    floor : float
        Softest plausible modal stiffness [N/m].
    why : str
        The bound that sets it, with its numbers, for a message.
    """
    d = TOOL_BAR_DIAMETER_SHARE * diameter_m
    k_bar = 3.0 * TOOL_E_PA * (math.pi * d**4 / 64.0) / stickout_m**3
    k_static = 1.0 / (1.0 / k_bar + 1.0 / TOOL_MOUNT_K_MIN_N_PER_M)
    bar_kg = TOOL_RHO_KG_PER_M3 * math.pi * d**2 / 4.0 * stickout_m
    k_mass = TOOL_MODAL_MASS_SHARE * bar_kg * (2.0 * math.pi * f_hz) ** 2
    if k_mass >= k_static:
        share = f"1/{1.0 / TOOL_MODAL_MASS_SHARE:.0f}"
        return k_mass, (
            f"a modal mass k/(2 pi f)^2 of at least {1e3 * bar_kg * TOOL_MODAL_MASS_SHARE:.3g} g, "
            f"{share} of a steel bar of {1e3 * d:.3g} mm x {1e3 * stickout_m:.3g} mm"
        )
    return k_static, (
        f"the static stiffness of a steel bar of {1e3 * d:.3g} mm x {1e3 * stickout_m:.3g} mm "
        f"({k_bar:.3g} N/m) on a mount of {TOOL_MOUNT_K_MIN_N_PER_M:.3g} N/m"
    )


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
