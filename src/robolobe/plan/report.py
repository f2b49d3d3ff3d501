"""Plan outputs: per-waypoint table, summary, plots and a self-contained HTML report.

:func:`write_outputs` writes, atomically (all files appear together or none),
into one directory:

- ``waypoints.csv``: the per-waypoint table (:func:`robolobe.plan.pipeline.plan_path`);
- ``summary.json``: MRR, cycle time, minimum margin and where, gains;
- ``plots/lobes.png``: lobes of chosen waypoints with their operating points;
- ``plots/speed_map.png``: waypoint x speed map of ``a_lim / (SF depth)``
  with the planned schedule;
- ``plots/path_margin.png``: the path in 3-D coloured by margin;
- ``plots/speed_power.png``: speed and power along the cutting length;
- ``report.html``: one file with the summary, the plots (embedded) and the
  tightest waypoints.

Plots use matplotlib's object API (:class:`matplotlib.figure.Figure` with the
Agg canvas), so nothing global is touched and workers may plot in parallel.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import TwoSlopeNorm
from matplotlib.figure import Figure

from robolobe._atomic import atomic_dir
from robolobe.plan.pipeline import PlanResult

__all__ = [
    "PLOTS",
    "plot_lobes",
    "plot_path_margin",
    "plot_speed_map",
    "plot_speed_power",
    "render_html",
    "write_csv",
    "write_outputs",
]

PLOTS: tuple[str, ...] = ("lobes", "speed_map", "path_margin", "speed_power")


def write_csv(df: pd.DataFrame, path: Path) -> None:
    """Write a table as CSV (pyarrow's writer when installed: ~6x faster, full precision)."""
    try:
        import pyarrow as pa
        import pyarrow.csv as pacsv
    except ImportError:  # pragma: no cover - pyarrow is an extra
        df.to_csv(path, index=False, float_format="%.9g")
        return
    table = pa.Table.from_pandas(df, preserve_index=False)
    pacsv.write_csv(table, path, write_options=pacsv.WriteOptions(quoting_style="needed"))


def _png(fig: Figure) -> bytes:
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _chosen(res: PlanResult, n: int = 4) -> list[int]:
    """Cutting waypoints (indices into the cut arrays) to show: tightest, then spread out."""
    best = res.outcome.best
    g = res.lobes.table.group
    ok = np.isfinite(best.margin) & (g < res.lobes.n_groups)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return []
    out = [int(idx[np.argmin(best.margin[idx])])]
    for k in np.linspace(0, idx.size - 1, 6).astype(int):
        c = int(idx[k])
        if all(g[c] != g[o] for o in out):
            out.append(c)
        if len(out) >= n:
            break
    return out


def plot_lobes(res: PlanResult) -> Figure:
    """Lobes (limiting depth vs speed) of chosen waypoints, with the operating points."""
    best = res.outcome.best
    tab = res.lobes.table
    sf = res.job.plan.safety_factor
    fig = Figure(figsize=(8, 4.8))
    ax = fig.add_subplot()
    chosen = _chosen(res)
    depth = best.depth_m * 1e3
    top = 4 * sf * depth if depth > 0 else 1.0
    for c in chosen:
        row = tab.a_lim[tab.group[c]] * 1e3
        i = int(res.cut_index[c])
        label = f"{res.table['source'].iloc[i]}:{int(res.table['line'].iloc[i])} (waypoint {i})"
        (line,) = ax.plot(tab.rpm, np.minimum(row, 10 * top), lw=1.2, label=f"a_lim at {label}")
        ax.plot([best.rpm[c]], [depth], "o", color=line.get_color(), ms=6)
    ax.axhline(depth, color="k", lw=0.8, ls="--", label=f"depth {depth:.3g} mm")
    ax.axhline(depth * sf, color="k", lw=0.8, ls=":", label=f"depth x SF {sf:g}")
    ax.set_ylim(0, top)
    ax.set_xlim(tab.rpm[0], tab.rpm[-1])
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("limiting depth a_lim [mm]")
    ax.set_title("Stability lobes with operating points (dots)")
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    return fig


def plot_speed_map(res: PlanResult, max_rows: int = 1500) -> Figure:
    """Waypoint x speed map of ``a_lim / (SF depth)`` (log2) with the planned speeds."""
    best = res.outcome.best
    tab = res.lobes.table
    sf = res.job.plan.safety_factor
    n = tab.n_cut
    step = max(1, int(np.ceil(n / max_rows)))
    rows = np.arange(0, n, step)
    ratio = tab.a_lim[tab.group[rows]] / (sf * max(best.depth_m, 1e-12))
    z = np.log2(np.clip(ratio, 0.25, 4.0))
    fig = Figure(figsize=(8, 4.8))
    ax = fig.add_subplot()
    im = ax.imshow(
        z.T,
        origin="lower",
        aspect="auto",
        extent=(rows[0] - 0.5, rows[-1] + 0.5, tab.rpm[0], tab.rpm[-1]),
        cmap="RdYlGn",
        norm=TwoSlopeNorm(vcenter=0.0, vmin=-2.0, vmax=2.0),
        interpolation="nearest",
    )
    ax.plot(np.arange(n), best.rpm, color="k", lw=1.2, label="planned speed")
    if res.outcome.constant is not None:
        ax.axhline(
            float(res.outcome.constant.rpm[0]), color="b", lw=0.8, ls="--", label="best constant"
        )
    cb = fig.colorbar(im, ax=ax)
    cb.set_label("log2( a_lim / (SF x depth) ): > 0 stable")
    ax.set_xlabel("cutting waypoint")
    ax.set_ylabel("spindle speed [rpm]")
    ax.set_title(f"Stability map at depth {best.depth_m * 1e3:.3g} mm")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


def plot_path_margin(res: PlanResult) -> Figure:
    """The path in 3-D (workpiece frame), cutting waypoints coloured by margin."""
    t = res.table
    fig = Figure(figsize=(7, 5.5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(t["x_mm"], t["y_mm"], t["z_mm"], color="0.7", lw=0.5)
    cut = np.isfinite(t["margin"].to_numpy())
    sc = ax.scatter(
        t["x_mm"][cut], t["y_mm"][cut], t["z_mm"][cut], c=t["margin"][cut], cmap="viridis", s=6
    )
    cb = fig.colorbar(sc, ax=ax, shrink=0.7)
    cb.set_label("margin a_lim / depth")
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_zlabel("z [mm]")
    ax.set_title("Path coloured by stability margin")
    return fig


def plot_speed_power(res: PlanResult) -> Figure:
    """Speed and cutting power along the cutting length."""
    o = res.outcome
    s = res.geom.s_m
    fig = Figure(figsize=(8, 5))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    ax1.plot(s, o.best.rpm, "k", lw=1.2, label=f"plan ({o.best.method})")
    if o.constant is not None:
        ax1.plot(s, o.constant.rpm, "b--", lw=0.8, label="best constant")
    if o.programmed is not None:
        ax1.plot(s, o.programmed.rpm, "r:", lw=0.8, label="programmed")
    ax1.set_ylabel("speed [rpm]")
    ax1.legend(fontsize=7)
    ax2.plot(s, o.power_W * 1e-3, "k", lw=1.2)
    ax2.axhline(res.job.spindle.power_W * 1e-3, color="r", lw=0.8, ls="--", label="power limit")
    ax2.set_ylabel("cutting power [kW]")
    ax2.set_xlabel("cutting length [m]")
    ax2.legend(fontsize=7)
    fig.tight_layout()
    return fig


_PLOTTERS = {
    "lobes": plot_lobes,
    "speed_map": plot_speed_map,
    "path_margin": plot_path_margin,
    "speed_power": plot_speed_power,
}


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


def render_html(res: PlanResult, images: dict[str, bytes]) -> str:
    """The self-contained HTML report (PNG images embedded as base64)."""
    s = res.summary
    rows = [
        ("Path", s["path"]),
        ("Job", f"{s['job']} ({s['job_file']})"),
        ("Robot / modes", f"{s['robot']} / {s['mode_source']}"),
        ("Waypoints (cutting, plunges)", f"{s['n_waypoints']} ({s['n_cut']}, {s['n_plunge']})"),
        ("Depth per pass [mm]", s["depth_mm"]),
        ("Speed [rpm]", f"{s['rpm_min']:.0f} - {s['rpm_max']:.0f} ({s['speed_mode']})"),
        ("MRR [cm^3/min]", s["mrr_cm3_per_min"]),
        ("Cycle time [s]", s["cycle_time_s"]),
        ("Minimum margin", f"{s['min_margin']:.3f} at {s['min_margin_at']['source']}"),
        ("Method", f"{s['method']} (IPOPT: {s['nlp_status']})"),
    ]
    for key, name in (
        ("vs_best_constant_speed", "best constant speed"),
        ("vs_programmed_speed", "programmed speed"),
    ):
        g = s.get(key)
        if g:
            rows.append(
                (
                    f"Gain vs {name}",
                    f"MRR {_fmt(g.get('mrr_gain_pct'))} % (that plan: {g['depth_mm']} mm at "
                    f"{g['rpm_mean']:.0f} rpm, "
                    f"{'feasible' if g['feasible'] else 'infeasible: ' + g['reason']})",
                )
            )
    table = "\n".join(f"<tr><th>{html.escape(k)}</th><td>{_fmt(v)}</td></tr>" for k, v in rows)
    t = res.table
    cut = t[np.isfinite(t["margin"].to_numpy())]
    tight = cut.nsmallest(10, "margin")[
        [
            "source",
            "line",
            "x_mm",
            "y_mm",
            "z_mm",
            "rpm",
            "a_lim_mm",
            "margin",
            "limiting",
            "power_kW",
        ]
    ]
    tight_html = tight.to_html(index=True, float_format=lambda v: f"{v:.4g}", border=0)
    imgs = "\n".join(
        f'<figure><img alt="{k}" src="data:image/png;base64,{base64.b64encode(v).decode()}">'
        f"<figcaption>{html.escape(k)}</figcaption></figure>"
        for k, v in images.items()
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in s.get("notes", []))
    timing = ", ".join(f"{k} {v:.3g} s" for k, v in s.get("timings_s", {}).items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>robolobe plan: {html.escape(str(s["path"]))}</title>
<style>
body {{ font-family: sans-serif; max-width: 1000px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ padding: 3px 10px; border-bottom: 1px solid #ddd; text-align: left; font-size: 14px; }}
figure {{ margin: 1em 0; }} img {{ max-width: 100%; }}
</style></head><body>
<h1>robolobe plan</h1>
<table>{table}</table>
<h2>Notes</h2><ul>{notes or "<li>none</li>"}</ul>
<h2>Plots</h2>
{imgs}
<h2>Tightest waypoints</h2>
{tight_html}
<p><small>robolobe {html.escape(str(s["robolobe_version"]))};
timings: {html.escape(timing)}</small></p>
</body></html>
"""


def write_outputs(
    res: PlanResult,
    out_dir: str | os.PathLike[str],
    *,
    plots: bool = True,
    html_report: bool = True,
) -> Path:
    """Write the plan into ``out_dir`` atomically (see the module docstring).

    Parameters
    ----------
    res : PlanResult
    out_dir : path-like
        Created if missing; files of earlier runs that this run does not
        write are left alone.
    plots, html_report : bool
        Write the PNG plots and the HTML report.

    Returns
    -------
    Path
        ``out_dir``.
    """
    out = Path(out_dir)
    images: dict[str, bytes] = {}
    if plots or html_report:
        for name in PLOTS:
            images[name] = _png(_PLOTTERS[name](res))
    with atomic_dir(out) as tmp:
        write_csv(res.table, tmp / "waypoints.csv")
        (tmp / "summary.json").write_text(
            json.dumps(res.summary, indent=2) + "\n", encoding="utf-8"
        )
        if plots:
            (tmp / "plots").mkdir()
            for name, data in images.items():
                (tmp / "plots" / f"{name}.png").write_bytes(data)
        if html_report:
            (tmp / "report.html").write_text(render_html(res, images), encoding="utf-8")
    return out
