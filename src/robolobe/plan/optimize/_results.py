"""Results of the schedule optimization: a verified schedule and the outcome."""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class Schedule:
    """A verified speed schedule and depth (or a baseline that may be infeasible).

    Attributes
    ----------
    method : str
        ``"nlp"``, ``"search"``, ``"constant"`` or ``"programmed"``.
    rpm : ndarray, shape (n_cut,)
        Speed at each cutting waypoint [rpm].
    depth_m : float
        Depth [m] (the largest that passes every check at these speeds).
    a_lim_m : ndarray, shape (n_cut,)
        Exact stability limit at each waypoint's speed [m].
    cut_time_s, cycle_time_s : float
        Time cutting, and in all (with rapids) [s].
    mrr_m3_per_s : float
        Material removal rate while cutting ``a b L / T_cut`` [m^3/s].
    feasible : bool
        Whether every constraint holds with ``depth_m >= depth_min``.
    reason : str
        Why not, when infeasible.
    knots_s_m, knots_rpm : ndarray, shape (n_knots,)
        The piecewise-linear schedule (cutting length [m], speed [rpm]).
    """

    method: str
    rpm: FloatArray
    depth_m: float
    a_lim_m: FloatArray
    cut_time_s: float
    cycle_time_s: float
    mrr_m3_per_s: float
    feasible: bool = True
    reason: str = ""
    knots_s_m: FloatArray = field(default_factory=lambda: np.zeros(0))
    knots_rpm: FloatArray = field(default_factory=lambda: np.zeros(0))

    @property
    def margin(self) -> FloatArray:
        """Stability margin ``a_lim / depth`` at each waypoint (>= safety factor)."""
        return (
            np.asarray(self.a_lim_m / self.depth_m)
            if self.depth_m > 0
            else np.full_like(self.rpm, np.inf)
        )

    @property
    def volume_rate_cm3_per_min(self) -> float:
        """MRR [cm^3/min]."""
        return self.mrr_m3_per_s * 6e7


@dataclass(frozen=True, eq=False)
class PlanOutcome:
    """The chosen schedule, the baselines and diagnostics.

    Attributes
    ----------
    best : Schedule
        The plan (the verified candidate with the highest MRR over the cycle).
    constant : Schedule or None
        Best constant speed (verified), None when no constant speed is feasible.
    programmed : Schedule or None
        The programmed speeds with their largest verified depth (may be
        infeasible), None when the path and the job program no speed.
    search, nlp : Schedule or None
        The global search's and the refinement's verified schedules.
    nlp_status : str
        IPOPT's return status (or why it did not run).
    limiting : ndarray of str, shape (n_cut,)
        The constraint closest to binding at each waypoint under ``best``.
    power_W : ndarray, shape (n_cut,)
        Cutting power under ``best``.
    timings : dict
        Seconds per step.
    """

    best: Schedule
    constant: Schedule | None
    programmed: Schedule | None
    search: Schedule | None
    nlp: Schedule | None
    nlp_status: str
    limiting: NDArray[np.str_]
    power_W: FloatArray
    timings: dict[str, float]
