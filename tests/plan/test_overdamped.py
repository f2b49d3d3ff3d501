"""Planning on a robot whose wrist mode is overdamped at some postures (issue 15).

The example user robot (``examples/robots/my_robot.toml``) has a heavily damped
wrist: at about a fifth of its postures one joint mode is overdamped (two real
poles). The planner keeps such a mode (``overdamped="keep"``: the frequency and
damping ratio >= 1 of its real poles) instead of refusing the posture. The
truth here is the twin's receptance solved directly from ``(M, C, K)``
(:func:`robolobe.twin.frf.receptance`, ``J (K - w^2 M + i w C)^-1 J^T``), not from modes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.plan.modes import TwinSource
from robolobe.robots import load_robot
from robolobe.twin import Twin
from robolobe.twin.frf import receptance

EXAMPLE_ROBOT = Path(__file__).resolve().parents[2] / "examples" / "robots" / "my_robot.toml"


@pytest.mark.slow
def test_overdamped_postures_are_planned_on_their_real_poles():
    robot = load_robot(str(EXAMPLE_ROBOT))
    twin = Twin(robot)
    q = np.random.default_rng(1).uniform(robot.q_min, robot.q_max, (120, 6))
    over = np.isnan(twin.modes(q, overdamped="drop").f_hz).any(axis=-1)
    assert 10 <= over.sum() < 60  # the fixture has both kinds of posture
    rm = TwinSource(robot).predict(q)  # refused these postures before
    md = twin.modes(q, overdamped="keep")
    assert np.all(np.isfinite(md.f_hz))
    assert np.all(md.zeta[over].max(axis=-1) >= 1.0)
    assert np.all(md.zeta[~over] < 1.0)
    f = np.linspace(1.0, 1500.0, 1500)
    s = twin.system(q[over])
    exact = receptance(s.M, s.K, s.C, s.J, f)
    model = rm.model.frf(2 * np.pi * f)[over]
    # the most negative real part of each driving point (what sets a chatter limit):
    # model / exact measured 0.69-1.60 at the overdamped postures of 400 (seed 1;
    # below 1: the model would allow more depth than the exact receptance), no worse
    # than the real-mode model does at this robot's other postures (0.31-3.42: its
    # wrist's damping ratio is above 0.5 everywhere)
    for d in range(3):
        ratio = model[:, :, d, d].real.min(axis=1) / exact[:, :, d, d].real.min(axis=1)
        assert ratio.min() > 0.65, (d, ratio.min())
    # leaving the overdamped term out would change the model there
    keep = md.zeta < 1.0
    assert np.any(~keep[over])


@pytest.mark.slow
def test_a_plan_on_heavily_damped_twin_modes_says_so(tmp_path):
    """The example robot's wrist is heavily damped everywhere: the plan's notes say that
    the real-mode receptance can be off the twin's exact one; A's (damping <= 0.08) do not."""
    from robolobe.plan.job import load_job
    from robolobe.plan.pipeline import HEAVY_DAMPING, plan_path

    from .conftest import example

    job = load_job(example("job_A_pocket.toml"))
    heavy = plan_path(example("pocket.nc"), job.replace(robot=str(EXAMPLE_ROBOT)), refine=False)
    notes = " ".join(heavy.summary.notes)
    assert "heavily damped" in notes
    zeta = heavy.table.filter(like="zeta").to_numpy()
    assert f"up to {np.nanmax(zeta):.2f}" in notes
    assert np.nanmax(zeta) >= HEAVY_DAMPING
    plain = plan_path(example("pocket.nc"), job, refine=False)
    assert "heavily damped" not in " ".join(plain.summary.notes)
