"""The updated model: robot.toml + effects.toml round trip."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.diagnose.updated_model import (
    effects_to_toml,
    load_updated_model,
    read_effects,
    write_updated_model,
)
from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.twin.effects import AddedMass, JointStiffness, SensorDelay, ToolMode
from robolobe.twin.model import Twin


def test_round_trip_gives_the_same_receptance(tmp_path: Path) -> None:
    r = load_robot("B")
    effects = (
        JointStiffness(joint=3, factor=0.8),
        AddedMass(mass_kg=4.0),
        ToolMode(f_hz=30.0, zeta=0.02, mass_kg=3.0, direction="x"),
        SensorDelay(delay_s=0.002),
    )
    out = write_updated_model(tmp_path / "upd", r, effects, note="test")
    twin = load_updated_model(out)
    # stage-0 effects are baked into the robot file, the others stay effects
    assert [e.name for e in twin.effects] == ["tool_mode", "sensor_delay"]
    assert twin.robot.stiffness[2] == pytest.approx(0.8 * r.stiffness[2])
    assert twin.robot.end_effector is not None
    q = np.radians([[0, 20, -70, 10, 40, 0]])
    f = np.arange(2.0, 40.0, 0.5)
    want = Twin(r, effects).receptance(q, f)
    got = twin.receptance(q, f)
    assert np.max(np.abs(got - want)) < 1e-9 * np.max(np.abs(want))


def test_read_effects_errors(tmp_path: Path) -> None:
    p = tmp_path / "effects.toml"
    with pytest.raises(InputError, match="no such file"):
        read_effects(p)
    p.write_text('format = "other/1"\n', encoding="utf-8")
    with pytest.raises(InputError, match="robolobe-effects/1"):
        read_effects(p)
    p.write_text(effects_to_toml([SensorDelay(0.001)]).replace("delay_s", "delay_ms"))
    with pytest.raises(InputError, match=r"effects\]\[0\]"):
        read_effects(p)
    p.write_text(effects_to_toml([SensorDelay(0.001)]))
    assert read_effects(p) == (SensorDelay(0.001),)


def test_calibrated_file_is_written_with_the_effects_on_top(tmp_path: Path) -> None:
    from robolobe.diagnose.calibration import FileParameters, calibration_candidate
    from robolobe.twin.params import apply_parameters

    r = load_robot("B")
    cand = calibration_candidate(r)
    p = np.ones(cand.n_params)
    p[1] = 0.85  # k2
    p[12] = 1.1  # m_ee
    (cal,) = cand.effects(p)
    assert isinstance(cal, FileParameters)
    tool = ToolMode(f_hz=63.0, zeta=0.03, mass_kg=10.0, direction="x", mass_in_file=True)
    out = write_updated_model(tmp_path / "upd", r, (cal, tool), note="file off + a mode")
    twin = load_updated_model(out)
    assert [e.name for e in twin.effects] == ["tool_mode"]  # the calibration is in robot.toml
    want_robot = apply_parameters(r, cal.groups, np.array(cal.theta))
    np.testing.assert_allclose(twin.robot.stiffness, want_robot.stiffness, rtol=1e-12)
    assert twin.robot.stiffness[1] == pytest.approx(0.85 * r.stiffness[1])
    ee, ee0 = twin.robot.end_effector, r.end_effector
    assert ee is not None
    assert ee0 is not None
    assert ee.mass_kg == pytest.approx(1.1 * ee0.mass_kg)
    q = np.radians([[0, 20, -70, 10, 40, 0]])
    f = np.arange(2.0, 80.0, 0.5)
    want = Twin(r, (cal, tool)).receptance(q, f)
    np.testing.assert_allclose(twin.receptance(q, f), want, rtol=1e-9, atol=1e-20)
