"""The parametrised-twin core :class:`robolobe.twin.params.BodyMassModel`, pinned.

Its mass matrix (moved centres of mass, scaled principal moments, mass
factors) and gravity torques against the twin's own assembly of a robot
file written with those bodies and read back by the loader: an
independent route (frame Jacobians at the new centres of mass, inertia
tensors rotated into the world).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import RigidBody, Robot, load_robot
from robolobe.robots.io import robot_to_toml
from robolobe.twin.dynamics import gravity_torques
from robolobe.twin.params import (
    COM_UNIT_M,
    PARAMETER_GROUPS,
    BodyMassModel,
    ParametrizedTwin,
    apply_parameters,
)
from robolobe.twin.seed_tables import SEED_TABLES
from robolobe.twin.system import nominal_system

COM = (0, 2, 3, 6)
MOMENTS = (1, 2, 6)


def _compliant_b() -> Robot:
    # tilt and mount DOFs move the bodies too: the core must carry their Jacobian columns
    r = (
        load_robot("B")
        .with_tilt(1, (2e7, 3e7), (900.0, 900.0))
        .with_tilt(4, (1e6, 2e6), (90.0, 90.0))
    )
    return r.with_mount((4e5, 5e5), (50.0, 50.0))


def _reloaded(robot: Robot, tmp_path: Path) -> Robot:
    path = tmp_path / "robot.toml"
    path.write_text(robot_to_toml(robot), encoding="utf-8")
    return load_robot(str(path))


def _with_bodies(robot: Robot, bodies: list[RigidBody]) -> Robot:
    import dataclasses

    joints = tuple(
        dataclasses.replace(jt, body=b) for jt, b in zip(robot.joints, bodies[:6], strict=True)
    )
    return robot.replace(joints=joints, end_effector=bodies[6])


def test_mass_matrix_and_gravity_equal_the_twin_of_the_written_robot_file(tmp_path: Path) -> None:
    robot = _compliant_b()
    q = SEED_TABLES["B"].postures_rad
    core = BodyMassModel(nominal_system(robot, q), com_bodies=COM, moment_bodies=MOMENTS)
    rng = np.random.default_rng(21)
    scales = np.exp(rng.normal(0.0, 0.3, 7))
    offsets = rng.uniform(-0.2, 0.2, (len(COM), 3))
    # smallest principal moment (eigh's order) scaled most: the bodies stay physical
    log_moments = -np.sort(-rng.uniform(-0.25, 0.25, (len(MOMENTS), 3)), axis=1)
    # the robot file with those bodies, built here from the file's own tensors
    bodies = [jt.body for jt in robot.joints]
    assert robot.end_effector is not None
    bodies.append(robot.end_effector)
    new = []
    for i, b in enumerate(bodies):
        com = b.com_m + (offsets[COM.index(i)] if i in COM else 0.0)
        inertia = b.inertia_kgm2
        if i in MOMENTS:
            lam, vec = np.linalg.eigh(inertia)
            inertia = vec @ np.diag(lam * np.exp(log_moments[MOMENTS.index(i)])) @ vec.T
            inertia = 0.5 * (inertia + inertia.T)
        new.append(RigidBody(b.mass_kg * scales[i], com, inertia * scales[i]))
    loaded = _reloaded(_with_bodies(robot, new), tmp_path)
    want = nominal_system(loaded, q)
    m = core.mass_matrix(scales, offsets, log_moments)
    assert m.shape == want.M.shape == (3, 6 + 4 + 2, 12)
    np.testing.assert_allclose(m, want.M, rtol=1e-9, atol=1e-9 * np.abs(want.M).max())
    tau = core.gravity_torques(scales, offsets)
    np.testing.assert_allclose(tau, gravity_torques(loaded, q), rtol=1e-9, atol=1e-9)
    # the file's bodies and its body frames
    np.testing.assert_allclose(core.coms(offsets), [new[i].com_m for i in COM], atol=1e-15)
    np.testing.assert_allclose(
        core.inertias(log_moments) * scales[list(MOMENTS), None, None],
        [new[i].inertia_kgm2 for i in MOMENTS],
        rtol=1e-12,
        atol=1e-12,
    )
    # nothing moved: the twin's own mass matrix
    ones = np.ones(7)
    np.testing.assert_allclose(
        core.mass_matrix(ones), nominal_system(robot, q).M, rtol=1e-12, atol=1e-12
    )


def test_parametrized_twin_equals_the_twin_of_the_file_apply_parameters_writes(
    tmp_path: Path,
) -> None:
    robot = _compliant_b()
    q = SEED_TABLES["B"].postures_rad
    groups = tuple(PARAMETER_GROUPS)
    theta = np.random.default_rng(3).normal(0.0, 0.3, sum(PARAMETER_GROUPS.values()))
    theta[-6:] = np.abs(theta[-6:])  # the load stiffening: >= 0 (the springs per posture)
    m, k, _ = ParametrizedTwin(robot, q, groups)._matrices(theta)
    want = nominal_system(_reloaded(apply_parameters(robot, groups, theta), tmp_path), q)
    np.testing.assert_allclose(m, want.M, rtol=1e-9, atol=1e-9 * np.abs(want.M).max())
    np.testing.assert_allclose(np.broadcast_to(k, want.K.shape), want.K, rtol=1e-12)


def test_seed_table_model_equals_the_twin_of_the_file_it_writes(tmp_path: Path) -> None:
    from robolobe.twin.calibration import SeedFitForm, _TableModel, seed_prior

    t = SEED_TABLES["C"]
    form = SeedFitForm(
        link_mass_bound=0.3, ee_mass_bound=0.3, load_joints=(1, 2), shape_bodies=(2, 3, 6)
    )
    model = _TableModel(seed_prior("C", load_robot("C")), t.postures_rad, form)
    x = model.physical(np.random.default_rng(8).uniform(0.5 * model.lower, 0.5 * model.upper))
    m, k = model.matrices(x)
    want = nominal_system(_reloaded(model.robot(x), tmp_path), t.postures_rad)
    np.testing.assert_allclose(m, want.M, rtol=1e-9, atol=1e-9 * np.abs(want.M).max())
    np.testing.assert_allclose(k, want.K, rtol=1e-9, atol=1e-6)


def test_derivatives_match_differences() -> None:
    robot = _compliant_b()
    q = SEED_TABLES["B"].postures_rad
    core = BodyMassModel(nominal_system(robot, q), com_bodies=COM, moment_bodies=MOMENTS)
    rng = np.random.default_rng(2)
    d = rng.uniform(-0.1, 0.1, (len(COM), 3))
    lm = rng.uniform(-0.2, 0.2, (len(MOMENTS), 3))
    dm, dtau = core.com_derivatives(slice(None), d)
    dml = core.moment_derivatives(slice(None), lm)
    # one posture and per unit of offset: the same numbers
    dm1, dtau1 = core.com_derivatives(1, d, COM_UNIT_M)
    np.testing.assert_allclose(dm1, COM_UNIT_M * dm[1], rtol=1e-12, atol=1e-12 * np.abs(dm).max())
    np.testing.assert_allclose(dtau1, COM_UNIT_M * dtau[1], rtol=1e-12, atol=1e-9)
    np.testing.assert_array_equal(core.moment_derivatives(2, lm), dml[2])
    for c, b in enumerate(COM):
        for k in range(3):
            fd = _central(lambda v: core.body_matrices(v, lm), d, c, k)
            np.testing.assert_allclose(fd[:, b], dm[:, c, k], atol=1e-7 * np.abs(dm).max())
            others = np.delete(fd, b, axis=1)
            assert np.abs(others).max() < 1e-7 * np.abs(dm).max()
            fg = _central(core.body_gravity, d, c, k)
            np.testing.assert_allclose(fg[:, b], dtau[:, c, k], atol=1e-6)
    for c, b in enumerate(MOMENTS):
        for k in range(3):
            fd = _central(lambda v: core.body_matrices(d, v), lm, c, k)
            np.testing.assert_allclose(fd[:, b], dml[:, c, k], atol=1e-7 * np.abs(dml).max())


def _central(f: Callable[[np.ndarray], np.ndarray], a: np.ndarray, c: int, k: int) -> np.ndarray:
    """Central difference of ``f`` at ``a`` along entry ``(c, k)``, step 1e-6."""
    h = 1e-6
    ap, an = a.copy(), a.copy()
    ap[c, k] += h
    an[c, k] -= h
    out: np.ndarray = (f(ap) - f(an)) / (2 * h)
    return out


@pytest.mark.parametrize(
    ("kw", "match"),
    [
        ({"com_bodies": (7,)}, "com_bodies"),
        ({"moment_bodies": (2, 2)}, "moment_bodies"),
        ({"com_bodies": (-1,)}, "com_bodies"),
    ],
)
def test_bad_bodies_are_refused(kw: dict[str, tuple[int, ...]], match: str) -> None:
    sys_ = nominal_system(load_robot("B"), SEED_TABLES["B"].postures_rad)
    with pytest.raises(InputError, match=match):
        BodyMassModel(sys_, **kw)


def test_offsets_of_the_wrong_shape_are_refused() -> None:
    sys_ = nominal_system(load_robot("B"), SEED_TABLES["B"].postures_rad)
    core = BodyMassModel(sys_, com_bodies=(0, 1))
    with pytest.raises(InputError, match=r"offsets_m: expected shape \(2, 3\)"):
        core.mass_matrix(np.ones(7), np.zeros((3, 3)))
