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
    "EE_MASS_SHARE",
    "MODAL_K_MIN_N_PER_M",
    "RECEPTANCE_MAX",
    "SPIKE_RATIO",
    "SPINDLE_K_MIN_N_PER_M",
    "SPINDLE_TIP_MASS_MIN_KG",
    "STRUCTURE_RECEPTANCE_MAX",
    "TOOL_MOUNT_K_MIN_N_PER_M",
    "frf_value_problem",
    "modal_mass_kg",
    "receptance_scale_problem",
    "robot_mode_mass_problem",
    "soft_tool_mode_problem",
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
#: Softest spindle and holder [N/m] a tool sits on, the robot left out: 1 N/um
#: (small electro-spindles measure 5-50 N/um at the tool point). A mode lighter
#: than the spindle's mass at the tip (:data:`SPINDLE_TIP_MASS_MIN_KG`) cannot
#: bend the robot or the bracket (that moves the whole spindle), so the springs
#: it deforms are the tool's, the holder's and the spindle's: no softer than this.
SPINDLE_K_MIN_N_PER_M = 1.0e6
#: Lightest effective mass [kg] of a spindle at its tool tip when the robot's end
#: effector is not known: robot spindles weigh 3.5 kg and more, and a spindle
#: rocking about its mount shows about 1/7 of its mass at the tip (robot A's
#: 150 kg spindle: 21 kg, :meth:`robolobe.robots.model.Robot.tcp_effective_mass_kg`).
SPINDLE_TIP_MASS_MIN_KG = 0.5
#: Share of the end effector's effective mass at the TCP below which no mode's
#: tip-normalised modal mass ``k / (2 pi f)^2`` can lie. Exactly, the share is 1
#: (the rigid end effector alone carries that kinetic energy, Rayleigh); a quarter
#: leaves room for a fit's error and a spindle on a soft bracket that rocks
#: without part of its mass. The twins' robot modes lie 1.6-2.7 times above
#: their end effector's mass (A, B, C, 200 postures each); a stiffness written
#: in N/mm lies 1000 times lower.
EE_MASS_SHARE = 0.25
#: Lightest tip-normalised modal mass of a tool mode, as a share of the bar's
#: mass: every bending mode of a uniform cantilever has a quarter of the beam's
#: mass (int phi^2 = L phi(L)^2 / 4), and a rigid tilt of the bar about any
#: pivot no less (exactly 1/4 at a pivot L/3 from the clamp); half of that for a
#: necked tool and the fit's error.
TOOL_MODAL_MASS_SHARE = 1.0 / 8.0


def modal_mass_kg(f_hz: float, k_N_per_m: float) -> float:
    """Tip-normalised modal mass ``k / (2 pi f)^2`` [kg] of a mode at ``f_hz`` [Hz]."""
    return float(k_N_per_m) / (2.0 * math.pi * float(f_hz)) ** 2


def tool_mode_k_floor(
    f_hz: float, diameter_m: float, stickout_m: float, carrier_kg: float | None = None
) -> tuple[float, str]:
    """Softest plausible modal stiffness of a tool-point mode, and the bound that sets it.

    A tool-point mode is one of two kinds, and its stiffness must fit one:

    - it moves the spindle as a whole (the robot, the bracket): its modal mass
      ``k / (2 pi f)^2`` is at least the spindle's effective mass at the tip
      (``carrier_kg``, else :data:`SPINDLE_TIP_MASS_MIN_KG`), and its stiffness
      at least the softest mount, :data:`TOOL_MOUNT_K_MIN_N_PER_M`;
    - it is lighter: then it bends the tool, the holder and the spindle only,
      and its stiffness is at least the static stiffness of a steel bar of
      ``0.8 diameter_m`` clamped at ``stickout_m`` (``k = 3 E I / L^3``) in
      series with :data:`SPINDLE_K_MIN_N_PER_M` (modal compliances of a driving
      point add up to the static one), and its modal mass at least
      :data:`TOOL_MODAL_MASS_SHARE` of that bar's mass.

    A stiffness written in N/mm (1000 times too soft) has a modal mass 1000
    times too light, lighter than the spindle for every mode of a spindle,
    holder or tool, and then falls below the second kind's floor for every
    mode up to about 1000 times that floor (some 1e8-1e9 N/m).

    Parameters
    ----------
    f_hz : float
        The mode's natural frequency [Hz].
    diameter_m, stickout_m : float
        The cutter's nominal diameter and stick-out from the holder [m].
    carrier_kg : float, optional
        The lightest modal mass [kg] of a mode that moves the spindle (the robot's
        :meth:`~robolobe.robots.model.Robot.tcp_effective_mass_kg` times
        :data:`EE_MASS_SHARE`); default :data:`SPINDLE_TIP_MASS_MIN_KG`.

    Returns
    -------
    floor : float
        Softest plausible modal stiffness [N/m].
    why : str
        The bound that sets it, with its numbers, for a message.
    """
    w2 = (2.0 * math.pi * f_hz) ** 2
    d = TOOL_BAR_DIAMETER_SHARE * diameter_m
    k_bar = 3.0 * TOOL_E_PA * (math.pi * d**4 / 64.0) / stickout_m**3
    k_static = 1.0 / (1.0 / k_bar + 1.0 / SPINDLE_K_MIN_N_PER_M)
    bar_kg = TOOL_RHO_KG_PER_M3 * math.pi * d**2 / 4.0 * stickout_m
    k_mass = TOOL_MODAL_MASS_SHARE * bar_kg * w2
    bar = f"a steel bar of {1e3 * d:.3g} mm x {1e3 * stickout_m:.3g} mm"
    light_kg = bar_kg * TOOL_MODAL_MASS_SHARE
    if k_mass >= k_static:
        share = f"1/{1.0 / TOOL_MODAL_MASS_SHARE:.0f}"
        light = k_mass
        why_light = (
            f"a modal mass k/(2 pi f)^2 of at least {1e3 * light_kg:.3g} g, {share} of {bar}"
        )
    else:
        light = k_static
        why_light = (
            f"the static stiffness of {bar} ({k_bar:.3g} N/m) on a spindle and holder "
            f"of {SPINDLE_K_MIN_N_PER_M:.3g} N/m"
        )
    carrier = SPINDLE_TIP_MASS_MIN_KG if carrier_kg is None else float(carrier_kg)
    heavy = max(TOOL_MOUNT_K_MIN_N_PER_M, carrier * w2)
    if heavy >= light:
        return light, why_light
    return heavy, (
        f"a mode that moves the spindle: a modal mass k/(2 pi f)^2 of at least {carrier:.3g} kg "
        f"(the spindle at the tip) on a mount of at least {TOOL_MOUNT_K_MIN_N_PER_M:.3g} N/m"
    )


def soft_tool_mode_problem(
    f_hz: float,
    k: float,
    diameter_m: float,
    stickout_m: float,
    stick_key: str,
    *,
    default: bool = False,
    carrier_kg: float | None = None,
) -> str | None:
    """Why a tool-point mode is softer than a tool of its size can be, or None.

    The job file, the Python API (``ToolSpec``) and ``sld --tool-diameter``
    say it in the same words (expected vs found, the bound of
    :func:`tool_mode_k_floor`, the value read as N/mm).

    Parameters
    ----------
    f_hz, k : float
        The mode's natural frequency [Hz] and modal stiffness [N/m].
    diameter_m, stickout_m : float
        The cutter's nominal diameter and stick-out [m].
    stick_key : str
        The key or option that gives the stick-out, named as the other way out.
    default : bool
        The stick-out was not given (said in the message).
    carrier_kg : float, optional
        The spindle's effective mass at the tip [kg] (default: the lightest).

    Returns
    -------
    str or None
        Expected vs found, for a message.
    """
    try:
        vals = [float(x) for x in (f_hz, k, diameter_m, stickout_m)]
    except (TypeError, ValueError):
        return None  # the fields' own checks say what is wrong
    if not all(math.isfinite(x) and x > 0 for x in vals):
        return None
    floor, why = tool_mode_k_floor(vals[0], vals[2], vals[3], carrier_kg)
    if vals[1] >= floor:
        return None
    return (
        f"expected at least {floor:.3g} N/m for a mode at {vals[0]:g} Hz of a "
        f"{vals[2] * 1e3:g} mm tool at a stick-out of {vals[3] * 1e3:g} mm"
        f"{' (the default)' if default else ''} ({why}), found {vals[1]:g}: a stiffness in "
        f"N/mm? In N/m it is {vals[1] * 1e3:.3g}; or give the tool's real {stick_key}"
    )


def robot_mode_mass_problem(
    f_hz: float, k_N_per_m: float, ee_mass_kg: float, direction: str
) -> str | None:
    """Why a robot mode at the TCP is lighter than the robot's end effector allows, or None.

    Every mode's tip-normalised modal mass ``k / (2 pi f)^2`` is at least the
    end effector's effective mass at the TCP along ``direction`` (the rigid
    body alone carries that kinetic energy); :data:`EE_MASS_SHARE` of it is the
    bound. A stiffness written in N/mm gives a mass 1000 times too light.

    Parameters
    ----------
    f_hz, k_N_per_m : float
        The mode's natural frequency [Hz] and driving-point modal stiffness [N/m].
    ee_mass_kg : float
        The end effector's effective mass [kg] at the TCP along ``direction``.
    direction : str
        For the message (``"xx"`` etc.).

    Returns
    -------
    str or None
        Expected vs found, with the value in N/m, for a message.
    """
    try:
        f, k, m_ee = float(f_hz), float(k_N_per_m), float(ee_mass_kg)
    except (TypeError, ValueError):
        return None  # the fields' own checks say what is wrong
    if not all(math.isfinite(x) and x > 0 for x in (f, k, m_ee)):
        return None
    m = modal_mass_kg(f, k)
    floor = EE_MASS_SHARE * m_ee
    if m >= floor:
        return None
    return (
        f"expected a modal mass k/(2 pi f)^2 of at least {floor:.3g} kg at {f:g} Hz "
        f"({EE_MASS_SHARE:g} of the end effector's {m_ee:.3g} kg at the TCP along "
        f"{direction[0]}), i.e. k >= {floor * (2 * math.pi * f) ** 2:.3g} N/m; found "
        f"{k:g} N/m ({m:.3g} kg): a stiffness in N/mm? In N/m it is {k * 1e3:.3g}"
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
