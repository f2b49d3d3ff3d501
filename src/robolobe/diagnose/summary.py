"""Plain-language conclusion of a diagnosis."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robolobe.diagnose.candidate import NONE
from robolobe.diagnose.fitting import CandidateFit
from robolobe.diagnose.library import Untestable
from robolobe.diagnose.locate import MismatchMap
from robolobe.diagnose.residuals import FitMetrics
from robolobe.diagnose.selection import Selection

__all__ = ["describe_fit", "summarize"]


def _pm(fit: CandidateFit, name: str, fmt: str = ".3g", scale: float = 1.0) -> str:
    i = [p.name for p in fit.candidate.params].index(name)
    v = fit.params[i] * scale
    s = fit.std[i] * scale
    if np.isfinite(s):
        return f"{v:{fmt}} ± {s:.2g}"
    return f"{v:{fmt}}"


def describe_fit(fit: CandidateFit) -> str:
    """One phrase saying what the fitted candidate means physically."""
    c = fit.candidate
    fx = c.fixed
    if c.name == "added_mass":
        return f"an extra {_pm(fit, 'mass_kg')} kg at the tool"
    if c.name == "joint_stiffness":
        return f"joint {fx['joint']} is {_pm(fit, 'factor', '.3f')} times as stiff as modelled"
    if c.name == "joint_damping":
        return f"joint {fx['joint']} has {_pm(fit, 'factor', '.3f')} times the modelled damping"
    if c.name == "gravity_stiffening":
        return (
            "joint stiffness rises with the gravity load "
            f"(beta {_pm(fit, 'beta')} per {fx['tau_ref_Nm']:.0e} N m of gravity torque)"
        )
    if c.name == "coupled_joint_stiffness":
        i, j = fx["joints"]
        return f"joints {i} and {j} are coupled by {_pm(fit, 'k_coupling_Nm_per_rad')} N m/rad"
    if c.name == "base_compliance":
        return f"the base is compliant (tilt stiffness {_pm(fit, 'stiffness_Nm_per_rad')} N m/rad)"
    if c.name == "tool_mode":
        return (
            f"a local tool/spindle mode at {_pm(fit, 'f_hz', '.2f')} Hz along {fx['direction']} "
            f"(damping {_pm(fit, 'zeta', '.3f')}, modal mass {_pm(fit, 'mass_kg')} kg)"
        )
    if c.name == "sensor_misalignment":
        deg = 180.0 / np.pi
        return (
            "the sensor axes are rotated by "
            f"rx {_pm(fit, 'rx_rad', '.2f', deg)}, ry {_pm(fit, 'ry_rad', '.2f', deg)}, "
            f"rz {_pm(fit, 'rz_rad', '.2f', deg)} deg"
        )
    if c.name == "sensor_delay":
        return f"the response channel lags the force by {_pm(fit, 'delay_s', '.3f', 1e3)} ms"
    if c.name == "link_flexibility":
        ax = "xyz"[int(np.argmax(fx["axis"]))]
        return (
            f"link {fx['link']} bends about its {ax} axis "
            f"(stiffness {_pm(fit, 'stiffness_Nm_per_rad')} N m/rad)"
        )
    if c.name == "friction_damping":
        return (
            f"joint friction of {_pm(fit, 'torque_Nm')} N m makes the damping fall "
            "as the hammer force rises"
        )
    return c.description


def summarize(
    sel: Selection,
    before: FitMetrics,
    after: FitMetrics,
    mm: MismatchMap,
    untestable: Sequence[Untestable],
) -> str:
    """The diagnosis in a few sentences.

    Parameters
    ----------
    sel : Selection
    before, after : FitMetrics
        Nominal and corrected (held-out) fit.
    mm : MismatchMap
    untestable : sequence of Untestable
    """
    fit_txt = (
        f"held-out FRAC {before.frac_mean:.2f} -> {after.frac_mean:.2f} "
        f"(worst posture {before.frac_min:.2f} -> {after.frac_min:.2f}), "
        f"NRMSE {before.nrmse_mean:.2f} -> {after.nrmse_mean:.2f}"
    )
    parts: list[str] = []
    v = sel.verdict
    if v.fit.candidate.name != NONE:
        parts.append(f"The recordings show {describe_fit(v.fit)} ({v.label}); {fit_txt}.")
        if v.explained < 0.7:
            parts.append(
                f"It explains {v.explained:.0%} of the mismatch beyond the noise: "
                "more may be missing."
            )
        if sel.runner_up is not None:
            parts.append(
                f"A close alternative is {sel.runner_up.label}: {describe_fit(sel.runner_up.fit)}."
            )
        notes = [n for n in v.fit.notes if "bound" in n or "poorly" in n or "correlated" in n]
        if notes:
            parts.append("Note: " + "; ".join(notes) + ".")
    else:
        score = sel.baseline.fit.deviance / max(sel.baseline.fit.n_resid, 1)
        best = next((r for r in sel.ranking if r.fit.candidate.name != NONE), None)
        if score < 1.5:
            parts.append(
                "The nominal model fits the recordings within the noise "
                f"(mismatch {score:.2f} noise variances per point; FRAC {before.frac_mean:.2f}); "
                "no candidate is needed."
            )
            if best is not None and best.delta_bic > 0 and best.gain is not None and best.gain > 0:
                parts.append(
                    f"The closest candidate, {best.label}, improves the held-out fit by only "
                    f"{best.gain:.3g} noise variances per point ({'; '.join(best.reasons)})."
                )
        else:
            parts.append(
                f"The nominal model misses the recordings ({score:.1f} noise variances per point, "
                f"FRAC {before.frac_mean:.2f}) but no candidate explains it"
                + (f" (best: {best.label}, {'; '.join(best.reasons)})" if best else "")
                + "."
            )
        worst = sorted(mm.bands, key=lambda b: -b.score)[:2]
        if worst and score >= 1.5:
            parts.append(
                "Largest mismatch: "
                + ", ".join(f"{b.direction} {b.f_lo_hz:g}-{b.f_hi_hz:g} Hz" for b in worst)
                + "."
            )
    if untestable:
        parts.append(
            "Not tested: " + "; ".join(f"{u.label} ({u.reason})" for u in untestable) + "."
        )
    return " ".join(parts)
