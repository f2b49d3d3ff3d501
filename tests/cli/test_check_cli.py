"""``robolobe check`` end to end (subprocess: real exit codes)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from .test_plan_cli import run

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


def test_missing_s_is_one_line_exit_2_nothing_written(tmp_path: Path) -> None:
    p = tmp_path / "nos.nc"
    p.write_text("G90 G21\nG0 X-40. Y0. Z5.\nG1 Z-2. F300.\nG1 X30. F1200.\nM30\n")
    r = run(["check", str(p), "--job", str(EX / "job_A_pocket.toml"), "-o", "out"], tmp_path)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1
    assert "nos.nc:3" in lines[0]  # the plunge into the default stock
    assert "spindle speed S" in lines[0]
    assert "--rpm" in lines[0]
    assert not (tmp_path / "out").exists()


def test_a_foreign_check_csv_is_refused_before_the_work(tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "check.csv").write_text("mine\n")
    r = run(
        ["check", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "-o", "out"],
        tmp_path,
    )
    assert r.returncode == 2
    assert "check.csv" in r.stderr
    assert "Traceback" not in r.stderr
    assert (out / "check.csv").read_text() == "mine\n"


@pytest.mark.slow
def test_pocket_as_written_exit_4_names_the_lines(tmp_path: Path) -> None:
    r = run(
        ["check", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"), "-o", "out"],
        tmp_path,
    )
    assert r.returncode == 4, r.stderr
    s = json.loads((tmp_path / "out" / "check.json").read_text())
    assert s["n_beyond_limit"] > 0
    assert s["min_margin"] < 1
    assert "beyond limit: pocket.nc:" in r.stderr
    assert "pocket.nc as written" in r.stdout
    assert "min margin" in r.stdout
    t = pd.read_csv(tmp_path / "out" / "check.csv")
    row = t[t["line"] == 12].iloc[0]  # the full-width centre slot
    assert row["ae_over_D"] == pytest.approx(1.0, abs=1e-3)
    assert row["status"] in ("beyond limit", "inside SF")  # margin ~1.04 at S18000, a_p 5 mm
    for name in ("check.csv", "check.json", "check_margin.png", "check_report.html"):
        assert (tmp_path / "out" / name).is_file()


@pytest.mark.slow
def test_the_plans_own_program_is_checked_the_same_way(tmp_path: Path) -> None:
    job = EX / "job_A_pocket.toml"
    r = run(
        ["plan", str(EX / "pocket.nc"), "--job", str(job), "-o", "plan", "--no-plots"], tmp_path
    )
    assert r.returncode == 0, r.stderr
    prog = tmp_path / "plan" / "program.nc"
    assert prog.is_file()
    report = (tmp_path / "plan" / "report.html").read_bytes()
    # checked into the plan's own folder: the plan's files stay as they were
    r = run(["check", str(prog), "--job", str(job), "-o", "plan"], tmp_path)
    assert r.returncode in (0, 4), r.stderr
    assert (tmp_path / "plan" / "report.html").read_bytes() == report
    assert prog.is_file()
    t = pd.read_csv(tmp_path / "plan" / "check.csv")
    plan = pd.read_csv(tmp_path / "plan" / "waypoints.csv")
    cut = plan[plan["motion"] == "cut"]
    # every move of every pass at the S the plan wrote into the program (whole rpm), not
    # the original S18000
    assert len(t) == int(cut["passes"].sum())
    dist = np.abs(t["rpm"].to_numpy()[:, None] - cut["rpm"].to_numpy()[None, :]).min(axis=1)
    assert dist.max() <= 1.0
    assert (t["rpm"] != 18000).any()
    assert "program.nc:" in (tmp_path / "plan" / "check.json").read_text()
