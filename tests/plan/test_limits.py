"""Process limits: cutting speed, chip load, robot path speed (robolobe.plan.limits).

Every reference number is worked out here by hand from vc = pi D n / 1000
(D in mm, n in rpm, vc in m/min) and f_z = F / (S N); none is read back from
the code under test.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import robolobe as rl
from robolobe.cli.main import main
from robolobe.errors import InputError
from robolobe.plan.check import check_program
from robolobe.plan.job import job_from_dict, job_to_dict, load_job
from robolobe.plan.limits import binding_limit, binding_notes, process_limits
from robolobe.plan.paths import read_toolpath
from robolobe.plan.pipeline import constraints_from_job
from robolobe.robots.io import load_robot, robot_from_dict, robot_to_dict

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))


def _job(name: str, **cut: Any) -> rl.Job:
    d = job_to_dict(load_job(EX / f"{name}.toml"))
    for key, value in cut.items():
        section, _, k = key.partition("__")
        d[section][k] = value
    return job_from_dict(d, source=f"{name}.toml", base_dir=EX)


def _program(name: str) -> tuple[Any, np.ndarray]:
    wp = read_toolpath(EX / name)
    return wp, (wp["motion"] == "cut").to_numpy()


# ------------------------------------------------------------- cutting speed
def test_face_in_c45_no_longer_plans_above_the_steel_vc_max() -> None:
    # before: 7,202.8 rpm with the 25 mm cutter = pi 25 7202.8 / 1000 = 565.7 m/min
    assert math.pi * 25 * 7202.8 / 1000 == pytest.approx(565.7, abs=0.05)
    job = load_job(EX / "job_C_face_steel.toml")
    s = rl.plan_path(EX / "face.mod", job).summary.to_dict()
    vc_max = 300.0  # the material table's steel row (carbide)
    n_max = vc_max * 1000 / (math.pi * 25)  # 3819.7 rpm
    assert n_max == pytest.approx(3819.72, abs=0.01)
    assert s["rpm_max"] <= n_max + 0.1  # summary rounds to 0.1 rpm
    assert math.pi * 25 * s["rpm_max"] / 1000 <= vc_max + 0.01
    # the binding limit is named where it binds (the face in passes: stability); on the slot
    # in C45 (D16, vc_max 300 m/min = 5968 rpm) the vc limit, not the spindle's 12000 rpm
    assert any(n.startswith("binding limit") for n in s["notes"]), s["notes"]
    slot = rl.plan_path(EX / "slot.src", load_job(EX / "job_A_slot_steel.toml")).summary
    assert any(
        n.startswith("binding limit") and "vc_max 300 m/min" in n and "5968 rpm" in n
        for n in slot.notes
    ), slot.notes
    assert any("cutting speed kept within vc 100-300 m/min" in n for n in s["notes"])


def test_rpm_range_is_the_spindle_range_within_the_vc_range() -> None:
    job = load_job(EX / "job_A_slot_steel.toml")  # D16, spindle 1000-12000 rpm, steel
    lim = process_limits(job)
    assert lim.rpm_min == pytest.approx(100 * 1000 / (math.pi * 16))  # 1989.4 rpm
    assert lim.rpm_max == pytest.approx(300 * 1000 / (math.pi * 16))  # 5968.3 rpm
    assert lim.rpm_min_why.startswith("vc_min 100 m/min (material table: steel")
    cons = constraints_from_job(job, 2e9)
    assert (cons.rpm_min, cons.rpm_max) == (lim.rpm_min, lim.rpm_max)
    # aluminium, D20, spindle 6000-24000: vc 200-2500 m/min is 3183-39789 rpm, the spindle binds
    pocket = process_limits(load_job(EX / "job_A_pocket.toml"))
    assert (pocket.rpm_min, pocket.rpm_max) == (6000.0, 24000.0)
    assert pocket.rpm_max_why == "spindle.rpm_max 24000 rpm"
    # job keys override the table, each end on its own
    lim = process_limits(_job("job_A_slot_steel", cut__vc_max_m_per_min=150.0))
    assert lim.rpm_max == pytest.approx(150 * 1000 / (math.pi * 16))  # 2984.2 rpm
    assert lim.rpm_max_why.startswith("vc_max 150 m/min (cut.vc_max_m_per_min)")
    assert lim.vc_min_m_per_min == 100.0  # still the table's
    assert "vc_min from material table: steel" in lim.vc_source


def test_every_table_row_has_ranges_and_a_source() -> None:
    for m in rl.sld.material_table():
        assert m.vc_range_m_per_min is not None
        assert m.vc_range_m_per_min[0] > 0
        assert m.vc_range_m_per_min[0] < m.vc_range_m_per_min[1] <= 5000
        assert m.fz_range_mm is not None
        assert 0 < m.fz_range_mm[0] < m.fz_range_mm[1] < 1
        assert m.cutting_source


# ---------------------------------------------------------------- chip load
def test_pocket_program_chip_load_differs_from_the_job_and_is_kept() -> None:
    job = load_job(EX / "job_A_pocket.toml")  # feed_per_tooth_mm = 0.08, 3 flutes
    wp, cut = _program("pocket.nc")
    lim = process_limits(job, wp, cut, "pocket.nc")
    fz = 5400 / (18000 * 3)  # pocket.nc:12 F5400 at S18000: 0.1 mm
    assert fz == pytest.approx(0.1)
    assert lim.feed_per_tooth_source == "program"
    assert lim.feed_per_tooth_m == pytest.approx(fz * 1e-3)
    row = int(np.flatnonzero(wp["line"].to_numpy() == 12)[0])
    assert lim.fz_program_m[row] == pytest.approx(1e-4)
    assert np.isnan(lim.fz_program_m[~cut]).all()
    note = next(n for n in lim.notes if "chip load differs" in n)
    assert "cut.feed_per_tooth_mm 0.08 mm" in note
    assert "first pocket.nc:12" in note
    assert "F5400 / (S18000 x 3) = 0.1 mm" in note
    assert "the plan keeps the program's" in note
    cons = constraints_from_job(job, 7.67e8, lim)
    assert cons.feed_per_tooth_m == pytest.approx(1e-4)
    # told to keep the job's
    job2 = _job("job_A_pocket", cut__feed_per_tooth_from="job")
    lim2 = process_limits(job2, wp, cut, "pocket.nc")
    assert lim2.feed_per_tooth_source == "job"
    assert lim2.feed_per_tooth_m == pytest.approx(0.08e-3)
    assert any("the plan keeps the job's" in n for n in lim2.notes)


def test_several_chip_loads_plan_at_the_largest_and_agreeing_ones_say_nothing() -> None:
    job = load_job(EX / "job_A_pocket.toml")
    wp, cut = _program("pocket.nc")
    wp = wp.copy()
    lateral_rows = np.flatnonzero(cut)[5:]
    wp.loc[lateral_rows[0], "feed_mm_per_min"] = 7200.0  # 7200 / (18000 3) = 0.1333 mm
    lim = process_limits(job, wp, cut, "pocket.nc")
    assert lim.feed_per_tooth_m == pytest.approx(7200 / (18000 * 3) * 1e-3)
    assert any("2 chip loads" in n and "0.133 mm" in n for n in lim.notes), lim.notes
    # a program at the job's chip load (4320 / (18000 3) = 0.08 mm) draws no disagreement
    wp["feed_mm_per_min"] = np.where(wp["feed_mm_per_min"] == 5400.0, 4320.0, np.nan)
    lim = process_limits(job, wp, cut, "pocket.nc")
    assert lim.feed_per_tooth_m == pytest.approx(0.08e-3)
    assert not any("differs" in n for n in lim.notes)


def test_program_without_spindle_speed_keeps_the_job_chip_load() -> None:
    job = load_job(EX / "job_A_slot_steel.toml")  # slot.src: KRL, no S; F720; 4 flutes
    wp, cut = _program("slot.src")
    lim = process_limits(job, wp, cut, "slot.src")
    assert lim.feed_per_tooth_source == "job"
    assert lim.feed_per_tooth_m == pytest.approx(0.05e-3)
    assert np.isnan(lim.fz_program_m).all()
    # at the job's programmed_rpm 3000: 720 / (3000 4) = 0.06 mm, 300 / (3000 4) = 0.025 mm
    assert any("no chip load" in n and "0.025-0.06 mm" in n for n in lim.notes), lim.notes


def test_chip_load_outside_the_table_range_is_said() -> None:
    lim = process_limits(_job("job_C_face_steel", cut__feed_per_tooth_mm=0.3))
    assert any("0.3 mm per tooth, lies outside 0.03-0.15 mm" in n for n in lim.notes)


# ----------------------------------------------------------- path speed
def test_path_speed_from_the_job_the_robot_file_or_the_default() -> None:
    # the job's 15000 mm/min is below robot A's 2000 mm/s = 120000 mm/min
    lim = process_limits(load_job(EX / "job_A_pocket.toml"))
    assert lim.max_feed_m_per_s == pytest.approx(15000 / 6e4)
    assert lim.max_feed_why.startswith("cut.max_feed_mm_per_min 15000")
    # no job key: robot A's file
    slot = load_job(EX / "job_A_slot_steel.toml")
    assert slot.cut.max_feed_m_per_s is None
    lim = process_limits(slot)
    assert lim.max_feed_m_per_s == pytest.approx(2.0)
    assert "max_path_speed_mm_per_s 2000 mm/s" in lim.max_feed_why
    # neither: the stated default, 1 m/s = 60000 mm/min
    d = robot_to_dict(load_robot("A"))
    del d["max_path_speed_mm_per_s"]
    bare = robot_from_dict(d, "bare.toml")
    lim = process_limits(slot, robot=bare)
    assert lim.max_feed_m_per_s == pytest.approx(1.0)
    assert any("default 60000 mm/min" in n for n in lim.notes)
    # a job asking more than the robot follows: the robot's
    lim = process_limits(_job("job_A_slot_steel", cut__max_feed_mm_per_min=200000.0))
    assert lim.max_feed_m_per_s == pytest.approx(2.0)
    assert any("exceeds the robot's path speed" in n for n in lim.notes)


def test_robot_file_path_speed_round_trips_and_is_checked() -> None:
    d = robot_to_dict(load_robot("C"))
    assert d["max_path_speed_mm_per_s"] == 2000
    assert robot_from_dict(d, "c.toml").max_path_speed_m_per_s == pytest.approx(2.0)
    for bad in (0.0, -5.0, 1e6):
        d["max_path_speed_mm_per_s"] = bad
        with pytest.raises(InputError, match="max_path_speed_mm_per_s"):
            robot_from_dict(d, "c.toml")


# -------------------------------------------------------------- refusals
@pytest.mark.parametrize(
    ("cut", "match"),
    [
        # D25 at spindle.rpm_max 8000: pi 25 8000 / 1000 = 628.3 m/min at most
        (
            {"cut__vc_min_m_per_min": 700.0, "cut__vc_max_m_per_min": 900.0},
            r"cut\.vc_min_m_per_min: .*at most .* 628\.3 m/min",
        ),
        # at spindle.rpm_min 800: pi 25 800 / 1000 = 62.83 m/min at least
        (
            {"cut__vc_min_m_per_min": 30.0, "cut__vc_max_m_per_min": 50.0},
            r"cut\.vc_max_m_per_min: .*at least .* 62\.83 m/min",
        ),
        # the job's vc_min above the table's vc_max 300
        ({"cut__vc_min_m_per_min": 400.0}, r"cut\.vc_min_m_per_min: expected vc_min < vc_max"),
        # the table's vc_min 100 m/min needs 1273 rpm; a spindle of at most 1000 rpm gives 78.5
        (
            {"spindle__rpm_max": 1000.0},
            r"vc_min \(material table: steel, carbide; estimate\): .* 78\.54 m/min.*"
            r"cut\.vc_min_m_per_min to override",
        ),
        # 100 mm/min path speed; the lowest speed 1273.2 rpm x 0.06 mm x 4 = 305.6 mm/min
        ({"cut__max_feed_mm_per_min": 100.0}, r"cut\.max_feed_mm_per_min: .* 305\.6 mm/min"),
    ],
)
def test_contradictory_limits_are_refused_naming_the_key(cut: dict, match: str) -> None:
    job = _job("job_C_face_steel", **cut)
    with pytest.raises(InputError, match=match) as info:
        process_limits(job)
    assert str(info.value).startswith("job_C_face_steel.toml: ")
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("vc_min_m_per_min", 300.0, "vc_min_m_per_min < vc_max_m_per_min"),
        ("vc_min_m_per_min", -1.0, "vc_min_m_per_min"),
        ("vc_max_m_per_min", 0.0, "vc_max_m_per_min"),
        ("vc_max_m_per_min", 1e6, "vc_max_m_per_min"),
        ("feed_per_tooth_min_mm", 0.5, "feed_per_tooth_min_mm < feed_per_tooth_max_mm"),
        ("feed_per_tooth_max_mm", -0.1, "feed_per_tooth_max_mm"),
        ("feed_per_tooth_from", "cam", "feed_per_tooth_from"),
    ],
)
def test_bad_limit_keys_are_refused_at_load(key: str, value: Any, match: str) -> None:
    d = job_to_dict(load_job(EX / "job_C_face_steel.toml"))
    d["cut"].update({"vc_max_m_per_min": 300.0, "feed_per_tooth_max_mm": 0.2})
    d["cut"][key] = value
    with pytest.raises(InputError, match=match):
        job_from_dict(d, source="j.toml", base_dir=EX)


def test_zero_feed_or_speed_on_a_cutting_move_is_refused_with_file_line() -> None:
    job = load_job(EX / "job_A_pocket.toml")
    wp, cut = _program("pocket.nc")
    for col, word in (("feed_mm_per_min", "feed F"), ("rpm_programmed", "spindle speed S")):
        bad = wp.copy()
        bad.loc[5, col] = 0.0
        line = int(bad["line"].iloc[5])
        with pytest.raises(InputError, match=rf"pocket\.nc:{line}: expected a positive {word}"):
            process_limits(job, bad, cut, "pocket.nc")


def test_plan_with_unreachable_vc_exits_2_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = (EX / "job_C_face_steel.toml").read_text()
    job = tmp_path / "job.toml"
    job.write_text(
        text.replace("[cut]\n", "[cut]\nvc_min_m_per_min = 700.0\nvc_max_m_per_min = 900.0\n", 1)
    )
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as info:
        main(["plan", str(EX / "face.mod"), "--job", str(job), "-o", str(out)])
    err = capsys.readouterr().err
    assert info.value.code == 2, err
    assert "cut.vc_min_m_per_min" in err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err
    assert not out.exists() or not any(out.iterdir())


def test_job_keys_round_trip() -> None:
    job = _job(
        "job_A_pocket",
        cut__vc_min_m_per_min=250.0,
        cut__vc_max_m_per_min=1800.0,
        cut__feed_per_tooth_min_mm=0.04,
        cut__feed_per_tooth_max_mm=0.2,
        cut__feed_per_tooth_from="job",
    )
    assert job.cut.vc_range_m_per_s == pytest.approx((250 / 60, 1800 / 60))
    assert job.cut.feed_per_tooth_range_m == pytest.approx((0.04e-3, 0.2e-3))
    back = job_from_dict(job_to_dict(job), source="j.toml", base_dir=EX)
    assert back.cut == job.cut


# --------------------------------------------------------------- binding
def test_binding_notes_name_the_physical_limit() -> None:
    job = load_job(EX / "job_C_face_steel.toml")
    lim = process_limits(job)
    labels = ["rpm_max", "stability", "rpm_max", "plunge", "feed_max", "rpm_max", "power"]
    src = ["f.nc"] * len(labels)
    line = [10, 11, 12, 13, 14, 15, 16]
    notes = binding_notes(labels, src, line, lim, job)
    assert len(notes) == 4  # plunges left out
    assert notes[0].startswith("binding limit at 3 of 7 cutting waypoints (first f.nc:10)")
    assert "vc_max 300 m/min" in notes[0]
    # ties (1 each) in path order: stability (line 11), feed_max (14), power (16)
    assert "f.nc:11" in notes[1]
    assert "stability" in notes[1]
    assert "f.nc:14" in notes[2]
    assert "cut.max_feed_mm_per_min 6000" in notes[2]
    assert "f.nc:16" in notes[3]
    assert "spindle.power_kW" in notes[3]
    assert "spindle.rpm_min" not in binding_limit("rpm_min", lim, job)  # vc_min binds there
    assert binding_limit("rpm_min", lim, job).startswith("the lowest speed: vc_min 100 m/min")


# ------------------------------------------------------------------ check
def test_check_reports_vc_chip_load_and_path_speed_per_move() -> None:
    # face.mod (no S) checked at the old plan's 7203 rpm: pi 25 7203 / 1000 = 565.7 m/min
    res = check_program(EX / "face.mod", EX / "job_C_face_steel.toml", rpm=7203.0)
    t = res.table
    engaged = t["status"] != "air"
    assert (t.loc[engaged, "vc_check"] == "high").all()
    assert (t.loc[~engaged, "vc_check"] == "").all()
    assert t["vc_m_per_min"].iloc[0] == pytest.approx(math.pi * 25 * 7203 / 1000)
    s = res.summary
    assert s["out_of_range"]["vc_high"] == int(engaged.sum())
    assert s["limits"]["vc_m_per_min"] == [100.0, 300.0]
    # the link move MoveL ... v200 (12000 mm/min) is above the job's 6000 mm/min path speed
    fast = t["feed_mm_per_min"] > 6000
    assert fast.sum() == 1
    assert (t.loc[fast, "feed_check"] == "high").all()
    assert s["out_of_range"]["feed_high"] == 1
    first = s["out_of_range_first_at"]["vc_high"]
    assert any(f"first {first}: 565.7 m/min" in n for n in res.notes)
    # at 3000 rpm (the job's programmed speed): vc 235.6 m/min, inside 100-300
    res = check_program(EX / "face.mod", EX / "job_C_face_steel.toml", rpm=3000.0)
    assert res.summary["out_of_range"]["vc_high"] == 0
    assert set(res.table["vc_check"]) <= {"ok", ""}
