"""The assembled linear model of the twin at one or more postures.

:class:`SystemMatrices` is what :class:`robolobe.twin.model.Twin` builds for
a posture and what the structural effects (:mod:`robolobe.twin.effects`)
modify: the bodies with their Jacobians (the mass matrix follows from them),
the stiffness and damping matrices, and the Jacobian of the measured TCP
point. The first six DOFs are always the joint deflections on the
controller axes q1..q6 [rad]; the robot's optional compliances come next
(:func:`compliance_dofs`: ``tilt<i>x``, ``tilt<i>y`` per joint i with tilt
compliance, ``mount_x``, ``mount_y`` for a compliant end-effector mount,
small rotations [rad]); effects may append DOFs after them (their names in
``dof_names``, units in the effect's documentation).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.robots import Robot, link_frames
from robolobe.robots.kinematics import TCP_FRAME, joint_axes
from robolobe.twin.dynamics import BodySet, _q, bodies_and_tcp_jacobian, gravity_torques

__all__ = ["JOINT_DOFS", "SystemMatrices", "compliance_dofs", "load_stiffened", "nominal_system"]

FloatArray = NDArray[np.float64]

JOINT_DOFS = ("q1", "q2", "q3", "q4", "q5", "q6")
"""Names of the six joint-deflection DOFs (always first)."""


@dataclass(frozen=True, eq=False)
class SystemMatrices:
    """Mass, stiffness, damping and TCP Jacobian of the model at postures q.

    Attributes
    ----------
    robot : Robot
        The robot after robot-level effects (added mass, joint factors).
    q : ndarray, shape (..., 6)
        Controller axis angles [rad].
    frames : ndarray, shape (..., 8, 4, 4)
        ``link_frames(robot, q)``.
    bodies : BodySet
        Bodies and their Jacobians over all DOFs; ``M`` follows from them.
    K, C : ndarray, shape (..., n, n)
        Stiffness and viscous damping matrices.
    tcp_jv, tcp_jw : ndarray, shape (..., 3, n)
        World-axes linear velocity of the measured TCP point and angular
        velocity of the TCP frame, per unit DOF velocity.
    dof_names : tuple of str
        Names of the n DOFs (``q1``..``q6`` first).
    """

    robot: Robot
    q: FloatArray
    frames: FloatArray
    bodies: BodySet
    K: FloatArray
    C: FloatArray
    tcp_jv: FloatArray
    tcp_jw: FloatArray
    dof_names: tuple[str, ...]

    @property
    def n_dof(self) -> int:
        """Number of DOFs."""
        return len(self.dof_names)

    @cached_property
    def M(self) -> FloatArray:
        """Mass matrix, shape (..., n, n)."""
        return self.bodies.mass_matrix()

    @property
    def tcp_rotation(self) -> FloatArray:
        """World rotation of the TCP frame, shape (..., 3, 3)."""
        return self.frames[..., TCP_FRAME, :3, :3]

    @property
    def tcp_position(self) -> FloatArray:
        """World position of the TCP [m], shape (..., 3)."""
        return self.frames[..., TCP_FRAME, :3, 3]

    @property
    def J(self) -> FloatArray:
        """Translational TCP Jacobian in the TCP frame, shape (..., 3, n)."""
        return np.swapaxes(self.tcp_rotation, -1, -2) @ self.tcp_jv

    @property
    def Jw(self) -> FloatArray:
        """Angular TCP Jacobian in the TCP frame, shape (..., 3, n)."""
        return np.swapaxes(self.tcp_rotation, -1, -2) @ self.tcp_jw

    def replace(self, **changes: Any) -> SystemMatrices:
        """Copy with fields replaced (the mass matrix is recomputed if needed)."""
        return dataclasses.replace(self, **changes)

    def add_dofs(
        self,
        names: tuple[str, ...],
        body_jv: FloatArray,
        body_jw: FloatArray,
        tcp_jv: FloatArray,
        tcp_jw: FloatArray,
        stiffness: ArrayLike,
    ) -> SystemMatrices:
        """Append DOFs with their Jacobian columns and springs (no damping yet).

        Parameters
        ----------
        names : tuple of str
            Names of the new DOFs (m of them).
        body_jv, body_jw : ndarray, shape (..., nb, 3, m)
            New Jacobian columns of the existing bodies (world axes).
        tcp_jv, tcp_jw : ndarray, shape (..., 3, m)
            New columns of the TCP Jacobians (world axes).
        stiffness : array_like, shape (..., m)
            Spring of each new DOF (diagonal, in the DOF's units).

        Returns
        -------
        SystemMatrices
            The new DOFs have zero damping; see :meth:`with_dof_damping`.
        """
        batch = self.q.shape[:-1]
        m = len(names)
        n = self.n_dof
        bodies = self.bodies.with_columns(
            np.broadcast_to(body_jv, (*batch, *body_jv.shape[-3:])),
            np.broadcast_to(body_jw, (*batch, *body_jw.shape[-3:])),
        )
        k_new = np.broadcast_to(np.asarray(stiffness, dtype=np.float64), (*batch, m))
        big_k = np.zeros((*batch, n + m, n + m))
        big_k[..., :n, :n] = self.K
        big_k[..., n:, n:] = k_new[..., :, None] * np.eye(m)
        big_c = np.zeros_like(big_k)
        big_c[..., :n, :n] = self.C
        return self.replace(
            bodies=bodies,
            K=big_k,
            C=big_c,
            tcp_jv=np.concatenate([self.tcp_jv, np.broadcast_to(tcp_jv, (*batch, 3, m))], -1),
            tcp_jw=np.concatenate([self.tcp_jw, np.broadcast_to(tcp_jw, (*batch, 3, m))], -1),
            dof_names=(*self.dof_names, *names),
        )

    def with_dof_damping(self, first: int, zeta: float) -> SystemMatrices:
        """Dashpots ``c = 2 zeta sqrt(k_jj M_jj)`` on the diagonal of DOFs ``first..n-1``.

        Each DOF's own oscillator (the others held fixed) then has damping
        ratio ``zeta``; ``M_jj`` is taken at each posture.
        """
        idx = np.arange(first, self.n_dof)
        k = self.K[..., idx, idx]
        m = self.M[..., idx, idx]
        big_c = self.C.copy()
        big_c[..., idx, idx] = 2.0 * zeta * np.sqrt(k * m)
        return self.replace(C=big_c)


def compliance_dofs(mats: SystemMatrices) -> SystemMatrices:
    """Append the robot's optional tilt and mount compliances as DOFs.

    Each is a small rotation [rad] about a fixed axis through a point, which
    turns a set of bodies and (if distal) the TCP rigidly:

    * tilt of joint i (``Joint.tilt_stiffness_Nm_per_rad``): about DH axis
      x_i (perpendicular to the joint axis) and about ``z_joint x x_i``,
      through the joint's axis point; turns links i..6, the end effector and
      the TCP. These are the non-actuated rotational virtual joints of VJM
      stiffness models (bearing and gearbox tilt; Klimchik et al.,
      docs/references.md), DOFs ``tilt<i>x``, ``tilt<i>y``.
    * mount (``Robot.mount_stiffness_Nm_per_rad``): about the flange (DH frame
      6) x and y axes through its origin; turns the end effector and the TCP.
      DOFs ``mount_x``, ``mount_y``.

    Each DOF has its own spring and viscous damper (diagonal).

    Parameters
    ----------
    mats : SystemMatrices
        With the six joint DOFs only.

    Returns
    -------
    SystemMatrices
        ``mats`` itself if the robot has no optional compliance.
    """
    robot = mats.robot
    if robot.is_flexible_joint_only:
        return mats
    names = mats.bodies.names
    fr = mats.frames
    z, o = joint_axes(robot, fr)
    dof: list[str] = []
    axes: list[FloatArray] = []
    points: list[FloatArray] = []
    masks: list[NDArray[np.bool_]] = []
    k: list[float] = []
    c: list[float] = []
    for i in robot.tilt_joints:
        jt = robot.joints[i]
        assert jt.tilt_stiffness_Nm_per_rad is not None
        assert jt.tilt_damping_Nms_per_rad is not None
        u = fr[..., i + 1, :3, 0]  # DH x_(i+1): perpendicular to joint i+1's axis
        zi = z[..., i, :]
        u = u - np.sum(u * zi, axis=-1, keepdims=True) * zi
        u = u / np.linalg.norm(u, axis=-1, keepdims=True)
        distal = np.array(
            [nm == "end_effector" or (nm.startswith("link") and int(nm[4:]) >= i + 1)
             for nm in names]
        )  # fmt: skip
        for tag, a in (("x", u), ("y", np.cross(zi, u))):
            dof.append(f"tilt{i + 1}{tag}")
            axes.append(a)
            points.append(o[..., i, :])
            masks.append(distal)
        k += list(jt.tilt_stiffness_Nm_per_rad)
        c += list(jt.tilt_damping_Nms_per_rad)
    if robot.has_mount:
        assert robot.mount_stiffness_Nm_per_rad is not None
        assert robot.mount_damping_Nms_per_rad is not None
        ee = np.array([nm == "end_effector" for nm in names])
        for col, tag in ((0, "x"), (1, "y")):
            dof.append(f"mount_{tag}")
            axes.append(fr[..., 6, :3, col])
            points.append(fr[..., 6, :3, 3])
            masks.append(ee)
        k += list(robot.mount_stiffness_Nm_per_rad)
        c += list(robot.mount_damping_Nms_per_rad)
    a = np.stack(axes, axis=-1)  # (..., 3, m)
    p = np.stack(points, axis=-1)  # (..., 3, m)
    mask = np.stack(masks, axis=-1).astype(np.float64)  # (nb, m)
    lever = mats.bodies.com_m[..., :, :, None] - p[..., None, :, :]  # (..., nb, 3, m)
    a_b = np.broadcast_to(a[..., None, :, :], lever.shape)
    body_jv = np.cross(a_b, lever, axis=-2) * mask[:, None, :]
    body_jw = a_b * mask[:, None, :]
    tcp_lever = mats.tcp_position[..., :, None] - p  # (..., 3, m)
    tcp_jv = np.cross(a, tcp_lever, axis=-2)
    n_old = mats.n_dof
    out = mats.add_dofs(tuple(dof), body_jv, body_jw, tcp_jv, a, np.array(k))
    big_c = out.C.copy()
    idx = np.arange(n_old, out.n_dof)
    big_c[..., idx, idx] = np.array(c)
    return out.replace(C=big_c)


def load_stiffened(k: ArrayLike, s: ArrayLike, tau: ArrayLike) -> FloatArray:
    """Joint springs that stiffen with the gravity torque they hold.

    ``k (1 + s |tau|)``: the tangent stiffness of a reducer whose
    torsional-rigidity curve is soft near zero torque (lost motion, backlash
    closing) and stiffer under load: the shape of the torsional-rigidity
    curves in Harmonic Drive and RV reducer catalogues (segments K1 < K2 < K3
    from no load to rated torque, K3 about 1.5-3 x K1), and the "gravity /
    load-dependent gear stiffness" of docs/references.md: missing physics. The linear
    form is the simplest one a few postures can identify; the diagnosis
    effect :class:`robolobe.twin.effects.GravityStiffening` is the same law
    with one coefficient for several joints.

    Parameters
    ----------
    k : array_like, shape (..., 6)
        Springs at zero load [N m/rad].
    s : array_like, shape (..., 6)
        Stiffening per unit torque [1/(N m)], >= 0.
    tau : array_like, shape (..., 6)
        Gravity torque held by each axis [N m]
        (:func:`robolobe.twin.dynamics.gravity_torques`).

    Returns
    -------
    ndarray, shape (..., 6)
        [N m/rad].
    """
    kk = np.asarray(k, dtype=np.float64)
    out: FloatArray = kk * (1.0 + np.asarray(s, dtype=np.float64) * np.abs(tau))
    return out


def nominal_system(robot: Robot, q: ArrayLike) -> SystemMatrices:
    """The model of docs/guide/robots.md at postures q, with the robot's compliances.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].

    Returns
    -------
    SystemMatrices
        Six joint DOFs, ``K = diag(stiffness)`` (stiffened by the gravity
        torque where a joint has ``load_stiffening_per_Nm``,
        :func:`load_stiffened`), ``C = diag(damping)``, then the optional tilt
        and mount DOFs of :func:`compliance_dofs`.
    """
    qq = _q(q)
    batch = qq.shape[:-1]
    frames = link_frames(robot, qq)
    bodies, tcp = bodies_and_tcp_jacobian(robot, qq, frames)
    k = np.broadcast_to(robot.stiffness, (*batch, 6))
    if robot.has_load_stiffening:
        k = load_stiffened(k, robot.load_stiffening, gravity_torques(robot, qq, bodies))
    mats = SystemMatrices(
        robot=robot,
        q=qq,
        frames=frames,
        bodies=bodies,
        K=k[..., :, None] * np.eye(6),
        C=np.broadcast_to(np.diag(robot.damping), (*batch, 6, 6)).copy(),
        tcp_jv=tcp[..., :3, :],
        tcp_jw=tcp[..., 3:, :],
        dof_names=JOINT_DOFS,
    )
    return compliance_dofs(mats)
