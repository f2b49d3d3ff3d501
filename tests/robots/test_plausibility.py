"""Robot-file plausibility: unit mistakes refused with key, unit and expected range."""

from __future__ import annotations

import copy
import logging
import math
import tomllib
from pathlib import Path

import pytest
import tomli_w

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.robots.io import builtin_path
from robolobe.robots.plausibility import robot_findings, robot_warnings

EXAMPLE = Path(__file__).parents[2] / "examples" / "robots" / "my_robot.toml"


def _base(name: str = "A") -> dict:
    return tomllib.loads(builtin_path(name).read_text())


def _write(tmp_path: Path, d: dict, name: str = "r.toml") -> Path:
    p = tmp_path / name
    p.write_text(tomli_w.dumps(d))
    return p


def _joints(key: str, scale: float):
    def f(d: dict) -> None:
        for j in d["joints"]:
            j[key] = j[key] * scale

    return f


def _joint(i: int, **kv):
    def f(d: dict) -> None:
        d["joints"][i].update(kv)

    return f


def _ee(**kv):
    def f(d: dict) -> None:
        d["end_effector"].update(kv)

    return f


def _lengths_mm(d: dict) -> None:
    for j in d["joints"]:
        j["a_m"] *= 1000
        j["d_m"] *= 1000


def _limits_rad(d: dict) -> None:
    for j in d["joints"]:
        j["q_min_deg"] = math.radians(j["q_min_deg"])
        j["q_max_deg"] = math.radians(j["q_max_deg"])


def _one_key_rad(key: str):
    """Only ``key`` (q_min_deg or q_max_deg) of every joint written in radians."""

    def f(d: dict) -> None:
        for j in d["joints"]:
            j[key] = math.radians(j[key])

    return f


def _alpha_rad(d: dict) -> None:
    for j in d["joints"]:
        j["alpha_deg"] = math.radians(j["alpha_deg"])


def _massless(d: dict) -> None:
    for body in [*d["joints"], d["end_effector"]]:
        body["mass_kg"] = 0.0
        body["inertia_kgm2"] = [0.0] * 6


def _tiny(d: dict) -> None:  # lengths in km
    for j in d["joints"]:
        j["a_m"] /= 1000
        j["d_m"] /= 1000
    d["tool"]["xyz_m"] = [x / 1000 for x in d["tool"]["xyz_m"]]


# (mutation, pattern of the message after "file: "): every one names key, unit and range
REFUSED = [
    (_lengths_mm, r"\[\[joints\]\]\[1\]\.a_m: expected a length of at most 20 m "
                  r"\(metres, not mm\), found 330 m"),
    (_joint(2, d_m=1500.0), r"\[\[joints\]\]\[3\]\.d_m: expected a length of at most 20 m"),
    (_tiny, r"\[\[joints\]\]\.a_m/d_m: expected an arm reach .* of 0\.05 to 20 m, found 0\.003"),
    (_joint(1, stiffness_Nm_per_rad=1e300),
     r"\[\[joints\]\]\[2\]\.stiffness_Nm_per_rad: expected a joint stiffness of 100 to 1e11 "
     r"N m/rad, found 1e300 N m/rad"),
    (_joint(1, stiffness_Nm_per_rad=1e-3), r"stiffness_Nm_per_rad: expected a joint stiffness"),
    (_joint(0, stiffness_Nm_per_rad=0.0),
     r"\[\[joints\]\]\[1\]\.stiffness_Nm_per_rad: expected a positive number, found 0"),
    (_joint(0, stiffness_Nm_per_rad=float("nan")), r"stiffness_Nm_per_rad: expected a finite"),
    (_joint(0, stiffness_Nm_per_rad=-2e6), r"stiffness_Nm_per_rad: expected a positive number"),
    (_joints("damping_Nms_per_rad", 1000.0),
     r"\[\[joints\]\]\[1\]\.damping_Nms_per_rad: expected a damping of at most 64800 N m s/rad"),
    (_ee(mass_kg=1e300), r"end_effector\.mass_kg: expected at most 10000 kg, found 1e300 kg"),
    (_joint(3, mass_kg=2e5), r"\[\[joints\]\]\[4\]\.mass_kg: expected at most 100000 kg"),
    (_joint(1, inertia_kgm2=[6.26e6, 5.85e7, 5.73e7, 0.0, 0.0, 0.0]),
     r"\[\[joints\]\]\[2\]\.inertia_kgm2: expected components of at most 100000 kg m\^2 "
     r"\(kg m\^2, not kg mm\^2\)"),
    (_ee(inertia_kgm2=[2.0e4, 2.5e4, 1.2e4, 0.0, 0.0, 0.0], mass_kg=1.0),
     r"end_effector\.inertia_kgm2: expected a radius of gyration .* at most 10 m"),
    (_limits_rad, r"\[\[joints\]\]\.q_min_deg/q_max_deg: expected joint limits in degrees, "
                  r"found all within \+-12\.6 .*radians"),
    # robot A's q_max_deg in radians (3.229 ... 6.109) beside q_min_deg in degrees
    (_one_key_rad("q_max_deg"),
     r"\[\[joints\]\]\.q_max_deg: expected joint limits in degrees, found every q_max_deg "
     r"within \+-12\.6 \(largest 6\.109\) while q_min_deg reaches 350: radians\?"),
    # one joint in radians: +-pi, +-2 pi
    (_joint(5, q_min_deg=-math.pi, q_max_deg=math.pi),
     r"\[\[joints\]\]\[6\]\.q_min_deg: expected a joint limit in degrees, found -3\.142 "
     r"\(a multiple of pi/2 in radians: -180 deg\?\)"),
    # one side of a symmetric range in radians: -185 deg written as -3.229
    (_joint(0, q_min_deg=math.radians(-185.0)),
     r"\[\[joints\]\]\[1\]\.q_min_deg: expected a joint limit in degrees, found -3\.229: "
     r"q_max_deg = 185 in radians \(-185 deg\?\)"),
    (_joint(3, q_max_deg=2 * math.pi), r"\[\[joints\]\]\[4\]\.q_max_deg: .*found 6\.283"),
    (lambda d: d["tool"].update(zyx_deg=[0.0, math.pi / 2, 0.0]),
     r"tool\.zyx_deg: expected angles in degrees, found 1\.571 \(pi/2 or pi in radians"),
    (lambda d: d["kinematics"].update(base={"zyx_deg": [math.pi, 0.0, 0.0]}),
     r"kinematics\.base\.zyx_deg: expected angles in degrees, found 3\.142"),
    (_joint(5, q_min_deg=-1e5, q_max_deg=1e5),
     r"\[\[joints\]\]\[6\]: expected joint limits within \+-3600 deg"),
    (_alpha_rad, r"\[\[joints\]\]\.alpha_deg: expected angles in degrees, found -1\.571"),
    (_massless, r"\[\[joints\]\]\.mass_kg: expected moving masses .* at least 1 kg in total, "
                r"found 0 kg"),
    (_joint(1, tilt_stiffness_Nm_per_rad=[1e-2, 1e8], tilt_damping_Nms_per_rad=[10.0, 10.0]),
     r"\[\[joints\]\]\[2\]\.tilt_stiffness_Nm_per_rad\[1\]: expected a tilt stiffness of 100 to "
     r"1e12 N m/rad"),
    (_joint(1, tilt_stiffness_Nm_per_rad=[1e8, 1e8], tilt_damping_Nms_per_rad=[10.0, 1e9]),
     r"\[\[joints\]\]\[2\]\.tilt_damping_Nms_per_rad\[2\]: expected a damping of at most 3000000"),
    (_ee(mount_stiffness_Nm_per_rad=[1e6, 1e6], mount_damping_Nms_per_rad=[1e6, 10.0]),
     r"end_effector\.mount_damping_Nms_per_rad\[1\]: expected a damping of at most 30000"),
    (lambda d: d["tool"].update(xyz_m=[200.0, 0.0, 450.0]),
     r"tool\.xyz_m: expected a length of at most 20 m \(metres, not mm\), found 492\.4 m"),
    (lambda d: d["kinematics"].update(base={"xyz_m": [0.0, 0.0, 450.0]}),
     r"kinematics\.base\.xyz_m: expected a base position within \+-50 m"),
    (_joint(2, com_m=[0.0, 150.0, 0.0]), r"\[\[joints\]\]\[3\]\.com_m: expected a length"),
]  # fmt: skip


@pytest.mark.parametrize(("mutate", "pattern"), REFUSED)
def test_implausible_values_are_refused(tmp_path: Path, mutate, pattern: str) -> None:
    d = _base()
    mutate(d)
    path = _write(tmp_path, d)
    with pytest.raises(InputError, match=pattern) as info:
        load_robot(path)
    msg = str(info.value)
    assert msg.startswith(f"{path}: "), msg
    assert "\n" not in msg
    assert "np." not in msg
    assert "array(" not in msg


@pytest.mark.parametrize(
    ("name", "mutate", "pattern"),
    [
        # robot C: every q_max_deg > 0, so q_min_deg in radians still reads as min < max
        ("C", _one_key_rad("q_min_deg"),
         r"\[\[joints\]\]\.q_min_deg: expected joint limits in degrees, found every q_min_deg "
         r"within \+-12\.6 \(largest 6\.981\) while q_max_deg reaches 400"),
        ("B", lambda d: d["kinematics"]["constraints"][0].update(min_deg=-math.pi / 2, max_deg=1.2),
         r"kinematics\.constraints\[1\]\.min_deg/max_deg: expected angles in degrees, found "
         r"-1\.571"),
    ],
)  # fmt: skip
def test_degree_keys_in_radians_on_other_robots_are_refused(tmp_path, name, mutate, pattern):
    d = _base(name)
    mutate(d)
    path = _write(tmp_path, d)
    with pytest.raises(InputError, match=pattern) as info:
        load_robot(path)
    assert str(info.value).startswith(f"{path}: ")


WARNED = [
    (_joint(5, stiffness_Nm_per_rad=5e3),
     r"\[\[joints\]\]\[6\]\.stiffness_Nm_per_rad: 5000 N m/rad is outside the usual joint "
     r"stiffness of 10000 to 1e9 N m/rad"),
    (_joint(0, damping_Nms_per_rad=0.0), r"\[\[joints\]\]\[1\]\.damping_Nms_per_rad: 0 N m s/rad"),
    (_joint(0, damping_Nms_per_rad=2e4), r"heavy damping"),
    (_ee(mass_kg=3000.0, inertia_kgm2=[100.0, 100.0, 50.0, 0.0, 0.0, 0.0]),
     r"end_effector\.mass_kg: 3000 kg is unusually heavy"),
    (_joint(1, a_m=4.0), r"arm reach 6\.397 m .* outside the usual 0\.3 to 6 m"),
    # one joint that moves 6 degrees: possible (a near-locked axis), or radians
    (_joint(4, q_min_deg=-3.0, q_max_deg=3.0),
     r"\[\[joints\]\]\[5\]: joint range -3 to 3 deg: the axis hardly moves; if these are "
     r"radians, write degrees"),
]  # fmt: skip


@pytest.mark.parametrize(("mutate", "pattern"), WARNED)
def test_unusual_values_are_warned(tmp_path: Path, caplog, mutate, pattern: str) -> None:
    d = _base()
    mutate(d)
    path = _write(tmp_path, d)
    with caplog.at_level(logging.WARNING, logger="robolobe.robots.io"):
        robot = load_robot(path)
    logged = [r.getMessage() for r in caplog.records]
    assert any(m.startswith(f"{path}: ") for m in logged), logged
    import re

    assert any(re.search(pattern, m) for m in logged), logged
    # the same words for the plan summary, from the robot alone
    assert any(re.search(pattern, w) for w in robot_warnings(robot))


@pytest.mark.parametrize("name", ["A", "B", "C", str(EXAMPLE)])
def test_shipped_robots_are_plausible(name: str) -> None:
    robot = load_robot(name)
    assert robot_findings(robot) == []
    assert 0.3 <= robot.reach_m <= 6.0


def test_findings_of_code_built_robot_list_errors_first() -> None:
    a = load_robot("A")
    odd = a.with_stiffness(a.stiffness * [1, 1, 1, 1, 1, 1e-9]).with_damping(a.damping * 0)
    f = robot_findings(odd)
    assert f[0].level == "error"
    assert f[0].key == "[[joints]][6].stiffness_Nm_per_rad"
    assert {x.level for x in f[1:]} <= {"error", "warning"}
    assert sum(x.level == "warning" for x in f) == 6  # six undamped joints


def test_plausibility_needs_no_extra_copy_of_the_file(tmp_path: Path) -> None:
    """A round trip keeps a robot plausible (the writer emits SI like the reader)."""
    from robolobe.robots import robot_to_toml

    d = copy.deepcopy(_base("B"))
    p = _write(tmp_path, d)
    again = tmp_path / "again.toml"
    again.write_text(robot_to_toml(load_robot(p)))
    assert robot_findings(load_robot(again)) == []
