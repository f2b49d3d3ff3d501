"""A small version of the concealed-effect study (studies/diagnose_concealed.py).

Campaigns of robot B and of a user-style robot file, each with one effect at
a realistic (medium) magnitude concealed in the twin, plus null campaigns;
20 postures each, the seed's simulated hammer test. The issue's goals:
>= 90 % of effect campaigns named correctly, no false discovery on nulls,
held-out FRAC >= 0.98 after the correction.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robolobe.diagnose.concealed import run_study, standard_cases, study_tables

from robolobe.robots import load_robot, save_robot
from robolobe.robots.model import RigidBody


def _user_robot(tmp: Path) -> str:
    """A user-style robot file: robot A re-made as somebody's own arm."""
    a = load_robot("A")
    user = a.with_stiffness(a.stiffness * np.array([1.3, 0.9, 1.2, 0.8, 1.1, 1.0])).replace(
        name="user arm (test)",
        end_effector=RigidBody(35.0, [0.0, 0.0, -0.12], np.diag([0.4, 0.4, 0.1])),
    )
    path = tmp / "user_arm.toml"
    save_robot(user, path)
    return str(path)


@pytest.mark.slow
def test_small_concealed_study(tmp_path: Path) -> None:
    user = _user_robot(tmp_path)
    cases = standard_cases(
        ["B"],
        n_postures=20,
        magnitudes=["medium"],
        n_null=2,
        families=["added_mass", "joint_stiffness", "tool_mode", "sensor_delay", "base_compliance"],
    ) + standard_cases(
        [user],
        n_postures=20,
        magnitudes=["medium"],
        n_null=1,
        families=["added_mass", "joint_stiffness", "sensor_misalignment"],
    )
    assert len(cases) == 11
    results = run_study(cases)
    t = study_tables(results)
    df = t["cases"]
    eff = df[df["truth"] != "none"]
    nul = df[df["truth"] == "none"]
    assert eff["correct"].mean() >= 0.9, t["confusion"].to_string()
    assert not (nul["verdict"] != "none").any(), nul.to_string()
    ok = eff[eff["correct"]]
    assert (ok["frac_after"] >= 0.98).all(), ok.to_string()
    assert (ok["frac_after"] > ok["frac_before"]).all()
