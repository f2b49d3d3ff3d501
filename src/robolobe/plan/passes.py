"""The program's own depth, planned in even step-down passes.

A program cuts each move at its own depth (the stock above the tool tip
under the engaged edge, :mod:`robolobe.stock`). Where that depth is more
than the stable depth at the planned speed, the move's *section* (a maximal
run of consecutive cutting moves, between rapids: one level of a pocket with
its approach and plunge) is cut in ``n = ceil(a / a_stable)`` even passes of
``a / n``, as CAM systems step down: the section repeated, shifted up the
tool axis by ``a / n`` per pass. A section that cuts material at more than
one height steps down itself (a CAM program's own levels joined by ramps):
shifting it whole would cut a lower level deeper than its pass, so it keeps
one pass and its moves are planned at their own full depth (``fixed``).

The optimizer plans one depth for the whole path; with a depth that differs
per move, the planned depth is the depth of the deepest move per pass and
every other move cuts its share of it (:meth:`LobeTable.per_depth`).
:func:`schedule_passes` tries the pass counts around the continuous optimum
(each at its exact pass depth, the speeds planned again) and keeps the
fastest in cycle time; :func:`section_passes` then gives each section the
fewest passes its own moves need at the planned speeds.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InfeasibleError
from robolobe.plan.optimize import Constraints, PlanOutcome
from robolobe.plan.paths._edit import cut_runs as sections
from robolobe.stock import LEVEL_TOL_M

__all__ = ["ProgramDepth", "program_depth", "schedule_passes", "section_passes", "sections"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: Pass counts tried below and above the continuous optimum's.
PASS_SPAN = 1


@dataclass(frozen=True, eq=False)
class ProgramDepth:
    """Depth of every cutting move of a program and its sections.

    Attributes
    ----------
    depth_m : ndarray, shape (n_cut,)
        Axial depth [m] of each cutting move as programmed (0: air).
    section : ndarray of int, shape (n_cut,)
        Section of each cutting move (consecutive moves at one tip height).
    deepest_m : float
        The largest depth of a move with a lateral limit [m].
    fixed : ndarray of bool, shape (n_cut,)
        Moves of sections that step down themselves: one pass, their own depth.
    """

    depth_m: FloatArray
    section: IntArray
    deepest_m: float
    fixed: NDArray[np.bool_]

    def share(self, passes: int) -> FloatArray:
        """Each move's depth per pass over the planned depth ``deepest_m / passes``.

        At most 1 for moves cut in passes; a ``fixed`` move's full depth
        over it (above 1 where it is deeper than a pass); 0 for air.
        """
        d = np.where(self.fixed, self.depth_m * passes, self.depth_m)
        return np.asarray(d / self.deepest_m)

    @property
    def n_sections(self) -> int:
        """Number of sections."""
        return int(self.section.max()) + 1 if self.section.size else 0

    def section_depth_m(self) -> FloatArray:
        """Deepest move of each section [m], shape (n_sections,)."""
        out = np.zeros(self.n_sections)
        np.maximum.at(out, self.section, self.depth_m)
        return out


def program_depth(
    depth_m: FloatArray, z_m: FloatArray, bounded: NDArray[np.bool_], section: IntArray
) -> ProgramDepth | None:
    """The program's depths and sections; None where no bounded move cuts material.

    Parameters
    ----------
    depth_m : ndarray, shape (n_cut,)
        Axial depth of each cutting move [m] (0 or NaN: air).
    z_m : ndarray, shape (n_cut,)
        Tool-tip height at the end of each cutting move [m].
    bounded : ndarray of bool, shape (n_cut,)
        Moves with a lateral stability limit (not plunges, not air).
    section : ndarray of int, shape (n_cut,)
        Section of each cutting move (:func:`sections`).
    """
    d = np.where(np.isfinite(depth_m) & (depth_m > 0), depth_m, 0.0)
    if not np.any(bounded & (d > 0)):
        return None
    z = np.asarray(z_m, dtype=np.float64)
    sec = np.asarray(section, dtype=np.int64)
    fixed = np.zeros(d.size, bool)
    cuts = d > 0
    for k in np.unique(sec[cuts]):
        zk = z[(sec == k) & cuts]
        if np.ptp(zk) > LEVEL_TOL_M:  # one height as the stock's engagement sees it
            fixed[sec == k] = True
    return ProgramDepth(depth_m=d, section=sec, deepest_m=float(d[bounded].max()), fixed=fixed)


def schedule_passes(
    run: Callable[[Constraints, int, bool], PlanOutcome],
    cons: Constraints,
    deepest_m: float,
    *,
    refine: bool = True,
) -> tuple[PlanOutcome, int, Constraints]:
    """The speed schedule and pass count with the shortest cutting time.

    The pass counts are compared on the global search's schedules; only the
    chosen one is refined (``refine``): the refinement moves speeds within
    their stable pockets, worth a few per cent of cutting time, less than
    one pass changes it.

    Parameters
    ----------
    run : callable
        ``run(constraints, passes, refine) -> PlanOutcome``: the optimizer
        on the table of :meth:`LobeTable.per_depth` with
        :meth:`ProgramDepth.share` of ``passes`` (the depth it plans is the
        deepest move's per pass), with or without its refinement.
    cons : Constraints
        The job's limits (depth bounds per pass).
    deepest_m : float
        The deepest move's programmed depth [m].
    refine : bool
        Refine the chosen schedule.

    Returns
    -------
    outcome : PlanOutcome
        Planned at the chosen pass depth ``deepest_m / passes`` (fixed).
    passes : int
    constraints : Constraints
        ``cons`` with the depth fixed at that pass depth.

    Raises
    ------
    InfeasibleError
        When no pass depth down to the job's ``depth_min`` is stable.
    """
    p_lo = max(1, math.ceil(deepest_m / cons.depth_cap_m - 1e-9))
    d_hi = deepest_m / p_lo
    free = dataclasses.replace(cons, depth_min_m=min(cons.depth_min_m, d_hi), depth_max_m=d_hi)
    first = run(free, p_lo, False)
    p0 = max(p_lo, math.ceil(deepest_m / first.best.depth_m - 1e-9))
    # with ``refine`` refined again below: not kept (a million waypoints: ~100 MB an outcome)
    unrefined = None if refine else first
    del first
    best: tuple[float, int, PlanOutcome | None, Constraints] | None = None
    for p in range(max(p_lo, p0 - PASS_SPAN), p0 + PASS_SPAN + 1):
        d = deepest_m / p
        fixed = dataclasses.replace(cons, depth_min_m=d, depth_max_m=d)
        try:
            out = run(fixed, p, False)
        except InfeasibleError:
            continue
        t = p * out.best.cut_time_s
        # with ``refine`` only the pass count is kept: its schedule is made again, refined
        if best is None or t < best[0] * (1 - 1e-9):
            best = (t, p, None if refine else out, fixed)
        del out  # not alive under the next count's run
    if best is None:  # the optimum's own speeds at its depth rounded down to passes
        d = deepest_m / p0
        # (not the same search twice)
        last = run(free, p_lo, True) if unrefined is None else unrefined
        return last, p0, dataclasses.replace(cons, depth_min_m=d, depth_max_m=d)
    _, p, kept, fixed = best
    return (run(fixed, p, True) if kept is None else kept), p, fixed


def section_passes(
    pd_: ProgramDepth,
    a_lim_m: FloatArray,
    bounded: NDArray[np.bool_],
    safety_factor: float,
    depth_cap_m: float,
) -> tuple[IntArray, IntArray]:
    """The fewest passes each section needs at the planned speeds.

    Parameters
    ----------
    pd_ : ProgramDepth
    a_lim_m : ndarray, shape (n_cut,)
        Each move's stability limit at its planned speed [m].
    bounded : ndarray of bool, shape (n_cut,)
        Moves with a lateral limit.
    safety_factor : float
    depth_cap_m : float
        Largest depth per pass (job and torque) [m].

    Returns
    -------
    passes : ndarray of int, shape (n_sections,)
    set_by : ndarray of int, shape (n_sections,)
        The cutting move (index into the cutting moves) that needs the most
        passes in each section (-1: none limits it).
    """
    d = pd_.depth_m
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(
            bounded & (d > 0) & ~pd_.fixed, np.ceil(d * safety_factor / a_lim_m - 1e-9), 1.0
        )
    need = np.maximum(np.nan_to_num(need, nan=1.0, posinf=1.0), 1.0).astype(np.int64)
    ns = pd_.n_sections
    passes = np.ones(ns, np.int64)
    np.maximum.at(passes, pd_.section, need)
    cap = np.maximum(np.ceil(pd_.section_depth_m() / depth_cap_m - 1e-9), 1).astype(np.int64)
    passes = np.maximum(passes, cap)
    fixed_s = np.zeros(ns, bool)
    fixed_s[pd_.section[pd_.fixed]] = True
    passes[fixed_s] = 1
    set_by = np.full(ns, -1, np.int64)
    order = np.lexsort((-(d * safety_factor / np.where(bounded, a_lim_m, np.inf)), pd_.section))
    first = np.r_[True, np.diff(pd_.section[order]) != 0]
    lead = order[first]
    lim = bounded[lead] & (d[lead] > 0)
    set_by[pd_.section[lead[lim]]] = lead[lim]
    return passes, set_by
