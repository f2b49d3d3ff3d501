"""``robolobe verify`` end to end (subprocess: real exit codes)."""

from __future__ import annotations

import dataclasses
import json
import shutil
import subprocess
from importlib import resources
from pathlib import Path

import pytest

from robolobe.robots.io import load_robot, save_robot

from .test_plan_cli import run

# subprocesses: a plan, then verify runs (~20 s each on a busy machine)
pytestmark = pytest.mark.slow

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


@pytest.fixture(scope="module")
def plan_dir(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("verify")
    job = EX / "job_C_face_ti_lowspeed.toml"
    r = run(
        ["plan", str(EX / "face.mod"), "--job", str(job), "-o", "plan", "--no-plots", "--no-html"],
        tmp,
    )
    assert r.returncode == 0, r.stderr
    return tmp / "plan"


def test_verify_on_the_same_robot_exit_0(plan_dir, tmp_path):
    r = run(["verify", str(plan_dir), "--robot", "C", "-o", "v"], tmp_path)
    assert r.returncode == 0, r.stderr
    s = json.loads((tmp_path / "v" / "verify.json").read_text())
    assert s["n_beyond_limit"] == 0
    assert (tmp_path / "v" / "plots" / "verify_margin.png").exists()
    assert "0 of" in r.stdout


def test_verify_on_a_less_damped_robot_exit_4_names_lines(plan_dir, tmp_path):
    c = load_robot("C")
    weak = c.replace(
        joints=tuple(
            dataclasses.replace(j, damping_Nms_per_rad=0.4 * j.damping_Nms_per_rad)
            for j in c.joints
        ),
        name="C-weak",
    )
    save_robot(weak, tmp_path / "weak.toml")
    r = run(["verify", str(plan_dir), "--robot", str(tmp_path / "weak.toml"), "-o", "v"], tmp_path)
    assert r.returncode == 4, r.stderr
    assert "chatter predicted: face.mod:" in r.stderr
    s = json.loads((tmp_path / "v" / "verify.json").read_text())
    assert s["n_beyond_limit"] > 0


def _one_line_exit_2(r: subprocess.CompletedProcess[str], *words: str) -> None:
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    err = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(err) == 1, err
    for w in words:
        assert w in err[0], err[0]


def test_bad_input_exit_2_one_line_nothing_written(plan_dir, tmp_path):
    broken = tmp_path / "broken"
    shutil.copytree(plan_dir, broken)
    (broken / "waypoints.csv").unlink()
    r = run(["verify", str(broken), "--robot", "C", "-o", "v"], tmp_path)
    _one_line_exit_2(r, "waypoints.csv")
    assert not (tmp_path / "v").exists()
    # a job with another material
    job = tmp_path / "job.toml"
    job.write_text((EX / "job_C_face_ti_lowspeed.toml").read_text().replace('"Ti6Al4V"', '"steel"'))
    r = run(["verify", str(plan_dir), "--robot", "C", "--job", str(job), "-o", "v"], tmp_path)
    _one_line_exit_2(r, "job.toml", "material")
    assert not (tmp_path / "v").exists()
    # postures outside the limits of another robot
    c = load_robot("C")
    narrow = c.replace(
        joints=tuple(dataclasses.replace(j, q_max_rad=j.q_min_rad + 0.01) for j in c.joints)
    )
    save_robot(narrow, tmp_path / "narrow.toml")
    r = run(
        ["verify", str(plan_dir), "--robot", str(tmp_path / "narrow.toml"), "-o", "v"], tmp_path
    )
    _one_line_exit_2(r, "waypoints.csv", "outside")
    assert not (tmp_path / "v").exists()
    # a campaign with too few postures
    camp = tmp_path / "camp"
    r = run(
        ["simulate", "C", "-o", str(camp), "--design", "random", "--n", "3", "--exact"], tmp_path
    )
    assert r.returncode == 0, r.stderr
    r = run(["verify", str(plan_dir), "--campaign", str(camp), "-o", "v"], tmp_path)
    _one_line_exit_2(r, "camp", "postures")
    assert not (tmp_path / "v").exists()
