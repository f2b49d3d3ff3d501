"""A hostile robot file on every command that reads one: one line, exit 2, nothing written.

And a merely unusual one: planned, with the warning repeated in the plan summary.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path

import pytest
import tomli_w

from robolobe.cli.main import main
from robolobe.robots.io import builtin_path

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


def _robot(tmp_path: Path, edit, name: str = "r.toml") -> Path:
    d = tomllib.loads(builtin_path("A").read_text())
    edit(d)
    p = tmp_path / name
    p.write_text(tomli_w.dumps(d))
    return p


def _job(tmp_path: Path, robot: Path) -> Path:
    text = (EX / "job_A_pocket.toml").read_text()
    text = text.replace('name = "A"', f'name = "{robot}"', 1)
    assert str(robot) in text
    p = tmp_path / "job.toml"
    p.write_text(text)
    return p


def _mm(d: dict) -> None:
    for j in d["joints"]:
        j["a_m"] *= 1000
        j["d_m"] *= 1000


HOSTILE = {
    "ee-mass-1e300": (lambda d: d["end_effector"].update(mass_kg=1e300),
                      "end_effector.mass_kg: expected at most 10000 kg, found 1e300 kg"),
    "lengths-in-mm": (_mm, "[[joints]][1].a_m: expected a length of at most 20 m"),
    "stiffness-1e300": (lambda d: d["joints"][1].update(stiffness_Nm_per_rad=1e300),
                        "[[joints]][2].stiffness_Nm_per_rad: expected a joint stiffness of"),
    "load-stiffening-negative": (
        lambda d: d["joints"][1].update(load_stiffening_per_kNm=-0.5),
        "[[joints]][2].load_stiffening_per_kNm: expected a non-negative number, found -0.5"),
    "load-stiffening-1e3": (
        lambda d: d["joints"][1].update(load_stiffening_per_kNm=1e3),
        "[[joints]][2].load_stiffening_per_kNm: expected a number <= 100, found 1000"),
}  # fmt: skip

COMMANDS = {
    "simulate": ["simulate", "{r}", "-o", "{o}/sim", "--design", "random", "--n", "2"],
    "design-tests": ["design-tests", "{r}", "--n", "3", "-o", "{o}/p.csv"],
    "plan": ["plan", str(EX / "pocket.nc"), "--job", "{j}", "-o", "{o}/plan"],
    "compare": ["compare", str(EX / "pocket.nc"), "--job", str(EX / "job_A_pocket.toml"),
                "--robots", "A", "{r}", "-o", "{o}/cmp"],
    "transfer": ["transfer", "{o}/m.csv", "--robot", "{r}", "-o", "{o}/t.npz"],
}  # fmt: skip


@pytest.mark.parametrize("command", sorted(COMMANDS))
@pytest.mark.parametrize("case", sorted(HOSTILE))
def test_hostile_robot_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str, case: str
) -> None:
    edit, expected = HOSTILE[case]
    robot = _robot(tmp_path, edit)
    job = _job(tmp_path, robot)
    out = tmp_path / "out"
    out.mkdir()
    (out / "m.csv").write_text("posture_id\n")
    before = sorted(p.name for p in out.rglob("*"))
    argv = [a.format(r=robot, j=job, o=out) for a in COMMANDS[command]]
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err.strip()
    assert info.value.code == 2, err
    assert "\n" not in err, err
    assert err.startswith("error: "), err
    assert f"{robot.name}: {expected}" in err, err
    assert f"{robot.name}: {robot.name}" not in err, err  # no doubled prefix
    assert sorted(p.name for p in out.rglob("*")) == before, "something was written"


@pytest.mark.slow
def test_unusual_robot_is_planned_with_the_warning_in_the_summary(tmp_path: Path) -> None:
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import plan_path

    robot = _robot(tmp_path, lambda d: d["joints"][5].update(stiffness_Nm_per_rad=8e3))
    res = plan_path(EX / "pocket.nc", load_job(_job(tmp_path, robot)), refine=False)
    notes = res.summary.notes
    hit = [n for n in notes if "[[joints]][6].stiffness_Nm_per_rad" in n]
    assert hit, notes
    assert str(robot) in hit[0]
    assert "outside the usual joint stiffness" in hit[0]


def test_robot_warning_is_one_warning_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    robot = _robot(tmp_path, lambda d: d["joints"][5].update(stiffness_Nm_per_rad=8e3))
    capsys.readouterr()
    with pytest.raises(SystemExit):  # stops after the robot is read: no postures file
        main(["simulate", str(robot), "-o", str(tmp_path / "s"),
              "--postures", str(tmp_path / "none.csv")])  # fmt: skip
    main_lines = capsys.readouterr().err.strip().splitlines()
    assert main_lines[0] == (
        f"warning: {robot}: [[joints]][6].stiffness_Nm_per_rad: 8000 N m/rad is outside the "
        "usual joint stiffness of 10000 to 1e9 N m/rad"
    )
    assert main_lines[1].startswith("error: ")
    assert len(main_lines) == 2  # the warning once (no second handler, no bare copy)
