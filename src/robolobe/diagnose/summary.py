"""Plain-language conclusion of a diagnosis."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from robolobe.diagnose.calibration import CALIBRATION, moved_parameters
from robolobe.diagnose.candidate import NONE
from robolobe.diagnose.fitting import CandidateFit
from robolobe.diagnose.forward import ForwardResult, NoiseTest
from robolobe.diagnose.library import Untestable
from robolobe.diagnose.locate import MismatchMap
from robolobe.diagnose.residuals import FitMetrics
from robolobe.modal.quality import QualityIssue

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
    if c.name == CALIBRATION:
        moved = moved_parameters(
            tuple(p.name for p in c.params), np.asarray(fit.params), np.asarray(fit.std)
        )
        what = ", ".join(f"{n} x{v:.3f} ± {sd:.2g}" for n, v, sd in moved[:6])
        more = f" and {len(moved) - 6} more" if len(moved) > 6 else ""
        return "the robot file's values are off" + (
            f" ({what}{more})" if moved else " (no single factor determined)"
        )
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
        held = " (its mass already in the file's end effector)" if fx.get("mass_in_file") else ""
        return (
            f"a local tool/spindle mode{held} at {_pm(fit, 'f_hz', '.2f')} Hz "
            f"along {fx['direction']} "
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
    if c.name == "servo_mode":
        return (
            f"joint {fx['joint']}'s servo holds it with {_pm(fit, 'stiffness_Nm_per_rad')} N m/rad "
            f"(damping {_pm(fit, 'zeta', '.3f')}, rotor {_pm(fit, 'rotor_inertia_kgm2')} kg m^2): "
            "a holding mode"
        )
    if c.name == "tcp_offset":
        return (
            "the tested point is offset from the file's TCP by "
            f"({_pm(fit, 'dx_m', '.3f', 1e3)}, {_pm(fit, 'dy_m', '.3f', 1e3)}, "
            f"{_pm(fit, 'dz_m', '.3f', 1e3)}) mm in the TCP frame"
        )
    if c.name == "sensor_gain":
        return "the response channel gains are off: " + ", ".join(
            f"{p.name[1]} x{_pm(fit, p.name, '.3f')}" for p in c.params
        )
    if c.name == "hammer_direction":
        deg = 180.0 / np.pi
        hit = c.fixed.get("hit", "")
        return (
            (f"the hammer's {hit} hits are off axis by " if hit else "the hammer hits off axis by ")
            + ", ".join(f"{p.name[:2]} {_pm(fit, p.name, '.2f', deg)}" for p in c.params)
            + " deg"
        )
    if c.name == "friction_damping":
        return (
            f"joint friction of {_pm(fit, 'torque_Nm')} N m makes the damping fall "
            "as the hammer force rises"
        )
    return c.description


def _x(per_residual: float) -> float:
    """RMS residual in noise deviations from a deviance per residual."""
    return float(np.sqrt(max(per_residual, 0.0)))


def _pct(share: float) -> str:
    """A share in percent, never rounded to a bare "0 %" or "100 %" when it is not."""
    pc = 100.0 * share
    if 0.0 < pc < 0.1:
        return "< 0.1 %"
    if 99.9 < pc < 100.0:
        return "> 99.9 %"
    if pc < 10.0 or pc > 90.0:
        return f"{pc:.1f} %"
    return f"{pc:.0f} %"


def _shares(fw: ForwardResult) -> str:
    """Each step's share of the explained misfit, with the misfit before and after it.

    A small effect next to a large one has a small share of the explained
    misfit while taking the rest of it down to the noise; the misfits say so.
    """
    if len(fw.steps) < 2:
        return ""
    parts = []
    prev = fw.baseline_cv.per_residual
    for st in fw.steps:
        parts.append(
            f"{st.label} {_pct(st.share)}, {_x(prev):.1f} -> {_x(st.per_residual):.1f} x the noise"
        )
        prev = st.per_residual
    head = " (shares of the explained held-out misfit, in the order taken: "
    return head + "; ".join(parts) + ")"


def _where(nt: NoiseTest) -> str:
    posts = ", ".join(f"{p} ({x:.1f} x)" for p, x in nt.worst_postures)
    bands = ", ".join(f"{b.direction} {b.f_lo_hz:g}-{b.f_hi_hz:g} Hz" for b in nt.worst_bands)
    return f"at postures {posts}" + (f" and bands {bands}" if bands else "")


def _calibration_effect(fw: ForwardResult) -> str:
    """What calibrating the file achieves, against the nominal file (named as a step, or not)."""
    base = _x(fw.baseline_cv.per_residual)
    cal = next(
        (r for r in fw.rounds[0].ranking if r.fit.candidate.name == CALIBRATION and r.cv), None
    )
    alone = _x(cal.cv.per_residual) if cal is not None and cal.cv is not None else None
    for i, st in enumerate(fw.steps):
        if st.candidate.name != CALIBRATION:
            continue
        if i == 0:
            what = f"lowers the held-out misfit from {base:.1f} to {_x(st.per_residual):.1f} x"
        else:
            earlier = ", ".join(s.label for s in fw.steps[:i])
            what = (
                f"on top of {earlier} lowers the held-out misfit from "
                f"{_x(fw.steps[i - 1].per_residual):.1f} to {_x(st.per_residual):.1f} x"
            )
            what += f" the noise (the nominal file misses by {base:.1f} x"
            what += f"; calibrating alone: {alone:.1f} x)" if alone is not None else ")"
            return f"The robot file is globally off: calibrating its values {what}."
        return f"The robot file is globally off: calibrating its values {what} the noise."
    if alone is None:
        return ""
    if alone < base:
        what = f"lowers the held-out misfit from {base:.1f} to {alone:.1f} x the noise"
    else:
        what = f"does not lower the held-out misfit ({base:.1f} -> {alone:.1f} x the noise)"
    off = "The robot file is globally off" if base > 2.0 else "The robot file fits"
    return f"{off}: calibrating its values alone {what}."


def summarize(
    fw: ForwardResult,
    before: FitMetrics,
    after: FitMetrics,
    mm: MismatchMap,
    untestable: Sequence[Untestable],
    band_hz: tuple[float, float],
    issues: Sequence[QualityIssue] = (),
) -> str:
    """The diagnosis in a few sentences.

    Parameters
    ----------
    fw : ForwardResult
        Named steps and the noise test.
    before, after : FitMetrics
        Nominal and corrected (held-out) fit.
    mm : MismatchMap
        Where the nominal model misses.
    untestable : sequence of Untestable
    band_hz : (float, float)
        The analysed band [Hz].
    issues : sequence of QualityIssue
        Data-quality findings (warnings and left-out data are repeated here).
    """
    nt = fw.noise
    fit_txt = (
        f"held-out FRAC {before.frac_mean:.2f} -> {after.frac_mean:.2f} "
        f"(worst posture {before.frac_min:.2f} -> {after.frac_min:.2f}), "
        f"NRMSE {before.nrmse_mean:.3f} -> {after.nrmse_mean:.3f} "
        f"(the noise alone: {nt.nrmse_noise:.3f})"
    )
    parts: list[str] = [f"Analysed {band_hz[0]:g}-{band_hz[1]:g} Hz."]
    base_x = float(np.sqrt(max(fw.baseline_cv.per_residual, 0.0)))
    if nt.unexplained:
        parts.append(
            f"UNEXPLAINED: the best model found still misses the held-out postures by "
            f"{nt.misfit_x_noise:.1f} x the noise (NRMSE {nt.nrmse_x_noise:.1f} x the noise's; "
            f"the worst band {nt.band_misfit_x_noise:.1f} x) "
            f"{_where(nt)}; nothing in the library explains the recordings."
        )
        if fw.steps:
            parts.append(
                "Closest candidates (partial corrections, not a diagnosis): "
                + "; ".join(f"{describe_fit(st.fit)} ({st.label})" for st in fw.steps)
                + _shares(fw)
                + f"; {fit_txt}."
            )
        else:
            close = [r for r in fw.rounds[0].ranking if r.fit.candidate.name != NONE and r.gain][:3]
            parts.append(
                f"The nominal model misses by {base_x:.1f} x the noise; closest candidates: "
                + (
                    ", ".join(f"{r.label} ({'; '.join(r.reasons) or 'passed'})" for r in close)
                    if close
                    else "none improves the held-out fit"
                )
                + "."
            )
        cal = _calibration_effect(fw)
        if cal:
            parts.append(cal)
    elif fw.steps:
        sure = [st for st in fw.steps if not st.ambiguous]
        amb = [st for st in fw.steps if st.ambiguous]
        if amb:
            parts.append(
                "AMBIGUOUS: "
                + "; ".join(
                    f"{st.label} and {', '.join(st.alternatives)} explain the recordings "
                    "about equally well"
                    for st in amb
                )
                + " (the data do not tell them apart; none of them is claimed)."
            )
        parts.append(
            ("Found: " if sure else "Model used for the corrected predictions: ")
            + "; ".join(f"{describe_fit(st.fit)} ({st.label})" for st in (sure or amb))
            + _shares(fw)
            + f". The corrected model predicts held-out postures within the noise "
            f"(misfit {nt.misfit_x_noise:.1f} x the noise, was {base_x:.1f} x); {fit_txt}."
        )
        cal = _calibration_effect(fw)
        if cal:
            parts.append(cal)
    else:
        parts.append(
            "The nominal model fits the recordings within the noise "
            f"(held-out misfit {nt.misfit_x_noise:.1f} x the noise; FRAC {before.frac_mean:.2f}); "
            "no candidate is needed."
        )
        best = next((r for r in fw.rounds[0].ranking if r.fit.candidate.name != NONE), None)
        if best is not None and best.gain is not None and best.gain > 0:
            parts.append(
                f"The closest candidate, {best.label}, improves the held-out fit by only "
                f"{best.gain:.3g} noise variances per point ({'; '.join(best.reasons)})."
            )
    bound = [
        f"{st.candidate.params[i].name} of {st.label} ({st.params[i]:.4g})"
        for st in fw.steps
        for i, b in enumerate(st.at_bound)
        if b
    ]
    if bound:
        parts.append(
            "On a search bound (a limit of the search, not a measured value): "
            + "; ".join(bound)
            + "."
        )
    if fw.rejected:
        parts.append("Not added: " + "; ".join(fw.rejected) + ".")
    if nt.unexplained or not fw.steps:
        worst = sorted(mm.bands, key=lambda b: -b.score)[:2]
        if worst and base_x > 1.2:
            parts.append(
                "Largest nominal mismatch: "
                + ", ".join(f"{b.direction} {b.f_lo_hz:g}-{b.f_hi_hz:g} Hz" for b in worst)
                + "."
            )
    warn = [q for q in issues if q.severity in ("warning", "error")]
    if warn:
        shown = "; ".join(f"{q.posture_id} {q.dir} {q.check}: {q.message}" for q in warn[:4])
        more = f" (and {len(warn) - 4} more)" if len(warn) > 4 else ""
        parts.append(f"Data warnings: {shown}{more}.")
    if untestable:
        parts.append(
            "Not tested: " + "; ".join(f"{u.label} ({u.reason})" for u in untestable) + "."
        )
    return " ".join(parts)
