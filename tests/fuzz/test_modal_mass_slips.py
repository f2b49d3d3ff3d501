"""A modal stiffness in N/mm over a grid of (f, k): typed right it reads, 1000x off it is refused.

The grid is built from physical structures, not from the bounds under test:

- tool-point modes of a job's tool (D 16-25 mm at 45-60 mm): a steel or
  carbide bar (E 210-600 GPa, 0.8-1.0 D) in series with a holder and spindle of
  1e6-1e9 N/m, carrying 1/4 of the bar's mass up to a 5 kg spindle shaft; and
  modes that move the whole spindle (0.5-50 kg at the tip) on 1e5-5e8 N/m
  (a slip of a mode stiffer than about 1000 times the tool's own floor, some
  1e9 N/m, reads as the tool's bending mode: no bound can tell them apart);
- a robot's modes at the TCP: modal masses from the end effector's own
  effective mass at the TCP (worked out below by hand for robot A's 150 kg
  spindle) up to 100 times it, at 5-150 Hz; and the twin's own modes at
  sampled postures.

Every mode of the grid, 1000 times too soft, has a modal mass ``k / (2 pi f)^2``
1000 times too light: lighter than the spindle that carries it. The grid spans
stiffnesses of 1e5 to 1e9 N/m at 15 Hz to 10 kHz, where the old bounds (a
stiffness floor of 1e4-1e5 N/m) let the slip of every mode above 1e8 N/m through.
"""

from __future__ import annotations

import copy
import math
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from robolobe.errors import InputError

EX = Path(str(resources.files("robolobe.data").joinpath("examples")))
TWO_PI = 2.0 * math.pi


def _bar(d_m: float, length_m: float, e_pa: float) -> tuple[float, float]:
    """Stiffness [N/m] and mass [kg] of a round bar clamped at one end (rho 7850-14500)."""
    k = 3.0 * e_pa * (math.pi * d_m**4 / 64.0) / length_m**3
    return k, 7850.0 * math.pi * d_m**2 / 4.0 * length_m


def _tool_grid() -> list[tuple[float, float, float, float]]:
    """(diameter_m, stickout_m, f_hz, k) of plausible tool-point modes."""
    out = []
    for diameter, stickout in ((0.016, 0.05), (0.02, 0.06), (0.025, 0.045)):
        for share, e_pa in ((0.8, 2.1e11), (1.0, 6.0e11)):
            k_bar, m_bar = _bar(share * diameter, stickout, e_pa)
            for k_s in np.geomspace(1e6, 1e9, 7):
                k = 1.0 / (1.0 / k_bar + 1.0 / k_s)
                for m in np.geomspace(m_bar / 4.0, 5.0, 5):
                    out.append((diameter, stickout, math.sqrt(k / m) / TWO_PI, k))
        for m in np.geomspace(0.5, 50.0, 5):  # the spindle moves, on the robot or a bracket
            for k in np.geomspace(1e5, 5e8, 8):
                out.append((diameter, stickout, math.sqrt(k / m) / TWO_PI, float(k)))
    return out


TOOL_GRID = _tool_grid()


@pytest.fixture(scope="module")
def pocket() -> dict[str, Any]:
    from robolobe.plan.job import job_to_dict, load_job

    return job_to_dict(load_job(EX / "job_A_pocket.toml"))


def test_tool_grid_spans_the_old_gap() -> None:
    f = np.array([g[2] for g in TOOL_GRID])
    k = np.array([g[3] for g in TOOL_GRID])
    assert f.min() < 20.0
    assert f.max() > 5000.0
    assert k.max() > 2e8
    assert k.min() <= 1e5
    assert np.sum((k > 1e8) & (f < 1000.0)) >= 10  # stiff modes at low frequency


def test_tool_modes_typed_right_read_and_in_n_per_mm_are_refused(pocket: dict[str, Any]) -> None:
    from robolobe.plan.job import job_from_dict

    read, refused = 0, 0
    for diameter, stickout, f_hz, k in TOOL_GRID:
        d = copy.deepcopy(pocket)
        d["tool"].update(diameter_mm=1e3 * diameter, stickout_mm=1e3 * stickout)
        d["tool"]["modes"] = [{"dir": "xy", "f_hz": f_hz, "zeta": 0.03, "k_N_per_m": k}]
        job_from_dict(d, source="j.toml")
        read += 1
        d["tool"]["modes"][0]["k_N_per_m"] = k * 1e-3
        with pytest.raises(InputError, match=r"^j\.toml: tool\.modes\[1\]\.k_N_per_m: expected"):
            job_from_dict(d, source="j.toml")
        refused += 1
    assert read == refused == len(TOOL_GRID) == 3 * (2 * 7 * 5 + 5 * 8)


def test_robot_a_end_effector_mass_at_the_tcp() -> None:
    """By hand: A's spindle, 150 kg at c = (-0.017, 0, -0.313) m from the TCP.

    Pushed along y at the TCP, the body moves at ``1/m`` and turns at
    ``I^-1 (c x e_y)`` with ``c x e_y = (0.313, 0, -0.017)``; with the x-z block of
    the inertia [[2.44, -0.16], [-0.16, 1.25]] kg m^2 (det 3.0244, inverse
    [[1.25, 0.16], [0.16, 2.44]] / 3.0244) the mobility is
    1/150 + (1.25 * 0.313^2 - 2 * 0.16 * 0.313 * 0.017 + 2.44 * 0.017^2) / 3.0244
    = 0.0066667 + 0.040161 = 0.046828 /kg: 21.355 kg.
    """
    from robolobe.robots import load_robot

    robot = load_robot("A")
    assert robot.end_effector is not None
    assert robot.end_effector.mass_kg == 150.0
    m = robot.tcp_effective_mass_kg()
    assert m[1] == pytest.approx(1.0 / (1.0 / 150.0 + 0.12146 / 3.0244), rel=2e-4)
    assert m[1] == pytest.approx(21.355, abs=0.005)
    assert m[2] > 140.0  # along the spindle's axis it hardly turns


def _frame(rows: list[tuple[str, float, float]]) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {"posture_id": f"P{i}", "dir": d, "mode": 1, "f_hz": f, "zeta": 0.04, "k_N_per_m": k}
            for i, (d, f, k) in enumerate(rows)
        ]
    )


@pytest.mark.parametrize("name", ["A", "C"])
def test_robot_modes_typed_right_read_and_in_n_per_mm_are_refused(name: str) -> None:
    from robolobe.robots import load_robot
    from robolobe.tl.transfer import check_mode_masses

    robot = load_robot(name)
    m_ee = robot.tcp_effective_mass_kg()
    n = 0
    for j, d in enumerate(("xx", "yy", "zz")):
        for f in np.geomspace(5.0, 150.0, 6):
            for m in np.geomspace(m_ee[j], 100.0 * m_ee[j], 6):
                k = float(m * (TWO_PI * f) ** 2)
                check_mode_masses(_frame([(d, f, k)]), "modal.csv", robot)
                with pytest.raises(InputError, match=r"^modal\.csv: k_N_per_m \(posture_id P0"):
                    check_mode_masses(_frame([(d, f, k * 1e-3)]), "modal.csv", robot)
                n += 1
    assert n == 3 * 36


def test_the_twins_own_modes_read_and_their_slips_are_refused() -> None:
    """The twin's modes at sampled postures, as a campaign would measure them.

    A file in N/mm is refused whole (its lightest modes give it away); one value
    typed in N/mm is refused for every mode up to 100 times the end effector's
    mass. Heavier modes seen weakly along one direction (25 of the 194 rows
    here, 2e8-8e8 N/m at 7-21 Hz) read 1000 times softer as a plausible robot
    mode: no physical bound can tell those apart.
    """
    from robolobe.robots import load_robot
    from robolobe.tl.transfer import check_mode_masses
    from robolobe.twin.model import Twin

    robot = load_robot("B")
    m_ee = robot.tcp_effective_mass_kg()
    twin = Twin(robot)
    rng = np.random.default_rng(3)
    lo, hi = robot.q_min, robot.q_max
    postures = []
    for _ in range(12):
        modes = twin.modes(lo + (hi - lo) * (0.2 + 0.6 * rng.random(6)))
        rows = []
        for j, d in enumerate(("xx", "yy", "zz")):
            for r in range(6):
                k = float(modes.k_N_per_m[j, r])
                if math.isfinite(k) and k < 1e9:  # seen at the TCP
                    rows.append((d, float(modes.f_undamped_hz[r]), k))
        postures.append(rows)
    every = [row for rows in postures for row in rows]
    assert len(every) > 100
    check_mode_masses(_frame(every), "modal.csv", robot)
    for rows in postures:
        with pytest.raises(InputError, match="N/mm"):
            check_mode_masses(_frame([(d, f, k * 1e-3) for d, f, k in rows]), "modal.csv", robot)
    single = 0
    for d, f, k in every:
        if k / (TWO_PI * f) ** 2 <= 100.0 * m_ee["xyz".index(d[0])]:
            with pytest.raises(InputError, match="N/mm"):
                check_mode_masses(_frame([(d, f, k * 1e-3)]), "modal.csv", robot)
            single += 1
    assert single > 0.7 * len(every)


def test_on_the_robot_the_spindle_sets_the_floor(pocket: dict[str, Any]) -> None:
    """Robot A's spindle shows 21.35 kg at the tip (y): a mode that moves it is that heavy.

    The pocket tool's own floor is 903,688 N/m (test_tool_mode_floor); a mode at
    100 Hz of 2.5e5 N/m (6.3 kg) reads without a robot (a 0.5 kg spindle:
    197,392 N/m) but on A it would be lighter than 1/4 of A's spindle
    (5.34 kg: 2.1e6 N/m at 100 Hz) and softer than the tool: refused.
    """
    from robolobe.plan.job import check_tool_modes_on, job_from_dict
    from robolobe.robots import load_robot

    d = copy.deepcopy(pocket)
    d["tool"]["modes"] = [{"dir": "xy", "f_hz": 100.0, "zeta": 0.03, "k_N_per_m": 2.5e5}]
    job = job_from_dict(d, source="j.toml")
    with pytest.raises(
        InputError, match=r"^j\.toml: tool\.modes\[1\] \(x, 100 Hz\)\.k_N_per_m on robot"
    ):
        check_tool_modes_on(job.tool, load_robot("A"), "j.toml")
    d["tool"]["modes"][0]["k_N_per_m"] = 2.5e6  # 6.3 kg: the spindle on its mount
    check_tool_modes_on(job_from_dict(d, source="j.toml").tool, load_robot("A"), "j.toml")
