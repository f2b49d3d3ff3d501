"""The planning pipeline for one path: waypoints -> postures -> modes -> lobes -> schedule.

Stages (each timed, :attr:`PlanResult.timings`):

1. ``read``: the toolpath into the waypoint table (:mod:`robolobe.plan.paths`).
2. ``ik``: TCP poses from the waypoints (workpiece placement, tool axis,
   rotation about it), inverse kinematics along the path with branch
   continuity, reachability, joint-limit, wrist-flip and singularity checks.
   With ``tool_rotation = "stiffest"`` the rotation about the tool axis is
   chosen from the allowed range for the largest worst-case stable depth.
3. ``modes``: robot modes at every cutting posture (tl model or twin), with
   spread.
4. ``frf``: tool-point models in the feed frame (robot + spindle/tool modes,
   rotated; :func:`robolobe.sld.toolpoint.tool_point_model`).
5. ``lobes``: ZOA lobes batched over the distinct dynamics
   (:func:`robolobe.plan.lobes.waypoint_lobes`), with the lobes of the
   waypoints next to a steep wall that get their own after the first schedule.
6. ``optimize``: global search, casadi refinement, exact verification
   (:func:`robolobe.plan.optimize.optimize_schedule`), every run of it (pass
   counts, the schedule again after a steep-wall split), without those lobes.
7. ``table``: the per-waypoint result table and the summary.

TCP frame convention (robot files): the TCP z axis points out of the tool
(from the flange towards the tip), so ``z_tcp = -tool_axis``. Where the path
leaves the rotation about the tool axis free (G-code, APT, CSV without
``ox oy oz``), the TCP x axis points from the waypoint towards the robot's
base axis (horizontally), then the job's ``tool_rotation_deg`` turns it
about ``z_tcp`` (right hand).
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import os
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, cast, overload

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._memory import RELEASE_MIN_ROWS, large_blocks_mapped, release_free_memory
from robolobe._threads import each_on_threads
from robolobe.errors import InfeasibleError, InputError, ReachabilityError, SingularityError
from robolobe.plan._summary import PlanSummary
from robolobe.plan.engagement import engagement_note, plan_engagement
from robolobe.plan.job import Job, check_tool_modes_on, load_job
from robolobe.plan.limits import ProcessLimits, process_limits
from robolobe.plan.lobes import (
    DynamicsTolerance,
    GroupedLobes,
    size_members,
    steep_members,
    waypoint_lobes,
)
from robolobe.plan.modes import (
    MODE_STRIDE,
    CorrectedTwinSource,
    ModeSource,
    RobotModes,
    RobustBound,
    TwinSource,
    as_mode_source,
    bound_scenario,
    interpolated_modes,
    mode_source,
    plan_bound,
)
from robolobe.plan.optimize import (
    Constraints,
    PathGeometry,
    PlanOutcome,
    limit_slacks,
    limiting_labels,
    optimize_schedule,
)
from robolobe.plan.passes import (
    ProgramDepth,
    program_depth,
    schedule_passes,
    section_passes,
    sections,
)
from robolobe.plan.paths import read_toolpath, segment_lengths, validate_waypoints
from robolobe.robots.ik import ik, ik_batch
from robolobe.robots.io import load_robot
from robolobe.robots.kinematics import joint_axes, link_frames
from robolobe.robots.model import Robot
from robolobe.sld.conditions import engagement_angles
from robolobe.sld.converged import LOBE_TOL
from robolobe.sld.frf import ModalModel
from robolobe.sld.material import Material, get_material
from robolobe.sld.toolpoint import feed_frame, tool_point_model
from robolobe.sld.zoa import LOW_IMMERSION
from robolobe.stock import Engagement

__all__ = [
    "PlanResult",
    "constraints_from_job",
    "cut_lobes",
    "feed_tcp",
    "job_fingerprint",
    "material_from_job",
    "plan_path",
    "plan_record",
    "tcp_targets",
    "waypoints_hash",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]

#: Below this |sin| of the wrist bend a posture counts as singular.
WRIST_SINGULAR = math.sin(math.radians(1.0))
#: Joint motion allowed between two waypoints: this much plus ``FLIP_PER_M_RAD`` per metre
#: of TCP motion.
FLIP_BASE_RAD = math.radians(20.0)
FLIP_PER_M_RAD = math.radians(100.0)
#: A cutting move whose feed has less than this component across the tool axis is a plunge.
PLUNGE_LATERAL = 0.2


@dataclass(frozen=True, eq=False)
class PlanResult:
    """Everything one plan produced.

    Attributes
    ----------
    job : Job
    path : str
        Toolpath file (or ``"<table>"``).
    robot : Robot
    waypoints : pandas.DataFrame
        The input waypoint table.
    table : pandas.DataFrame
        The per-waypoint result (see :func:`plan_path`).
    outcome : PlanOutcome
        Schedules (plan and baselines) for the cutting waypoints; its
        ``timings`` are the optimizer's seconds per step summed over all its
        runs for this plan (the pass counts tried, the schedule made again
        after a steep-wall split), ``runs`` their number.
    lobes : GroupedLobes
        Lobes of the distinct dynamics.
    cut_index : ndarray of int, shape (n_cut,)
        Row of each cutting waypoint in ``table``.
    q : ndarray, shape (n, 6)
        Postures [rad].
    geom : PathGeometry
        Cutting lengths and rapid time.
    summary : PlanSummary
        Headline figures, provenance and notes (``summary.to_dict()``:
        ``summary.json``).
    timings : dict
        Seconds per stage.
    """

    job: Job
    path: str
    robot: Robot
    waypoints: pd.DataFrame
    table: pd.DataFrame
    outcome: PlanOutcome
    lobes: GroupedLobes
    cut_index: NDArray[np.int64]
    q: FloatArray
    geom: PathGeometry
    summary: PlanSummary
    timings: dict[str, float] = field(default_factory=dict)


# --------------------------------------------------------------- job helpers
def material_from_job(job: Job) -> Material:
    """The job's material: table entry (with overrides) or the coefficients given."""
    m = job.material
    kt = m.Kt_N_per_m2
    kr = (m.Kn_N_per_m2 / kt) if (kt is not None and m.Kn_N_per_m2 is not None) else None
    if m.name is not None:
        try:
            return get_material(m.name, kt=kt, kr=kr)
        except InputError:
            if kt is None:
                raise
            return Material(name=m.name, kt=kt, kr=float(kr or 0.0), source="job file")
    if kt is None:
        raise InputError("material: expected name or Kt_N_per_mm2", source=job.source)
    return Material(name="user", kt=kt, kr=float(kr or 0.0), source="job file")


def constraints_from_job(job: Job, kt: float, limits: ProcessLimits | None = None) -> Constraints:
    """Process limits of a job (``kt`` [N/m^2] for power and torque).

    The speed range, chip load and feed cap come from ``limits``
    (:func:`robolobe.plan.limits.process_limits` of the job and its program);
    without, from the job alone (``process_limits(job)``: spindle range within
    the vc range, the job's chip load, the path-speed cap of the job or the
    robot file).
    """
    lim = limits if limits is not None else process_limits(job)
    return Constraints(
        teeth=job.tool.teeth,
        feed_per_tooth_m=lim.feed_per_tooth_m,
        width_m=job.cut.radial_width_m,
        kt_N_per_m2=kt,
        power_W=job.spindle.power_W,
        torque_Nm=job.spindle.torque_Nm,
        rpm_min=lim.rpm_min,
        rpm_max=lim.rpm_max,
        depth_min_m=job.plan.depth_min_m,
        depth_max_m=job.plan.depth_max_m,
        safety_factor=job.plan.safety_factor,
        max_feed_m_per_s=lim.max_feed_m_per_s,
        max_rate_rpm_per_s=job.plan.max_rate_rpm_per_s,
        max_rate_rpm_per_m=job.plan.max_rate_rpm_per_m,
        constant_speed=job.plan.speed == "constant",
    )


def _tool_model(job: Job) -> ModalModel | None:
    modes = job.tool.modes
    if not modes:
        return None
    return ModalModel.from_directional(
        [m.f_hz for m in modes],
        [m.zeta for m in modes],
        [m.k_N_per_m for m in modes],
        [m.direction * 2 for m in modes],
        dim=3,
    )


# ------------------------------------------------------------------ targets
def _unit(v: FloatArray) -> FloatArray:
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.asarray(v / np.where(n > 0, n, 1.0))


def tcp_targets(
    wp: pd.DataFrame, robot: Robot, placement: FloatArray, rotation_rad: float
) -> tuple[FloatArray, FloatArray]:
    """World TCP poses of the waypoints and the rotation path frame -> world.

    Parameters
    ----------
    wp : pandas.DataFrame
        Waypoint table.
    robot : Robot
    placement : ndarray, shape (4, 4)
        Workpiece (path) frame in the robot base frame.
    rotation_rad : float
        Rotation of the TCP x axis about ``z_tcp``.

    Returns
    -------
    poses : ndarray, shape (n, 4, 4)
    r_world_path : ndarray, shape (3, 3)
    """
    n = len(wp)
    p = wp[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64)
    axis = wp[["i", "j", "k"]].to_numpy(dtype=np.float64)
    ref = wp[["ox", "oy", "oz"]].to_numpy(dtype=np.float64)
    r_pl = placement[:3, :3]
    p_b = p @ r_pl.T + placement[:3, 3]
    z = -_unit(axis @ r_pl.T)
    ref_b = ref @ r_pl.T
    free = ~np.all(np.isfinite(ref_b), axis=1)
    radial = np.stack([-p_b[:, 0], -p_b[:, 1], np.zeros(n)], axis=1)
    small = np.linalg.norm(radial, axis=1) < 1e-6
    radial[small] = [-1.0, 0.0, 0.0]
    ref_b = np.where(free[:, None], radial, ref_b)
    x = ref_b - np.sum(ref_b * z, axis=1, keepdims=True) * z
    bad = np.linalg.norm(x, axis=1) < 1e-6
    if np.any(bad):  # reference along the tool axis: take base x, else base y
        alt = np.where(np.abs(z[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        alt = alt - np.sum(alt * z, axis=1, keepdims=True) * z
        x = np.where(bad[:, None], alt, x)
    x = _unit(x)
    if rotation_rad:
        c, s = math.cos(rotation_rad), math.sin(rotation_rad)
        x = c * x + s * np.cross(z, x)
    y = np.cross(z, x)
    poses = np.zeros((n, 4, 4))
    poses[:, :3, 0] = x
    poses[:, :3, 1] = y
    poses[:, :3, 2] = z
    poses[:, :3, 3] = p_b
    poses[:, 3, 3] = 1.0
    poses = robot.base @ poses
    return poses, robot.base[:3, :3] @ r_pl


def _label(wp: pd.DataFrame, i: int) -> str:
    return f"{wp['source'].iloc[i]}:{int(wp['line'].iloc[i])}"


def _start_posture(robot: Robot, pose: FloatArray, source: ModeSource | None) -> FloatArray:
    """A good first posture: within limits, away from them, inside the model's range."""
    res = ik(robot, pose)
    qv = res.q[res.valid]
    if qv.shape[0] == 0:
        return res.q[0]
    lo, hi = robot.q_min, robot.q_max
    span = np.maximum(hi - lo, 1e-9)
    margin = np.minimum(qv - lo, hi - qv) / span
    score = margin.min(axis=1) + 0.5 * margin.mean(axis=1)
    wm = res.wrist_measure[res.valid]
    score = score + 0.2 * np.minimum(wm, 0.5)
    predictor = getattr(source, "predictor", None)
    if predictor is not None and hasattr(predictor, "extrapolation"):
        with contextlib.suppress(InputError):
            score = score - 2.0 * np.asarray(predictor.extrapolation(qv))
    return qv[int(np.argmax(score))]


def _postures(
    wp: pd.DataFrame, robot: Robot, poses: FloatArray, source: ModeSource | None
) -> tuple[FloatArray, FloatArray]:
    """Postures along the path (n, 6) [rad] and their wrist measure (n,) (checked)."""
    try:
        q_ref = _start_posture(robot, poses[0], source)
    except ReachabilityError as exc:
        raise ReachabilityError(f"{_label(wp, 0)}: waypoint 0 unreachable: {exc}") from None
    try:
        q = ik_batch(robot, poses, q_ref, continuity=True)
    except ReachabilityError as exc:
        import re

        m = re.search(r"waypoint (\d+)", str(exc))
        if m:
            i = int(m.group(1))
            raise ReachabilityError(f"{_label(wp, i)}: waypoint {i} unreachable: {exc}") from None
        raise
    wm = _wrist_measure(robot, q)
    sing = wm < WRIST_SINGULAR
    if np.any(sing):
        i = int(np.argmax(sing))
        raise SingularityError(
            f"{_label(wp, i)}: waypoint {i} is at a wrist singularity (|sin| of the wrist bend "
            f"{wm[i]:.4f}); move the workpiece or tilt the tool"
        )
    # wrist flips: large joint motion over a short TCP motion
    if len(q) > 1:
        dq = np.abs(np.diff(q, axis=0)).max(axis=1)
        dp = np.linalg.norm(np.diff(poses[:, :3, 3], axis=0), axis=1)
        flip = dq > FLIP_BASE_RAD + FLIP_PER_M_RAD * dp
        if np.any(flip):
            i = int(np.argmax(flip)) + 1
            j = int(np.argmax(np.abs(q[i] - q[i - 1])))
            raise SingularityError(
                f"{_label(wp, i)}: waypoint {i}: joint {j + 1} turns "
                f"{math.degrees(abs(q[i, j] - q[i - 1, j])):.0f} deg for a TCP move of "
                f"{dp[i - 1] * 1e3:.1f} mm (a wrist flip or branch change near a singularity); "
                "move the workpiece or change the tool rotation"
            )
    return q, wm


#: Postures per chunk of the per-posture stages (wrist measure, modes): bounds
#: their temporaries (the twin's ~10 kB per posture) whatever the path's length.
_CHUNK = 16_384
#: Threads predicting modes chunk by chunk on a long path (each holds one chunk's
#: temporaries); the chunks' results do not depend on it.
_THREADS = min(2, os.cpu_count() or 1)
#: Distinct postures from which the modes are predicted on the threads even within one
#: :data:`_CHUNK` (below, one call: the threads' start costs more than they give).
_SPLIT_MIN = 2_048
#: Postures of the first call alone (the source's lazy set-up) when the rest is split.
_HEAD = 64


def _wrist_measure(robot: Robot, q: FloatArray) -> FloatArray:
    """|sin| of the wrist bend per posture (n,), in chunks on up to :data:`_THREADS`
    threads (numpy's batched products release the GIL; each chunk is its own)."""
    out = np.empty(q.shape[0])

    def part(c0: int) -> None:
        frames = link_frames(robot, q[c0 : c0 + _CHUNK])
        axes, _ = joint_axes(robot, frames)  # (m, 6, 3)
        out[c0 : c0 + _CHUNK] = np.linalg.norm(np.cross(axes[:, 3], axes[:, 5]), axis=-1)

    each_on_threads(part, range(0, q.shape[0], _CHUNK), _THREADS)
    return out


def _predict_modes(source: ModeSource, q: FloatArray) -> RobotModes:
    """Modes at the postures ``q`` (n, 6): each distinct posture once, in chunks.

    Postures that repeat exactly (a path that passes a point twice) are
    predicted once; the source sees chunks of :data:`_CHUNK` postures, so its
    temporaries stay bounded, on up to :data:`_THREADS` threads after the first
    chunk. Each posture's modes are those of a call with all postures at once
    (sources predict per posture).
    """
    n = q.shape[0]
    key = np.ascontiguousarray(q + 0.0).view(np.dtype((np.void, 6 * 8))).ravel()
    _, first, inv = np.unique(key, return_index=True, return_inverse=True)
    inv = np.asarray(inv).ravel()
    if first.size == n and (n < _SPLIT_MIN or _THREADS < 2):
        return source.predict(q)
    order = np.sort(first)  # distinct postures in path order
    rank = np.empty(n, np.int64)
    rank[order] = np.arange(order.size)
    expand = rank[first[inv]]  # row of each posture among the distinct ones
    del key, first, inv, rank
    uq = q[order]
    n_u = uq.shape[0]
    filled = _ModesFill(n_u)
    # a first chunk alone (a source's lazy set-up happens once), the rest on the
    # cores: numpy releases the GIL in the per-posture linear algebra. From
    # _SPLIT_MIN postures on, the first is small and the rest is shared between the
    # threads, so that a path of one chunk uses both cores too
    step = _CHUNK
    head = _CHUNK
    if n_u >= _SPLIT_MIN and _THREADS > 1:
        head = min(_HEAD, n_u)
        step = min(_CHUNK, -(-(n_u - head) // _THREADS))
    try:
        _fill_modes(source, uq, filled, head, step)
    except InputError:
        if n_u <= _CHUNK:
            # refused by a part: the refusal of one call over every posture (a message
            # that counts the postures counts them all, not those of one part)
            source.predict(uq)
        raise
    return filled.result(None if order.size == n else expand)


def _fill_modes(
    source: ModeSource, uq: FloatArray, filled: _ModesFill, head: int, step: int
) -> None:
    """Modes of ``uq`` into ``filled``: rows ``:head`` first, then parts of ``step`` rows
    on up to :data:`_THREADS` threads."""
    n_u = uq.shape[0]
    filled.put(0, source.predict(uq[:head]))
    rest = list(range(head, n_u, step))
    workers = min(_THREADS, len(rest))
    if workers > 1:
        from concurrent.futures import ThreadPoolExecutor

        from robolobe._threads import one_blas_thread

        with one_blas_thread(), ThreadPoolExecutor(workers) as ex:
            parts = ex.map(lambda c0: source.predict(uq[c0 : c0 + step]), rest)
            for c0, part in zip(rest, parts, strict=True):
                filled.put(c0, part)
    else:
        for c0 in rest:
            filled.put(c0, source.predict(uq[c0 : c0 + step]))


class _ModesFill:
    """One :class:`RobotModes` filled batch by batch into arrays allocated once.

    (Concatenating the batches at the end would hold every posture's modes twice.)
    """

    _NAMES = ("f_hz", "zeta", "k_N_per_m", "log_std", "extrapolation")
    _MODEL = ("omega", "zeta", "residues")

    def __init__(self, n: int) -> None:
        self.n = n
        self.first: RobotModes | None = None
        self.arrays: dict[str, Any] = {}

    def _put(self, key: str, c0: int, val: Any) -> None:
        if val is None:
            self.arrays[key] = None
            return
        val = np.asarray(val)
        if key not in self.arrays:
            self.arrays[key] = np.empty((self.n, *val.shape[1:]), dtype=val.dtype)
        self.arrays[key][c0 : c0 + val.shape[0]] = val

    def put(self, c0: int, part: RobotModes) -> None:
        """Batch ``part`` holds the postures from row ``c0`` on."""
        if self.first is None:
            self.first = part
        for name in self._NAMES:
            self._put(name, c0, getattr(part, name))
        for name in self._MODEL:
            self._put("model." + name, c0, getattr(part.model, name))

    def result(self, take: NDArray[np.int64] | None) -> RobotModes:
        """The filled modes, optionally rows ``take`` of them."""
        import dataclasses

        assert self.first is not None
        a = self.arrays
        if take is not None:
            a = {k: None if v is None else v[take] for k, v in a.items()}
        model = ModalModel(a["model.omega"], a["model.zeta"], a["model.residues"])
        for name in self._NAMES[:4]:  # handed over, not copied (no one else holds them)
            if a[name] is not None:
                a[name].setflags(write=False)
        params = dataclasses.replace(
            self.first.parameters,
            f_hz=a["f_hz"],
            zeta=a["zeta"],
            k_N_per_m=a["k_N_per_m"],
            log_std=a["log_std"],
        )
        return dataclasses.replace(
            self.first, parameters=params, model=model, extrapolation=a["extrapolation"]
        )


# --------------------------------------------------------------------- main
def _read(
    path: str | os.PathLike[str] | pd.DataFrame, options: dict[str, Any] | None = None
) -> tuple[pd.DataFrame, str]:
    if isinstance(path, pd.DataFrame):
        return validate_waypoints(path, "<table>"), "<table>"
    return read_toolpath(path, applicable_only=True, **(options or {})), str(path)


def _feed_lateral(f_tcp: FloatArray) -> FloatArray:
    return np.asarray(np.linalg.norm(f_tcp[:, :2], axis=1))


class _Labels(Sequence[str]):
    """``file:line`` of each cutting waypoint, made when asked (messages name a few).

    Parameters
    ----------
    source : array of str, shape (n_rows,)
        The waypoint table's ``source`` column (its own array: no object per row).
    line : ndarray of int, shape (n_rows,)
    rows : ndarray of int, shape (n,)
        The table's row of each labelled waypoint.
    """

    def __init__(self, source: Any, line: NDArray[Any], rows: NDArray[np.int64]) -> None:
        self.source, self.line, self.rows = source, line, rows

    def __len__(self) -> int:
        return int(self.rows.shape[0])

    @overload
    def __getitem__(self, i: int) -> str: ...
    @overload
    def __getitem__(self, i: slice) -> list[str]: ...
    def __getitem__(self, i: int | slice) -> str | list[str]:
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        r = int(self.rows[i])
        return f"{self.source[r]}:{int(self.line[r])}"


def _lobes_for_rotation(
    job: Job,
    wp: pd.DataFrame,
    robot: Robot,
    source: ModeSource,
    rotation: float,
    cut: NDArray[np.bool_],
    material: Material,
    tool: ModalModel | None,
    rpm: FloatArray,
    eng: Engagement | None = None,
) -> tuple[
    FloatArray,
    FloatArray,
    RobotModes | _ModeColumns,
    NDArray[np.bool_],
    GroupedLobes,
    dict[str, float],
    FloatArray,
    RobustBound | None,
    Callable[[NDArray[np.bool_], GroupedLobes], GroupedLobes],
    Callable[[GroupedLobes, FloatArray], NDArray[np.bool_]],
]:
    """Postures, modes (or their table columns), lobes of the path at one tool rotation.

    The last items: ``split(own, reuse)`` gives the lobes again with ``own``
    waypoints on lobes of their own (:func:`cut_lobes`'s ``own``/``reuse``);
    ``members(grouped, rpm)`` finds the members whose own limit at their planned
    speeds lies outside the promise of the shared one
    (:func:`~robolobe.plan.lobes.size_members`: a robust plan's on every scenario's
    models, made again for it; on a streamed path the members' models are made
    again for it, block by block).
    A path of at least :data:`_STREAM_MIN` cutting waypoints is streamed
    (:func:`_streamed_lobes`) unless the plan is robust. With ``eng`` every
    cutting move is planned at its own engagement, air moves without a limit.
    """
    timings: dict[str, float] = {}
    t = time.perf_counter()
    poses, r_wp = tcp_targets(wp, robot, job.placement, rotation)
    q, wm = _postures(wp, robot, poses, source)
    ci = np.flatnonzero(cut)
    f_tcp = feed_tcp(wp, poses, r_wp, ci)
    del poses  # (n, 4, 4): not needed past here
    timings["ik"] = time.perf_counter() - t
    angles: tuple[FloatArray, FloatArray] | None = None
    air: NDArray[np.bool_] | None = None
    if eng is not None:
        angles = (eng.phi_entry[ci], eng.phi_exit[ci])
        air = ~eng.engaged[ci]
    if ci.size >= _STREAM_MIN:
        streamed = _streamed_lobes(
            job, source, q, f_tcp, material, tool, rpm, ci, len(wp), angles, air
        )
        if streamed is not None:
            cols, plunge, grouped, t_lobes, feed_angle, split_s, members_s = streamed
            timings.update(t_lobes)
            return q, wm, cols, plunge, grouped, timings, feed_angle, None, split_s, members_s
    t = time.perf_counter()
    modes = _predict_modes(source, q[ci])
    timings["modes"] = time.perf_counter() - t
    # the nominal tool-point models (the caller does not keep them: ~1 kB per waypoint)
    model0, plunge, grouped, t_lobes, feed_angle, bound = cut_lobes(
        job, modes, f_tcp, material, tool, rpm, engagement=angles, air=air
    )
    timings.update(t_lobes)
    cut_args = _lobe_args(job, material, rpm, engagement=angles)
    nominal = model0 if bound is None else None  # a robust plan's: made again for the check
    del model0

    def members(shared: GroupedLobes, planned: FloatArray) -> NDArray[np.bool_]:
        # a robust plan's members on every scenario's models (made again as the lobes
        # made them, not held through the schedule: ~1 kB a waypoint and scenario)
        models = [nominal] if nominal is not None else _scenario_models(job, modes, f_tcp, tool)[2]
        return size_members(
            shared,
            models,
            planned,
            **{k: cut_args[k] for k in ("teeth", "kt", "kr", "phi_entry", "phi_exit")},
        )

    def split(own: NDArray[np.bool_], reuse: GroupedLobes) -> GroupedLobes:
        return cut_lobes(
            job, modes, f_tcp, material, tool, rpm, own=own, reuse=reuse, engagement=angles, air=air
        )[2]

    return q, wm, modes, plunge, grouped, timings, feed_angle, bound, split, members


def feed_tcp(
    wp: pd.DataFrame, poses: FloatArray, r_wp: FloatArray, idx: NDArray[np.int64]
) -> FloatArray:
    """Feed direction of the waypoints ``idx`` in their TCP frames, shape (len(idx), 3).

    ``poses`` and ``r_wp`` are :func:`tcp_targets`'s.
    """
    f_path = wp[["fx", "fy", "fz"]].to_numpy(dtype=np.float64)[idx]
    return np.asarray(np.einsum("nji,nj->ni", poses[idx, :3, :3], f_path @ r_wp.T))


#: Cutting waypoints from which a nominal plan streams the modes (:func:`_streamed_lobes`).
_STREAM_MIN = 4 * _CHUNK
#: Waypoints per chunk of the streamed pass: each thread holds one chunk's temporaries
#: (the twin's ~10 kB per posture), which add to the peak.
_STREAM_CHUNK = _CHUNK // 2
#: Exact modes at every so many postures of a streamed chunk, interpolated between
#: where checked (:func:`~robolobe.plan.modes.interpolated_modes`); 1: all exact.
_MODE_STRIDE = MODE_STRIDE


@dataclass(frozen=True)
class _ModeColumns:
    """What the result table and the summary read of the robot modes (a streamed plan
    keeps these, not the models).

    Attributes
    ----------
    columns : dict of str to ndarray, shape (n_waypoints,)
        The table's mode columns ``f{r}_{d}_hz``, ``zeta{r}_{d}``,
        ``k{r}_{d}_N_per_m`` in the table's order (NaN off the cut), made
        once: the table takes them as they are.
    extrapolation : ndarray, shape (n_cut,) or None
    """

    columns: dict[str, FloatArray]
    extrapolation: FloatArray | None


def _mode_column_names(m: int) -> list[tuple[str, int, int, str]]:
    """(column, direction, mode, quantity) of the result table's mode columns, in order."""
    out = []
    for d, dn in enumerate("xyz"):
        for r in range(m):
            for name, unit in (("f", "_hz"), ("zeta", ""), ("k", "_N_per_m")):
                out.append((f"{name}{r + 1}_{dn}{unit}", d, r, name))
    return out


class _StreamedModels:
    """Nominal feed-frame tool-point models of the cutting waypoints, made when taken.

    Stands for the :class:`ModalModel` of all of them (dim 2, batch (n,)) in
    :func:`~robolobe.plan.lobes.waypoint_lobes`, which takes only the
    leaders': each taken model is that of the whole batch (modes and models
    are per waypoint).

    Parameters
    ----------
    source : ModeSource
    q : ndarray, shape (n_rows, 6)
        Postures of every waypoint [rad].
    rows : ndarray of int, shape (n,)
        The cutting waypoints' rows of ``q`` (not a copy of their postures).
    f_use : ndarray, shape (n, 3)
        Feed directions in the TCP frame (plunges replaced, as in :func:`cut_lobes`).
    tool : ModalModel or None
    tol : DynamicsTolerance, optional
        The grouping tolerance the streamed pass interpolated the modes to
        (:meth:`block_models`).
    """

    dim = 2

    def __init__(
        self,
        source: ModeSource,
        q: FloatArray,
        rows: NDArray[np.int64],
        f_use: FloatArray,
        tool: ModalModel | None,
        tol: DynamicsTolerance | None = None,
    ) -> None:
        self.source, self.q, self.rows, self.f_use, self.tool = source, q, rows, f_use, tool
        self.tol = tol or DynamicsTolerance()
        self.batch_shape = (int(rows.shape[0]),)
        # the last models taken: the lobes take the leaders', the steep-wall split
        # takes them again with a few more (only those are made)
        self._last: tuple[NDArray[np.int64], ModalModel] | None = None

    #: Waypoints per block of :meth:`block_models` where the blocks start at multiples of it:
    #: the streamed pass's chunks, so each block's modes are the ones that pass made
    block_rows = _STREAM_CHUNK

    def _make(self, idx: NDArray[np.int64]) -> ModalModel:
        modes = _predict_modes(self.source, self.q[self.rows[idx]])
        rot = feed_frame(self.f_use[idx], (0.0, 0.0, -1.0), rotation="cw")
        return _tool_point_models(rot, modes.model, self.tool)

    def block_models(self, lo: int, hi: int) -> ModalModel:
        """The models of waypoints ``lo .. hi - 1`` from their modes made as the streamed
        pass made them (exact at every :data:`_MODE_STRIDE`-th posture from ``lo``,
        interpolated where checked: :func:`~robolobe.plan.modes.interpolated_modes`), for
        the members' check (:func:`~robolobe.plan.lobes.size_members`) without every
        posture's modes. With ``lo`` a multiple of :attr:`block_rows` and ``hi`` the next
        one (or the end), the same values bit for bit as the pass's chunk."""
        md = interpolated_modes(self.source, self.q[self.rows[lo:hi]], self.tol, _MODE_STRIDE)
        rot = feed_frame(self.f_use[lo:hi], (0.0, 0.0, -1.0), rotation="cw")
        return tool_point_model(rot, md.model, self.tool)

    def take(self, index: Any) -> ModalModel:
        """The models of waypoints ``index`` (int, slice or array of int)."""
        idx = np.atleast_1d(np.arange(self.batch_shape[0])[index]).astype(np.int64)
        out = None
        if self._last is not None:
            known, model = self._last
            kidx = pd.Index(known)
            if kidx.is_unique:
                pos = np.asarray(kidx.get_indexer(pd.Index(idx)), np.int64)
                have = pos >= 0
                if np.all(have):
                    out = model.take(pos)
                elif np.any(have):
                    new = self._make(idx[~have])
                    old = model.take(pos[have])
                    arrays = []
                    for name in ("omega", "zeta", "residues"):
                        a_old, a_new = getattr(old, name), getattr(new, name)
                        a = np.empty((idx.size, *a_old.shape[1:]), a_old.dtype)
                        a[have], a[~have] = a_old, a_new
                        arrays.append(a)
                    out = ModalModel(*arrays)
        if out is None:
            out = self._make(idx)
        self._last = (idx, out)
        return out


def _streamed_lobes(
    job: Job,
    source: ModeSource,
    q: FloatArray,
    f_tcp: FloatArray,
    material: Material,
    tool: ModalModel | None,
    rpm: FloatArray,
    cut_rows: NDArray[np.int64],
    n_rows: int,
    angles: tuple[FloatArray, FloatArray] | None = None,
    air: NDArray[np.bool_] | None = None,
) -> (
    tuple[
        _ModeColumns,
        NDArray[np.bool_],
        GroupedLobes,
        dict[str, float],
        FloatArray,
        Callable[[NDArray[np.bool_], GroupedLobes], GroupedLobes],
        Callable[[GroupedLobes, FloatArray], NDArray[np.bool_]],
    ]
    | None
):
    """:func:`cut_lobes` for a long path without keeping every waypoint's models.

    Chunks of :data:`_STREAM_CHUNK` cutting waypoints (on up to :data:`_THREADS`
    threads) pass through the modes, the feed-frame models and the grouping
    features; only the features and the modes' table columns are kept, and
    the leaders' models are made again for their lobes
    (:class:`_StreamedModels`). The same groups, lobes and columns as
    :func:`cut_lobes` after :func:`_predict_modes` (every step is per
    waypoint). ``cut_rows`` (n,): the waypoint table's row of each cutting
    waypoint, of ``n_rows``; ``q`` (n_rows, 6): every waypoint's posture (the
    cutting ones read through ``cut_rows``, not copied). ``angles`` and
    ``air``: each cutting waypoint's own engagement (:func:`cut_lobes`).

    Returns
    -------
    tuple or None
        The table's mode columns, the plunge mask, the grouped lobes, the
        timings (``modes`` covers the feed-frame models and the features too,
        ``frf`` is 0), the feed angles [deg] and ``split(own, reuse)`` (the
        steep-wall split, as :func:`cut_lobes` with ``own``/``reuse``) and
        ``members(grouped, rpm)`` (:func:`~robolobe.plan.lobes.size_members`, the
        members' models made again in blocks of the candidates); None
        for a robust plan (its bound needs every waypoint's modes at once:
        the caller plans in memory).
    """
    from robolobe.plan.lobes import _features
    from robolobe.sld.directional import directional_factors

    t = time.perf_counter()
    n = int(cut_rows.size)
    plunge = _feed_lateral(f_tcp) < PLUNGE_LATERAL
    f_use = np.where(plunge[:, None], [[1.0, 0.0, 0.0]], f_tcp)
    args = _lobe_args(job, material, rpm, engagement=angles)
    tol = args["tol"]
    unb = plunge if air is None else plunge | air
    if angles is None:
        alpha = directional_factors(args["phi_entry"], args["phi_exit"], args["kr"])
    else:  # each waypoint's own (zeros where unbounded: no features are made there)
        alpha = np.zeros((n, 2, 2))
        ib = np.flatnonzero(~unb)
        alpha[ib] = directional_factors(angles[0][ib], angles[1][ib], args["kr"])
    n_before = np.r_[0, np.cumsum(~unb)]  # bounded waypoints before each row

    def work(c0: int) -> tuple[RobotModes, FloatArray]:
        rows = slice(c0, c0 + _STREAM_CHUNK)
        md = interpolated_modes(source, q[cut_rows[rows]], tol, _MODE_STRIDE)
        rot = feed_frame(f_use[rows], (0.0, 0.0, -1.0), rotation="cw")
        model = tool_point_model(rot, md.model, tool)
        b = ~unb[rows]
        al = alpha if alpha.ndim == 2 else alpha[rows][b]
        return md, _features(model if b.all() else model.take(np.flatnonzero(b)), tol, al)

    md0, f0 = work(0)  # alone: a source's lazy set-up happens once
    if plan_bound(job.plan, md0, None)[1]:
        return None
    # held here only until waypoint_lobes takes it over (it frees it after grouping)
    held = [np.empty((int(n_before[-1]), f0.shape[1]))]
    names = _mode_column_names(md0.f_hz.shape[-1])
    # a quantity the same bit for bit in every direction (the twin's coupled modes'
    # frequency and damping) is one array in the three columns while it stays so
    # (the table shares it: pandas copies on write)
    first = {(r, name): c for c, d, r, name in reversed(names)}  # direction x's column
    base = {c: first[(r, name)] for c, d, r, name in names}
    shared = {c for c, d, r, name in names if d > 0 and name != "k"}
    columns: dict[str, FloatArray] = {}
    for c, *_ in names:
        columns[c] = columns[base[c]] if c in shared else np.full(n_rows, np.nan)
    cols = _ModeColumns(columns, None if md0.extrapolation is None else np.empty(n))

    def put(c0: int, md: RobotModes, f: FloatArray) -> None:
        c1 = c0 + md.f_hz.shape[0]
        rows = cut_rows[c0:c1]
        arrs = {"f": md.f_hz, "zeta": md.zeta, "k": md.k_N_per_m}
        for c, d, r, name in names:  # direction x (a shared column's base) first
            v = arrs[name][:, d, r]
            if c in shared:
                if np.array_equal(v.view(np.int64), arrs[name][:, 0, r].view(np.int64)):
                    continue
                shared.discard(c)  # differs here: a column of its own from now on
                columns[c] = columns[base[c]].copy()
            columns[c][rows] = v
        if cols.extrapolation is not None:
            cols.extrapolation[c0:c1] = md.extrapolation
        held[0][n_before[c0] : n_before[c1]] = f

    put(0, md0, f0)
    del md0, f0
    rest = list(range(_STREAM_CHUNK, n, _STREAM_CHUNK))
    if _THREADS > 1 and len(rest) > 1:
        from concurrent.futures import ThreadPoolExecutor

        from robolobe._threads import one_blas_thread

        with one_blas_thread(), ThreadPoolExecutor(_THREADS) as ex:
            for c0, (md, f) in zip(rest, ex.map(work, rest), strict=True):
                put(c0, md, f)
                del md, f
    else:
        for c0 in rest:
            put(c0, *work(c0))
    timings = {"modes": time.perf_counter() - t, "frf": 0.0}
    t = time.perf_counter()
    # waypoint_lobes needs only dim, batch_shape and take of the models given features
    models = cast("ModalModel", _StreamedModels(source, q, cut_rows, f_use, tool, tol))
    # explicit keywords, not ``**args``: a call through ``**`` keeps its keyword dict (and
    # the features in it) alive until it returns, and waypoint_lobes frees them after
    # grouping, before the leaders' lobes (600 bytes a waypoint: the lobe stage's peak)
    grouped = waypoint_lobes(
        [models],
        unbounded=unb,
        features=held.pop(),
        teeth=args["teeth"],
        kt=args["kt"],
        kr=args["kr"],
        phi_entry=args["phi_entry"],
        phi_exit=args["phi_exit"],
        rpm=args["rpm"],
        immersion=args["immersion"],
        tol=args["tol"],
    )
    timings["lobes"] = time.perf_counter() - t
    feed_angle = np.degrees(np.arctan2(f_use[:, 1], f_use[:, 0]))

    def split(own: NDArray[np.bool_], reuse: GroupedLobes) -> GroupedLobes:
        return waypoint_lobes([models], unbounded=unb, own=own, reuse=reuse, **args)

    def members(shared: GroupedLobes, planned: FloatArray) -> NDArray[np.bool_]:
        return size_members(
            shared,
            models,
            planned,
            **{k: args[k] for k in ("teeth", "kt", "kr", "phi_entry", "phi_exit")},
        )

    return cols, plunge, grouped, timings, feed_angle, split, members


def _tool_point_models(
    rot: FloatArray, robot_model: ModalModel, tool: ModalModel | None
) -> ModalModel:
    """:func:`~robolobe.sld.toolpoint.tool_point_model` per waypoint, in chunks.

    Chunks of :data:`_CHUNK` waypoints (on up to :data:`_THREADS` threads)
    written into arrays allocated once: the rotation's temporaries stay
    bounded (~1.7 kB per waypoint at once otherwise); each waypoint's model is
    that of one call over all of them (the model is per waypoint).

    Parameters
    ----------
    rot : ndarray, shape (n, 3, 3)
        Feed frames (:func:`~robolobe.sld.toolpoint.feed_frame`).
    robot_model : ModalModel
        TCP-frame robot modes, dim 3, batch (n,).
    tool : ModalModel or None

    Returns
    -------
    ModalModel
        Feed-frame models, dim 2, batch (n,).
    """
    n = rot.shape[0]
    if n <= _CHUNK or rot.shape != (n, 3, 3) or robot_model.batch_shape != (n,):
        return tool_point_model(rot, robot_model, tool)

    def part(c0: int) -> ModalModel:
        rows = slice(c0, c0 + _CHUNK)
        return tool_point_model(rot[rows], robot_model.take(rows), tool)

    first = part(0)
    w = np.empty((n, *first.omega.shape[1:]), first.omega.dtype)
    z = np.empty((n, *first.zeta.shape[1:]), first.zeta.dtype)
    a = np.empty((n, *first.residues.shape[1:]), first.residues.dtype)

    def put(c0: int, m: ModalModel) -> None:
        c1 = c0 + m.omega.shape[0]
        w[c0:c1], z[c0:c1], a[c0:c1] = m.omega, m.zeta, m.residues

    put(0, first)
    rest = list(range(_CHUNK, n, _CHUNK))
    if _THREADS > 1 and len(rest) > 1:
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(_THREADS) as ex:
            for c0, m in zip(rest, ex.map(part, rest), strict=True):
                put(c0, m)
    else:
        for c0 in rest:
            put(c0, part(c0))
    return ModalModel(w, z, a)


def _lobe_args(
    job: Job,
    material: Material,
    rpm: FloatArray,
    dynamics_tol: float | None = None,
    engagement: tuple[Any, Any] | None = None,
) -> dict[str, Any]:
    """The job's arguments of :func:`~robolobe.plan.lobes.waypoint_lobes` (cut, grid, tolerance).

    ``engagement`` (entry, exit) [rad], floats or per-waypoint arrays (n,)
    (NaN where a move cuts air), replaces the job's ``cut.radial_width_mm``
    and ``cut.milling``; the validity flag then takes the smallest immersion.
    """
    st: Any
    ex: Any
    if engagement is None:
        st, ex = engagement_angles(job.radial_immersion, job.cut.milling)
        immersion = job.radial_immersion
    elif np.ndim(engagement[0]) == 0:
        st, ex = (float(v) for v in engagement)
        immersion = 0.5 * (math.cos(st) - math.cos(ex))
    else:
        st, ex = (np.asarray(v, dtype=np.float64) for v in engagement)
        imm = 0.5 * (np.cos(st) - np.cos(ex))
        imm = imm[np.isfinite(imm)]
        immersion = float(imm.min()) if imm.size else job.radial_immersion
    dt = job.plan.dynamics_tol if dynamics_tol is None else dynamics_tol
    tol = DynamicsTolerance(
        freq=dt,
        damping=10 * dt,
        residue=7 * dt,
        freq_low=10 * dt / 3,
        f_low_hz=0.5 * job.spindle.rpm_min * job.tool.teeth / 60.0,
    )
    return {
        "teeth": job.tool.teeth,
        "kt": material.kt,
        "kr": material.kr,
        "phi_entry": st,
        "phi_exit": ex,
        "rpm": rpm,
        "immersion": immersion,
        "tol": tol,
    }


def cut_lobes(
    job: Job,
    modes: RobotModes,
    f_tcp: FloatArray,
    material: Material,
    tool: ModalModel | None,
    rpm: FloatArray,
    *,
    dynamics_tol: float | None = None,
    robust: bool | None = None,
    own: NDArray[np.bool_] | None = None,
    reuse: GroupedLobes | None = None,
    engagement: tuple[Any, Any] | None = None,
    air: NDArray[np.bool_] | None = None,
) -> tuple[
    ModalModel, NDArray[np.bool_], GroupedLobes, dict[str, float], FloatArray, RobustBound | None
]:
    """Lobes of the cutting waypoints from their robot modes and feed directions.

    The one place where the planner turns robot modes into stability limits
    (tool-point model, feed frame, robust bound, grouping, ZOA): planning and
    :func:`robolobe.plan.verify.verify_plan` both call it.

    Parameters
    ----------
    job : Job
    modes : RobotModes
        Robot modes at the n cutting waypoints.
    f_tcp : ndarray, shape (n, 3)
        Feed direction in the TCP frame.
    material : Material
    tool : ModalModel or None
        Spindle/tool modes (3-D).
    rpm : ndarray, shape (n_rpm,)
        Speed grid [rpm].
    dynamics_tol : float, optional
        Overrides ``job.plan.dynamics_tol`` (0: every waypoint its own lobes).
    robust : bool, optional
        Overrides ``job.plan.robust``.
    own : ndarray of bool, shape (n,), optional
        Waypoints that get lobes of their own (see :func:`robolobe.plan.lobes.steep_members`).
    reuse : GroupedLobes, optional
        The result of the same call without ``own``: its grouping and lobes are
        kept, only the added waypoints' lobes are computed (same result).
    engagement : tuple, optional
        Entry and exit angles [rad]: floats for all ``n`` waypoints, or arrays
        (n,) of each one's own (the planner on a stock; NaN where ``air``).
        Default: the job's ``cut.radial_width_mm`` and ``cut.milling``.
    air : ndarray of bool, shape (n,), optional
        Feed moves that cut no material: no lateral limit (the unbounded row).

    Returns
    -------
    model : ModalModel
        Nominal feed-frame tool-point models, batch (n,).
    plunge : ndarray of bool, shape (n,)
    grouped : GroupedLobes
    timings : dict
        Seconds for ``frf`` and ``lobes``.
    feed_angle_deg : ndarray, shape (n,)
        Feed direction in the TCP x/y plane [deg].
    bound : RobustBound or None
        The robust bound planned on (None for a nominal plan).
    """
    timings: dict[str, float] = {}
    t = time.perf_counter()
    plunge, f_use, models, windows, bound = _scenario_models(job, modes, f_tcp, tool, robust)
    timings["frf"] = time.perf_counter() - t
    t = time.perf_counter()
    grouped = waypoint_lobes(
        models,
        unbounded=plunge if air is None else plunge | air,
        window=windows,
        own=own,
        reuse=reuse,
        **_lobe_args(job, material, rpm, dynamics_tol, engagement),
    )
    timings["lobes"] = time.perf_counter() - t
    feed_angle = np.degrees(np.arctan2(f_use[:, 1], f_use[:, 0]))
    return models[0], plunge, grouped, timings, feed_angle, bound


def _scenario_models(
    job: Job,
    modes: RobotModes,
    f_tcp: FloatArray,
    tool: ModalModel | None,
    robust: bool | None = None,
) -> tuple[
    NDArray[np.bool_], FloatArray, list[ModalModel], list[FloatArray] | None, RobustBound | None
]:
    """The feed-frame tool-point models the lobes are computed on (:func:`cut_lobes`).

    Returns the plunge mask (n,), the feed directions used (n, 3) (plunges
    along TCP x), the models (nominal first, then each corner of the robust
    bound held at margin 1, batch (n,)), their speed windows (None for a
    nominal plan) and the bound (None for a nominal plan; ``robust``
    overrides ``job.plan.robust``).
    """
    plunge = _feed_lateral(f_tcp) < PLUNGE_LATERAL
    f_use = np.where(plunge[:, None], [[1.0, 0.0, 0.0]], f_tcp)
    rot = feed_frame(f_use, (0.0, 0.0, -1.0), rotation="cw")
    models = [_tool_point_models(rot, modes.model, tool)]
    bound, _ = plan_bound(job.plan, modes, robust)
    windows: list[FloatArray] | None = None
    if bound is not None:
        # the nominal modes at the safety factor as a plain plan takes them (no window: a
        # window there compounds the safety factor with the frequency error, out-of-form C0
        # steel 0.70 of the oracle's MRR, 0.82 without), each corner of the joint region
        # at margin 1 in its own window
        windows = [np.zeros(len(bound.window))]
        for bm, bw in bound.corners():
            models.append(bound_scenario(_tool_point_models(rot, bm, tool), job.plan.safety_factor))
            windows.append(bw)
    return plunge, f_use, models, windows, bound


#: Damping ratio of a twin mode from which the plan says that its real-mode receptance
#: may be off the twin's exact one (studies/planner_receptance.py: robot B with its
#: joint damping x2, x4, x8 (ratios up to 0.09, 0.18, 0.36) puts the chatter-setting
#: real part at 0.82-1.21, 0.71-1.30, 0.60-1.39 of the exact; B as shipped 0.89-1.18).
HEAVY_DAMPING = 0.15


def _heavy_damping_note(table: pd.DataFrame, source: ModeSource) -> str:
    """A note when the twin's modes along the cut are heavily damped (the planner's
    real-mode receptance of them can then be well off the twin's exact one), else ""."""
    if not isinstance(source, (TwinSource, CorrectedTwinSource)):
        return ""  # a predictor's modes are the model itself
    cols = [c for c in table.columns if c.startswith("zeta")]
    cut = (table["motion"] == "cut").to_numpy()
    if not cols or not cut.any():
        return ""
    # per waypoint, column by column (the (n_cut, n_cols) block of a long path at once
    # was its plan's peak memory)
    z_max = np.full(int(cut.sum()), -np.inf)
    for c in cols:
        z = table[c].to_numpy(dtype=np.float64)[cut]
        np.fmax(z_max, np.where(np.isfinite(z), z, -np.inf), out=z_max)
    n = int(np.count_nonzero(z_max >= HEAVY_DAMPING))
    if not n:
        return ""
    return (
        f"the twin's modes are heavily damped at {n} cutting waypoint{'s' if n != 1 else ''} "
        f"(damping ratio up to {z_max.max():.2f}): the planner's real-mode receptance "
        "can be 30 % or more off the twin's exact one there (README, known limit); plan "
        "robustly, or check the plan on measured FRFs with robolobe verify"
    )


def _robust_infeasible(
    reason: str, grouped: GroupedLobes, bound: RobustBound, cons: Constraints
) -> str:
    """Why a robust plan is infeasible and what would make it feasible (issue 27)."""
    rpm = grouped.table.rpm
    ok = (rpm >= cons.rpm_min) & (rpm <= cons.rpm_hi)
    nominal = grouped.diagrams[0].a_lim
    held = np.min(np.stack([d.a_lim for d in grouped.diagrams[1:]]), axis=0)
    sf = cons.safety_factor
    best_nom = np.where(ok, nominal, 0.0).max(axis=1) / sf  # per group
    best_bound = np.where(ok, held, 0.0).max(axis=1) / sf  # the bound at margin 1
    worst = int(np.argmin(best_bound))
    d = bound.describe()
    plain = (
        "a plain plan (plan.robust = false) on the prediction is feasible"
        if np.all(best_nom >= cons.depth_min_m)
        else "the prediction alone is infeasible too"
    )
    return (
        f"{reason} (robust plan: on the bound, stiffness to {d['stiffness_lowered_to_pct']:.3g} % "
        f"and damping to {d['damping_lowered_to_pct']:.3g} % of the prediction, speed window "
        f"+-{d['frequency_window_pct_max']:.3g} %, the deepest stable cut of the worst "
        f"dynamics is {best_bound[worst] * 1e3:.3g} mm, the prediction's "
        f"{best_nom[worst] * 1e3:.3g} mm; {plain}). To plan robustly: a smaller plan.k_sigma "
        f"(now {bound.k_sigma:g}), a narrower spread from hammer tests near these postures, "
        "or a smaller plan.depth_min"
    )


def plan_path(
    path: str | os.PathLike[str] | pd.DataFrame,
    job: Job | str | os.PathLike[str],
    *,
    robot: Robot | str | os.PathLike[str] | None = None,
    source: ModeSource | None = None,
    modes: object | None = None,
    refine: bool = True,
) -> PlanResult:
    """Plan one toolpath with one job.

    Parameters
    ----------
    path : path-like or pandas.DataFrame
        Toolpath file (any supported format) or a waypoint table.
    job : Job or path-like
        The job or its file.
    robot : Robot or str or path-like, optional
        Overrides ``job.robot``: a loaded robot, ``"A"``, ``"B"``, ``"C"`` or
        a robot file.
    source : ModeSource, optional
        Overrides ``job.model``.
    modes : optional
        Overrides ``job.model`` with any mode predictor
        (:func:`robolobe.plan.modes.as_mode_source`: a fitted
        ``CorrectedTwin``, ``TwinCalibration`` or ``ModalPredictor``, a
        ``Robot`` for its twin, ``ModalParameters`` or a mode source); not
        with ``source``.
    refine : bool
        Run the casadi refinement.

    Returns
    -------
    PlanResult
        ``table`` columns: ``source line motion x_mm y_mm z_mm q1_deg..q6_deg
        wrist_sin feed_angle_deg`` (feed direction in the TCP x/y plane),
        per TCP direction d and mode r ``f{r}_{d}_hz zeta{r}_{d} k{r}_{d}_N_per_m``,
        ``extrapolation``, ``dynamics_group``, ``a_lim_mm`` (at the planned
        speed), ``a_min_mm`` / ``rpm_best`` (lowest and best point of the
        waypoint's lobes on the grid), ``rpm``, ``depth_mm``, ``margin``
        (a_lim / depth), ``limiting``, ``power_kW``, ``feed_mm_per_min``,
        ``rpm_programmed``.

    Raises
    ------
    InputError, ReachabilityError, SingularityError, InfeasibleError
        With the waypoint and its ``file:line``.
    """
    # a long path's large arrays mapped, not from the heap, but in the lobe stages
    # (robolobe._memory: the heap's fragments, not what is alive, set a long plan's peak)
    with large_blocks_mapped(_long_path(path)):
        return _plan_path(path, job, robot=robot, source=source, modes=modes, refine=refine)


def _long_path(path: str | os.PathLike[str] | pd.DataFrame) -> bool:
    """Whether ``path`` has (a program of the size of) :data:`RELEASE_MIN_ROWS` waypoints."""
    if isinstance(path, pd.DataFrame):
        return len(path) >= RELEASE_MIN_ROWS
    try:
        return os.path.getsize(path) >= RELEASE_MIN_ROWS * _PROGRAM_LINE_BYTES
    except (OSError, TypeError, ValueError):
        return False  # refused when read, with its message


#: Bytes of a typical program line (a G1 move with coordinates), for :func:`_long_path`.
_PROGRAM_LINE_BYTES = 24


def _plan_path(
    path: str | os.PathLike[str] | pd.DataFrame,
    job: Job | str | os.PathLike[str],
    *,
    robot: Robot | str | os.PathLike[str] | None,
    source: ModeSource | None,
    modes: object | None,
    refine: bool,
) -> PlanResult:
    """:func:`plan_path`'s work (its parameters)."""
    job = load_job(job)  # a path is read; anything but a Job or a path is refused
    timings: dict[str, float] = {}
    t = time.perf_counter()
    wp, path_name = _read(path, job.path_options)
    timings["read"] = time.perf_counter() - t
    robot = load_robot(job.robot if robot is None else robot)
    check_tool_modes_on(job.tool, robot, job.source)
    note = ""
    if modes is not None:
        if source is not None:
            raise InputError("plan_path: give modes or source, not both")
        source = as_mode_source(modes)
    if source is None:
        source, note = mode_source(job.model, robot, job.robot, job.effects)
    material = material_from_job(job)
    tool = _tool_model(job)
    if not np.all(np.isfinite(wp[["fx", "fy", "fz"]].to_numpy(dtype=np.float64))):
        raise InputError(
            "expected a path that moves, found all waypoints at one point",
            source=Path(path_name).name,
        )
    cut = (wp["motion"] == "cut").to_numpy()
    if not np.any(cut):
        raise InputError(
            "expected at least one cutting move (G1/G2/G3, LIN, MoveL), found none",
            Path(path_name).name,
        )
    t = time.perf_counter()
    with large_blocks_mapped(False):  # the Z-map's many blocks: the heap's (robolobe._memory)
        eng, eng_note = plan_engagement(job, wp, path_name)  # [stock]: refused before any lobes
    timings["engagement"] = time.perf_counter() - t
    note = (note + "; " if note else "") + eng_note
    if eng is not None:
        note += "; " + engagement_note(job, wp, eng)
    engaged = cut if eng is None else cut & eng.engaged
    limits = process_limits(job, wp, engaged, path_name, robot=robot)
    # the lobes over the speeds the plan may use (the spindle's range within the vc range)
    rpm = np.linspace(limits.rpm_min, limits.rpm_max, job.plan.n_rpm)
    rotation = job.tool_rotation_rad
    cons = constraints_from_job(job, material.kt, limits)
    rot_note = ""
    with large_blocks_mapped(False):  # many large blocks made and freed: the heap's
        if job.tool_rotation == "stiffest":
            rotation, rot_note = _stiffest_rotation(
                job, wp, robot, source, cut, material, tool, rpm, cons, eng
            )
        q, wm, modes, plunge, grouped, t_stage, feed_angle, bound, split, members = (
            _lobes_for_rotation(job, wp, robot, source, rotation, cut, material, tool, rpm, eng)
        )
    timings.update(t_stage)
    release_free_memory(len(wp))  # the lobe stage's temporaries: not under the next peaks
    t = time.perf_counter()
    ci = np.flatnonzero(cut)
    pos = wp[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64)
    seg = segment_lengths(pos)
    rapid_time = float(seg[~cut].sum() / job.cut.rapid_feed_m_per_s)
    geom = PathGeometry(seg[ci], rapid_time)
    prog = wp["rpm_programmed"].to_numpy(dtype=np.float64)[ci]
    if job.cut.programmed_rpm is not None:
        prog = np.where(np.isfinite(prog), prog, job.cut.programmed_rpm)
    labels = _Labels(_string_column(wp["source"]), wp["line"].to_numpy(), ci)
    depth: ProgramDepth | None = None
    if eng is not None:
        bounded = ~plunge & eng.engaged[ci]
        depth = program_depth(eng.depth_m[ci], pos[ci, 2], bounded, sections(ci))
        if depth is not None and ci[0] == 0 and not depth.fixed[0]:
            # a program that starts with a cut has no start point to come back to between
            # passes (the writers refuse them there): its first section keeps one pass
            first = depth.section == depth.section[0]
            depth = dataclasses.replace(depth, fixed=depth.fixed | first)
            note = (note + "; " if note else "") + (
                f"the program starts with a cutting move ({labels[0]}): its first run of "
                "cutting moves is planned in one pass at its own depth (no start point to "
                "return to between passes); program an approach move to allow passes there"
            )
        if depth is not None:
            width = float(np.nanmax(np.where(bounded, eng.radial_width_m[ci], np.nan)))
            cons = dataclasses.replace(cons, width_m=width)  # the widest engagement: power, torque
    del pos  # (n, 3): not under the peaks of the table and the passes

    def schedule(table: Any) -> PlanOutcome:
        made: dict[int, Any] = {}  # the depth-share tables (one unless a section is fixed)

        def scaled(p: int) -> Any:
            assert depth is not None
            key = p if depth.fixed.any() else 1
            if key not in made:
                made.clear()
                made[key] = table.per_depth(depth.share(p))
            return made[key]

        def run(c: Constraints, p: int = 1, fine: bool = refine) -> PlanOutcome:
            out = optimize_schedule(
                table if depth is None else scaled(p),
                geom,
                c,
                programmed_rpm=prog if np.any(np.isfinite(prog)) else None,
                labels=labels,
                refine=fine,
            )
            for k, v in out.timings.items():
                opt_s[k] = opt_s.get(k, 0.0) + v
            opt_s["runs"] = opt_s.get("runs", 0) + 1
            return out

        if depth is None:
            return run(cons)
        # headroom of the lobes' stated tolerance: the program's own check (its own lobe
        # sharing, whole-rpm speeds) then finds every move at the safety factor too
        room = dataclasses.replace(cons, safety_factor=cons.safety_factor * (1 + LOBE_TOL))
        return schedule_passes(run, room, depth.deepest_m, refine=refine)[0]

    # the optimizer's seconds per step summed over all its runs (the pass counts tried,
    # the schedule made again after the split) and the number of runs
    opt_s: dict[str, float] = {}
    t_split = 0.0
    try:
        outcome = schedule(grouped.table)
    except InfeasibleError as exc:
        if bound is None:
            raise
        raise InfeasibleError(_robust_infeasible(str(exc), grouped, bound, cons)) from None
    # lobe sharing keeps its promise: members planned next to a steep wall of their
    # leader's lobes, or whose own modes set a limit outside the promise of the shared
    # one there (a dominant mode's size, shared to the residue tolerance), get lobes of
    # their own, and the schedule is made again
    steep = steep_members(grouped, outcome.best.rpm)
    t_size = time.perf_counter()
    with large_blocks_mapped(False):
        steep |= members(grouped, outcome.best.rpm)
    t_split += time.perf_counter() - t_size
    del members  # its models (~1 kB a cutting waypoint): not under the schedule made again
    release_free_memory(len(wp))  # the check's blocks (two threads' heaps): not under it either
    n_split = int(steep.sum())
    if n_split:
        t0_split = time.perf_counter()
        with large_blocks_mapped(False):
            grouped = split(steep, grouped)
        t_split += time.perf_counter() - t0_split
    timings["lobes"] += t_split
    if n_split:
        del outcome  # the first schedule (~100 bytes a waypoint): not under the second
        outcome = schedule(grouped.table)
    del split  # its models' inputs (feed directions, angles: ~40 bytes a waypoint)
    outcome = dataclasses.replace(outcome, timings=opt_s)
    timings["optimize"] = time.perf_counter() - t - t_split  # the split's lobes: in "lobes"
    t = time.perf_counter()
    if grouped.forget is not None:
        grouped.forget()  # the optimizer's kept answers: not under the table's and outputs' peaks
    release_free_memory(len(wp))
    table = _result_table(
        wp, q, wm, modes, grouped, outcome, ci, plunge, feed_angle, job, cons, seg
    )
    if limits.feed_per_tooth_source == "program":
        # each move at the program's own chip load (the optimizer planned on the largest)
        fz = limits.fz_program_m
        fz = np.where(np.isfinite(fz) & (fz > 0), fz, cons.feed_per_tooth_m)
        feed = table["feed_mm_per_min"].to_numpy().copy()
        feed[ci] = fz[ci] * job.tool.teeth * table["rpm"].to_numpy()[ci] * 1e3
        with _columns_added():
            table["feed_mm_per_min"] = feed
    passes_rows = None
    if depth is not None:
        assert eng is not None
        release_free_memory(len(wp))
        with _columns_added():
            passes_rows = _apply_passes(table, grouped, outcome, depth, ci, plunge, eng, cons, seg)
        most = max(passes_rows, key=lambda r: r["passes"])
        if most["passes"] > MANY_PASSES:
            note = (note + "; " if note else "") + (
                f"{most['lines']} needs {most['passes']} passes of {most['depth_per_pass_mm']:g} "
                f"mm for its {most['program_depth_mm']:g} mm (set by {most['set_by']}): the "
                "robot is far too soft for this cut here; a stiffer posture or placement "
                "(robolobe compare), a shorter or stiffer tool, or a lighter program"
            )
        imm = eng.immersion[ci]
        low = ~plunge & eng.engaged[ci] & (imm < LOW_IMMERSION)
        if low.any():
            # said per move here, not as the lobes' one sentence of the smallest immersion
            grouped = dataclasses.replace(grouped, message="")
            k = int(np.flatnonzero(low)[0])
            note = (note + "; " if note else "") + (
                f"{int(low.sum())} of {int((~plunge & eng.engaged[ci]).sum())} engaged moves "
                f"cut at a_e/D < {LOW_IMMERSION:g} (first {labels[k]}: {imm[k]:.3f}), where "
                "the zero-order lobes are least reliable"
            )
    engagement_from = (
        "cut.radial_width_mm"
        if depth is None
        else ("stock" if job.stock is not None else "default stock")
    )
    # per-move arrays, all in the table now: not under the last steps' peaks
    eng = depth = None
    own_col = np.zeros(len(wp), bool)
    own_col[ci] = steep
    with _columns_added():
        table["lobes_own"] = own_col
    release_free_memory(len(wp))
    heavy = _heavy_damping_note(table, source)
    if heavy:
        note = (note + "; " if note else "") + heavy
    record = plan_record(job, path if not isinstance(path, pd.DataFrame) else None, table)
    summary = PlanSummary.build(
        job=job,
        path=path_name,
        robot=robot,
        mode_source=source.name,
        material=material.name,
        waypoints=wp,
        table=table,
        cut_index=ci,
        lobes=grouped,
        outcome=outcome,
        constraints=cons,
        geometry=geom,
        tool_rotation_rad=rotation,
        tool_rotation_search=rot_note,
        plan_record=record,
        extrapolation=modes.extrapolation,
        bound=bound,
        mode_note=note,
        n_split=n_split,
        sections=passes_rows,
        limits=limits,
        engagement=engagement_from,
    )
    timings["table"] = time.perf_counter() - t
    summary = summary.with_timings(timings)
    return PlanResult(
        job=job,
        path=path_name,
        robot=robot,
        waypoints=wp,
        table=table,
        outcome=outcome,
        lobes=grouped,
        cut_index=ci.astype(np.int64),
        q=q,
        geom=geom,
        summary=summary,
        timings=timings,
    )


def _stiffest_rotation(
    job: Job,
    wp: pd.DataFrame,
    robot: Robot,
    source: ModeSource,
    cut: NDArray[np.bool_],
    material: Material,
    tool: ModalModel | None,
    rpm: FloatArray,
    cons: Constraints,
    eng: Engagement | None = None,
) -> tuple[float, str]:
    """Rotation about the tool axis with the largest worst-case stable depth.

    Each candidate is judged on a subsample of the cutting waypoints (at most
    200) by ``min over waypoints of max over allowed speeds of a_lim``; an
    unreachable or singular candidate is skipped.
    """
    lo, hi = job.tool_rotation_range_rad
    step = job.tool_rotation_step_rad
    cands = np.arange(lo, hi + 1e-9, step) if hi > lo else np.array([lo])
    ci = np.flatnonzero(cut)
    sub = np.unique(np.r_[ci[:: max(1, ci.size // 200)], ci[-1]])
    keep = np.zeros(len(wp), bool)
    keep[sub] = True
    # keep the path continuous for IK: all waypoints, cut mask reduced to the subsample
    allowed = (rpm >= cons.rpm_min) & (rpm <= cons.rpm_hi)
    best, best_val, tried = None, -np.inf, []
    for r in cands:
        try:
            *_, grouped, _, _, _, _, _ = _lobes_for_rotation(
                job, wp, robot, source, float(r), keep, material, tool, rpm, eng
            )
        except (ReachabilityError, SingularityError) as exc:
            tried.append(f"{math.degrees(r):.0f} deg: {type(exc).__name__}")
            continue
        best_g = np.max(grouped.table.a_lim[:, allowed], axis=1)  # per group
        val = float(np.min(best_g[grouped.table.group]))
        tried.append(f"{math.degrees(r):.0f} deg: {val * 1e3:.3g} mm")
        if val > best_val:
            best, best_val = float(r), val
    if best is None:
        raise ReachabilityError(
            "no tool rotation in the allowed range reaches the whole path: " + "; ".join(tried)
        )
    return best, "; ".join(tried)


# ------------------------------------------------------------------ outputs
def _string_column(col: pd.Series) -> Any:
    """A string column for the result table: its own array when pandas stores it as
    strings (immutable, shared without a copy), else its values as before."""
    if isinstance(col.dtype, pd.StringDtype):
        return col.array
    return col.to_numpy()


def _result_table(
    wp: pd.DataFrame,
    q: FloatArray,
    wm: FloatArray,
    modes: RobotModes | _ModeColumns,
    grouped: GroupedLobes,
    outcome: PlanOutcome,
    ci: NDArray[np.int64],
    plunge: NDArray[np.bool_],
    feed_angle: FloatArray,
    job: Job,
    cons: Constraints,
    seg: FloatArray,
) -> pd.DataFrame:
    n = len(wp)
    best = outcome.best
    # the masks once, from the string column (not an object array of it per use)
    is_cut = (wp["motion"] == "cut").to_numpy(dtype=bool)
    is_rapid = (wp["motion"] == "rapid").to_numpy(dtype=bool)
    cols: dict[str, Any] = {
        # the waypoint table's own string arrays (immutable: shared, not converted)
        "source": _string_column(wp["source"]),
        "line": wp["line"].to_numpy(),
        "motion": _string_column(wp["motion"]),
        "x_mm": wp["x_m"].to_numpy() * 1e3,
        "y_mm": wp["y_m"].to_numpy() * 1e3,
        "z_mm": wp["z_m"].to_numpy() * 1e3,
    }
    qd = np.degrees(q)
    for j in range(6):
        cols[f"q{j + 1}_deg"] = qd[:, j]
    cols["wrist_sin"] = wm
    fa = np.full(n, np.nan)
    fa[ci] = np.where(plunge, np.nan, feed_angle)
    cols["feed_angle_deg"] = fa
    if isinstance(modes, _ModeColumns):
        cols.update(modes.columns)  # made whole while streaming (not copied)
    else:
        arrs = {"f": modes.f_hz, "zeta": modes.zeta, "k": modes.k_N_per_m}
        for c, d, r, name in _mode_column_names(modes.f_hz.shape[-1]):
            v = np.full(n, np.nan)
            v[ci] = arrs[name][:, d, r]
            cols[c] = v
    ex = np.full(n, np.nan)
    if modes.extrapolation is not None:
        ex[ci] = modes.extrapolation
    cols["extrapolation"] = ex
    grp = np.full(n, -1, np.int64)
    g = grouped.table.group
    grp[ci] = np.where(plunge, -1, g)
    cols["dynamics_group"] = grp
    # per group, then per waypoint (not an (n_cut, n_rpm) copy of the grid)
    allowed = (grouped.table.rpm >= cons.rpm_min) & (grouped.table.rpm <= cons.rpm_hi)
    a_low = grouped.table.a_lim[:, allowed].min(axis=1)
    amin = np.full(n, np.nan)
    amin[ci] = np.where(np.isfinite(a_low), a_low, np.nan)[g] * 1e3
    cols["a_min_mm"] = amin
    rb = np.full(n, np.nan)
    jbest = np.argmax(np.where(allowed, grouped.table.a_lim, -np.inf), axis=1)
    rb[ci] = np.where(plunge, np.nan, grouped.table.rpm[jbest][g])
    cols["rpm_best"] = rb
    alim = np.full(n, np.nan)
    alim[ci] = np.where(np.isfinite(best.a_lim_m), best.a_lim_m * 1e3, np.nan)
    cols["a_lim_mm"] = alim
    # speed along the whole path: the schedule at each waypoint's cutting length
    s_all = np.cumsum(np.where(is_cut, seg, 0.0))
    if best.knots_rpm.size >= 2:
        rpm_all = np.interp(s_all, best.knots_s_m, best.knots_rpm)
    else:
        rpm_all = np.full(n, float(best.rpm[0]))
    rpm_all[ci] = best.rpm
    cols["rpm"] = rpm_all
    cols["depth_mm"] = np.where(is_cut, best.depth_m * 1e3, np.nan)
    mg = np.full(n, np.nan)
    mg[ci] = np.where(np.isfinite(best.margin), best.margin, np.nan)
    cols["margin"] = mg
    lim = np.full(n, "", dtype=object)
    lim[ci] = _shared_labels(np.where(plunge, "plunge", outcome.limiting))
    lim[is_rapid] = "rapid"
    cols["limiting"] = lim
    pw = np.full(n, np.nan)
    pw[ci] = outcome.power_W * 1e-3
    cols["power_kW"] = pw
    cols["feed_mm_per_min"] = np.where(is_cut, cons.feed_per_rev_m * rpm_all * 1e3, np.nan)
    cols["rpm_programmed"] = wp["rpm_programmed"].to_numpy()
    # the columns as they are (not consolidated into one block: a copy of the table)
    return pd.DataFrame(cols, copy=False)


def _shared_labels(labels: NDArray[np.str_]) -> NDArray[np.object_]:
    """Labels as an object array whose equal entries are one ``str`` object each.

    ``labels.astype(object)`` makes a string object per entry (a million
    small objects on a long path, ~60 bytes each, scattered over the heap);
    the few distinct labels are made once here and shared.

    Parameters
    ----------
    labels : ndarray of str, shape (n,)

    Returns
    -------
    ndarray of object, shape (n,)
        The same values.
    """
    out = np.empty(labels.shape, dtype=object)
    rest = np.ones(labels.shape, dtype=bool)
    while rest.any():  # once per distinct label
        v = labels[int(np.argmax(rest))]
        same = labels == v
        out[same] = str(v)
        rest &= ~same
    return out


@contextlib.contextmanager
def _columns_added() -> Iterator[None]:
    """Columns set on a result table one by one, without pandas' fragmentation warning.

    The table's columns are separate blocks on purpose (:func:`_result_table`:
    no consolidating copy of a long path's table); pandas warns about that
    past 100 blocks (robots with many modes), which says nothing to a user.
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", pd.errors.PerformanceWarning)
        yield


#: Cutting waypoints labelled at a time where a plan in passes names its binding limits.
_LABEL_BLOCK = 65_536
#: Passes of one section above which the plan's notes say the cut is far beyond the robot.
MANY_PASSES = 10
#: Relative slack under which a limit binds at a move of a plan in passes (above it for
#: every limit the move's speed is held by the schedule: ``limiting = "schedule"``).
BINDING_SLACK = 0.01


def _apply_passes(
    table: pd.DataFrame,
    grouped: GroupedLobes,
    outcome: PlanOutcome,
    depth: ProgramDepth,
    ci: NDArray[np.int64],
    plunge: NDArray[np.bool_],
    eng: Engagement,
    cons: Constraints,
    seg: FloatArray,
) -> list[dict[str, Any]]:
    """Each section's passes into the result table; the sections' rows for the summary.

    Columns set (cutting rows): ``passes`` (of the move's section),
    ``depth_mm`` (the section's step per pass: its deepest move over its
    passes, the step the program's passes are written at),
    ``cut_depth_mm`` (this move's own depth per pass), ``program_depth_mm``
    (as programmed), ``a_lim_mm`` (the move's own limit at its speed and
    engagement), ``margin`` (``a_lim / cut_depth``), ``section``,
    ``ae_over_D``, ``phi_entry_deg``, ``phi_exit_deg``; ``limiting`` is
    ``"air"`` on feed moves that cut nothing.
    """
    best = outcome.best
    a_lim = grouped.table.query(best.rpm)  # each move's own limit (not the depth share's)
    bounded = ~plunge & eng.engaged[ci]
    passes_s, set_by = section_passes(
        depth, a_lim, bounded, cons.safety_factor * (1 + LOBE_TOL), cons.depth_cap_m
    )
    p = passes_s[depth.section]
    sec_depth = depth.section_depth_m()
    step = sec_depth[depth.section] / p
    cut_d = depth.depth_m / p
    n = len(table)

    def col(v: Any, fill: Any = np.nan, dtype: Any = np.float64) -> Any:
        out = np.full(n, fill, dtype=dtype)
        out[ci] = v
        return out

    # the columns one at a time, each temporary gone before the next (a long path's
    # peak: the table is whole here)
    table["section"] = col(depth.section, -1, np.int64)
    table["passes"] = col(p, 1, np.int64)
    table["depth_mm"] = col(step * 1e3)
    del step, p
    table["cut_depth_mm"] = col(np.where(depth.depth_m > 0, cut_d * 1e3, 0.0))
    table["program_depth_mm"] = col(depth.depth_m * 1e3)
    table["a_lim_mm"] = col(np.where(bounded & np.isfinite(a_lim), a_lim * 1e3, np.nan))
    with np.errstate(divide="ignore", invalid="ignore"):
        mg = np.where(bounded & (cut_d > 0), a_lim / cut_d, np.nan)
    table["margin"] = col(mg)
    engaged = eng.engaged[ci]
    table["ae_over_D"] = col(np.where(engaged, eng.immersion[ci], 0.0))
    table["phi_entry_deg"] = col(np.degrees(eng.phi_entry[ci]))
    table["phi_exit_deg"] = col(np.degrees(eng.phi_exit[ci]))
    # each distinct label one str object (to_numpy() makes one per row: 60 bytes each)
    codes, names = pd.factorize(table["limiting"], use_na_sentinel=False)
    lim = np.asarray(names, dtype=object)[codes]
    del codes
    lab = lim[ci]
    fix = lab == "depth_max"
    if np.any(fix):
        # the pass depth is fixed (not a limit that binds): name what binds besides it,
        # each move at its own depth and margin
        pw = table["power_kW"].to_numpy()[ci] * 1e3
        at = np.flatnonzero(fix)
        for s in range(0, at.size, _LABEL_BLOCK):  # blocks: a slack per limit is (n,) each
            r = at[s : s + _LABEL_BLOCK]
            slack = limit_slacks(cons, best.rpm[r], cut_d[r], a_lim[r], pw[r], fixed_depth=True)
            slack["stability"] = np.where(bounded[r], slack["stability"], np.inf)
            lab[r] = _shared_labels(limiting_labels(slack, free=BINDING_SLACK))
        lim[ci] = lab
        del pw
    del lab, fix, cut_d, a_lim
    lim[ci[~engaged & ~plunge]] = "air"
    table["limiting"] = lim
    del lim
    src = table["source"].array  # a few entries are read: not an object array of them all
    line = table["line"].to_numpy()
    t_pass = seg[ci] / np.maximum(table["feed_mm_per_min"].to_numpy()[ci] / 6e4, 1e-300)
    width = np.where(engaged, eng.radial_width_m[ci], 0.0)
    vol = np.where(bounded, depth.depth_m * width * seg[ci], 0.0)
    del width, engaged
    rows = []
    for k in range(depth.n_sections):
        idx = np.flatnonzero(depth.section == k)
        i0, i1 = int(ci[idx[0]]), int(ci[idx[-1]])
        b = bounded[idx] & (depth.depth_m[idx] > 0)
        sb = int(set_by[k])
        rows.append(
            {
                "section": k,
                "lines": f"{src[i0]}:{int(line[i0])}-{int(line[i1])}",
                "z_mm": round(
                    float(table["z_mm"].iloc[int(ci[idx[np.argmax(depth.depth_m[idx])]])]), 4
                ),
                "moves": int(idx.size),
                "program_depth_mm": round(float(depth.depth_m[idx].max()) * 1e3, 4),
                "passes": int(passes_s[k]),
                "depth_per_pass_mm": round(float(sec_depth[k] / passes_s[k]) * 1e3, 4),
                "set_by": f"{src[ci[sb]]}:{int(line[ci[sb]])}" if sb >= 0 else "",
                "min_margin": round(float(np.nanmin(mg[idx][b])), 4) if b.any() else None,
                "rpm_min": round(float(best.rpm[idx].min()), 1),
                "rpm_max": round(float(best.rpm[idx].max()), 1),
                "cut_time_s": round(float(passes_s[k] * t_pass[idx].sum()), 3),
                # removed once whatever the passes: depth x radial width x length
                "volume_cm3": round(float(vol[idx].sum()) * 1e6, 4),
            }
        )
    return rows


def waypoints_hash(table: pd.DataFrame) -> str:
    """SHA-256 of a plan's path geometry (source, line, x/y/z to 1 nm) from its table."""
    import hashlib

    h = hashlib.sha256()
    _hash_joined(h, table["source"])
    h.update(np.asarray(table["line"], dtype=np.int64).tobytes())
    xyz = np.round(table[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=np.float64), 6) + 0.0
    h.update(xyz.tobytes())
    _hash_joined(h, table["motion"])
    return h.hexdigest()


def _hash_joined(h: Any, col: pd.Series, block: int = 65_536) -> None:
    """``h.update("\\n".join(map(str, col.tolist())).encode())``, a block of rows at a time.

    The same bytes (the hash is unchanged), without a million string objects
    and their joined text at once.
    """
    for s in range(0, len(col), block):
        part = "\n".join(map(str, col.iloc[s : s + block].tolist()))
        h.update((part if s == 0 else "\n" + part).encode())


def job_fingerprint(job: Job) -> dict[str, Any]:
    """What of a job a plan's limits depend on (beside the robot and its modes), JSON-ready."""
    material = material_from_job(job)
    return {
        "robot": job.robot,
        "tool": {
            "diameter_mm": round(job.tool.diameter_m * 1e3, 9),
            "teeth": job.tool.teeth,
            "modes": [[m.direction, m.f_hz, m.zeta, m.k_N_per_m] for m in job.tool.modes],
        },
        "material": {"name": material.name, "Kt": material.kt, "Kr": material.kr},
        "cut": {
            "radial_width_mm": round(job.cut.radial_width_m * 1e3, 9),
            "milling": job.cut.milling,
        },
        "spindle_rpm": [job.spindle.rpm_min, job.spindle.rpm_max],
        "n_rpm": job.plan.n_rpm,
        "dynamics_tol": job.plan.dynamics_tol,
        "safety_factor": job.plan.safety_factor,
        "placement": [round(float(v), 12) for v in np.asarray(job.placement).ravel()],
    }


def plan_record(
    job: Job, path: str | os.PathLike[str] | None, table: pd.DataFrame
) -> dict[str, Any]:
    """What ``robolobe verify`` needs to check that a job and a path belong to a plan.

    Returns
    -------
    dict
        ``job`` (:func:`job_fingerprint`), ``path_sha256`` (the toolpath
        file's bytes; None for a table), ``waypoints_sha256``
        (:func:`waypoints_hash`).
    """
    import hashlib

    p_hash = None
    if path is not None and Path(path).is_file():
        with open(path, "rb") as fh:  # in blocks (a long program: not its bytes whole)
            p_hash = hashlib.file_digest(fh, "sha256").hexdigest()
    return {
        "format": "robolobe-plan-record/1",
        "job": job_fingerprint(job),
        "path_sha256": p_hash,
        "waypoints_sha256": waypoints_hash(table),
    }
