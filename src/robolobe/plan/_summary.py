"""The typed summary of one plan (:class:`PlanSummary`) and its presentation.

Everything a plan says about itself in words and headline numbers is made
here, once: the rounded figures of ``summary.json``, the notes (reader and
robot-file warnings, extrapolation, plunges, lobe splits, the robust
bound's statement) and the comparison with the baselines. The pipeline
hands over its typed results (:meth:`PlanSummary.build`); readers take
typed attributes; :meth:`PlanSummary.to_dict` gives the JSON that
``robolobe plan`` writes (``summary.json``), key for key.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from robolobe._text import count
from robolobe.robots.plausibility import robot_warnings

if TYPE_CHECKING:
    import pandas as pd

    from robolobe.plan.job import Job
    from robolobe.plan.limits import ProcessLimits
    from robolobe.plan.lobes import GroupedLobes
    from robolobe.plan.modes import RobustBound
    from robolobe.plan.optimize import Constraints, PathGeometry, PlanOutcome, Schedule
    from robolobe.robots.model import Robot

__all__ = [
    "BaselineComparison",
    "Candidates",
    "LimitCount",
    "MarginLocation",
    "PlanSummary",
    "RobustBoundSummary",
    "ScheduleSummary",
    "SpreadPct",
]

#: Relative prediction extrapolation (share of a joint range) above which a
#: cutting posture counts as outside the model's training range in the notes.
EXTRAPOLATION_NOTE = 0.1


def _plain(value: Any) -> Any:
    """``value`` as JSON types: typed pieces by their ``to_dict``, tuples as lists."""
    if isinstance(value, _Piece):
        return value.to_dict()
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    return value


class _Piece:
    """``to_dict`` of a frozen dataclass: its fields in order, as JSON types."""

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of this piece (field names as keys, in field order)."""
        assert dataclasses.is_dataclass(self)
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}


@dataclass(frozen=True)
class ScheduleSummary(_Piece):
    """Headline figures of one verified schedule (the plan's or a baseline's).

    Attributes
    ----------
    method : str
        ``"nlp"``, ``"search"``, ``"constant"`` or ``"programmed"``.
    feasible : bool
        Whether every constraint holds at a depth of at least the job's minimum.
    reason : str
        Why not, when infeasible (else ``""``).
    depth_mm : float
        Depth per pass [mm], to 1e-4 mm.
    rpm_min, rpm_max, rpm_mean : float
        Spindle speed over the cutting waypoints [rpm], to 0.1 rpm.
    mrr_cm3_per_min : float
        Material removal rate while cutting [cm^3/min], to 1e-3.
    cut_time_s, cycle_time_s : float
        Time cutting, and in all with the rapids [s], to 1 ms.
    """

    method: str
    feasible: bool
    reason: str
    depth_mm: float
    rpm_min: float
    rpm_max: float
    rpm_mean: float
    mrr_cm3_per_min: float
    cut_time_s: float
    cycle_time_s: float

    @classmethod
    def of(cls, s: Schedule) -> ScheduleSummary:
        """The rounded figures of schedule ``s``."""
        return cls(**_schedule_figures(s))


def _schedule_figures(s: Schedule) -> dict[str, Any]:
    return {
        "method": s.method,
        "feasible": bool(s.feasible),
        "reason": s.reason,
        "depth_mm": round(s.depth_m * 1e3, 4),
        "rpm_min": round(float(np.min(s.rpm)), 1),
        "rpm_max": round(float(np.max(s.rpm)), 1),
        "rpm_mean": round(float(np.mean(s.rpm)), 1),
        "mrr_cm3_per_min": round(s.volume_rate_cm3_per_min, 3),
        "cut_time_s": round(s.cut_time_s, 3),
        "cycle_time_s": round(s.cycle_time_s, 3),
    }


@dataclass(frozen=True)
class BaselineComparison(ScheduleSummary):
    """A baseline schedule and what the plan gains over it.

    Attributes
    ----------
    mrr_gain_pct : float or None
        Removal rate of the plan over the baseline's, minus 1 [%], to 0.01 %;
        None when the baseline is infeasible or removes nothing.
    cycle_time_saving_pct : float or None
        Cycle time saved for the same stock [%] (the depths set how many
        passes each needs), to 0.01 %; None as ``mrr_gain_pct``.

    Notes
    -----
    The baseline's own figures are those of :class:`ScheduleSummary`.
    """

    mrr_gain_pct: float | None = None
    cycle_time_saving_pct: float | None = None

    @classmethod
    def between(cls, best: Schedule, base: Schedule) -> BaselineComparison:
        """Plan ``best`` against baseline ``base``."""
        gain = saving = None
        if base.feasible and base.mrr_m3_per_s > 0:
            gain = round(100.0 * (best.mrr_m3_per_s / base.mrr_m3_per_s - 1.0), 2)
            # same volume: the depth ratio sets how many passes a given stock needs
            saving = round(
                100.0
                * (1.0 - (best.cycle_time_s / best.depth_m) / (base.cycle_time_s / base.depth_m)),
                2,
            )
        return cls(**_schedule_figures(base), mrr_gain_pct=gain, cycle_time_saving_pct=saving)


@dataclass(frozen=True)
class Candidates(_Piece):
    """The verified candidates the plan was chosen from (None: not made).

    Attributes
    ----------
    search : ScheduleSummary or None
        The global search's schedule.
    nlp : ScheduleSummary or None
        The casadi/IPOPT refinement's schedule.
    constant : ScheduleSummary or None
        The best constant speed.
    """

    search: ScheduleSummary | None
    nlp: ScheduleSummary | None
    constant: ScheduleSummary | None


@dataclass(frozen=True)
class MarginLocation(_Piece):
    """Where the plan's stability margin is smallest.

    Attributes
    ----------
    waypoint : int
        Row in the waypoint table (0-based, all waypoints).
    source : str
        ``file:line`` of the waypoint in the toolpath.
    x_mm, y_mm, z_mm : float
        Waypoint in the path frame [mm], to 1 um.
    rpm : float
        Planned spindle speed there [rpm], to 0.1 rpm.
    """

    waypoint: int
    source: str
    x_mm: float
    y_mm: float
    z_mm: float
    rpm: float


@dataclass(frozen=True)
class LimitCount(_Piece):
    """How many cutting waypoints one constraint limits.

    Attributes
    ----------
    limit : str
        The constraint closest to binding (``"stability"``, ``"power"``,
        ``"torque"``, ``"depth_max"``, ``"rpm_min"``, ``"rpm_max"``,
        ``"feed_max"``) or ``"plunge"`` (a move along the tool axis).
    count : int
        Cutting waypoints it limits.
    """

    limit: str
    count: int


@dataclass(frozen=True)
class SpreadPct(_Piece):
    """A relative spread of the modal parameters [%] (``100 (exp(std of log) - 1)``).

    Attributes
    ----------
    f, zeta, k : float
        Natural frequency, damping ratio and modal stiffness [%], to 1e-3 %.
    """

    f: float
    zeta: float
    k: float


@dataclass(frozen=True)
class RobustBoundSummary(_Piece):
    """The bound a robust plan plans on, in figures and one sentence.

    Attributes
    ----------
    k_sigma : float
        Standard deviations below the prediction.
    confidence_pct : float
        One-sided probability per quantity if the spread is normal in log [%].
    spread_from : str
        Where the spread came from.
    frequency_window_pct_max, frequency_window_pct_median : float
        Relative half-width of the speed window over the waypoints [%].
    stiffness_lowered_to_pct, damping_lowered_to_pct : float
        Modal stiffness and damping planned on, relative to the prediction [%].
    spread_pct_median : SpreadPct or None
        Median spread over the modes that matter (None: not known).
    spread_pct_max : SpreadPct
        Largest spread over them.
    statement : str
        The bound in words (also the plan's note).
    """

    k_sigma: float
    confidence_pct: float
    spread_from: str
    frequency_window_pct_max: float
    frequency_window_pct_median: float
    stiffness_lowered_to_pct: float
    damping_lowered_to_pct: float
    spread_pct_median: SpreadPct | None
    spread_pct_max: SpreadPct
    statement: str

    @classmethod
    def of(cls, bound: RobustBound) -> RobustBoundSummary:
        """The figures :meth:`RobustBound.describe` states, typed."""
        d = dict(bound.describe())
        for key in ("spread_pct_median", "spread_pct_max"):
            v = d[key]
            d[key] = None if v is None else SpreadPct(**v)  # type: ignore[arg-type]
        return cls(**d)  # type: ignore[arg-type]


@dataclass(frozen=True)
class PlanSummary(_Piece):
    """What one plan says about itself: headline figures, provenance and notes.

    Made by :meth:`build` from the pipeline's results; :meth:`to_dict` is
    ``summary.json`` (the keys in this order). Lengths in mm, speeds in rpm,
    times in s, as the names say; figures rounded as written.

    Attributes
    ----------
    robolobe_version : str
    job : str
        The job's name.
    job_file : str
        The job file (``"<code>"`` for a job made in Python).
    path : str
        The toolpath file (or ``"<table>"``).
    robot : str
        The robot's name.
    robot_spec : str
        The robot as the job names it (built-in name or file).
    mode_source : str
        What predicted the robot's modes.
    tool_rotation_deg : float
        Rotation of the tool about its axis [deg], to 1e-3 deg.
    tool_rotation_search : str or None
        The candidates tried (``tool_rotation = "stiffest"``), else None.
    material : str
    n_waypoints, n_cut, n_plunge : int
        Waypoints, cutting ones, and plunges among those.
    n_dynamics_groups : int
        Distinct dynamics the lobes were computed for.
    speed_mode : {"scheduled", "constant"}
    robust : bool
        Planned on the lower bound of the prediction spread.
    robust_by_default : bool
        Robust because the modes carry a calibrated spread and the job does
        not set ``plan.robust``.
    k_sigma : float or None
        The job's ``k_sigma`` when robust.
    robust_bound : RobustBoundSummary or None
        The bound planned on (None: nominal modes).
    safety_factor : float
        Required ratio of the stability limit to the depth.
    method : str
        The chosen schedule's method (:attr:`ScheduleSummary.method`).
    nlp_status : str
        IPOPT's return status (or why it did not run).
    depth_mm : float
        Depth per pass [mm], to 1e-4 mm.
    rpm_min, rpm_max : float
        Planned spindle speed over the cutting waypoints [rpm], to 0.1 rpm.
    mrr_cm3_per_min : float
        Removal rate while cutting [cm^3/min], to 1e-3.
    cycle_time_s, cut_time_s, rapid_time_s : float
        Time in all, cutting and in rapids [s], to 1 ms.
    cut_length_m : float
        Cutting length [m], to 0.1 mm.
    min_margin : float
        Smallest ratio of stability limit to depth (>= ``safety_factor``), to 1e-4.
    min_margin_at : MarginLocation
    max_power_kW : float
        Largest cutting power [kW], to 0.1 W.
    torque_Nm : float
        Cutting torque at the planned depth [N m], to 1e-4.
    limiting_counts : tuple of LimitCount
        Cutting waypoints per limiting constraint, most first (ties in path order).
    vs_best_constant_speed, vs_programmed_speed : BaselineComparison or None
        The plan against the best constant speed and the programmed speeds
        (None: no such baseline).
    candidates : Candidates
    engagement : str
        What each move was planned at: ``"stock"`` (the job's ``[stock]``),
        ``"default stock"`` (the stock the program implies) -- each move's own
        engagement and depth, in passes -- or ``"cut.radial_width_mm"`` (one
        width, the planned depth).
    passes : tuple of mapping
        Per section of the program (consecutive cutting moves at one height):
        ``lines``, ``z_mm``, ``moves``, ``program_depth_mm``, ``passes``,
        ``depth_per_pass_mm``, ``set_by`` (the move that needs the most
        passes), ``min_margin``, ``rpm_min``/``rpm_max``, ``cut_time_s`` (all
        passes), ``volume_cm3`` (removed: depth x radial width x length of
        its engaged moves). Empty without engagement; with it ``mrr_cm3_per_min``
        is that volume over the cutting time of all passes.
    notes : tuple of str
        Warnings and remarks for the user, one sentence each.
    plan_record : mapping
        What ``robolobe verify`` checks a job and a path against
        (:func:`robolobe.plan.pipeline.plan_record`).
    timings_s : mapping of str to float
        Seconds per pipeline stage, to 0.1 ms.
    """

    robolobe_version: str
    job: str
    job_file: str
    path: str
    robot: str
    robot_spec: str
    mode_source: str
    tool_rotation_deg: float
    tool_rotation_search: str | None
    material: str
    n_waypoints: int
    n_cut: int
    n_plunge: int
    n_dynamics_groups: int
    speed_mode: str
    robust: bool
    robust_by_default: bool
    k_sigma: float | None
    robust_bound: RobustBoundSummary | None
    safety_factor: float
    method: str
    nlp_status: str
    depth_mm: float
    rpm_min: float
    rpm_max: float
    mrr_cm3_per_min: float
    cycle_time_s: float
    cut_time_s: float
    rapid_time_s: float
    cut_length_m: float
    min_margin: float
    min_margin_at: MarginLocation
    max_power_kW: float
    torque_Nm: float
    limiting_counts: tuple[LimitCount, ...]
    vs_best_constant_speed: BaselineComparison | None
    vs_programmed_speed: BaselineComparison | None
    candidates: Candidates
    engagement: str
    passes: tuple[Mapping[str, Any], ...]
    notes: tuple[str, ...]
    plan_record: Mapping[str, Any]
    timings_s: Mapping[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """``summary.json``: every attribute under its name, in order, as JSON types
        (``limiting_counts`` as an object of limit to count)."""
        d = super().to_dict()
        d["limiting_counts"] = {c.limit: c.count for c in self.limiting_counts}
        return d

    def with_timings(self, timings: Mapping[str, float]) -> PlanSummary:
        """This summary with the stage timings ``timings`` [s] (rounded to 0.1 ms)."""
        return dataclasses.replace(self, timings_s={k: round(v, 4) for k, v in timings.items()})

    @classmethod
    def build(
        cls,
        *,
        job: Job,
        path: str,
        robot: Robot,
        mode_source: str,
        material: str,
        waypoints: pd.DataFrame,
        table: pd.DataFrame,
        cut_index: NDArray[np.int64],
        lobes: GroupedLobes,
        outcome: PlanOutcome,
        constraints: Constraints,
        geometry: PathGeometry,
        tool_rotation_rad: float,
        plan_record: Mapping[str, Any],
        tool_rotation_search: str = "",
        extrapolation: NDArray[np.float64] | None = None,
        bound: RobustBound | None = None,
        mode_note: str = "",
        n_split: int = 0,
        sections: Sequence[Mapping[str, Any]] | None = None,
        engagement: str = "cut.radial_width_mm",
        limits: ProcessLimits | None = None,
    ) -> PlanSummary:
        """The summary of a plan from the pipeline's results.

        Parameters
        ----------
        job : Job
        path : str
            The toolpath file (or ``"<table>"``).
        robot : Robot
        mode_source : str
            Name of what predicted the modes.
        material : str
            The material's name.
        waypoints : pandas.DataFrame
            The input waypoint table (its ``attrs["warnings"]`` from the reader).
        table : pandas.DataFrame
            The per-waypoint result table (``limiting``, ``motion``, ``source``,
            ``line``, ``x_mm`` ``y_mm`` ``z_mm``).
        cut_index : ndarray of int, shape (n_cut,)
            Row of each cutting waypoint in ``table``.
        lobes : GroupedLobes
        outcome : PlanOutcome
        constraints : Constraints
        geometry : PathGeometry
        tool_rotation_rad : float
            Rotation of the tool about its axis [rad].
        plan_record : mapping
            :func:`robolobe.plan.pipeline.plan_record` of the plan.
        tool_rotation_search : str
            The rotations tried, when searched.
        extrapolation : ndarray, shape (n_cut,), optional
            Relative extrapolation of the mode prediction at each cutting posture.
        bound : RobustBound, optional
            The bound planned on (robust plans).
        mode_note : str
            The mode source's remark.
        n_split : int
            Waypoints that got lobes of their own next to a steep lobe wall.
        sections : sequence of mapping, optional
            The program's sections with their passes (the planner on a
            stock): the margins are then the table's (each move's own depth
            per pass) and the cutting time counts every pass.
        engagement : str
            :attr:`engagement`.
        limits : ProcessLimits, optional
            The limits the plan kept (:func:`robolobe.plan.limits.process_limits`);
            default: the job's alone, as :func:`~robolobe.plan.pipeline.constraints_from_job`
            makes them without.
        """
        import robolobe

        best = outcome.best
        mg = best.margin
        cut_time = best.cut_time_s
        mrr = best.volume_rate_cm3_per_min
        if sections:
            mg = table["margin"].to_numpy(dtype=np.float64)[cut_index]
            cut_time = float(sum(float(r["cut_time_s"]) for r in sections))
            vol = float(sum(float(r["volume_cm3"]) for r in sections))
            mrr = vol / max(cut_time, 1e-300) * 60.0
        k = int(np.argmin(np.where(np.isfinite(mg), mg, np.inf)))
        i = int(cut_index[k])
        counts = table.loc[table["motion"] == "cut", "limiting"].value_counts().to_dict()
        n_plunge = int(np.sum(table["limiting"] == "plunge"))
        robust = bool(job.plan.robust) or bound is not None
        rb = RobustBoundSummary.of(bound) if bound is not None else None
        notes = _notes(
            job=job,
            robot=robot,
            waypoints=waypoints,
            lobes=lobes,
            extrapolation=extrapolation,
            n_plunge=n_plunge,
            robust=robust,
            bound=rb,
            mode_note=mode_note,
            n_split=n_split,
        )
        notes += _limit_notes(job, robot, table, cut_index, limits)
        return cls(
            robolobe_version=robolobe.__version__,
            job=job.name,
            job_file=job.source,
            path=path,
            robot=robot.name,
            robot_spec=job.robot,
            mode_source=mode_source,
            tool_rotation_deg=round(math.degrees(tool_rotation_rad), 3),
            tool_rotation_search=tool_rotation_search or None,
            material=material,
            n_waypoints=len(waypoints),
            n_cut=int(cut_index.size),
            n_plunge=n_plunge,
            n_dynamics_groups=lobes.n_groups,
            speed_mode=job.plan.speed,
            robust=robust,
            robust_by_default=robust and job.plan.robust is None,
            k_sigma=job.plan.k_sigma if robust else None,
            robust_bound=rb,
            safety_factor=constraints.safety_factor,
            method=best.method,
            nlp_status=outcome.nlp_status,
            depth_mm=round(best.depth_m * 1e3, 4),
            rpm_min=round(float(best.rpm.min()), 1),
            rpm_max=round(float(best.rpm.max()), 1),
            mrr_cm3_per_min=round(mrr, 3),
            cycle_time_s=round(cut_time + geometry.rapid_time_s, 3),
            cut_time_s=round(cut_time, 3),
            rapid_time_s=round(geometry.rapid_time_s, 3),
            cut_length_m=round(geometry.length_m, 4),
            min_margin=round(float(mg[k]), 4),
            min_margin_at=MarginLocation(
                waypoint=i,
                source=f"{table['source'].iloc[i]}:{int(table['line'].iloc[i])}",
                x_mm=round(float(table["x_mm"].iloc[i]), 3),
                y_mm=round(float(table["y_mm"].iloc[i]), 3),
                z_mm=round(float(table["z_mm"].iloc[i]), 3),
                rpm=round(float(best.rpm[k]), 1),
            ),
            max_power_kW=round(float(np.max(outcome.power_W)) * 1e-3, 4),
            torque_Nm=round(constraints.torque_Nm_at(best.depth_m), 4),
            limiting_counts=tuple(LimitCount(str(a), int(b)) for a, b in counts.items()),
            vs_best_constant_speed=_comparison(best, outcome.constant),
            vs_programmed_speed=_comparison(best, outcome.programmed),
            candidates=Candidates(
                search=_schedule(outcome.search),
                nlp=_schedule(outcome.nlp),
                constant=_schedule(outcome.constant),
            ),
            engagement=engagement,
            passes=tuple(dict(r) for r in sections or ()),
            notes=tuple(notes),
            plan_record=plan_record,
        )


def _schedule(s: Schedule | None) -> ScheduleSummary | None:
    return None if s is None else ScheduleSummary.of(s)


def _comparison(best: Schedule, base: Schedule | None) -> BaselineComparison | None:
    return None if base is None else BaselineComparison.between(best, base)


def _limit_notes(
    job: Job,
    robot: Robot,
    table: pd.DataFrame,
    cut_index: NDArray[np.int64],
    limits: ProcessLimits | None,
) -> list[str]:
    """The process limits kept (vc, chip load, path speed) and which limit binds where."""
    from robolobe.plan.limits import binding_notes, process_limits

    lim = limits if limits is not None else process_limits(job, robot=robot)
    limiting = table["limiting"].to_numpy()[cut_index]
    line = table["line"].to_numpy()[cut_index]
    # the file of the few waypoints named, not an object array of every waypoint's
    source = _Taken(table["source"].array, cut_index)
    return [*lim.notes, *binding_notes(limiting, source, line, lim, job)]


class _Taken:
    """``values[index]``, an entry at a time (``taken[k]`` is ``values[index[k]]``)."""

    def __init__(self, values: Any, index: NDArray[np.int64]) -> None:
        self.values, self.index = values, index

    def __len__(self) -> int:
        return int(self.index.size)

    def __getitem__(self, k: int) -> Any:
        return self.values[int(self.index[k])]


def _notes(
    *,
    job: Job,
    robot: Robot,
    waypoints: pd.DataFrame,
    lobes: GroupedLobes,
    extrapolation: NDArray[np.float64] | None,
    n_plunge: int,
    robust: bool,
    bound: RobustBoundSummary | None,
    mode_note: str,
    n_split: int,
) -> list[str]:
    """The plan's notes, one sentence each, in the order the summary lists them."""
    note = mode_note
    if n_split:
        note = (note + "; " if note else "") + (
            f"{count(n_split, 'waypoint')} next to a steep lobe wall got "
            + (
                "its own lobes (sharing would have moved its limit)"
                if n_split == 1
                else "lobes of their own (sharing would have moved their limit)"
            )
        )
    notes = [s for s in (note, lobes.message) if s]
    reader: Sequence[str] = waypoints.attrs.get("warnings", [])
    notes += [f"toolpath reader: {w}" for w in reader]
    notes += [f"robot file {robot.source}: {w}" for w in robot_warnings(robot)]
    ex = extrapolation
    if ex is not None and np.any(ex > EXTRAPOLATION_NOTE):
        k = int(np.sum(ex > EXTRAPOLATION_NOTE))
        notes.append(
            f"{k} of {count(ex.size, 'cutting posture')} {'lies' if k == 1 else 'lie'} beyond "
            f"the model's training range (up to {100 * float(ex.max()):.0f} % of a joint "
            "range): predictions there are extrapolations"
        )
    if n_plunge:
        notes.append(
            f"{count(n_plunge, 'cutting move')} "
            + (
                "runs along the tool axis (a plunge): the lateral (ZOA) stability model does "
                "not apply to it and it does not limit the depth"
                if n_plunge == 1
                else "run along the tool axis (plunges): the lateral (ZOA) stability model "
                "does not apply to them and they do not limit the depth"
            )
        )
    if robust and bound is None:
        notes.append(
            "robust mode: neither the mode source nor the job gives a spread (k_sigma or the "
            "spread_*_pct keys are 0); planned on the nominal modes"
        )
    elif bound is not None:
        why = (
            " (plan.robust not set: robust by default on a calibrated spread)"
            if job.plan.robust is None
            else ""
        )
        notes.append("robust plan" + why + ": " + bound.statement)
    return notes
