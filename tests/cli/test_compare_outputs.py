"""``compare`` output folder: one managed set (no stale robot folders after a re-run)."""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

import pandas as pd
import pytest

from robolobe._atomic import MANIFEST
from robolobe.errors import InputError
from robolobe.plan.compare import (
    Comparison,
    compare_robots,
    robot_folder_notes,
    robot_folders,
    write_comparison,
)
from robolobe.plan.job import load_job

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


@pytest.fixture(scope="module")
def plan_a() -> Comparison:
    job = load_job(EX / "job_A_pocket.toml").replace(model="twin")
    return compare_robots(EX / "pocket.nc", job, ["A"], refine=False)


def _as(cmp: Comparison, specs: list[str]) -> Comparison:
    """The same plan under other robot names (as if planned on those robot files)."""
    row = cmp.table.iloc[0]
    table = pd.DataFrame([{**row.to_dict(), "robot": s} for s in specs])
    res = next(iter(cmp.results.values()))
    return Comparison(table=table, results=dict.fromkeys(specs, res))


def test_folder_names_are_unique() -> None:
    got = robot_folders(["A", "cell1/r.toml", "cell2/r.toml", "compare.toml", "B"])
    assert got == {"A": "A", "cell1/r.toml": "r", "cell2/r.toml": "r-2",
                   "compare.toml": "compare", "B": "B"}  # fmt: skip
    assert len(set(got.values())) == len(got)


def test_rerun_replaces_the_whole_set(tmp_path: Path, plan_a: Comparison) -> None:
    out = tmp_path / "cmp"
    write_comparison(_as(plan_a, ["A", "/lab/r1.toml", "/old/r1.toml"]), out, plans=False)
    assert {p.name for p in out.iterdir()} >= {"A", "r1", "r1-2", "compare.csv"}
    (out / "my_notes.txt").write_text("keep me")
    (out / "other").mkdir()
    (out / "other" / "summary.json").write_text("{}")  # not written by a comparison
    write_comparison(_as(plan_a, ["A", "/lab/r2.toml"]), out, plans=False)
    names = {p.name for p in out.iterdir()}
    assert names == {"A", "r2", "compare.csv", "compare.json", "compare.png", "my_notes.txt",
                     "other", MANIFEST}  # fmt: skip
    records = json.loads((out / "compare.json").read_text())
    assert [r["folder"] for r in records] == ["A", "r2"]
    assert (out / "r2" / "summary.json").is_file()


def test_foreign_record_is_refused_and_nothing_outside_touched(
    tmp_path: Path, plan_a: Comparison
) -> None:
    # a compare.json robolobe did not write (no manifest lists it) naming ".." folders
    out = tmp_path / "deep" / "cmp"
    out.mkdir(parents=True)
    (tmp_path / "deep" / "summary.json").write_text("{}")
    record = json.dumps([{"robot": "..", "folder": ".."}, {"robot": "x", "folder": "../.."}])
    (out / "compare.json").write_text(record)
    with pytest.raises(InputError, match=r"already holds compare\.json, which robolobe did not"):
        write_comparison(_as(plan_a, ["A"]), out, plans=False)
    assert (tmp_path / "deep" / "summary.json").read_text() == "{}"
    assert sorted(p.name for p in out.iterdir()) == ["compare.json"]
    assert (out / "compare.json").read_text() == record


def test_hostile_robot_names_stay_inside(tmp_path: Path, plan_a: Comparison) -> None:
    out = tmp_path / "w" / "cmp"
    (tmp_path / "w" / "keep").mkdir(parents=True)
    (tmp_path / "w" / "keep" / "k.txt").write_text("k")
    specs = ["...toml", "..toml", "a/../...toml", "x\\..\\.toml", "\x1b[31mred.toml"]
    write_comparison(_as(plan_a, specs), out, plans=False)
    write_comparison(_as(plan_a, specs), out, plans=False)  # and a re-run
    assert sorted(p.name for p in (tmp_path / "w").iterdir()) == ["cmp", "keep"]
    assert (tmp_path / "w" / "keep" / "k.txt").read_text() == "k"
    folders = [r["folder"] for r in json.loads((out / "compare.json").read_text())]
    assert folders == ["robot", "robot-2", "robot-3", "x_.._", "red"]
    assert all((out / f / "summary.json").is_file() for f in folders)
    notes = robot_folder_notes(specs)
    assert len(notes) == 5
    assert "'...toml': outputs in 'robot'" in notes[0]


def test_bad_or_repeated_robot_is_refused_before_planning(tmp_path: Path) -> None:
    job = load_job(EX / "job_A_pocket.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text(
        (EX.parent / "robots" / "A.toml").read_text().replace("a_m = 1.15", "a_m = 1150")
    )
    with pytest.raises(InputError, match=r"bad\.toml: \[\[joints\]\]\[2\]\.a_m: expected a length"):
        compare_robots(EX / "pocket.nc", job, ["A", str(bad)])
    with pytest.raises(InputError, match="found A twice"):
        compare_robots(EX / "pocket.nc", job, ["A", "a"])
