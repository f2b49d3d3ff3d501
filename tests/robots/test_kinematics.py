"""Forward kinematics and Jacobians: hand computations, conventions, finite differences."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.robots import Robot, load_robot
from robolobe.robots.kinematics import (
    dh_angles,
    frame_jacobians,
    link_frames,
    point_jacobian,
    tcp_jacobian,
    tcp_pose,
)
from robolobe.robots.model import Joint, RigidBody

BODY = RigidBody(2.0, np.zeros(3), np.eye(3))


def _robot(convention, rows, coupling=None, offsets=None, tool=None, base=None) -> Robot:
    offsets = np.zeros(6) if offsets is None else np.radians(offsets)
    joints = tuple(
        Joint(a, np.radians(al), d, off, -7.0, 7.0, BODY, 1e6, 1e3)
        for (a, al, d), off in zip(rows, offsets, strict=True)
    )
    return Robot(
        "t",
        convention,
        joints,
        coupling=np.eye(6) if coupling is None else np.asarray(coupling, float),
        tool=np.eye(4) if tool is None else tool,
        base=np.eye(4) if base is None else base,
    )


def test_planar_arm_by_hand() -> None:
    # all axes parallel to z: a planar arm, TCP x/y by hand
    a = [0.5, 0.4, 0.3, 0.2, 0.1, 0.05]
    r = _robot("standard-dh", [(ai, 0.0, 0.1) for ai in a])
    q = np.array([0.3, -0.2, 0.5, 0.1, -0.4, 0.2])
    cum = np.cumsum(q)
    p = tcp_pose(r, q)
    assert p[0, 3] == pytest.approx(np.sum(np.asarray(a) * np.cos(cum)), abs=1e-12)
    assert p[1, 3] == pytest.approx(np.sum(np.asarray(a) * np.sin(cum)), abs=1e-12)
    assert p[2, 3] == pytest.approx(0.6, abs=1e-12)
    assert np.arctan2(p[1, 0], p[0, 0]) == pytest.approx(cum[-1], abs=1e-12)


def test_modified_dh_single_rows_by_hand() -> None:
    # modified DH row i: Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i)
    r = _robot("modified-dh", [(0.0, 0, 0.7), (0.3, -90, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0),
                               (0, 0, 0)])  # fmt: skip
    q = np.array([np.pi / 2, 0.0, 0, 0, 0, 0])
    f = link_frames(r, q)
    # frame 1 at (0, 0, 0.7) rotated 90 deg about z; frame 2 at a1 = 0.3 along x1 = world y
    np.testing.assert_allclose(f[1, :3, 3], [0, 0, 0.7], atol=1e-12)
    np.testing.assert_allclose(f[2, :3, 3], [0, 0.3, 0.7], atol=1e-12)
    # alpha1 = -90 deg: z2 = Rx(-90) z in frame 1 = +y1 = world -x
    np.testing.assert_allclose(f[2, :3, 2], [-1, 0, 0], atol=1e-12)


def test_base_and_tool_are_applied() -> None:
    r0 = load_robot("A")
    base = np.eye(4)
    base[:3, 3] = [1.0, 2.0, 0.5]
    base[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    r1 = r0.replace(base=base)
    q = np.radians([10, -80, 100, 20, 30, 40])
    np.testing.assert_allclose(tcp_pose(r1, q), base @ tcp_pose(r0, q), atol=1e-12)
    f = link_frames(r0, q)
    np.testing.assert_allclose(f[7], f[6] @ r0.tool, atol=1e-12)


def test_standard_and_modified_dh_describe_the_same_arm(rng: np.random.Generator) -> None:
    # robot B's geometry written in both conventions (same coupling/offsets)
    coupling = [[-1, 0, 0, 0, 0, 0], [0, 1, 0, 0, 0, 0], [0, -1, -1, 0, 0, 0],
                [0, 0, 0, -1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, -1]]  # fmt: skip
    offsets = [0, -90, -90, 0, 0, 180]
    std = _robot(
        "standard-dh",
        [
            (0.46, -90, 1.14),
            (1.05, 0, 0),
            (0.25, -90, 0),
            (0, 90, 1.205),
            (0, -90, 0),
            (0, 0, 0.282),
        ],
        coupling,
        offsets,
    )
    mod = load_robot("B").replace(tool=np.eye(4))
    q = rng.uniform(-2, 2, (200, 6))
    np.testing.assert_allclose(tcp_pose(std, q), tcp_pose(mod, q), atol=1e-12)


def test_dh_angles_use_coupling_and_offset() -> None:
    r = load_robot("B")
    q = np.radians([10, 20, -100, 30, 40, 50])
    th = np.degrees(dh_angles(r, q))
    np.testing.assert_allclose(th, [-10, 20 - 90, -(20 - 100) - 90, -30, 40, -50 + 180])


def test_batch_shapes() -> None:
    r = load_robot("C")
    q = np.zeros((4, 3, 6))
    assert link_frames(r, q).shape == (4, 3, 8, 4, 4)
    assert tcp_pose(r, q).shape == (4, 3, 4, 4)
    assert point_jacobian(r, q, 5, [0.1, 0, 0]).shape == (4, 3, 6, 6)
    assert tcp_jacobian(r, q).shape == (4, 3, 6, 6)
    assert frame_jacobians(r, q).shape == (4, 3, 7, 6, 6)
    with pytest.raises(ValueError, match="expected shape"):
        link_frames(r, np.zeros(5))


def _fd_jacobian(r: Robot, q: np.ndarray, frame: int, point: np.ndarray, h: float = 1e-6):
    def pose(qq):
        f = link_frames(r, qq)[frame]
        return f[:3, :3] @ point + f[:3, 3], f[:3, :3]

    _p0, r0 = pose(q)
    jac = np.zeros((6, 6))
    for j in range(6):
        dq = np.zeros(6)
        dq[j] = h
        pp, rp = pose(q + dq)
        pm, rm = pose(q - dq)
        jac[:3, j] = (pp - pm) / (2 * h)
        w = (rp - rm) / (2 * h) @ r0.T  # skew(omega)
        jac[3:, j] = [w[2, 1], w[0, 2], w[1, 0]]
    return jac


@pytest.mark.parametrize("frame", [1, 2, 3, 4, 5, 6, 7])
def test_point_jacobian_matches_finite_differences(
    builtin: Robot, frame: int, rng: np.random.Generator
) -> None:
    for _ in range(3):
        q = rng.uniform(-2.5, 2.5, 6)
        point = rng.uniform(-0.5, 0.5, 3)
        jac = point_jacobian(builtin, q, frame, point)
        np.testing.assert_allclose(jac, _fd_jacobian(builtin, q, frame, point), atol=2e-8)


def test_frame_jacobians_agree_with_point_jacobian(builtin: Robot, rng) -> None:
    q = rng.uniform(-2, 2, (5, 6))
    pts = rng.uniform(-0.3, 0.3, (7, 3))
    all_j = frame_jacobians(builtin, q, pts)
    for k in range(7):
        np.testing.assert_allclose(all_j[:, k], point_jacobian(builtin, q, k + 1, pts[k]),
                                   atol=1e-14)  # fmt: skip


def test_tcp_jacobian_frames(builtin: Robot, rng) -> None:
    q = rng.uniform(-2, 2, (10, 6))
    jw = tcp_jacobian(builtin, q, "world")
    jt = tcp_jacobian(builtin, q, "tcp")
    rot = tcp_pose(builtin, q)[:, :3, :3]
    np.testing.assert_allclose(rot @ jt[:, :3], jw[:, :3], atol=1e-12)
    np.testing.assert_allclose(rot @ jt[:, 3:], jw[:, 3:], atol=1e-12)
    with pytest.raises(ValueError, match="expressed_in"):
        tcp_jacobian(builtin, q, "flange")  # type: ignore[arg-type]


def test_parallelogram_coupling_in_jacobian() -> None:
    # For B, moving q2 alone keeps the forearm's absolute orientation (parallelogram):
    # the angular velocity of frames 3..7 has no q2 component.
    r = load_robot("B")
    q = np.radians([10, 20, -100, 30, 40, 50])
    for frame in (3, 4, 5, 6, 7):
        np.testing.assert_allclose(point_jacobian(r, q, frame)[3:, 1], 0.0, atol=1e-12)
    # while for A (serial) it does
    a = load_robot("A")
    assert np.linalg.norm(point_jacobian(a, np.radians([0, -90, 90, 0, 0, 0]), 7)[3:, 1]) > 0.9
