"""Robots: description files, kinematics (FK, Jacobians), inverse kinematics, limits.

The built-in robots "A" (KUKA KR 300 R2700-2), "B" (Comau NJ 650-2.7) and "C"
(ABB IRB 4400/60) and any user file of docs/guide/robots.md load with
:func:`load_robot`. Angles are radians; ``q`` are the controller's axis angles
(DH angles follow through ``Robot.coupling``).

Modules: :mod:`~robolobe.robots.model` (data model), :mod:`~robolobe.robots.io`
(files), :mod:`~robolobe.robots.kinematics` (FK, Jacobians),
:mod:`~robolobe.robots.ik` (inverse kinematics), :mod:`~robolobe.robots.limits`
(joint limits, constraints, sampling), :mod:`~robolobe.robots.transforms`.
"""

from robolobe.robots.ik import IKResult, ik, ik_batch, ik_numeric, nearest
from robolobe.robots.io import load_robot, robot_from_dict, robot_to_toml, save_robot
from robolobe.robots.kinematics import (
    dh_angles,
    frame_jacobians,
    link_frames,
    point_jacobian,
    tcp_jacobian,
    tcp_pose,
)
from robolobe.robots.limits import check_posture, sample_postures, within_limits
from robolobe.robots.model import Joint, LinearConstraint, RigidBody, Robot, robots_allclose

__all__ = [
    "IKResult",
    "Joint",
    "LinearConstraint",
    "RigidBody",
    "Robot",
    "check_posture",
    "dh_angles",
    "frame_jacobians",
    "ik",
    "ik_batch",
    "ik_numeric",
    "link_frames",
    "load_robot",
    "nearest",
    "point_jacobian",
    "robot_from_dict",
    "robot_to_toml",
    "robots_allclose",
    "sample_postures",
    "save_robot",
    "tcp_jacobian",
    "tcp_pose",
    "within_limits",
]
