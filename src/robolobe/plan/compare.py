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
import logging
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robolobe._atomic import atomic_dir
from robolobe.errors import (
    InfeasibleError,
    InputError,
    ReachabilityError,
    RobolobeError,
    SingularityError,
)
from robolobe.plan.job import Job
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
    job: Job,
    robots: list[str],
    *,
    refine: bool = True,
) -> Comparison:
    """Plan the same path and job on each robot.

    Parameters
    ----------
    path : path-like or DataFrame
        The toolpath.
    job : Job
        The job (its robot is replaced by each of ``robots``; a ``builtin``
        model means each robot's shipped model).
    robots : list of str
        ``"A"``, ``"B"``, ``"C"`` or robot files.
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
        spec = key.upper() if key.upper() in ("A", "B", "C") else str(Path(key))
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
                passes=_passes(jr, s.depth_mm),
                part_time_s=_passes(jr, s.depth_mm) * s.cycle_time_s,
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


def _passes(job: Job, depth_mm: float) -> float:
    """Passes needed to remove the job's stock at ``depth_mm`` per pass (NaN: no stock given)."""
    stock = job.cut.stock_depth_m
    if stock is None or depth_mm <= 0:
        return math.nan
    return float(math.ceil(stock * 1e3 / depth_mm - 1e-9))


def _plot(cmp: Comparison) -> bytes:
    import io

    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = cmp.table
    fig = Figure(figsize=(11, 7))
    axes = fig.subplots(2, 2)
    names = list(t["robot"].astype(str))
    colors = ["C0", "C1", "C2", "C3", "C4", "C5"]
    # Per part, never per pass: a robot that needs three times the passes
    # must not look fastest because each pass is short.
    per_part = pd.to_numeric(t["part_time_s"], errors="coerce").notna().any()
    time_col, time_label = (
        ("part_time_s", "time per part, all passes [s]")
        if per_part
        else ("time_per_mm_depth_s", "machining time per mm of depth [s/mm]")
    )
    for ax, col, label in (
        (axes[0, 0], "mrr_cm3_per_min", "MRR [cm^3/min]"),
        (axes[0, 1], time_col, time_label),
        (axes[1, 0], "min_margin", "minimum margin a_lim/depth"),
    ):
        vals = pd.to_numeric(t[col], errors="coerce").fillna(0.0).to_numpy()
        ax.bar(names, vals, color=colors[: len(names)])
        for i, st in enumerate(t["status"]):
            if st != "ok":
                ax.text(i, 0, st, ha="center", va="bottom", rotation=90, fontsize=8)
        ax.set_ylabel(label)
    ax = axes[1, 1]
    for i, (key, res) in enumerate(cmp.results.items()):
        ax.plot(res.geom.s_m, res.outcome.best.rpm, color=colors[i % len(colors)], label=key)
    ax.set_xlabel("cutting length [m]")
    ax.set_ylabel("planned speed [rpm]")
    ax.set_title("planned spindle speed along the path")
    if cmp.results:
        ax.legend(fontsize=8)
    fig.suptitle("Same job on each robot")
    fig.tight_layout()
    FigureCanvasAgg(fig)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=100)
    return buf.getvalue()


#: Files of a comparison; with the robot folders they are the managed output set.
COMPARE_FILES = ("compare.csv", "compare.json", "compare.png")


def robot_folders(robots: list[str]) -> dict[str, str]:
    """The output folder name of each robot of a comparison (robot spec -> name).

    The file stem of a robot file (``cells/r1.toml`` -> ``r1``), the name of
    a built-in robot; a stem that repeats (``a/r.toml``, ``b/r.toml``) gets
    ``-2``, ``-3`` ...
    """
    out: dict[str, str] = {}
    for spec in robots:
        stem = Path(spec).stem or "robot"
        name, n = stem, 1
        while name in out.values() or name in COMPARE_FILES:
            n += 1
            name = f"{stem}-{n}"
        out[spec] = name
    return out


def _stale_folders(out: Path) -> list[str]:
    """Robot folders an earlier comparison wrote into ``out`` (from its compare.json).

    Only plain names of folders that hold a ``summary.json`` count, so a
    damaged or foreign compare.json cannot remove anything else.
    """
    import json

    try:
        records = json.loads((out / "compare.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    if not isinstance(records, list):
        return []
    specs = [str(r["robot"]) for r in records if isinstance(r, dict) and "robot" in r]
    names = [
        str(r.get("folder") or robot_folders(specs).get(str(r["robot"]), ""))
        for r in records
        if isinstance(r, dict) and "robot" in r
    ]
    return [
        n
        for n in names
        if n
        and n not in (".", "..")
        and Path(n).name == n
        and "\\" not in n
        and (out / n / "summary.json").is_file()
    ]


def write_comparison(
    cmp: Comparison, out_dir: str | os.PathLike[str], *, plans: bool = True
) -> Path:
    """Write ``compare.csv``, ``compare.json``, ``compare.png`` (+ each robot's plan) atomically.

    The outputs are one set: a re-run into the same folder replaces the
    files and removes the robot folders of the earlier comparison that this
    one did not write (other files in the folder are kept).
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
    managed = (*COMPARE_FILES, *_stale_folders(out), *folders.values())
    with atomic_dir(out, managed=managed) as tmp:
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
