"""``robolobe plan / compare / batch`` end to end (subprocess: real exit codes)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from importlib import resources
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from robolobe.cli.main import app

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "COLUMNS": "120"}
    return subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=300,
        env=env,
        check=False,
    )


def twin_job(tmp_path: Path, name: str = "job_A_pocket.toml", **plan: str) -> Path:
    text = (EX / name).read_text(encoding="utf-8").replace('model = "builtin"', 'model = "twin"')
    for k, v in plan.items():
        text = re.sub(rf"(?m)^{k} = .*$", f"{k} = {v}", text)
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


@pytest.mark.slow
def test_plan_without_arguments_runs_the_bundled_example(tmp_path):
    r = run(["plan"], tmp_path)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "robolobe-out"
    s = json.loads((out / "summary.json").read_text())
    assert s["path"].endswith("pocket.nc")
    assert (out / "report.html").exists()
    assert (out / "plots" / "lobes.png").exists()
    assert "MRR" in r.stdout
    assert "minimum margin" in r.stdout


@pytest.mark.slow
def test_bad_path_exit_2_one_line_nothing_written(tmp_path):
    bad = tmp_path / "bad.nc"
    bad.write_text("G0 X0 Y0\nG1 X10 Y0 F100\nG81 Z-5 R1\n", encoding="utf-8")
    r = run(["plan", str(bad), "--job", str(twin_job(tmp_path)), "-o", "out"], tmp_path)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    err = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(err) == 1
    assert "bad.nc:3" in err[0]
    assert "canned cycle" in err[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_infeasible_job_exit_3(tmp_path):
    job = twin_job(tmp_path, depth_min_mm="14.0")
    r = run(["plan", str(EX / "pocket.nc"), "--job", str(job), "-o", "out"], tmp_path)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr
    assert "pocket.nc:" in r.stderr
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_compare_and_batch(tmp_path):
    job = twin_job(tmp_path)
    r = run(
        [
            "compare",
            str(EX / "pocket.nc"),
            "--job",
            str(job),
            "--robots",
            "A",
            "C",
            "-o",
            "cmp",
            "--no-refine",
        ],
        tmp_path,
    )
    assert r.returncode == 0, r.stderr
    t = pd.read_csv(tmp_path / "cmp" / "compare.csv")
    assert list(t["robot"]) == ["A", "C"]
    assert (t["status"] == "ok").all()
    shutil.copy(EX / "pocket.nc", tmp_path / "p1.nc")
    (tmp_path / "p2.nc").write_text("G0 X0\nG41 G1 X5\n", encoding="utf-8")
    r = run(
        ["batch", "p1.nc", "p2.nc", "--job", str(job), "-o", "b", "--workers", "1", "--no-refine"],
        tmp_path,
    )
    assert r.returncode == 2  # one path failed; the table is still written
    assert "p2.nc:2" in r.stderr
    assert "Traceback" not in r.stderr
    t = pd.read_parquet(tmp_path / "b" / "batch.parquet")
    assert dict(zip(t["path"], t["status"], strict=True)) == {"p1.nc": "ok", "p2.nc": "error"}


def test_help_lists_units():
    res = CliRunner().invoke(app, ["plan", "--help"])
    assert res.exit_code == 0
    shown = " ".join(res.output.split())  # help text is wrapped to the terminal
    assert "--job" in shown
    assert "Exit code 3" in shown


@pytest.mark.slow
def test_plan_needs_both_path_and_job(tmp_path):
    r = run(["plan", str(EX / "pocket.nc")], tmp_path)
    assert r.returncode == 2
    assert "give both PATH and --job" in r.stderr


@pytest.mark.parametrize("robots", [["--robots", "A,C"], ["--robots", "A", "--robots", "C"]])
def test_compare_robot_list_forms(tmp_path, robots, monkeypatch):
    from robolobe.plan import compare as cmp_mod

    seen: dict[str, list[str]] = {}

    def fake(path, job, names, refine=True):
        seen["names"] = names
        return cmp_mod.Comparison(
            table=pd.DataFrame({"robot": names, "status": ["ok"] * len(names), "message": ""})
        )

    monkeypatch.setattr(cmp_mod, "compare_robots", fake)
    monkeypatch.setattr(cmp_mod, "write_comparison", lambda c, o: o)
    res = CliRunner().invoke(
        app,
        [
            "compare",
            str(EX / "pocket.nc"),
            "--job",
            str(twin_job(tmp_path)),
            *robots,
            "-o",
            str(tmp_path / "c"),
        ],
    )
    assert res.exit_code == 0, res.output
    assert seen["names"] == ["A", "C"]


def test_compare_table_says_where_the_workpiece_was_moved(tmp_path, monkeypatch):
    """The terminal table: one format per column, a moved workpiece said in the status
    and in a note with its position (the plan on B is not for the job's placement)."""
    from robolobe.plan import compare as cmp_mod

    rows = [
        {"robot": "A", "status": "ok", "placement_adjusted": False, "depth_mm": 2.8791,
         "rpm_min": 22514.2, "rpm_max": 22676.4, "mrr_cm3_per_min": 155.597,
         "cycle_time_s": 8.795, "passes": 5.0, "part_time_s": 43.97, "min_margin": 1.3,
         "worst_source": "pocket.nc:27", "message": ""},
        {"robot": "B", "status": "ok", "placement_adjusted": True,
         "placement_xyz_m": [1.868, 0.0, 1.2051], "depth_mm": 1.97, "rpm_min": 24000.0,
         "rpm_max": 24000.0, "mrr_cm3_per_min": 113.7, "cycle_time_s": 8.3, "passes": 7.0,
         "part_time_s": 57.8, "min_margin": 1.30004, "worst_source": "pocket.nc:34",
         "message": ""},
        {"robot": "C", "status": "unreachable", "message": "C: no placement reaches the path"},
    ]  # fmt: skip
    table = pd.DataFrame(rows)
    monkeypatch.setattr(cmp_mod, "compare_robots", lambda *a, **k: cmp_mod.Comparison(table))
    monkeypatch.setattr(cmp_mod, "write_comparison", lambda c, o: o)
    args = ["compare", str(EX / "pocket.nc"), "--job", str(twin_job(tmp_path)), "-o", "c"]
    res = CliRunner().invoke(app, [*args, "--robots", "A", "B", "C"])
    assert res.exit_code == 0, res.output
    lines = res.output.splitlines()
    a = next(ln for ln in lines if ln.lstrip().startswith("A "))
    b = next(ln for ln in lines if ln.lstrip().startswith("B "))
    # (the last column, the worst waypoint, may fold at the console's width)
    assert a.split()[:8] == ["A", "ok", "2.88", "22514-22676", "155.6", "5", "44.0", "1.30"]
    assert b.split()[:4] == ["B", "ok,", "moved", "1.97"]
    assert "24000" in b.split()
    text = " ".join(res.output.split())
    assert "workpiece moved for robot B" in text
    assert "x 1.868, y 0.000, z 1.205 m" in text
    assert "robot A" not in text  # A's workpiece is where the job puts it
