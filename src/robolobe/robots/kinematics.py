"""Forward kinematics and geometric Jacobians (vectorized over postures).

Every function takes controller axis angles ``q`` [rad] of shape ``(..., 6)``
and broadcasts over the leading dimensions. DH angles are
``theta = coupling @ q + theta_offset`` (docs/guide/robots.md).

Frames (``link_frames``): index 0 = base (DH frame 0), 1..6 = DH frames 1..6
(6 = flange), 7 = TCP (flange @ tool). Link i's body is given in frame i.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.robots.model import Robot

__all__ = [
    "TCP_FRAME",
    "dh_angles",
    "frame_jacobians",
    "joint_angles",
    "joint_axes",
    "joint_transforms",
    "link_frames",
    "point_jacobian",
    "tcp_jacobian",
    "tcp_pose",
]

FloatArray = NDArray[np.float64]

TCP_FRAME = 7
"""Index of the TCP frame in :func:`link_frames`."""


def joint_angles(q: ArrayLike) -> FloatArray:
    """``q`` as a float array of joint angles, shape (..., 6) [rad].

    Raises
    ------
    InputError
        When the last axis does not hold six angles.
    """
    arr = np.asarray(q, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != 6:
        raise InputError(f"q: expected shape (..., 6) of joint angles [rad], found {arr.shape}")
    return arr


def dh_angles(robot: Robot, q: ArrayLike) -> FloatArray:
    """DH angles ``theta = coupling @ q + theta_offset`` [rad].

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].

    Returns
    -------
    ndarray, shape (..., 6)
    """
    return joint_angles(q) @ robot.coupling.T + robot.theta_offset


def joint_transforms(robot: Robot, theta: ArrayLike) -> FloatArray:
    """Transforms from DH frame i-1 to frame i for DH angles ``theta``.

    Parameters
    ----------
    robot : Robot
    theta : array_like, shape (..., 6)
        DH angles [rad] (not controller angles; see :func:`dh_angles`).

    Returns
    -------
    ndarray, shape (..., 6, 4, 4)
    """
    th = np.asarray(theta, dtype=np.float64)
    ct, st = np.cos(th), np.sin(th)
    ca, sa = np.cos(robot.alpha), np.sin(robot.alpha)
    a, d = robot.a, robot.d
    out = np.zeros((*th.shape, 4, 4))
    out[..., 3, 3] = 1.0
    if robot.convention == "standard-dh":
        # Rz(theta) Tz(d) Tx(a) Rx(alpha)
        out[..., 0, 0] = ct
        out[..., 0, 1] = -st * ca
        out[..., 0, 2] = st * sa
        out[..., 0, 3] = a * ct
        out[..., 1, 0] = st
        out[..., 1, 1] = ct * ca
        out[..., 1, 2] = -ct * sa
        out[..., 1, 3] = a * st
        out[..., 2, 1] = sa
        out[..., 2, 2] = ca
        out[..., 2, 3] = d
    else:
        # Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta) Tz(d)
        out[..., 0, 0] = ct
        out[..., 0, 1] = -st
        out[..., 0, 3] = a
        out[..., 1, 0] = st * ca
        out[..., 1, 1] = ct * ca
        out[..., 1, 2] = -sa
        out[..., 1, 3] = -sa * d
        out[..., 2, 0] = st * sa
        out[..., 2, 1] = ct * sa
        out[..., 2, 2] = ca
        out[..., 2, 3] = ca * d
    return out


def link_frames(robot: Robot, q: ArrayLike) -> FloatArray:
    """World poses of the base, DH frames 1..6 and the TCP.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].

    Returns
    -------
    ndarray, shape (..., 8, 4, 4)
        Index 0 = base, 1..6 = DH frames (6 = flange), 7 = TCP.
    """
    tj = joint_transforms(robot, dh_angles(robot, q))
    frames = [np.broadcast_to(robot.base, (*tj.shape[:-3], 4, 4))]
    cur = robot.base @ tj[..., 0, :, :]
    frames.append(cur)
    for i in range(1, 6):
        cur = cur @ tj[..., i, :, :]
        frames.append(cur)
    frames.append(cur @ robot.tool)
    return np.stack(frames, axis=-3)


def tcp_pose(robot: Robot, q: ArrayLike) -> FloatArray:
    """World pose of the TCP, shape (..., 4, 4)."""
    tj = joint_transforms(robot, dh_angles(robot, q))
    cur = robot.base @ tj[..., 0, :, :]
    for i in range(1, 6):
        cur = cur @ tj[..., i, :, :]
    return cur @ robot.tool


def joint_axes(robot: Robot, frames: FloatArray) -> tuple[FloatArray, FloatArray]:
    """World directions and points of the six joint axes.

    Parameters
    ----------
    robot : Robot
    frames : ndarray, shape (..., 8, 4, 4)
        Output of :func:`link_frames`.

    Returns
    -------
    z : ndarray, shape (..., 6, 3)
        Unit axis directions (positive DH angle = right-hand rotation about z).
    o : ndarray, shape (..., 6, 3)
        A point on each axis [m].
    """
    sl = slice(0, 6) if robot.convention == "standard-dh" else slice(1, 7)
    return frames[..., sl, :3, 2], frames[..., sl, :3, 3]


def frame_jacobians(
    robot: Robot,
    q: ArrayLike,
    points_m: ArrayLike | None = None,
    *,
    point_frames: ArrayLike | None = None,
    frames: FloatArray | None = None,
) -> FloatArray:
    """Geometric Jacobians of points fixed in frames 1..7, all at once.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    points_m : array_like, shape (m, 3), optional
        Points [m], row k fixed in frame ``point_frames[k]``; default: the
        origins of frames 1..7 (pass the link COMs to get the COM Jacobians).
    point_frames : array_like of int, shape (m,), optional
        Frame of each point, 1..6 = DH frames, 7 = TCP; default 1..7 (then
        ``m`` must be 7).
    frames : ndarray, shape (..., 8, 4, 4), optional
        ``link_frames(robot, q)`` if already computed.

    Returns
    -------
    ndarray, shape (..., m, 6, 6)
        World-frame ``[v; w]`` Jacobians with respect to q (coupling
        included); entry k belongs to point k.
    """
    if frames is None:
        frames = link_frames(robot, q)
    pts = np.zeros((7, 3)) if points_m is None else np.asarray(points_m, dtype=np.float64)
    fidx = np.arange(1, 8) if point_frames is None else np.asarray(point_frames, dtype=np.intp)
    if fidx.ndim != 1 or np.any((fidx < 1) | (fidx > 7)):
        raise InputError(f"point_frames: expected frame numbers 1..7, found {fidx.tolist()}")
    if pts.shape != (fidx.size, 3):
        raise InputError(f"points_m: expected shape ({fidx.size}, 3), found {pts.shape}")
    fr = frames[..., fidx, :, :]  # (..., m, 4, 4)
    p = (fr[..., :3, :3] @ pts[..., None])[..., 0] + fr[..., :3, 3]  # (..., 7, 3)
    z, o = joint_axes(robot, frames)  # (..., 6, 3)
    # lever[..., k, j] = p_k - o_j
    lever = p[..., :, None, :] - o[..., None, :, :]  # (..., m, 6, 3)
    zb = np.broadcast_to(z[..., None, :, :], lever.shape)
    jv = np.cross(zb, lever)
    # joint j (0-based) moves frame f iff j <= f - 1
    mask = (np.arange(6)[None, :] <= (fidx - 1)[:, None]).astype(np.float64)  # (m, 6)
    jt = np.empty((*lever.shape[:-1], 6))  # (..., m, 6, 6) as [k, j, row]
    jt[..., :3] = jv
    jt[..., 3:] = zb
    jt = jt * mask[..., None]
    j_theta = np.swapaxes(jt, -1, -2)  # (..., 7, 6 rows, 6 joints)
    return j_theta @ robot.coupling


def point_jacobian(
    robot: Robot, q: ArrayLike, frame: int, point_m: ArrayLike | None = None
) -> FloatArray:
    """Geometric Jacobian of a point fixed in one frame.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    frame : int
        1..6 = DH frames, 7 = TCP.
    point_m : array_like, shape (3,), optional
        The point [m] in ``frame`` (origin if omitted).

    Returns
    -------
    ndarray, shape (..., 6, 6)
        World-frame ``[v; w]``: rows 0-2 the point's linear velocity, rows 3-5
        the frame's angular velocity, per unit dq (coupling included).
    """
    if not 1 <= int(frame) <= 7:
        raise InputError(f"frame: expected 1..7, found {frame}")
    k = int(frame) - 1
    pts = np.zeros((7, 3))
    if point_m is not None:
        pt = np.asarray(point_m, dtype=np.float64)
        if pt.shape != (3,):
            raise InputError(f"point_m: expected shape (3,), found {pt.shape}")
        pts[k] = pt
    return frame_jacobians(robot, q, pts)[..., k, :, :]


def tcp_jacobian(
    robot: Robot, q: ArrayLike, expressed_in: Literal["world", "tcp"] = "tcp"
) -> FloatArray:
    """Geometric Jacobian ``[v; w]`` of the TCP.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    expressed_in : {"tcp", "world"}
        Axes the velocity is expressed in. The translational TCP Jacobian in
        the TCP frame (docs/guide/robots.md) is ``tcp_jacobian(r, q)[..., :3, :]``.

    Returns
    -------
    ndarray, shape (..., 6, 6)
    """
    if expressed_in not in ("world", "tcp"):
        raise InputError(f"expressed_in: expected 'world' or 'tcp', found {expressed_in!r}")
    jac = point_jacobian(robot, q, TCP_FRAME)
    if expressed_in == "world":
        return jac
    rt = np.swapaxes(tcp_pose(robot, q)[..., :3, :3], -1, -2)
    out = np.empty_like(jac)
    out[..., :3, :] = rt @ jac[..., :3, :]
    out[..., 3:, :] = rt @ jac[..., 3:, :]
    return out
