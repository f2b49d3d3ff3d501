"""Robot files: loading, round trip, and error messages for broken files."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot, robot_to_toml, robots_allclose, save_robot
from robolobe.robots.io import builtin_path, robot_from_dict, robot_to_dict


def test_builtins_load_case_insensitive() -> None:
    for name in ("A", "b", "C"):
        r = load_robot(name)
        assert r.source == f"built-in {name.upper()}"
        assert len(r.joints) == 6
    assert load_robot("A").convention == "standard-dh"
    assert load_robot("B").convention == "modified-dh"


def test_builtin_masses_match_sources() -> None:
    # A: KUKA URDF links 1-6 = 874.8 kg (+ 150 kg spindle); B, C: seed Table 1 weights
    # (2450 kg, 1040 kg) minus the (scaled) base
    a = load_robot("A")
    assert sum(j.body.mass_kg for j in a.joints) == pytest.approx(874.8, abs=0.1)
    b = load_robot("B")
    assert sum(j.body.mass_kg for j in b.joints) == pytest.approx(2450 - 438.39 * 0.9455, abs=1)
    c = load_robot("C")
    assert sum(j.body.mass_kg for j in c.joints) == pytest.approx(1040 - 225.96 * 0.9039, abs=1)


def test_round_trip(builtin, tmp_path: Path) -> None:
    text = robot_to_toml(builtin)
    path = tmp_path / "r.toml"
    path.write_text(text)
    again = load_robot(path)
    assert robots_allclose(again, builtin)
    assert again.source == str(path)
    saved = save_robot(builtin, tmp_path / "sub" / "s.toml")
    assert robots_allclose(load_robot(saved), builtin)


def test_allclose_detects_differences() -> None:
    a = load_robot("A")
    assert not robots_allclose(a, a.with_stiffness(a.stiffness * 1.01))
    assert not robots_allclose(a, a.replace(end_effector=None))
    assert not robots_allclose(a, load_robot("C"))


def test_with_stiffness_and_damping() -> None:
    a = load_robot("A")
    k = np.arange(1.0, 7.0) * 1e5
    a2 = a.with_stiffness(k).with_damping(k / 100)
    np.testing.assert_array_equal(a2.stiffness, k)
    np.testing.assert_array_equal(a2.damping, k / 100)
    np.testing.assert_array_equal(a.stiffness, load_robot("A").stiffness)  # original untouched
    with pytest.raises(ValueError, match="shape"):
        a.with_stiffness(np.ones(5))
    assert not a.q_min.flags.writeable


# --------------------------------------------------------------- broken files
def _base() -> dict:
    import tomllib

    return tomllib.loads(builtin_path("A").read_text())


def _write(tmp_path: Path, d: dict, name: str = "bad.toml") -> Path:
    import tomli_w

    p = tmp_path / name
    p.write_text(tomli_w.dumps(d))
    return p


def _mutate_joint(i: int, key: str, value):
    def f(d):
        d["joints"][i][key] = value

    return f


def _del(path: tuple):
    def f(d):
        node = d
        for k in path[:-1]:
            node = node[k]
        del node[path[-1]]

    return f


def _set(path: tuple, value):
    def f(d):
        node = d
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = value

    return f


BROKEN = [
    (_mutate_joint(2, "stiffness_Nm_per_rad", -5.0),
     r"bad\.toml: \[\[joints\]\]\[3\]\.stiffness_Nm_per_rad: expected a positive number, found -5"),
    (_del(("joints", 1, "a_m")), r"\[\[joints\]\]\[2\]\.a_m: missing required key"),
    (_mutate_joint(0, "mass_kg", "heavy"),
     r"\[\[joints\]\]\[1\]\.mass_kg: expected a number, found 'heavy'"),
    (lambda d: d["joints"].pop(), r"bad\.toml: \[\[joints\]\]: expected exactly 6 joints, found 5"),
    (_mutate_joint(3, "inertia_kgm2", [1.0, 1.0, 5.0, 0.0, 0.0, 0.0]),
     r"\[\[joints\]\]\[4\]\.inertia_kgm2: expected a positive-definite"),
    (_mutate_joint(3, "inertia_kgm2", [1.0, 1.0, -1.0, 0.0, 0.0, 0.0]),
     r"\[\[joints\]\]\[4\]\.inertia_kgm2: expected a positive-definite"),
    (_mutate_joint(4, "inertia_kgm2", [1.0, 1.0, 1.0]),
     r"\[\[joints\]\]\[5\]\.inertia_kgm2: expected 6 entries, found 3"),
    (_set(("kinematics", "convention"), "craig"),
     r"kinematics\.convention: expected one of 'standard-dh' or 'modified-dh', found 'craig'"),
    (_set(("format",), "robolobe-robot/2"), r"format: expected one of 'robolobe-robot/1'"),
    (_del(("format",)), r"bad\.toml: format: missing required key"),
    (_mutate_joint(1, "q_min_deg", 10.0),
     r"\[\[joints\]\]\[2\]: expected q_min_deg < q_max_deg, found 10.0 >= -5.0"),
    (_set(("kinematics", "coupling"), [[1, 0, 0, 0, 0, 0]] * 6),
     r"kinematics\.coupling: expected an invertible 6x6 matrix"),
    (_set(("kinematics", "coupling"), [[1, 0, 0, 0, 0]] * 6),
     r"kinematics\.coupling\[1\]: expected 6 entries, found 5"),
    (_set(("tool", "xyz_m"), [0.0, 0.0]), r"tool\.xyz_m: expected 3 entries, found 2"),
    (_set(("end_effector", "com_m"), [0.0, 0.0, "x"]),
     r"end_effector\.com_m\[3\]: expected a number, found 'x'"),
    (_set(("kinematics", "constraints"), [{"coeffs": [0, 1, 1, 0, 0, 0], "min_deg": 5,
                                            "max_deg": -5}]),
     r"kinematics\.constraints\[1\]: expected min_deg < max_deg"),
    (_mutate_joint(5, "damping_Nms_per_rad", True),
     r"\[\[joints\]\]\[6\]\.damping_Nms_per_rad: expected a number, found true"),
    (_mutate_joint(0, "d_m", float("nan")), r"\[\[joints\]\]\[1\]\.d_m: expected a finite number"),
    (_del(("kinematics",)), r"kinematics: missing required key"),
    # optional compliances (tilt per joint, end-effector mount)
    (lambda d: d["joints"][1].update(tilt_stiffness_Nm_per_rad=[-1e7, 1e7],
                                     tilt_damping_Nms_per_rad=[10.0, 10.0]),
     r"\[\[joints\]\]\[2\]\.tilt_stiffness_Nm_per_rad\[1\]: "
     r"expected a positive number, found -10000000"),
    (lambda d: d["joints"][1].update(tilt_stiffness_Nm_per_rad=[1e7, 1e13],
                                     tilt_damping_Nms_per_rad=[10.0, 10.0]),
     r"\[\[joints\]\]\[2\]\.tilt_stiffness_Nm_per_rad\[2\]: "
     r"expected a number <= 1e12, found 10000000000000"),
    (lambda d: d["joints"][0].update(tilt_stiffness_Nm_per_rad=[1e7, 1e7]),
     r"\[\[joints\]\]\[1\]\.tilt_damping_Nms_per_rad: expected two numbers beside "
     r"tilt_stiffness_Nm_per_rad, found it missing"),
    (lambda d: d["joints"][2].update(tilt_stiffness_Nm_per_rad=[1e7],
                                     tilt_damping_Nms_per_rad=[1.0, 1.0]),
     r"\[\[joints\]\]\[3\]\.tilt_stiffness_Nm_per_rad: expected 2 entries, found 1"),
    (lambda d: d["joints"][2].update(tilt_stiffness_Nm_per_rad=[1e7, 1e7],
                                     tilt_damping_Nms_per_rad=[1.0, -1.0]),
     r"\[\[joints\]\]\[3\]\.tilt_damping_Nms_per_rad\[2\]: expected a non-negative number"),
    (lambda d: d["end_effector"].update(mount_stiffness_Nm_per_rad=[0.0, 1e6],
                                        mount_damping_Nms_per_rad=[1.0, 1.0]),
     r"end_effector\.mount_stiffness_Nm_per_rad\[1\]: expected a positive number, found 0"),
    (lambda d: d["end_effector"].update(mount_damping_Nms_per_rad=[1.0, 1.0]),
     r"end_effector\.mount_stiffness_Nm_per_rad: expected two numbers beside"),
    (lambda d: d["end_effector"].update(mass_kg=0.0, inertia_kgm2=[0.0] * 6,
                                        mount_stiffness_Nm_per_rad=[1e6, 1e6],
                                        mount_damping_Nms_per_rad=[1.0, 1.0]),
     r"end_effector\.mount_stiffness_Nm_per_rad: expected an end effector with mass"),
    # load-dependent joint stiffness
    (_mutate_joint(1, "load_stiffening_per_kNm", -0.1),
     r"\[\[joints\]\]\[2\]\.load_stiffening_per_kNm: expected a non-negative number"),
    (_mutate_joint(2, "load_stiffening_per_kNm", 500.0),
     r"\[\[joints\]\]\[3\]\.load_stiffening_per_kNm: expected a number <= 100"),
    (_mutate_joint(2, "load_stiffening_per_kNm", "soft"),
     r"\[\[joints\]\]\[3\]\.load_stiffening_per_kNm: expected a number, found 'soft'"),
]  # fmt: skip


@pytest.mark.parametrize(("mutate", "pattern"), BROKEN)
def test_broken_file_messages(tmp_path: Path, mutate, pattern: str) -> None:
    d = _base()
    mutate(d)
    path = _write(tmp_path, d)
    with pytest.raises(InputError, match=pattern) as info:
        load_robot(path)
    assert str(path) in str(info.value)
    assert "\n" not in str(info.value)


def test_toml_syntax_error_names_line(tmp_path: Path) -> None:
    p = tmp_path / "syn.toml"
    p.write_text('name = "x"\nformat = "robolobe-robot/1"\n[kinematics\nconvention = 1\n')
    with pytest.raises(InputError, match=re.escape(f"{p}:3: TOML syntax error")):
        load_robot(p)


def test_missing_file_and_unknown_builtin(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such file"):
        load_robot(tmp_path / "nope.toml")
    with pytest.raises(InputError, match="no such file"):
        load_robot("D")


def test_robot_from_dict_names_source() -> None:
    d = _base()
    d["joints"][0]["stiffness_Nm_per_rad"] = 0
    with pytest.raises(InputError, match=r"^lab\.toml: \[\[joints\]\]\[1\]\.stiffness"):
        robot_from_dict(d, "lab.toml")
    with pytest.raises(InputError, match="top level"):
        robot_from_dict([1, 2], "x.toml")  # type: ignore[arg-type]


def test_misspelt_keys_are_refused_and_extra_keys_allowed(tmp_path: Path) -> None:
    d = _base()
    d["joints"][2]["stifness_Nm_per_rad"] = 1.0  # typo of a known key
    with pytest.raises(
        InputError, match=r"\[\[joints\]\]\[3\]\.stifness_Nm_per_rad; did you mean 'stiffness_Nm"
    ):
        load_robot(_write(tmp_path, d, "typo.toml"))
    d = _base()
    d["tool"]["zxy_deg"] = [0, 0, 0]  # typo of an optional key: would be ignored silently
    with pytest.raises(InputError, match=r"tool\.zxy_deg; did you mean 'zyx_deg'"):
        load_robot(_write(tmp_path, d, "typo2.toml"))
    d = _base()
    d["comment"] = "lab robot 2"  # unrelated extra key: allowed
    r = load_robot(_write(tmp_path, d, "extra.toml"))
    assert r.joints[2].stiffness_Nm_per_rad == load_robot("A").joints[2].stiffness_Nm_per_rad


def test_optional_sections_default(tmp_path: Path) -> None:
    d = _base()
    del d["tool"], d["end_effector"], d["kinematics"]["base"], d["kinematics"]["coupling"]
    for j in d["joints"]:
        del j["theta_offset_deg"]
    r = load_robot(_write(tmp_path, d))
    np.testing.assert_array_equal(r.tool, np.eye(4))
    np.testing.assert_array_equal(r.coupling, np.eye(6))
    assert r.end_effector is None
    np.testing.assert_array_equal(r.theta_offset, 0.0)
    assert robot_to_dict(r)["kinematics"] == {"convention": "standard-dh"}


def test_example_user_robot_loads_and_round_trips(tmp_path: Path) -> None:
    example = Path(__file__).parents[2] / "examples" / "robots" / "my_robot.toml"
    r = load_robot(example)
    assert r.convention == "standard-dh"
    assert r.base[2, 3] == pytest.approx(0.3)
    p = tmp_path / "again.toml"
    p.write_text(robot_to_toml(r))
    assert robots_allclose(load_robot(p), r)
    assert "Example" in repr(r)
