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
from typing import TYPE_CHECKING, Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._atomic import atomic_dir
from robolobe.plan.pipeline import PlanResult

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = [
    "CAPTIONS",
    "OUTPUTS",
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
#: The top-level names a plan writes into its folder (replaced as a set).
OUTPUTS: tuple[str, ...] = (
    "waypoints.csv",
    "waypoints.parquet",
    "summary.json",
    "plots",
    "report.html",
)
#: What ``write_outputs(waypoints=...)`` accepts.
WAYPOINT_FORMATS: tuple[str, ...] = ("csv", "parquet", "none")

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


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


def _png(fig: Figure) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110)
    return buf.getvalue()


def _margins(
    fig: Figure,
    *,
    left: float,
    right: float = 0.981,
    bottom: float = 0.122,
    top: float = 0.924,
    hspace: float | None = None,
) -> None:
    """Fixed margins (figure fractions) where ``tight_layout`` would measure every label.

    The values are what ``tight_layout`` chose on the bundled plans, with room
    for five-digit tick labels; measuring them cost about 40 % of a plot.
    """
    fig.subplots_adjust(left=left, right=right, bottom=bottom, top=top, hspace=hspace)


def _runs(x: FloatArray, y: FloatArray, cls: IntArray) -> tuple[list[FloatArray], IntArray]:
    """Polylines through consecutive moves of one class: the moves ``i -> i + 1`` of
    class ``cls[i]`` (-1: not drawn) joined while the class stays the same.

    Returns each run's (k, 2) vertices and its class.
    """
    if cls.size == 0:
        return [], np.zeros(0, np.int64)
    cut = np.flatnonzero(np.diff(cls)) + 1
    starts = np.r_[0, cut]
    stops = np.r_[cut, cls.size]
    keep = cls[starts] >= 0
    xy = np.column_stack([x, y])
    lines = [xy[a : b + 1] for a, b in zip(starts[keep], stops[keep], strict=True)]
    return lines, cls[starts[keep]]


def _margin_classes(margin: FloatArray, bounds: list[float]) -> IntArray:
    """Colour class of each margin as ``BoundaryNorm(bounds)`` bins it (-1: NaN, not drawn).

    ``len(bounds) - 1`` is the 'over' class (at or above the last bound).
    """
    m = np.asarray(margin, dtype=np.float64)
    fin = np.isfinite(m)
    cls = np.maximum(np.searchsorted(bounds, np.where(fin, m, 0.0), side="right") - 1, 0)
    return np.where(fin, cls, -1).astype(np.int64)


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


def plot_lobes(res: PlanResult) -> Figure:
    """Lobes of the tightest distinct waypoints, each with its operating point."""
    from matplotlib.figure import Figure

    best = res.outcome.best
    tab = res.lobes.table
    sf = res.job.plan.safety_factor
    fig = Figure(figsize=(8, 4.8))
    ax = fig.add_subplot()
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
    for rank, c in enumerate(chosen):
        row = tab.a_lim[tab.group[c]] * 1e3
        label = f"{_where(res, c)}, waypoint {int(res.cut_index[c])} (margin {best.margin[c]:.2f})"
        if rank == 0:
            label += ", tightest"
        (line,) = ax.plot(tab.rpm, row, lw=1.3, label=label, zorder=2)
        ax.plot([best.rpm[c]], [depth], "o", ms=9, mfc=line.get_color(), mec="k", mew=1.2, zorder=4)
    ax.axhline(depth, color="k", lw=1.0, ls="--", label=f"planned depth {depth:.3g} mm")
    ax.axhline(depth * sf, color="k", lw=0.8, ls=":", label=f"depth x safety factor {sf:g}")
    ax.set_ylim(0, top)
    pad = 0.015 * (tab.rpm[-1] - tab.rpm[0])
    ax.set_xlim(tab.rpm[0] - pad, tab.rpm[-1] + pad)
    ax.set_xlabel("spindle speed [rpm]")
    ax.set_ylabel("limiting depth a_lim [mm]")
    ax.set_title("Stability lobes at the tightest waypoints (dots: planned speed and depth)")
    ax.legend(fontsize=8, loc="upper left", framealpha=0.9)
    _margins(fig, left=0.09)
    return fig


def _two_slope() -> Any:
    from matplotlib.colors import TwoSlopeNorm

    return TwoSlopeNorm(vcenter=0.0, vmin=-2.0, vmax=2.0)


def plot_speed_map(res: PlanResult, max_rows: int = 1500) -> Figure:
    """Waypoint x speed map of ``a_lim / (SF depth)`` (log2) with the planned speeds."""
    from matplotlib.figure import Figure

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
        norm=_two_slope(),
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
    _margins(fig, left=0.115)
    return fig


def plot_path_margin(res: PlanResult) -> Figure:
    """Top view (x-y, workpiece frame) of the path, cutting moves coloured by margin."""
    from matplotlib.collections import LineCollection
    from matplotlib.colors import BoundaryNorm, ListedColormap
    from matplotlib.figure import Figure

    t = res.table
    sf = res.job.plan.safety_factor
    x = t["x_mm"].to_numpy()
    y = t["y_mm"].to_numpy()
    margin = t["margin"].to_numpy()
    fig = Figure(figsize=(8, 5.5))
    ax = fig.add_subplot()
    ax.plot(x, y, color="0.75", lw=0.6, ls="--", zorder=1, label="rapid / non-cutting")
    # A move ends at its row: segment i-1 -> i carries row i's margin.
    # Classes an engineer reads at a glance: below the safety factor (the
    # plan's own limit) is red, at it orange, then more and more spare depth.
    bounds = [0.0, 1.0, sf, 1.1 * sf, 1.5 * sf, 2.0 * sf, 4.0 * sf]
    colors = ["#8b0000", "#e34a33", "#fdae61", "#fee08b", "#a6d96a", "#1a9850"]
    cmap = ListedColormap(colors).with_extremes(over="#006837")
    norm = BoundaryNorm(bounds, cmap.N)
    m = margin[1:]
    # the class of each move (its colour), consecutive moves of a class drawn as one
    # line: the same picture as one segment per move, without a path object per move
    lines, run_cls = _runs(x, y, _margin_classes(m, bounds))
    lc = LineCollection(lines, colors=[cmap(c) for c in run_cls], linewidths=2.4, zorder=2)
    ax.add_collection(lc)
    k = res.summary.min_margin_at.waypoint
    ax.plot(x[k], y[k], "kx", ms=10, mew=2, zorder=3, label="tightest waypoint")
    from matplotlib.cm import ScalarMappable

    cb = fig.colorbar(
        ScalarMappable(norm=norm, cmap=cmap), ax=ax, extend="max", ticks=bounds, spacing="uniform"
    )
    cb.ax.set_yticklabels(["0", "1 (chatter)", f"{sf:g} (SF)", *(f"{b:.2f}" for b in bounds[3:])])
    cb.set_label("margin = limiting depth / planned depth")
    ax.set_aspect("equal", adjustable="datalim")
    ax.autoscale_view()
    ax.set_xlabel("x [mm]")
    ax.set_ylabel("y [mm]")
    ax.set_title("Path (top view) coloured by stability margin")
    ax.legend(fontsize=8, loc="best")
    _margins(fig, left=0.1, right=0.945, bottom=0.106, top=0.934)
    return fig


def plot_speed_power(res: PlanResult) -> Figure:
    """Speed and cutting power along the cutting length."""
    from matplotlib.figure import Figure

    o = res.outcome
    s = res.geom.s_m * 1e3
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
    ax2.set_xlabel("cutting length along the path [mm]")
    ax2.legend(fontsize=7)
    ax1.set_title("Spindle speed and cutting power along the path")
    _margins(fig, left=0.115, bottom=0.117, top=0.927, hspace=0.11)
    return fig


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
    return html.escape(str(v))


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
    res: PlanResult, images: dict[str, bytes], base: str | os.PathLike[str] | None = None
) -> str:
    """The self-contained HTML report (PNG images embedded as base64).

    Parameters
    ----------
    res : PlanResult
    images : dict of str to bytes
        PNG images by plot name (:data:`PLOTS`).
    base : path-like, optional
        Folder the report is written to; file names are shown relative to it.
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
    table = "\n".join(
        f"<tr><th>{html.escape(k)}</th><td>{html.escape(str(v))}</td></tr>" for k, v in rows
    )
    tight = _tightest(res)
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
    imgs = "\n".join(
        f'<figure><img alt="{html.escape(k)}" '
        f'src="data:image/png;base64,{base64.b64encode(v).decode()}">'
        f"<figcaption>{html.escape(CAPTIONS.get(k, k))}</figcaption></figure>"
        for k, v in images.items()
    )
    notes = "".join(f"<li>{html.escape(n)}</li>" for n in s.notes)
    timing = ", ".join(f"{k} {v:.3g} s" for k, v in s.timings_s.items())
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>robolobe plan: {html.escape(_shown_path(s.path, b))}</title>
<style>
body {{ font-family: sans-serif; max-width: 1000px; margin: 2em auto; color: #222; }}
table {{ border-collapse: collapse; margin: 1em 0; }}
th, td {{ padding: 3px 10px; border-bottom: 1px solid #ddd; text-align: left; font-size: 14px; }}
figure {{ margin: 1.5em 0; }} img {{ max-width: 100%; }}
figcaption {{ font-size: 14px; color: #444; max-width: 800px; }}
</style></head><body>
<h1>robolobe plan</h1>
<table>{table}</table>
<h2>Notes</h2><ul>{notes or "<li>none</li>"}</ul>
<h2>Plots</h2>
{imgs}
<h2>Tightest waypoints</h2>
<p>The cutting waypoints with the smallest margin, one row per position.</p>
{tight_html}
<p><small>robolobe {html.escape(s.robolobe_version)};
timings: {html.escape(timing)}</small></p>
</body></html>
"""


def write_outputs(
    res: PlanResult,
    out_dir: str | os.PathLike[str],
    *,
    plots: bool = True,
    html_report: bool = True,
    waypoints: str = "csv",
    waypoints_every: int = 1,
) -> Path:
    """Write the plan into ``out_dir`` atomically (see the module docstring).

    Parameters
    ----------
    res : PlanResult
    out_dir : path-like
        Created if missing. A plan's files of an earlier run (:data:`OUTPUTS`)
        that this run does not write are removed, so the folder holds one
        plan; other files are left alone.
    plots, html_report : bool
        Write the PNG plots and the HTML report.
    waypoints : {"csv", "parquet", "none"}
        The per-waypoint table as ``waypoints.csv``, ``waypoints.parquet``
        (needs pyarrow; refused before anything is written) or not at all
        (long paths: the summary and plots still cover every waypoint).
    waypoints_every : int
        Write one row per block of this many waypoints, the tightest of the
        block (:func:`thin_rows`); 1 writes every waypoint.

    Returns
    -------
    Path
        ``out_dir``.
    """
    out = Path(out_dir)
    if waypoints == "parquet":
        require_pyarrow("waypoints")
    if int(waypoints_every) < 1:
        from robolobe.errors import InputError

        raise InputError(f"waypoints_every: expected an integer >= 1, found {waypoints_every!r}")
    images: dict[str, bytes] = {}
    if plots or html_report:
        for name in PLOTS:
            images[name] = _png(_PLOTTERS[name](res))
    with atomic_dir(out, managed=OUTPUTS) as tmp:
        _write_waypoints(res.table, tmp, waypoints, int(waypoints_every))
        (tmp / "summary.json").write_text(
            json.dumps(res.summary.to_dict(), indent=2) + "\n", encoding="utf-8"
        )
        if plots:
            (tmp / "plots").mkdir()
            for name, data in images.items():
                (tmp / "plots" / f"{name}.png").write_bytes(data)
        if html_report:
            (tmp / "report.html").write_text(render_html(res, images, out), encoding="utf-8")
    return out
