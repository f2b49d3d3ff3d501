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
def _limiting(ctx: _Ctx, sch: Schedule) -> tuple[NDArray[np.str_], FloatArray]:
    cons = ctx.cons
    n = sch.rpm
    a = max(sch.depth_m, 1e-300)
    power = cons.power_W_at(a, n)
    slack = {
        "stability": sch.a_lim_m / (cons.safety_factor * a) - 1.0,
        "power": cons.power_W / np.maximum(power, 1e-300) - 1.0,
        "torque": np.full(n.size, cons.torque_Nm / cons.torque_Nm_at(a) - 1.0),
        "depth_max": np.full(n.size, cons.depth_max_m / a - 1.0),
        "rpm_min": n / cons.rpm_min - 1.0,
        "rpm_max" if cons.rpm_hi >= cons.rpm_max else "feed_max": cons.rpm_hi / n - 1.0,
    }
    names = list(slack)
    mat = np.stack([slack[k] for k in names])
    # rpm_min / rpm_max only limit when the schedule sits on them *and* wants to move
    lim = np.asarray(names)[np.argmin(mat, axis=0)]
    return lim, power


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
