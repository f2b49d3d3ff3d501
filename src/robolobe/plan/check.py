"""Check a program as written: every move at its own speed, feed and engagement.

:func:`check_program` takes a program and a job and judges each cutting move
with the planner's own modelling, but nothing chosen by a planner: the spindle
speed S and feed F the program states at that move
(:mod:`robolobe.plan.paths`: ``rpm_programmed``, ``feed_mm_per_min``), the
move's own radial engagement (entry/exit angles) and axial depth from the
stock (:func:`robolobe.plan.engagement.stock_engagement`; without ``[stock]``
the stock the program implies, :func:`robolobe.stock.default_stock`, with a
note), the robot's modes at the move's posture (:func:`~robolobe.plan.pipeline.tcp_targets`,
the planner's inverse kinematics and mode prediction) and the converged lobes
(:func:`~robolobe.plan.pipeline.cut_lobes`, :func:`robolobe.plan.lobes.waypoint_lobes`)
queried exactly at the move's S.

Each move's lobes use its own entry and exit angles, as the planner's
(:func:`~robolobe.plan.pipeline.cut_lobes` with per-waypoint angles: lobe
sharing groups moves by engagement as well as dynamics, each group's lobes
at its leader's own angles), so a plan's own program checks at the margins
the plan states. (Until issue 26 the lobes took one pair of angles per
call and check bounded each 0.25 deg bin by its corners: up to 2.9 % below
the exact limit and one lobe computation per class and corner.)

Per move: ``margin = a_lim / a_p``; status ``"ok"``, ``"inside SF"``
(``1 <= margin <`` the job's safety factor), ``"beyond limit"``
(``margin < 1``), ``"air"`` (a feed move that meets no material: no limit)
or ``"plunge"`` (a move along the tool axis: no lateral limit, as the
planner). Each move's cutting speed, chip load and feed are also judged
against the process limits (:mod:`robolobe.plan.limits`: the material
table's or the job's vc and chip-load ranges, the robot's path speed):
columns in check.csv, counts in check.json (``out_of_range``), a note naming
the first ``file:line`` out of each range. They do not change the verdict
(stability) or the exit status.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._text import count, html_text, plot_text
from robolobe.errors import InputError
from robolobe.plan.engagement import stock_engagement
from robolobe.plan.job import Job, load_job
from robolobe.plan.limits import ProcessLimits, brief_source, process_limits
from robolobe.plan.modes import ModeSource, mode_source
from robolobe.plan.paths._text import MAX_ABS
from robolobe.plan.pipeline import (
    _postures,
    _predict_modes,
    _read,
    _stiffest_rotation,
    _tool_model,
    constraints_from_job,
    cut_lobes,
    feed_tcp,
    material_from_job,
    tcp_targets,
)
from robolobe.robots.io import load_robot
from robolobe.robots.model import Robot

__all__ = ["CHECK_FILES", "CheckResult", "check_program", "write_check"]

FloatArray = NDArray[np.float64]

#: Status words of the check table.
OK, INSIDE_SF, BEYOND, AIR, PLUNGE = "ok", "inside SF", "beyond limit", "air", "plunge"


@dataclass(frozen=True, eq=False)
class CheckResult:
    """A program checked as written.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per feed move (the program's cutting moves, air included):
        ``waypoint`` (row of the read program), ``source``, ``line``, ``rpm``
        (S), ``feed_mm_per_min`` (F), ``feed_per_tooth_mm``,
        ``vc_m_per_min``, ``ae_over_D``, ``phi_entry_deg``, ``phi_exit_deg``
        (the move's own), ``class_entry_deg``, ``class_exit_deg`` (the outer
        corner of its engagement bin, module docstring),
        ``depth_mm`` (a_p), ``a_lim_mm``, ``margin`` (a_lim / a_p; NaN for air
        and plunges), ``status``; against the process limits
        (:func:`robolobe.plan.limits.process_limits`) ``vc_check`` (engaged
        moves), ``feed_per_tooth_check`` (engaged moves but plunges),
        ``feed_check`` (every feed move against the robot's path speed):
        ``"ok"``, ``"low"``, ``"high"``, ``""`` where not judged.
    n_beyond, n_inside_sf : int
        Moves beyond their limit; moves with a margin below the safety factor
        (beyond included).
    min_margin : float
        Smallest margin (inf without a bounded move); ``min_margin_at`` its ``file:line``.
    beyond, inside_sf : tuple of str
        ``file:line`` of the moves beyond the limit, and inside the safety
        factor but not beyond.
    safety_factor : float
    notes : tuple of str
    summary : dict
        JSON-ready (check.json).
    """

    table: pd.DataFrame
    n_beyond: int
    n_inside_sf: int
    min_margin: float
    min_margin_at: str
    beyond: tuple[str, ...]
    inside_sf: tuple[str, ...]
    safety_factor: float
    notes: tuple[str, ...]
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no move is beyond its limit."""
        return self.n_beyond == 0


#: Smallest ``--rpm`` [rpm] or ``--feed`` [mm/min] taken (1e-300 is a slip, not a speed);
#: the largest is the toolpath readers' bound on any number.
_CONSTANT_MIN = 1e-3


def _filled(
    values: FloatArray,
    constant: float | None,
    labels: list[str],
    need: NDArray[np.bool_],
    what: str,
    hint: str = "",
) -> FloatArray:
    """Programmed values, ``constant`` where none is programmed; refused where missing."""
    v = np.asarray(values, dtype=np.float64).copy()
    if constant is not None:
        if not (math.isfinite(constant) and _CONSTANT_MIN <= constant <= MAX_ABS):
            raise InputError(
                f"expected a positive {what} of {_CONSTANT_MIN:g} to {MAX_ABS:g}, "
                f"found {constant:g}",
                "--" + what,
            )
        v = np.where(np.isfinite(v), v, constant)
    bad = need & ~(np.isfinite(v) & (v > 0))
    if np.any(bad):
        k = int(np.argmax(bad))
        word = {"rpm": "spindle speed S", "feed": "feed F"}[what]
        found = "none programmed" if not np.isfinite(v[k]) else f"{v[k]:g}"
        raise InputError(
            f"expected a positive {word} on this cutting move, found {found} "
            f"(program it, or give --{what}{hint})",
            labels[k],
        )
    return v


def check_program(
    program: str | os.PathLike[str] | pd.DataFrame,
    job: Job | str | os.PathLike[str],
    *,
    rpm: float | None = None,
    feed: float | None = None,
    robot: Robot | str | os.PathLike[str] | None = None,
    source: ModeSource | None = None,
) -> CheckResult:
    """Check every cutting move of a program at its own S, F and engagement.

    Parameters
    ----------
    program : path-like or pandas.DataFrame
        The program (any format :func:`robolobe.plan.paths.read_toolpath`
        reads, e.g. a plan's ``program.<ext>``) or a waypoint table.
    job : Job or path-like
        Robot, placement, tool, material, spindle, safety factor, ``[stock]``.
    rpm, feed : float, optional
        Spindle speed [rpm] and feed [mm/min] for the moves where the program
        states none (default: refused with the move's ``file:line``).
    robot : Robot or path-like, optional
        Overrides ``job.robot``.
    source : ModeSource, optional
        Overrides ``job.model``.

    Returns
    -------
    CheckResult

    Raises
    ------
    InputError
        S or F missing or not positive on a cutting move (naming its
        ``file:line``), a stock that does not contain the program, a tilted
        tool; also :class:`~robolobe.errors.ReachabilityError` /
        :class:`~robolobe.errors.SingularityError` from the postures.
    """
    job = load_job(job)
    wp, path_name = _read(program, job.path_options)
    cut = (wp["motion"] == "cut").to_numpy()
    labels_all = [f"{a}:{int(b)}" for a, b in zip(wp["source"], wp["line"], strict=True)]
    if not np.any(cut):
        raise InputError(
            "expected at least one cutting move (G1/G2/G3, LIN, MoveL), found none",
            Path(path_name).name,
        )
    notes: list[str] = []
    eng = stock_engagement(job, wp, path_name, default=True)
    assert eng is not None
    notes.extend(eng.notes)
    engaged = cut & eng.engaged
    prog_rpm = job.cut.programmed_rpm
    s_all = _filled(
        wp["rpm_programmed"].to_numpy(),
        rpm,
        labels_all,
        engaged,
        "rpm",
        f"; the job's cut.programmed_rpm is {prog_rpm:g}" if prog_rpm else "",
    )
    f_all = _filled(wp["feed_mm_per_min"].to_numpy(), feed, labels_all, engaged, "feed")
    rob = load_robot(job.robot if robot is None else robot)
    limits = process_limits(job, wp, engaged, path_name, robot=rob)
    if source is None:
        source, mnote = mode_source(job.model, rob, job.robot, job.effects)
        if mnote:
            notes.append(mnote)
    material = material_from_job(job)
    tool = _tool_model(job)
    ei = np.flatnonzero(engaged)
    s_eng = s_all[ei]
    lo_s, hi_s = job.spindle.rpm_min, job.spindle.rpm_max
    if ei.size:
        out_rng = (s_eng < lo_s) | (s_eng > hi_s)
        if np.any(out_rng):
            k = ei[int(np.argmax(out_rng))]
            notes.append(
                f"{count(int(out_rng.sum()), 'cutting move')} programmed outside the "
                f"spindle's range {lo_s:g}-{hi_s:g} rpm (first {labels_all[k]}: "
                f"S{s_all[k]:g}); checked at the programmed speed"
            )
    grid = np.linspace(
        min(lo_s, float(s_eng.min()) if ei.size else lo_s),
        max(hi_s, float(s_eng.max()) if ei.size else hi_s),
        job.plan.n_rpm,
    )
    rotation = job.tool_rotation_rad
    if job.tool_rotation == "stiffest":
        rotation, tried = _stiffest_rotation(
            job,
            wp,
            rob,
            source,
            cut,
            material,
            tool,
            grid,
            constraints_from_job(job, material.kt, limits),
        )
        notes.append(
            f"tool rotation: the planner's stiffest choice {math.degrees(rotation):.0f} deg "
            f"({tried})"
        )
    poses, r_wp = tcp_targets(wp, rob, job.placement, rotation)
    q, _ = _postures(wp, rob, poses, source)
    ci = np.flatnonzero(cut)
    n = ci.size
    pe_all, px_all = eng.phi_entry[ci], eng.phi_exit[ci]
    on = engaged[ci]
    a_lim = np.full(n, np.nan)
    plunge = np.zeros(n, bool)
    robust = False  # the job's plan.robust, as the planner decides it
    n_groups = 0
    if np.any(on):
        k = np.flatnonzero(on)
        wk = ci[k]
        modes = _predict_modes(source, q[wk])
        f_k = feed_tcp(wp, poses, r_wp, wk)
        _, pl, grouped, _, _, bound = cut_lobes(
            job, modes, f_k, material, tool, grid, engagement=(pe_all[k], px_all[k])
        )
        robust = bound is not None
        n_groups = grouped.n_groups
        if not grouped.valid and grouped.message:
            notes.append(grouped.message)
        a_lim[k] = np.where(pl, np.inf, grouped.table.query(s_all[wk]))
        plunge[k] = pl
    depth = eng.depth_m[ci]
    bounded = on & ~plunge
    margin = np.full(n, np.nan)
    margin[bounded] = a_lim[bounded] / np.maximum(depth[bounded], 1e-300)
    sf = float(job.plan.safety_factor)
    status = np.full(n, AIR, dtype=object)
    status[on & plunge] = PLUNGE
    status[bounded] = OK
    status[bounded & (margin < sf * (1 - 1e-9))] = INSIDE_SF
    status[bounded & (margin < 1.0)] = BEYOND
    s_cut, f_cut = s_all[ci], f_all[ci]
    teeth = job.tool.teeth
    d_mm = job.tool.diameter_m * 1e3
    with np.errstate(invalid="ignore", divide="ignore"):
        fz = f_cut / (s_cut * teeth)
    labels = [labels_all[i] for i in ci]
    table = pd.DataFrame(
        {
            "waypoint": ci,
            "source": wp["source"].to_numpy()[ci],
            "line": wp["line"].to_numpy()[ci],
            "rpm": s_cut,
            "feed_mm_per_min": f_cut,
            "feed_per_tooth_mm": fz,
            "vc_m_per_min": math.pi * d_mm * s_cut / 1e3,
            "ae_over_D": np.where(on, eng.immersion[ci], 0.0),
            "phi_entry_deg": np.degrees(pe_all),
            "phi_exit_deg": np.degrees(px_all),
            "depth_mm": depth * 1e3,
            "a_lim_mm": np.where(np.isfinite(a_lim), a_lim * 1e3, np.nan),
            "margin": margin,
            "status": status.astype(str),
        }
    )
    fz_job = job.cut.feed_per_tooth_m * 1e3 if job.cut.feed_per_tooth_m else None
    if fz_job and np.any(on):
        fz_on = fz[on]
        off = np.abs(fz_on / fz_job - 1.0) > 0.10
        if np.any(off):
            k = int(np.flatnonzero(on)[int(np.argmax(off))])
            notes.append(
                f"the program's feed per tooth differs from the job's cut.feed_per_tooth_mm "
                f"{fz_job:g} by more than 10 % on {count(int(off.sum()), 'cutting move')} (first "
                f"{labels[k]}: {fz[k]:.3g} mm); the check uses the program's"
            )
    in_range, range_summary = _range_checks(table, on, on & ~plunge, labels, limits, notes)
    for col, v in in_range.items():
        table[col] = v
    if np.any(bounded):
        kmin = int(np.nanargmin(np.where(bounded, margin, np.inf)))
        mmin, at = float(margin[kmin]), labels[kmin]
    else:
        mmin, at = math.inf, ""
    beyond = [labels[i] for i in np.flatnonzero(status == BEYOND)]
    inside = [labels[i] for i in np.flatnonzero(status == INSIDE_SF)]
    counts = {s: int(np.sum(status == s)) for s in (OK, INSIDE_SF, BEYOND, AIR, PLUNGE)}
    summary: dict[str, Any] = {
        "program": str(path_name),
        "job_file": job.source,
        "mode_source": source.name,
        "stock": eng.stock.describe(),
        "stock_given": job.stock is not None,
        "zmap_cell_mm": round(eng.resolution_m * 1e3, 6),
        "n_dynamics_groups": n_groups,
        "safety_factor": sf,
        "robust": robust,
        "n_feed_moves": n,
        "counts": counts,
        "n_bounded": int(np.sum(bounded)),
        "n_beyond_limit": len(beyond),
        "n_inside_safety_factor": len(beyond) + len(inside),
        "min_margin": None if not math.isfinite(mmin) else round(mmin, 5),
        "min_margin_at": at,
        "beyond_limit_at": beyond,
        "inside_safety_factor_at": inside,
        "verdict": "moves beyond their stability limit" if beyond else "no move beyond its limit",
        **range_summary,
        "notes": notes,
    }
    return CheckResult(
        table=table,
        n_beyond=len(beyond),
        n_inside_sf=len(beyond) + len(inside),
        min_margin=mmin,
        min_margin_at=at,
        beyond=tuple(beyond),
        inside_sf=tuple(inside),
        safety_factor=sf,
        notes=tuple(notes),
        summary=summary,
    )


#: Words of the range columns (``vc_check``, ``feed_per_tooth_check``, ``feed_check``).
IN_RANGE, LOW, HIGH = "ok", "low", "high"


def _range_checks(
    table: pd.DataFrame,
    on: NDArray[np.bool_],
    lateral: NDArray[np.bool_],
    labels: list[str],
    limits: ProcessLimits,
    notes: list[str],
) -> tuple[dict[str, NDArray[np.str_]], dict[str, Any]]:
    """Each move's vc, chip load and feed against the process limits.

    vc is judged on the engaged moves (``on``), the chip load on those that
    are not plunges (``lateral``: plunges are fed slower by design), the feed
    on every feed move against the robot's path speed. Returns the columns
    (``""`` where not judged) and the summary keys; appends a note per limit
    some move breaks, naming the first ``file:line``.
    """
    vc = table["vc_m_per_min"].to_numpy(dtype=np.float64)
    fz = table["feed_per_tooth_mm"].to_numpy(dtype=np.float64) * 1e-3
    feed = table["feed_mm_per_min"].to_numpy(dtype=np.float64) / 6e4
    tol = 1e-9
    checks = (
        ("vc_check", vc, on, limits.vc_min_m_per_min, limits.vc_max_m_per_min, "m/min",
         1.0, "cutting speed vc", limits.vc_source, ".4g"),
        ("feed_per_tooth_check", fz, lateral, limits.fz_min_m, limits.fz_max_m, "mm", 1e3,
         "chip load", limits.fz_range_source, ".3g"),
        ("feed_check", feed, np.isfinite(feed), 0.0, limits.max_feed_m_per_s, "mm/min", 6e4,
         "feed (robot path speed)", limits.max_feed_why, ".6g"),
    )  # fmt: skip
    cols: dict[str, NDArray[np.str_]] = {}
    counts: dict[str, int] = {}
    first: dict[str, str] = {}
    for col, v, judged, lo, hi, unit, scale, what, why, fmt in checks:
        word = np.full(v.size, "", dtype=object)
        low = judged & (v < lo * (1 - tol))
        high = judged & (v > hi * (1 + tol))
        word[judged] = IN_RANGE
        word[low], word[high] = LOW, HIGH
        cols[col] = word.astype(str)
        name = col.removesuffix("_check")
        for side, sel, bound in (("below", low, lo), ("above", high, hi)):
            n = int(sel.sum())
            if col == "feed_check" and side == "below":
                continue
            key = f"{name}_{'low' if side == 'below' else 'high'}"
            counts[key] = n
            if n:
                k = int(np.argmax(sel))
                first[key] = labels[k]
                bound_word = {"below": "minimum", "above": "maximum"}[side]
                notes.append(
                    f"{count(n, 'move')} {side} the {what} {bound_word} "
                    f"{bound * scale:{fmt}} {unit} ({brief_source(why)}) (first {labels[k]}: "
                    f"{v[k] * scale:{fmt}} {unit})"
                )
    summary = {
        "limits": {
            "vc_m_per_min": [limits.vc_min_m_per_min, _finite(limits.vc_max_m_per_min)],
            "vc_source": limits.vc_source,
            "rpm": [round(limits.rpm_min, 1), round(limits.rpm_max, 1)],
            "rpm_why": [limits.rpm_min_why, limits.rpm_max_why],
            "feed_per_tooth_mm": [limits.fz_min_m * 1e3, _finite(limits.fz_max_m * 1e3)],
            "feed_per_tooth_source": limits.fz_range_source,
            "max_feed_mm_per_min": round(limits.max_feed_m_per_s * 6e4, 3),
            "max_feed_why": limits.max_feed_why,
        },
        "out_of_range": counts,
        "out_of_range_first_at": first,
    }
    return cols, summary


def _finite(v: float) -> float | None:
    return v if math.isfinite(v) else None


def plot_check_margin(res: CheckResult) -> Any:
    """Margin (a_lim / a_p) of every bounded move along the program, by status."""
    from matplotlib.figure import Figure

    t = res.table
    fig = Figure(figsize=(8, 4))
    ax = fig.add_subplot()
    x = np.arange(len(t))
    m = t["margin"].to_numpy(dtype=np.float64)
    st = t["status"].to_numpy()
    ax.plot(x, m, lw=0.8, color="0.7")
    for s, color in ((OK, "C2"), (INSIDE_SF, "C1"), (BEYOND, "C3")):
        sel = st == s
        if np.any(sel):
            ax.plot(x[sel], m[sel], ".", ms=3, color=color, label=s)
    air = st == AIR
    if np.any(air):
        ax.plot(x[air], np.zeros(int(air.sum())), "|", color="0.5", label="air (no limit)")
    ax.axhline(1.0, color="C3", lw=0.8)
    ax.axhline(res.safety_factor, color="k", lw=0.8, ls=":", label=f"SF {res.safety_factor:g}")
    finite = m[np.isfinite(m)]
    top = max(2.5 * res.safety_factor, float(np.percentile(finite, 90)) if finite.size else 1.0)
    ax.set_ylim(0, top)
    ax.set_xlabel("feed move of the program")
    ax.set_ylabel("a_lim / a_p")
    ax.set_title(plot_text(f"Program as written: {Path(res.summary['program']).name}", 80))
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


#: The files :func:`write_check` writes (checked before a run: :mod:`robolobe._atomic`);
#: not ``report.html``: a check written into a plan's folder keeps the plan's report.
CHECK_FILES: tuple[str, ...] = ("check.csv", "check.json", "check_margin.png", "check_report.html")


def _html(res: CheckResult, png: bool, n: int = 50) -> str:
    s = res.summary
    h = html_text
    rows = "".join(
        f"<tr><th>{h(k)}</th><td>{h(v)}</td></tr>"
        for k, v in (
            ("program", s["program"]),
            ("job", s["job_file"]),
            ("modes", s["mode_source"]),
            ("stock", s["stock"] + ("" if s["stock_given"] else " (default: no [stock])")),
            ("feed moves", s["n_feed_moves"]),
            *((f"status {k}", v) for k, v in s["counts"].items()),
            ("safety factor", s["safety_factor"]),
            ("minimum margin", f"{s['min_margin']} at {s['min_margin_at']}"),
            *(
                (f"out of range: {k}", f"{v} (first {s['out_of_range_first_at'][k]})")
                for k, v in s["out_of_range"].items()
                if v
            ),
            ("verdict", s["verdict"]),
        )
    )
    t = res.table
    risk = t[t["status"].isin([BEYOND, INSIDE_SF])].sort_values("margin").head(n)
    cols = ["source", "line", "rpm", "feed_mm_per_min", "feed_per_tooth_mm", "ae_over_D"]
    cols += ["phi_entry_deg", "phi_exit_deg", "depth_mm", "a_lim_mm", "margin", "status"]
    cols += ["vc_m_per_min", "vc_check", "feed_per_tooth_check", "feed_check"]

    def cell(v: Any) -> str:
        return h(f"{v:.4g}" if isinstance(v, float) else v)

    risk_rows = "".join(
        "<tr>" + "".join(f"<td>{cell(r[c])}</td>" for c in cols) + "</tr>"
        for r in risk.to_dict("records")
    )
    notes = "".join(f"<li>{h(x)}</li>" for x in res.notes)
    return (
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>robolobe check</title>"
        "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:2px 6px;text-align:left}</style></head><body>"
        f"<h1>Program as written: {h(Path(s['program']).name)}</h1>"
        f"<table>{rows}</table><h2>Notes</h2><ul>{notes}</ul>"
        f"<h2>Moves at risk (margin below the safety factor; {len(risk)} of "
        f"{res.n_inside_sf} shown, all in check.csv)</h2>"
        "<table><tr>"
        + "".join(f"<th>{h(c)}</th>" for c in cols)
        + f"</tr>{risk_rows}</table>"
        + ("<h2>Margin along the program</h2><img src='check_margin.png'>" if png else "")
        + "</body></html>\n"
    )


def write_check(res: CheckResult, out_dir: str | os.PathLike[str], *, plots: bool = True) -> Path:
    """Write check.csv, check.json, check_margin.png and check_report.html atomically.

    A re-run replaces the set; other files in ``out_dir`` are kept, a file
    robolobe did not write is never replaced (:func:`robolobe._atomic.atomic_dir`,
    kind ``check``).
    """
    from robolobe._atomic import atomic_dir
    from robolobe.plan import _plots
    from robolobe.plan.report import write_csv

    out = Path(out_dir)
    png = _plots.png(plot_check_margin(res)) if plots else None
    csv_name, json_name, png_name, html_name = CHECK_FILES
    with atomic_dir(out, "check", option="--output") as tmp:
        write_csv(res.table, tmp / csv_name)
        (tmp / json_name).write_text(json.dumps(res.summary, indent=2) + "\n", encoding="utf-8")
        if png is not None:
            (tmp / png_name).write_bytes(png)
        (tmp / html_name).write_text(_html(res, png is not None), encoding="utf-8")
    return out
