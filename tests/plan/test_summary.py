"""The typed plan summary: ``to_dict()`` is ``summary.json``, its figures agree with
the per-waypoint table, and it is read by attribute only."""

from __future__ import annotations

import collections
import dataclasses
import json
import types

import numpy as np
import pandas as pd
import pytest

import robolobe as rl
from robolobe.plan import PlanSummary, report
from robolobe.plan._summary import BaselineComparison, _notes
from robolobe.plan.job import load_job
from robolobe.plan.optimize import Schedule
from robolobe.plan.pipeline import plan_path
from robolobe.robots import load_robot

from .conftest import example

#: The keys of summary.json, in the order written (the file contract).
TOP_KEYS = [
    "robolobe_version", "job", "job_file", "path", "robot", "robot_spec", "mode_source",
    "tool_rotation_deg", "tool_rotation_search", "material", "n_waypoints", "n_cut", "n_plunge",
    "n_dynamics_groups", "speed_mode", "robust", "robust_by_default", "k_sigma", "robust_bound",
    "safety_factor", "method", "nlp_status", "depth_mm", "rpm_min", "rpm_max", "mrr_cm3_per_min",
    "cycle_time_s", "cut_time_s", "rapid_time_s", "cut_length_m", "min_margin", "min_margin_at",
    "max_power_kW", "torque_Nm", "limiting_counts", "vs_best_constant_speed",
    "vs_programmed_speed", "candidates", "engagement", "passes", "notes", "plan_record",
    "timings_s",
]  # fmt: skip
SCHEDULE_KEYS = [
    "method", "feasible", "reason", "depth_mm", "rpm_min", "rpm_max", "rpm_mean",
    "mrr_cm3_per_min", "cut_time_s", "cycle_time_s",
]  # fmt: skip
BOUND_KEYS = [
    "k_sigma", "confidence_pct", "spread_from", "frequency_window_pct_max",
    "frequency_window_pct_median", "stiffness_lowered_to_pct", "damping_lowered_to_pct",
    "spread_pct_median", "spread_pct_max", "statement",
]  # fmt: skip


@pytest.fixture(scope="module")
def robust_contour():
    """Robot B's twin on the bundled contour, robust (the job's assumed spread)."""
    job = load_job(example("job_B_contour.toml")).replace(model="twin")
    job = job.replace(plan=dataclasses.replace(job.plan, robust=True))
    return plan_path(example("contour.apt"), job, refine=False)


def test_to_dict_is_the_written_json_key_for_key(tmp_path, robust_contour):
    res = robust_contour
    s = res.summary
    out = report.write_outputs(res, tmp_path / "o", plots=False, html_report=False)
    text = (out / "summary.json").read_text(encoding="utf-8")
    d = json.loads(text)
    assert d == s.to_dict()
    assert list(d) == TOP_KEYS
    assert list(d["min_margin_at"]) == ["waypoint", "source", "x_mm", "y_mm", "z_mm", "rpm"]
    assert list(d["candidates"]) == ["search", "nlp", "constant"]
    assert d["candidates"]["nlp"] is None  # refine=False: no refinement ran
    assert list(d["candidates"]["search"]) == SCHEDULE_KEYS
    for key in ("vs_best_constant_speed", "vs_programmed_speed"):
        assert list(d[key]) == [*SCHEDULE_KEYS, "mrr_gain_pct", "cycle_time_saving_pct"], key
    assert list(d["robust_bound"]) == BOUND_KEYS
    assert list(d["robust_bound"]["spread_pct_max"]) == ["f", "zeta", "k"]
    assert isinstance(d["notes"], list)
    assert all(isinstance(n, str) for n in d["notes"])
    assert list(d["timings_s"]) == list(res.timings)
    assert d["plan_record"]["format"] == "robolobe-plan-record/1"


def test_headline_figures_agree_with_the_waypoint_table(robust_contour):
    res = robust_contour
    s, t = res.summary, res.table
    cut = t["motion"] == "cut"
    assert s.n_waypoints == len(t)
    assert s.n_cut == int(cut.sum())
    assert s.n_plunge == int((t["limiting"] == "plunge").sum())
    # the limits of the cutting waypoints, most first
    counted = collections.Counter(t.loc[cut, "limiting"])
    assert {c.limit: c.count for c in s.limiting_counts} == dict(counted)
    assert [c.count for c in s.limiting_counts] == sorted(counted.values(), reverse=True)
    assert s.depth_mm == pytest.approx(float(t.loc[cut, "depth_mm"].iloc[0]), abs=1e-4)
    assert s.rpm_min == pytest.approx(float(t.loc[cut, "rpm"].min()), abs=0.05)
    assert s.rpm_max == pytest.approx(float(t.loc[cut, "rpm"].max()), abs=0.05)
    k = int(np.nanargmin(t["margin"].to_numpy(dtype=float)))
    assert s.min_margin == pytest.approx(float(t["margin"].iloc[k]), abs=1e-4)
    assert s.min_margin_at.waypoint == k
    assert s.min_margin_at.source == f"{t['source'].iloc[k]}:{int(t['line'].iloc[k])}"
    assert s.min_margin_at.x_mm == pytest.approx(float(t["x_mm"].iloc[k]), abs=1e-3)
    assert s.min_margin >= s.safety_factor * (1 - 1e-6)
    assert s.max_power_kW == pytest.approx(float(t["power_kW"].max()), abs=1e-4)
    assert s.robust
    assert not s.robust_by_default
    assert s.robust_bound is not None
    assert s.k_sigma == s.robust_bound.k_sigma
    assert "robust plan: " + s.robust_bound.statement in s.notes  # the limit notes follow


def test_summary_is_typed_frozen_and_read_by_attribute(robust_contour):
    s = robust_contour.summary
    assert isinstance(s, PlanSummary)
    assert rl.PlanSummary is PlanSummary
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.depth_mm = 1.0
    with pytest.raises(TypeError):  # no mapping shim: summary.to_dict() is the mapping
        _ = s["depth_mm"]
    later = s.with_timings({"read": 0.123456789})
    assert later.timings_s == {"read": 0.1235}
    assert later.to_dict()["timings_s"] == {"read": 0.1235}
    assert dataclasses.replace(later, timings_s=s.timings_s) == s


def _schedule(depth_mm: float, cycle_s: float, mrr_cm3_per_min: float, feasible=True):
    rpm = np.array([10000.0, 12000.0, 14000.0])
    return Schedule(
        method="constant",
        rpm=rpm,
        depth_m=depth_mm * 1e-3,
        a_lim_m=np.full(3, 5e-3),
        cut_time_s=0.9 * cycle_s,
        cycle_time_s=cycle_s,
        mrr_m3_per_s=mrr_cm3_per_min / 6e7,
        feasible=feasible,
        reason="" if feasible else "power",
    )


def test_baseline_comparison_by_hand():
    best = _schedule(depth_mm=2.0, cycle_s=10.0, mrr_cm3_per_min=60.0)
    base = _schedule(depth_mm=1.0, cycle_s=10.0, mrr_cm3_per_min=40.0)
    g = BaselineComparison.between(best, base)
    assert g.mrr_gain_pct == pytest.approx(50.0)  # 60 / 40 - 1
    # the same stock takes half as many passes of the same cycle time
    assert g.cycle_time_saving_pct == pytest.approx(50.0)
    assert (g.depth_mm, g.rpm_min, g.rpm_max, g.rpm_mean) == (1.0, 10000.0, 14000.0, 12000.0)
    assert g.mrr_cm3_per_min == pytest.approx(40.0)
    bad = BaselineComparison.between(best, _schedule(1.0, 10.0, 40.0, feasible=False))
    assert (bad.mrr_gain_pct, bad.cycle_time_saving_pct, bad.feasible) == (None, None, False)
    assert bad.to_dict()["reason"] == "power"


def test_notes_in_order_with_the_lobe_split_joined_to_the_mode_note():
    job = load_job(example("job_A_pocket.toml"))
    wp = pd.DataFrame({"x": [0.0]})
    wp.attrs["warnings"] = ["no G20/G21: mm assumed"]
    notes = _notes(
        job=job,
        robot=load_robot("A"),
        waypoints=wp,
        lobes=types.SimpleNamespace(message="lobes shared"),
        extrapolation=np.array([0.0, 0.05, 0.2, 0.3]),
        n_plunge=0,
        robust=False,
        bound=None,
        mode_note="model note",
        n_split=3,
    )
    assert notes == [
        "model note; 3 waypoints next to a steep lobe wall got lobes of their own "
        "(sharing would have moved their limit)",
        "lobes shared",
        "toolpath reader: no G20/G21: mm assumed",
        "2 of 4 cutting postures lie beyond the model's training range (up to 30 % of a "
        "joint range): predictions there are extrapolations",
    ]


def test_notes_count_one_in_the_singular():
    job = load_job(example("job_A_pocket.toml"))
    notes = _notes(
        job=job,
        robot=load_robot("A"),
        waypoints=pd.DataFrame({"x": [0.0]}),
        lobes=types.SimpleNamespace(message=""),
        extrapolation=np.array([0.0, 0.3]),
        n_plunge=1,
        robust=False,
        bound=None,
        mode_note="",
        n_split=1,
    )
    assert notes[0] == (
        "1 waypoint next to a steep lobe wall got its own lobes (sharing would have moved "
        "its limit)"
    )
    assert notes[1].startswith("1 of 2 cutting postures lies beyond")
    assert notes[2].startswith("1 cutting move runs along the tool axis (a plunge)")
