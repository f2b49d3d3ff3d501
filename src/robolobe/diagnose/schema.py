"""The JSON a diagnosis writes (``robolobe diagnose CAMPAIGN --json OUT.json``).

``format = "robolobe-diagnosis/1"``. Top-level keys:

- ``verdict``: ``none``, the named families joined by ``+``
  (``file_parameters+tool_mode``), ``unexplained`` or ``ambiguous``; ``verdict_label`` adds
  the variants; ``unexplained``: whether the best model still misses the
  held-out postures by more than twice the noise (then ``steps`` are only
  the closest candidates); ``steps``: the named candidates in order with
  parameters (standard deviations include the remaining misfit and the
  spread over the folds), held-out gain and share of the explained misfit;
  ``noise_test``: held-out misfit and NRMSE against the noise, worst
  postures and bands; ``parameters``: all steps' parameters;
- ``summary``: the conclusion in plain language;
- ``candidates``: every tested candidate, ranked (``rank`` 1 is best), with
  its scores (``bic``, ``delta_bic`` against none, held-out ``gain`` in noise
  variances per residual, ``posture_share``, ``explained``), parameters,
  identifiability and why it was not named;
- ``untestable``: candidates the data cannot test, with the reason;
- ``fit_before`` / ``fit_after``: mean and minimum FRAC and mean NRMSE over
  held-out postures (driving points), plus per-posture values;
- ``mismatch``: the located mismatch (per-direction signatures, worst bands);
- ``quality``: data-quality findings; ``modes``: paired nominal and recorded
  modes per posture (before and after);
- ``noise``, ``band_hz``, ``window_decay_per_s``, ``elapsed_s``, ...
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from robolobe.diagnose.fitting import CandidateFit
from robolobe.diagnose.locate import ModePair
from robolobe.diagnose.pipeline import Diagnosis
from robolobe.diagnose.residuals import FitMetrics
from robolobe.diagnose.selection import Ranked

__all__ = ["DiagnosisReport", "to_report"]

FORMAT = "robolobe-diagnosis/1"


def _f(x: Any) -> float | None:
    """JSON-safe float (None for NaN/inf)."""
    v = float(x)
    return v if math.isfinite(v) else None


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ParamOut(_Model):
    """A fitted parameter."""

    name: str
    value: float
    std: float | None = Field(description="standard deviation, same unit; null if undetermined")
    lower: float
    upper: float
    at_bound: bool


class CandidateOut(_Model):
    """One ranked candidate."""

    rank: int
    name: str
    variant: str
    label: str
    description: str
    params: list[ParamOut]
    deviance_per_residual: float
    bic: float
    aic: float
    delta_bic: float = Field(description="BIC(none) - BIC: positive is better than none")
    gain: float | None = Field(
        description="held-out deviance drop per residual vs none (noise variances); "
        "null if not cross-validated"
    )
    posture_share: float | None
    explained: float = Field(description="share of the nominal model's excess deviance removed")
    identifiable: bool
    condition_number: float | None
    notes: list[str]
    named: bool = Field(description="whether this is the verdict")
    passed: bool
    reasons: list[str] = Field(description="why it could not be named (empty if it passed)")


class UntestableOut(_Model):
    """A candidate the data cannot test."""

    name: str
    variant: str
    reason: str


class FitOut(_Model):
    """FRAC/NRMSE over postures (driving points)."""

    frac_mean: float | None
    frac_min: float | None
    nrmse_mean: float | None
    by_posture: dict[str, dict[str, float | None]]


class DirectionOut(_Model):
    """Mismatch signature of one direction."""

    direction: str
    score: float | None
    level_offset: float | None
    delay_ms: float | None
    delay_std_ms: float | None


class BandOut(_Model):
    """Mismatch of one direction in one band."""

    direction: str
    f_lo_hz: float
    f_hi_hz: float
    score: float | None
    worst_posture: str
    worst_score: float | None


class MismatchOut(_Model):
    """The located mismatch (scores in noise variances per point; 1 = at the noise)."""

    overall_score: float | None
    directions: list[DirectionOut]
    worst_bands: list[BandOut]
    by_posture: dict[str, float | None]
    cross_ratio: dict[str, float | None]


class ModeOut(_Model):
    """A row of a per-mode table."""

    posture: str
    status: str
    f_nom_hz: float | None
    zeta_nom: float | None
    f_meas_hz: float | None
    zeta_meas: float | None
    df_pct: float | None
    mac: float | None


class QualityOut(_Model):
    """A data-quality finding."""

    posture: str
    dir: str
    check: str
    severity: str
    message: str


class StepOut(_Model):
    """One candidate named by the forward selection (a closest one if unexplained)."""

    name: str
    label: str
    description: str
    params: list[ParamOut]
    gain: float | None = Field(description="held-out deviance drop per point [noise variances]")
    share: float = Field(description="share of the explained held-out misfit (0..1)")
    misfit_x_noise_after: float | None
    alternatives: list[str] = Field(
        default_factory=list,
        description="other-family candidates about as good (non-empty: ambiguous, not claimed)",
    )


class NoiseTestOut(_Model):
    """The chosen model's held-out misfit against the noise."""

    misfit_x_noise: float | None = Field(description="RMS held-out residual / noise")
    nrmse_x_noise: float | None = Field(description="held-out NRMSE / the noise's NRMSE")
    nrmse_noise: float | None
    limit: float
    unexplained: bool
    worst_postures: dict[str, float | None]
    worst_bands: list[str]


class DiagnosisReport(_Model):
    """Everything ``robolobe diagnose`` writes to JSON."""

    format: str = FORMAT
    campaign: str
    robot: str
    verdict: str
    verdict_label: str
    unexplained: bool
    summary: str
    steps: list[StepOut]
    noise_test: NoiseTestOut
    stop_reason: str
    parameters: list[ParamOut]
    runner_up: str | None
    candidates: list[CandidateOut]
    untestable: list[UntestableOut]
    fit_before: FitOut
    fit_after: FitOut
    mismatch: MismatchOut
    modes_before: list[ModeOut]
    modes_after: list[ModeOut]
    quality: list[QualityOut]
    n_postures: int
    n_records: int
    directions: list[str]
    band_hz: tuple[float, float]
    window_decay_per_s: float
    noise: dict[str, float]
    thresholds: dict[str, float] = Field(
        description="conditions for naming a candidate (robolobe.diagnose.selection)"
    )
    elapsed_s: float


def _params(fit: CandidateFit) -> list[ParamOut]:
    return [
        ParamOut(
            name=p.name,
            value=float(v),
            std=_f(s),
            lower=p.lower,
            upper=p.upper,
            at_bound=b,
        )
        for p, v, s, b in zip(fit.candidate.params, fit.params, fit.std, fit.at_bound, strict=True)
    ]


def _cand(r: Ranked, named: bool) -> CandidateOut:
    f = r.fit
    return CandidateOut(
        rank=r.rank,
        name=f.candidate.name,
        variant=f.candidate.variant,
        label=f.candidate.label,
        description=f.candidate.description,
        params=_params(f),
        deviance_per_residual=f.deviance / max(f.n_resid, 1),
        bic=f.bic,
        aic=f.aic,
        delta_bic=r.delta_bic,
        gain=None if r.gain is None else _f(r.gain),
        posture_share=r.posture_share,
        explained=r.explained,
        identifiable=f.identifiable,
        condition_number=_f(f.cond),
        notes=list(f.notes),
        named=named,
        passed=r.passed,
        reasons=list(r.reasons),
    )


def _fit(m: FitMetrics, ids: tuple[str, ...]) -> FitOut:
    return FitOut(
        frac_mean=_f(m.frac_mean),
        frac_min=_f(m.frac_min),
        nrmse_mean=_f(m.nrmse_mean),
        by_posture={
            pid: {"frac": _f(a), "nrmse": _f(b)}
            for pid, a, b in zip(ids, m.frac, m.nrmse, strict=True)
        },
    )


def _modes(rows: tuple[ModePair, ...]) -> list[ModeOut]:
    return [
        ModeOut(
            posture=r.record,
            status=r.status,
            f_nom_hz=_f(r.f_nom_hz),
            zeta_nom=_f(r.zeta_nom),
            f_meas_hz=_f(r.f_meas_hz),
            zeta_meas=_f(r.zeta_meas),
            df_pct=_f(r.df_pct) if r.status == "paired" else None,
            mac=_f(r.mac),
        )
        for r in rows
    ]


def to_report(d: Diagnosis) -> DiagnosisReport:
    """The JSON model of a diagnosis."""
    sel = d.selection
    obs = d.obs
    mm = d.mismatch
    worst = sorted(mm.bands, key=lambda b: -b.score)[:8]
    sig = obs.sigma[obs.mask]
    fw = d.forward
    nt = fw.noise
    return DiagnosisReport(
        campaign=d.campaign,
        robot=d.robot.source,
        verdict=d.verdict,
        verdict_label=(
            ("unexplained; closest: " if nt.unexplained else "")
            + ("ambiguous; " if d.verdict == "ambiguous" else "")
            + (" + ".join(st.label for st in fw.steps) or "none")
        ),
        unexplained=nt.unexplained,
        summary=d.summary,
        steps=[
            StepOut(
                name=st.candidate.name,
                label=st.label,
                description=st.candidate.description,
                params=_params(st.fit),
                gain=_f(st.gain),
                share=st.share,
                misfit_x_noise_after=_f(math.sqrt(max(st.per_residual, 0.0))),
                alternatives=list(st.alternatives),
            )
            for st in fw.steps
        ],
        noise_test=NoiseTestOut(
            misfit_x_noise=_f(nt.misfit_x_noise),
            nrmse_x_noise=_f(nt.nrmse_x_noise),
            nrmse_noise=_f(nt.nrmse_noise),
            limit=nt.limit,
            unexplained=nt.unexplained,
            worst_postures={p: _f(v) for p, v in nt.worst_postures},
            worst_bands=[f"{b.direction} {b.f_lo_hz:g}-{b.f_hi_hz:g} Hz" for b in nt.worst_bands],
        ),
        stop_reason=fw.stop_reason,
        parameters=[p for st in fw.steps for p in _params(st.fit)],
        runner_up=None if sel.runner_up is None else sel.runner_up.label,
        candidates=[_cand(r, r is sel.verdict and not nt.unexplained) for r in sel.ranking],
        untestable=[
            UntestableOut(name=u.name, variant=u.variant, reason=u.reason) for u in d.untestable
        ],
        fit_before=_fit(d.fit_before, obs.record_ids),
        fit_after=_fit(d.fit_after, obs.record_ids),
        mismatch=MismatchOut(
            overall_score=_f(mm.overall),
            directions=[
                DirectionOut(
                    direction=s.direction,
                    score=_f(s.score),
                    level_offset=_f(s.level_offset),
                    delay_ms=_f(1e3 * s.delay_s),
                    delay_std_ms=_f(1e3 * s.delay_std_s),
                )
                for s in mm.directions
            ],
            worst_bands=[
                BandOut(
                    direction=b.direction,
                    f_lo_hz=b.f_lo_hz,
                    f_hi_hz=b.f_hi_hz,
                    score=_f(b.score),
                    worst_posture=b.worst_record,
                    worst_score=_f(b.worst_score),
                )
                for b in worst
            ],
            by_posture={p: _f(v) for p, v in zip(mm.record_ids, mm.record_score, strict=True)},
            cross_ratio={p: _f(v) for p, v in zip(mm.record_ids, mm.cross_ratio, strict=True)},
        ),
        modes_before=_modes(d.modes_before),
        modes_after=_modes(d.modes_after),
        quality=[
            QualityOut(
                posture=q.posture_id,
                dir=q.dir,
                check=q.check,
                severity=q.severity,
                message=q.message,
            )
            for q in d.quality
        ],
        n_postures=len(obs.groups),
        n_records=obs.n,
        directions=list(obs.directions),
        band_hz=(float(obs.freq_hz[0]), float(obs.freq_hz[-1])),
        window_decay_per_s=d.window_decay_per_s,
        noise={
            "median_relative": float(np.median(sig)),
            "p90_relative": float(np.percentile(sig, 90)),
            "line_correlation_inflation": obs.inflation,
        },
        thresholds={
            "min_delta_bic": d.settings.selection.min_delta_bic,
            "min_gain": d.settings.selection.min_gain,
            "min_posture_share": d.settings.selection.min_posture_share,
            "n_folds": float(d.settings.selection.n_folds),
            "noise_floor": d.settings.noise_floor,
        },
        elapsed_s=d.elapsed_s,
    )
