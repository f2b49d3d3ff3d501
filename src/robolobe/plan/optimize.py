"""Spindle speed schedule and depth along a path: global search, casadi refinement, verification.

The decision is one axial depth ``a`` for the whole path (one depth per
pass) and a spindle speed ``n(s)`` along the cutting length ``s``,
piecewise linear between knots (one knot per block of the path). The
objective is the material removal rate over the cycle,
``a * b * L_cut / (T_cut(n) + T_rapid)``, with the feed rate tied to the
speed by the feed per tooth (``v_f = f_z N n / 60``). Constraints at every
cutting waypoint ``i``:

- stability: ``a * SF <= a_lim_i(n_i)`` (``SF`` the safety factor);
- power: ``Kt a b f_z N n_i / 60 <= P_max`` (specific cutting energy ~ Kt);
- torque: ``Kt a b f_z N / (2 pi) <= T_max`` (independent of the speed);
- range: ``rpm_min <= n_i <= min(rpm_max, 60 v_f,max / (f_z N))``;
- rate: ``|dn/ds| <= r_mm`` or ``|dn/dt| <= r_s`` along the cutting length
  (rapids in between are not credited); or one speed for all (``constant``).

Three stages (REFERENCES.md section 5):

1. **Global search.** A dynamic program over blocks of the path x the speed
   grid, vectorised over a ladder of depths (sliding-window minima by a
   sparse table, so a rate limit costs O(1) per state), finds the fastest
   feasible speed sequence for each depth and the depth with the best MRR.
2. **Refinement.** casadi/IPOPT moves the knot speeds and the depth within
   the stable pockets the search found, with the lobe boundary of every
   constrained waypoint as its cubic B-spline interpolant on the speed grid
   (exact Hessians; ``expand=False`` is not needed because the B-spline
   pieces are written out as SX polynomials; ``nlp_scaling_method=none``,
   started from the search's answer). Waypoints enter the NLP when their
   margin is small (constraint generation: violated ones are added and the
   NLP solved again). Bounded by iterations and rounds (not time: the
   result does not depend on the load), and skipped where it cannot improve
   on its start to first order (:func:`_refine_cannot_improve`; the outcome's
   ``nlp_status`` then says why).
3. **Verification.** Every candidate (refined, searched, best constant
   speed) is checked against the exact lobe boundary at every waypoint
   (:attr:`LobeTable.exact`); its depth becomes the largest one that passes
   every constraint there. Only verified schedules are returned; the best one
   is the plan.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import make_interp_spline

from robolobe.errors import InfeasibleError, InputError

__all__ = [
    "Constraints",
    "LobeTable",
    "PathGeometry",
    "PlanOutcome",
    "Schedule",
    "optimize_schedule",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


# ---------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Constraints:
    """Process limits in SI units.

    Parameters
    ----------
    teeth : int
        Number of flutes N.
    feed_per_tooth_m : float
        f_z [m].
    width_m : float
        Radial width of cut b [m].
    kt_N_per_m2 : float
        Tangential cutting coefficient [N/m^2] (power and torque).
    power_W, torque_Nm : float
        Spindle power [W] and torque [N m] limits.
    rpm_min, rpm_max : float
        Speed range [rpm].
    depth_min_m, depth_max_m : float
        Bounds on the depth [m].
    safety_factor : float
        ``a <= a_lim / safety_factor``.
    max_feed_m_per_s : float or None
        Cap on the feed rate [m/s].
    max_rate_rpm_per_s, max_rate_rpm_per_m : float or None
        Rate limits of the speed [rpm/s] or [rpm/m] (at most one).
    constant_speed : bool
        One speed for the whole path.
    """

    teeth: int
    feed_per_tooth_m: float
    width_m: float
    kt_N_per_m2: float
    power_W: float
    torque_Nm: float
    rpm_min: float
    rpm_max: float
    depth_min_m: float
    depth_max_m: float
    safety_factor: float = 1.0
    max_feed_m_per_s: float | None = None
    max_rate_rpm_per_s: float | None = None
    max_rate_rpm_per_m: float | None = None
    constant_speed: bool = False

    def __post_init__(self) -> None:
        for name in ("feed_per_tooth_m", "width_m", "kt_N_per_m2", "power_W", "torque_Nm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{name}: expected a positive number, found {v!r}")
        if not 0 < self.rpm_min < self.rpm_max:
            raise InputError(
                f"expected 0 < rpm_min < rpm_max, found {self.rpm_min}, {self.rpm_max}"
            )
        if not 0 < self.depth_min_m <= self.depth_max_m:
            raise InputError(
                f"expected 0 < depth_min <= depth_max, found {self.depth_min_m}, {self.depth_max_m}"
            )
        if self.safety_factor < 1:
            raise InputError(f"safety_factor: expected >= 1, found {self.safety_factor}")
        if self.max_rate_rpm_per_s is not None and self.max_rate_rpm_per_m is not None:
            raise InputError("give max_rate_rpm_per_s or max_rate_rpm_per_m, not both")

    @property
    def feed_per_rev_m(self) -> float:
        """``f_z N`` [m/rev]: feed rate [m/s] = this x rpm / 60."""
        return self.feed_per_tooth_m * self.teeth

    @property
    def rpm_hi(self) -> float:
        """Highest usable speed [rpm]: spindle range and feed cap."""
        hi = self.rpm_max
        if self.max_feed_m_per_s is not None:
            hi = min(hi, self.max_feed_m_per_s * 60.0 / self.feed_per_rev_m)
        return hi

    @property
    def depth_cap_m(self) -> float:
        """Largest depth [m] allowed by ``depth_max`` and the torque limit."""
        return min(self.depth_max_m, self.torque_depth_m)

    @property
    def torque_depth_m(self) -> float:
        """Depth [m] at which the cutting torque reaches the limit."""
        return self.torque_Nm * _TWO_PI / (self.kt_N_per_m2 * self.width_m * self.feed_per_rev_m)

    @property
    def power_product(self) -> float:
        """``a * n`` [m rpm] at which the cutting power reaches the limit."""
        return self.power_W * 60.0 / (self.kt_N_per_m2 * self.width_m * self.feed_per_rev_m)

    def power_W_at(self, depth_m: float, rpm: ArrayLike) -> FloatArray:
        """Cutting power [W] at a depth [m] and speeds [rpm]."""
        n = np.asarray(rpm, dtype=np.float64)
        return np.asarray(
            self.kt_N_per_m2 * depth_m * self.width_m * self.feed_per_rev_m * n / 60.0
        )

    def torque_Nm_at(self, depth_m: float) -> float:
        """Cutting torque [N m] at a depth [m]."""
        return self.kt_N_per_m2 * depth_m * self.width_m * self.feed_per_rev_m / _TWO_PI


@dataclass(frozen=True, eq=False)
class LobeTable:
    """Stability limits of the cutting waypoints on a speed grid, plus the exact boundary.

    Waypoints with the same dynamics share a row (``group``).

    Parameters
    ----------
    rpm : ndarray, shape (n_rpm,)
        Increasing speed grid [rpm].
    a_lim : ndarray, shape (n_groups, n_rpm)
        Limiting depth [m] on the grid (``inf``: no lobe there).
    group : ndarray of int, shape (n_cut,)
        Row of each cutting waypoint.
    exact : callable, optional
        ``exact(rpm_rows, groups) -> a_lim``: the exact boundary [m] of the
        groups ``groups`` (g,) at the speeds ``rpm_rows`` (g, m) [rpm], shape
        (g, m) (e.g. the lobe polylines of :mod:`robolobe.sld.lobes`). Without
        it the grid is interpolated linearly (then "exact" means "on the grid").
    """

    rpm: FloatArray
    a_lim: FloatArray
    group: IntArray
    exact: Callable[[FloatArray, IntArray], FloatArray] | None = None

    def __post_init__(self) -> None:
        r = np.asarray(self.rpm, dtype=np.float64)
        a = np.asarray(self.a_lim, dtype=np.float64)
        g = np.asarray(self.group, dtype=np.int64)
        if r.ndim != 1 or r.size < 4 or np.any(np.diff(r) <= 0):
            raise InputError("rpm: expected an increasing grid of at least 4 speeds")
        if a.ndim != 2 or a.shape[1] != r.size:
            raise InputError(f"a_lim: expected shape (n_groups, {r.size}), found {a.shape}")
        if g.ndim != 1 or (g.size and (g.min() < 0 or g.max() >= a.shape[0])):
            raise InputError("group: expected row indices into a_lim")
        if np.any(np.isnan(a)) or np.any(a <= 0):
            raise InputError("a_lim: expected positive limits (inf where unbounded), found NaN/<=0")
        object.__setattr__(self, "rpm", r)
        object.__setattr__(self, "a_lim", a)
        object.__setattr__(self, "group", g)

    @property
    def n_cut(self) -> int:
        """Number of cutting waypoints."""
        return int(self.group.size)

    def rows(self, rows: ArrayLike, groups: ArrayLike) -> FloatArray:
        """Exact limits [m] of ``groups`` (g,) at speeds ``rows`` (g, m) [rpm]."""
        r = np.asarray(rows, dtype=np.float64)
        g = np.asarray(groups, dtype=np.int64)
        if g.size == 0:
            return np.zeros(r.shape)
        if self.exact is not None:
            out = np.asarray(self.exact(r, g), dtype=np.float64)
            if out.shape != r.shape:
                raise InputError(f"exact: expected shape {r.shape}, found {out.shape}")
            return out
        out = np.empty_like(r)
        for k, gi in enumerate(g):  # fallback only (tests, tables without lobes)
            out[k] = np.interp(r[k], self.rpm, self.a_lim[gi])
        return out

    def query_groups(self, rpm: ArrayLike, groups: ArrayLike) -> FloatArray:
        """Exact limits of some groups at shared speeds.

        Parameters
        ----------
        rpm : array_like, shape (m,)
        groups : array_like of int, shape (g,)

        Returns
        -------
        ndarray, shape (g, m) [m]
        """
        r = np.atleast_1d(np.asarray(rpm, dtype=np.float64))
        g = np.asarray(groups, dtype=np.int64)
        return self.rows(np.broadcast_to(r, (g.size, r.size)).copy(), g)

    def query_shared(self, rpm: ArrayLike) -> FloatArray:
        """Exact limits of every cutting waypoint at shared speeds.

        Parameters
        ----------
        rpm : array_like, shape (m,)

        Returns
        -------
        ndarray, shape (n_cut, m) [m]
        """
        r = np.atleast_1d(np.asarray(rpm, dtype=np.float64))
        used = np.unique(self.group)
        vals = np.full((self.a_lim.shape[0], r.size), np.inf)
        vals[used] = self.query_groups(r, used)
        return vals[self.group]

    def query(self, rpm: ArrayLike) -> FloatArray:
        """Exact limit of each cutting waypoint at its own speed.

        Parameters
        ----------
        rpm : array_like, shape (n_cut,)

        Returns
        -------
        ndarray, shape (n_cut,) [m]
        """
        r = np.asarray(rpm, dtype=np.float64)
        if r.shape != self.group.shape:
            raise InputError(f"rpm: expected shape {self.group.shape}, found {r.shape}")
        if r.size == 0:
            return np.zeros(0)
        # unique (group, speed) pairs, one padded row per group
        key = np.stack([self.group.astype(np.float64), r], axis=1)
        uniq, inv = np.unique(key, axis=0, return_inverse=True)
        inv = np.asarray(inv).ravel()
        g = uniq[:, 0].astype(np.int64)
        used, slot = np.unique(g, return_inverse=True)
        counts = np.bincount(slot)
        m = int(counts.max())
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        pos = np.arange(len(uniq)) - start[slot]
        rows = np.empty((used.size, m))
        rows[:] = uniq[start, 1][:, None]  # pad with the group's first speed
        rows[slot, pos] = uniq[:, 1]
        vals = self.rows(rows, used)
        return vals[slot, pos][inv]


@dataclass(frozen=True, eq=False)
class PathGeometry:
    """Where the cutting waypoints are along the path.

    Parameters
    ----------
    seg_m : ndarray, shape (n_cut,)
        Length [m] of the cutting move that ends at each cutting waypoint.
    rapid_time_s : float
        Time [s] of all other moves (independent of the speed).
    """

    seg_m: FloatArray
    rapid_time_s: float = 0.0

    def __post_init__(self) -> None:
        s = np.asarray(self.seg_m, dtype=np.float64)
        if s.ndim != 1 or np.any(~np.isfinite(s)) or np.any(s < 0):
            raise InputError("seg_m: expected finite non-negative lengths")
        object.__setattr__(self, "seg_m", s)

    @property
    def s_m(self) -> FloatArray:
        """Cumulative cutting length [m] at each cutting waypoint, shape (n_cut,)."""
        return np.cumsum(self.seg_m)

    @property
    def length_m(self) -> float:
        """Total cutting length [m]."""
        return float(self.seg_m.sum())


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


# ------------------------------------------------------------ helpers
def _window_min(v: FloatArray, lo: IntArray, hi: IntArray) -> FloatArray:
    """``out[..., j] = min(v[..., lo[j]:hi[j] + 1])`` by a sparse table (O(J log J) build)."""
    nj = v.shape[-1]
    if np.all(lo == 0) and np.all(hi == nj - 1):
        return np.broadcast_to(v.min(axis=-1, keepdims=True), v.shape).copy()
    length = hi - lo + 1
    top = int(np.floor(np.log2(max(int(length.max()), 1))))
    table = [v]
    k = 1
    for _ in range(top):
        prev = table[-1]
        nxt = np.full_like(prev, np.inf)
        nxt[..., : nj - k] = np.minimum(prev[..., : nj - k], prev[..., k:])
        table.append(nxt)
        k *= 2
    t = np.stack(table)  # (L, ..., J)
    lev = np.floor(np.log2(length)).astype(np.int64)
    a = t[lev, ..., lo]  # (J, ...)
    b = t[lev, ..., hi - (1 << lev) + 1]
    out = np.minimum(a, b)
    return np.moveaxis(out, 0, -1)


def _rate_windows(rpm: FloatArray, dist_m: float, cons: Constraints) -> tuple[IntArray, IntArray]:
    """Grid index range of speeds that may precede each speed over ``dist_m`` of cutting."""
    nj = rpm.size
    if cons.constant_speed:
        idx = np.arange(nj)
        return idx, idx
    if cons.max_rate_rpm_per_m is not None:
        d = cons.max_rate_rpm_per_m * dist_m
        lo_v, hi_v = rpm - d, rpm + d
    elif cons.max_rate_rpm_per_s is not None:
        r2 = cons.max_rate_rpm_per_s * dist_m * 60.0 / cons.feed_per_rev_m  # rpm^2
        lo_v = rpm - r2 / rpm
        hi_v = 0.5 * (rpm + np.sqrt(rpm * rpm + 4.0 * r2))
    else:
        return np.zeros(nj, np.int64), np.full(nj, nj - 1, np.int64)
    tol = 1e-9 * rpm.max()
    lo = np.searchsorted(rpm, lo_v - tol, side="left").astype(np.int64)
    hi = (np.searchsorted(rpm, hi_v + tol, side="right") - 1).astype(np.int64)
    idx = np.arange(nj)
    return np.minimum(lo, idx), np.maximum(hi, idx)


def _rate_fix(u: FloatArray, dist: FloatArray, cons: Constraints) -> FloatArray:
    """Lower knot speeds until every knot-to-knot change meets the rate limit."""
    u = u.copy()
    if cons.constant_speed:
        return np.full_like(u, u.min())
    if cons.max_rate_rpm_per_m is None and cons.max_rate_rpm_per_s is None:
        return u

    def up_limit(base: float, d: float) -> float:
        if cons.max_rate_rpm_per_m is not None:
            return base + cons.max_rate_rpm_per_m * d
        r2 = float(cons.max_rate_rpm_per_s) * d * 60.0 / cons.feed_per_rev_m  # type: ignore[arg-type]
        return 0.5 * (base + math.sqrt(base * base + 4.0 * r2))

    for k in range(1, u.size):  # rises
        u[k] = min(u[k], up_limit(u[k - 1], dist[k - 1]))
    for k in range(u.size - 2, -1, -1):  # falls
        u[k] = min(u[k], up_limit(u[k + 1], dist[k]))
    return u


def _rate_ok(u: FloatArray, dist: FloatArray, cons: Constraints, rtol: float = 1e-6) -> bool:
    if u.size < 2:
        return True
    if cons.constant_speed:
        return bool(np.ptp(u) <= rtol * u.max())
    if cons.max_rate_rpm_per_m is None and cons.max_rate_rpm_per_s is None:
        return True
    du = np.abs(np.diff(u))
    if cons.max_rate_rpm_per_m is not None:
        lim = cons.max_rate_rpm_per_m * dist
        return bool(np.all(du <= lim * (1 + rtol) + 1e-9))
    r2 = float(cons.max_rate_rpm_per_s) * dist * 60.0 / cons.feed_per_rev_m  # type: ignore[arg-type]
    top = np.maximum(u[1:], u[:-1])
    return bool(np.all(du * top <= r2 * (1 + rtol) + 1e-9))


def _interp_matrix(s: FloatArray, knots: FloatArray) -> tuple[IntArray, FloatArray]:
    """Left knot index and weight of the right knot for each ``s`` (flat outside)."""
    if knots.size == 1:
        return np.zeros(s.size, np.int64), np.zeros(s.size)
    k = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, knots.size - 2)
    span = knots[k + 1] - knots[k]
    w = np.clip(np.divide(s - knots[k], span, out=np.zeros_like(s), where=span > 0), 0.0, 1.0)
    return k.astype(np.int64), w


@dataclass
class _Ctx:
    lobes: LobeTable
    geom: PathGeometry
    cons: Constraints
    allowed: NDArray[np.bool_]
    labels: Sequence[str] | None

    def where(self, i: int) -> str:
        if self.labels is not None and 0 <= i < len(self.labels):
            return f"waypoint {i} ({self.labels[i]})"
        return f"waypoint {i}"


def _times(ctx: _Ctx, rpm: FloatArray) -> tuple[float, float]:
    c = ctx.cons.feed_per_rev_m
    cut = float(np.sum(ctx.geom.seg_m * 60.0 / (c * rpm)))
    return cut, cut + ctx.geom.rapid_time_s


def _verify(
    ctx: _Ctx,
    method: str,
    rpm: FloatArray,
    depth_hint: float,
    knots_s: FloatArray | None = None,
    knots_rpm: FloatArray | None = None,
    *,
    check_rate: bool = True,
) -> Schedule:
    """Largest depth <= depth_hint that passes every check at ``rpm`` (exact lobes)."""
    cons = ctx.cons
    a_ex = ctx.lobes.query(rpm)
    sf = cons.safety_factor
    caps = [depth_hint, cons.depth_cap_m, cons.power_product / float(rpm.max())]
    depth = float(min(min(caps), float(np.min(a_ex)) / sf))
    reasons = []
    lo_ok = bool(np.all(rpm >= cons.rpm_min * (1 - 1e-9)))
    hi_ok = bool(np.all(rpm <= cons.rpm_hi * (1 + 1e-9)))
    if not lo_ok:
        reasons.append(f"speed below rpm_min at {ctx.where(int(np.argmin(rpm)))}")
    if not hi_ok:
        reasons.append(f"speed above the usable maximum at {ctx.where(int(np.argmax(rpm)))}")
    if (
        check_rate
        and knots_rpm is not None
        and knots_s is not None
        and not _rate_ok(knots_rpm, np.diff(knots_s), cons)
    ):
        reasons.append("speed changes faster than the rate limit")
    if depth < cons.depth_min_m * (1 - 1e-9):
        i = int(np.argmin(a_ex))
        what = "stability" if np.min(a_ex) / sf <= min(caps) else "power/torque"
        reasons.append(
            f"largest verified depth {depth * 1e3:.3g} mm < depth_min "
            f"{cons.depth_min_m * 1e3:.3g} mm ({what}; tightest at {ctx.where(i)}, "
            f"{rpm[i]:.0f} rpm, a_lim {a_ex[i] * 1e3:.3g} mm)"
        )
    cut, cycle = _times(ctx, rpm)
    vol = max(depth, 0.0) * cons.width_m * ctx.geom.length_m
    return Schedule(
        method=method,
        rpm=np.asarray(rpm, dtype=np.float64),
        depth_m=max(depth, 0.0),
        a_lim_m=a_ex,
        cut_time_s=cut,
        cycle_time_s=cycle,
        mrr_m3_per_s=vol / cut if cut > 0 else 0.0,
        feasible=not reasons,
        reason="; ".join(reasons),
        knots_s_m=np.zeros(0) if knots_s is None else np.asarray(knots_s, dtype=np.float64),
        knots_rpm=np.zeros(0) if knots_rpm is None else np.asarray(knots_rpm, dtype=np.float64),
    )


def _score(sch: Schedule | None) -> float:
    """Volume per cycle time (the objective), -inf when infeasible."""
    if sch is None or not sch.feasible or sch.cycle_time_s <= 0:
        return -math.inf
    return sch.depth_m / sch.cycle_time_s


# ----------------------------------------------------------- stages
def _prechecks(ctx: _Ctx) -> None:
    cons, lobes = ctx.cons, ctx.lobes
    if cons.torque_depth_m < cons.depth_min_m:
        raise InfeasibleError(
            f"torque: depth_min {cons.depth_min_m * 1e3:.3g} mm needs "
            f"{cons.torque_Nm_at(cons.depth_min_m):.3g} N m > torque limit "
            f"{cons.torque_Nm:.3g} N m "
            "(lower the width, the feed per tooth or depth_min)"
        )
    if cons.rpm_hi < cons.rpm_min:
        raise InfeasibleError(
            f"feed: the feed cap allows at most {cons.rpm_hi:.0f} rpm < rpm_min {cons.rpm_min:.0f}"
        )
    if not np.any(ctx.allowed):
        raise InfeasibleError(
            f"speed: no grid speed within [{cons.rpm_min:.0f}, {cons.rpm_hi:.0f}] rpm"
        )
    if cons.depth_min_m * cons.rpm_min > cons.power_product:
        p = float(cons.power_W_at(cons.depth_min_m, cons.rpm_min))
        raise InfeasibleError(
            f"power: depth_min {cons.depth_min_m * 1e3:.3g} mm at rpm_min {cons.rpm_min:.0f} needs "
            f"{p / 1e3:.3g} kW > {cons.power_W / 1e3:.3g} kW"
        )
    # each waypoint alone, at its best allowed speed (power at depth_min)
    ok_speed = ctx.allowed & (cons.depth_min_m * lobes.rpm <= cons.power_product)
    best = np.where(ok_speed, lobes.a_lim, 0.0).max(axis=1) / cons.safety_factor
    per_wp = best[lobes.group]
    if np.any(per_wp < cons.depth_min_m):
        i = int(np.argmin(per_wp))
        raise InfeasibleError(
            f"stability: at {ctx.where(i)} the largest stable depth over "
            f"{cons.rpm_min:.0f}-{cons.rpm_hi:.0f} rpm is {per_wp[i] * 1e3:.3g} mm with safety "
            f"factor {cons.safety_factor:g}, below depth_min {cons.depth_min_m * 1e3:.3g} mm"
        )


def _constant(ctx: _Ctx) -> Schedule | None:
    """Best single speed: grid scan, then zoom on the best pockets with the exact boundary."""
    cons, lobes = ctx.cons, ctx.lobes
    used = np.unique(lobes.group)
    rpm = lobes.rpm
    env = lobes.a_lim[used].min(axis=0) / cons.safety_factor
    a = np.minimum(np.minimum(env, cons.depth_cap_m), cons.power_product / rpm)
    cut = ctx.geom.length_m * 60.0 / (cons.feed_per_rev_m * rpm)
    score = np.where(
        ctx.allowed & (a >= cons.depth_min_m), a / (cut + ctx.geom.rapid_time_s), -np.inf
    )
    if not np.any(np.isfinite(score)):
        return None
    order = np.argsort(-score)
    cands = [int(j) for j in order[:3] if np.isfinite(score[j])]

    def envelope(trial: FloatArray) -> FloatArray:
        # exact minimum over the groups that could be the minimum near these speeds
        # (within 1.5x of the grid minimum at the neighbouring grid speeds); the
        # final verification checks every waypoint anyway
        j0 = np.clip(np.searchsorted(rpm, trial) - 1, 0, rpm.size - 2)
        near = np.minimum(lobes.a_lim[used][:, j0], lobes.a_lim[used][:, j0 + 1])
        cand = used[np.any(near <= 1.5 * near.min(axis=0, keepdims=True), axis=1)]
        return lobes.query_groups(trial, cand).min(axis=0)

    lo_all, hi_all = cons.rpm_min, cons.rpm_hi
    speeds = []
    for j in cands:
        lo = rpm[max(j - 1, 0)]
        hi = rpm[min(j + 1, rpm.size - 1)]
        speeds.append(np.linspace(max(lo, lo_all), min(hi, hi_all), 17))
    trial = np.unique(np.concatenate(speeds))
    for _ in range(2):  # zoom twice on the best exact speed
        vals = envelope(trial) / cons.safety_factor
        a_t = np.minimum(np.minimum(vals, cons.depth_cap_m), cons.power_product / trial)
        t_t = ctx.geom.length_m * 60.0 / (cons.feed_per_rev_m * trial) + ctx.geom.rapid_time_s
        s_t = np.where(a_t >= cons.depth_min_m, a_t / t_t, -np.inf)
        k = int(np.argmax(s_t))
        step = (trial[min(k + 1, trial.size - 1)] - trial[max(k - 1, 0)]) / 2
        centre = trial[k]
        trial = np.unique(
            np.concatenate(
                [[centre], np.linspace(max(centre - step, lo_all), min(centre + step, hi_all), 9)]
            )
        )
    vals = envelope(trial) / cons.safety_factor
    a_t = np.minimum(np.minimum(vals, cons.depth_cap_m), cons.power_product / trial)
    t_t = ctx.geom.length_m * 60.0 / (cons.feed_per_rev_m * trial) + ctx.geom.rapid_time_s
    s_t = np.where(a_t >= cons.depth_min_m, a_t / t_t, -np.inf)
    if not np.any(np.isfinite(s_t)):
        n_best = float(rpm[cands[0]])
    else:
        n_best = float(trial[int(np.argmax(s_t))])
    n = np.full(lobes.n_cut, n_best)
    s = ctx.geom.s_m
    knots_s = np.array([s[0], s[-1]]) if s.size else np.zeros(0)
    return _verify(ctx, "constant", n, cons.depth_cap_m, knots_s, np.full(knots_s.size, n_best))


@dataclass
class _Blocks:
    start: IntArray  # first cutting waypoint of each block
    knots_s: FloatArray  # block centres [m] (knots of ramped schedules)
    length: FloatArray  # cutting length per block [m]
    a_blk: FloatArray  # (K, J) block minimum of a_lim [m]
    edge_s: FloatArray  # knots at the first and last waypoint of each block [m]
    edge_block: IntArray  # block of each edge knot


def _blocks(ctx: _Ctx, n_blocks: int) -> _Blocks:
    s = ctx.geom.s_m
    n = s.size
    total = float(s[-1]) if n else 0.0
    if total <= 0 or n_blocks <= 1:
        bid = np.zeros(n, np.int64)
    else:
        edges = np.linspace(0.0, total, n_blocks + 1)
        bid = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, n_blocks - 1)
    start = np.flatnonzero(np.r_[True, np.diff(bid) != 0]).astype(np.int64)
    end = np.r_[start[1:], n] - 1
    # knot at the middle of the block's span of cutting length
    knots = 0.5 * (np.r_[0.0, s][start] + s[end])
    length = np.add.reduceat(ctx.geom.seg_m, start)
    a_blk = _block_min(ctx.lobes.a_lim, ctx.lobes.group, start)
    # strictly increasing knots (blocks of zero length share a position)
    knots = np.maximum.accumulate(knots)
    bump = np.arange(knots.size) * 1e-12 * max(total, 1.0)
    # edge knots: a block holds its speed from its first to its last waypoint;
    # the speed may change over the move into the next block's first waypoint
    pos = np.stack([s[start], s[end]], axis=1).ravel()
    blk_of = np.repeat(np.arange(start.size), 2)
    edge_s, first = np.unique(pos, return_index=True)
    return _Blocks(start, knots + bump, length, a_blk, edge_s, blk_of[first].astype(np.int64))


def _block_min(
    a_lim: FloatArray, group: IntArray, start: IntArray, chunk: int = 8192
) -> FloatArray:
    """Per block of consecutive waypoints (first ``start``) the minimum of their grid rows.

    In chunks of waypoints, so that no (n_cut, n_rpm) copy of the grid is formed.
    """
    n = group.size
    out = np.full((start.size, a_lim.shape[1]), np.inf)
    bid = np.repeat(np.arange(start.size), np.diff(np.r_[start, n]))
    for c0 in range(0, n, chunk):
        b = bid[c0 : c0 + chunk]
        st = np.flatnonzero(np.r_[True, b[1:] != b[:-1]])
        part = np.minimum.reduceat(a_lim[group[c0 : c0 + chunk]], st, axis=0)
        out[b[st]] = np.minimum(out[b[st]], part)
    return out


def _search(ctx: _Ctx, max_blocks: int, n_depth: int) -> tuple[Schedule | None, _Blocks, str]:
    """Dynamic program over blocks x speeds, vectorised over a ladder of depths."""
    cons, lobes = ctx.cons, ctx.lobes
    rpm = lobes.rpm
    n_cut = lobes.n_cut
    k_blocks = min(n_cut, max_blocks)
    while True:
        blk = _blocks(ctx, k_blocks)
        kb = blk.start.size
        best_blk = np.where(ctx.allowed, blk.a_blk, 0.0).max(axis=1) / cons.safety_factor
        depth_hi = min(cons.depth_cap_m, float(best_blk.min()))
        if depth_hi >= cons.depth_min_m or kb >= n_cut:
            break
        k_blocks = min(n_cut, 4 * k_blocks)  # blocks too coarse to be feasible at one speed
    if depth_hi < cons.depth_min_m:
        b = int(np.argmin(best_blk))
        return None, blk, f"no single speed is stable over block {b}"
    depths = (
        np.geomspace(cons.depth_min_m, depth_hi, n_depth)
        if depth_hi > cons.depth_min_m
        else np.array([depth_hi])
    )
    c = cons.feed_per_rev_m
    inv_n = 60.0 / (c * rpm)
    dist = np.diff(blk.knots_s)
    sf_d = cons.safety_factor * depths[:, None]
    power_ok = depths[:, None] * rpm[None, :] <= cons.power_product * (1 + 1e-12)
    base_ok = ctx.allowed[None, :] & power_ok

    def cost(b: int, d_sel: slice | int) -> FloatArray:
        feas = (blk.a_blk[b][None, :] >= sf_d[d_sel]) & base_ok[d_sel]
        return np.where(feas, blk.length[b] * inv_n[None, :], np.inf)

    v = cost(0, slice(None))
    windows = [_rate_windows(rpm, float(d), cons) for d in dist]
    for b in range(1, kb):
        lo, hi = windows[b - 1]
        v = cost(b, slice(None)) + _window_min(v, lo, hi)
    total = v.min(axis=1) + ctx.geom.rapid_time_s
    score = np.where(np.isfinite(total), depths / total, -np.inf)
    if not np.any(np.isfinite(score)):
        return None, blk, "the rate limit keeps the speed from reaching a stable pocket"
    d_best = int(np.argmax(score))
    # refine the depth between the neighbouring rungs of the ladder
    lo_d = depths[max(d_best - 1, 0)]
    hi_d = depths[min(d_best + 1, depths.size - 1)]
    if hi_d > lo_d:
        fine = np.linspace(lo_d, hi_d, 17)
        sf_f = cons.safety_factor * fine[:, None]
        ok_f = ctx.allowed[None, :] & (
            fine[:, None] * rpm[None, :] <= cons.power_product * (1 + 1e-12)
        )
        vf = np.where(
            (blk.a_blk[0][None, :] >= sf_f) & ok_f, blk.length[0] * inv_n[None, :], np.inf
        )
        for b in range(1, kb):
            lo, hi = windows[b - 1]
            cb = np.where(
                (blk.a_blk[b][None, :] >= sf_f) & ok_f, blk.length[b] * inv_n[None, :], np.inf
            )
            vf = cb + _window_min(vf, lo, hi)
        tf = vf.min(axis=1) + ctx.geom.rapid_time_s
        sc_f = np.where(np.isfinite(tf), fine / tf, -np.inf)
        if np.max(sc_f) > score[d_best]:
            depths = np.r_[depths, fine]
            sf_d = cons.safety_factor * depths[:, None]
            base_ok = ctx.allowed[None, :] & (
                depths[:, None] * rpm[None, :] <= cons.power_product * (1 + 1e-12)
            )
            d_best = depths.size - fine.size + int(np.argmax(sc_f))
    # second pass at the chosen depth, keeping the values for backtracking
    vals = np.empty((kb, rpm.size))
    vb = cost(0, slice(d_best, d_best + 1))[0]
    vals[0] = vb
    for b in range(1, kb):
        lo, hi = windows[b - 1]
        vb = cost(b, slice(d_best, d_best + 1))[0] + _window_min(vb[None, :], lo, hi)[0]
        vals[b] = vb
    j = np.empty(kb, np.int64)
    j[-1] = int(np.argmin(vals[-1]))
    for b in range(kb - 2, -1, -1):
        lo, hi = windows[b]
        l0, h0 = int(lo[j[b + 1]]), int(hi[j[b + 1]])
        j[b] = l0 + int(np.argmin(vals[b, l0 : h0 + 1]))
    u = rpm[j].astype(np.float64)
    if cons.max_rate_rpm_per_m is None and cons.max_rate_rpm_per_s is None:
        # free changes: hold each block's speed, change between blocks
        ks, uk = blk.edge_s, u[blk.edge_block]
    else:
        ks, uk = blk.knots_s, _rate_fix(u, dist, cons)
    n_wp = _knot_speeds(ctx, ks, uk)
    sch = _verify(ctx, "search", n_wp, float(depths[d_best]), ks, uk)
    return sch, blk, "ok"


def _knot_speeds(ctx: _Ctx, knots_s: FloatArray, u: FloatArray) -> FloatArray:
    k, w = _interp_matrix(ctx.geom.s_m, knots_s)
    if knots_s.size == 1:
        return np.full(ctx.geom.s_m.size, float(u[0]))
    return np.asarray((1 - w) * u[k] + w * u[k + 1])


def _pocket_bounds(
    ctx: _Ctx, a_rows: FloatArray, u: FloatArray, depth: float, reach: int = 3
) -> tuple[FloatArray, FloatArray]:
    """Per knot: the connected speed interval around ``u`` where its block stays near-stable.

    ``a_rows`` (n_knots, n_rpm) is the block minimum of ``a_lim`` for each knot.
    """
    cons = ctx.cons
    rpm = ctx.lobes.rpm
    ok = (a_rows >= 0.6 * cons.safety_factor * depth) & ctx.allowed[None, :]
    j0 = np.clip(np.searchsorted(rpm, u), 0, rpm.size - 1)
    lo = np.empty(u.size)
    hi = np.empty(u.size)
    for k in range(u.size):  # K <= a few hundred; each a short scan
        row = ok[k]
        j = int(j0[k])
        a = j
        while a > 0 and row[a - 1]:
            a -= 1
        b = j
        while b < rpm.size - 1 and row[b + 1]:
            b += 1
        # trust region: the pocket, at most ``reach`` grid steps each way
        lo[k] = rpm[max(a - 1, j - reach, 0)]
        hi[k] = rpm[min(b + 1, j + reach, rpm.size - 1)]
    lo = np.maximum(np.minimum(lo, u), cons.rpm_min)
    hi = np.minimum(np.maximum(hi, u), cons.rpm_hi)
    return lo, np.maximum(hi, lo)


def _sparse_interp(k0: IntArray, k1: IntArray, w: FloatArray, n_knots: int) -> Any:
    """casadi sparse matrix ``W`` with ``(W u)_i = (1 - w_i) u[k0_i] + w_i u[k1_i]``."""
    import casadi as ca
    import scipy.sparse as sps

    rows = np.arange(k0.size)
    mat = sps.coo_matrix(
        (np.r_[1.0 - w, w], (np.r_[rows, rows], np.r_[k0, k1])), shape=(k0.size, n_knots)
    ).tocsc()
    mat.sum_duplicates()
    sp = ca.Sparsity(k0.size, n_knots, mat.indptr.tolist(), mat.indices.tolist())
    return ca.DM(sp, mat.data)


def _refine(
    ctx: _Ctx,
    blk: _Blocks,
    start: Schedule,
    *,
    max_rounds: int = 3,
    max_active: int = 600,
    max_iter: int = 100,
    n_bins: int = 8,
) -> tuple[Schedule | None, str]:
    """casadi/IPOPT refinement of knot speeds and depth, with constraint generation.

    Variables: knot speeds ``u`` [krpm] and the depth ``a`` [mm]. Objective
    ``T_cycle(u) / a`` (the inverse MRR; its Hessian is sparse), with the
    cutting time summed over the waypoints binned by their position between
    two knots (``n_bins`` per interval; the verification uses the exact sum).
    Constraints: the B-spline boundary of each active waypoint,
    ``S_i(n_i) >= SF a``; power ``a u_k <= (a n)_max`` at the knots (which
    bounds every interpolated speed); the rate limit between knots.

    Bounded by IPOPT iterations (``max_iter`` per round) and rounds, not by
    time, so that the result does not depend on the machine or its load.
    """
    import casadi as ca

    cons, lobes = ctx.cons, ctx.lobes
    knots_s = blk.edge_s
    if start.knots_rpm.size >= 2:
        u_start = np.interp(knots_s, start.knots_s_m, start.knots_rpm)
    else:
        u_start = np.full(knots_s.size, float(start.rpm[0]))
    u0 = u_start / 1000.0
    kn = u0.size
    if kn == 0:
        return None, "no knots"
    sf = cons.safety_factor
    c_feed = cons.feed_per_rev_m
    lo_b, hi_b = _pocket_bounds(ctx, blk.a_blk[blk.edge_block], u_start, start.depth_m, reach=2)
    lo_b, hi_b = lo_b / 1000.0, hi_b / 1000.0
    row_of = np.where(np.all(np.isfinite(lobes.a_lim), axis=1), 0, -1)
    k_idx, w = _interp_matrix(ctx.geom.s_m, knots_s)
    if kn == 1:
        k_idx = np.zeros_like(k_idx)
        w = np.zeros_like(w)
    k1 = np.minimum(k_idx + 1, kn - 1)
    n_lo = np.minimum(lo_b[k_idx], lo_b[k1])
    n_hi = np.maximum(hi_b[k_idx], hi_b[k1])

    u = ca.MX.sym("u", kn)
    a = ca.MX.sym("a")
    # objective: cutting time from binned waypoints + rapids, over the depth
    seg = ctx.geom.seg_m
    nz = np.flatnonzero(seg > 0)
    wb = np.round(w[nz] * n_bins).astype(np.int64)
    key = k_idx[nz] * (n_bins + 1) + wb
    uk, inv = np.unique(key, return_inverse=True)
    tw = seg[nz] * 60.0 / (c_feed * 1000.0)  # s krpm
    csum = np.bincount(inv, weights=tw)
    wmean = np.bincount(inv, weights=tw * w[nz]) / np.maximum(csum, 1e-300)
    kb = (uk // (n_bins + 1)).astype(np.int64)
    kb1 = np.minimum(kb + 1, kn - 1)
    wk = _sparse_interp(kb, kb1, wmean, kn)
    n_bin = ca.mtimes(wk, u)
    t_total = ca.sum1(ca.DM(csum) / n_bin) + ctx.geom.rapid_time_s
    obj = t_total / a

    # piecewise-cubic boundary, one mapped SX function for all active waypoints:
    # per group, a cubic interpolant of the exact boundary sampled finely over
    # the speeds its active waypoints may take
    step = float(lobes.rpm[1] - lobes.rpm[0]) / 1000.0
    fine = 3

    def local_splines(idx: list[int]) -> tuple[FloatArray, FloatArray, int]:
        grp = lobes.group[idx]
        ug, ginv = np.unique(grp, return_inverse=True)
        lo_g = np.full(ug.size, np.inf)
        hi_g = np.full(ug.size, -np.inf)
        np.minimum.at(lo_g, ginv, n_lo[idx])
        np.maximum.at(hi_g, ginv, n_hi[idx])
        width = float(np.max(hi_g - lo_g)) if ug.size else step
        m = max(int(np.ceil(width / step * fine)) + 1, 4)
        tt = np.linspace(0.0, 1.0, m)
        xs = lo_g[:, None] + (hi_g - lo_g)[:, None] * tt  # (G, m) [krpm]
        xs = np.where((hi_g - lo_g)[:, None] > 1e-9, xs, lo_g[:, None] + step * (tt - 0.5))
        vals = np.empty((ug.size, m))
        sub = lobes.rows(xs * 1000.0, ug) * 1e3  # exact boundary [mm]
        vals[:] = np.where(np.isfinite(sub), sub, 1e6)
        cm = np.zeros((4, (m - 1) * len(idx)))
        bm = np.zeros((m - 1, len(idx)))
        for gi in range(ug.size):  # one small spline per active group
            spl = make_interp_spline(xs[gi], vals[gi], k=3)
            xl = xs[gi, :-1]
            cg = np.stack([spl(xl, nu=3) / 6.0, spl(xl, nu=2) / 2.0, spl(xl, nu=1), spl(xl)])
            for col in np.flatnonzero(ginv == gi):
                cm[:, col * (m - 1) : (col + 1) * (m - 1)] = cg
                bm[:, col] = xl
        bm[0, :] = -1e30
        return cm, bm, m - 1

    fn_cache: dict[int, ca.Function] = {}

    def piece_fn(n_piece: int) -> ca.Function:
        if n_piece not in fn_cache:
            x = ca.SX.sym("x")
            cp = ca.SX.sym("c", 4, n_piece)
            bp = ca.SX.sym("b", n_piece)
            expr = ca.SX(0)
            for p in range(n_piece):
                dx = x - bp[p]
                poly = ((cp[0, p] * dx + cp[1, p]) * dx + cp[2, p]) * dx + cp[3, p]
                expr = poly if p == 0 else ca.if_else(x >= bp[p], poly, expr)
            fn_cache[n_piece] = ca.Function("boundary", [x, cp, bp], [expr])
        return fn_cache[n_piece]

    g_fixed = []
    lbg_fixed: list[float] = []
    ubg_fixed: list[float] = []
    if not cons.constant_speed and kn > 1:
        dist = np.diff(knots_s)
        du = u[1:] - u[:-1]
        if cons.max_rate_rpm_per_m is not None:
            lim = cons.max_rate_rpm_per_m * dist / 1000.0
            g_fixed.append(du)
            lbg_fixed += list(-lim)
            ubg_fixed += list(lim)
        elif cons.max_rate_rpm_per_s is not None:
            r2 = cons.max_rate_rpm_per_s * dist * 60.0 / c_feed / 1e6  # krpm^2
            g_fixed += [du * u[1:], -du * u[:-1]]
            lbg_fixed += [-np.inf] * (2 * (kn - 1))
            ubg_fixed += list(r2) + list(r2)
    g_fixed.append(a * u)
    lbg_fixed += [-np.inf] * kn
    ubg_fixed += [cons.power_product] * kn  # a[mm] * n[krpm] == a[m] * n[rpm]
    lbx = np.r_[lo_b, cons.depth_min_m * 1e3]
    ubx = np.r_[hi_b, cons.depth_cap_m * 1e3]
    opts = {
        "ipopt.print_level": 0,
        "print_time": 0,
        "ipopt.sb": "yes",
        "ipopt.nlp_scaling_method": "none",
        "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-8,
        "ipopt.acceptable_tol": 1e-6,
        "ipopt.acceptable_iter": 5,
        "error_on_fail": False,
        "expand": False,
    }

    constrained = row_of[lobes.group] >= 0
    margin = np.where(constrained, start.a_lim_m / (sf * max(start.depth_m, 1e-12)), np.inf)
    # one representative per (group, knot interval, tenth of the interval): waypoints
    # sharing all three see the same boundary at nearly the same speed
    rep_key = (lobes.group * (kn + 1) + k_idx) * 11 + np.round(w * 10).astype(np.int64)
    order = np.argsort(margin, kind="stable")
    _, first = np.unique(rep_key[order], return_index=True)
    reps = order[np.sort(first)]
    near = reps[np.isfinite(margin[reps]) & (margin[reps] <= 1.5)]
    active = {int(i) for i in near[:max_active]}
    active.update(int(i) for i in order[:16] if np.isfinite(margin[i]))
    x0 = np.r_[u0, 0.97 * start.depth_m * 1e3]  # a little inside: splines sample the boundary
    status = "not run"
    best: Schedule | None = None
    n_piece = 0
    for _round in range(max_rounds):
        idx = sorted(active)
        if idx:
            cmat, bmat, n_piece = local_splines(idx)
            n_act = ca.mtimes(_sparse_interp(k_idx[idx], k1[idx], w[idx], kn), u)
            g_sp = piece_fn(n_piece).map(len(idx))(n_act.T, ca.DM(cmat), ca.DM(bmat)).T - sf * a
        else:
            g_sp = ca.MX(0, 1)
        g = ca.vertcat(*g_fixed, g_sp)
        lbg = lbg_fixed + [0.0] * len(idx)
        ubg = ubg_fixed + [np.inf] * len(idx)
        tb = time.perf_counter()
        nlp: dict[str, Any] = {"x": ca.vertcat(u, a), "f": obj, "g": g}
        solver = ca.nlpsol("plan", "ipopt", nlp, cast(Any, opts))
        x0 = np.clip(x0, lbx, ubx)
        ts = time.perf_counter()
        res = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg)
        logger.debug(
            "refine round %d: %d constraints, %d pieces, build %.2fs, solve %.2fs, %s",
            _round,
            len(idx),
            n_piece if idx else 0,
            ts - tb,
            time.perf_counter() - ts,
            solver.stats().get("return_status"),
        )
        status = str(solver.stats().get("return_status", "unknown"))
        xs = np.asarray(res["x"]).ravel()
        u_opt = xs[:kn] * 1000.0
        if cons.constant_speed:
            u_opt = np.full(kn, u_opt.min())
        u_opt = _rate_fix(np.clip(u_opt, cons.rpm_min, cons.rpm_hi), np.diff(knots_s), cons)
        n_opt = _knot_speeds(ctx, knots_s, u_opt)
        cand = _verify(ctx, "nlp", n_opt, xs[-1] * 1e-3, knots_s, u_opt)
        logger.debug(
            "refine round %d: NLP depth %.4g mm, verified %.4g mm, score %.5g (start %.5g)",
            _round,
            xs[-1],
            cand.depth_m * 1e3,
            _score(cand),
            _score(start),
        )
        if cand.feasible and _score(cand) > _score(best):
            best = cand
        # constraint generation: waypoints outside the NLP that limit its answer
        a_target = xs[-1] * 1e-3
        viol = np.flatnonzero(constrained & (cand.a_lim_m < sf * a_target * (1 - 1e-3)))
        new = [int(i) for i in viol[np.argsort(cand.a_lim_m[viol])] if int(i) not in active][:200]
        if not new:
            break
        active.update(new)
        # next round from the verified point (inside the exact boundary everywhere)
        x0 = np.r_[u_opt / 1000.0, 0.97 * cand.depth_m * 1e3]
    return best, status


def _refine_cannot_improve(ctx: _Ctx, start: Schedule, rel: float = 1e-4) -> str:
    """Why the refinement cannot improve on ``start`` (first order), or "" when it may.

    The objective (depth over cycle time) improves only by a faster speed
    somewhere or a larger depth. Where every waypoint already runs at the
    highest usable speed, only the depth is left; it cannot grow when it sits
    at its cap (depth_max, torque), or when the stability limit binds and, at
    every binding waypoint, the limit falls for a slightly lower speed
    (``rel`` of it), so that any allowed move lowers the depth. Power binds
    only through ``a * n``: there a lower speed can buy depth, so the
    refinement runs.
    """
    cons = ctx.cons
    n = start.rpm
    if n.size == 0 or not start.feasible or start.depth_m <= 0:
        return ""
    if np.any(n < cons.rpm_hi * (1 - 1e-9)):
        return ""
    a = start.depth_m
    if a * float(n.max()) >= cons.power_product * (1 - 1e-9):
        return ""
    if a >= cons.depth_cap_m * (1 - 1e-9):
        return "at the highest usable speed everywhere and the depth at its cap"
    sf = cons.safety_factor
    binding = np.flatnonzero(start.a_lim_m <= sf * a * (1 + 1e-6))
    if binding.size == 0:
        return ""
    lower = ctx.lobes.rows((n[binding] * (1.0 - rel))[:, None], ctx.lobes.group[binding])[:, 0]
    if np.all(lower < start.a_lim_m[binding]):
        return (
            "at the highest usable speed everywhere, and at the waypoints where stability "
            "binds a lower speed lowers the limit"
        )
    return ""


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
