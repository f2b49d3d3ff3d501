"""The same job on several robots, with placement search."""

from __future__ import annotations

import json

import numpy as np
import pytest

from robolobe.errors import ReachabilityError
from robolobe.plan.compare import compare_robots, find_placement, write_comparison
from robolobe.plan.job import load_job
from robolobe.plan.paths import read_toolpath
from robolobe.robots.io import load_robot

from .conftest import example


@pytest.fixture(scope="module")
def job():
    return load_job(example("job_A_pocket.toml")).replace(model="twin")


@pytest.mark.slow
def test_compare_adjusts_placement_and_writes(tmp_path, job):
    cmp = compare_robots(example("pocket.nc"), job, ["A", "C"], refine=False)
    t = cmp.table.set_index("robot")
    assert list(t.index) == ["A", "C"]
    assert (t["status"] == "ok").all()
    assert not t.loc["A", "placement_adjusted"]  # the job's placement is A's
    # a placement out of everyone's reach is moved in front of each robot
    far = job.placement.copy()
    far[:3, 3] = [3.5, 0.0, 0.3]
    cmp_far = compare_robots(
        example("pocket.nc"), job.replace(placement=far), ["A", "C"], refine=False
    )
    tf = cmp_far.table.set_index("robot")
    assert (tf["status"] == "ok").all()
    assert tf["placement_adjusted"].all()
    assert all(np.hypot(*xyz[:2]) < 3.0 for xyz in tf["placement_xyz_m"])
    assert np.all(t["min_margin"] >= job.plan.safety_factor - 1e-6)
    # per part, not per pass: each plan makes the program's own 5 mm in passes, and its
    # cycle time counts them all
    for r in ("A", "C"):
        plan = cmp.results[r].summary
        n = t.loc[r, "passes"]
        assert n == max(sec["passes"] for sec in plan.passes)
        assert n * t.loc[r, "depth_mm"] == pytest.approx(5.0, rel=1e-3)
        assert t.loc[r, "part_time_s"] == pytest.approx(t.loc[r, "cycle_time_s"])
    out = write_comparison(cmp, tmp_path / "cmp")
    rows = json.loads((out / "compare.json").read_text())
    assert [r["robot"] for r in rows] == ["A", "C"]
    assert (out / "compare.png").read_bytes()[:4] == b"\x89PNG"
    assert (out / "C" / "waypoints.csv").exists()
    assert (out / "A" / "report.html").exists()


def test_unreachable_robot_is_reported(tmp_path, job):
    # a toy arm far too small for the pocket: every placement fails
    src = load_robot("A")
    small = src.replace(
        joints=tuple(
            j.__class__(**{**vars(j), "a_m": j.a_m * 0.02, "d_m": j.d_m * 0.02}) for j in src.joints
        )
    )
    from robolobe.robots.io import save_robot

    path = tmp_path / "tiny.toml"
    save_robot(small.replace(tool=np.eye(4)), path)
    wp = read_toolpath(example("pocket.nc"))
    with pytest.raises(ReachabilityError):
        find_placement(wp, load_robot(path), job)
    cmp = compare_robots(example("pocket.nc"), job, [str(path)], refine=False)
    assert cmp.table["status"].iloc[0] == "unreachable"
    assert "tiny" in cmp.table["robot"].iloc[0]
