"""The optimizer's entry point: the stages in order, then verification and the choice."""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InfeasibleError, InputError
from robolobe.plan.optimize._common import _Ctx, _score, _verify
from robolobe.plan.optimize._inputs import Constraints, LobeTable, PathGeometry
from robolobe.plan.optimize._nlp import _refine, _refine_cannot_improve
from robolobe.plan.optimize._results import PlanOutcome, Schedule
from robolobe.plan.optimize._search import _constant, _prechecks, _search

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


# ------------------------------------------------------------- limiting
def limit_slacks(
    cons: Constraints,
    rpm: FloatArray,
    depth_m: float | FloatArray,
    a_lim_m: FloatArray,
    power_W: FloatArray,
    *,
    fixed_depth: bool = False,
) -> dict[str, FloatArray]:
    """Relative slack of every process limit at each cutting waypoint.

    Parameters
    ----------
    cons : Constraints
    rpm : ndarray, shape (n,)
        Speed at each waypoint [rpm].
    depth_m : float or ndarray, shape (n,)
        Depth cut at each waypoint [m].
    a_lim_m : ndarray, shape (n,)
        Stability limit at each waypoint at its speed [m] (NaN or inf: none).
    power_W : ndarray, shape (n,)
        Cutting power at each waypoint [W].
    fixed_depth : bool
        The depth is given (a plan in passes): ``depth_max`` is then not a
        limit that binds.

    Returns
    -------
    dict of str to ndarray, shape (n,)
        ``limit / demand - 1`` per limit (0: the limit binds; ``inf``: no limit).
    """
    n = np.asarray(rpm, dtype=np.float64)
    a = np.maximum(np.broadcast_to(np.asarray(depth_m, dtype=np.float64), n.shape), 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        stab = a_lim_m / (cons.safety_factor * a) - 1.0
    slack = {
        "stability": np.where(np.isfinite(stab), stab, np.inf),
        "power": cons.power_W / np.maximum(power_W, 1e-300) - 1.0,
        "torque": cons.torque_Nm / np.maximum(cons.torque_Nm_at(1.0) * a, 1e-300) - 1.0,
    }
    if not fixed_depth:
        slack["depth_max"] = cons.depth_max_m / a - 1.0
    slack["rpm_min"] = n / cons.rpm_min - 1.0
    slack["rpm_max" if cons.rpm_hi >= cons.rpm_max else "feed_max"] = cons.rpm_hi / n - 1.0
    return slack


def limiting_labels(slack: dict[str, FloatArray], free: float | None = None) -> NDArray[np.str_]:
    """The limit that binds at each waypoint: the one with the least slack.

    Parameters
    ----------
    slack : dict of str to ndarray, shape (n,)
        From :func:`limit_slacks`.
    free : float, optional
        A waypoint whose every slack exceeds this is labelled ``"schedule"``
        (its speed is held by the schedule, not by a limit there).
    """
    # np.argmin over the stacked slacks, one limit at a time (no (limits, n) copy: at a
    # million waypoints ~50 MB, in every optimizer run): the first least, a NaN first
    names = list(slack)
    values = list(slack.values())
    best = np.array(values[0], dtype=np.float64, copy=True)
    code = np.zeros(best.shape, np.intp)
    for i, v in enumerate(values[1:], start=1):
        nan_b = np.isnan(best)
        better = (v < best) | (np.isnan(v) & ~nan_b)
        code[better] = i
        np.copyto(best, v, where=better)
    width = max(len(x) for x in [*names, "schedule"])
    lim = np.asarray(names, dtype=f"<U{width}")[code]
    if free is not None:
        lim[best > free] = "schedule"  # NaN: never free (as np.where's comparison)
    return lim


def _limiting(ctx: _Ctx, sch: Schedule) -> tuple[NDArray[np.str_], FloatArray]:
    # rpm_min / rpm_max only limit when the schedule sits on them *and* wants to move
    power = ctx.cons.power_W_at(max(sch.depth_m, 1e-300), sch.rpm)
    return limiting_labels(limit_slacks(ctx.cons, sch.rpm, sch.depth_m, sch.a_lim_m, power)), power


# ------------------------------------------------------------------- API
def optimize_schedule(
    lobes: LobeTable,
    geom: PathGeometry,
    cons: Constraints,
    *,
    programmed_rpm: ArrayLike | None = None,
    labels: Sequence[str] | None = None,
    max_blocks: int = 200,
    n_depth: int = 48,
    refine: bool = True,
) -> PlanOutcome:
    """Plan the speed schedule and depth for one path.

    Parameters
    ----------
    lobes : LobeTable
        Stability limits of the cutting waypoints (robust bounds already
        applied when planning robustly).
    geom : PathGeometry
        Cutting lengths and rapid time.
    cons : Constraints
        Process limits.
    programmed_rpm : array_like, shape (n_cut,), optional
        The programmed speeds (NaN where none); a baseline only.
    labels : sequence of str, optional
        ``file:line`` of each cutting waypoint, for messages.
    max_blocks : int
        Knots of the schedule (blocks of the global search).
    n_depth : int
        Depth levels of the global search.
    refine : bool
        Run the casadi/IPOPT refinement (where it can improve on the search).

    Returns
    -------
    PlanOutcome

    Raises
    ------
    InfeasibleError
        When no verified plan exists; the message says where and why.
    """
    t0 = time.perf_counter()
    if lobes.n_cut == 0:
        raise InfeasibleError("the path has no cutting move")
    if geom.seg_m.size != lobes.n_cut:
        raise InputError(f"geom: expected {lobes.n_cut} cutting moves, found {geom.seg_m.size}")
    allowed = (lobes.rpm >= cons.rpm_min * (1 - 1e-12)) & (lobes.rpm <= cons.rpm_hi * (1 + 1e-12))
    ctx = _Ctx(lobes, geom, cons, allowed, labels)
    _prechecks(ctx)
    timings: dict[str, float] = {}
    t = time.perf_counter()
    constant = _constant(ctx)
    timings["constant"] = time.perf_counter() - t
    search: Schedule | None = None
    nlp: Schedule | None = None
    status = "not run"
    if cons.constant_speed:
        status = "not needed (constant speed)"
    else:
        t = time.perf_counter()
        search, blk, why = _search(ctx, max_blocks, n_depth)
        timings["search"] = time.perf_counter() - t
        if search is None:
            status = f"not run: {why}"
        elif refine and search.feasible:
            t = time.perf_counter()
            start = search
            if constant is not None and _score(constant) > _score(search):
                start = constant
            why_not = _refine_cannot_improve(ctx, start)
            if why_not:
                status = f"not needed: {why_not}"
            else:
                try:
                    nlp, status = _refine(ctx, blk, start)
                except RuntimeError as exc:  # casadi/IPOPT failures
                    nlp, status = None, f"failed: {exc}"
            timings["refine"] = time.perf_counter() - t
    cands = [c for c in (nlp, search, constant) if c is not None and c.feasible]
    if not cands:
        reasons = [c.reason for c in (search, constant) if c is not None and c.reason]
        if constant is None:
            used = np.unique(lobes.group)
            env = lobes.a_lim[used].min(axis=0) / cons.safety_factor
            j = int(np.argmax(np.where(allowed, env, -np.inf)))
            worst = int(np.argmin(lobes.a_lim[lobes.group, j]))
            reasons.append(
                f"no single speed is stable everywhere: at the best one, {lobes.rpm[j]:.0f} rpm, "
                f"{ctx.where(worst)} allows only "
                f"{lobes.a_lim[lobes.group[worst], j] / cons.safety_factor * 1e3:.3g} mm"
            )
        raise InfeasibleError("no feasible plan: " + "; ".join(reasons or ["unknown"]))
    best = max(cands, key=_score)
    programmed = None
    if programmed_rpm is not None:
        p = np.asarray(programmed_rpm, dtype=np.float64)
        if p.shape == (lobes.n_cut,) and np.any(np.isfinite(p)):
            p = _fill(p)
            programmed = _verify(ctx, "programmed", p, cons.depth_cap_m, check_rate=False)
    limiting, power = _limiting(ctx, best)
    timings["total"] = time.perf_counter() - t0
    return PlanOutcome(
        best=best,
        constant=constant if constant is not None and constant.feasible else None,
        programmed=programmed,
        search=search,
        nlp=nlp,
        nlp_status=status,
        limiting=limiting,
        power_W=power,
        timings=timings,
    )


def _fill(p: FloatArray) -> FloatArray:
    """Carry programmed speeds forward (then backward) over gaps."""
    idx = np.where(np.isfinite(p), np.arange(p.size), -1)
    np.maximum.accumulate(idx, out=idx)
    out = np.where(idx >= 0, p[np.maximum(idx, 0)], np.nan)
    first = int(np.argmax(np.isfinite(out)))
    out[:first] = out[first]
    return out
