"""verify_plan: a plan on other modes, with the planner's own modelling."""

from __future__ import annotations

import dataclasses
import json
import shutil

import numpy as np
import pandas as pd
import pytest

from robolobe._atomic import MANIFEST
from robolobe.errors import InputError
from robolobe.plan.job import load_job
from robolobe.plan.modes import TwinSource
from robolobe.plan.pipeline import plan_path
from robolobe.plan.report import write_outputs
from robolobe.plan.verify import VerifyResult, verify_plan, write_verify
from robolobe.robots.io import load_robot

from .conftest import example

CASES = [
    ("pocket.nc", "job_A_pocket.toml"),
    ("contour.apt", "job_B_contour.toml"),
    ("face.mod", "job_C_face_steel.toml"),
    ("slot.src", "job_A_slot_steel.toml"),
    ("face.mod", "job_C_face_ti_lowspeed.toml"),
]


@pytest.fixture(scope="module")
def plans(tmp_path_factory):
    out = {}
    for path, job in CASES:
        d = tmp_path_factory.mktemp(job.split(".")[0])
        j = load_job(example(job))
        res = plan_path(example(path), j, refine=False)
        write_outputs(res, d, plots=False, html_report=False)
        out[job] = (d, j, res)
    return out


@pytest.mark.parametrize("job", [c[1] for c in CASES])
def test_verify_on_the_plans_own_modes_reproduces_a_lim(plans, job):
    d, j, res = plans[job]
    v = verify_plan(d, robot=j.robot, job=j)
    assert isinstance(v, VerifyResult)
    t = v.table
    ok = np.isfinite(t["a_lim_plan_mm"])
    assert ok.sum() > 5
    np.testing.assert_allclose(t["a_lim_mm"][ok], t["a_lim_plan_mm"][ok], rtol=0, atol=1e-9)
    assert v.ok
    assert v.n_beyond == 0
    assert v.min_margin == pytest.approx(res.summary.min_margin, abs=1e-3)


@pytest.mark.parametrize("job", [c[1] for c in CASES])
def test_shared_lobes_within_half_a_percent_of_each_waypoints_own(plans, job):
    """Lobe sharing keeps its promise: the stated limit vs every waypoint's own lobes."""
    d, j, _ = plans[job]
    v = verify_plan(d, robot=j.robot, job=j, dynamics_tol=0.0)
    t = v.table
    ok = np.isfinite(t["a_lim_plan_mm"])
    rel = np.abs(t["a_lim_mm"][ok] / t["a_lim_plan_mm"][ok] - 1.0)
    assert rel.max() <= 0.005  # issue 25: within 0.5 % of each waypoint's own lobes


def test_less_damped_robot_is_predicted_to_chatter_with_file_lines(plans, tmp_path):
    d, j, _ = plans["job_C_face_ti_lowspeed.toml"]
    weak = load_robot("C")
    weak = weak.replace(
        joints=tuple(
            dataclasses.replace(jt, damping_Nms_per_rad=0.4 * jt.damping_Nms_per_rad)
            for jt in weak.joints
        )
    )
    v = verify_plan(d, source=TwinSource(weak), job=j)
    assert not v.ok
    assert v.n_beyond > 0
    assert v.min_margin < 1.0
    assert all(c.startswith("face.mod:") for c in v.chatter)
    out = write_verify(v, tmp_path / "v")
    s = json.loads((out / "verify.json").read_text())
    assert s["n_beyond_limit"] == v.n_beyond
    assert (out / "plots" / "verify_margin.png").stat().st_size > 1000
    write_verify(v, out, plots=False)  # a re-run replaces the set: no stale plot
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "verify.csv", "verify.json"]


def test_bad_inputs(plans, tmp_path):
    d, j, _ = plans["job_A_pocket.toml"]
    with pytest.raises(InputError, match="exactly one"):
        verify_plan(d, job=j)
    with pytest.raises(InputError, match="exactly one"):
        verify_plan(d, robot="A", model="A", job=j)
    # missing files
    bad = tmp_path / "missing"
    shutil.copytree(d, bad)
    (bad / "summary.json").unlink()
    with pytest.raises(InputError, match=r"summary\.json"):
        verify_plan(bad, robot="A", job=j)
    # a job with another tool, material
    other = j.replace(tool=dataclasses.replace(j.tool, teeth=j.tool.teeth + 1))
    with pytest.raises(InputError, match="tool"):
        verify_plan(d, robot="A", job=other)
    other = j.replace(material=dataclasses.replace(j.material, name="steel"))
    with pytest.raises(InputError, match="material"):
        verify_plan(d, robot="A", job=other)
    # edited waypoints: path hash
    edited = tmp_path / "edited"
    shutil.copytree(d, edited)
    wp = pd.read_csv(edited / "waypoints.csv")
    wp.loc[5, "x_mm"] += 1.0
    wp.to_csv(edited / "waypoints.csv", index=False)
    with pytest.raises(InputError, match="path hash"):
        verify_plan(edited, robot="A", job=j)
    # postures outside the robot's limits
    narrow = load_robot("A")
    narrow = narrow.replace(
        joints=tuple(dataclasses.replace(jt, q_max_rad=jt.q_min_rad + 0.01) for jt in narrow.joints)
    )
    with pytest.raises(InputError, match="outside"):
        verify_plan(d, robot=narrow, job=j)
