"""Job files: the bundled jobs, round trip, clear errors naming the key."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict, job_to_toml, load_job
from robolobe.plan.pipeline import material_from_job

from .conftest import example

JOBS = ["job_A_pocket.toml", "job_B_contour.toml", "job_C_face_steel.toml", "job_A_slot_steel.toml"]


@pytest.mark.parametrize("name", JOBS)
def test_bundled_jobs_load_and_round_trip(tmp_path, name):
    job = load_job(example(name))
    assert job.robot in ("A", "B", "C")
    assert job.spindle.rpm_min < job.spindle.rpm_max
    p = tmp_path / "again.toml"
    p.write_text(job_to_toml(job), encoding="utf-8")
    back = load_job(p)
    for field in ("tool", "material", "cut", "spindle", "plan"):
        a, b = getattr(job, field), getattr(back, field)
        for k, v in vars(a).items():
            w = getattr(b, k)
            if isinstance(v, float):
                assert w == pytest.approx(v, rel=1e-9), (field, k)
            else:
                assert w == v, (field, k)
    assert np.allclose(back.placement, job.placement)
    assert back.tool_rotation_rad == pytest.approx(job.tool_rotation_rad)


def test_units_at_the_edge():
    job = load_job(example("job_A_pocket.toml"))
    assert job.tool.diameter_m == pytest.approx(0.020)
    assert job.cut.feed_per_tooth_m == pytest.approx(0.08e-3)
    assert job.cut.max_feed_m_per_s == pytest.approx(15.0 / 60.0)
    assert job.spindle.power_W == pytest.approx(15e3)
    assert job.plan.depth_max_m == pytest.approx(0.015)
    assert job.radial_immersion == pytest.approx(0.5)
    assert job.tool.helix_rad == pytest.approx(math.radians(30))
    # "xy" modes expand to one per direction
    assert [m.direction for m in job.tool.modes] == ["x", "y", "x", "y"]
    mat = material_from_job(job)
    assert mat.kt == pytest.approx(767.01e6)


def _base() -> dict:
    return tomllib.loads(example("job_A_pocket.toml").read_text(encoding="utf-8"))


@pytest.mark.parametrize(
    ("edit", "key", "what"),
    [
        (lambda d: d["spindle"].pop("power_kW"), "spindle.power_kW", "missing"),
        (lambda d: d["spindle"].update(power_kW=-3.0), "spindle.power_kW", "positive"),
        (lambda d: d["tool"].update(teeth=2.5), "tool.teeth", "integer"),
        (lambda d: d["cut"].update(milling="sideways"), "cut.milling", "one of"),
        (lambda d: d["tool"]["modes"][1].update(zeta=1.5), "tool.modes[2].zeta", "< 1"),
        (lambda d: d["spindle"].update(rpm_min=30000.0), "spindle", "rpm_min < rpm_max"),
        (lambda d: d["cut"].update(immersion=0.5), "cut", "exactly one"),
        (lambda d: d["plan"].update(max_rate_rpm_per_mm=5.0), "plan", "not both"),
        (lambda d: d["placement"].update(xyz_m=[1.0, 2.0]), "placement.xyz_m", "3 entries"),
        (lambda d: d.update(format="robolobe-job/9"), "format", "one of"),
        (lambda d: d["robot"].update(name="nonexistent.toml"), "robot.name", "no such file"),
        (lambda d: d["cut"].update(radial_width_mm=25.0), "cut.radial_width_mm", "at most"),
        (
            lambda d: d["material"].update(name=None) or d["material"].pop("name"),
            "material",
            "neither",
        ),
    ],
)
def test_errors_name_file_and_key(edit, key, what):
    d = _base()
    edit(d)
    with pytest.raises(InputError) as ei:
        job_from_dict(d, source="/some/dir/job.toml")
    msg = str(ei.value)
    assert msg.startswith(f"job.toml: {key}"), msg
    assert what in msg


def test_misspelt_keys_are_refused_with_did_you_mean():
    d = _base()
    d["tool"]["diamter_mm"] = 12.0
    with pytest.raises(
        InputError, match=r"^job\.toml: unknown key tool\.diamter_mm; did you mean 'diameter_mm'"
    ):
        job_from_dict(d, source="job.toml")
    # an optional key misspelt: would silently plan with the default safety factor
    d = _base()
    d["plan"] = {"safty_factor": 2.0}
    with pytest.raises(InputError, match=r"plan\.safty_factor; did you mean 'safety_factor'"):
        job_from_dict(d, source="job.toml")
    # a required key misspelt gets the hint too (not just "missing")
    d = _base()
    d["cut"]["feed_per_toth_mm"] = d["cut"].pop("feed_per_tooth_mm")
    with pytest.raises(InputError, match="did you mean 'feed_per_tooth_mm'"):
        job_from_dict(d, source="job.toml")
    # an unrelated extra key is allowed
    d = _base()
    d["comment"] = "second shift"
    job_from_dict(d, source="job.toml")


def test_toml_syntax_error_has_line(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text('format = "robolobe-job/1"\n[robot\nname = "A"\n', encoding="utf-8")
    with pytest.raises(InputError, match=r"^bad\.toml:2: TOML syntax error"):
        load_job(p)


def test_robot_and_model_files_relative_to_the_job(tmp_path):
    d = _base()
    (tmp_path / "robots").mkdir()
    (tmp_path / "robots" / "mine.toml").write_text("x = 1\n", encoding="utf-8")
    d["robot"]["name"] = "robots/mine.toml"
    d["robot"]["model"] = "twin"
    job = job_from_dict(d, source=str(tmp_path / "job.toml"), base_dir=tmp_path)
    assert job.robot == str(tmp_path / "robots" / "mine.toml")
    assert job.model == "twin"


def test_material_coefficients_without_name():
    d = _base()
    d["material"] = {"Kt_N_per_mm2": 2000.0, "Kr": 0.4}
    job = job_from_dict(d, source="job.toml")
    mat = material_from_job(job)
    assert mat.kt == pytest.approx(2e9)
    assert mat.kr == pytest.approx(0.4)


@pytest.mark.parametrize(
    ("section", "key", "value", "match"),
    [
        ("spindle", "rpm_max", 1e12, r"spindle\.rpm_max: expected a number <= 100000"),
        ("placement", "xyz_m", [1600.0, 0.0, 1200.0], r"placement\.xyz_m\[1\]: .*<= 50"),
        ("tool", "diameter_mm", 20000.0, r"tool\.diameter_mm: .*<= 500"),
        ("cut", "feed_per_tooth_mm", 80.0, r"cut\.feed_per_tooth_mm: .*<= 5"),
        ("spindle", "power_kW", 15000.0, r"spindle\.power_kW: .*<= 1000"),
    ],
)
def test_implausible_values_are_refused_with_the_key(section, key, value, match):
    d = _base()
    d.setdefault(section, {})[key] = value
    if section == "spindle" and key == "rpm_max":
        d["spindle"]["rpm_min"] = 6000.0
    with pytest.raises(InputError, match=match):
        job_from_dict(d, source="job.toml")
