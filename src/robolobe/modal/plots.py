"""Plots of an identification: stabilization diagrams and measured-vs-synthesized FRFs (PNG).

Matplotlib with the non-interactive Agg backend; one figure per posture.
"""

from __future__ import annotations

import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from numpy.typing import NDArray

from robolobe._atomic import SafeNames, unique_names
from robolobe._directions import AXES
from robolobe._text import count, plot_text
from robolobe.modal.measurement import MeasurementModal
from robolobe.modal.posture import PostureModal
from robolobe.modal.stabilization import StabilizationDiagram
from robolobe.modal.synthesis import poles_to_modal, synthesize_frf

__all__ = [
    "not_written",
    "plot_frf_overlay",
    "plot_measurement",
    "plot_stabilization",
    "posture_plot_names",
    "save_posture_plots",
]

_SAFE = re.compile(r"[^A-Za-z0-9_.\-]+")


def _figure(figsize: tuple[float, float]) -> Figure:
    return Figure(figsize=figsize, layout="constrained")


def _diagram_axes(
    ax: Any,
    dg: StabilizationDiagram | None,
    written_hz: NDArray[np.float64],
    others: Sequence[tuple[float, str]],
) -> None:
    """Stabilization diagram markers, solid lines at ``written_hz``, dotted ones at ``others``."""
    if dg is not None and dg.poles.size:
        f = dg.f_hz
        phys = dg.physical
        stab = dg.stable
        fonly = phys & dg.stable_f & ~stab
        other = phys & ~dg.stable_f
        ax.plot(f[other], dg.order[other], ".", color="0.7", ms=3, label="pole")
        ax.plot(f[fonly], dg.order[fonly], "+", color="tab:blue", ms=5, label="stable f")
        ax.plot(
            f[stab],
            dg.order[stab],
            "o",
            mfc="none",
            color="tab:green",
            ms=5,
            label="stable f, zeta, shape",
        )
    for i, fr in enumerate(written_hz):
        ax.axvline(fr, color="tab:red", lw=0.9, alpha=0.8, label="written" if i == 0 else None)
    kinds: set[str] = set()
    for fr, why in others:
        ax.axvline(
            fr,
            color="tab:orange" if why.startswith("negative") else "0.5",
            lw=0.9,
            ls=":",
            label=None if why in kinds else f"not written: {why}",
        )
        kinds.add(why)


def not_written(pm: PostureModal, rows: pd.DataFrame) -> list[tuple[float, str]]:
    """Fitted modes of a posture that are not in its modal-dataset rows, with the reason.

    Parameters
    ----------
    pm : PostureModal
    rows : pandas.DataFrame
        This posture's rows of the modal dataset (``f_hz`` corrected, as written).

    Returns
    -------
    list of (f_hz, reason)
        ``f_hz`` as seen in the measured (windowed) data, the abscissa of the
        stabilization diagram; reasons: a negative driving-point residue,
        outside the band, beyond ``n_modes`` per direction, not visible or
        imprecise.
    """
    s = pm.settings
    fm = poles_to_modal(pm.poles_measured)[0]
    wf = rows["f_hz"].to_numpy(float)
    is_w = np.array([bool(np.any(np.isclose(wf, x, rtol=1e-9))) for x in pm.f_hz], bool)
    neg = np.zeros(pm.n_modes, bool)
    seen = np.zeros(pm.n_modes, bool)
    for d in range(3):
        if pm.used[d, d]:
            neg[pm.negative_modes(d)] = True
            seen[pm.modes_for_direction(d)] = True
    in_band = (pm.f_hz >= s.fmin_hz) & (pm.f_hz <= s.fmax_hz)

    def why(i: int) -> str:
        if neg[i]:
            return "negative driving-point residue"
        if not in_band[i]:
            return "outside the band"
        if seen[i]:
            return f"beyond {s.n_modes} modes per direction"
        return "not visible or imprecise"

    return [(float(fm[i]), why(int(i))) for i in np.flatnonzero(~is_w)]


def plot_stabilization(
    pm: PostureModal, path: str | os.PathLike[str], rows: pd.DataFrame | None = None
) -> Path:
    """Stabilization diagram of one posture over the measured FRF magnitudes.

    Markers: ``o`` stable in frequency, damping and shape, ``+`` stable in
    frequency only, ``.`` other physical poles. Solid red lines: the modes
    written to the modal dataset (``rows``, this posture's rows of it);
    dotted lines: the other fitted poles with the reason they are not written
    (orange: a negative driving-point residue; grey: outside the band or not
    visible). Without ``rows`` every fitted pole is drawn solid.
    """
    fm = poles_to_modal(pm.poles_measured)[0]
    if rows is None:
        written = fm
        others: list[tuple[float, str]] = []
    else:
        others = not_written(pm, rows)
        written = np.array([x for x in fm if not any(x == o[0] for o in others)])
    s = pm.settings
    pid = plot_text(pm.posture_id, 40)
    title = f"posture {pid}: stabilization diagram ({written.size} modes written" + (
        f", {len(others)} fitted, not written)" if others else ")"
    )
    curves = [
        (pm.freq_hz, np.abs(pm.H[:, d, d]), f"|H_{AXES[d]}{AXES[d]}|")
        for d in range(3)
        if pm.H.size and pm.used[d, d]
    ]
    xlim = (s.fmin_hz * 0.5, s.fmax_hz * (1 + s.fit_margin))
    return _diagram_figure(pm.diagram, written, others, xlim, title, curves, path)


def _diagram_figure(
    dg: StabilizationDiagram | None,
    written: NDArray[np.float64],
    others: Sequence[tuple[float, str]],
    xlim: tuple[float, float],
    title: str,
    curves: Sequence[tuple[NDArray[np.float64], NDArray[np.float64], str]],
    path: str | os.PathLike[str],
) -> Path:
    """One stabilization-diagram PNG: markers, mode lines, |H| curves on a second axis."""
    fig = _figure((9.0, 5.0))
    ax = fig.add_subplot(1, 1, 1)
    _diagram_axes(ax, dg, written, others)
    ax.set_xlim(*xlim)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    ax.set_title(title)
    if curves:
        ax2 = ax.twinx()
        for f, mag, lab in curves:
            ax2.semilogy(f, mag, lw=0.8, alpha=0.6, label=lab)
        ax2.set_ylabel("|H| [m/N]")
        ax2.legend(loc="upper right", fontsize=7)
    ax.legend(loc="upper left", fontsize=7)
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out


def plot_measurement(mm: MeasurementModal, path: str | os.PathLike[str]) -> Path:
    """Stabilization diagram of a measurement over its FRF magnitudes (PNG).

    Solid red lines: the modes in the written table (every mode visible in
    some FRF, whatever the sign of its residues).
    """
    s = mm.settings
    written = poles_to_modal(mm.poles - s.window_decay_per_s)[0]
    xlim = (s.fmin_hz * 0.5, min(s.fmax_hz * (1 + s.fit_margin), float(mm.freq_hz[-1])))
    title = f"{mm.name}: stabilization diagram ({count(mm.n_modes, 'mode')} written)"
    curves = [(mm.freq_hz, np.abs(mm.H[:, j]), f"|H {lab}|") for j, lab in enumerate(mm.labels[:8])]
    return _diagram_figure(mm.diagram, written, [], xlim, title, curves, path)


def plot_frf_overlay(pm: PostureModal, rows: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Measured driving-point FRFs and those synthesized from the modal-dataset rows.

    Parameters
    ----------
    pm : PostureModal
    rows : pandas.DataFrame
        The modal-dataset rows of this posture (``dir, f_hz, zeta, k_N_per_m``).
    path : path-like
        PNG file.
    """
    dirs = [d for d in range(3) if pm.used[d, d]]
    fig = _figure((9.0, 2.6 * max(1, len(dirs))))
    f = pm.freq_hz
    decay = pm.settings.window_decay_per_s
    for k, d in enumerate(dirs):
        ax = fig.add_subplot(max(1, len(dirs)), 1, k + 1)
        ax.semilogy(f, np.abs(pm.H[:, d, d]), color="k", lw=1.0, label="measured")
        g = rows[rows["dir"] == AXES[d] * 2]
        if len(g):
            fn = g["f_hz"].to_numpy(float)
            z = g["zeta"].to_numpy(float)
            # as seen through the exponential window
            hp = synthesize_frf(fn, z, g["k_N_per_m"].to_numpy(float), f, window_decay_per_s=decay)
            ax.semilogy(
                f,
                np.abs(hp),
                color="tab:red",
                lw=1.0,
                ls="--",
                label=f"synthesized ({len(g)} modes)",
            )
            for x in fn:
                ax.axvline(x, color="tab:red", lw=0.5, alpha=0.4)
        ax.set_ylabel(f"|H_{AXES[d]}{AXES[d]}| [m/N]")
        ax.axvspan(f[0], pm.settings.fmin_hz, color="0.9")
        ax.axvspan(pm.settings.fmax_hz, f[-1] if f.size else pm.settings.fmax_hz, color="0.9")
        ax.legend(fontsize=7, loc="upper right")
    if dirs:
        fig.axes[-1].set_xlabel("frequency [Hz]")
        fig.axes[0].set_title(f"posture {plot_text(pm.posture_id, 40)}: measured vs synthesized")
    out = Path(path)
    fig.savefig(out, dpi=110)
    return out


def posture_plot_names(postures: Sequence[PostureModal]) -> SafeNames:
    """The file-name part of each posture's plots (:func:`save_posture_plots`), with notes.

    The posture id made a safe, distinct file name
    (:func:`robolobe._atomic.unique_names`); the notes name the ids written
    under another name.
    """
    return unique_names(
        [_SAFE.sub("_", pm.posture_id) for pm in postures],
        what="posture",
        fallback="posture",
        labels=[pm.posture_id for pm in postures],
    )


def save_posture_plots(
    postures: Sequence[PostureModal], table: pd.DataFrame, folder: str | os.PathLike[str]
) -> list[Path]:
    """Write ``stab_<posture>.png`` and ``frf_<posture>.png`` for every posture into ``folder``."""
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    groups = {pid: g for pid, g in table.groupby("posture_id", sort=False)}
    paths = []
    for pm, name in zip(postures, posture_plot_names(postures).names, strict=True):
        rows = groups.get(pm.posture_id, table.iloc[0:0])
        paths.append(plot_stabilization(pm, out / f"stab_{name}.png", rows))
        paths.append(plot_frf_overlay(pm, rows, out / f"frf_{name}.png"))
    return paths
