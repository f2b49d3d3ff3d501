"""Shared pieces of the optimization stages: speed-rate windows, verification, scores."""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robolobe.plan.optimize._inputs import Constraints, LobeTable, PathGeometry
from robolobe.plan.optimize._results import Schedule

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


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
    lo, hi = _rate_windows_all(rpm, np.array([dist_m], dtype=np.float64), cons)
    return lo[0], hi[0]


def _rate_windows_all(
    rpm: FloatArray, dist_m: FloatArray, cons: Constraints
) -> tuple[IntArray, IntArray]:
    """:func:`_rate_windows` for each distance of ``dist_m`` (n,) at once: (n, J) each."""
    nj = rpm.size
    d_m = np.asarray(dist_m, dtype=np.float64).reshape(-1, 1)
    idx = np.broadcast_to(np.arange(nj, dtype=np.int64), (d_m.shape[0], nj))
    if cons.constant_speed:
        return idx.copy(), idx.copy()
    if cons.max_rate_rpm_per_m is not None:
        d = cons.max_rate_rpm_per_m * d_m
        lo_v, hi_v = rpm - d, rpm + d
    elif cons.max_rate_rpm_per_s is not None:
        r2 = cons.max_rate_rpm_per_s * d_m * 60.0 / cons.feed_per_rev_m  # rpm^2
        lo_v = rpm - r2 / rpm
        hi_v = 0.5 * (rpm + np.sqrt(rpm * rpm + 4.0 * r2))
    else:
        return np.zeros(idx.shape, np.int64), np.full(idx.shape, nj - 1, np.int64)
    tol = 1e-9 * rpm.max()
    lo = np.searchsorted(rpm, (lo_v - tol).ravel(), side="left").reshape(lo_v.shape)
    hi = np.searchsorted(rpm, (hi_v + tol).ravel(), side="right").reshape(hi_v.shape) - 1
    return np.minimum(lo.astype(np.int64), idx), np.maximum(hi.astype(np.int64), idx)


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


@dataclass
class _Blocks:
    start: IntArray  # first cutting waypoint of each block
    knots_s: FloatArray  # block centres [m] (knots of ramped schedules)
    length: FloatArray  # cutting length per block [m]
    a_blk: FloatArray  # (K, J) block minimum of a_lim [m]
    edge_s: FloatArray  # knots at the first and last waypoint of each block [m]
    edge_block: IntArray  # block of each edge knot


def _knot_speeds(ctx: _Ctx, knots_s: FloatArray, u: FloatArray) -> FloatArray:
    k, w = _interp_matrix(ctx.geom.s_m, knots_s)
    if knots_s.size == 1:
        return np.full(ctx.geom.s_m.size, float(u[0]))
    return np.asarray((1 - w) * u[k] + w * u[k + 1])
