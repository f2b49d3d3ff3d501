"""The diagnosis from end to end: locate, fit every candidate, select, explain.

Usage::

    from robolobe.diagnose import diagnose
    result = diagnose("campaigns/B_2024_05")      # or a Campaign object
    print(result.summary)                         # plain language
    result.verdict                                # "added_mass", ..., or "none"

Steps (each in its own module):

1. read the campaign and the robot it names; quality checks; put the FRFs on
   one grid in the analysis band (:mod:`~robolobe.diagnose.campaign_data`);
   estimate the noise (:mod:`~robolobe.diagnose.noise`);
2. nominal FRFs of every posture and the mismatch map and per-mode tables
   (:mod:`~robolobe.diagnose.locate`);
3. fit every testable candidate of the library (:mod:`~robolobe.diagnose.library`)
   to all postures at once on a decimated grid (:mod:`~robolobe.diagnose.fitting`);
4. rank by BIC, cross-validate the best over postures, name one or ``none``
   (:mod:`~robolobe.diagnose.selection`);
5. FRAC/NRMSE before (nominal) and after (held-out predictions of the
   verdict), a plain-language summary, and the updated model.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from robolobe._threads import one_blas_thread
from robolobe.campaign import Campaign, read_campaign
from robolobe.diagnose.campaign_data import campaign_observations
from robolobe.diagnose.candidate import NONE
from robolobe.diagnose.fitting import CandidateFit, fit_candidate
from robolobe.diagnose.forward import ForwardResult, ForwardSettings, forward_select
from robolobe.diagnose.library import Untestable, build_library
from robolobe.diagnose.locate import MismatchMap, ModePair, mismatch_map, pair_modes, recorded_peaks
from robolobe.diagnose.observations import Observations
from robolobe.diagnose.residuals import FitMetrics, fit_metrics
from robolobe.diagnose.selection import Selection, SelectionSettings
from robolobe.diagnose.summary import summarize
from robolobe.diagnose.twin_model import TwinModel, twin_modes
from robolobe.errors import InputError
from robolobe.modal.quality import QualityIssue
from robolobe.robots import Robot, load_robot
from robolobe.robots.limits import check_posture, within_limits
from robolobe.twin.effects import Effect

__all__ = ["DiagnoseSettings", "Diagnosis", "diagnose"]

log = logging.getLogger(__name__)

Progress = Callable[[str, int, int], None]


@dataclass(frozen=True)
class DiagnoseSettings:
    """Settings of :func:`diagnose`.

    Parameters
    ----------
    band_hz : (float, float) or None
        Analysis band [Hz]; None (default): the whole recorded band from
        1 Hz up to 80 % of its highest line, below the anti-aliasing filter
        (stated in the summary). Candidates' ranges (a tool mode's
        frequency) follow the band.
    max_fit_lines : int
        Frequency lines used by the fits (the band is decimated to this,
        evenly in log frequency).
    noise_floor : float
        Lower bound of the relative noise (model-form tolerance).
    families : tuple of str or None
        Candidate families to test (None: all).
    window_decay_per_s : float or None
        Exponential-window decay of the recordings [1/s]; None: from the
        campaign's ``[test]`` table.
    n_starts : int
        Local fits per candidate (from the best grid points).
    max_nfev : int
        Residual evaluations per local fit.
    selection : SelectionSettings
    forward : ForwardSettings
        Forward selection of several candidates and the absolute noise test.
    n_jobs : int
        Worker processes for each round's candidate fits (1: in this
        process; -1: all cores); the diagnosis is the same either way
        (to round-off).
    """

    band_hz: tuple[float, float] | None = None
    max_fit_lines: int = 240
    noise_floor: float = 0.01
    families: tuple[str, ...] | None = None
    window_decay_per_s: float | None = None
    n_starts: int = 2
    max_nfev: int = 30
    selection: SelectionSettings = field(default_factory=SelectionSettings)
    forward: ForwardSettings = field(default_factory=ForwardSettings)
    n_jobs: int = 1


@dataclass(frozen=True, eq=False)
class Diagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    verdict : str
        ``"none"`` (the file fits within the noise), the family names of the
        named candidates joined by ``+`` (``"file_parameters+tool_mode"``),
        ``"unexplained"`` (the best model found still misses the held-out
        postures by more than 1.5 x the noise on average, or one direction
        in one 5 Hz band by more than 6 x; the candidates are then only
        the closest ones, see ``forward.steps``), or ``"ambiguous"`` (the
        model fits, but a step has an other-family alternative about as good:
        ``forward.steps[i].alternatives``; only unambiguous steps are in
        :attr:`named`).
    selection : Selection
        Round-1 ranking with scores (every candidate on the nominal model).
    fits : tuple of CandidateFit
        Every fitted candidate (round 1).
    forward : ForwardResult
        The named steps, their shares, the stop reason and the noise test.
    untestable : tuple of Untestable
        Candidates the data cannot test, and why.
    quality : tuple of QualityIssue
        Data-quality findings.
    mismatch : MismatchMap
        Where the nominal model misses.
    modes_before, modes_after : tuple of ModePair
        Nominal and corrected modes paired with the recorded peaks.
    fit_before, fit_after : FitMetrics
        Nominal, and held-out predictions of the verdict.
    obs : Observations
        The recordings on the analysis grid.
    H_nominal, H_after : ndarray, shape (n, n_freq, 3, 3)
        Nominal and held-out corrected receptance.
    robot : Robot
    effects : tuple of Effect
        The verdict's effects at the parameters fitted to all postures.
    window_decay_per_s : float
    summary : str
        Plain-language conclusion.
    campaign : str
        Where the data came from.
    elapsed_s : float
        Wall time of the diagnosis.
    settings : DiagnoseSettings
        The settings used.
    """

    verdict: str
    selection: Selection
    fits: tuple[CandidateFit, ...]
    forward: ForwardResult
    untestable: tuple[Untestable, ...]
    quality: tuple[QualityIssue, ...]
    mismatch: MismatchMap
    modes_before: tuple[ModePair, ...]
    modes_after: tuple[ModePair, ...]
    fit_before: FitMetrics
    fit_after: FitMetrics
    obs: Observations
    H_nominal: NDArray[np.complex128]
    H_after: NDArray[np.complex128]
    robot: Robot
    effects: tuple[Effect, ...]
    window_decay_per_s: float
    summary: str
    campaign: str
    elapsed_s: float
    settings: DiagnoseSettings = field(default_factory=DiagnoseSettings)

    @property
    def winner(self) -> CandidateFit:
        """Joint fit of the named candidates (the ``none`` fit if nothing was named)."""
        return self.forward.model_fit

    @property
    def named(self) -> tuple[str, ...]:
        """Family names of the candidates presented as found (empty if none or unexplained)."""
        if self.forward.noise.unexplained:
            return ()
        return tuple(s.candidate.name for s in self.forward.steps if not s.ambiguous)

    @property
    def unexplained(self) -> bool:
        """Whether the held-out misfit stays above the noise limit."""
        return self.forward.noise.unexplained


def _mode_table(
    model: TwinModel,
    effects: tuple[Effect, ...],
    obs: Observations,
    peaks: list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    band: tuple[float, float],
) -> tuple[ModePair, ...]:
    """Model modes of each posture paired with the recorded peaks."""
    f_all, z_all, sh_all = twin_modes(model.twin(effects), obs.q_rad)
    rows: list[ModePair] = []
    for k in range(obs.n):
        ok = np.isfinite(f_all[k])
        f, z, shp = f_all[k, ok], z_all[k, ok], sh_all[k, ok]
        # visible modes: in the band, with a driving-point peak >= 2 % of the largest
        meas = obs.dir_mask[k].diagonal()
        peak = np.max(np.where(meas, shp**2, 0.0), axis=1) / np.maximum(
            2 * z * (2 * np.pi * f) ** 2, 1e-30
        )
        vis = (f >= band[0]) & (f <= band[1]) & (peak >= 0.02 * peak.max(initial=0.0))
        fm, zm, sm = peaks[k]
        rows.extend(
            pair_modes(
                obs.record_ids[k],
                f[vis],
                z[vis],
                np.where(meas, shp, 0.0)[vis],
                fm,
                zm,
                np.nan_to_num(sm),
            )
        )
    return tuple(rows)


def diagnose(
    campaign: Campaign | str | os.PathLike[str],
    *,
    robot: Robot | None = None,
    settings: DiagnoseSettings | None = None,
    force_N: NDArray[np.float64] | None = None,
    progress: Progress | None = None,
) -> Diagnosis:
    """Diagnose the mismatch between a campaign and its nominal robot model.

    Parameters
    ----------
    campaign : Campaign or path
        A campaign folder (docs/guide/campaign.md) or a campaign read already.
    robot : Robot, optional
        The nominal robot; default the one the campaign names.
    settings : DiagnoseSettings, optional
    force_N : ndarray, shape (n,), optional
        Hammer force level of each posture [N]; default the campaign's
        ``force_N`` (the ``postures.csv`` column).
    progress : callable, optional
        ``progress(stage, done, total)`` for a progress display.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        Missing robot file, postures outside limits, unusable FRFs (naming
        the file and what was expected).
    """
    # the fits' matrices are small or tall and thin: threaded BLAS only adds contention
    # (a 52000 x 19 product took 3 s instead of 0.03 s on a loaded 2-core machine)
    with one_blas_thread():
        return _diagnose(
            campaign, robot=robot, settings=settings, force_N=force_N, progress=progress
        )


def _diagnose(
    campaign: Campaign | str | os.PathLike[str],
    *,
    robot: Robot | None,
    settings: DiagnoseSettings | None,
    force_N: NDArray[np.float64] | None,
    progress: Progress | None,
) -> Diagnosis:
    t0 = time.perf_counter()
    st = settings or DiagnoseSettings()
    source = "<campaign>"
    if not isinstance(campaign, Campaign):
        source = os.fspath(campaign)
        folder = Path(campaign)
        # limits are checked below: postures outside them are left out, not fatal
        camp = read_campaign(folder, check_limits=False)
    else:
        camp = campaign
    if force_N is None:
        force_N = camp.force_N
    if robot is None:
        try:
            robot = load_robot(camp.robot)
        except InputError as exc:
            raise InputError(
                f"robot {camp.robot!r}: {exc}", source="campaign.toml[robot]"
            ) from None
    extra_issues: list[QualityIssue] = []
    bad = ~np.asarray(within_limits(robot, camp.q_rad), dtype=bool).reshape(-1)
    if bad.any():
        keep = np.flatnonzero(~bad)
        if keep.size < 2:
            for b in np.flatnonzero(bad):
                check_posture(
                    robot, camp.q_rad[b], posture_id=camp.posture_ids[b], source="postures.csv"
                )
        for b in np.flatnonzero(bad):
            try:
                check_posture(
                    robot, camp.q_rad[b], posture_id=camp.posture_ids[b], source="postures.csv"
                )
            except InputError as exc:
                msg = str(exc)
            else:  # pragma: no cover - within_limits and check_posture agree
                msg = "outside the robot's joint limits"
            extra_issues.append(
                QualityIssue(camp.posture_ids[b], "*", "limits", "error", f"left out: {msg}")
            )
        camp = dataclasses.replace(
            camp,
            posture_ids=tuple(camp.posture_ids[i] for i in keep),
            q_rad=camp.q_rad[keep],
            frfs=tuple(camp.frfs[i] for i in keep),
        )
        if force_N is not None:
            force_N = np.asarray(force_N)[keep]
    obs, decay, issues = campaign_observations(
        camp,
        band_hz=st.band_hz,
        window_decay_per_s=st.window_decay_per_s,
        force_N=force_N,
        noise_floor=st.noise_floor,
    )
    issues = extra_issues + issues
    if len(obs.groups) < 2:
        raise InputError(
            f"expected at least 2 postures to cross-validate a diagnosis, found {len(obs.groups)}",
            source="postures.csv",
        )
    # More folds than postures (the default 5 on a small campaign, or postures left out
    # above) is leave-one-posture-out: make_folds takes one fold per posture.
    model = TwinModel(robot, window_decay_per_s=decay)
    obs_fit = obs.decimated(st.max_fit_lines)
    H_nom = model((), obs)
    mm = mismatch_map(H_nom, obs)

    cands, untestable = build_library(
        robot,
        directions=obs.directions,
        n_force_levels=obs.force_levels_N.size,
        band_hz=(float(obs.freq_hz[0]), float(obs.freq_hz[-1])),
        families=st.families,
    )
    fw = forward_select(
        cands,
        model,
        obs_fit,
        obs,
        selection=st.selection,
        settings=st.forward,
        fit=partial(fit_candidate, n_starts=st.n_starts, max_nfev=st.max_nfev),
        progress=progress,
        n_jobs=st.n_jobs,
    )
    sel = fw.rounds[0]
    H_after = fw.cv.H
    effects = fw.effects
    before = fit_metrics(H_nom, obs)
    after = fit_metrics(H_after, obs)
    peaks = recorded_peaks(obs, window_decay_per_s=decay)
    band = (float(obs.freq_hz[0]), float(obs.freq_hz[-1]))
    modes_before = _mode_table(model, (), obs, peaks, band)
    modes_after = modes_before if not effects else _mode_table(model, effects, obs, peaks, band)
    if fw.noise.unexplained:
        verdict = "unexplained"
    elif fw.ambiguous:
        verdict = "ambiguous"
    elif fw.steps:
        verdict = "+".join(s.candidate.name for s in fw.steps)
    else:
        verdict = NONE
    summary = summarize(fw, before, after, mm, untestable, band, issues)
    return Diagnosis(
        verdict=verdict,
        selection=sel,
        fits=fw.fits,
        forward=fw,
        untestable=tuple(untestable),
        quality=tuple(issues),
        mismatch=mm,
        modes_before=modes_before,
        modes_after=modes_after,
        fit_before=before,
        fit_after=after,
        obs=obs,
        H_nominal=H_nom,
        H_after=H_after,
        robot=robot,
        effects=effects,
        window_decay_per_s=decay,
        summary=summary,
        campaign=source,
        elapsed_s=time.perf_counter() - t0,
        settings=st,
    )
