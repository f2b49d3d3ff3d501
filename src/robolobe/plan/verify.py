"""Verify an existing plan against another source of robot modes.

A plan (the folder :func:`robolobe.plan.report.write_outputs` wrote) states a
speed and a depth at every cutting waypoint and the limit it believed. This
module re-evaluates those limits on other modes, with exactly the planner's
modelling: the postures and feed directions the plan recorded, the job's
tool-point model, feed frame, lobes and lookup (:func:`robolobe.plan.pipeline.cut_lobes`),
only the robot modes swapped. Sources: a robot file (its twin, optionally
with physics effects), a tl model file, or a fresh hammer-test campaign
(identified, then the robot file it names calibrated to it,
:class:`robolobe.tl.graybox.TwinCalibration`).

Verifying a plan against the modes that made it reproduces its ``a_lim_mm``
column (a nominal plan; a robust plan's column is the robust bound, which a
verification on one robot does not apply).
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

from robolobe._atomic import check_input_file
from robolobe._text import plot_text
from robolobe.errors import InputError
from robolobe.plan.job import Job, load_job
from robolobe.plan.limits import process_limits
from robolobe.plan.modes import ModeSource, TwinSource, model_file_source
from robolobe.plan.pipeline import (
    _tool_model,
    cut_lobes,
    job_fingerprint,
    material_from_job,
    waypoints_hash,
)
from robolobe.robots.io import load_robot
from robolobe.robots.model import Robot

__all__ = ["VERIFY_FILES", "VerifyResult", "read_plan", "verify_plan", "write_verify"]

FloatArray = NDArray[np.float64]

#: Fewest postures of a campaign that ``verify --campaign`` calibrates a twin on.
MIN_CAMPAIGN_POSTURES = 8

_NEEDED: tuple[str, ...] = (
    *("source", "line", "motion", "x_mm", "y_mm", "z_mm", "feed_angle_deg", "rpm"),
    *("depth_mm", "a_lim_mm", "limiting", *(f"q{j}_deg" for j in range(1, 7))),
)


@dataclass(frozen=True, eq=False)
class VerifyResult:
    """A plan evaluated on other modes.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per cutting waypoint: ``waypoint`` (row of waypoints.csv),
        ``source``, ``line``, ``rpm``, ``depth_mm``, ``a_lim_plan_mm`` (the
        plan's), ``a_lim_mm`` (on the verifying modes), ``margin``
        (``a_lim_mm / depth_mm``; inf for plunges), ``status`` (``"chatter"``
        where ``margin < 1``, ``"inside SF"`` where ``margin`` is below the
        plan's safety factor, ``"ok"``, ``"plunge"``, ``"air"``). A plan made
        at each move's own engagement is verified at it: ``depth_mm`` is then
        the move's own depth per pass (``cut_depth_mm`` of the plan).
    n_beyond : int
        Waypoints predicted to chatter (depth above the limit).
    n_inside_sf : int
        Waypoints whose margin is below the safety factor (chatter included).
    min_margin : float
        Smallest margin (inf when there is no bounded waypoint).
    min_margin_at : str
        ``file:line`` of that waypoint.
    chatter : tuple of str
        ``file:line`` of every waypoint predicted to chatter.
    safety_factor : float
    mode_source : str
        What the modes came from.
    plan_dir : str
    summary : dict
        JSON-ready summary.
    """

    table: pd.DataFrame
    n_beyond: int
    n_inside_sf: int
    min_margin: float
    min_margin_at: str
    chatter: tuple[str, ...]
    safety_factor: float
    mode_source: str
    plan_dir: str
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        """True when no waypoint is beyond its limit."""
        return self.n_beyond == 0


def read_plan(
    plan_dir: str | os.PathLike[str], job: str | os.PathLike[str] | Job | None = None
) -> tuple[pd.DataFrame, dict[str, Any], Job]:
    """A plan's table, summary and job, checked to belong together.

    Parameters
    ----------
    plan_dir : path-like
        Folder with ``waypoints.csv`` and ``summary.json``.
    job : path-like or Job, optional
        The job (default: the job file the summary records).

    Raises
    ------
    InputError
        Missing or unreadable files, a plan without a record, a job whose tool,
        material, cut or placement differ from the plan's, a path whose hash
        differs.
    """
    d = Path(plan_dir)
    if not d.is_dir():
        raise InputError("expected a plan folder (robolobe plan -o DIR), found none", str(d))
    for name in ("waypoints.csv", "summary.json"):
        check_input_file(d / name, f"{name} in the plan folder (robolobe plan -o DIR)")
    from robolobe._documents import parse_json

    where = str(d / "summary.json")
    try:
        text = (d / "summary.json").read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"unreadable JSON: {exc}", where) from None
    summary = parse_json(text, where)
    record = summary.get("plan_record")
    if not isinstance(record, dict) or "job" not in record:
        raise InputError(
            "no plan_record (written by an older robolobe or edited): plan the path again",
            where,
        )
    # a tampered record: each field the check reads, of the type the plan wrote
    for key, kind, expected in (
        ("job", dict, "a table"),
        ("waypoints_sha256", str, "a string"),
        ("path_sha256", (str, type(None)), "a string"),
    ):
        if not isinstance(record.get(key), kind):
            raise InputError(
                f"plan_record.{key}: expected {expected}, found {type(record.get(key)).__name__} "
                "(the record was edited: plan the path again)",
                where,
            )
    for key in ("path", "job_file", "mode_source"):
        if not isinstance(summary.get(key), str | type(None)):
            raise InputError(
                f"{key}: expected a string, found {type(summary.get(key)).__name__} "
                "(the record was edited: plan the path again)",
                where,
            )
    try:
        table = pd.read_csv(d / "waypoints.csv", keep_default_na=True)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise InputError(f"unreadable CSV: {exc}", str(d / "waypoints.csv")) from None
    missing = [c for c in _NEEDED if c not in table.columns]
    if missing:
        raise InputError(
            f"expected the plan's columns, missing {', '.join(missing)}", str(d / "waypoints.csv")
        )
    table["limiting"] = table["limiting"].fillna("").astype(str)
    table["source"] = table["source"].astype(str)
    if waypoints_hash(table) != record.get("waypoints_sha256"):
        raise InputError(
            "path hash differs from the plan's record (the waypoints were edited or come from "
            "another plan)",
            str(d / "waypoints.csv"),
        )
    path = summary.get("path")
    if record.get("path_sha256") and path and Path(str(path)).is_file():
        import hashlib

        if hashlib.sha256(Path(str(path)).read_bytes()).hexdigest() != record["path_sha256"]:
            raise InputError(
                "toolpath changed since the plan (path hash differs from summary.json's): "
                "plan it again",
                str(path),
            )
    if isinstance(job, Job):
        j = job
    else:
        spec = job if job is not None else summary.get("job_file")
        if not spec or spec == "<code>" or not Path(str(spec)).is_file():
            raise InputError(
                f"expected the plan's job file, found {spec!r} (give it with --job)",
                str(d / "summary.json"),
            )
        j = load_job(spec)
    found = job_fingerprint(j)
    want = record["job"]
    diff = [k for k in want if json.dumps(found.get(k)) != json.dumps(want[k])]
    if diff:
        k = diff[0]
        raise InputError(
            f"job does not match the plan: {k} is {json.dumps(found.get(k))}, the plan used "
            f"{json.dumps(want[k])}" + (f" (also {', '.join(diff[1:])})" if diff[1:] else ""),
            j.source,
        )
    return table, summary, j


def _check_limits(robot: Robot, q: FloatArray, table: pd.DataFrame, where: str) -> None:
    lo, hi = robot.q_min, robot.q_max
    bad = (q < lo - 1e-9) | (q > hi + 1e-9)
    if np.any(bad):
        i, j = (int(v) for v in np.argwhere(bad)[0])
        raise InputError(
            f"waypoint {int(table.index[i])} ({table['source'].iloc[i]}:"
            f"{int(table['line'].iloc[i])}): q{j + 1} = {math.degrees(q[i, j]):.2f} deg outside "
            f"{robot.name}'s limits [{math.degrees(lo[j]):.1f}, {math.degrees(hi[j]):.1f}] deg",
            where,
        )


def _campaign_source(campaign: str | os.PathLike[str]) -> TwinSource:
    """Identify a hammer-test campaign and calibrate its robot file to it."""
    from robolobe.campaign import read_campaign
    from robolobe.modal.identify import identify_campaign
    from robolobe.tl.graybox import TwinCalibration

    camp = read_campaign(campaign)
    n = len(camp.posture_ids)
    if n < MIN_CAMPAIGN_POSTURES:
        raise InputError(
            f"expected at least {MIN_CAMPAIGN_POSTURES} postures to calibrate a twin on, found {n}",
            str(campaign),
        )
    modal = identify_campaign(camp)
    cal = TwinCalibration(robot=camp.robot).fit(modal.table)
    src = TwinSource(cal.robot_)
    src.name = f"twin of {camp.robot} calibrated to {Path(campaign).name} ({n} postures)"
    return src


def verify_plan(
    plan_dir: str | os.PathLike[str],
    *,
    robot: str | os.PathLike[str] | Robot | None = None,
    effects: str | os.PathLike[str] | None = None,
    model: str | os.PathLike[str] | None = None,
    campaign: str | os.PathLike[str] | None = None,
    source: ModeSource | None = None,
    job: str | os.PathLike[str] | Job | None = None,
    dynamics_tol: float | None = None,
) -> VerifyResult:
    """Evaluate a plan on other robot modes (see the module docstring).

    Give exactly one of ``robot`` (with optional ``effects``), ``model``,
    ``campaign`` or ``source``.

    Parameters
    ----------
    plan_dir : path-like
        The plan folder.
    robot : path-like or Robot, optional
        A robot (``"A"``, ``"B"``, ``"C"`` or a file): its twin's modes.
    effects : path-like, optional
        An effects.toml added to that twin.
    model : path-like, optional
        A tl model file (``.npz``) or ``"A"``, ``"B"``, ``"C"`` (shipped).
    campaign : path-like, optional
        A hammer-test campaign folder: identified, its robot calibrated.
    source : ModeSource, optional
        Any mode source (Python use).
    job : path-like or Job, optional
        Default: the job file the plan records.
    dynamics_tol : float, optional
        Lobe-sharing tolerance (default the job's, as the planner; 0: every
        waypoint its own lobes).

    Returns
    -------
    VerifyResult

    Raises
    ------
    InputError
        See :func:`read_plan`; also no or several mode sources, postures
        outside the robot's limits, a campaign with too few postures.
    """
    given = [x is not None for x in (robot, model, campaign, source)]
    if sum(given) != 1:
        raise InputError("expected exactly one of --robot, --model, --campaign", "verify")
    if effects is not None and robot is None:
        raise InputError("--effects acts on a robot's twin: give --robot too", str(effects))
    table, summary, j = read_plan(plan_dir, job)
    cut = (table["motion"] == "cut").to_numpy()
    ci = np.flatnonzero(cut)
    sub = table.iloc[ci]
    q = np.radians(sub[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(dtype=np.float64))
    if not np.all(np.isfinite(q)):
        raise InputError(
            "expected finite postures q1_deg..q6_deg", str(Path(plan_dir) / "waypoints.csv")
        )
    where = str(Path(plan_dir) / "waypoints.csv")
    if source is None:
        if robot is not None:
            rob = robot if isinstance(robot, Robot) else load_robot(robot)
            _check_limits(rob, q, sub, where)
            eff: tuple[Any, ...] = ()
            if effects is not None:
                from robolobe.twin.effects_file import read_effects

                eff = tuple(read_effects(effects))
            source = TwinSource(rob, eff)
        elif model is not None:
            from robolobe.tl.models import check_model_robot, load_model

            pred = load_model(str(model) if str(model).upper() in ("A", "B", "C") else Path(model))
            plan_robot = load_robot(j.robot)
            check_model_robot(pred, plan_robot, "--model")
            _check_limits(plan_robot, q, sub, where)
            source = model_file_source(pred, Path(str(model)).name)
        else:
            assert campaign is not None
            source = _campaign_source(campaign)
            _check_limits(source.twin.robot, q, sub, where)
    modes = source.predict(q)
    fa = np.radians(sub["feed_angle_deg"].to_numpy(dtype=np.float64))
    plunge_rec = (sub["limiting"] == "plunge").to_numpy()
    f_tcp = np.stack([np.cos(fa), np.sin(fa), np.zeros_like(fa)], axis=1)
    f_tcp[plunge_rec] = [0.0, 0.0, 1.0]
    # the plan's own grid: the spindle's range within the vc range (plan_path)
    lim = process_limits(j)
    rpm_grid = np.linspace(lim.rpm_min, lim.rpm_max, j.plan.n_rpm)
    own = (
        sub["lobes_own"].astype(str).str.lower().isin(("true", "1")).to_numpy()
        if "lobes_own" in sub.columns
        else None
    )
    # a plan made at each move's own engagement is checked at it, at each move's own depth
    engagement = None
    air = None
    depth_col = "depth_mm"
    if {"phi_entry_deg", "phi_exit_deg", "cut_depth_mm"} <= set(sub.columns):
        pe = np.radians(sub["phi_entry_deg"].to_numpy(dtype=np.float64))
        px = np.radians(sub["phi_exit_deg"].to_numpy(dtype=np.float64))
        air = ~(np.isfinite(pe) & np.isfinite(px))
        engagement = (pe, px)
        depth_col = "cut_depth_mm"
    _, plunge, grouped, _, _, _ = cut_lobes(
        j,
        modes,
        f_tcp,
        material_from_job(j),
        _tool_model(j),
        rpm_grid,
        dynamics_tol=dynamics_tol,
        robust=False,
        own=own,
        engagement=engagement,
        air=air,
    )
    rpm = sub["rpm"].to_numpy(dtype=np.float64)
    depth = sub[depth_col].to_numpy(dtype=np.float64) * 1e-3
    a_lim = grouped.table.query(rpm)
    is_air = np.zeros(plunge.shape, bool) if air is None else air & ~plunge
    plunge = plunge | is_air  # no lateral limit either way
    margin = np.where(plunge, np.inf, a_lim / np.maximum(depth, 1e-300))
    sf = float(j.plan.safety_factor)
    status = np.where(
        plunge,
        np.where(is_air, "air", "plunge"),
        np.where(margin < 1.0, "chatter", np.where(margin < sf * (1 - 1e-9), "inside SF", "ok")),
    )
    labels = [f"{a}:{int(b)}" for a, b in zip(sub["source"], sub["line"], strict=True)]
    out = pd.DataFrame(
        {
            "waypoint": ci,
            "source": sub["source"].to_numpy(),
            "line": sub["line"].to_numpy(),
            "rpm": rpm,
            "depth_mm": depth * 1e3,
            "a_lim_plan_mm": sub["a_lim_mm"].to_numpy(dtype=np.float64),
            "a_lim_mm": np.where(np.isfinite(a_lim), a_lim * 1e3, np.nan),
            "margin": margin,
            "status": status,
        }
    )
    bounded = np.isfinite(margin)
    if np.any(bounded):
        k = int(np.argmin(np.where(bounded, margin, np.inf)))
        mmin, at = float(margin[k]), labels[k]
    else:
        mmin, at = math.inf, ""
    beyond = np.flatnonzero(status == "chatter")
    n_inside = int(np.sum((status == "chatter") | (status == "inside SF")))
    n_b = int(np.sum(bounded))
    summ = {
        "plan_dir": str(plan_dir),
        "plan_mode_source": summary.get("mode_source"),
        "mode_source": source.name,
        "n_cut": int(ci.size),
        "n_bounded": n_b,
        "n_beyond_limit": int(beyond.size),
        "pct_beyond_limit": round(100.0 * beyond.size / max(n_b, 1), 3),
        "n_inside_safety_factor": n_inside,
        "pct_inside_safety_factor": round(100.0 * n_inside / max(n_b, 1), 3),
        "safety_factor": sf,
        "min_margin": None if not math.isfinite(mmin) else round(mmin, 5),
        "min_margin_at": at,
        "chatter_at": [labels[i] for i in beyond],
        "verdict": "chatter predicted" if beyond.size else "no chatter predicted",
    }
    return VerifyResult(
        table=out,
        n_beyond=int(beyond.size),
        n_inside_sf=n_inside,
        min_margin=mmin,
        min_margin_at=at,
        chatter=tuple(labels[i] for i in beyond),
        safety_factor=sf,
        mode_source=source.name,
        plan_dir=str(plan_dir),
        summary=summ,
    )


def plot_verify_margin(res: VerifyResult) -> Any:
    """Margin (verified limit / depth) along the path, with the plan's own for comparison."""
    from matplotlib.figure import Figure

    t = res.table
    fig = Figure(figsize=(8, 4))
    ax = fig.add_subplot()
    x = np.arange(len(t))
    m_plan = t["a_lim_plan_mm"].to_numpy() / t["depth_mm"].to_numpy()
    ax.plot(x, m_plan, lw=1.0, color="0.6", label="plan's own margin")
    ax.plot(
        x,
        t["margin"].to_numpy(),
        lw=1.2,
        color="C0",
        label=f"margin on {plot_text(res.mode_source)}",
    )
    bad = (t["status"] == "chatter").to_numpy()
    if np.any(bad):
        ax.plot(x[bad], t["margin"].to_numpy()[bad], "x", color="C3", label="chatter")
    ax.axhline(1.0, color="C3", lw=0.8, label="limit (margin 1)")
    ax.axhline(
        res.safety_factor, color="k", lw=0.8, ls=":", label=f"safety factor {res.safety_factor:g}"
    )
    finite = t["margin"].to_numpy()[np.isfinite(t["margin"].to_numpy())]
    top = max(2.5 * res.safety_factor, float(np.nanpercentile(finite, 90)) if finite.size else 1.0)
    ax.set_ylim(0, top)
    ax.set_xlabel("cutting waypoint")
    ax.set_ylabel("a_lim / depth")
    ax.set_title("Verified stability margin along the path")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


#: The files :func:`write_verify` always writes (checked before a run: :mod:`robolobe._atomic`).
VERIFY_FILES: tuple[str, ...] = ("verify.csv", "verify.json")


def write_verify(res: VerifyResult, out_dir: str | os.PathLike[str], *, plots: bool = True) -> Path:
    """Write ``verify.csv``, ``verify.json`` and ``plots/verify_margin.png`` atomically.

    A re-run replaces the whole set (``plots/`` of an earlier run goes when
    ``plots`` is False); other files in ``out_dir`` are kept
    (:func:`robolobe._atomic.atomic_dir`, kind ``verify``).
    """
    from robolobe._atomic import atomic_dir
    from robolobe.plan import _plots
    from robolobe.plan.report import write_csv

    out = Path(out_dir)
    png = _plots.png(plot_verify_margin(res)) if plots else None
    with atomic_dir(out, "verify", option="--output") as tmp:
        csv_name, json_name = VERIFY_FILES
        write_csv(res.table, tmp / csv_name)
        (tmp / json_name).write_text(json.dumps(res.summary, indent=2) + "\n", encoding="utf-8")
        if png is not None:
            (tmp / "plots").mkdir()
            (tmp / "plots" / "verify_margin.png").write_bytes(png)
    return out
