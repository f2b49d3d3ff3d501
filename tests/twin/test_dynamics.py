"""Mass matrix, gravity torques: checked against independent finite-difference energies."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import Robot, link_frames, load_robot
from robolobe.twin.dynamics import (
    GRAVITY_M_PER_S2,
    gravity_torques,
    mass_matrix,
    robot_bodies,
)


def _bodies(robot: Robot):
    """(frame index, mass, com in frame, inertia in frame) of links 1..6 and the EE."""
    out = [
        (i + 1, j.body.mass_kg, j.body.com_m, j.body.inertia_kgm2)
        for i, j in enumerate(robot.joints)
    ]
    ee = robot.end_effector
    if ee is not None:
        out.append((7, ee.mass_kg, ee.com_m, ee.inertia_kgm2))
    return out


def _kinetic_energy_fd(robot: Robot, q: np.ndarray, qd: np.ndarray, h: float = 1e-6) -> float:
    """T = sum_b 1/2 m |v|^2 + 1/2 w^T I_world w from central differences of link_frames."""
    fp = link_frames(robot, q + h * qd)
    fm = link_frames(robot, q - h * qd)
    f0 = link_frames(robot, q)
    t = 0.0
    for k, m, c, inertia in _bodies(robot):
        p_plus = fp[k, :3, :3] @ c + fp[k, :3, 3]
        p_minus = fm[k, :3, :3] @ c + fm[k, :3, 3]
        v = (p_plus - p_minus) / (2 * h)
        r_dot = (fp[k, :3, :3] - fm[k, :3, :3]) / (2 * h)
        r0 = f0[k, :3, :3]
        w_hat = r_dot @ r0.T
        w = (
            np.array(
                [w_hat[2, 1] - w_hat[1, 2], w_hat[0, 2] - w_hat[2, 0], w_hat[1, 0] - w_hat[0, 1]]
            )
            / 2
        )
        i_world = r0 @ inertia @ r0.T
        t += 0.5 * m * v @ v + 0.5 * w @ i_world @ w
    return float(t)


def _random_coupling(rng: np.random.Generator) -> np.ndarray:
    c = np.eye(6)
    c[2, 1] = -1.0  # parallelogram-like
    c[4, 3] = 0.3
    c += 0.1 * rng.normal(size=(6, 6))
    return c


@pytest.fixture(scope="module", params=["A", "B", "C", "A-coupled"])
def robot(request: pytest.FixtureRequest) -> Robot:
    if request.param == "A-coupled":
        return load_robot("A").replace(coupling=_random_coupling(np.random.default_rng(5)))
    return load_robot(request.param)


def test_mass_matrix_matches_kinetic_energy(robot: Robot) -> None:
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = rng.uniform(-2.5, 2.5, 6)
        qd = rng.normal(size=6)
        m = mass_matrix(robot, q)
        t_model = 0.5 * qd @ m @ qd
        t_fd = _kinetic_energy_fd(robot, q, qd)
        # central differences: O(h^2) truncation, O(eps/h) rounding ~ 1e-9 relative
        assert t_model == pytest.approx(t_fd, rel=1e-7)


def test_mass_matrix_symmetric_positive_definite(robot: Robot) -> None:
    q = np.random.default_rng(2).uniform(-3, 3, (20, 6))
    m = mass_matrix(robot, q)
    assert m.shape == (20, 6, 6)
    np.testing.assert_array_equal(m, np.swapaxes(m, -1, -2))
    assert np.all(np.linalg.eigvalsh(m) > 0)


def test_mass_matrix_batches_like_single_postures() -> None:
    r = load_robot("B")
    q = np.random.default_rng(3).uniform(-2, 2, (2, 3, 6))
    m = mass_matrix(r, q)
    assert m.shape == (2, 3, 6, 6)
    np.testing.assert_allclose(m[1, 2], mass_matrix(r, q[1, 2]), rtol=1e-13, atol=1e-10)


def test_end_effector_adds_its_own_term() -> None:
    r = load_robot("C")
    bare = r.replace(end_effector=None)
    q = np.array([0.2, 0.3, -0.4, 0.5, 0.6, -0.7])
    assert len(robot_bodies(bare, q).names) == 6
    dm = mass_matrix(r, q) - mass_matrix(bare, q)
    # the end effector alone: positive semidefinite, rank <= 6, kinetic energy positive
    assert np.all(np.linalg.eigvalsh(dm) > -1e-9)
    qd = np.ones(6)
    assert qd @ dm @ qd > 0


def test_gravity_torque_is_minus_potential_gradient(robot: Robot) -> None:
    rng = np.random.default_rng(4)
    q = rng.uniform(-2, 2, 6)

    def potential(qq: np.ndarray) -> float:
        f = link_frames(robot, qq)
        return float(
            sum(
                m * GRAVITY_M_PER_S2 * (f[k, :3, :3] @ c + f[k, :3, 3])[2]
                for k, m, c, _ in _bodies(robot)
            )
        )

    h = 1e-6
    grad = np.array([(potential(q + h * e) - potential(q - h * e)) / (2 * h) for e in np.eye(6)])
    np.testing.assert_allclose(gravity_torques(robot, q), -grad, rtol=1e-6, atol=1e-4)


@pytest.mark.parametrize("q", [np.zeros(5), np.array([0, 0, 0, 0, 0, np.nan])])
def test_bad_postures_raise(q: np.ndarray) -> None:
    with pytest.raises(InputError, match="q"):
        mass_matrix(load_robot("A"), q)
