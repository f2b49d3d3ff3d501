"""Stage 1: the constant-speed candidate and the global dynamic-programming search."""

from __future__ import annotations

import logging
import math
from types import ModuleType

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InfeasibleError
from robolobe.plan.optimize._common import (
    _Blocks,
    _Ctx,
    _knot_speeds,
    _rate_fix,
    _rate_windows_all,
    _verify,
    _window_min,
)
from robolobe.plan.optimize._results import Schedule

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


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
        near = np.minimum(lobes.a_lim[used[:, None], j0], lobes.a_lim[used[:, None], j0 + 1])
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
    # the same blocks of the same table in the next run (pass counts, the refinement):
    # their grid minima are kept (few blocks only: each is (blocks, n_rpm))
    memo = ctx.lobes._block_mins
    key = start.tobytes()
    a_blk = memo.get(key)
    if a_blk is None:
        a_blk = _block_min(ctx.lobes.a_lim, ctx.lobes.group, start)
        if start.size <= _MEMO_BLOCKS:
            memo[key] = a_blk
    # strictly increasing knots (blocks of zero length share a position)
    knots = np.maximum.accumulate(knots)
    bump = np.arange(knots.size) * 1e-12 * max(total, 1.0)
    # edge knots: a block holds its speed from its first to its last waypoint;
    # the speed may change over the move into the next block's first waypoint
    pos = np.stack([s[start], s[end]], axis=1).ravel()
    blk_of = np.repeat(np.arange(start.size), 2)
    edge_s, first = np.unique(pos, return_index=True)
    return _Blocks(start, knots + bump, length, a_blk, edge_s, blk_of[first].astype(np.int64))


#: Most blocks whose grid minima a table keeps between runs (:func:`_blocks`).
_MEMO_BLOCKS = 4096


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


#: Whether the search runs its dynamic program compiled: None where another kernel has
#: started numba in this process (:func:`robolobe._jit.started`: its start-up paid; the
#: 10k zig-zag's optimize stage, cache load included, 0.33-0.37 s CPU compiled vs
#: 0.48-0.52 s on numpy), True wherever numba is available, False never. The same
#: values either way.
COMPILED_DP: bool | None = None


def _dp_kernels() -> ModuleType | None:
    """The compiled dynamic program (:mod:`._dp_kernels`) where :data:`COMPILED_DP` allows."""
    from robolobe import _jit

    if COMPILED_DP is False or (COMPILED_DP is None and not _jit.started()):
        return None
    if not _jit.available():
        return None
    from robolobe.plan.optimize import _dp_kernels as kern

    return kern


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
        if depth_hi >= cons.depth_min_m or kb >= n_cut or k_blocks >= n_cut:
            break  # (blocks of zero length merge: kb can stay below n_cut)
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

    lo_all, hi_all = _rate_windows_all(rpm, dist, cons)  # (kb - 1, J) each
    windows = list(zip(lo_all, hi_all, strict=True))
    kern = _dp_kernels()
    if kern is not None and not kern.monotone(lo_all, hi_all):
        kern = None
    if kern is not None:
        v, _ = kern.dp(blk.a_blk, blk.length, inv_n, sf_d[:, 0], base_ok, lo_all, hi_all)
    else:
        v = cost(0, slice(None))
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
        if kern is not None:
            vf, _ = kern.dp(blk.a_blk, blk.length, inv_n, sf_f[:, 0], ok_f, lo_all, hi_all)
        else:
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
    if kern is not None:
        one = slice(d_best, d_best + 1)
        _, kept = kern.dp(
            blk.a_blk, blk.length, inv_n, sf_d[one, 0], base_ok[one], lo_all, hi_all, keep=True
        )
        assert kept is not None
        vals = kept
    else:
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
