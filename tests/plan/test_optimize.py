"""The schedule optimizer on analytic lobe boundaries whose optimum is known."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InfeasibleError
from robolobe.plan.optimize import (
    Constraints,
    LobeTable,
    PathGeometry,
    limit_slacks,
    limiting_labels,
    optimize_schedule,
)
from robolobe.plan.optimize._common import _rate_fix, _rate_ok, _window_min

RPM = np.linspace(6000.0, 24000.0, 181)  # 100 rpm steps
KT = 800e6


def bump(centre: float, height: float, base: float = 1e-3, width: float = 600.0):
    def a(n: np.ndarray) -> np.ndarray:
        return base * (1.0 + height * np.exp(-(((np.asarray(n) - centre) / width) ** 2)))

    return a


def table(funcs, group, *, dent: float = 0.0) -> LobeTable:
    """Grid and exact boundary from analytic functions; ``dent`` lowers the exact
    boundary between grid points (it equals the grid at the grid points)."""
    grid = np.stack([f(RPM) for f in funcs])
    step = RPM[1] - RPM[0]

    def exact(rows: np.ndarray, groups: np.ndarray) -> np.ndarray:
        out = np.stack([funcs[g](rows[k]) for k, g in enumerate(groups)])
        return out * (1.0 - dent * np.abs(np.sin(np.pi * (rows - RPM[0]) / step)))

    return LobeTable(RPM, grid, np.asarray(group), exact)


def cons(**kw) -> Constraints:
    base = dict(
        teeth=3,
        feed_per_tooth_m=1e-4,
        width_m=0.01,
        kt_N_per_m2=KT,
        power_W=1e9,
        torque_Nm=1e9,
        rpm_min=6000.0,
        rpm_max=24000.0,
        depth_min_m=1e-4,
        depth_max_m=0.05,
        safety_factor=1.0,
    )
    base.update(kw)
    return Constraints(**base)


def test_single_pocket_matches_the_analytic_optimum():
    # objective a/T with T ~ 1/n: maximise a(n) n; brute force on a fine grid is the reference
    f = bump(15000.0, 2.0)
    n = 200
    out = optimize_schedule(table([f], np.zeros(n, int)), PathGeometry(np.full(n, 0.005)), cons())
    fine = np.linspace(6000, 24000, 400001)
    n_star = fine[np.argmax(f(fine) * fine)]
    best = out.best
    assert best.feasible
    assert np.allclose(best.rpm, n_star, atol=3.0)
    assert best.depth_m == pytest.approx(float(f(n_star)), rel=2e-4)
    assert best.depth_m <= float(np.min(f(best.rpm))) * (1 + 1e-12)
    assert out.constant is not None
    assert out.constant.depth_m == pytest.approx(best.depth_m, rel=1e-3)


@pytest.mark.slow
def test_schedule_switches_pockets_and_beats_constant_speed():
    f0, f1 = bump(10000.0, 2.0), bump(18000.0, 2.0)
    n = 200
    group = np.r_[np.zeros(n // 2, int), np.ones(n // 2, int)]
    out = optimize_schedule(table([f0, f1], group), PathGeometry(np.full(n, 0.005)), cons())
    best = out.best
    assert best.feasible
    # each half sits in its own pocket at (nearly) the full pocket depth 3 mm
    assert best.depth_m > 2.9e-3
    assert np.all(np.abs(best.rpm[: n // 2] - 10000) < 800)
    assert np.all(np.abs(best.rpm[n // 2 :] - 18000) < 800)
    assert out.constant is not None
    assert out.constant.depth_m < 1.6e-3
    assert best.mrr_m3_per_s > 1.5 * out.constant.mrr_m3_per_s
    # verified: depth x SF below the exact limit everywhere
    assert np.all(best.a_lim_m >= best.depth_m * (1 - 1e-12))


def test_rate_limit_holds_between_knots_and_waypoints():
    f0, f1 = bump(10000.0, 2.0), bump(18000.0, 2.0)
    n = 400
    seg = np.full(n, 0.0025)  # 1 m of cutting
    group = np.r_[np.zeros(n // 2, int), np.ones(n // 2, int)]
    r = 40000.0  # rpm per metre: 8000 rpm take 0.2 m
    c = cons(max_rate_rpm_per_m=r)
    out = optimize_schedule(table([f0, f1], group), PathGeometry(seg), c)
    best = out.best
    assert best.feasible
    dn = np.abs(np.diff(best.rpm))
    assert np.all(dn <= r * seg[1:] * (1 + 1e-6) + 1e-6)
    k = best.knots_rpm
    assert np.all(np.abs(np.diff(k)) <= r * np.diff(best.knots_s_m) * (1 + 1e-6) + 1e-6)
    # the ramp costs depth against the free schedule but still beats constant speed
    assert out.constant is not None
    assert best.mrr_m3_per_s >= out.constant.mrr_m3_per_s * (1 - 1e-9)


def test_rate_limit_per_second():
    f0, f1 = bump(10000.0, 2.0), bump(18000.0, 2.0)
    n = 300
    seg = np.full(n, 0.004)
    group = np.r_[np.zeros(n // 2, int), np.ones(n // 2, int)]
    r = 3000.0  # rpm/s
    c = cons(max_rate_rpm_per_s=r)
    out = optimize_schedule(table([f0, f1], group), PathGeometry(seg), c)
    best = out.best
    # |dn/dt| = |dn/ds| * v, v = fz N n / 60, worst at the faster end of each knot interval
    k, s = best.knots_rpm, best.knots_s_m
    rate = np.abs(np.diff(k)) / np.diff(s) * c.feed_per_rev_m * np.maximum(k[1:], k[:-1]) / 60.0
    assert np.all(rate <= r * (1 + 1e-6))


def test_power_limit_and_limiting_constraint():
    f = bump(18000.0, 2.0)
    n = 100
    c0 = cons()
    # power allows a * n <= 3 mm * 12000 rpm: the pocket at 18000 cannot be used at full depth
    power = 3e-3 * 12000.0 * KT * c0.width_m * c0.feed_per_rev_m / 60.0
    c = cons(power_W=power)
    out = optimize_schedule(table([f], np.zeros(n, int)), PathGeometry(np.full(n, 0.01)), c)
    best = out.best
    assert np.all(out.power_W <= power * (1 + 1e-9))
    assert "power" in set(out.limiting)
    assert best.depth_m * best.rpm.max() <= c.power_product * (1 + 1e-9)


def test_verification_uses_the_exact_boundary_not_the_grid():
    f = bump(15000.0, 2.0, width=250.0)
    n = 50
    tab = table([f], np.zeros(n, int), dent=0.3)
    out = optimize_schedule(tab, PathGeometry(np.full(n, 0.01)), cons(safety_factor=1.25))
    best = out.best
    exact = tab.query(best.rpm)
    assert np.all(exact >= 1.25 * best.depth_m * (1 - 1e-12))
    assert best.margin.min() == pytest.approx(1.25, rel=1e-9)


def test_programmed_baseline():
    f = bump(15000.0, 2.0)
    n = 40
    out = optimize_schedule(
        table([f], np.zeros(n, int)),
        PathGeometry(np.full(n, 0.01)),
        cons(safety_factor=1.5),
        programmed_rpm=np.r_[np.full(n // 2, np.nan), np.full(n // 2, 9000.0)],
    )
    assert out.programmed is not None
    assert np.all(out.programmed.rpm == 9000.0)  # gaps filled from the next programmed value
    assert out.programmed.depth_m == pytest.approx(float(f(9000.0)) / 1.5, rel=1e-9)
    assert out.best.mrr_m3_per_s > out.programmed.mrr_m3_per_s


def test_constant_speed_mode():
    f0, f1 = bump(10000.0, 2.0), bump(18000.0, 2.0)
    n = 60
    group = np.r_[np.zeros(n // 2, int), np.ones(n // 2, int)]
    out = optimize_schedule(
        table([f0, f1], group), PathGeometry(np.full(n, 0.01)), cons(constant_speed=True)
    )
    assert np.ptp(out.best.rpm) == 0.0
    assert out.nlp is None
    assert out.search is None


def test_infeasible_torque():
    f = bump(15000.0, 2.0)
    with pytest.raises(InfeasibleError, match="torque"):
        optimize_schedule(
            table([f], np.zeros(5, int)), PathGeometry(np.full(5, 0.01)), cons(torque_Nm=1e-3)
        )


def test_infeasible_stability_names_the_waypoint():
    f0, f1 = bump(15000.0, 2.0), bump(15000.0, 0.1, base=0.2e-3)
    group = np.array([0, 0, 1, 0])
    labels = ["p.nc:10", "p.nc:11", "p.nc:12", "p.nc:13"]
    with pytest.raises(InfeasibleError, match=r"waypoint 2 \(p\.nc:12\)") as ei:
        optimize_schedule(
            table([f0, f1], group),
            PathGeometry(np.full(4, 0.01)),
            cons(depth_min_m=0.5e-3),
            labels=labels,
        )
    assert ei.value.exit_code == 3


def test_infeasible_constant_speed_conflict():
    # each group alone is fine, but no single speed serves both at depth_min
    f0, f1 = bump(10000.0, 2.0, base=0.2e-3), bump(18000.0, 2.0, base=0.2e-3)
    group = np.r_[np.zeros(10, int), np.ones(10, int)]
    with pytest.raises(InfeasibleError, match="no single speed"):
        optimize_schedule(
            table([f0, f1], group),
            PathGeometry(np.full(20, 0.01)),
            cons(depth_min_m=0.5e-3, constant_speed=True),
        )


def test_window_min_matches_brute_force():
    rng = np.random.default_rng(7)
    for _ in range(20):
        nj = int(rng.integers(1, 40))
        v = rng.normal(size=(3, nj))
        lo = rng.integers(0, nj, nj)
        hi = np.maximum(lo, rng.integers(0, nj, nj))
        got = _window_min(v, lo, hi)
        ref = np.stack([[v[d, lo[j] : hi[j] + 1].min() for j in range(nj)] for d in range(3)])
        assert np.array_equal(got, ref)


def test_rate_fix_gives_feasible_lower_speeds():
    rng = np.random.default_rng(3)
    for kw in ({"max_rate_rpm_per_m": 5000.0}, {"max_rate_rpm_per_s": 2000.0}):
        c = cons(**kw)
        u = rng.uniform(6000, 24000, 50)
        dist = rng.uniform(0.01, 0.1, 49)
        fixed = _rate_fix(u, dist, c)
        assert np.all(fixed <= u + 1e-9)
        assert _rate_ok(fixed, dist, c)


def _rising(slope: float):
    def a(n: np.ndarray) -> np.ndarray:
        return 1e-3 * (1.0 + slope * (np.asarray(n) - 6000.0) / 18000.0)

    return a


def test_refinement_skipped_only_where_it_cannot_improve():
    """At the top speed with limits that fall for lower speeds the NLP has nothing to gain:
    it is skipped and the plan is the one without refinement; with a pocket below the top
    speed, or power binding, it runs."""
    geom = PathGeometry(np.full(40, 0.01), rapid_time_s=1.0)
    group = np.repeat([0, 1], 20)
    tab = table([_rising(0.5), _rising(0.8)], group)
    out = optimize_schedule(tab, geom, cons())
    assert out.nlp_status.startswith("not needed"), out.nlp_status
    ref = optimize_schedule(tab, geom, cons(), refine=False)
    assert out.best.depth_m == ref.best.depth_m
    np.testing.assert_array_equal(out.best.rpm, ref.best.rpm)
    assert np.all(out.best.rpm == 24000.0)
    # a pocket below the top speed: the refinement runs
    pocket = table([bump(15000.0, 1.0), bump(15200.0, 1.0)], group)
    assert not optimize_schedule(pocket, geom, cons()).nlp_status.startswith("not needed")
    # power binds at the top speed: a lower speed can buy depth, so it runs
    p = cons(power_W=KT * 0.01 * 3e-4 * 1.2e-3 * 24000.0 / 60.0)
    assert not optimize_schedule(tab, geom, p).nlp_status.startswith("not needed")


def test_block_minimum_in_chunks_equals_the_full_grid():
    from robolobe.plan.optimize._search import _block_min

    rng = np.random.default_rng(2)
    a = rng.uniform(1e-3, 5e-3, (30, 17))
    a[3, 5] = np.inf
    group = rng.integers(0, 30, 1000)
    start = np.unique(np.r_[0, rng.integers(1, 1000, 40)])
    ref = np.minimum.reduceat(a[group], start, axis=0)
    for chunk in (1, 7, 64, 5000):
        np.testing.assert_array_equal(_block_min(a, group, start, chunk), ref)


@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"max_rate_rpm_per_m": 40000.0},
        {"max_rate_rpm_per_s": 3000.0},
        {"constant_speed": True},
        {"power_W": 9000.0, "safety_factor": 1.3},
    ],
)
def test_compiled_search_equals_the_numpy_search(monkeypatch, kw):
    """The search's dynamic program compiled gives the numpy path's schedule bit for bit."""
    from robolobe import _jit
    from robolobe.plan.optimize import _search

    if not _jit.available():
        pytest.skip("numba not installed")
    rng = np.random.default_rng(5)
    centres = [10000.0, 19000.0, 12000.0, 21000.0, 15000.0, 11000.0]
    funcs = [bump(c, 2.5 + 0.3 * rng.random()) for c in centres]
    n = 180  # below max_blocks: a block per waypoint, so each sixth keeps its pocket
    group = np.repeat(np.arange(6), -(-n // 6))[:n]  # one pocket per sixth of the path
    geom = PathGeometry(np.full(n, 0.004))
    c = cons(**kw)
    out = {}
    for compiled in (False, True):
        monkeypatch.setattr(_search, "COMPILED_DP", compiled)
        out[compiled] = optimize_schedule(table(funcs, group), geom, c, refine=False)
    a, b = out[False], out[True]
    assert (a.search is None) == (b.search is None)
    if a.search is not None:
        assert b.search is not None
        if not kw:
            assert np.unique(a.search.rpm).size >= 4  # the search moved between pockets
        assert a.search.depth_m == b.search.depth_m
        np.testing.assert_array_equal(a.search.rpm, b.search.rpm)
        np.testing.assert_array_equal(a.search.knots_rpm, b.search.knots_rpm)
    assert a.best.depth_m == b.best.depth_m
    np.testing.assert_array_equal(a.best.rpm, b.best.rpm)


def test_rate_windows_are_the_speeds_the_rate_limit_allows():
    """Each window (all distances at once) holds exactly the grid speeds from which the
    speed may be reached over that distance (the rate check of :func:`_rate_ok`, brute
    force), and the one-distance form gives the same rows."""
    from robolobe.plan.optimize._common import _rate_ok, _rate_windows, _rate_windows_all

    rng = np.random.default_rng(4)
    dist = rng.uniform(0.0005, 0.02, 25)
    for kw in ({"max_rate_rpm_per_m": 20000.0}, {"max_rate_rpm_per_s": 800.0}, {}):
        c = cons(**kw)
        lo, hi = _rate_windows_all(RPM, dist, c)
        assert lo.shape == hi.shape == (dist.size, RPM.size)
        for k, d in enumerate(dist):
            for j in range(0, RPM.size, 7):
                ok = [
                    i
                    for i in range(RPM.size)
                    if _rate_ok(np.array([RPM[i], RPM[j]]), np.array([d]), c, rtol=0.0)
                ]
                assert (lo[k, j], hi[k, j]) == (min(ok), max(ok))
            one = _rate_windows(RPM, float(d), c)
            np.testing.assert_array_equal(one[0], lo[k])
            np.testing.assert_array_equal(one[1], hi[k])


def test_compiled_dp_windows_equal_the_sparse_table():
    """The monotone-queue window minimum of the kernel is the sparse table's, block by block."""
    from robolobe import _jit

    if not _jit.available():
        pytest.skip("numba not installed")
    from robolobe.plan.optimize import _dp_kernels
    from robolobe.plan.optimize._common import _rate_windows

    rng = np.random.default_rng(9)
    kb, nj = 40, RPM.size
    a_blk = rng.uniform(0.5e-3, 3e-3, (kb, nj))
    length = rng.uniform(0.001, 0.01, kb)
    inv_n = 60.0 / (1e-4 * 3 * RPM)
    sf_d = np.geomspace(1e-4, 3e-3, 7)
    ok = rng.random((7, nj)) > 0.1
    for kw in ({"max_rate_rpm_per_m": 20000.0}, {"max_rate_rpm_per_s": 800.0}, {}):
        c = cons(**kw)
        wins = [_rate_windows(RPM, float(d), c) for d in rng.uniform(0.0005, 0.02, kb - 1)]
        lo = np.array([w[0] for w in wins])
        hi = np.array([w[1] for w in wins])
        assert _dp_kernels.monotone(lo, hi)
        v = np.where((a_blk[0] >= sf_d[:, None]) & ok, length[0] * inv_n, np.inf)
        ref_vals = [v[3].copy()]
        for b in range(1, kb):
            cost = np.where((a_blk[b] >= sf_d[:, None]) & ok, length[b] * inv_n, np.inf)
            v = cost + _window_min(v, lo[b - 1], hi[b - 1])
            ref_vals.append(v[3].copy())
        got, _ = _dp_kernels.dp(a_blk, length, inv_n, sf_d, ok, lo, hi)
        np.testing.assert_array_equal(got, v)
        _, kept = _dp_kernels.dp(a_blk, length, inv_n, sf_d[3:4], ok[3:4], lo, hi, keep=True)
        np.testing.assert_array_equal(kept, np.array(ref_vals))


def test_limit_slacks_name_the_least_slack_and_leave_out_a_fixed_depth():
    c = cons(safety_factor=1.5)
    rpm = np.array([9000.0, 12000.0, 24000.0])  # the last sits on rpm_max
    depth = np.array([1e-3, 1e-3, 2e-3])
    a_lim = np.array([1.5e-3 * 1.005, 10e-3, 10e-3])  # the first sits on stability
    power = c.power_W_at(1.0, rpm) * depth
    slack = limit_slacks(c, rpm, depth, a_lim, power)
    assert "depth_max" in slack
    np.testing.assert_allclose(slack["stability"], a_lim / (1.5 * depth) - 1.0)
    torque = c.kt_N_per_m2 * depth * c.width_m * c.feed_per_rev_m / (2 * np.pi)
    np.testing.assert_allclose(slack["torque"], c.torque_Nm / torque - 1.0)
    assert limiting_labels(slack)[0] == "stability"
    fixed = limit_slacks(c, rpm, depth, a_lim, power, fixed_depth=True)
    assert "depth_max" not in fixed
    # where every limit has more than the stated slack, the schedule holds the speed
    lab = limiting_labels(fixed, free=0.01)
    assert lab[0] == "stability"
    assert lab[2] == "rpm_max"
    mins = np.min(np.stack(list(fixed.values())), axis=0)
    assert all((lab[k] == "schedule") == (mins[k] > 0.01) for k in range(3))


def test_lobe_table_query_pads_groups_by_their_own_number_of_speeds():
    """Each waypoint's limit at its own speed (as the grid interpolation, via ``exact``),
    with the rows asked of ``exact`` padded to at most twice each group's distinct
    speeds: one busy group does not pad every other group to its count."""
    rng = np.random.default_rng(4)
    rpm = np.linspace(5000.0, 25000.0, 81)
    n_groups = 300
    a_grid = 1e-3 * (1.5 + np.sin(rpm[None, :] / 900.0 + np.arange(n_groups)[:, None]))
    busy = np.zeros(20_000, np.int64)  # group 0: 20,000 moves at distinct speeds
    quiet = np.repeat(np.arange(1, n_groups), 3)  # the others: 3 moves at 1-3 speeds
    group = rng.permutation(np.r_[busy, quiet])
    speeds = np.where(group == 0, rng.uniform(5000.0, 25000.0, group.size), 0.0)
    speeds = np.where(group == 0, speeds, 6000.0 + 1000.0 * rng.integers(0, 3, group.size))
    asked = []

    def exact(rows, groups):
        asked.append(rows.size)
        return np.array([np.interp(r, rpm, a_grid[g]) for r, g in zip(rows, groups, strict=True)])

    tab = LobeTable(rpm=rpm, a_lim=a_grid, group=group, exact=exact)
    got = tab.query(speeds)
    want = np.array([np.interp(s, rpm, a_grid[g]) for s, g in zip(speeds, group, strict=True)])
    np.testing.assert_array_equal(got, want)
    pairs = np.unique(np.c_[group, speeds], axis=0).shape[0]
    assert sum(asked) <= 2 * pairs  # not n_groups x 20,000


def test_limiting_labels_are_the_first_least_slack():
    """The binding limit is the first least slack (a NaN first), as np.argmin over the
    stacked slacks, and "schedule" where every slack exceeds ``free`` (written here as
    that reference: the production code takes one limit at a time)."""

    def reference(slack, free=None):
        names = np.asarray(list(slack))
        mat = np.stack(list(slack.values()))
        lim = names[np.argmin(mat, axis=0)]
        if free is not None:
            lim = np.where(mat.min(axis=0) > free, "schedule", lim)
        return lim

    rng = np.random.default_rng(5)
    pool = ["stability", "power", "torque", "depth_max", "rpm_min", "rpm_max", "ab"]
    for _ in range(500):
        n, k = int(rng.integers(1, 30)), int(rng.integers(1, 7))
        slack = {}
        for name in rng.choice(pool, k, replace=False):
            if rng.random() < 0.5:  # ties, infinities and NaN
                slack[str(name)] = rng.choice([-1.0, 0.0, 0.5, np.inf, np.nan], n)
            else:
                slack[str(name)] = rng.normal(size=n)
        for free in (None, 0.01, -0.5):
            np.testing.assert_array_equal(limiting_labels(slack, free=free), reference(slack, free))
    # a short name list still holds "schedule" whole
    assert limiting_labels({"ab": np.array([1.0])}, free=0.5)[0] == "schedule"
