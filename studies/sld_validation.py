"""Validation table of the stability-lobe solvers (REFERENCES.md section 3).

Prints computed values next to the references: directional factors, the
1-DOF and 2-DOF zero-order minima, semi-discretization (SDM) against ZOA for
slotting, half immersion and low immersion, and the up/down symmetry; then
the converged lobes (:func:`robolobe.sld.converged_lobes`) against the tests'
independent textbook ZOA (``tests/sld/zoa_reference.py``) on the cases of
``tests/sld/test_converged.py`` (robot modes with a tool mode, overdamped
robot modes) and the bundled plans' stated limits at every cutting waypoint
(``tests/plan/test_converged_plans.py``). About 75 s of CPU. Usage:
``python studies/sld_validation.py [--plans pocket,contour,face]`` (from the
repository root; ``--plans`` names the bundled plans checked, all by default).

Reference system (Insperger, Mann, Stepan & Bayly 2003; REFERENCES.md): N = 2,
Kt = 6e8 N/m^2, Kn = 2e8 N/m^2, f_n = 922 Hz, zeta = 0.011,
k = m (2 pi f_n)^2 with m = 0.03993 kg.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from robolobe.sld import (
    CuttingConditions,
    Material,
    ModalModel,
    critical_depth,
    directional_factors,
    engagement_angles,
    sdm_lobes,
    stability_lobes,
)

N, KT, KR = 2, 6e8, 2e8 / 6e8
F_N, ZETA = 922.0, 0.011
K = 0.03993 * (2 * math.pi * F_N) ** 2
MAT = Material("reference", KT, KR)
X1 = ModalModel.from_directional([F_N], [ZETA], [K], ["xx"])
ISO = ModalModel.isotropic([F_N], [ZETA], [K])


def row(what: str, got: float, ref: str, note: str) -> None:
    print(f"{what:48s} {got:>12.6g} {ref:>12s}  {note}")


def zoa_min(model: ModalModel, immersion: float, milling: str = "down") -> tuple[float, object]:
    alpha = directional_factors(*engagement_angles(immersion, milling), KR)
    crit = critical_depth(model, alpha, teeth=N, kt=KT)
    return float(crit.depth), crit


def sdm_min(model: ModalModel, cond: CuttingConditions, rpm: np.ndarray, m: int = 40) -> float:
    return float(
        sdm_lobes(
            model, teeth=N, kt=KT, kr=KR, conditions=cond, rpm=rpm, intervals=m, rtol=2e-5
        ).a_lim.min()
    )


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--plans",
        default="pocket,contour,face",
        help="Comma-separated bundled plans whose stated a_lim_mm are checked.",
    )
    plans = [p for p in ap.parse_args(argv).plans.split(",") if p]
    print(f"{'quantity':48s} {'computed':>12s} {'reference':>12s}  note")
    slot = directional_factors(0.0, math.pi, KR)
    err = np.abs(slot - [[-KR * math.pi, -math.pi], [math.pi, -KR * math.pi]]).max()
    row("slot alphas, max |error|", err, "0", "[-Kr pi, -pi, pi, -Kr pi]")
    half = directional_factors(*engagement_angles(0.5, "down"), KR)
    want = [[1 - KR * math.pi / 2, -math.pi / 2 + KR], [math.pi / 2 + KR, -1 - KR * math.pi / 2]]
    row("half-immersion down alphas, max |error|", np.abs(half - want).max(), "0", "closed form")
    for imm, ref in [(1.0, 0.298054), (0.5, 0.64091), (0.1, 0.99944), (0.05, 1.79158)]:
        a, _ = zoa_min(X1, imm)
        row(
            f"1-DOF (x) ZOA min, a/D={imm:g} down [mm]",
            a * 1e3,
            f"{ref:g}",
            f"rel {a * 1e3 / ref - 1:+.1e}",
        )
    a_iso, crit = zoa_min(ISO, 1.0)
    row(
        "2-DOF isotropic slot ZOA min [mm]",
        a_iso * 1e3,
        "0.047925",
        f"rel {a_iso * 1e3 / 0.047925 - 1:+.1e}",
    )
    slot_c = CuttingConditions.from_immersion(1.0, "down")
    for k in (0, 1, 2):
        n0 = float(crit.rpm(k))
        a = sdm_min(ISO, slot_c, n0 * np.linspace(0.985, 1.015, 11))
        row(
            f"2-DOF slot SDM lobe {k} min (m=40) [mm]",
            a * 1e3,
            "within 0.5%",
            f"SDM/ZOA - 1 = {a / a_iso - 1:+.2%} near {n0:.0f} rpm",
        )
    rpm = np.array([float(crit.rpm(1))])
    vals = [
        float(
            sdm_lobes(
                ISO, teeth=N, kt=KT, kr=KR, conditions=slot_c, rpm=rpm, intervals=m, rtol=1e-7
            ).a_lim[0]
        )
        for m in (20, 30, 40)
    ]
    lim = (1600 * vals[2] - 900 * vals[1]) / 700
    row("SDM m=40 vs Richardson limit (m=30,40)", vals[2] / lim - 1, "< 3e-3", "relative")
    for model, name in ((ISO, "2-DOF"), (X1, "1-DOF x")):
        a_z, c = zoa_min(model, 0.5)
        a_s = sdm_min(
            model,
            CuttingConditions.from_immersion(0.5, "down"),
            float(c.rpm(1)) * np.linspace(0.95, 1.05, 21),
        )
        row(
            f"{name} a/D=0.5 down: ZOA min / SDM lobe-1 min",
            a_z / a_s,
            "~1.07-1.15",
            "documented ZOA error at half immersion",
        )
    a1_z, c1 = zoa_min(X1, 1.0)
    a1_s = sdm_min(X1, slot_c, float(c1.rpm(1)) * np.linspace(0.95, 1.05, 21))
    row("1-DOF x slot: ZOA min / SDM lobe-1 min", a1_z / a1_s, "0.94-1.003", "documented -6%/+0.3%")
    for imm in (0.1, 0.05):
        cond = CuttingConditions.from_immersion(imm, "down")
        a_z, _ = zoa_min(ISO, imm)
        a_s = sdm_min(ISO, cond, np.linspace(55000.0, 58000.0, 13), m=30)
        row(
            f"2-DOF a/D={imm:g} down: ZOA min / SDM flip-lobe min",
            a_z / a_s,
            ">= 1.3",
            "ZOA misses the period-doubling lobe",
        )
    rpm = np.linspace(8000, 60000, 500)
    res = {}
    for model, name in ((ISO, "2-DOF"), (X1, "1-DOF x")):
        for mill in ("up", "down"):
            res[name, mill] = stability_lobes(
                model,
                cutter=N,
                material=MAT,
                rpm=rpm,
                conditions=CuttingConditions.from_immersion(0.3, mill),
            ).a_lim
        up, down = res[name, "up"], res[name, "down"]
        ok = np.isfinite(up) & np.isfinite(down)
        row(
            f"{name} a/D=0.3: max |up/down - 1|",
            np.abs(up[ok] / down[ok] - 1).max(),
            "0" if name == "2-DOF" else "> 0",
            "identical only for isotropic 2-DOF",
        )
    converged(plans)


def converged(plans: list[str]) -> None:
    """Converged lobes / reference ZOA at every speed, the cases of tests/sld/test_converged.py."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from tests.sld.test_converged import _ratio, _robot_and_tool
    from tests.sld.zoa_reference import alphas, reference_envelope

    from robolobe.sld import converged_lobes, zoa_lobes

    print(f"\n{'converged lobes / reference ZOA, every speed':48s} {'min':>12s} {'max':>12s}  note")
    f, z, res = _robot_and_tool()
    al = alphas(0.0, math.pi / 2, 0.3)
    rpm = np.linspace(1000.0, 30000.0, 300)
    ref = reference_envelope(f, z, res, al, teeth=3, kt=7e8, rpm=rpm)
    model = ModalModel(2 * np.pi * f, z, res)
    r = _ratio(converged_lobes(model, al, teeth=3, kt=7e8, rpm=rpm).a_lim, ref)
    w = model.frequency_grid()
    fixed = zoa_lobes(w, model.frf(w), alpha=al, teeth=3, kt=7e8, rpm=rpm, max_lobe=None)
    print(
        f"{'robot 12/25 Hz + tool 1.5 kHz, 1,000-30,000 rpm':48s} {r.min():12.6f} {r.max():12.6f}"
        f"  fixed grid: max {_ratio(fixed.a_lim, ref).max():.3f}"
    )
    for zeta in (0.6, 1.0, 2.5):
        z2 = z.copy()
        z2[0] = zeta
        al2 = alphas(0.0, math.pi, 0.3)
        rpm2 = np.linspace(600.0, 24000.0, 80)
        ref2 = reference_envelope(f, z2, res, al2, teeth=2, kt=7e8, rpm=rpm2)
        got = converged_lobes(ModalModel(2 * np.pi * f, z2, res), al2, teeth=2, kt=7e8, rpm=rpm2)
        r2 = _ratio(got.a_lim, ref2)
        print(
            f"{f'robot mode 12 Hz with zeta {zeta:g}, slot':48s} {r2.min():12.6f} {r2.max():12.6f}"
        )
    # the bundled plans' stated a_lim_mm at every cutting waypoint (tests/plan/test_converged_plans)
    from tests.plan.test_converged_plans import PLANS, _ratios

    unknown = sorted(set(plans) - set(PLANS))
    if unknown:
        sys.exit(f"--plans: expected names from {', '.join(PLANS)}, found {', '.join(unknown)}")
    for name in plans:
        path, job = PLANS[name]
        r3, _ = _ratios(name, every=1)
        what = f"{name} on {job[4]}, {r3.size} waypoints (stated a_lim_mm)"
        print(f"{what:48s} {r3.min():12.6f} {r3.max():12.6f}  {path}, {job}, at the planned rpm")


if __name__ == "__main__":
    main()
