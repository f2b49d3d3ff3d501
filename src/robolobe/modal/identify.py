"""Campaign-level identification: from a hammer-test campaign to a modal dataset.

Steps (:func:`identify_frfs`, :func:`identify_campaign`):

1. Each posture is identified on its own (:func:`robolobe.modal.posture.identify_posture`),
   in parallel over postures (joblib) when ``n_jobs != 1``.
2. Modes are tracked across postures (:func:`robolobe.modal.tracking.track_modes`).
3. Mode numbers (``numbering``): by default the modes of a posture that are
   visible at some driving point are numbered by rising frequency; or, per
   driving direction, the tracks visible there at the most postures become
   modes 1, 2, ..., numbered by rising median frequency. How many: every
   mode the stabilization diagram selects that a driving point sees
   (``n_modes=None``, the default), or at most ``n_modes``.
4. Neighbour recovery (the seed's practice of comparing neighbouring
   postures): a chosen track missing at a posture is searched for again,
   starting from the median pole of the nearest postures that have it;
   it is kept if the refined pole stays within 5 % of that start and its
   term is visible at the driving point.
5. The rows of ``modal.csv`` (docs/guide/modal.md) plus FRAC / NRMSE of the
   FRF synthesized from those rows against the measured FRF, per posture and
   direction, on the analysis band.

Extra columns of the table: ``source`` (``identified``, ``weak``: the mode
is identified at the posture but barely visible at this driving point, or
``recovered``), ``visibility`` (peak of the mode's term over the peak of
the measured FRF) and ``k_rel_std`` (relative standard deviation of the
driving-point residue from the LSFD covariance, about that of ``k``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES
from robolobe._matching import match_modes
from robolobe._modal_parameters import ModalParameters
from robolobe._text import count
from robolobe._threads import with_one_blas_thread
from robolobe._workers import map_chunks
from robolobe.campaign import Campaign, TestHeader, read_campaign
from robolobe.campaign.metrics import frac, nrmse
from robolobe.errors import InputError, InputTypeError
from robolobe.modal._pool import identify_item, refit_item
from robolobe.modal.modal_csv import MODAL_COLUMNS, Q_COLUMNS, validate_modal_frame
from robolobe.modal.posture import IdentifySettings, PostureModal
from robolobe.modal.quality import QualityIssue, check_campaign_grids
from robolobe.modal.synthesis import poles_to_modal, synthesize_frf
from robolobe.modal.tracking import (
    ModeTracks,
    TrackingSettings,
    posture_distances,
    spectral_distances,
    track_modes,
)

__all__ = [
    "EXTRA_COLUMNS",
    "CampaignModal",
    "campaign_band_top",
    "identify_campaign",
    "identify_frfs",
    "settings_from_test",
]

#: Columns of :attr:`CampaignModal.fit`.
FIT_COLUMNS: tuple[str, ...] = (
    "posture_id", "dir", "n_modes", "frac", "nrmse", "frac_fit", "outside_share",
)  # fmt: skip

#: Extra columns of the modal table beyond docs/guide/modal.md.
EXTRA_COLUMNS: tuple[str, ...] = ("source", "visibility", "k_rel_std")


@dataclass(frozen=True, eq=False)
class CampaignModal:
    """Result of a campaign identification.

    Attributes
    ----------
    table : pandas.DataFrame
        The modal dataset (columns of ``MODAL_COLUMNS`` plus ``source`` and
        ``visibility``), validated, sorted by posture, direction, mode.
    postures : tuple of PostureModal
        Per-posture results (after recovery), campaign order.
    tracks : ModeTracks
    direction_tracks : dict
        ``{"xx": (track of mode 1, track of mode 2, ...), ...}``.
    fit : pandas.DataFrame
        ``posture_id, dir, n_modes, frac, nrmse``: the FRF synthesized from
        the rows of ``table`` against the measured FRF on the analysis band;
        ``frac_fit``: FRAC of the identification's own fit (LSFD with its
        residual terms); ``outside_share``: the share of the FRF the
        residual terms carry (modes outside the band, which modal.csv cannot
        hold; :func:`_residual_share`).
    issues : tuple of QualityIssue
        All data-quality findings.
    n_recovered : int
        Rows that come from neighbour recovery.
    negative : pandas.DataFrame
        Modes identified and numbered at a driving point with a negative
        residue (``k_N_per_m < 0``, see :mod:`robolobe.modal.posture` for the
        sign convention): columns of ``table`` without the extras. They are
        not in ``table`` (a driving-point stiffness is positive in
        ``modal.csv``); the ``sign`` issues say why.
    settings : IdentifySettings
    """

    table: pd.DataFrame
    postures: tuple[PostureModal, ...]
    tracks: ModeTracks
    direction_tracks: Mapping[str, tuple[int, ...]]
    fit: pd.DataFrame
    issues: tuple[QualityIssue, ...]
    n_recovered: int
    negative: pd.DataFrame = field(repr=False)
    settings: IdentifySettings = field(repr=False)

    def parameters(
        self, directions: Sequence[str] | None = None, n_modes: int | None = None
    ) -> ModalParameters:
        """:attr:`table` as :class:`~robolobe._modal_parameters.ModalParameters`.

        Parameters
        ----------
        directions : sequence of str, optional
            Driving points (default: every one with rows, ``xx, yy, zz`` order).
        n_modes : int, optional
            Modes per direction (default: the highest mode number).

        Returns
        -------
        ModalParameters
            Shape (n_postures, n_directions, n_modes), posture ids and joint
            angles set; a mode a posture does not list is absent (NaN).
        """
        return ModalParameters.from_frame(
            self.table, directions=directions, n_modes=n_modes, source="identify"
        )


def campaign_band_top(freq_hz: Sequence[ArrayLike]) -> float:
    """Top of the band every posture of a campaign measured [Hz]: the default ``fmax_hz``.

    The lowest of the postures' top lines, so that the analysis band covers
    what the campaign measured (bracket and tool modes far above the arm's
    included) and no posture is analysed beyond its data.

    Parameters
    ----------
    freq_hz : sequence of array_like
        Frequency grid per posture [Hz].

    Returns
    -------
    float
        NaN when no grid has a finite line.
    """
    tops = [float(np.nanmax(f)) for f in (np.asarray(x, dtype=float) for x in freq_hz) if f.size]
    tops = [t for t in tops if math.isfinite(t)]
    return min(tops) if tops else float("nan")


def _default_fmax(freqs: Sequence[ArrayLike], fmin_hz: float | None) -> float:
    """The default ``fmax_hz``: the campaign's top line (the fixed default if that is no band)."""
    top = campaign_band_top(freqs)
    fmin = IdentifySettings.fmin_hz if fmin_hz is None else float(fmin_hz)
    return top if math.isfinite(top) and top > fmin else IdentifySettings.fmax_hz


def settings_from_test(test: Mapping[str, Any], **overrides: Any) -> IdentifySettings:
    """Identification settings with the window and record length of a campaign's ``[test]``.

    The window's decay rate is :attr:`robolobe.campaign.TestHeader.decay_per_s`
    (``-ln(window_end) / duration_s``, or ``window_decay_per_s`` given
    directly); ``duration_s`` (record length ``T``) also enables the
    truncation correction with ``record_length_s = T``. Keys absent: no
    correction. ``overrides`` are passed to :class:`IdentifySettings` and win.

    Raises
    ------
    InputError
        A value out of range, or ``window_end`` without ``duration_s``.
    """
    header = TestHeader.from_mapping(test)
    kw: dict[str, Any] = {}
    if header.duration_s is not None:
        kw["record_length_s"] = header.duration_s
    if header.has_window:
        kw["window_decay_per_s"] = header.decay_per_s
    kw.update(overrides)
    return IdentifySettings(**kw)


def _choose_tracks(
    postures: Sequence[PostureModal],
    tracks: ModeTracks,
    d: int,
    n_modes: int | None,
    min_presence: float,
) -> tuple[int, ...]:
    counts = np.zeros(tracks.n_tracks, dtype=int)
    freqs: dict[int, list[float]] = {}
    n_d = 0
    for p, pm in enumerate(postures):
        if not pm.used[d, d]:
            continue
        n_d += 1
        for i in pm.modes_for_direction(d):
            t = int(tracks.labels[p][i])
            counts[t] += 1
            freqs.setdefault(t, []).append(float(pm.f_hz[i]))
    if n_d == 0:
        return ()
    need = max(1, math.ceil(min_presence * n_d))
    eligible = np.flatnonzero(counts >= need)
    top = eligible[np.argsort(-counts[eligible], kind="stable")][:n_modes]
    return tuple(sorted((int(t) for t in top), key=lambda t: float(np.median(freqs[t]))))


def _relabel(
    old: PostureModal,
    new: PostureModal,
    old_labels: NDArray,
    extra_f: NDArray,
    extra_t: Sequence[int],
) -> NDArray[np.int64]:
    """Labels of ``new``'s modes: matched to old modes or to the extra starts by frequency."""
    ref_f = np.concatenate([old.f_hz, extra_f])
    ref_t = np.concatenate([old_labels, np.asarray(extra_t, dtype=np.int64)])
    if new.f_hz.size == 0 or ref_f.size == 0:
        return np.full(new.f_hz.size, -1, dtype=np.int64)
    c = np.abs(new.f_hz[:, None] - ref_f[None, :]) / ref_f[None, :]
    # an extra may only claim a mode that is not one of the old ones
    cc = np.where(c <= 0.05, c, np.inf)
    cc[:, : old.f_hz.size] = np.where(c[:, : old.f_hz.size] <= 0.01, c[:, : old.f_hz.size], np.inf)
    rows, cols = match_modes(cc)
    lab = np.full(new.f_hz.size, -1, dtype=np.int64)
    lab[rows] = ref_t[cols]
    return lab


def _recover(
    postures: list[PostureModal],
    labels: list[NDArray[np.int64]],
    chosen: Mapping[str, tuple[int, ...]],
    q_rad: NDArray,
    n_neighbours: int,
    tracking: TrackingSettings | None,
    n_jobs: int = 1,
) -> dict[int, set[int]]:
    """Neighbour recovery in place; returns {posture: indices of recovered modes}.

    A track is looked for at posture ``p`` only when most of ``p``'s
    ``n_neighbours`` nearest postures (spectral + joint-space distance, as in
    the tracking) have it and it is missing at ``p``.
    """
    recovered: dict[int, set[int]] = {}
    all_tracks = sorted({t for ts in chosen.values() for t in ts})
    n = len(postures)
    if not all_tracks or n < 3:
        return recovered
    ts = tracking if tracking is not None else TrackingSettings()
    dist = spectral_distances([pm.f_hz for pm in postures]) + ts.joint_weight * (
        posture_distances(q_rad)
    )
    np.fill_diagonal(dist, np.inf)
    k_nb = min(n_neighbours, n - 1)
    nearest = np.argsort(dist, axis=1)[:, :k_nb]
    # every posture's starts come from the identification before recovery (not from
    # neighbours recovered a moment earlier): the result does not depend on the order
    # or on the number of workers, and the refits can run in parallel
    jobs: list[tuple[int, NDArray[np.complex128], list[int]]] = []
    for p, pm in enumerate(postures):
        if pm.H.size == 0:
            continue
        nb = nearest[p]
        starts, start_t = [], []
        for t in all_tracks:
            if np.any(labels[p] == t):
                continue
            near = [
                (int(o), int(np.flatnonzero(labels[o] == t)[0]))
                for o in nb
                if np.any(labels[o] == t)
            ]
            if 2 * len(near) <= k_nb:
                continue  # the neighbours do not agree that the mode should be here
            lam = np.array([postures[o].poles_measured[i] for o, i in near])
            fn, zn = poles_to_modal(lam)
            f0, z0 = float(np.median(fn)), float(np.median(zn))
            if not pm.settings.fmin_hz <= f0 <= pm.settings.fmax_hz:
                continue
            if (
                pm.f_hz.size
                and np.min(np.abs(poles_to_modal(pm.poles_measured)[0] - f0)) < 0.01 * f0
            ):
                continue  # a mode is already there (tracked elsewhere): leave it
            starts.append(-z0 * 2 * np.pi * f0 + 1j * 2 * np.pi * f0 * math.sqrt(1 - z0**2))
            start_t.append(t)
        if starts:
            jobs.append((p, np.array(starts), start_t))
    refits = map_chunks(refit_item, [(postures[p], st) for p, st, _ in jobs], n_jobs)
    for (p, starts_a, start_t), new in zip(jobs, refits, strict=True):
        pm = postures[p]
        # compare in the corrected domain: shift the starts like the poles
        extra_f = poles_to_modal(starts_a + pm.settings.window_decay_per_s)[0]
        lab = _relabel(pm, new, labels[p], extra_f, start_t)
        seen = set()
        for d in range(3):
            if new.used[d, d]:
                seen |= {int(i) for i in new.modes_for_direction(d)}
        got = np.array([i for i in np.flatnonzero(np.isin(lab, start_t)) if int(i) in seen], int)
        if got.size == 0:
            continue
        # extras that are not visible anywhere are not modes: no track
        lab = np.where(np.isin(lab, start_t) & ~np.isin(np.arange(lab.size), got), -1, lab)
        postures[p] = new
        labels[p] = lab
        recovered[p] = {int(i) for i in got}
    return recovered


@with_one_blas_thread
def identify_frfs(
    posture_ids: Sequence[str],
    q_rad: ArrayLike,
    freq_hz: Sequence[ArrayLike],
    H: Sequence[ArrayLike],
    *,
    coherence: Sequence[ArrayLike | None] | None = None,
    settings: IdentifySettings | None = None,
    tracking: TrackingSettings | None = None,
    min_presence: float = 0.2,
    recover: bool = True,
    n_neighbours: int = 3,
    weak_factor: float = 1.0,
    numbering: str = "rank",
    n_jobs: int = 1,
    progress: Callable[[int], None] | None = None,
) -> CampaignModal:
    """Identify the modes of every posture and build the modal dataset.

    Parameters
    ----------
    posture_ids : sequence of str, length n
    q_rad : array_like, shape (n, 6)
        Joint angles, rad.
    freq_hz : sequence of array_like, each shape (n_freq_p,)
        Frequency grid per posture, Hz.
    H : sequence of array_like, each shape (n_freq_p, 3, 3)
        Receptance per posture (m/N); NaN for absent directions.
    coherence : sequence of array_like or None, optional
        Coherence per posture (same shapes as ``H``).
    settings : IdentifySettings, optional
        Default: :class:`IdentifySettings` with the band up to the campaign's
        top line (:func:`campaign_band_top`) and every visible mode.
    tracking : TrackingSettings, optional
    min_presence : float
        A track becomes a mode of a direction only if it is visible there at
        this fraction of the postures (at least one).
    recover : bool
        Neighbour recovery of missing modes.
    n_neighbours : int
        Postures whose poles start a recovery.
    weak_factor : float
        A tracked mode identified at a posture but with visibility below
        ``visibility_min`` at a driving point is still written (``source =
        weak``) when its visibility is at least ``weak_factor *
        visibility_min`` (default 1: no weak rows; in simulated tests weak
        rows had 90th-percentile stiffness errors of ~16 %, up to 100 %).
    numbering : {"rank", "track"}
        ``"rank"``: at each posture the modes that are visible at some
        driving point are numbered 1, 2, ... by rising frequency (docs/guide/modal.md);
        a mode hidden at one driving point does not shift the
        numbers of the others, since it is still seen at another; tracking
        and neighbour recovery find modes hidden at all of them); each
        direction gets its visible modes (at most ``n_modes`` when set, the
        first ones, so a number can exceed ``n_modes``). ``"track"``:
        mode ``m`` of a direction is the ``m``-th of the (at most ``n_modes``) tracks
        visible there most often, by median frequency (consistent physical
        identity where postures are dense; numbers need not rise with
        frequency at every posture). With a single measured direction use
        ``"track"``.
    n_jobs : int
        Parallel workers over postures (joblib; -1: all cores).
    progress : callable, optional
        Called with the number of postures just finished.

    Returns
    -------
    CampaignModal
    """
    ids = [str(p) for p in posture_ids]
    q = np.asarray(q_rad, dtype=float)
    n = len(ids)
    if q.shape != (n, 6) or len(freq_hz) != n or len(H) != n:
        raise InputError(
            f"expected {n} postures: q_rad ({n}, 6), {n} grids and {n} FRF arrays; found "
            f"q_rad {q.shape}, {len(freq_hz)} grids, {len(H)} FRF arrays",
            source="identify_frfs",
        )
    if n == 0:
        raise InputError("expected at least one posture, found none", source="identify_frfs")
    freqs = [np.asarray(f, dtype=float) for f in freq_hz]
    s = settings if settings is not None else IdentifySettings(fmax_hz=_default_fmax(freqs, None))
    Hs = [np.asarray(h, dtype=complex) for h in H]
    cohs: list[NDArray | None] = (
        [None] * n
        if coherence is None
        else [None if c is None else np.asarray(c, dtype=float) for c in coherence]
    )
    issues: list[QualityIssue] = check_campaign_grids(ids, freqs)
    items = [(ids[i], freqs[i], Hs[i], cohs[i], s) for i in range(n)]
    postures = map_chunks(identify_item, items, n_jobs, progress=progress)
    for pm in postures:
        issues.extend(pm.issues)

    tr = track_modes(
        [pm.f_hz for pm in postures],
        [pm.zeta for pm in postures],
        [pm.shapes for pm in postures],
        [pm.signed_shapes for pm in postures],
        q,
        settings=tracking,
    )
    labels = [lab.copy() for lab in tr.labels]
    dirs = [d for d in range(3) if any(pm.used[d, d] for pm in postures)]
    if numbering not in ("rank", "track"):
        raise InputError(
            f"expected 'rank' or 'track', found {numbering!r}", source="identify_frfs(numbering)"
        )
    chosen = {AXES[d] * 2: _choose_tracks(postures, tr, d, s.n_modes, min_presence) for d in dirs}
    recovered_modes = (
        _recover(postures, labels, chosen, q, n_neighbours, tracking, n_jobs) if recover else {}
    )
    tracks = ModeTracks(tuple(labels), tr.n_tracks, tr.order, tr.parent)
    # mode numbers per posture and direction: {(p, d): [(mode number, mode index), ...]}
    numbers: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for p, pm in enumerate(postures):
        vis_sets = {d: set(pm.modes_for_direction(d).tolist()) for d in dirs if pm.used[d, d]}
        if numbering == "rank":
            phys = sorted(
                set().union(*vis_sets.values()) if vis_sets else set(),
                key=lambda i: float(pm.f_hz[i]),
            )
            for d in vis_sets:
                # the first n_modes modes visible at this driving point, numbered by their
                # rank among all the posture's modes
                numbers[(p, d)] = [
                    (m_no, i) for m_no, i in enumerate(phys, start=1) if i in vis_sets[d]
                ][: s.n_modes]
        else:
            for d in vis_sets:
                lst = []
                for m_no, t in enumerate(chosen[AXES[d] * 2], start=1):
                    hit = np.flatnonzero(labels[p] == t)
                    if hit.size:
                        lst.append((m_no, int(hit[0])))
                numbers[(p, d)] = lst

    rows = []
    neg_rows = []
    fit_rows = []
    vis_min = s.visibility_min
    for p, pm in enumerate(postures):
        q_deg = np.degrees(q[p])
        for d in dirs:
            dname = AXES[d] * 2
            if not pm.used[d, d]:
                continue
            sel_modes: list[int] = []
            for m_no, i in numbers.get((p, d), []):
                k = float(pm.k_N_per_m[d, i])
                vis = float(pm.visibility[d, i])
                rel = float(pm.k_rel_std[d, i])
                precise = not (rel > s.k_rel_std_max)  # NaN (unknown) passes
                row = {
                    "posture_id": pm.posture_id,
                    **{c: float(v) for c, v in zip(Q_COLUMNS, q_deg, strict=True)},
                    "dir": dname,
                    "mode": m_no,
                    "f_hz": float(pm.f_hz[i]),
                    "zeta": float(pm.zeta[i]),
                    "k_N_per_m": k,
                }
                if math.isfinite(k) and k < 0 and vis >= vis_min and precise:
                    neg_rows.append(row)
                    continue
                if not (math.isfinite(k) and k > 0) or vis < weak_factor * vis_min or not precise:
                    continue
                src = (
                    "recovered"
                    if i in recovered_modes.get(p, set())
                    else ("identified" if vis >= vis_min else "weak")
                )
                rows.append({**row, "source": src, "visibility": vis, "k_rel_std": rel})
                sel_modes.append(i)
            fr, nr = _fit_metrics(pm, d, sel_modes)
            fr_fit, share = _residual_share(pm, d)
            fit_rows.append(
                {
                    "posture_id": pm.posture_id,
                    "dir": dname,
                    "n_modes": len(sel_modes),
                    "frac": fr,
                    "nrmse": nr,
                    "frac_fit": fr_fit,
                    "outside_share": share,
                }
            )
    if not rows:
        why = (
            f"; {count(len(neg_rows), 'mode')} {'has' if len(neg_rows) == 1 else 'have'} a "
            "negative driving-point residue (reversed "
            "polarity or transfer FRFs: see the sign convention)"
            if neg_rows
            else ""
        )
        raise InputError(
            "no modes identified in any posture; check the band (--fmin/--fmax) and the data" + why,
            source="identify",
        )
    table = validate_modal_frame(pd.DataFrame(rows, columns=[*MODAL_COLUMNS, *EXTRA_COLUMNS]))
    fit = pd.DataFrame(fit_rows, columns=list(FIT_COLUMNS))
    return CampaignModal(
        table=table,
        postures=tuple(postures),
        tracks=tracks,
        direction_tracks=chosen,
        fit=fit,
        issues=tuple(issues),
        n_recovered=int(np.count_nonzero(table["source"] == "recovered")),
        negative=pd.DataFrame(neg_rows, columns=list(MODAL_COLUMNS)),
        settings=s,
    )


def _residual_share(pm: PostureModal, d: int) -> tuple[float, float]:
    """FRAC of the LSFD fit with its residual terms, and the share the residual terms carry.

    The residual terms stand for modes outside the band (and the window's
    low-frequency distortion); modal.csv cannot hold them. A low FRAC of the
    rows with a high FRAC here is the band, not the identification: modes
    outside it (heavily damped ones reach far into it) carry
    ``outside_share`` (norm of the residual terms' FRF over the measured
    FRF's norm on the band) of this FRF.
    """
    s = pm.settings
    band = (pm.freq_hz >= s.fmin_hz) & (pm.freq_hz <= s.fmax_hz)
    if pm.lsfd is None or not band.any():
        return float("nan"), float("nan")
    fb = pm.freq_hz[band]
    hm = pm.H[band, d, d]
    full = pm.lsfd.synthesize(fb)[:, d, d]
    modes = pm.lsfd.synthesize(fb, residuals=False)[:, d, d]
    norm = float(np.linalg.norm(hm))
    share = float(np.linalg.norm(full - modes)) / norm if norm > 0 else float("nan")
    return float(frac(full, hm)), share


def _fit_metrics(pm: PostureModal, d: int, modes: Sequence[int]) -> tuple[float, float]:
    """FRAC and NRMSE of the modal-parameter FRF (measured-domain damping) on the band."""
    s = pm.settings
    band = (pm.freq_hz >= s.fmin_hz) & (pm.freq_hz <= s.fmax_hz)
    if not band.any():
        return float("nan"), float("nan")
    hm = pm.H[band, d, d]
    idx = np.asarray(modes, dtype=int)
    if idx.size == 0:
        hp = np.zeros_like(hm)
    else:
        fn, zw = poles_to_modal(pm.poles_measured[idx])
        hp = synthesize_frf(fn, zw, pm.k_N_per_m[d, idx], pm.freq_hz[band])
    return float(frac(hp, hm)), float(nrmse(hp, hm))


def identify_campaign(
    campaign: Campaign | str | os.PathLike[str],
    *,
    settings: IdentifySettings | None = None,
    overrides: Mapping[str, Any] | None = None,
    **kwargs: Any,
) -> CampaignModal:
    """Identify a :class:`robolobe.campaign.Campaign`.

    Parameters
    ----------
    campaign : Campaign or path-like
        As read by :func:`robolobe.campaign.read_campaign`, or its folder.
    settings : IdentifySettings, optional
        Default: :func:`settings_from_test` of ``campaign.test`` (window and
        record length), updated with ``overrides``; the band reaches the
        campaign's top line (:func:`campaign_band_top`) unless ``overrides``
        give ``fmax_hz``.
    overrides : mapping, optional
        Fields of :class:`IdentifySettings` to set (ignored if ``settings``).
    **kwargs
        Passed to :func:`identify_frfs` (``n_jobs``, ``progress``, ...).

    Returns
    -------
    CampaignModal
    """
    if isinstance(campaign, str | os.PathLike):
        campaign = read_campaign(campaign)
    if not isinstance(campaign, Campaign):
        raise InputTypeError("campaign", "a campaign folder's path or a Campaign", campaign)
    if settings is not None:
        s = settings
    else:
        over = dict(overrides or {})
        if over.get("fmax_hz") is None:
            over["fmax_hz"] = _default_fmax([f.freq_hz for f in campaign.frfs], over.get("fmin_hz"))
        s = settings_from_test(campaign.test, **over)
    return identify_frfs(
        campaign.posture_ids,
        campaign.q_rad,
        [f.freq_hz for f in campaign.frfs],
        [f.H for f in campaign.frfs],
        settings=s,
        **kwargs,
    )
