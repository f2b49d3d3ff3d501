"""Stage 2: the casadi/IPOPT refinement of the searched schedule, and when to skip it."""

from __future__ import annotations

import logging
import math
import time
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from robolobe.plan.optimize._common import (
    _Blocks,
    _Ctx,
    _interp_matrix,
    _knot_speeds,
    _rate_fix,
    _score,
    _verify,
)
from robolobe.plan.optimize._results import Schedule

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi


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
    from scipy.interpolate import make_interp_spline  # only when refining: ~0.12 s import

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
