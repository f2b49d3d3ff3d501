"""The same job on several robots: placement that reaches the path, plans side by side.

For each robot the job's placement is tried first; when the path is out of
reach (or passes a singularity) there, :func:`find_placement` searches
positions of the workpiece in front of the robot (same orientation) for one
where every waypoint is reachable, away from singularities and joint limits
and, with a tl model, inside its training range. A robot with no such
placement is reported as unreachable. The rows of :class:`Comparison` hold
MRR, cycle time, minimum margin and the worst waypoint per robot.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robolobe._atomic import SafeNames, atomic_dir, unique_names
from robolobe._text import plot_text
from robolobe.errors import (
    InfeasibleError,
    InputError,
    InputTypeError,
    ReachabilityError,
    RobolobeError,
    SingularityError,
)
from robolobe.plan._summary import PlanSummary
from robolobe.plan.job import Job, load_job
from robolobe.plan.modes import ModeSource, mode_source
from robolobe.plan.paths import read_toolpath, validate_waypoints
from robolobe.plan.pipeline import (
    WRIST_SINGULAR,
    PlanResult,
    _postures,
    _wrist_measure,
    plan_path,
    tcp_targets,
)
from robolobe.robots.io import load_robot
from robolobe.robots.model import Robot

__all__ = [
    "COMPARE_FILES",
    "Comparison",
    "compare_robots",
    "find_placement",
    "moved_note",
    "robot_folder_notes",
    "robot_folders",
    "write_comparison",
]

logger = logging.getLogger(__name__)


def _placement_score(
    wp: pd.DataFrame,
    robot: Robot,
    placement: np.ndarray,
    rotation: float,
    source: ModeSource | None,
) -> float:
    """Quality of a placement (higher is better), -inf when a waypoint fails."""
    try:
        poses, _ = tcp_targets(wp, robot, placement, rotation)
        q, _ = _postures(wp, robot, poses, source)
    except (ReachabilityError, SingularityError, RobolobeError):
        return -math.inf
    wm = _wrist_measure(robot, q)
    if np.any(wm < WRIST_SINGULAR):
        return -math.inf
    span = np.maximum(robot.q_max - robot.q_min, 1e-9)
    margin = np.minimum(q - robot.q_min, robot.q_max - q) / span
    score = float(margin.min()) + 0.2 * float(np.min(np.minimum(wm, 0.5)))
    predictor = getattr(source, "predictor", None)
    if predictor is not None:
        with contextlib.suppress(RobolobeError):
            score -= 2.0 * float(np.max(predictor.extrapolation(q)))
    return score


def find_placement(
    wp: pd.DataFrame,
    robot: Robot,
    job: Job,
    source: ModeSource | None = None,
    *,
    n_sample: int = 40,
) -> tuple[np.ndarray, float]:
    """A workpiece placement from which the robot reaches the whole path.

    Keeps the job's placement orientation and moves the path's centre over a
    grid in front of the robot (radius 35-85 % of the reach, height -0.6 to
    +1.2 m), judging each candidate on ``n_sample`` waypoints (then the
    winner on all).

    Returns
    -------
    placement : ndarray, shape (4, 4)
    score : float

    Raises
    ------
    ReachabilityError
        When no candidate reaches the path.
    """
    sub = wp.iloc[np.unique(np.linspace(0, len(wp) - 1, min(n_sample, len(wp))).astype(int))]
    sub = sub.reset_index(drop=True)
    r_pl = job.placement[:3, :3]
    centre = wp[["x_m", "y_m", "z_m"]].to_numpy().mean(axis=0)
    reach = robot.reach_m
    best: tuple[float, np.ndarray] | None = None
    for frac in (0.6, 0.5, 0.7, 0.45, 0.8, 0.4, 0.85, 0.35):
        for z in (0.0, 0.3, -0.3, 0.6, -0.6, 0.9, 1.2):
            target = np.array([frac * reach, 0.0, z])
            pl = np.eye(4)
            pl[:3, :3] = r_pl
            pl[:3, 3] = target - r_pl @ centre
            s = _placement_score(sub, robot, pl, job.tool_rotation_rad, source)
            if math.isfinite(s) and (best is None or s > best[0]):
                best = (s, pl)
    if best is None:
        raise ReachabilityError(
            f"robot {robot.name!r}: no placement in front of it reaches the path"
        )
    full = _placement_score(wp, robot, best[1], job.tool_rotation_rad, source)
    if not math.isfinite(full):
        raise ReachabilityError(
            f"robot {robot.name!r}: the best placement found reaches the sampled waypoints "
            "but not all"
        )
    return best[1], full


@dataclass(frozen=True, eq=False)
class Comparison:
    """Plans of one path and job on several robots.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per robot: ``robot status placement_xyz_m depth_mm rpm_min
        rpm_max mrr_cm3_per_min cycle_time_s min_margin worst_waypoint
        worst_source method mode_source message``.
    results : dict
        Robot key -> :class:`PlanResult` (feasible plans only).
    """

    table: pd.DataFrame
    results: dict[str, PlanResult] = field(default_factory=dict)


def _model_for(job: Job, spec: str) -> str:
    """The job's model for another robot: a model file only fits the job's own robot."""
    if job.model == "twin":
        return "twin"
    if job.model != "builtin" and spec == job.robot:
        return job.model
    return "builtin" if spec in ("A", "B", "C") else "twin"


def compare_robots(
    path: str | os.PathLike[str] | pd.DataFrame,
    job: Job | str | os.PathLike[str],
    robots: Sequence[str | os.PathLike[str]] | str,
    *,
    refine: bool = True,
) -> Comparison:
    """Plan the same path and job on each robot.

    Parameters
    ----------
    path : path-like or DataFrame
        The toolpath.
    job : Job or path-like
        The job or its file (its robot is replaced by each of ``robots``; a ``builtin``
        model means each robot's shipped model).
    robots : list of str or path-like
        ``"A"``, ``"B"``, ``"C"`` or robot files (a single string is split
        at commas: ``"A,B,C"``).
    refine : bool
        casadi refinement.

    Returns
    -------
    Comparison

    Raises
    ------
    InputError
        A robot file that cannot be read or is implausible, or a robot
        given twice (before any planning).
    """
    if isinstance(robots, str | os.PathLike):
        robots = [r.strip() for r in os.fspath(robots).split(",")]  # "A,B,C" as on the CLI
    try:
        robots = list(robots)
    except TypeError:
        raise InputTypeError("robots", "robot keys or robot files' paths", robots) from None
    if not robots:
        raise InputError("robots: expected at least one robot, found none")
    for key in robots:
        if not isinstance(key, str | os.PathLike):
            raise InputTypeError("robots", "robot keys or robot files' paths", key)
    job = load_job(job)
    wp = (
        validate_waypoints(path, "<table>")
        if isinstance(path, pd.DataFrame)
        else read_toolpath(path, applicable_only=True, **job.path_options)
    )
    rows: list[dict[str, Any]] = []
    results: dict[str, PlanResult] = {}
    # every robot file is read before any planning: a bad file is the user's
    # input (one error now), not a row after minutes of planning the others
    loaded: dict[str, Robot] = {}
    for key in robots:
        spec = os.fspath(key)
        spec = spec.upper() if spec.upper() in ("A", "B", "C") else str(Path(spec))
        if spec in loaded:
            raise InputError(f"--robots: expected each robot once, found {spec} twice")
        loaded[spec] = load_robot(spec)
    for spec, robot in loaded.items():
        row: dict[str, Any] = {"robot": spec}
        try:
            model = _model_for(job, spec)
            # the job's physics effects belong to the job's own robot only
            effects = job.effects if spec == job.robot else ()
            source, _note = mode_source(model, robot, spec, effects)
            jr = job.replace(robot=spec, model=model, effects=effects)
            placement = jr.placement
            adjusted = False
            if not math.isfinite(
                _placement_score(wp, robot, placement, jr.tool_rotation_rad, source)
            ):
                placement, _ = find_placement(wp, robot, jr, source)
                adjusted = True
            jr = jr.replace(placement=placement)
            res = plan_path(wp, jr, robot=robot, source=source, refine=refine)
            if adjusted:  # said in the robot's summary.json, report and the comparison
                note = moved_note(spec, placement[:3, 3])
                res = dataclasses.replace(
                    res, summary=dataclasses.replace(res.summary, notes=(note, *res.summary.notes))
                )
            s = res.summary
            row.update(
                status="ok",
                placement_adjusted=adjusted,
                placement_xyz_m=[round(float(v), 4) for v in placement[:3, 3]],
                depth_mm=s.depth_mm,
                rpm_min=s.rpm_min,
                rpm_max=s.rpm_max,
                mrr_cm3_per_min=s.mrr_cm3_per_min,
                cycle_time_s=s.cycle_time_s,
                passes=_passes(jr, s),
                part_time_s=_part_time(jr, s),
                time_per_mm_depth_s=s.cycle_time_s / s.depth_mm,
                min_margin=s.min_margin,
                worst_waypoint=s.min_margin_at.waypoint,
                worst_source=s.min_margin_at.source,
                method=s.method,
                mode_source=s.mode_source,
                message="; ".join(s.notes),
            )
            results[spec] = res
        except (ReachabilityError, SingularityError) as exc:
            row.update(status="unreachable", message=str(exc))
        except InfeasibleError as exc:
            row.update(status="infeasible", message=str(exc))
        except RobolobeError as exc:
            row.update(status="error", message=str(exc))
        rows.append(row)
    cols = [
        "robot", "status", "placement_adjusted", "placement_xyz_m", "depth_mm", "rpm_min",
        "rpm_max", "mrr_cm3_per_min", "cycle_time_s", "passes", "part_time_s",
        "time_per_mm_depth_s", "min_margin", "worst_waypoint",
        "worst_source", "method", "mode_source", "message",
    ]  # fmt: skip
    table = pd.DataFrame(rows).reindex(columns=cols)
    return Comparison(table=table, results=results)


def moved_note(robot: str, xyz_m: Any) -> str:
    """The note of a plan whose workpiece :func:`compare_robots` moved.

    Parameters
    ----------
    robot : str
    xyz_m : sequence of 3 floats
        The placement's position [m] (``placement_xyz_m`` of the table).
    """
    x, y, z = (float(v) for v in xyz_m)
    return (
        f"workpiece moved for robot {robot}: the job's placement does not reach the path, so "
        f"the part is placed at x {x:.3f}, y {y:.3f}, z {z:.3f} m in the robot's base frame "
        "(same orientation); this plan is for that placement"
    )


def _part_time(job: Job, s: PlanSummary) -> float:
    """Time per part [s]: the plan's cycle time where it plans the program's own depth in
    passes, else its passes of the job's stock depth times its cycle time (NaN: neither)."""
    if s.passes:
        return s.cycle_time_s
    return _passes(job, s) * s.cycle_time_s


def _passes(job: Job, s: PlanSummary) -> float:
    """Passes: the most of any section where the plan plans the program's own depth, else
    those needed to remove the job's stock depth at the plan's depth (NaN: no stock given)."""
    if s.passes:
        return float(max(int(r["passes"]) for r in s.passes))
    depth_mm = s.depth_mm
    stock = job.cut.stock_depth_m
    if stock is None or depth_mm <= 0:
        return math.nan
    return float(math.ceil(stock * 1e3 / depth_mm - 1e-9))


#: Line style and marker of each robot's speed curve, so that equal curves stay visible.
_STYLES = (("-", "o"), ("--", "s"), (":", "^"), ("-.", "D"), ((0, (5, 1, 1, 1)), "v"))


def _plot(cmp: Comparison) -> bytes:
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = cmp.table
    fig = Figure(figsize=(11, 7.4))
    axes = fig.subplots(2, 2)
    moved = t.get("placement_adjusted", pd.Series(False, index=t.index)).fillna(False)
    names = [
        f"{plot_text(str(r), 30)} *" if bool(m) else plot_text(str(r), 32)
        for r, m in zip(t["robot"], moved, strict=True)
    ]
    colors = ["C0", "C1", "C2", "C3", "C4", "C5"]
    # Per part, never per pass: a robot that needs three times the passes
    # must not look fastest because each pass is short.
    per_part = pd.to_numeric(t["part_time_s"], errors="coerce").notna().any()
    time_col, time_label = (
        ("part_time_s", "time per part, all passes [s]")
        if per_part
        else ("time_per_mm_depth_s", "machining time per mm of depth [s/mm]")
    )
    for ax, col, label, fmt in (
        (axes[0, 0], "mrr_cm3_per_min", "MRR [cm^3/min]", "{:.1f}"),
        (axes[0, 1], time_col, time_label, "{:.1f}"),
        (axes[1, 0], "min_margin", "minimum margin a_lim/depth", "{:.2f}"),
    ):
        vals = pd.to_numeric(t[col], errors="coerce").fillna(0.0).to_numpy()
        bars = ax.bar(names, vals, color=colors[: len(names)])
        for i, st in enumerate(t["status"]):
            if st != "ok":
                ax.text(i, 0, st, ha="center", va="bottom", rotation=90, fontsize=8)
        ok = (t["status"] == "ok").to_numpy()
        ax.bar_label(
            bars,
            labels=[fmt.format(v) if k else "" for v, k in zip(vals, ok, strict=True)],
            fontsize=8,
        )
        ax.set_ylabel(label)
        ax.margins(y=0.12)
    ax = axes[1, 1]
    n = max(len(cmp.results), 1)
    for i, (key, res) in enumerate(cmp.results.items()):
        ls, marker = _STYLES[i % len(_STYLES)]
        s_m = np.asarray(res.geom.s_m)
        rpm = np.asarray(res.outcome.best.rpm)
        span = (
            f"{rpm.min():.0f} rpm" if np.ptp(rpm) < 0.5 else f"{rpm.min():.0f}-{rpm.max():.0f} rpm"
        )
        # markers staggered between the robots: where curves coincide each stays visible
        every = max(1, len(s_m) // 8)
        label = f"{plot_text(key, 32)}: {span}"
        ax.plot(
            s_m, rpm, color=colors[i % len(colors)], ls=ls, lw=1.6, marker=marker, ms=6,
            markevery=(int(every * i / n), every), mfc="none", mew=1.4, label=label,
        )  # fmt: skip
    ax.set_xlabel("cutting length [m]")
    ax.set_ylabel("planned speed [rpm]")
    ax.set_title("planned spindle speed along the path", fontsize=10)
    if cmp.results:
        ax.legend(fontsize=8)
    fig.suptitle("Same job on each robot")
    if moved.any():
        fig.text(
            0.01, 0.01,
            "* workpiece moved: the job's placement does not reach the path on this robot; "
            "the plan is for the placement in compare.csv (placement_xyz_m)",
            fontsize=8,
        )  # fmt: skip
    fig.tight_layout(rect=(0, 0.03 if moved.any() else 0, 1, 1))
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


#: Files of a comparison; with the robot folders they are the managed output set.
COMPARE_FILES = ("compare.csv", "compare.json", "compare.png")


def robot_folders(robots: list[str]) -> dict[str, str]:
    """The output folder name of each robot of a comparison (robot spec -> name).

    The file stem of a robot file (``cells/r1.toml`` -> ``r1``), the name of
    a built-in robot, made a safe folder name (:func:`robolobe._atomic.safe_name`:
    ``...toml`` -> ``robot``); a name that repeats (``a/r.toml``,
    ``b/r.toml``) gets ``-2``, ``-3`` ... (:func:`robot_folder_notes` says which).
    """
    return dict(zip(robots, _folder_names(robots).names, strict=True))


def robot_folder_notes(robots: list[str]) -> tuple[str, ...]:
    """One line per robot whose folder is not its file stem as written (and why)."""
    return _folder_names(robots).notes


def _folder_names(robots: list[str]) -> SafeNames:
    return unique_names(
        [Path(spec).stem for spec in robots],
        what="robot",
        fallback="robot",
        taken=COMPARE_FILES,
        labels=robots,
    )


def write_comparison(
    cmp: Comparison, out_dir: str | os.PathLike[str], *, plans: bool = True
) -> Path:
    """Write ``compare.csv``, ``compare.json``, ``compare.png`` (+ each robot's plan) atomically.

    The outputs are one set (:func:`robolobe._atomic.atomic_dir`, kind
    ``compare``): a re-run into the same folder replaces the files and
    removes those of the earlier comparison that this one did not write (its
    robot folders); files robolobe did not write are kept, and one in the way
    of a new file is refused (:class:`~robolobe.errors.InputError`).
    """
    import json

    from robolobe.plan import _plots
    from robolobe.plan.report import _PLOTTERS, PLOTS, _program_files, render_html, write_csv

    out = Path(out_dir)
    png = _plot(cmp)
    folders = robot_folders([str(r) for r in cmp.table["robot"]])
    per_robot: dict[str, dict[str, bytes]] = {}
    programs: dict[str, dict[str, str]] = {}
    if plans:
        for key, res in cmp.results.items():
            per_robot[key] = {name: _plots.png(_PLOTTERS[name](res)) for name in PLOTS}
            programs[key] = _program_files(res, True, None)  # refused before anything is written
    table = cmp.table.copy()
    table["folder"] = [folders[str(r)] if r in cmp.results else "" for r in table["robot"]]
    with atomic_dir(out, "compare", option="--output") as tmp:
        t = table.copy()
        t["placement_xyz_m"] = t["placement_xyz_m"].map(
            lambda v: json.dumps(v) if isinstance(v, list) else ""
        )
        t.to_csv(tmp / "compare.csv", index=False)
        records = json.loads(table.to_json(orient="records"))
        (tmp / "compare.json").write_text(json.dumps(records, indent=2) + "\n", encoding="utf-8")
        (tmp / "compare.png").write_bytes(png)
        for key, res in cmp.results.items():
            d = tmp / folders[key]
            (d / "plots").mkdir(parents=True)
            write_csv(res.table, d / "waypoints.csv")
            (d / "summary.json").write_text(
                json.dumps(res.summary.to_dict(), indent=2) + "\n", encoding="utf-8"
            )
            for name, data in per_robot.get(key, {}).items():
                (d / "plots" / f"{name}.png").write_bytes(data)
            for name, text in programs.get(key, {}).items():
                (d / name).write_text(text, encoding="utf-8")
            if key in per_robot:
                (d / "report.html").write_text(
                    render_html(res, per_robot[key], program=programs.get(key)), encoding="utf-8"
                )
    return out
