"""Campaigns with a concealed effect, and the study that checks the diagnosis on them.

A concealed campaign is what a test lab would hand over: simulated hammer
tests (:func:`robolobe.twin.hammer.simulate_hammer_test`, the seed's test:
1024 Hz, 4 s, 5 impacts, exponential window, noise on both channels) of the
twin *with* an effect, written as an ordinary campaign that names only the
nominal robot. The diagnosis is then run without being told the effect.

Friction campaigns repeat every posture at several hammer force levels
(``force_N`` column of ``postures.csv``); all other campaigns use one level.

:func:`run_study` runs many cases (robots x effects x magnitudes plus null
campaigns) and :func:`study_tables` summarises them: confusion matrix,
detection rate per effect and magnitude, false discoveries on nulls, and
FRAC before/after. ``studies/diagnose_concealed.py`` is the full study;
the slow test runs a small one.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.diagnose.candidate import NONE
from robolobe.diagnose.pipeline import DiagnoseSettings, Diagnosis, diagnose
from robolobe.diagnose.twin_model import windowed_receptance
from robolobe.errors import InputError
from robolobe.robots import Robot, load_robot
from robolobe.twin.campaign import Campaign, PostureFRF, write_campaign
from robolobe.twin.designs import TESTED_RANGES_DEG, space_filling_design
from robolobe.twin.effects import Effect, FrictionDamping
from robolobe.twin.hammer import HammerTestSettings, simulate_hammer_test
from robolobe.twin.model import Twin

__all__ = [
    "Case",
    "CaseResult",
    "make_concealed_campaign",
    "results_frame",
    "run_case",
    "run_study",
    "standard_cases",
    "study_tables",
    "write_concealed_campaign",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Case:
    """One concealed campaign of a study.

    Parameters
    ----------
    robot : str
        ``"A"``, ``"B"``, ``"C"`` or a robot file path.
    effect : Effect or None
        The concealed effect (None: a null campaign).
    magnitude : str
        Label of the magnitude (``"small"``, ``"medium"``, ``"large"``, ``"null"``).
    n_postures : int
        Postures of the campaign.
    seed : int
        Seed of the design and of the test noise.
    force_levels_N : tuple of float
        Hammer force levels (several for friction campaigns).
    noise : float
        Test noise as a multiple of the default (:class:`HammerTestSettings`).
    """

    robot: str
    effect: Effect | None
    magnitude: str
    n_postures: int = 30
    seed: int = 0
    force_levels_N: tuple[float, ...] = (300.0,)
    noise: float = 1.0

    @property
    def truth(self) -> str:
        """Family name of the concealed effect (``none`` for null campaigns)."""
        return self.effect.name if self.effect is not None else NONE

    @property
    def robot_label(self) -> str:
        """Short robot label for tables."""
        return self.robot if self.robot in ("A", "B", "C") else Path(self.robot).stem


def _ranges(robot: str) -> tuple[tuple[float, float], ...] | None:
    return TESTED_RANGES_DEG.get(robot)


def make_concealed_campaign(
    case: Case, *, settings: HammerTestSettings | None = None
) -> tuple[Campaign, np.ndarray | None]:
    """Simulate the hammer campaign of ``case``.

    Parameters
    ----------
    case : Case
    settings : HammerTestSettings, optional
        Test settings (default: the seed's test, :class:`HammerTestSettings`).

    Returns
    -------
    campaign : Campaign
        Names only the nominal robot; ``test`` records the window.
    force_N : ndarray, shape (n,), or None
        Force level per posture (None for a single level).
    """
    rng = np.random.default_rng(case.seed)
    robot = load_robot(case.robot)
    design = space_filling_design(robot, case.n_postures, rng, ranges_deg=_ranges(case.robot))
    ids0 = list(design["posture_id"])
    q0 = np.radians(design[[f"q{i}_deg" for i in range(1, 7)]].to_numpy(dtype=float))
    s = settings or HammerTestSettings()
    s = s.replace(
        force_noise_n=s.force_noise_n * case.noise,
        accel_noise_m_per_s2=s.accel_noise_m_per_s2 * case.noise,
    )
    effects = () if case.effect is None else (case.effect,)
    ids: list[str] = []
    qs: list[np.ndarray] = []
    frfs: list[PostureFRF] = []
    forces: list[float] = []
    multi = len(case.force_levels_N) > 1
    for level in case.force_levels_N:
        eff = tuple(
            dataclasses.replace(e, force_N=float(level)) if isinstance(e, FrictionDamping) else e
            for e in effects
        )
        twin = Twin(robot, eff)
        # the twin's receptance by modal superposition (exact, faster on the fine grid)
        res = simulate_hammer_test(
            windowed_receptance(twin, q0, s.fine_freq_hz),
            rng=rng,
            settings=s.replace(force_peak_n=float(level)),
        )
        for k, pid in enumerate(ids0):
            ids.append(f"{pid}_F{level:g}" if multi else pid)
            qs.append(q0[k])
            frfs.append(PostureFRF(res.freq_hz, res.H1[k]))
            forces.append(float(level))
    camp = Campaign(
        robot=case.robot,
        posture_ids=tuple(ids),
        q_rad=np.array(qs),
        frfs=tuple(frfs),
        notes="simulated hammer test (robolobe.diagnose.concealed)",
        test={
            "sample_rate_hz": s.sample_rate_hz,
            "duration_s": s.duration_s,
            "impacts": s.impacts,
            "window_end": s.window_end,
        },
    )
    return camp, (np.array(forces) if multi else None)


def write_concealed_campaign(
    case: Case, path: str | os.PathLike[str], *, settings: HammerTestSettings | None = None
) -> Path:
    """Write the campaign of ``case`` as a folder (force levels in ``postures.csv``).

    Returns
    -------
    Path
        The folder.
    """
    camp, force = make_concealed_campaign(case, settings=settings)
    out = write_campaign(path, camp)
    if force is not None:
        from robolobe.twin.campaign import write_postures

        write_postures(
            out / "postures.csv", camp.posture_ids, camp.q_rad, extra={"force_N": force.tolist()}
        )
    return out


@dataclass(frozen=True)
class CaseResult:
    """Outcome of one case.

    Parameters
    ----------
    case : Case
    verdict : str
        Family named by the diagnosis.
    verdict_label : str
        Family and variant.
    frac_before, frac_after, frac_min_after : float
        Held-out FRAC of the nominal and of the corrected model (mean, min).
    nrmse_before, nrmse_after : float
    seconds : float
        Diagnosis wall time.
    params : dict
        Fitted parameters of the verdict.
    gain : float
        Held-out gain of the best-ranked candidate other than ``none``
        (noise variances per residual; the margin to the threshold).
    best_label : str
        That candidate.
    mismatch : float
        Nominal deviance per residual (1: the nominal model is at the noise).
    """

    case: Case
    verdict: str
    verdict_label: str
    frac_before: float
    frac_after: float
    frac_min_after: float
    nrmse_before: float
    nrmse_after: float
    seconds: float
    params: dict[str, float]
    gain: float = float("nan")
    best_label: str = ""
    mismatch: float = float("nan")

    @property
    def correct(self) -> bool:
        """Whether the diagnosis named the concealed family."""
        return self.verdict == self.case.truth


def run_case(
    case: Case, *, settings: DiagnoseSettings | None = None
) -> tuple[CaseResult, Diagnosis]:
    """Simulate and diagnose one case."""
    camp, force = make_concealed_campaign(case)
    robot: Robot = load_robot(case.robot)
    t0 = time.perf_counter()
    d = diagnose(camp, robot=robot, settings=settings, force_N=force)
    w = d.winner
    best = next((r for r in d.selection.ranking if r.fit.candidate.name != NONE), None)
    res = CaseResult(
        case=case,
        verdict=d.verdict,
        verdict_label=w.candidate.label,
        frac_before=d.fit_before.frac_mean,
        frac_after=d.fit_after.frac_mean,
        frac_min_after=d.fit_after.frac_min,
        nrmse_before=d.fit_before.nrmse_mean,
        nrmse_after=d.fit_after.nrmse_mean,
        seconds=time.perf_counter() - t0,
        params={p.name: float(v) for p, v in zip(w.candidate.params, w.params, strict=True)},
        gain=float(best.gain) if best is not None and best.gain is not None else float("nan"),
        best_label=best.label if best is not None else "",
        mismatch=d.selection.baseline.fit.deviance / max(d.selection.baseline.fit.n_resid, 1),
    )
    return res, d


def standard_cases(
    robots: Sequence[str],
    *,
    n_postures: int = 30,
    seeds: Sequence[int] = (0,),
    magnitudes: Sequence[str] = ("small", "medium", "large"),
    n_null: int = 2,
    families: Sequence[str] | None = None,
    noise: float = 1.0,
) -> list[Case]:
    """Cases for every robot: each effect at the given magnitudes plus null campaigns.

    Magnitudes are realistic (REFERENCES.md section 6 and common lab
    experience): e.g. an added 2/5/12 kg at the tool, a joint stiffness off by
    10/20/35 %, a 1/2/4 deg rotated sensor, a 1/2/4 ms channel delay.

    Parameters
    ----------
    robots : sequence of str
        ``"A"``, ``"B"``, ``"C"`` or robot file paths.
    n_postures : int
    seeds : sequence of int
        One case per seed for each robot, effect and magnitude.
    magnitudes : sequence of str
        Subset of small, medium, large.
    n_null : int
        Null campaigns per robot and seed (every second one at three hammer
        force levels).
    families : sequence of str, optional
        Effect families to include (default all).
    noise : float
        Test noise as a multiple of the default.
    """
    deg = np.pi / 180.0
    table: dict[str, dict[str, Callable[[Robot], Effect]]] = {
        "added_mass": {
            "small": lambda r: _e("added_mass", mass_kg=2.0),
            "medium": lambda r: _e("added_mass", mass_kg=5.0),
            "large": lambda r: _e("added_mass", mass_kg=12.0),
        },
        "joint_stiffness": {
            "small": lambda r: _e("joint_stiffness", joint=2, factor=0.88),
            "medium": lambda r: _e("joint_stiffness", joint=3, factor=0.8),
            "large": lambda r: _e("joint_stiffness", joint=5, factor=0.65),
        },
        "joint_damping": {
            "small": lambda r: _e("joint_damping", joint=2, factor=1.6),
            "medium": lambda r: _e("joint_damping", joint=1, factor=2.0),
            "large": lambda r: _e("joint_damping", joint=3, factor=3.0),
        },
        "gravity_stiffening": {
            "small": lambda r: _e("gravity_stiffening", beta=0.15),
            "medium": lambda r: _e("gravity_stiffening", beta=0.3),
            "large": lambda r: _e("gravity_stiffening", beta=0.6),
        },
        "coupled_joint_stiffness": {
            "small": lambda r: _e("coupled_joint_stiffness", k_coupling_Nm_per_rad=_k23(r, 0.15)),
            "medium": lambda r: _e("coupled_joint_stiffness", k_coupling_Nm_per_rad=_k23(r, 0.3)),
            "large": lambda r: _e("coupled_joint_stiffness", k_coupling_Nm_per_rad=_k23(r, -0.45)),
        },
        "base_compliance": {
            "small": lambda r: _e("base_compliance", stiffness_Nm_per_rad=3e8),
            "medium": lambda r: _e("base_compliance", stiffness_Nm_per_rad=1e8),
            "large": lambda r: _e("base_compliance", stiffness_Nm_per_rad=4e7),
        },
        "tool_mode": {
            "small": lambda r: _e("tool_mode", f_hz=31.0, zeta=0.03, mass_kg=3.0, direction="y"),
            "medium": lambda r: _e("tool_mode", f_hz=24.0, zeta=0.02, mass_kg=5.0, direction="x"),
            "large": lambda r: _e("tool_mode", f_hz=18.0, zeta=0.03, mass_kg=10.0, direction="xyz"),
        },
        "sensor_misalignment": {
            "small": lambda r: _e("sensor_misalignment", rz_rad=1.0 * deg),
            "medium": lambda r: _e("sensor_misalignment", rx_rad=1.5 * deg, rz_rad=1.5 * deg),
            "large": lambda r: _e("sensor_misalignment", ry_rad=4.0 * deg),
        },
        "sensor_delay": {
            "small": lambda r: _e("sensor_delay", delay_s=0.001),
            "medium": lambda r: _e("sensor_delay", delay_s=0.002),
            "large": lambda r: _e("sensor_delay", delay_s=0.004),
        },
        "link_flexibility": {
            "small": lambda r: _e("link_flexibility", link=3, stiffness_Nm_per_rad=_klink(r, 3.0)),
            "medium": lambda r: _e(
                "link_flexibility",
                link=2,
                axis=(0.0, 1.0, 0.0),
                stiffness_Nm_per_rad=_klink(r, 1.5),
            ),
            "large": lambda r: _e("link_flexibility", link=3, stiffness_Nm_per_rad=_klink(r, 0.8)),
        },
        "friction_damping": {
            "small": lambda r: _e("friction_damping", torque_Nm=20.0),
            "medium": lambda r: _e("friction_damping", torque_Nm=50.0),
            "large": lambda r: _e("friction_damping", torque_Nm=120.0),
        },
    }
    fams = list(table) if families is None else list(families)
    cases: list[Case] = []
    for rb in robots:
        robot = load_robot(rb)
        for seed in seeds:
            for fam in fams:
                if fam not in table:
                    raise InputError(f"family: expected one of {sorted(table)}, found {fam!r}")
                for mag in magnitudes:
                    eff = table[fam][mag](robot)
                    levels = (100.0, 300.0, 900.0) if fam == "friction_damping" else (300.0,)
                    cases.append(Case(rb, eff, mag, n_postures, seed, levels, noise))
            for k in range(n_null):
                # every second null campaign is a friction test (3 force levels), so that
                # friction_damping is tested on nulls too
                levels = (100.0, 300.0, 900.0) if k % 2 == 1 else (300.0,)
                cases.append(
                    Case(rb, None, "null", n_postures, 1000 * (k + 1) + seed, levels, noise)
                )
    return cases


def _e(name: str, **kw: object) -> Effect:
    from robolobe.twin.effects import effect_from_dict

    return effect_from_dict({"name": name, **kw})


def _k23(robot: Robot, frac: float) -> float:
    return float(frac * np.sqrt(robot.stiffness[1] * robot.stiffness[2]))


def _klink(robot: Robot, mult: float) -> float:
    """A link-bending stiffness ``mult`` times the robot's joint-3 stiffness."""
    return float(mult * robot.stiffness[2])


def run_study(
    cases: Sequence[Case],
    *,
    settings: DiagnoseSettings | None = None,
    progress: Callable[[int, int, CaseResult], None] | None = None,
) -> list[CaseResult]:
    """Diagnose every case (sequentially; each case is independent).

    Parameters
    ----------
    cases : sequence of Case
    settings : DiagnoseSettings, optional
    progress : callable, optional
        ``progress(done, total, result)`` after each case.
    """
    out = []
    for i, c in enumerate(cases):
        r, _ = run_case(c, settings=settings)
        out.append(r)
        if progress is not None:
            progress(i + 1, len(cases), r)
    return out


def results_frame(results: Sequence[CaseResult]) -> pd.DataFrame:
    """One row per case (what ``studies/diagnose_concealed.py`` writes to ``cases.csv``)."""
    return pd.DataFrame(
        [
            {
                "robot": r.case.robot_label,
                "truth": r.case.truth,
                "magnitude": r.case.magnitude,
                "seed": r.case.seed,
                "noise": r.case.noise,
                "verdict": r.verdict,
                "verdict_label": r.verdict_label,
                "correct": r.correct,
                "frac_before": r.frac_before,
                "frac_after": r.frac_after,
                "frac_min_after": r.frac_min_after,
                "nrmse_before": r.nrmse_before,
                "nrmse_after": r.nrmse_after,
                "mismatch": r.mismatch,
                "best_other": r.best_label,
                "gain": r.gain,
                "seconds": r.seconds,
                "params": ";".join(f"{k}={v:.4g}" for k, v in r.params.items()),
            }
            for r in results
        ]
    )


def study_tables(results: Sequence[CaseResult] | pd.DataFrame) -> dict[str, pd.DataFrame]:
    """Summary tables of a study.

    Parameters
    ----------
    results : sequence of CaseResult, or the frame of :func:`results_frame`

    Returns
    -------
    dict of DataFrame
        ``cases`` (one row per case), ``confusion`` (truth x verdict counts),
        ``detection`` (rate per effect and magnitude), ``nulls`` (false
        discoveries per robot), ``fit`` (FRAC/NRMSE before and after per
        effect, effect campaigns named correctly).
    """
    df = results if isinstance(results, pd.DataFrame) else results_frame(results)
    if df.empty:
        return {"cases": df}
    df = df.assign(correct=df["correct"].astype(bool))
    confusion = pd.crosstab(df["truth"], df["verdict"])
    eff = df[df["truth"] != NONE]
    detection = (
        eff.pivot_table(index="truth", columns="magnitude", values="correct", aggfunc="mean")
        if not eff.empty
        else pd.DataFrame()
    )
    nul = df[df["truth"] == NONE]
    nulls = (
        nul.groupby("robot").agg(
            campaigns=("verdict", "size"), false_discoveries=("correct", lambda s: int((~s).sum()))
        )
        if not nul.empty
        else pd.DataFrame()
    )
    ok = eff[eff["correct"]]
    fit = (
        ok.groupby("truth")[
            ["frac_before", "frac_after", "frac_min_after", "nrmse_before", "nrmse_after"]
        ].mean()
        if not ok.empty
        else pd.DataFrame()
    )
    return {"cases": df, "confusion": confusion, "detection": detection, "nulls": nulls, "fit": fit}
