"""Diagnosis report: a folder with ``index.html``, PNG figures and the JSON.

Figures (matplotlib, Agg, no global state):

- ``mismatch_map.png``: posture x frequency map of the nominal model's
  mismatch in noise variances (log scale; 1 = at the noise);
- ``frf_overlays.png``: recorded, nominal and corrected (held-out) driving-
  point FRFs of the postures where the nominal model misses most;
- ``ranking.png``: candidates by held-out gain and BIC against ``none``;
- ``modes.png``: recorded against model natural frequencies, before and after.

Written atomically (:func:`robolobe._atomic.atomic_dir`): a failed run leaves
the target as it was.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import LogNorm
from matplotlib.figure import Figure

from robolobe._atomic import atomic_dir
from robolobe._directions import DRIVING, dir_index
from robolobe._text import html_text, plot_text
from robolobe.diagnose.pipeline import Diagnosis
from robolobe.diagnose.schema import DiagnosisReport, to_report

__all__ = ["REPORT_FILES", "write_report"]


def _save(fig: Figure, path: Path) -> None:
    FigureCanvasAgg(fig)
    fig.savefig(path, dpi=110, bbox_inches="tight")


def _mismatch_map(d: Diagnosis, path: Path) -> None:
    mm = d.mismatch
    n = len(mm.record_ids)
    fig = Figure(figsize=(9, max(3.0, 0.18 * n + 1.5)))
    ax = fig.add_subplot()
    data = np.where(np.isfinite(mm.score), np.clip(mm.score, 1e-2, None), np.nan)
    f = mm.freq_hz
    im = ax.imshow(
        data,
        aspect="auto",
        origin="lower",
        extent=(f[0], f[-1], -0.5, n - 0.5),
        norm=LogNorm(vmin=0.1, vmax=max(10.0, float(np.nanmax(data)))),
        cmap="magma",
        interpolation="nearest",
    )
    step = max(1, n // 30)
    ax.set_yticks(range(0, n, step))
    ax.set_yticklabels([plot_text(r, 24) for r in mm.record_ids[::step]], fontsize=7)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("posture")
    ax.set_title("Nominal model vs recordings: mismatch (1 = noise level)")
    fig.colorbar(im, ax=ax, label="noise variances per point")
    _save(fig, path)


def _overlays(d: Diagnosis, path: Path, n_post: int = 4) -> None:
    obs = d.obs
    dirs = [dd for dd in DRIVING if dd in obs.directions]
    order = np.argsort(-np.nan_to_num(d.mismatch.record_score))[:n_post]
    fig = Figure(figsize=(4.0 * max(1, len(dirs)), 2.6 * len(order)))
    axes = fig.subplots(len(order), max(1, len(dirs)), squeeze=False)
    f = obs.freq_hz
    for r, k in enumerate(order):
        for c, dd in enumerate(dirs):
            i, j = dir_index(dd)
            ax = axes[r, c]
            ax.semilogy(f, np.abs(obs.H[k, :, i, j]), color="0.2", lw=1.2, label="recorded")
            ax.semilogy(
                f, np.abs(d.H_nominal[k, :, i, j]), "--", color="tab:red", lw=1, label="nominal"
            )
            ax.semilogy(
                f,
                np.abs(d.H_after[k, :, i, j]),
                ":",
                color="tab:blue",
                lw=1.4,
                label="corrected (held out)",
            )
            ax.set_title(f"{plot_text(obs.record_ids[k], 24)}  H_{dd}", fontsize=9)
            if r == len(order) - 1:
                ax.set_xlabel("frequency [Hz]")
            if c == 0:
                ax.set_ylabel("|H| [m/N]")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    _save(fig, path)


def _ranking(rep: DiagnosisReport, path: Path, top: int = 14) -> None:
    cands = rep.candidates[:top]
    fig = Figure(figsize=(9, 0.35 * len(cands) + 1.5))
    ax1, ax2 = fig.subplots(1, 2, sharey=True)
    y = np.arange(len(cands))[::-1]
    labels = [c.label for c in cands]
    gains = [c.gain if c.gain is not None else np.nan for c in cands]
    colors = ["tab:green" if c.named else ("tab:blue" if c.passed else "0.6") for c in cands]
    ax1.barh(y, np.nan_to_num(gains), color=colors)
    ax1.set_yticks(y)
    ax1.set_yticklabels(labels, fontsize=8)
    ax1.set_xlabel("held-out gain [noise variances / residual]")
    ax1.axvline(0, color="k", lw=0.5)
    thr = rep.thresholds["min_gain"]
    ax1.axvline(thr, color="tab:red", ls="--", lw=0.8, label=f"threshold {thr:g}")
    ax1.set_xlim(
        min(0.0, float(np.nanmin(gains))) - 0.05 * thr,
        max(2.0 * thr, float(np.nanmax(gains))) * 1.05,
    )
    ax1.legend(fontsize=7, loc="lower right")
    dbic = np.array([c.delta_bic for c in cands])
    ax2.barh(y, np.sign(dbic) * np.log10(1 + np.abs(dbic)), color=colors)
    ax2.set_xlabel("sign x log10(1 + |BIC(none) - BIC|)")
    ax2.axvline(0, color="k", lw=0.5)
    fig.suptitle(f"Candidates (verdict: {rep.verdict_label})")
    fig.tight_layout()
    _save(fig, path)


def _modes_fig(d: Diagnosis, path: Path) -> None:
    fig = Figure(figsize=(8, 4))
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    for ax, rows, title in (
        (axes[0], d.modes_before, "nominal"),
        (axes[1], d.modes_after, "corrected"),
    ):
        pr = [r for r in rows if r.status == "paired"]
        if pr:
            fn = np.array([r.f_nom_hz for r in pr])
            fm = np.array([r.f_meas_hz for r in pr])
            ax.plot(fn, fm, ".", ms=4)
            lo, hi = float(min(fn.min(), fm.min())), float(max(fn.max(), fm.max()))
            ax.plot([lo, hi], [lo, hi], "k-", lw=0.6)
        un = [r for r in rows if r.status != "paired"]
        ax.set_title(f"{title}: {len(pr)} paired, {len(un)} unpaired modes", fontsize=9)
        ax.set_xlabel("model f [Hz]")
    axes[0].set_ylabel("recorded peak f [Hz]")
    fig.tight_layout()
    _save(fig, path)


def _table(headers: list[str], rows: Sequence[Sequence[object]]) -> str:
    h = "".join(f"<th>{html_text(x)}</th>" for x in headers)
    body = "".join(
        "<tr>" + "".join(f"<td>{html_text(_fmt(v))}</td>" for v in r) + "</tr>" for r in rows
    )
    return f"<table><tr>{h}</tr>{body}</table>"


def _fmt(v: object) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def _html(rep: DiagnosisReport) -> str:
    fb, fa = rep.fit_before, rep.fit_after
    cand_rows = [
        [
            c.rank,
            c.label + (" (verdict)" if c.named else ""),
            ", ".join(
                f"{p.name}={p.value:.4g}" + (f"±{p.std:.2g}" if p.std is not None else "")
                for p in c.params
            ),
            c.delta_bic,
            c.gain,
            c.posture_share,
            c.explained,
            "yes" if c.identifiable else "no",
            "; ".join(c.reasons),
        ]
        for c in rep.candidates
    ]
    sections = [
        f"<h1>Mismatch diagnosis</h1><p><b>Campaign:</b> {html_text(rep.campaign)}<br>"
        f"<b>Robot:</b> {html_text(rep.robot)}<br>"
        f"<b>Band:</b> {rep.band_hz[0]:g}-{rep.band_hz[1]:g} Hz, "
        f"{rep.n_postures} postures, directions {', '.join(rep.directions)}</p>",
        f"<h2>Verdict: {html_text(rep.verdict_label)}</h2>"
        f"<p>{html_text(rep.summary, newlines=True)}</p>",
        _table(
            ["", "FRAC mean", "FRAC min", "NRMSE mean"],
            [
                ["nominal", fb.frac_mean, fb.frac_min, fb.nrmse_mean],
                ["corrected (held-out postures)", fa.frac_mean, fa.frac_min, fa.nrmse_mean],
            ],
        ),
        "<h2>Where the nominal model misses</h2><img src='mismatch_map.png'>",
        _table(
            ["direction", "score", "level offset (log)", "delay [ms]", "± [ms]"],
            [
                [s.direction, s.score, s.level_offset, s.delay_ms, s.delay_std_ms]
                for s in rep.mismatch.directions
            ],
        ),
        "<h3>Worst bands</h3>"
        + _table(
            ["direction", "band [Hz]", "score", "worst posture", "its score"],
            [
                [
                    b.direction,
                    f"{b.f_lo_hz:g}-{b.f_hi_hz:g}",
                    b.score,
                    b.worst_posture,
                    b.worst_score,
                ]
                for b in rep.mismatch.worst_bands
            ],
        ),
        "<h2>FRFs before and after</h2><img src='frf_overlays.png'>",
        "<h2>Candidates</h2><img src='ranking.png'>",
        _table(
            [
                "rank",
                "candidate",
                "parameters",
                "ΔBIC",
                "held-out gain",
                "postures improved",
                "explained",
                "identifiable",
                "why not named",
            ],
            cand_rows,
        ),
    ]
    if rep.untestable:
        sections.append(
            "<h3>Not tested</h3>"
            + _table(
                ["candidate", "reason"],
                [
                    [u.name + (f"[{u.variant}]" if u.variant else ""), u.reason]
                    for u in rep.untestable
                ],
            )
        )
    sections.append("<h2>Modes</h2><img src='modes.png'>")
    for title, rows in (("nominal", rep.modes_before), ("corrected", rep.modes_after)):
        sections.append(
            f"<h3>Per-mode table ({title} vs recorded peaks)</h3>"
            + _table(
                [
                    "posture",
                    "status",
                    "f model [Hz]",
                    "ζ model",
                    "f recorded [Hz]",
                    "ζ recorded",
                    "Δf [%]",
                    "MAC",
                ],
                [
                    [
                        m.posture,
                        m.status,
                        m.f_nom_hz,
                        m.zeta_nom,
                        m.f_meas_hz,
                        m.zeta_meas,
                        m.df_pct,
                        m.mac,
                    ]
                    for m in rows
                ],
            )
        )
    if rep.quality:
        sections.append(
            "<h2>Data quality</h2>"
            + _table(
                ["posture", "dir", "check", "severity", "message"],
                [[q.posture, q.dir, q.check, q.severity, q.message] for q in rep.quality],
            )
        )
    style = (
        "body{font-family:sans-serif;max-width:1100px;margin:auto}"
        "table{border-collapse:collapse;margin:8px 0}td,th{border:1px solid #bbb;padding:2px 6px;"
        "font-size:12px}img{max-width:100%}"
    )
    return (
        f"<!doctype html><html><head><meta charset='utf-8'><title>robolobe diagnosis</title>"
        f"<style>{style}</style></head><body>{''.join(sections)}</body></html>"
    )


#: The files :func:`write_report` writes (checked before a run: :mod:`robolobe._atomic`).
REPORT_FILES: tuple[str, ...] = (
    "mismatch_map.png",
    "frf_overlays.png",
    "ranking.png",
    "modes.png",
    "diagnosis.json",
    "index.html",
)


def write_report(d: Diagnosis, path: str | os.PathLike[str]) -> Path:
    """Write the report folder (index.html, figures, diagnosis.json) atomically.

    Parameters
    ----------
    d : Diagnosis
    path : path-like
        Target folder.

    Returns
    -------
    Path
        The folder.
    """
    rep = to_report(d)
    target = Path(path)
    with atomic_dir(target, "diagnose-report", option="--report") as tmp:
        mismatch, overlays, ranking, modes, json_name, index = REPORT_FILES
        _mismatch_map(d, tmp / mismatch)
        _overlays(d, tmp / overlays)
        _ranking(rep, tmp / ranking)
        _modes_fig(d, tmp / modes)
        (tmp / json_name).write_text(rep.model_dump_json(indent=2), encoding="utf-8")
        (tmp / index).write_text(_html(rep), encoding="utf-8")
    return target
