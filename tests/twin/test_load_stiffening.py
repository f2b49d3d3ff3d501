"""Load-dependent joint stiffness (robot-file key ``load_stiffening_per_kNm``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import link_frames, load_robot, robot_to_toml, robots_allclose
from robolobe.twin.model import Twin
from robolobe.twin.system import nominal_system

# seed Table 3 postures 1-3 of robot B [deg]
Q = np.radians(
    [[-2, 21, -27, 5, 1, -29], [-60, 50, -120, 115, -66, -197], [23, -28, -101, -82, 124, 168]]
)
S = np.array([0.0, 2e-4, 1e-4, 5e-4, 3e-4, 1e-3])  # [1/(N m)]


def _potential(robot, q: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    """Gravitational potential energy [J] from the link frames alone (no Jacobians)."""
    fr = link_frames(robot, q)
    v = 0.0
    bodies = [(i + 1, j.body) for i, j in enumerate(robot.joints)]
    bodies.append((7, robot.end_effector))
    for f, b in bodies:
        com = fr[f, :3, :3] @ b.com_m + fr[f, :3, 3]
        v += b.mass_kg * 9.81 * com[2]
    return v


def _torque_by_differences(robot, q: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    h = 1e-6
    out = np.zeros(6)
    for i in range(6):
        e = np.zeros(6)
        e[i] = h
        out[i] = -(_potential(robot, q + e) - _potential(robot, q - e)) / (2 * h)
    return out


def test_springs_stiffen_with_the_gravity_torque_from_the_potential_energy() -> None:
    b = load_robot("B")
    r = b.with_load_stiffening(S)
    k = np.diagonal(nominal_system(r, Q).K, axis1=-2, axis2=-1)
    for p, q in enumerate(Q):
        tau = _torque_by_differences(b, q)
        assert np.max(np.abs(tau[1:3])) > 1e3  # the postures load axes 2-3
        np.testing.assert_allclose(k[p], b.stiffness * (1 + S * np.abs(tau)), rtol=1e-6)
    # the frequencies move: stiffer joints, higher modes
    f0 = Twin(b).modes(Q).f_hz
    f1 = Twin(r).modes(Q).f_hz
    assert np.all(f1 >= f0 - 1e-9)
    assert np.max(f1 / f0) > 1.01


def test_without_the_key_the_springs_are_constant() -> None:
    for name in ("A", "B", "C"):
        r = load_robot(name)
        assert not r.has_load_stiffening
        k = nominal_system(r, Q).K
        np.testing.assert_array_equal(
            k[:, :6, :6], np.broadcast_to(np.diag(r.stiffness), (3, 6, 6))
        )


def test_file_round_trip_and_comparison(tmp_path: Path) -> None:
    r = load_robot("C").with_load_stiffening(S)
    p = tmp_path / "c.toml"
    p.write_text(robot_to_toml(r))
    assert "load_stiffening_per_kNm = 0.2" in p.read_text()  # 2e-4 per N m, kN m at the edge
    again = load_robot(p)
    assert robots_allclose(again, r)
    assert not robots_allclose(again, load_robot("C"))
    np.testing.assert_allclose(again.load_stiffening, S)


def test_negative_stiffening_is_refused_in_code() -> None:
    with pytest.raises(ValueError, match="load_stiffening_per_Nm"):
        load_robot("B").with_load_stiffening([0, -1e-4, 0, 0, 0, 0])


def test_the_six_spring_calibration_refuses_load_dependent_springs() -> None:
    from robolobe.twin.calibration import TARGETS, fit_stiffness

    r = load_robot("A").with_load_stiffening(S)
    with pytest.raises(InputError, match="load_stiffening"):
        fit_stiffness(r, Q[:1], TARGETS["A"])
