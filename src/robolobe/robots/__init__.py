"""Robots: description files, kinematics (FK, Jacobians), inverse kinematics, limits.

Public API (DESIGN.md): :class:`Robot` and its parts, :func:`load_robot`,
forward kinematics and Jacobians in :mod:`robolobe.robots.kinematics`.
"""

from robolobe.robots.io import load_robot, robot_from_dict, robot_to_toml, save_robot
from robolobe.robots.kinematics import (
    dh_angles,
    frame_jacobians,
    link_frames,
    point_jacobian,
    tcp_jacobian,
    tcp_pose,
)
from robolobe.robots.model import Joint, LinearConstraint, RigidBody, Robot, robots_allclose

__all__ = [
    "Joint",
    "LinearConstraint",
    "RigidBody",
    "Robot",
    "dh_angles",
    "frame_jacobians",
    "link_frames",
    "load_robot",
    "point_jacobian",
    "robot_from_dict",
    "robot_to_toml",
    "robots_allclose",
    "save_robot",
    "tcp_jacobian",
    "tcp_pose",
]
