"""Small rigid-transform helpers (4x4 homogeneous matrices, ZYX angles).

Conventions: a pose is a 4x4 matrix ``[[R, p], [0, 1]]``; ZYX angles
``(a, b, c)`` give ``R = Rz(a) @ Ry(b) @ Rx(c)`` (docs/guide/robots.md; KUKA
A, B, C). All functions broadcast over leading dimensions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "inv_pose",
    "pose_from_xyz_zyx",
    "rot_x",
    "rot_y",
    "rot_z",
    "rotation_from_zyx",
    "skew",
    "xyz_zyx_from_pose",
    "zyx_from_rotation",
]

FloatArray = NDArray[np.float64]


def rot_x(angle: ArrayLike) -> FloatArray:
    """Rotation about x by ``angle`` [rad]; shape (..., 3, 3)."""
    t = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack(
        [np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2
    )


def rot_y(angle: ArrayLike) -> FloatArray:
    """Rotation about y by ``angle`` [rad]; shape (..., 3, 3)."""
    t = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack(
        [np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2
    )


def rot_z(angle: ArrayLike) -> FloatArray:
    """Rotation about z by ``angle`` [rad]; shape (..., 3, 3)."""
    t = np.asarray(angle, dtype=np.float64)
    c, s = np.cos(t), np.sin(t)
    o, z = np.ones_like(t), np.zeros_like(t)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def rotation_from_zyx(zyx_rad: ArrayLike) -> FloatArray:
    """``Rz(a) @ Ry(b) @ Rx(c)`` for ``zyx_rad = (..., [a, b, c])`` [rad]; shape (..., 3, 3)."""
    e = np.asarray(zyx_rad, dtype=np.float64)
    return rot_z(e[..., 0]) @ rot_y(e[..., 1]) @ rot_x(e[..., 2])


def zyx_from_rotation(rot: ArrayLike) -> FloatArray:
    """Inverse of :func:`rotation_from_zyx` (b in [-pi/2, pi/2]); shape (..., 3) [rad]."""
    r = np.asarray(rot, dtype=np.float64)
    b = np.arcsin(np.clip(-r[..., 2, 0], -1.0, 1.0))
    a = np.arctan2(r[..., 1, 0], r[..., 0, 0])
    c = np.arctan2(r[..., 2, 1], r[..., 2, 2])
    gimbal = np.abs(np.cos(b)) < 1e-12
    if np.any(gimbal):  # a and c rotate about the same axis: put it all into a
        a = np.where(gimbal, np.arctan2(-r[..., 0, 1], r[..., 1, 1]), a)
        c = np.where(gimbal, 0.0, c)
    return np.stack([a, b, c], -1)


def pose_from_xyz_zyx(xyz_m: ArrayLike, zyx_rad: ArrayLike) -> FloatArray:
    """Pose from a translation [m] and ZYX angles [rad]; shape (..., 4, 4)."""
    p = np.asarray(xyz_m, dtype=np.float64)
    rot = rotation_from_zyx(zyx_rad)
    shape = np.broadcast_shapes(p.shape[:-1], rot.shape[:-2])
    out = np.zeros((*shape, 4, 4))
    out[..., :3, :3] = rot
    out[..., :3, 3] = p
    out[..., 3, 3] = 1.0
    return out


def xyz_zyx_from_pose(pose: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Translation [m] and ZYX angles [rad] of a pose; shapes (..., 3) each."""
    t = np.asarray(pose, dtype=np.float64)
    return t[..., :3, 3].copy(), zyx_from_rotation(t[..., :3, :3])


def inv_pose(pose: ArrayLike) -> FloatArray:
    """Inverse of a rigid transform; shape (..., 4, 4)."""
    t = np.asarray(pose, dtype=np.float64)
    rt = np.swapaxes(t[..., :3, :3], -1, -2)
    out = np.zeros_like(t)
    out[..., :3, :3] = rt
    out[..., :3, 3] = -(rt @ t[..., :3, 3:4])[..., 0]
    out[..., 3, 3] = 1.0
    return out


def skew(v: ArrayLike) -> FloatArray:
    """Cross-product matrix ``[v]x`` with ``[v]x @ u = v x u``; shape (..., 3, 3)."""
    w = np.asarray(v, dtype=np.float64)
    z = np.zeros_like(w[..., 0])
    return np.stack(
        [
            np.stack([z, -w[..., 2], w[..., 1]], -1),
            np.stack([w[..., 2], z, -w[..., 0]], -1),
            np.stack([-w[..., 1], w[..., 0], z], -1),
        ],
        -2,
    )
