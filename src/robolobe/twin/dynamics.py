"""Joint-space mass matrix, bodies and gravity torques of the flexible-joint model.

The nominal model (docs/guide/robots.md): rigid links 1..6 plus the end
effector, elastic joints with diagonal stiffness ``K`` and viscous damping
``C`` on the controller axes q, motor side held fixed. ``K`` and ``C``, with
the optional compliances and the load-dependent stiffening, are assembled in
one place, :func:`robolobe.twin.system.nominal_system`. The mass matrix with
respect to q (i.e. through the robot's ``coupling``) is

    M(q) = sum_b m_b Jv_b^T Jv_b + Jw_b^T (R_b I_b R_b^T) Jw_b

over the bodies b, with ``Jv_b`` the world linear Jacobian of the body's
centre of mass, ``Jw_b`` its angular Jacobian, ``R_b`` its world rotation and
``I_b`` its inertia about the COM in its own frame.

The bodies and their Jacobians are kept as a :class:`BodySet`, so that
effects which add degrees of freedom (base compliance, link flexibility, a
tool mode) extend the Jacobians and the mass matrix follows from the same
sum (:mod:`robolobe.twin.effects`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.robots import Robot, frame_jacobians, link_frames
from robolobe.robots.kinematics import joint_angles

__all__ = [
    "GRAVITY_M_PER_S2",
    "BodySet",
    "gravity_torques",
    "mass_matrix",
    "robot_bodies",
]

FloatArray = NDArray[np.float64]

GRAVITY_M_PER_S2 = 9.81
"""Gravitational acceleration [m/s^2], along world -z."""


def _q(q: ArrayLike) -> FloatArray:
    arr = joint_angles(q)
    if not np.all(np.isfinite(arr)):
        raise InputError("q: expected finite joint angles, found inf or nan")
    return arr


@dataclass(frozen=True, eq=False)
class BodySet:
    """Rigid bodies of the model with their Jacobians at one or more postures.

    Attributes
    ----------
    names : tuple of str
        One per body (``"link1"``..``"link6"``, ``"end_effector"``, ...).
    mass_kg : ndarray, shape (nb,)
        Masses [kg].
    com_m : ndarray, shape (..., nb, 3)
        Centres of mass in the world [m].
    inertia_kgm2 : ndarray, shape (..., nb, 3, 3)
        Inertia tensors about the COM, world axes [kg m^2].
    jv : ndarray, shape (..., nb, 3, n)
        World linear velocity of each COM per unit DOF velocity.
    jw : ndarray, shape (..., nb, 3, n)
        World angular velocity of each body per unit DOF velocity.
    """

    names: tuple[str, ...]
    mass_kg: FloatArray
    com_m: FloatArray
    inertia_kgm2: FloatArray
    jv: FloatArray
    jw: FloatArray

    @property
    def n_dof(self) -> int:
        """Number of degrees of freedom (columns of the Jacobians)."""
        return int(self.jv.shape[-1])

    def mass_matrix(self) -> FloatArray:
        """``sum_b m_b Jv_b^T Jv_b + Jw_b^T I_b Jw_b``, shape (..., n, n)."""
        mv = np.einsum("b,...bki,...bkj->...ij", self.mass_kg, self.jv, self.jv)
        iw = self.inertia_kgm2 @ self.jw  # (..., nb, 3, n)
        mw = np.einsum("...bki,...bkj->...ij", self.jw, iw)
        out: FloatArray = mv + mw
        return 0.5 * (out + np.swapaxes(out, -1, -2))

    def with_columns(self, jv_new: FloatArray, jw_new: FloatArray) -> BodySet:
        """Append DOF columns to every body's Jacobians.

        Parameters
        ----------
        jv_new, jw_new : ndarray, shape (..., nb, 3, n_new)
        """
        return BodySet(
            names=self.names,
            mass_kg=self.mass_kg,
            com_m=self.com_m,
            inertia_kgm2=self.inertia_kgm2,
            jv=np.concatenate([self.jv, jv_new], axis=-1),
            jw=np.concatenate([self.jw, jw_new], axis=-1),
        )

    def with_body(
        self,
        name: str,
        mass_kg: float,
        com_m: FloatArray,
        inertia_kgm2: FloatArray,
        jv: FloatArray,
        jw: FloatArray,
    ) -> BodySet:
        """Append one body.

        Parameters
        ----------
        name : str
        mass_kg : float
        com_m : ndarray, shape (..., 3)
            World COM [m].
        inertia_kgm2 : ndarray, shape (..., 3, 3)
            Inertia about the COM, world axes [kg m^2].
        jv, jw : ndarray, shape (..., 3, n)
            Its Jacobians over all current DOFs.
        """
        batch = self.com_m.shape[:-2]
        n = self.n_dof

        def cat(old: FloatArray, new: FloatArray, shape: tuple[int, ...]) -> FloatArray:
            new_b = np.expand_dims(np.broadcast_to(new, (*batch, *shape)), len(batch))
            return np.concatenate([old, new_b], axis=len(batch))

        return BodySet(
            names=(*self.names, name),
            mass_kg=np.append(self.mass_kg, float(mass_kg)),
            com_m=cat(self.com_m, com_m, (3,)),
            inertia_kgm2=cat(self.inertia_kgm2, inertia_kgm2, (3, 3)),
            jv=cat(self.jv, jv, (3, n)),
            jw=cat(self.jw, jw, (3, n)),
        )


def robot_bodies(robot: Robot, q: ArrayLike, frames: FloatArray | None = None) -> BodySet:
    """Links 1..6 and the end effector with their COM Jacobians w.r.t. q.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    frames : ndarray, shape (..., 8, 4, 4), optional
        ``link_frames(robot, q)`` if already computed.

    Returns
    -------
    BodySet
        6 or 7 bodies (the end effector only if the robot has one), 6 DOFs.
    """
    return _bodies(robot, _q(q), frames, with_tcp=False)[0]


def bodies_and_tcp_jacobian(
    robot: Robot, q: ArrayLike, frames: FloatArray | None = None
) -> tuple[BodySet, FloatArray]:
    """:func:`robot_bodies` and the TCP origin's Jacobian in one kinematic pass.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    frames : ndarray, shape (..., 8, 4, 4), optional
        ``link_frames(robot, q)`` if already computed.

    Returns
    -------
    bodies : BodySet
    tcp_jacobian : ndarray, shape (..., 6, 6)
        World-frame ``[v; w]`` of the TCP origin (``point_jacobian(robot, q, 7)``).
    """
    bodies, tcp = _bodies(robot, _q(q), frames, with_tcp=True)
    assert tcp is not None
    return bodies, tcp


def _bodies(
    robot: Robot, qq: FloatArray, frames: FloatArray | None, *, with_tcp: bool
) -> tuple[BodySet, FloatArray | None]:
    fr = link_frames(robot, qq) if frames is None else frames
    bodies = [j.body for j in robot.joints]
    names = [f"link{i + 1}" for i in range(6)]
    pts = np.zeros((7, 3))
    for i, b in enumerate(bodies):
        pts[i] = b.com_m
    if robot.end_effector is not None:
        bodies.append(robot.end_effector)
        names.append("end_effector")
        pts[6] = robot.end_effector.com_m
    nb = len(bodies)
    # one pass over the kinematics: the seven COM points, then the TCP origin
    pts8 = np.vstack([pts, np.zeros((1, 3))]) if with_tcp else pts
    frame_of = np.arange(1, 9 if with_tcp else 8).clip(max=7)
    jac_all = frame_jacobians(robot, qq, pts8, point_frames=frame_of, frames=fr)
    jac = jac_all[..., :nb, :, :]  # (..., nb, 6, 6)
    rot = fr[..., 1 : nb + 1, :3, :3]  # frames 1..6 (links), 7 (TCP = end effector)
    com = (rot @ pts[:nb, :, None])[..., 0] + fr[..., 1 : nb + 1, :3, 3]
    inertia_local = np.stack([b.inertia_kgm2 for b in bodies])  # (nb, 3, 3)
    inertia = rot @ inertia_local @ np.swapaxes(rot, -1, -2)
    body_set = BodySet(
        names=tuple(names),
        mass_kg=np.array([b.mass_kg for b in bodies]),
        com_m=com,
        inertia_kgm2=inertia,
        jv=jac[..., :3, :],
        jw=jac[..., 3:, :],
    )
    return body_set, (jac_all[..., 7, :, :] if with_tcp else None)


def mass_matrix(robot: Robot, q: ArrayLike) -> FloatArray:
    """Joint-space mass matrix of links 1..6 and the end effector.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].

    Returns
    -------
    ndarray, shape (..., 6, 6)
        ``M(q)`` [kg m^2], with respect to q (through ``robot.coupling``),
        symmetric positive definite.
    """
    return robot_bodies(robot, q).mass_matrix()


def gravity_torques(robot: Robot, q: ArrayLike, bodies: BodySet | None = None) -> FloatArray:
    """Generalised gravity forces on the controller axes.

    ``tau_g = sum_b m_b Jv_b^T g`` with ``g = (0, 0, -9.81) m/s^2`` in the
    world: the torque gravity exerts on each axis (the gears hold
    ``-tau_g``), links 1..6 and the end effector.

    Parameters
    ----------
    robot : Robot
    q : array_like, shape (..., 6)
        Controller axis angles [rad].
    bodies : BodySet, optional
        ``robot_bodies(robot, q)`` if already computed (only its first six
        DOFs are used).

    Returns
    -------
    ndarray, shape (..., 6)
        [N m].
    """
    b = robot_bodies(robot, q) if bodies is None else bodies
    g = np.array([0.0, 0.0, -GRAVITY_M_PER_S2])
    force = b.mass_kg[:, None] * g  # (nb, 3)
    tau: FloatArray = np.einsum("bk,...bkj->...j", force, b.jv[..., :6])
    return tau
