"""Robot files with hostile values (hypothesis): refused in one line, or a sane robot.

Each example edits up to three numeric values of a shipped robot file the way
people get them wrong: a unit factor (mm for m, radians for degrees, N mm for
N m, kg mm^2 for kg m^2), a sign, zero, an extreme. The loader must either
refuse the file with one :class:`InputError` that names the file, or return a
robot whose twin has finite, positive natural frequencies; a robot whose
lowest mode lies outside 0.5-1000 Hz must at least have been warned about
(the warning the plan summary repeats). No other exception is allowed.
"""

from __future__ import annotations

import logging
import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from robolobe.errors import InputError

FUZZ = settings(
    max_examples=30,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
BIG = settings(FUZZ, max_examples=400)

FACTORS = [1000.0, 1e-3, 1e6, 180 / math.pi, math.pi / 180, -1.0, 0.0, 10.0]
EXTREMES = [1e300, -1e300, 1e-300, 0.0, -5.0, 1e12, 3.0]


def _text(robot: str) -> str:
    return resources.files("robolobe.data").joinpath("robots", f"{robot}.toml").read_text()


def _leaves(d: Any, path: tuple = ()) -> list[tuple]:
    """Key paths of every number in a parsed robot file."""
    out: list[tuple] = []
    if isinstance(d, dict):
        for k, v in d.items():
            out += _leaves(v, (*path, k))
    elif isinstance(d, list):
        for i, v in enumerate(d):
            out += _leaves(v, (*path, i))
    elif isinstance(d, int | float) and not isinstance(d, bool):
        out.append(path)
    return out


def _set(d: Any, path: tuple, value: float) -> None:
    for k in path[:-1]:
        d = d[k]
    d[path[-1]] = value


def _get(d: Any, path: tuple) -> float:
    for k in path:
        d = d[k]
    return float(d)


@st.composite
def edited(draw: st.DrawFn, robot: str) -> dict:
    d = tomllib.loads(_text(robot))
    leaves = _leaves(d)
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from(leaves))
        if draw(st.booleans()):
            value = _get(d, path) * draw(st.sampled_from(FACTORS))
        else:
            value = draw(st.sampled_from(EXTREMES))
        _set(d, path, value)
    if draw(st.booleans()):  # a whole column in the wrong unit (all joints)
        key = draw(st.sampled_from(["a_m", "d_m", "stiffness_Nm_per_rad", "damping_Nms_per_rad",
                                    "mass_kg", "q_min_deg", "alpha_deg"]))  # fmt: skip
        factor = draw(st.sampled_from(FACTORS))
        for j in d["joints"]:
            j[key] = j[key] * factor
    return d


def _check(tmp_path: Path, d: dict, caplog: pytest.LogCaptureFixture) -> None:
    from robolobe.robots import load_robot
    from robolobe.robots.plausibility import robot_findings
    from robolobe.twin.model import Twin

    f = tmp_path / "fz.toml"
    f.write_text(tomli_w.dumps(d), encoding="utf-8")
    caplog.clear()
    try:
        with caplog.at_level(logging.WARNING, logger="robolobe.robots.io"):
            robot = load_robot(f)
    except InputError as exc:
        msg = str(exc)
        assert msg.startswith(f"{f}"), msg
        assert "\n" not in msg, msg
        assert "np.float64" not in msg, msg
        return
    assert all(x.level == "warning" for x in robot_findings(robot))
    q = np.clip(0.5 * (robot.q_min + robot.q_max), -math.pi, math.pi)
    try:
        modes = Twin(robot).modes(q)
    except InputError as exc:
        refused = str(exc)
    else:
        refused = ""
    if refused:
        # an overdamped robot (heavy damping on a stiff, light joint) is refused
        # by the twin, in one line; the file check cannot see its modes
        assert "underdamped" in refused, refused
        assert caplog.records, f"refused by the twin without a warning: {refused}"
        return
    f_hz = np.asarray(modes.f_hz)
    assert np.all(np.isfinite(f_hz)), f_hz
    assert np.all(f_hz > 0), f_hz
    assert np.all(np.isfinite(modes.zeta)), modes.zeta
    if not 0.5 <= float(f_hz.min()) <= 1000.0:
        assert caplog.records, f"lowest mode {f_hz.min():.3g} Hz accepted without a warning"


@pytest.mark.parametrize("robot", ["A", "B"])
@FUZZ
@given(data=st.data())
def test_robot_values(tmp_path: Path, caplog, robot: str, data: st.DataObject) -> None:
    _check(tmp_path, data.draw(edited(robot)), caplog)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["A", "B", "C"])
@BIG
@given(data=st.data())
def test_robot_values_many(tmp_path: Path, caplog, robot: str, data: st.DataObject) -> None:
    _check(tmp_path, data.draw(edited(robot)), caplog)
