"""More than one thing wrong: forward selection of candidates, and the test against the noise.

Round 1 is the one-candidate selection of :func:`robolobe.diagnose.selection.select`
over the whole library (the file calibration included). If it names a
candidate, that candidate joins the model and round 2 fits every remaining
candidate *on top of it* (the earlier ones fixed at their fit), selects
again, and so on. Round 2 fits the whole remaining library: how well a
candidate fits the nominal model says nothing about how it fits on top of a
large effect (next to a 24 Hz tool mode that puts the nominal model at 15x
the noise, a gravity stiffening ranked 40th of 46 by round-1 BIC, below
``none``, and a screen by the round-1 ranking never tried it again). Later
rounds fit the ``screen_k`` candidates best by the previous round's BIC
(on top of all but the latest step), the file calibration and ``none``.
Fixed earlier steps hide an effect they have partly
absorbed (the file calibration's stiffness factors take up part of a
gravity stiffening, and the gravity term on top of them then gains too
little), so from round 2 on the round's winner and the next
``joint_k`` candidates best by BIC on top are refitted *jointly* with the
earlier steps (all parameters free, warm-started), and the one with the
lowest joint BIC is the round's candidate (its own parameters must be
determined in the joint fit). The ``joint_k`` candidates best by round-1
BIC (on the nominal model) are refitted jointly too, started at their
round-1 fit: an effect the earlier steps absorbed gains little on top of
them (on robot D, +3 kg at the tool next to an axis-1 servo drive: the
calibrated spindle and link masses took up the mass, the added mass gained
a tenth of a TCP offset on top, and a 12 mm TCP offset was named in its
place, a wrong family). Each accepted step is cross-validated over
postures with every parameter refitted in each fold: a step is kept only if
this joint model lowers the held-out deviance per residual by at least
``min_gain`` noise variances against the previous step, and a later step
by at least ``min_share`` of the previous step's held-out excess over the
noise (it must remove most of what is left, not mop up a residue), so a
second effect is named only when it beats the noise on postures the fit did
not see. (The share is of what is left, not of the nominal model's excess:
against a 31 Hz tool mode that puts the nominal model at 13x the noise, a
gravity stiffening that takes the rest from 1.15x down to the noise was
refused by a share of the nominal excess.) When two effects are left, each
removes only part of what is left: a step that beats ``min_gain`` but not
the share, with a round to spare, is taken *on trial* and kept only if the
next step's joint model, with it, removes the share the trial step needed
(and the next step gains ``min_gain`` itself); otherwise the model goes back
to the one before the trial step. (On the independent generator's robot D,
+3 kg at the tool with an axis-1 servo drive: the file calibration took
round 1 with its axis-1 factors on their bounds, mimicking the drive; the
drive on top removed 2.04 of the 4.16 noise variances left, under the
half, and the search stopped, `unexplained`.) The search stops when a round
names nothing, when the held-out misfit is at the noise, or after
``max_effects`` effects (the file calibration is a correction of the file,
not an effect, and takes no place: on the independent generator's robot D a
TCP offset with two hammer directions off, in a file 10 % off, needs three
effects and the calibration, and a limit of three steps left it
``unexplained`` at 5x the noise).

A step is *ambiguous* when a candidate of another family explains the
data about as well: in round 1 the selection's runner-up (held-out gain
within ``ambiguity`` of the winner's), later a candidate of the joint pool
whose joint fit comes within ``ambiguity_bic`` (10) of the step's. The
corrected model keeps the step (its predictions are as good either way) but
neither family is claimed: on the independent generator's robot B at 12
postures, a 4 kg point mass at the tool was named "file calibration + TCP
offset" (the calibrated spindle mass plus a shifted measuring point mimic
it) at 1.2x the noise, a wrong family presented as found. Families a file
calibration holds by design (joint stiffness, damping) are not alternatives
to it.

Each named effect gets its *share* of the explained misfit: the held-out
deviance drop of its step over the drop of all steps (attribution in the
order the steps were taken).

The absolute test (:func:`noise_test`) then compares the chosen model's
held-out misfit with the noise: the RMS held-out residual in noise standard
deviations (``sqrt(D_cv / N)``) and the mean held-out NRMSE over the NRMSE the
noise alone gives (:func:`robolobe.diagnose.residuals.noise_nrmse`). If
either exceeds ``max_misfit_x_noise`` (1.5) the recordings are *unexplained*:
(a claim is false, by the issue's measure, when the misfit stays above 2x
the noise; the margin keeps a library candidate that only mimics physics
outside the library from being presented as found)
the diagnosis says so, where (postures and bands), and presents the
candidates only as the closest ones.

The averages alone are no test of a claim: most of the band lies far from
any mode, where a calibrated file predicts within the stated model-form
tolerance (1 %) and the misfit is nearly zero, and a model that misses the
lowest modes badly still averages under the limit. (On the independent
generator's robot B, damping that grows with the gravity load was named
"file off" at 1.5x the noise on average while the held-out prediction
missed 5-10 Hz by 11-15 noise deviations RMS in every direction: 2.5x the
*true* noise, a false claim.) So the recordings are also *unexplained* when
one direction in one 5 Hz band misses by more than ``max_band_misfit_x_noise``
(6) noise deviations RMS over all postures. Noise alone does not do that:
a band's mean over ~12 postures x 20 lines scatters by ~10 %; what a correct
model reads there is set by the noise estimate's local error: on the
independent study's null and correct claims (robots B and D, 12 postures)
the worst band read 3.2-3.5x, on a later fresh set up to 4.2x (cross
directions at anti-resonances and near the top of the band, where the
roughness estimate reads 0.4-0.6x the true noise); the limit is 1.4-1.9x
these (the false claim above read 15x).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe._workers import map_chunks
from robolobe.diagnose.calibration import CALIBRATION, FileParameters
from robolobe.diagnose.candidate import NONE, Candidate
from robolobe.diagnose.fitting import REL_STD_MAX, CandidateFit, ModelFn, fit_candidate
from robolobe.diagnose.locate import BandScore, mismatch_map
from robolobe.diagnose.observations import Observations
from robolobe.diagnose.residuals import fit_metrics, noise_nrmse
from robolobe.diagnose.selection import (
    CrossValidation,
    Selection,
    SelectionSettings,
    cross_validate,
    make_folds,
    select,
)

__all__ = [
    "ForwardResult",
    "ForwardSettings",
    "NoiseTest",
    "Step",
    "combine",
    "forward_select",
    "noise_test",
]

#: Families a calibrated file already holds (not searched after the calibration).
SUBSUMED_BY_CALIBRATION = ("joint_stiffness", "joint_damping")


@dataclass(frozen=True)
class ForwardSettings:
    """Settings of :func:`forward_select`.

    Parameters
    ----------
    max_effects : int
        Most named candidates besides the file calibration.
    min_share : float
        Least held-out deviance drop of a later step, as a share of the
        previous step's held-out excess over the noise (per residual, over 1).
    at_noise : float
        RMS held-out residual (noise deviations) at which the search stops
        (0: it goes on until a round names nothing; a campaign's noise floor
        lies below 1, at 0.7-0.9 in the study, and a fixed level of 1.0
        stopped a calibrated file at 0.86x on robot C before its gravity
        stiffening was tried).
    screen_k : int
        Candidates refitted in rounds after the second: those best by BIC in
        the previous round (and the file calibration; round 2 fits all).
    max_misfit_x_noise : float
        Above this held-out misfit (either measure) the recordings are unexplained.
    max_band_misfit_x_noise : float
        Above this held-out RMS misfit of one direction in one 5 Hz band (over
        all postures, in noise deviations) the recordings are unexplained.
    joint_max_nfev : int
        Evaluations of the joint refit of each step.
    joint_k : int
        Candidates besides a round's winner refitted jointly with the earlier
        steps (rounds after the first; module notes).
    ambiguity_bic : float
        A candidate of another family whose joint fit comes within this BIC
        of the step's (or, in round 1, the selection's runner-up of another
        family) makes the step *ambiguous*: both explain the recordings and
        the data do not tell them apart, so neither is claimed (module notes).
    """

    max_effects: int = 3
    ambiguity_bic: float = 10.0
    min_share: float = 0.5
    at_noise: float = 0.0
    screen_k: int = 12
    max_misfit_x_noise: float = 1.5
    max_band_misfit_x_noise: float = 6.0
    joint_max_nfev: int = 30
    joint_k: int = 2


def combine(cands: Sequence[Candidate]) -> Candidate:
    """One candidate with the parameters of ``cands`` in order (effects concatenated).

    A file calibration's effect is put first, so that later robot-level
    effects (an added mass) act on the calibrated file.
    """
    sizes = [c.n_params for c in cands]
    cuts = np.cumsum([0, *sizes])

    def build(p: NDArray[np.float64]) -> tuple[Any, ...]:
        eff: list[Any] = []
        for c, a, b in zip(cands, cuts[:-1], cuts[1:], strict=True):
            eff += list(c.effects(p[a:b]))
        return tuple(sorted(eff, key=lambda e: not isinstance(e, FileParameters)))

    return Candidate(
        "+".join(c.name for c in cands),
        tuple(p for c in cands for p in c.params),
        build,
        variant="; ".join(c.label for c in cands),
        description="; ".join(c.description for c in cands),
        require_identifiable=all(c.require_identifiable for c in cands),
    )


def _on_top(model: ModelFn, base: tuple[Any, ...]) -> ModelFn:
    if not base:
        return model

    def fn(effects: tuple[Any, ...], obs: Observations) -> NDArray[np.complex128]:
        return model(tuple(base) + tuple(effects), obs)

    return fn


@dataclass(frozen=True, eq=False)
class Step:
    """One named candidate of the forward selection.

    Parameters
    ----------
    candidate : Candidate
    params, std : ndarray, shape (p,)
        Its parameters in the joint fit of all steps so far, and their
        standard deviations (statistical, inflated by the remaining misfit,
        combined with the spread over the cross-validation folds).
    at_bound : tuple of bool
    notes : tuple of str
        Identifiability remarks of its screening fit.
    gain : float
        Held-out deviance drop per residual against the previous step [noise variances].
    share : float
        Its share of the explained held-out misfit (0..1).
    per_residual : float
        Held-out deviance per residual after this step.
    alternatives : tuple of str
        Labels of candidates of other families that explain the data about as
        well (``ForwardSettings.ambiguity_bic``); non-empty: not claimed.
    """

    candidate: Candidate
    params: NDArray[np.float64]
    std: NDArray[np.float64]
    at_bound: tuple[bool, ...]
    notes: tuple[str, ...]
    gain: float
    share: float
    per_residual: float
    alternatives: tuple[str, ...] = ()

    @property
    def ambiguous(self) -> bool:
        """Whether a candidate of another family explains the data about as well."""
        return bool(self.alternatives)

    @property
    def label(self) -> str:
        """Candidate label."""
        return self.candidate.label

    @property
    def fit(self) -> CandidateFit:
        """A :class:`CandidateFit` view of the step (for descriptions)."""
        p = self.candidate.n_params
        return CandidateFit(
            candidate=self.candidate,
            params=self.params,
            std=self.std,
            corr=np.eye(p),
            deviance=float("nan"),
            n_resid=0,
            cond=float("nan"),
            identifiable=True,
            notes=self.notes,
            at_bound=self.at_bound,
            nfev=0,
        )


@dataclass(frozen=True)
class NoiseTest:
    """The chosen model's held-out misfit against the noise.

    Parameters
    ----------
    misfit_x_noise : float
        RMS held-out residual in noise standard deviations, ``sqrt(D_cv / N)``.
    nrmse_x_noise : float
        Mean held-out NRMSE over the mean NRMSE of the noise alone.
    nrmse_noise : float
        Mean NRMSE the noise alone gives.
    unexplained : bool
        Whether either ratio exceeds the limit.
    worst_postures : tuple of (str, float)
        Postures with the largest held-out misfit (id, RMS residual in noise deviations).
    worst_bands : tuple of BandScore
        Direction/bands with the largest held-out misfit.
    limit : float
    band_misfit_x_noise : float
        RMS held-out residual of the worst direction/band, in noise deviations
        (square root of its mean score).
    band_limit : float
        Above this worst-band misfit the recordings are unexplained (module notes).
    """

    misfit_x_noise: float
    nrmse_x_noise: float
    nrmse_noise: float
    unexplained: bool
    worst_postures: tuple[tuple[str, float], ...]
    worst_bands: tuple[BandScore, ...]
    limit: float = 1.5
    band_misfit_x_noise: float = 0.0
    band_limit: float = float("inf")


def noise_test(
    cv: CrossValidation,
    obs: Observations,
    *,
    limit: float = 1.5,
    band_limit: float = 6.0,
    n_worst: int = 3,
) -> NoiseTest:
    """Compare held-out predictions with the noise (module notes).

    Parameters
    ----------
    cv : CrossValidation
        Held-out predictions of the chosen model on ``obs``.
    obs : Observations
        The records on the evaluation grid.
    limit : float
        Largest misfit (x noise) still counted as explained.
    band_limit : float
        Largest RMS misfit of one direction in one band (x noise) still
        counted as explained.
    n_worst : int
        Postures and bands listed.
    """
    per_res = cv.per_residual
    mx = float(np.sqrt(max(per_res, 0.0)))
    met = fit_metrics(cv.H, obs)
    nn = float(np.nanmean(noise_nrmse(obs)))
    nx = float(met.nrmse_mean / nn) if nn > 0 else float("inf")
    rec = np.sqrt(cv.deviance / np.maximum(cv.count, 1))
    order = np.argsort(-rec)[:n_worst]
    mm = mismatch_map(cv.H, obs)
    ranked = sorted(mm.bands, key=lambda b: -b.score)
    bands = tuple(b for b in ranked[:n_worst] if b.score > 1.0)
    bx = float(np.sqrt(max(ranked[0].score, 0.0))) if ranked else 0.0
    return NoiseTest(
        misfit_x_noise=mx,
        nrmse_x_noise=nx,
        nrmse_noise=nn,
        unexplained=bool(mx > limit or nx > limit or bx > band_limit),
        worst_postures=tuple((obs.record_ids[i], float(rec[i])) for i in order),
        worst_bands=bands,
        limit=limit,
        band_misfit_x_noise=bx,
        band_limit=band_limit,
    )


@dataclass(frozen=True, eq=False)
class ForwardResult:
    """Outcome of :func:`forward_select`.

    Parameters
    ----------
    steps : tuple of Step
        Named candidates in the order taken (empty: none).
    rounds : tuple of Selection
        The selection of each round (the last one named nothing, or the
        limit was reached).
    fits : tuple of CandidateFit
        Round-1 fits of every candidate (on the nominal model).
    model_fit : CandidateFit
        The joint fit of all steps (the ``none`` fit if there are none).
    cv : CrossValidation
        Its held-out predictions.
    baseline_cv : CrossValidation
        Held-out predictions of the nominal model.
    stop_reason : str
        Why the search stopped.
    noise : NoiseTest
        The absolute test of the chosen model.
    """

    steps: tuple[Step, ...]
    rounds: tuple[Selection, ...]
    fits: tuple[CandidateFit, ...]
    model_fit: CandidateFit
    cv: CrossValidation
    baseline_cv: CrossValidation
    stop_reason: str
    noise: NoiseTest
    rejected: tuple[str, ...] = field(default=())

    @property
    def ambiguous(self) -> bool:
        """Whether a named step has an other-family alternative about as good."""
        return any(s.ambiguous for s in self.steps)

    @property
    def effects(self) -> tuple[Any, ...]:
        """Effects of the joint fit."""
        f = self.model_fit
        return tuple(f.candidate.effects(f.params)) if f.candidate.n_params else ()


def _fold_spread(cv: CrossValidation, cand: Candidate) -> NDArray[np.float64]:
    """Jackknife-style spread of the fold parameters (physical units), shape (p,)."""
    fp = cv.fold_params
    k = fp.shape[0]
    if k < 2 or fp.shape[1] == 0:
        return np.zeros(fp.shape[1])
    z = np.array([cand.to_internal(p) for p in fp])
    sd_z = np.sqrt((k - 1) / k * np.sum((z - z.mean(axis=0)) ** 2, axis=0))
    g = np.array([ps.dphys_dz(zi) for ps, zi in zip(cand.params, z.mean(axis=0), strict=True)])
    return np.asarray(sd_z * np.abs(g))


def _own_params_determined(jf: CandidateFit, cand: Candidate, start: int) -> bool:
    """Whether ``cand``'s parameters (from ``start`` in the joint fit ``jf``) are determined."""
    for k, ps in enumerate(cand.params):
        v, sd = float(jf.params[start + k]), float(jf.std[start + k])
        if not np.isfinite(sd):
            return False
        rel = sd / max(abs(v), 1e-300) if ps.scale == "log" else sd / (ps.upper - ps.lower)
        if rel > REL_STD_MAX:
            return False
    return True


def _joint_round(
    sel: Selection,
    fits: Sequence[CandidateFit],
    round1: Sequence[CandidateFit],
    chosen: Sequence[Candidate],
    joint: CandidateFit,
    model: ModelFn,
    obs_fit: Observations,
    sel_st: SelectionSettings,
    st: ForwardSettings,
) -> tuple[CandidateFit, CandidateFit, tuple[str, ...]] | None:
    """The round's candidate by joint BIC (module notes).

    Returns its on-top fit, the joint fit and the labels of other-family
    candidates whose joint fit comes within ``ambiguity_bic`` of it.
    """
    f0 = next(f for f in fits if f.candidate.name == NONE)
    pool: list[CandidateFit] = [sel.verdict.fit] if sel.name != NONE else []
    for f in sorted(fits, key=lambda f: f.bic):
        if len(pool) >= st.joint_k + (1 if sel.name != NONE else 0):
            break
        if f.candidate.name == NONE or any(f is g for g in pool):
            continue
        if f0.bic - f.bic < sel_st.min_delta_bic:
            break
        pool.append(f)
    # also the candidates that explained most on the nominal model: an effect the
    # earlier steps have absorbed (a tool mass taken up by the calibrated spindle
    # mass) gains little on top of them, and only a joint refit shows it (module notes)
    start_z = {id(f): f.z for f in pool}
    here = {f.candidate.label: f for f in fits}
    n_own = 0
    for g in sorted(round1, key=lambda f: f.bic):
        if n_own >= st.joint_k:
            break
        fh = here.get(g.candidate.label)
        if fh is None or fh.candidate.name == NONE or not g.identifiable:
            continue
        if any(fh is h for h in pool):
            continue
        pool.append(fh)
        start_z[id(fh)] = g.z
        n_own += 1
    start = int(joint.params.size)
    best: tuple[CandidateFit, CandidateFit] | None = None
    done: list[tuple[CandidateFit, CandidateFit]] = []
    for f in pool:
        comp = combine([*chosen, f.candidate])
        jf = fit_candidate(
            comp,
            model,
            obs_fit,
            z0=np.concatenate([joint.z, start_z[id(f)]]),
            max_nfev=st.joint_max_nfev,
        )
        if f.candidate.require_identifiable and not _own_params_determined(jf, f.candidate, start):
            continue
        if joint.bic - jf.bic < sel_st.min_delta_bic:
            continue
        done.append((f, jf))
        if best is None or jf.bic < best[1].bic:
            best = (f, jf)
    if best is None:
        return None
    return best[0], best[1], _alternatives(best[0].candidate, best[1].bic, done, st)


def _interchangeable(a: Candidate, b: Candidate) -> bool:
    """Same family, or both within what a file calibration holds (by design equivalent)."""
    cal = (CALIBRATION, *SUBSUMED_BY_CALIBRATION)
    return a.name == b.name or (a.name in cal and b.name in cal)


def _alternatives(
    win: Candidate,
    bic: float,
    others: Sequence[tuple[CandidateFit, CandidateFit]],
    st: ForwardSettings,
) -> tuple[str, ...]:
    """Labels of other-family candidates whose joint BIC is within ``ambiguity_bic``."""
    return tuple(
        f.candidate.label
        for f, jf in others
        if not _interchangeable(f.candidate, win) and jf.bic - bic < st.ambiguity_bic
    )


FitOne = Callable[[Candidate, ModelFn, Observations], CandidateFit]


def _fit_with(c: Candidate, fit_one: FitOne, model: ModelFn, obs: Observations) -> CandidateFit:
    """``fit_one(c, model, obs)`` (a module-level function the workers import by name)."""
    return fit_one(c, model, obs)


def _fit_round(
    todo: Sequence[Candidate],
    fit_one: FitOne,
    model: ModelFn,
    obs: Observations,
    n_jobs: int,
    tick: Callable[[int], None] | None = None,
) -> list[CandidateFit]:
    """Every candidate of a round fitted, in order; over ``n_jobs`` workers if > 1.

    The fits are independent and deterministic, so the workers give the
    fits of one process (to round-off: 1e-12 relative). Each task carries a
    few candidates taken round-robin (the costly file calibration and tool
    modes spread over the workers) and one copy of the model and the records
    (:func:`robolobe._workers.map_chunks`).
    """
    if n_jobs == 1 or len(todo) < 4:
        out = []
        for i, c in enumerate(todo):
            if tick is not None:
                tick(i)
            out.append(fit_one(c, model, obs))
        return out
    fn = functools.partial(_fit_with, fit_one=fit_one, model=model, obs=obs)
    n_parts = 4 * (n_jobs if n_jobs > 0 else 2)
    return map_chunks(fn, todo, n_jobs, parts=n_parts)


def _screen(
    remaining: Sequence[Candidate], previous: Sequence[CandidateFit], k: int
) -> list[Candidate]:
    """``none``, the calibration and the ``k`` remaining candidates best by the previous BIC."""
    labels = {c.label for c in remaining}
    ranked = [f for f in sorted(previous, key=lambda f: f.bic) if f.candidate.label in labels]
    keep = {f.candidate.label for f in ranked if f.candidate.require_identifiable}
    top = [f.candidate.label for f in ranked if f.candidate.label in keep][:k]
    return [c for c in remaining if c.name == NONE or not c.require_identifiable or c.label in top]


def forward_select(
    candidates: Sequence[Candidate],
    model: ModelFn,
    obs_fit: Observations,
    obs_eval: Observations,
    *,
    selection: SelectionSettings | None = None,
    settings: ForwardSettings | None = None,
    fit: Callable[..., CandidateFit] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    n_jobs: int = 1,
) -> ForwardResult:
    """Name candidates one after another while each beats the noise on held-out postures.

    Parameters
    ----------
    candidates : sequence of Candidate
        The library, ``none`` included.
    model : ModelFn
    obs_fit, obs_eval : Observations
        Records on the fitting and the evaluation grid.
    selection : SelectionSettings, optional
    settings : ForwardSettings, optional
    fit : callable, optional
        ``fit(candidate, model, obs) -> CandidateFit`` (default
        :func:`fit_candidate` with its defaults).
    progress : callable, optional
    n_jobs : int
        Workers for each round's candidate fits (1: in this process; -1: all
        cores). The fits are the same either way (to round-off).

    Returns
    -------
    ForwardResult
    """
    sel_st = selection or SelectionSettings()
    st = settings or ForwardSettings()
    fit_one = fit or (lambda c, m, o: fit_candidate(c, m, o))
    folds = make_folds(obs_fit.group, sel_st.n_folds)
    remaining = list(candidates)
    chosen: list[Candidate] = []
    steps: list[Step] = []
    rounds: list[Selection] = []
    rejected: list[str] = []
    round1: list[CandidateFit] = []
    prev_fits: list[CandidateFit] = []
    joint: CandidateFit | None = None
    joint_cv: CrossValidation | None = None
    base_cv: CrossValidation | None = None
    prev_cv: CrossValidation | None = None
    stop = f"the limit of {st.max_effects} named effects"
    # a step taken on trial (module notes): the held-out fit before it, the gain it
    # needed, its label, and the state to go back to
    pending: tuple[CrossValidation, float, str, tuple[Any, ...]] | None = None

    def _snapshot() -> tuple[Any, ...]:
        return (list(chosen), list(steps), list(remaining), joint, joint_cv, prev_cv)

    def _n_effects(cs: Sequence[Candidate]) -> int:
        return sum(c.name != CALIBRATION for c in cs)

    # the calibration takes no place among the effects: one round more at most
    for r in range(st.max_effects + 1):
        full = _n_effects(chosen) >= st.max_effects
        if full and any(c.name == CALIBRATION for c in chosen):
            break
        base = joint.candidate.effects(joint.params) if joint is not None else ()
        m_r = _on_top(model, tuple(base))
        # round 2 fits everything on top of the first step (module notes)
        todo = remaining if r <= 1 else _screen(remaining, prev_fits, st.screen_k)
        if full:  # only the calibration may still join
            todo = [c for c in todo if c.name in (NONE, CALIBRATION)]
            if len(todo) < 2:
                break
        total = len(todo)

        def tick(i: int, r: int = r, todo: Sequence[Candidate] = todo) -> None:
            if progress is not None:
                progress(f"round {r + 1}: fitting {todo[i].label}", i, len(todo))

        if progress is not None and n_jobs != 1:
            progress(f"round {r + 1}: fitting {total} candidates on {n_jobs} workers", 0, total)
        fits = _fit_round(todo, fit_one, m_r, obs_fit, n_jobs, tick)
        if r == 0:
            round1 = fits
        prev_fits = fits
        if progress is not None:
            progress(f"round {r + 1}: cross-validating", total, total)
        sel = select(fits, m_r, obs_fit, obs_eval, sel_st)
        rounds.append(sel)
        if base_cv is None:
            base_cv = sel.baseline.cv
            prev_cv = base_cv
        assert base_cv is not None
        assert prev_cv is not None
        if joint is None:
            if sel.name == NONE:
                stop = "no further candidate beats the noise on held-out postures"
                break
            win = sel.verdict.fit
            jf = fit_candidate(
                combine([win.candidate]), model, obs_fit, z0=win.z, max_nfev=st.joint_max_nfev
            )
            ru = sel.runner_up
            alts: tuple[str, ...] = (
                (ru.fit.candidate.label,)
                if ru is not None and not _interchangeable(ru.fit.candidate, win.candidate)
                else ()
            )
        else:
            if progress is not None:
                progress(f"round {r + 1}: joint refits", total, total)
            picked = _joint_round(sel, fits, round1, chosen, joint, model, obs_fit, sel_st, st)
            if picked is None:
                stop = "no further candidate beats the noise on held-out postures"
                break
            win, jf, alts = picked
        jcv = cross_validate(jf, model, obs_fit, obs_eval, folds, max_nfev=sel_st.cv_max_nfev)
        n_eval = float(max(int(base_cv.count.sum()), 1))
        gain = float((prev_cv.deviance.sum() - jcv.deviance.sum()) / n_eval)
        # a later step must remove most of what the previous steps left over the noise
        excess = max(prev_cv.per_residual - 1.0, 0.0)
        need = max(sel_st.min_gain, st.min_share * excess) if steps else sel_st.min_gain
        if pending is not None:
            # the step before was taken on trial: with this one, the two must remove
            # the share the trial step alone did not
            p_cv, p_need, p_label = pending[0], pending[1], pending[2]
            both = float((p_cv.deviance.sum() - jcv.deviance.sum()) / n_eval)
            if gain < sel_st.min_gain or both < p_need:
                rejected.append(
                    f"{p_label} and {win.candidate.label}: held-out gain {both:.3g} noise "
                    f"variances per point together on top of the earlier steps < {p_need:.3g}"
                )
                stop = "the next candidates do not beat the noise on held-out postures"
                break
            pending = None
        elif gain < need:
            # room for a partner: an effect slot after this step, or the calibration
            room = st.max_effects - _n_effects([*chosen, win.candidate])
            cal_left = all(c.name != CALIBRATION for c in (*chosen, win.candidate))
            if steps and gain >= sel_st.min_gain and (room >= 1 or cal_left):
                # more than one effect may be left: a step that removes less than the
                # share may be one of two; taken on trial, kept only with the next
                pending = (prev_cv, need, win.candidate.label, _snapshot())
            else:
                rejected.append(
                    f"{win.candidate.label}: held-out gain {gain:.3g} noise variances per point "
                    f"on top of the earlier steps < {need:.3g}"
                )
                stop = "the next candidate does not beat the noise on held-out postures"
                break
        chosen.append(win.candidate)
        joint, joint_cv, prev_cv = jf, jcv, jcv
        steps.append(
            Step(
                candidate=win.candidate,
                params=win.params,
                std=win.std,
                at_bound=win.at_bound,
                notes=win.notes,
                gain=gain,
                share=0.0,
                per_residual=jcv.per_residual,
                alternatives=alts,
            )
        )
        remaining = [
            c
            for c in remaining
            if c.label != win.candidate.label
            and not (win.candidate.name == CALIBRATION and c.name in SUBSUMED_BY_CALIBRATION)
        ]
        if np.sqrt(max(jcv.per_residual, 0.0)) <= st.at_noise:
            stop = "the held-out misfit is at the noise"
            break
    if pending is not None:
        # the trial step found no partner: back to the model before it
        chosen, steps, remaining, joint, joint_cv, prev_cv = pending[3]
        if not rejected or not rejected[-1].startswith(pending[2] + " and "):
            rejected.append(
                f"{pending[2]}: held-out gain on top of the earlier steps below "
                f"{pending[1]:.3g} noise variances per point, and no further step with it"
            )
        stop = "the next candidate does not beat the noise on held-out postures"
    assert base_cv is not None
    none_fit = next(f for f in round1 if f.candidate.name == NONE)
    if joint is None or joint_cv is None:
        model_fit, model_cv = none_fit, base_cv
    else:
        model_fit, model_cv = joint, joint_cv
        # parameters from the joint fit; std: statistical (inflated by the remaining
        # misfit through D / (N - p)) combined with the spread over the folds
        spread = _fold_spread(joint_cv, joint.candidate)
        total_gain = sum(s.gain for s in steps)
        a = 0
        out: list[Step] = []
        for s in steps:
            b = a + s.candidate.n_params
            std = np.sqrt(joint.std[a:b] ** 2 + spread[a:b] ** 2)
            out.append(
                Step(
                    candidate=s.candidate,
                    params=joint.params[a:b],
                    std=std,
                    at_bound=joint.at_bound[a:b],
                    notes=s.notes,
                    gain=s.gain,
                    share=s.gain / total_gain if total_gain > 0 else 0.0,
                    per_residual=s.per_residual,
                    alternatives=s.alternatives,
                )
            )
            a = b
        steps = out
    # an alternative that is itself in the model, or the file calibration (a generic
    # correction, named or not on its own held-out merit), is no rival explanation
    in_model = {s.candidate.name for s in steps}
    cal = (CALIBRATION, *SUBSUMED_BY_CALIBRATION)
    steps = [
        dataclasses.replace(
            s,
            alternatives=tuple(
                a for a in s.alternatives if a.split("[")[0] not in in_model | set(cal)
            ),
        )
        for s in steps
    ]
    nt = noise_test(
        model_cv,
        obs_eval,
        limit=st.max_misfit_x_noise,
        band_limit=st.max_band_misfit_x_noise,
    )
    return ForwardResult(
        steps=tuple(steps),
        rounds=tuple(rounds),
        fits=tuple(round1),
        model_fit=model_fit,
        cv=model_cv,
        baseline_cv=base_cv,
        stop_reason=stop,
        noise=nt,
        rejected=tuple(rejected),
    )
