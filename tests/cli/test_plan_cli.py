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
