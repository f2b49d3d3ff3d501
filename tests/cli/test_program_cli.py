"""``robolobe plan -o`` writes the program; ``robolobe program`` writes it from a plan folder."""

from __future__ import annotations

import shutil
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from robolobe.plan.paths import read_toolpath

from .test_plan_cli import run

# subprocesses: plans then program runs (~15 s each on a busy machine); the same paths run
# in process in tests/plan/test_program_write.py
pytestmark = pytest.mark.slow

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


@pytest.fixture(scope="module")
def planned(tmp_path_factory) -> Path:
    tmp = tmp_path_factory.mktemp("program")
    for name in ("pocket.nc", "job_A_pocket.toml"):
        shutil.copy(EX / name, tmp / name)
    r = run(
        ["plan", "pocket.nc", "--job", "job_A_pocket.toml", "-o", "out", "--no-plots",
         "--no-html", "--no-refine"],
        tmp,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    return tmp


def test_plan_writes_the_program_and_program_rewrites_it(planned) -> None:
    assert (planned / "out" / "program.nc").is_file()
    r = run(["program", "out", "-o", "again.nc"], planned)
    assert r.returncode == 0, r.stderr
    a = read_toolpath(planned / "again.nc")
    b = read_toolpath(planned / "pocket.nc")
    # the pocket in passes: its one section once per pass, the last pass its own moves
    ca = (a["motion"] == "cut").to_numpy()
    cb = (b["motion"] == "cut").to_numpy()
    passes = ca.sum() // cb.sum()
    assert passes > 1
    assert ca.sum() == passes * cb.sum()
    pa = a[["x_m", "y_m", "z_m"]].to_numpy()[ca][-cb.sum() :]
    assert np.abs(pa - b[["x_m", "y_m", "z_m"]].to_numpy()[cb]).max() < 1e-9
    cut = ca
    assert (a["rpm_programmed"].to_numpy()[cut] > 18000).all()  # the plan's speeds


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["-o", "x.src", "--program-format", "krl"], "translation from gcode to 'krl'"),
        (["-o", "x.nc", "--program-format", "nc"], "--program-format: expected one of"),
        (["-o", "adir"], "found a directory"),
    ],
)
def test_program_bad_input_is_one_line_and_writes_nothing(planned, args, message) -> None:
    (planned / "adir").mkdir(exist_ok=True)
    before = sorted(p.name for p in planned.iterdir())
    r = run(["program", "out", *args], planned)
    assert r.returncode == 2
    assert message in r.stderr
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in planned.iterdir()) == before


def test_program_refuses_a_changed_or_missing_source(tmp_path) -> None:
    for name in ("pocket.nc", "job_A_pocket.toml"):
        shutil.copy(EX / name, tmp_path / name)
    r = run(
        ["plan", "pocket.nc", "--job", "job_A_pocket.toml", "-o", "out", "--no-plots",
         "--no-html", "--no-refine"],
        tmp_path,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    (tmp_path / "old.nc").write_text("previous\n")
    with (tmp_path / "pocket.nc").open("a") as fh:
        fh.write("(edited)\n")
    r = run(["program", "out", "-o", "old.nc"], tmp_path)
    assert r.returncode == 2
    assert "changed since the plan" in r.stderr
    (tmp_path / "pocket.nc").unlink()
    r = run(["program", "out", "-o", "old.nc"], tmp_path)
    assert r.returncode == 2
    assert "source program pocket.nc is not found" in r.stderr
    assert (tmp_path / "old.nc").read_text() == "previous\n"


def test_plan_refuses_an_undefined_translation_before_planning(tmp_path) -> None:
    for name in ("pocket.nc", "job_A_pocket.toml"):
        shutil.copy(EX / name, tmp_path / name)
    r = run(
        ["plan", "pocket.nc", "--job", "job_A_pocket.toml", "-o", "out", "--no-plots",
         "--no-html", "--program-format", "rapid"],
        tmp_path,
    )  # fmt: skip
    assert r.returncode == 2
    assert "translation from gcode to 'rapid' is not defined" in r.stderr
    assert "robtargets" in r.stderr
    assert "Traceback" not in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_program_translates_gcode_to_apt(planned) -> None:
    r = run(["program", "out", "-o", "again.apt", "--program-format", "apt"], planned)
    assert r.returncode == 0, r.stderr
    a = read_toolpath(planned / "again.apt")
    b = read_toolpath(planned / "pocket.nc")
    cut_a = (a["motion"] == "cut").to_numpy()
    cut_b = (b["motion"] == "cut").to_numpy()
    pa = a[["x_m", "y_m", "z_m"]].to_numpy()[cut_a] * 1e3
    pb = b[["x_m", "y_m", "z_m"]].to_numpy()[cut_b] * 1e3
    assert len(pa) % len(pb) == 0  # the section once per pass, the last its own moves
    assert abs(pa[-len(pb) :] - pb).max() < 1e-6
