"""The pipeline end to end on the bundled examples (twin modes: exact and fast)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pandas as pd
import pytest

import robolobe.plan.modes
from robolobe.errors import InfeasibleError, InputError, ReachabilityError, SingularityError
from robolobe.plan.job import load_job
from robolobe.plan.modes import REGION_CORNERS, PredictorSource, TwinSource, region_corners
from robolobe.plan.paths import read_toolpath
from robolobe.plan.pipeline import _wrist_measure, plan_path, tcp_targets
from robolobe.robots.io import load_robot
from robolobe.robots.kinematics import tcp_pose
from robolobe.tl.estimator import ModalPrediction

from .conftest import example


@pytest.fixture(scope="module")
def pocket_job():
    return load_job(example("job_A_pocket.toml")).replace(model="twin")


@pytest.fixture(scope="module")
def pocket(pocket_job):
    return plan_path(example("pocket.nc"), pocket_job, refine=False)


def test_plan_respects_every_constraint(pocket, pocket_job):
    t = pocket.table
    job = pocket_job
    cut = (t["motion"] == "cut") & ~t["limiting"].isin(["plunge", "air"])
    # the pocket is planned at each move's own engagement, in passes per section
    assert pocket.summary.engagement == "default stock"
    for _, sec in t[cut].groupby("section"):
        assert np.ptp(sec["depth_mm"]) == 0.0  # one step per pass in a section
        assert np.ptp(sec["passes"]) == 0
        np.testing.assert_allclose(
            sec["cut_depth_mm"], sec["program_depth_mm"] / sec["passes"], rtol=1e-12
        )
        assert np.all(sec["cut_depth_mm"] <= sec["depth_mm"] * (1 + 1e-12))
    depth = t.loc[cut, "cut_depth_mm"].to_numpy()
    # stable with the safety factor at every cutting waypoint (a_lim: exact, at the planned speed)
    assert np.all(t.loc[cut, "a_lim_mm"] >= job.plan.safety_factor * depth * (1 - 1e-9))
    assert t.loc[cut, "margin"].min() >= job.plan.safety_factor * (1 - 1e-9)
    # the full-width slot at the start (pocket.nc:12) is planned at its full engagement
    slot = t[(t["line"] == 12) & cut]
    assert (slot["ae_over_D"] > 0.99).all()
    rpm = t.loc[t["motion"] == "cut", "rpm"].to_numpy()
    assert np.all((rpm >= job.spindle.rpm_min - 1e-6) & (rpm <= job.spindle.rpm_max + 1e-6))
    assert t["power_kW"].max() <= job.spindle.power_W * 1e-3 * (1 + 1e-9)
    # speed changes within the rate limit (rpm/s at the feed each move runs at)
    s = t[t["motion"] == "cut"]
    seg = np.linalg.norm(np.diff(s[["x_mm", "y_mm", "z_mm"]].to_numpy(), axis=0), axis=1) * 1e-3
    v = s["feed_mm_per_min"].to_numpy() / 6e4
    dt = seg / np.maximum(v[1:], v[:-1])
    dn = np.abs(np.diff(s["rpm"].to_numpy()))
    ok = dt > 0
    assert np.all(dn[ok] <= job.plan.max_rate_rpm_per_s * dt[ok] * (1 + 1e-6) + 1e-6)
    # feed follows the speed at each move's own programmed chip load (the cut at F5400 and
    # S18000 with 3 flutes: 0.1 mm, the job says 0.08; the plunge at F600): F S_new / S_old
    prog = read_toolpath(example("pocket.nc"))
    f_old = prog.loc[prog["motion"] == "cut", "feed_mm_per_min"].to_numpy()
    assert np.allclose(s["feed_mm_per_min"], f_old * s["rpm"] / 18000.0)
    assert np.isclose(f_old, 5400.0).sum() > 100


def test_postures_reach_the_targets(pocket, pocket_job):
    robot = load_robot("A")
    wp = read_toolpath(example("pocket.nc"))
    poses, _ = tcp_targets(wp, robot, pocket_job.placement, 0.0)
    got = tcp_pose(robot, pocket.q)
    assert np.allclose(got[:, :3, 3], poses[:, :3, 3], atol=1e-6)
    assert np.allclose(got[:, :3, :3], poses[:, :3, :3], atol=1e-6)
    # tool axis of the pocket (+z of the path) is -z_tcp
    assert np.allclose(got[:, :3, 2], [0, 0, -1], atol=1e-9)
    assert np.max(np.abs(np.diff(pocket.q, axis=0))) < np.radians(20)  # no wrist flip


def test_summary_contents(pocket):
    s = pocket.summary
    assert s.min_margin_at.source.startswith("pocket.nc:")
    assert s.n_plunge == 2  # the two plunges at the slot start
    assert s.vs_programmed_speed is not None
    assert s.vs_programmed_speed.mrr_gain_pct >= 0.0
    assert s.vs_best_constant_speed is not None
    assert s.vs_best_constant_speed.mrr_gain_pct >= -1e-9
    assert s.cycle_time_s == pytest.approx(s.cut_time_s + s.rapid_time_s)
    assert 1 <= s.n_dynamics_groups <= s.n_cut
    # every cutting waypoint counted once under its limit, the plunges among them
    assert sum(c.count for c in s.limiting_counts) == s.n_cut
    assert {c.limit: c.count for c in s.limiting_counts}["plunge"] == s.n_plunge
    assert set(s.timings_s) == set(pocket.timings)
    assert set(pocket.timings) >= {"read", "ik", "modes", "frf", "lobes", "optimize", "table"}


def test_unreachable_placement_names_the_line(pocket_job):
    far = pocket_job.placement.copy()
    far[:3, 3] = [3.5, 0.0, 0.3]
    with pytest.raises(ReachabilityError, match=r"pocket\.nc:\d+: waypoint \d+"):
        plan_path(example("pocket.nc"), pocket_job.replace(placement=far), refine=False)


def test_singular_path_is_reported(tmp_path, pocket_job):
    # A at q = (0, -90, 90, 0, 0, 0) has its wrist straight (q5 = 0) with the TCP at
    # (2.24, 0, 1.91) pointing +x: a cut across that spot passes the wrist singularity
    p = tmp_path / "sing.csv"
    p.write_text("x_m,y_m,z_m,i,j,k\n0,0,0,-1,0,0\n0,0.01,0,-1,0,0\n", encoding="utf-8")
    pl = np.eye(4)
    pl[:3, 3] = [2.24, -0.005, 1.91]
    with pytest.raises(SingularityError, match=r"sing\.csv:3: waypoint 1: joint 4 turns 180 deg"):
        plan_path(p, pocket_job.replace(placement=pl), refine=False)


def test_wrist_measure_vanishes_with_a_straight_wrist():
    robot = load_robot("A")
    q = np.radians([[0, -90, 90, 0, 0, 0], [0, -90, 90, 0, 30, 0]])
    wm = _wrist_measure(robot, q)
    assert wm[0] == pytest.approx(0.0, abs=1e-12)
    assert wm[1] == pytest.approx(0.5, rel=1e-9)  # |sin 30 deg|


@pytest.mark.parametrize("threads", [1, 2])
def test_wrist_measure_in_chunks_on_threads_equals_one_call(monkeypatch, threads):
    """Chunks (on threads) that do not divide the postures give each posture's value of
    one call over all of them, and |sin q5| (robot A's wrist is the usual one)."""
    from robolobe.plan import pipeline

    robot = load_robot("A")
    rng = np.random.default_rng(4)
    q = np.radians([10.0, -80.0, 90.0, 5.0, 40.0, 3.0]) + rng.normal(0.0, 0.4, (50, 6))
    whole = _wrist_measure(robot, q)
    monkeypatch.setattr(pipeline, "_CHUNK", 7)
    monkeypatch.setattr(pipeline, "_THREADS", threads)
    np.testing.assert_array_equal(_wrist_measure(robot, q), whole)
    np.testing.assert_allclose(whole, np.abs(np.sin(q[:, 4])), rtol=1e-9, atol=1e-12)


def test_impossible_limits_are_infeasible(pocket_job):
    job = pocket_job.replace(plan=dataclasses.replace(pocket_job.plan, depth_min_m=0.014))
    with pytest.raises(InfeasibleError) as ei:
        plan_path(example("pocket.nc"), job, refine=False)
    assert ei.value.exit_code == 3
    assert "pocket.nc:" in str(ei.value)


def test_stiffest_rotation_picks_from_the_range(pocket_job):
    job = pocket_job.replace(
        tool_rotation="stiffest", tool_rotation_range_rad=(-np.pi / 2, np.pi / 2),
        tool_rotation_step_rad=np.pi / 2,
    )  # fmt: skip
    res = plan_path(example("pocket.nc"), job, refine=False)
    s = res.summary
    assert s.tool_rotation_deg in (-90.0, 0.0, 90.0)
    assert s.tool_rotation_search is not None
    assert s.tool_rotation_search.count("deg:") == 3


class _FakePredictor:
    """Twin modes as the centre with a 5 % log spread (a stand-in for a tl ensemble)."""

    def __init__(self, twin: TwinSource) -> None:
        self.twin = twin

    def predict(self, q, warn=True):
        m = self.twin.predict(q)
        vals = np.stack([m.f_hz, m.zeta, np.where(np.isfinite(m.k_N_per_m), m.k_N_per_m, 1e12)], -1)
        vals = vals[..., :4, :]  # four modes per direction
        return ModalPrediction(("xx", "yy", "zz"), np.log(vals), np.full(vals.shape, 0.05), "log")

    def extrapolation(self, q):
        return np.zeros(len(np.atleast_2d(q)))


def test_robust_mode_plans_on_the_lower_bound(pocket_job, monkeypatch):
    src = PredictorSource(_FakePredictor(TwinSource(load_robot("A"))), "fake ensemble")
    nominal = plan_path(example("pocket.nc"), pocket_job, source=src, refine=False)
    job = pocket_job.replace(plan=dataclasses.replace(pocket_job.plan, robust=True, k_sigma=2.0))
    default = plan_path(example("pocket.nc"), job, source=src, refine=False)
    # an ensemble's spread is not a calibrated prediction-error spread: the modes are
    # not lowered together (plan.modes.MODE_LOWERING holds for calibrated spreads), each
    # takes its own 2 sigma as under the rule "each" (the figures below)
    monkeypatch.setattr(robolobe.plan.modes, "MODE_LOWERING", "each")
    robust = plan_path(example("pocket.nc"), job, source=src, refine=False)
    assert default.summary.robust_bound == robust.summary.robust_bound
    assert default.summary.cycle_time_s == robust.summary.cycle_time_s
    assert robust.summary.robust is True
    # in passes of the program's 5 mm: the robust plan is the slower one (more passes or
    # a lower speed)
    assert robust.summary.cycle_time_s > nominal.summary.cycle_time_s
    # nominal + the joint region's corners (stiffness and damping lowered part of the way),
    # each twice: the modes that do not lead moved down, then up, by their own spread
    assert len(robust.lobes.diagrams) == 1 + 2 * REGION_CORNERS
    b = robust.summary.robust_bound
    assert b is not None
    assert b.k_sigma == 2.0
    assert b.confidence_pct == pytest.approx(95.45, abs=0.01)  # the joint region (issue 27)
    # spread 0.05 in log f, 2 sigma: a +-10 % speed window; k zeta (spread 0.05 each)
    # lowered by 2 sqrt(0.05^2 + 0.05^2), half on each: k and zeta x exp(-sqrt(2) 0.05)
    assert b.frequency_window_pct_max == pytest.approx(10.0, abs=1e-6)
    assert b.stiffness_lowered_to_pct == pytest.approx(100 * np.exp(-(2**0.5) * 0.05), abs=0.01)
    assert b.damping_lowered_to_pct == pytest.approx(100 * np.exp(-(2**0.5) * 0.05), abs=0.01)
    assert b.spread_pct_max.f == pytest.approx(100 * np.expm1(0.05), abs=1e-3)
    assert any(n.startswith("robust plan:") for n in robust.summary.notes)
    assert robust.summary.min_margin_at.source.startswith("pocket.nc:")
    # the stated limit is the smallest of the nominal lobes at the speed (a plain plan's)
    # and each corner of the joint region over its own speed window (the bound held at
    # margin 1: its scenarios' lobes are the bound's times the safety factor)
    tab = robust.lobes.table
    rpm = robust.outcome.best.rpm
    k = int(np.argmin(robust.outcome.best.a_lim_m))
    g = tab.group[k]
    from robolobe.sld.lobes import lobe_envelope

    def env(d, speeds):
        om = d.omega[g] if np.ndim(d.omega) > 1 else d.omega
        return lobe_envelope(
            om, d.depth[g], d.eps[g], teeth=d.teeth, rpm=speeds, max_lobe=d.max_lobe
        )

    nom = env(robust.lobes.diagrams[0], np.array([rpm[k]]))
    corners = []
    for d, (c_t, _) in zip(
        robust.lobes.diagrams[1:], np.repeat(region_corners(), 2, axis=0), strict=True
    ):
        w = 0.1 * c_t
        shifts = np.clip(rpm[k] * (1 + np.linspace(-w, w, 201)), tab.rpm[0], tab.rpm[-1])
        corners.append(env(d, shifts).min())
    stated = robust.outcome.best.a_lim_m[k]
    assert stated == pytest.approx(min(nom.min(), *corners), rel=0.05)


def test_twin_robust_uses_the_jobs_assumed_spread_and_never_nan(pocket_job):
    job = pocket_job.replace(plan=dataclasses.replace(pocket_job.plan, robust=True))
    res = plan_path(example("pocket.nc"), job, refine=False)
    b = res.summary.robust_bound
    assert b is not None
    assert "assumed spread" in b.spread_from
    assert b.frequency_window_pct_max == pytest.approx(100 * 2 * np.log1p(0.005), abs=1e-3)
    assert np.all(np.isfinite(res.outcome.best.a_lim_m[np.isfinite(res.outcome.best.margin)]))
    nominal = plan_path(example("pocket.nc"), pocket_job, refine=False)
    assert res.outcome.best.depth_m <= nominal.outcome.best.depth_m


def test_robust_infeasible_says_why_and_where(pocket_job):
    job = pocket_job.replace(
        plan=dataclasses.replace(
            pocket_job.plan, robust=True, k_sigma=3.0, depth_min_m=pocket_job.plan.depth_max_m
        )
    )
    with pytest.raises(InfeasibleError, match=r"pocket\.nc:\d+") as exc:
        plan_path(example("pocket.nc"), job, refine=False)
    assert "nan" not in str(exc.value).lower()
    # why (the bound's lowering, the deepest cut on it and on the prediction) and what to do
    msg = str(exc.value)
    assert "robust plan: on the bound, stiffness to" in msg
    assert re.search(r"the deepest stable cut of the worst dynamics is [\d.]+ mm", msg)
    assert "plan.k_sigma (now 3)" in msg
    assert "plan.depth_min" in msg


def test_degenerate_paths(tmp_path, pocket_job):
    still = tmp_path / "still.csv"
    still.write_text("x_m,y_m,z_m\n0,0,0\n0,0,0\n", encoding="utf-8")
    with pytest.raises(InputError, match=r"^still\.csv: expected a path that moves"):
        plan_path(still, pocket_job, refine=False)
    rapid = tmp_path / "rapid.csv"
    rapid.write_text("x_m,y_m,z_m,motion\n0,0,0,rapid\n0.01,0,0,rapid\n", encoding="utf-8")
    with pytest.raises(InputError, match="at least one cutting move"):
        plan_path(rapid, pocket_job, refine=False)
    plunge = tmp_path / "plunge.csv"
    plunge.write_text("x_m,y_m,z_m\n0,0,0\n0,0,-0.005\n", encoding="utf-8")
    res = plan_path(plunge, pocket_job, refine=False)
    assert res.summary.n_plunge == 2
    assert any("plunges" in n for n in res.summary.notes)
    assert res.lobes.n_groups == 0


@pytest.mark.parametrize(
    ("threads", "split"), [(1, False), (2, False), (1, True), (2, True), (2, "distinct")]
)
@pytest.mark.parametrize("source_kind", ["twin", "builtin"])
def test_modes_of_distinct_postures_in_chunks_equal_one_call(
    pocket, monkeypatch, source_kind, threads, split
):
    """Each distinct posture predicted once, in chunks (on one or two threads; from
    _SPLIT_MIN postures on a small first chunk and the rest shared between the threads),
    expanded: the modes of one call."""
    from robolobe.plan import pipeline
    from robolobe.plan.modes import mode_source

    robot = load_robot("A")
    source, _ = mode_source(source_kind, robot, "A")
    q = pocket.q[pocket.cut_index][:60]
    if split != "distinct":
        q = np.concatenate([q, q[::-3], q[:5]])  # repeats, out of order
    monkeypatch.setattr(pipeline, "_CHUNK", 16)
    monkeypatch.setattr(pipeline, "_THREADS", threads)
    if split:
        monkeypatch.setattr(pipeline, "_SPLIT_MIN", 20)
        monkeypatch.setattr(pipeline, "_HEAD", 5)
    calls = []
    inner = source.predict

    def counted(x):
        calls.append(len(x))
        return inner(x)

    monkeypatch.setattr(source, "predict", counted)
    got = pipeline._predict_modes(source, q)
    assert sum(calls) == 60
    assert max(calls) <= 16
    if split and threads == 2:
        assert calls[0] == 5
        assert len(calls) > 2
    ref = inner(q)
    for name in ("f_hz", "zeta", "k_N_per_m", "log_std", "extrapolation"):
        a, b = getattr(got, name), getattr(ref, name)
        if b is None:
            assert a is None
        else:
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=0.0)
    for name in ("omega", "zeta", "residues"):
        np.testing.assert_allclose(
            getattr(got.model, name), getattr(ref.model, name), rtol=1e-12, atol=1e-300
        )
    assert got.source == ref.source


@pytest.mark.slow
def test_compiled_and_reused_paths_plan_as_the_numpy_reference(tmp_path, pocket_job, monkeypatch):
    """A zig-zag large enough for the compiled lobes, exact queries and the steep-wall
    reuse plans the same depth and speeds (1e-9) as the numpy reference paths."""
    from robolobe import _jit

    lines = ["G90 G21 G17", "S18000 M3", "G0 X0. Y0. Z5.", "G1 Z-1. F1000."]
    for k in range(16):
        xs = np.linspace(0.0, 400.0, 160)[:: -1 if k % 2 else 1]
        lines += [f"Y{10.0 * k:.3f}"] if k else []
        lines += [f"X{x:.3f} F4000." for x in xs]
    path = tmp_path / "zz.nc"
    path.write_text("\n".join([*lines, "G0 Z5.", "M30"]) + "\n", encoding="utf-8")
    pl = pocket_job.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]
    job = pocket_job.replace(placement=pl, model="twin")
    fast = plan_path(path, job)
    assert fast.lobes.n_groups * fast.lobes.diagrams[0].omega.shape[-1] >= 1_000_000
    monkeypatch.setitem(_jit._STATE, "ok", False)
    ref = plan_path(path, job)
    assert fast.outcome.best.method == ref.outcome.best.method
    assert fast.outcome.best.depth_m == pytest.approx(ref.outcome.best.depth_m, rel=1e-9)
    np.testing.assert_allclose(fast.outcome.best.rpm, ref.outcome.best.rpm, rtol=1e-9)
    np.testing.assert_array_equal(fast.lobes.table.group, ref.lobes.table.group)


@pytest.mark.parametrize("threads", [1, 2])
def test_tool_point_models_in_chunks_equal_one_call(pocket, pocket_job, monkeypatch, threads):
    """The feed-frame models of a long path, made chunk by chunk (one or two threads),
    are those of one call over every waypoint, bit for bit."""
    from robolobe.plan import pipeline
    from robolobe.sld.toolpoint import feed_frame, tool_point_model

    source = TwinSource(load_robot("A"))
    model = source.predict(pocket.q[pocket.cut_index]).model
    n = model.batch_shape[0]
    f = np.random.default_rng(3).normal(size=(n, 3))
    f[:, 2] *= 0.1
    rot = feed_frame(f / np.linalg.norm(f, axis=1, keepdims=True), (0.0, 0.0, -1.0), rotation="cw")
    tool = pipeline._tool_model(pocket_job)
    assert tool is not None
    ref = tool_point_model(rot, model, tool)
    monkeypatch.setattr(pipeline, "_CHUNK", 16)
    monkeypatch.setattr(pipeline, "_THREADS", threads)
    got = pipeline._tool_point_models(rot, model, tool)
    assert n > 3 * 16
    for name in ("omega", "zeta", "residues"):
        np.testing.assert_array_equal(getattr(got, name), getattr(ref, name))


def _zigzag(tmp_path, pocket_job, n_x=200):
    """A 6-line zig-zag of ``6 n_x`` cutting moves with plunges (the streamed tests' path)."""
    lines = ["G90 G21 G17", "S18000 M3", "G0 X0. Y0. Z5.", "G1 Z-1. F1000."]
    for k in range(6):
        xs = np.linspace(0.0, 300.0, n_x)[:: -1 if k % 2 else 1]
        lines += [f"Y{8.0 * k:.3f}"] if k else []
        lines += [f"X{x:.3f} F4000." for x in xs]
        lines += ["G1 Z-1.5 F500.", "G1 Z-1. F500."]  # plunges: unbounded rows
    path = tmp_path / "zz.nc"
    path.write_text("\n".join([*lines, "G0 Z5.", "M30"]) + "\n", encoding="utf-8")
    pl = pocket_job.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]
    return path, pocket_job.replace(placement=pl, model="twin")


@pytest.mark.slow
def test_streamed_path_with_interpolated_modes_plans_as_in_memory(
    tmp_path, pocket_job, monkeypatch
):
    """Streamed with the modes exact at every 8th posture and interpolated where checked
    (:func:`robolobe.plan.modes.interpolated_modes`): far fewer postures predicted, the
    table's modes within the stated tolerance of every posture's exact modes, and each
    move's stated limit within 0.5 % of the plan with exact modes at the same speed."""
    from robolobe.plan import pipeline
    from robolobe.plan.lobes import DynamicsTolerance
    from robolobe.plan.modes import MODE_INTERP_FRACTION

    path, job = _zigzag(tmp_path, pocket_job, n_x=1500)
    ref = plan_path(path, job)
    seen = []
    inner = TwinSource.predict

    def counted(self, q_rad):
        seen.append(len(q_rad))
        return inner(self, q_rad)

    monkeypatch.setattr(TwinSource, "predict", counted)
    monkeypatch.setattr(pipeline, "_STREAM_MIN", 500)
    monkeypatch.setattr(pipeline, "_STREAM_CHUNK", 2000)
    monkeypatch.setattr(pipeline, "_MODE_STRIDE", 8)
    got = plan_path(path, job)
    n_cut = int(np.sum(ref.table["motion"] == "cut"))
    # (the leaders' models made again included, and the members' check's models from
    # interpolated modes again: size_members)
    assert sum(seen) < 0.7 * n_cut
    tol, fr = DynamicsTolerance(), MODE_INTERP_FRACTION
    cut = (ref.table["motion"] == "cut").to_numpy()
    for c in ref.table.columns:
        if re.fullmatch(r"(f|zeta)\d_[xyz](_hz)?", c):
            a, b = got.table[c].to_numpy()[cut], ref.table[c].to_numpy()[cut]
            allowed = fr * (tol.freq if c.startswith("f") else tol.damping)
            assert np.max(np.abs(a / b - 1.0)) <= allowed, c
    # each move's limit at the plan's own speeds from the exact plan's lobes
    a_got = got.table["a_lim_mm"].to_numpy()[cut]
    a_ref = ref.lobes.table.query(got.table["rpm"].to_numpy()[cut]) * 1e3
    ok = np.isfinite(a_ref) & np.isfinite(a_got)
    assert ok.sum() > 0.9 * n_cut
    assert np.max(a_got[ok] / a_ref[ok]) <= 1.005
    assert np.min(a_got[ok] / a_ref[ok]) >= 0.99


@pytest.mark.slow
@pytest.mark.parametrize("threads", [1, 2])
def test_streamed_long_path_plans_as_in_memory(tmp_path, pocket_job, monkeypatch, threads):
    """A path long enough to be streamed (modes, feed-frame models and grouping features
    chunk by chunk, only the leaders' models made again) plans bit for bit as in memory:
    groups, leaders, depth, every speed and every column of the table, the steep-wall
    split included; a robust plan is not streamed."""
    from robolobe.plan import lobes as lobes_mod
    from robolobe.plan import pipeline

    path, job = _zigzag(tmp_path, pocket_job)
    monkeypatch.setattr(pipeline, "_THREADS", threads)
    monkeypatch.setattr(pipeline, "_MODE_STRIDE", 1)  # every posture's exact modes
    monkeypatch.setattr(pipeline, "_CHUNK", 97)  # chunks that do not divide the path
    monkeypatch.setattr(pipeline, "_STREAM_CHUNK", 89)
    monkeypatch.setattr(lobes_mod, "_BLOCK", 101)  # the in-place compaction in blocks
    inner_predict = TwinSource.predict

    def predict(self, q_rad):  # one direction's frequency differs on part of the path
        md = inner_predict(self, q_rad)
        f = md.f_hz.copy()  # the modes are read-only
        f[:, 1, 0] += np.where(np.asarray(q_rad)[:, 0] < 0.07, 1.0, 0.0)
        return dataclasses.replace(md, parameters=dataclasses.replace(md.parameters, f_hz=f))

    monkeypatch.setattr(TwinSource, "predict", predict)
    ref = plan_path(path, job)
    col_x, col_y = ref.table["f1_x_hz"].to_numpy(), ref.table["f1_y_hz"].to_numpy()
    assert 0 < np.sum(col_x != col_y) < np.sum(np.isfinite(col_x))  # the column un-shares
    calls = []
    inner = pipeline._streamed_lobes

    def counted(*a, **k):
        out = inner(*a, **k)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(pipeline, "_streamed_lobes", counted)
    monkeypatch.setattr(pipeline, "_STREAM_MIN", 500)
    got = plan_path(path, job)
    assert calls == [True]
    assert int(np.sum(got.table["limiting"] == "plunge")) >= 5
    assert got.lobes.n_groups > 10
    np.testing.assert_array_equal(got.lobes.table.group, ref.lobes.table.group)
    np.testing.assert_array_equal(got.lobes.leader, ref.lobes.leader)
    np.testing.assert_array_equal(got.lobes.table.a_lim, ref.lobes.table.a_lim)
    assert got.outcome.best.depth_m == ref.outcome.best.depth_m
    np.testing.assert_array_equal(got.outcome.best.rpm, ref.outcome.best.rpm)
    assert list(got.table.columns) == list(ref.table.columns)
    for c in ref.table.columns:
        np.testing.assert_array_equal(got.table[c].to_numpy(), ref.table[c].to_numpy(), err_msg=c)
    # robust: the bound needs every posture's modes at once -> planned in memory
    calls.clear()
    rob = plan_path(path, job.replace(plan=dataclasses.replace(job.plan, robust=True)))
    assert calls == [False]
    assert rob.summary.robust


def test_columns_added_to_a_fragmented_result_table_do_not_warn():
    import warnings

    from robolobe.plan.pipeline import _columns_added

    table = pd.DataFrame({f"c{k}": np.zeros(4) for k in range(120)}, copy=False)
    with pytest.warns(pd.errors.PerformanceWarning):
        table["outside"] = np.ones(4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with _columns_added():
            table["inside"] = np.ones(4)
    assert table["inside"].sum() == 4


def test_optimizer_timings_cover_every_run(pocket_job, monkeypatch):
    """The plan's optimizer timings are summed over all its runs (the pass counts that
    schedule_passes tries, the final one), with their number; the optimize stage
    leaves out the lobes of a steep-wall split (counted under lobes)."""
    from robolobe.plan import pipeline

    inner = pipeline.optimize_schedule
    seen = []

    def counted(*a, **k):
        out = inner(*a, **k)
        seen.append(dict(out.timings))
        return out

    monkeypatch.setattr(pipeline, "optimize_schedule", counted)
    res = plan_path(example("pocket.nc"), pocket_job)
    got = res.outcome.timings
    assert len(seen) >= 2  # the bundled pocket is planned in passes: several runs
    assert got["runs"] == len(seen)
    for key in ("constant", "total"):
        assert got[key] == pytest.approx(sum(t.get(key, 0.0) for t in seen), rel=1e-12)
    assert res.timings["optimize"] >= got["total"]  # the stage holds every run


def test_modes_refused_in_parts_are_refused_as_in_one_call(pocket, monkeypatch):
    """A path whose modes are predicted in parts on the threads and refused by one of
    them gets the refusal of one call over all its postures (given modal parameters
    that miss most of the path's postures: all of them counted, not one part's)."""
    from robolobe._modal_parameters import ModalParameters
    from robolobe.plan import pipeline
    from robolobe.plan.modes import ParametersSource

    robot = load_robot("A")
    q = pocket.q[pocket.cut_index][:60]
    given = TwinSource(robot).predict(q[:10]).parameters
    source = ParametersSource(
        ModalParameters(given.f_hz, given.zeta, given.k_N_per_m, given.directions, q_rad=q[:10])
    )
    monkeypatch.setattr(pipeline, "_THREADS", 2)
    monkeypatch.setattr(pipeline, "_SPLIT_MIN", 20)
    monkeypatch.setattr(pipeline, "_HEAD", 5)
    with pytest.raises(InputError) as one:
        source.predict(q)
    assert "50 postures missing" in str(one.value)
    with pytest.raises(InputError) as parts:
        pipeline._predict_modes(source, q)
    assert str(parts.value) == str(one.value)
