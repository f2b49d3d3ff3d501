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
import json
import logging
import os
from collections.abc import Callable, Collection
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._atomic import atomic_dir
from robolobe._memory import RELEASE_MIN_ROWS, large_blocks_mapped, release_free_memory
from robolobe._text import html_text, visible
from robolobe.plan import _plots
from robolobe.plan._plots import PlotWorker
from robolobe.plan.pipeline import PlanResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "CAPTIONS",
    "OUTPUTS",
    "PLOTS",
    "output_files",
    "plot_lobes",
    "plot_path_margin",
    "plot_speed_map",
    "plot_speed_power",
    "render_html",
    "write_csv",
    "write_outputs",
]

PLOTS: tuple[str, ...] = ("lobes", "speed_map", "path_margin", "speed_power")
#: The top-level names a plan writes into its folder (replaced as a set).
OUTPUTS: tuple[str, ...] = (
    "waypoints.csv",
    "waypoints.parquet",
    "summary.json",
    "plots",
    "report.html",
    # the program written back (plan/program.py); KRL writes its .dat beside it
    "program.nc",
    "program.apt",
    "program.src",
    "program.dat",
    "program.mod",
    "program.csv",
)
#: What ``write_outputs(waypoints=...)`` accepts.
WAYPOINT_FORMATS: tuple[str, ...] = ("csv", "parquet", "none")


def output_files(
    *, plots: bool = True, html_report: bool = True, waypoints: str = "csv"
) -> tuple[str, ...]:
    """The files (relative POSIX paths) :func:`write_outputs` writes with these options."""
    files = ["summary.json"]
    if waypoints in ("csv", "parquet"):
        files.append(f"waypoints.{waypoints}")
    if plots:
        files += [f"plots/{name}.png" for name in PLOTS]
    if html_report:
        files.append("report.html")
    return tuple(files)


FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


#: Rows converted to Arrow and written at a time by :func:`write_csv` (a million-row
#: table is not converted whole: its validity masks and string columns were ~50 bytes a
#: row above the table while the file was written).
CSV_BLOCK_ROWS = 65_536


def write_csv(df: pd.DataFrame, path: Path, *, block_rows: int = CSV_BLOCK_ROWS) -> None:
    """Write a table as CSV (pyarrow's writer when installed: ~6x faster, full precision).

    The rows go to the file ``block_rows`` at a time under one schema, the
    one pyarrow infers from the whole table, so the file is byte for byte the
    one a single conversion of the whole table writes.

    Parameters
    ----------
    df : pandas.DataFrame, shape (n, m)
        The table; its index is not written.
    path : Path
        The file (written directly: callers write into a temporary folder).
    block_rows : int
        Rows converted and written at a time (>= 1).
    """
    try:
        import pyarrow as pa
        import pyarrow.csv as pacsv
    except ImportError:  # pragma: no cover - pyarrow is an extra
        df.to_csv(path, index=False, float_format="%.9g")
        return
    schema = pa.Schema.from_pandas(df, preserve_index=False)
    options = pacsv.WriteOptions(quoting_style="needed")
    step = max(1, int(block_rows))
    with pacsv.CSVWriter(path, schema, write_options=options) as writer:
        for lo in range(0, len(df), step):
            block = df.iloc[lo : lo + step]
            writer.write_table(pa.Table.from_pandas(block, schema=schema, preserve_index=False))


#: Characters encoded and written at a time by :func:`write_text_blocks`.
TEXT_BLOCK_CHARS = 1 << 20


def write_text_blocks(path: Path, text: str, *, block_chars: int = TEXT_BLOCK_CHARS) -> None:
    """``path.write_text(text, encoding="utf-8")``, encoded ``block_chars`` at a time.

    The same file (the same newline translation), without an encoded copy of
    a long program's whole text beside the text.
    """
    step = max(1, int(block_chars))
    with open(path, "w", encoding="utf-8") as f:
        for lo in range(0, len(text), step):
            f.write(text[lo : lo + step])


def require_pyarrow(what: str) -> None:
    """Refuse up front (before any work) when Parquet is asked for without pyarrow."""
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        from robolobe.errors import InputError

        raise InputError(
            f"{what}: Parquet needs pyarrow (pip install 'robolobe[parquet]'), or write CSV"
        ) from None


def thin_rows(table: pd.DataFrame, every: int) -> pd.DataFrame:
    """Every ``every``-th row of a plan's table, each the tightest of its block.

    The rows are cut into blocks of ``every``; from each block the row with
    the smallest margin is kept (the first row where no row cuts), so the
    thinned table still holds the path's tightest waypoint. The ``line``
    column tells where each row sits in the path.
    """
    if every <= 1 or len(table) == 0:
        return table
    n = len(table)
    every = min(int(every), n)  # a block longer than the table is the table
    margin = table["margin"].to_numpy(dtype=np.float64)
    key = np.where(np.isfinite(margin), margin, np.inf)
    pad = (-n) % every
    blocks = np.r_[key, np.full(pad, np.inf)].reshape(-1, every)
    pick = np.argmin(blocks, axis=1) + np.arange(blocks.shape[0]) * every
    return table.iloc[np.minimum(pick, n - 1)].reset_index(drop=True)


def _write_waypoints(table: pd.DataFrame, folder: Path, fmt: str, every: int) -> None:
    if fmt not in WAYPOINT_FORMATS:
        from robolobe.errors import InputError

        raise InputError(f"waypoints: expected one of {WAYPOINT_FORMATS}, found {fmt!r}")
    if fmt == "none":
        return
    rows = thin_rows(table, every)
    if fmt == "parquet":
        require_pyarrow("waypoints")
        rows.to_parquet(folder / "waypoints.parquet", index=False)
    else:
        write_csv(rows, folder / "waypoints.csv")


def _chosen(res: PlanResult, n: int = 3) -> list[int]:
    """Waypoints whose lobes to show (indices into the cut arrays).

    The tightest waypoint first; then, of the other waypoints, those whose
    lobes differ most from the ones already shown (mean absolute log ratio
    over the speed grid, at least 5 %), so the figure shows the range of
    dynamics along the path instead of near-copies of one curve.
    """
    best = res.outcome.best
    tab = res.lobes.table
    g = tab.group
    ok = np.isfinite(best.margin) & (g < res.lobes.n_groups)
    idx = np.flatnonzero(ok)
    if idx.size == 0:
        return []
    out = [int(idx[np.argmin(best.margin[idx])])]
    # one candidate per group: its tightest waypoint
    order = idx[np.argsort(best.margin[idx], kind="stable")]
    _, first = np.unique(g[order], return_index=True)
    cand = order[np.sort(first)]
    with np.errstate(divide="ignore", invalid="ignore"):
        log_a = np.log(np.clip(tab.a_lim, 1e-9, 1e3))
    rows = log_a[g[cand]]
    dist = np.full(cand.size, np.inf)
    while len(out) < n:
        # distance of each candidate to the nearest curve shown (updated by the newest)
        dist = np.minimum(dist, np.mean(np.abs(rows - log_a[g[out[-1]]]), axis=1))
        j = int(np.argmax(dist)) if dist.size else -1
        if j < 0 or dist[j] < 0.05:
            break
        out.append(int(cand[j]))
    return out


def _where(res: PlanResult, c: int) -> str:
    i = int(res.cut_index[c])
    return f"{res.table['source'].iloc[i]}:{int(res.table['line'].iloc[i])}"


def _lobes_data(res: PlanResult) -> _plots.LobesData:
    best = res.outcome.best
    tab = res.lobes.table
    sf = res.job.plan.safety_factor
    chosen = _chosen(res)
    depth = best.depth_m * 1e3
    # Show the operating region: up to a few times the limit the plan keeps,
    # and at least every chosen waypoint's limit at its planned speed.
    a_op = [
        float(tab.a_lim[tab.group[c], np.argmin(np.abs(tab.rpm - best.rpm[c]))]) * 1e3
        for c in chosen
    ]
    finite = [a for a in a_op if np.isfinite(a)]
    top = max([3.0 * sf * depth, *(1.15 * a for a in finite)]) if depth > 0 else 1.0
    labels = []
    for rank, c in enumerate(chosen):
        label = f"{_where(res, c)}, waypoint {int(res.cut_index[c])} (margin {best.margin[c]:.2f})"
        labels.append(label + (", tightest" if rank == 0 else ""))
    return _plots.LobesData(
        rpm=np.asarray(tab.rpm, np.float64),
        curves_mm=np.asarray(tab.a_lim[tab.group[chosen]] * 1e3, np.float64).reshape(
            len(chosen), -1
        ),
        labels=tuple(labels),
        dot_rpm=np.asarray(best.rpm[chosen], np.float64),
        depth_mm=float(depth),
        safety_factor=float(sf),
        top_mm=float(top),
    )


def _speed_map_data(res: PlanResult, max_rows: int = 1500) -> _plots.SpeedMapData:
    best = res.outcome.best
    tab = res.lobes.table
    sf = res.job.plan.safety_factor
    n = tab.n_cut
    step = max(1, int(np.ceil(n / max_rows)))
    rows = np.arange(0, n, step)
    ratio = tab.a_lim[tab.group[rows]] / (sf * max(best.depth_m, 1e-12))
    const = res.outcome.constant
    return _plots.SpeedMapData(
        rows=rows,
        z=np.log2(np.clip(ratio, 0.25, 4.0)),
        rpm_lo=float(tab.rpm[0]),
        rpm_hi=float(tab.rpm[-1]),
        planned_rpm=np.asarray(best.rpm, np.float64),
        constant_rpm=None if const is None else float(const.rpm[0]),
        depth_mm=float(best.depth_m * 1e3),
    )


def _path_margin_data(res: PlanResult) -> _plots.PathMarginData:
    t = res.table
    return _plots.PathMarginData(
        x_mm=t["x_mm"].to_numpy(dtype=np.float64),
        y_mm=t["y_mm"].to_numpy(dtype=np.float64),
        margin=t["margin"].to_numpy(dtype=np.float64),
        tightest=int(res.summary.min_margin_at.waypoint),
        safety_factor=float(res.job.plan.safety_factor),
    )


def _speed_power_data(res: PlanResult) -> _plots.SpeedPowerData:
    o = res.outcome
    return _plots.SpeedPowerData(
        s_mm=res.geom.s_m * 1e3,
        rpm=np.asarray(o.best.rpm, np.float64),
        method=str(o.best.method),
        constant_rpm=None if o.constant is None else np.asarray(o.constant.rpm, np.float64),
        programmed_rpm=None if o.programmed is None else np.asarray(o.programmed.rpm, np.float64),
        power_kW=o.power_W * 1e-3,
        power_limit_kW=float(res.job.spindle.power_W * 1e-3),
    )


def plot_lobes(res: PlanResult) -> Figure:
    """Lobes of the tightest distinct waypoints, each with its operating point."""
    return _plots.draw_lobes(_lobes_data(res))


def plot_speed_map(res: PlanResult, max_rows: int = 1500) -> Figure:
    """Waypoint x speed map of ``a_lim / (SF depth)`` (log2) with the planned speeds."""
    return _plots.draw_speed_map(_speed_map_data(res, max_rows))


def plot_path_margin(res: PlanResult) -> Figure:
    """Top view (x-y, workpiece frame) of the path, cutting moves coloured by margin."""
    return _plots.draw_path_margin(_path_margin_data(res))


def plot_speed_power(res: PlanResult) -> Figure:
    """Speed and cutting power along the cutting length."""
    return _plots.draw_speed_power(_speed_power_data(res))


#: The record builder of each plot (what the figure shows, drawn by :mod:`._plots`).
_DATA: dict[str, Callable[[PlanResult], Any]] = {
    "lobes": _lobes_data,
    "speed_map": _speed_map_data,
    "path_margin": _path_margin_data,
    "speed_power": _speed_power_data,
}
_PLOTTERS = {
    "lobes": plot_lobes,
    "speed_map": plot_speed_map,
    "path_margin": plot_path_margin,
    "speed_power": plot_speed_power,
}


#: What to read from each figure (the report's captions).
CAPTIONS: dict[str, str] = {
    "lobes": (
        "Limiting depth of cut against spindle speed at the tightest waypoint and at the "
        "waypoints whose dynamics differ most from it. Everything below a curve is stable at "
        "that waypoint; each dot "
        "is the planned speed and depth, and its height under the curve is the margin. Curves "
        "that rise steadily with speed are the zeroth lobe of the robot's own low-frequency "
        "modes (the spindle turns far faster than they vibrate); the peaked lobes come from the "
        "spindle, holder and tool modes."
    ),
    "speed_map": (
        "Stability along the path: for every cutting waypoint (x) and spindle speed (y), green "
        "where the limit exceeds the planned depth times the safety factor, red where it does "
        "not. The black line is the planned speed, which must stay in green; the dashed line the "
        "best single speed."
    ),
    "path_margin": (
        "The path seen from above in the workpiece frame, each cutting move coloured by its "
        "margin (limiting depth / planned depth). Orange moves run at the safety factor, the "
        "plan's own limit; green ones have depth to spare; red would chatter or break the "
        "safety factor. The cross marks the tightest waypoint."
    ),
    "speed_power": (
        "Planned spindle speed (top) and cutting power (bottom) along the cutting length, with "
        "the best constant and the programmed speed for comparison and the spindle's power "
        "limit."
    ),
}


def _fmt(v: Any) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html_text(str(v))


def _shown_path(path: str | None, base: Path | None) -> str:
    """A file name as the report shows it: relative to the report, never a home path."""
    if not path or path.startswith("<"):
        return path or "-"
    p = Path(path)
    try:
        from importlib import resources

        bundled = Path(str(resources.files("robolobe.data").joinpath("examples")))
        if p.resolve().is_relative_to(bundled.resolve()):
            return f"{p.name} (bundled example)"
    except (OSError, ValueError):  # pragma: no cover - unusual package layouts
        pass
    if base is not None and p.is_absolute():
        rel = os.path.relpath(p, base.resolve())
        if rel.count("..") <= 2:
            return rel
    return p.name if p.is_absolute() else str(p)


def _tightest(res: PlanResult, n: int = 10) -> pd.DataFrame:
    """The ``n`` tightest cutting waypoints, one row per distinct position (0.1 mm)."""
    t = res.table
    cut = t[np.isfinite(t["margin"].to_numpy())]
    cols = ["source", "line", "x_mm", "y_mm", "z_mm", "rpm", "a_lim_mm", "margin", "limiting"]
    cols += [c for c in ("power_kW",) if c in cut.columns]
    order = cut.sort_values("margin", kind="stable")
    pos = order[["x_mm", "y_mm", "z_mm"]].round(1)
    return order.loc[~pos.duplicated(), cols].head(n)


def render_html(
    res: PlanResult,
    images: dict[str, bytes],
    base: str | os.PathLike[str] | None = None,
    *,
    program: dict[str, str] | None = None,
) -> str:
    """The self-contained HTML report (PNG images embedded as base64).

    Parameters
    ----------
    res : PlanResult
    images : dict of str to bytes
        PNG images by plot name (:data:`PLOTS`).
    base : path-like, optional
        Folder the report is written to; file names are shown relative to it.
    program : dict of str to str, optional
        The program files written beside the report: a section lists where
        the program's S, F or passes change and links the file.
    """
    return _with_images(_report_parts(res, base, program), images)


def _with_images(parts: tuple[str, str], images: dict[str, bytes]) -> str:
    """The report page: its text before and after the plots, with the PNGs between."""
    imgs = "\n".join(
        f'<figure><img alt="{html_text(k)}" '
        f'src="data:image/png;base64,{base64.b64encode(v).decode()}">'
        f"<figcaption>{html_text(CAPTIONS.get(k, k))}</figcaption></figure>"
        for k, v in images.items()
    )
    return parts[0] + imgs + parts[1]


def _report_parts(
    res: PlanResult, base: str | os.PathLike[str] | None, program: Collection[str] | None
) -> tuple[str, str]:
    """The report page before and after its plots (:func:`render_html`).

    Apart so that :func:`write_outputs` composes them while the plot workers
    draw (the tables are about 20 ms of a report).
    """
    s = res.summary
    b = Path(base) if base is not None else None
    where = s.min_margin_at
    rows = [
        ("Path", _shown_path(s.path, b)),
        ("Job", f"{s.job} ({_shown_path(s.job_file, b)})"),
        ("Robot / modes", f"{s.robot} / {s.mode_source}"),
        ("Waypoints (cutting, plunges)", f"{s.n_waypoints} ({s.n_cut}, {s.n_plunge})"),
        ("Depth per pass [mm]", f"{s.depth_mm:.3f}"),
        ("Speed [rpm]", f"{s.rpm_min:.0f} - {s.rpm_max:.0f} ({s.speed_mode})"),
        ("MRR [cm^3/min]", f"{s.mrr_cm3_per_min:.1f}"),
        ("Cycle time [s]", f"{s.cycle_time_s:.2f}"),
        (
            "Minimum margin",
            f"{s.min_margin:.3f} (safety factor {s.safety_factor:g}) at "
            f"{where.source}, x {where.x_mm:.1f} y {where.y_mm:.1f} "
            f"z {where.z_mm:.1f} mm, {where.rpm:.0f} rpm",
        ),
        ("Method", f"{s.method} (IPOPT: {s.nlp_status})"),
    ]
    if s.robust:
        rb = s.robust_bound
        text = rb.statement if rb is not None else f"k_sigma {s.k_sigma}"
        if rb is not None and rb.spread_from:
            text += f"; spread: {rb.spread_from}"
        if s.robust_by_default:
            text += " (robust by default: the job does not set plan.robust)"
        rows.append(("Robust plan", text))
    for g, name in (
        (s.vs_best_constant_speed, "best constant speed"),
        (s.vs_programmed_speed, "programmed speed"),
    ):
        if g is not None:
            rows.append(
                (
                    f"Gain vs {name}",
                    f"MRR {_fmt(g.mrr_gain_pct)} % (that plan: {g.depth_mm} mm at "
                    f"{g.rpm_mean:.0f} rpm, "
                    f"{'feasible' if g.feasible else 'infeasible: ' + g.reason})",
                )
            )
    if s.passes:
        rows[4] = ("Engagement", f"each move's own on the {s.engagement}, in passes (below)")
    else:
        rows[4] = ("Depth per pass [mm]", f"{s.depth_mm:.3f} (cut.radial_width_mm: one width)")
    table = "\n".join(
        f"<tr><th>{html_text(k)}</th><td>{html_text(str(v))}</td></tr>" for k, v in rows
    )
    tight = _tightest(res)
    tight["source"] = tight["source"].map(visible)  # to_html escapes HTML, not controls
    tight_html = tight.to_html(
        index=False,
        border=0,
        formatters={
            "rpm": lambda v: f"{v:.0f}",
            "x_mm": lambda v: f"{v:.1f}",
            "y_mm": lambda v: f"{v:.1f}",
            "z_mm": lambda v: f"{v:.1f}",
            "a_lim_mm": lambda v: f"{v:.3f}",
            "margin": lambda v: f"{v:.3f}",
            "power_kW": lambda v: f"{v:.2f}",
        },
    )
    notes = "".join(f"<li>{html_text(n)}</li>" for n in s.notes)
    timing = ", ".join(f"{k} {v:.3g} s" for k, v in s.timings_s.items())
    before = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>robolobe plan: {html_text(_shown_path(s.path, b))}</title>
<style>
body {{ font-family: sans-serif; max-width: 1000px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ padding: 3px 10px; border-bottom: 1px solid #ddd; text-align: left; font-size: 14px; }}
figure {{ margin: 1.5em 0; }} img {{ max-width: 100%; }}
figcaption {{ font-size: 14px; color: #444; max-width: 800px; }}
</style></head><body>
<h1>robolobe plan</h1>
{_program_sections_html(res)}
<table>{table}</table>
<h2>Notes</h2><ul>{notes or "<li>none</li>"}</ul>
<h2>Plots</h2>
"""
    after = f"""
<h2>Tightest waypoints</h2>
<p>The cutting waypoints with the smallest margin, one row per position.</p>
{tight_html}
{_program_html(res, program)}
<p><small>robolobe {html_text(s.robolobe_version)};
timings: {html_text(timing)}</small></p>
</body></html>
"""
    return before, after


def _program_sections_html(res: PlanResult, n: int = 20) -> str:
    """The "What to program" section: per program section S, F, passes, limit, margin."""
    s = res.summary
    deep = [r for r in s.passes if r["program_depth_mm"] > 0]
    if not deep:
        return ""
    tab = res.table
    cut = tab["motion"] == "cut"
    rows = []
    for r in deep[:n]:
        sel = cut & (tab["section"] == r["section"])
        lim = tab.loc[sel, "limiting"].value_counts()
        feed = tab.loc[sel, "feed_mm_per_min"]
        rows.append(
            "<tr>"
            + "".join(
                f"<td>{html_text(str(v))}</td>"
                for v in (
                    r["lines"],
                    f"{r['rpm_min']:.0f}"
                    + (f"-{r['rpm_max']:.0f}" if r["rpm_max"] > r["rpm_min"] + 0.5 else ""),
                    f"{feed.min():.0f}"
                    + (f"-{feed.max():.0f}" if feed.max() > feed.min() + 0.5 else ""),
                    r["passes"],
                    f"{r['depth_per_pass_mm']:.3f} of {r['program_depth_mm']:.3f}",
                    ", ".join(str(k) for k in lim.index[:2]),
                    "-" if r["min_margin"] is None else f"{r['min_margin']:.3f}",
                    r["set_by"] or "-",
                )
            )
            + "</tr>"
        )
    more = f"<p>... and {len(deep) - n} more sections (summary.json).</p>" if len(deep) > n else ""
    head = "".join(
        f"<th>{h}</th>"
        for h in (
            "Program lines",
            "S [rpm]",
            "F [mm/min]",
            "Passes",
            "Depth per pass [mm]",
            "Binding limit",
            "Min margin",
            "Passes set by",
        )
    )
    return (
        "<h2>What to program</h2><p>Per section of the program (a run of cutting moves "
        "between rapids, repeated per pass, each pass shifted up the tool axis by the depth "
        f"per pass): each move planned at its own engagement and depth on the {s.engagement}, "
        f"safety factor {s.safety_factor:g}.</p>"
        f"<table><tr>{head}</tr>{''.join(rows)}</table>{more}"
    )


def _program_html(res: PlanResult, program: Collection[str] | None, n: int = 30) -> str:
    """The report's "Program" section: changed S/F/pass lines and a link to the first file.

    ``program``: the names of the program files written (or a mapping with them as keys).
    """
    if not program:
        return ""
    from robolobe.plan.program import program_changes

    ch = program_changes(res)
    name = next(iter(program))
    shown = ch.head(n).rename(
        columns={
            "rpm_old": "S old [rpm]",
            "rpm_new": "S new [rpm]",
            "feed_old": "F old [mm/min]",
            "feed_new": "F new [mm/min]",
        }
    )
    for c in shown.columns:
        if not pd.api.types.is_numeric_dtype(shown[c]):
            shown[c] = shown[c].map(visible)  # to_html escapes HTML, not controls
    body = shown.to_html(
        index=False,
        border=0,
        na_rep="-",
        float_format=lambda v: f"{v:.6g}",
    )
    more = f"<p>... and {len(ch) - n} more.</p>" if len(ch) > n else ""
    return (
        f'<h2>Program</h2><p>Written: <a href="{html_text(name)}">{html_text(name)}</a> '
        f"(changed blocks end with a ROBOLOBE comment). Blocks where the program's spindle "
        f"speed, feed or passes change ({len(ch)}):</p>{body}{more}"
    )


def write_outputs(
    res: PlanResult,
    out_dir: str | os.PathLike[str],
    *,
    plots: bool = True,
    html_report: bool = True,
    waypoints: str = "csv",
    waypoints_every: int = 1,
    worker: PlotWorker | None = None,
    option: str | None = None,
    program: bool = True,
    program_format: str | None = None,
) -> Path:
    """Write the plan into ``out_dir`` atomically (see the module docstring).

    Parameters
    ----------
    res : PlanResult
    out_dir : path-like
        Created if missing. The files of an earlier plan there (listed in
        its ``.robolobe-outputs.json``) that this run does not write are
        removed, so the folder holds one plan; other files are left alone,
        and a file robolobe did not write where this run writes one is
        refused (:func:`robolobe._atomic.atomic_dir`).
    plots, html_report : bool
        Write the PNG plots and the HTML report.
    waypoints : {"csv", "parquet", "none"}
        The per-waypoint table as ``waypoints.csv``, ``waypoints.parquet``
        (needs pyarrow; refused before anything is written) or not at all
        (long paths: the summary and plots still cover every waypoint).
    waypoints_every : int
        Write one row per block of this many waypoints, the tightest of the
        block (:func:`thin_rows`); 1 writes every waypoint.
    worker : PlotWorker, optional
        A plot process started before planning (:class:`PlotWorker`): it draws
        the plots while the tables are written, on another core. The same PNGs
        as drawn here; drawn here if the worker fails.
    option : str, optional
        The option that named ``out_dir``, for messages.
    program : bool
        Also write the program with the plan's speeds, feeds and passes
        (``program.<ext>``, :func:`robolobe.plan.program.program_text`) when
        the plan read a program file whose dialect has a writer.
    program_format : str, optional
        Dialect of that program (default: the one read); refused, before
        anything is written, where no translation is defined.

    Returns
    -------
    Path
        ``out_dir``.
    """
    from robolobe.errors import InputTypeError

    if not isinstance(res, PlanResult):
        raise InputTypeError("res", "a PlanResult (from plan_path)", res)
    if not isinstance(out_dir, str | os.PathLike):
        raise InputTypeError("out_dir", "a folder's path", out_dir)
    out = Path(out_dir)
    if waypoints == "parquet":
        require_pyarrow("waypoints")
    if int(waypoints_every) < 1:
        from robolobe.errors import InputError

        raise InputError(f"waypoints_every: expected an integer >= 1, found {waypoints_every!r}")
    records = {name: _DATA[name](res) for name in PLOTS} if plots or html_report else {}
    if worker is not None and records:
        # drawn there while the program, the tables and the report's text are made here
        worker.send(records)
    # a long plan's large blocks mapped: each goes back when freed (robolobe._memory)
    with large_blocks_mapped(len(res.table) >= RELEASE_MIN_ROWS):
        release_free_memory(len(res.table))  # the plan's temporaries: not under the writers' peaks
        program_files = _program_files(res, program, program_format)
        release_free_memory(len(res.table))
        with atomic_dir(out, "plan", option=option) as tmp:
            # the program first: each text goes once written (not held while the table is)
            program_names = list(program_files)
            for name in program_names:
                write_text_blocks(tmp / name, program_files.pop(name))
            _write_waypoints(res.table, tmp, waypoints, int(waypoints_every))
            (tmp / "summary.json").write_text(
                json.dumps(res.summary.to_dict(), indent=2) + "\n", encoding="utf-8"
            )
            page = _report_parts(res, out, program_names) if html_report else None
            got = worker.receive() if worker is not None and records else None
            if got is None or set(got) != set(records):
                got = {name: _plots.png(_plots.draw(rec)) for name, rec in records.items()}
            images = {name: got[name] for name in records}  # the report's order: PLOTS
            if plots:
                (tmp / "plots").mkdir()
                for name, data in images.items():
                    (tmp / "plots" / f"{name}.png").write_bytes(data)
            if page is not None:
                (tmp / "report.html").write_text(_with_images(page, images), encoding="utf-8")
    return out


def _program_files(res: PlanResult, program: bool, fmt: str | None) -> dict[str, str]:
    """The program files to write with the plan (none for a table given in memory)."""
    if not program or (fmt is None and res.path in ("<table>", "")):
        return {}
    from robolobe.plan.paths import detect_format
    from robolobe.plan.program import PROGRAM_DEFAULTS, IncompleteProgramError, program_text

    read_fmt = detect_format(res.path) if Path(res.path).is_file() else None
    opts = {**PROGRAM_DEFAULTS, **res.job.program_options}
    if (
        fmt is None
        and read_fmt in ("krl", "rapid")
        and (opts["analog_output"] is None or opts["analog_rpm_full_scale"] is None)
    ):
        # asked for implicitly: the plan stands without it (explicitly: refused by key)
        logging.getLogger(__name__).warning(
            "%s: no program written: a %s program sets the spindle speed by an analog output; "
            "give [program] analog_output and analog_rpm_full_scale in the job",
            Path(res.path).name,
            read_fmt.upper() if read_fmt == "krl" else "RAPID",
        )
        return {}
    try:
        return dict(program_text(res, fmt))
    except IncompleteProgramError as exc:
        if fmt is not None:
            raise  # asked for explicitly: refused
        # a program without its end is planned (its reader warned) but not written back
        logging.getLogger(__name__).warning("no program written: %s", exc)
        return {}
