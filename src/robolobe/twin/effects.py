"""Optional physics effects that the nominal twin leaves out (docs/references.md: missing physics).

Each effect is a frozen dataclass with one to three physical parameters (and
perhaps a setting such as a joint index or a direction), a snake_case
``name``, and validation in ``__post_init__`` (:class:`~robolobe.errors.InputError`
on nonsense). Joint indices count from 1 (joint 2 is q2). Every effect acts
through exactly one of three hooks, called by :class:`robolobe.twin.model.Twin`:

``apply_robot(robot) -> robot``
    A posture-independent change of the robot description (stage 0):
    :class:`AddedMass`, :class:`JointStiffness`, :class:`JointDamping`.
``modify(mats) -> mats``
    A change of the assembled :class:`~robolobe.twin.system.SystemMatrices` at
    the postures: joint-level stiffness/damping (stage 1:
    :class:`GravityStiffening`, :class:`CoupledJointStiffness`; stage 2:
    :class:`FrictionDamping`), extra DOFs of the structure (stage 3:
    :class:`BaseCompliance`, :class:`LinkFlexibility`) and an attachment at
    the TCP (stage 4: :class:`ToolMode`).
``modify_frf(H, freq_hz) -> H``
    A change of the measured receptance (stage 5): :class:`SensorMisalignment`,
    :class:`SensorDelay`.

The twin applies effects by stage (stable within a stage), so the result
does not depend on the order they are listed in, except for the order of
extra DOFs. :func:`effect_to_dict` / :func:`effect_from_dict` serialise them.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar, Literal

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError
from robolobe.robots import RigidBody, Robot
from robolobe.robots.kinematics import joint_axes
from robolobe.robots.transforms import rotation_from_zyx, skew
from robolobe.twin.dynamics import gravity_torques
from robolobe.twin.modes import undamped_modes
from robolobe.twin.system import SystemMatrices, load_stiffened

__all__ = [
    "EFFECTS",
    "AddedMass",
    "BaseCompliance",
    "CoupledJointStiffness",
    "Effect",
    "FrictionDamping",
    "GravityStiffening",
    "HammerDirection",
    "JointDamping",
    "JointStiffness",
    "LinkFlexibility",
    "SensorDelay",
    "SensorGain",
    "SensorMisalignment",
    "ServoMode",
    "TcpOffset",
    "ToolMode",
    "effect_from_dict",
    "effect_to_dict",
    "link_bending_axes",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


# ------------------------------------------------------------- validation
def _num(effect: str, field: str, value: Any, lo: float, hi: float, unit: str) -> float:
    """A finite number in [lo, hi]; InputError naming the effect and field."""
    try:
        if isinstance(value, bool):
            raise TypeError
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{effect}.{field}: expected a number [{unit}], found {value!r}") from None
    if not (math.isfinite(x) and lo <= x <= hi):
        raise InputError(
            f"{effect}.{field}: expected {lo:g} <= value <= {hi:g} [{unit}], found {x:g}"
        )
    return x


def _pos(effect: str, field: str, value: Any, hi: float, unit: str) -> float:
    x = _num(effect, field, value, 0.0, hi, unit)
    if x <= 0.0:
        raise InputError(f"{effect}.{field}: expected a positive number [{unit}], found {x:g}")
    return x


def _joint(effect: str, field: str, value: Any, hi: int = 6) -> int:
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or not 1 <= value <= hi:
        raise InputError(f"{effect}.{field}: expected a joint number 1..{hi}, found {value!r}")
    return int(value)


def _vec3(
    effect: str, field: str, value: Any, unit: str, *, unit_norm: bool = False
) -> tuple[float, float, float]:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(
            f"{effect}.{field}: expected 3 numbers [{unit}], found {value!r}"
        ) from None
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{effect}.{field}: expected 3 finite numbers [{unit}], found {value!r}")
    if unit_norm:
        norm = float(np.linalg.norm(arr))
        if norm < 1e-9:
            raise InputError(f"{effect}.{field}: expected a non-zero direction, found {value!r}")
        arr = arr / norm
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _set(obj: Any, field: str, value: Any) -> None:
    object.__setattr__(obj, field, value)


# ------------------------------------------------------------------- base
class Effect:
    """Base of all effects (see the module docstring for the three hooks).

    Attributes
    ----------
    name : str
        Snake-case identifier used in files and by the diagnosis.
    stage : int
        Application order in the twin (0 robot, 1-2 joint matrices, 3 extra
        structural DOFs, 4 TCP attachment, 5 measurement).
    """

    name: ClassVar[str] = ""
    stage: ClassVar[int] = 0

    def apply_robot(self, robot: Robot) -> Robot:
        """Change the robot description (stage 0 effects); identity otherwise."""
        return robot

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Change the assembled matrices (stages 1-4); identity otherwise."""
        return mats

    def modify_frf(self, H: ComplexArray, freq_hz: FloatArray) -> ComplexArray:
        """Change the measured receptance (stage 5); identity otherwise.

        Parameters
        ----------
        H : ndarray, shape (..., n_freq, 3, 3), complex
        freq_hz : ndarray, shape (n_freq,)
        """
        return H

    def params(self) -> dict[str, Any]:
        """The effect's fields as plain Python values (tuples as lists)."""
        out: dict[str, Any] = {}
        for f in dataclasses.fields(self):  # type: ignore[arg-type]
            v = getattr(self, f.name)
            out[f.name] = list(v) if isinstance(v, tuple) else v
        return out


# ----------------------------------------------------------- stage 0
@dataclass(frozen=True)
class AddedMass(Effect):
    """A point mass rigidly fixed near the TCP (sensor, adapter, clamp).

    Merged into the robot's end effector (mass, COM and the parallel-axis
    inertia), so that it moves with every structural DOF. For a point mass at
    the TCP itself the receptance becomes ``H' = H (I - w^2 m H)^-1``
    (Sherman-Morrison-Woodbury), i.e. ``H / (1 - w^2 m H)`` in 1-D: all modes
    shift down, most where the TCP modal mass is small.

    Parameters
    ----------
    mass_kg : float
        Mass [kg], 0 < m <= 5000.
    offset_m : tuple of 3 floats
        Position in the TCP frame [m], each |component| <= 3 m.
    """

    name: ClassVar[str] = "added_mass"
    stage: ClassVar[int] = 0
    mass_kg: float = 1.0
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        _set(self, "mass_kg", _pos(self.name, "mass_kg", self.mass_kg, 5000.0, "kg"))
        off = _vec3(self.name, "offset_m", self.offset_m, "m")
        if max(abs(x) for x in off) > 3.0:
            raise InputError(f"{self.name}.offset_m: expected |components| <= 3 m, found {off}")
        _set(self, "offset_m", off)

    def apply_robot(self, robot: Robot) -> Robot:
        """Merge the point mass into the end effector."""
        m2 = self.mass_kg
        c2 = np.array(self.offset_m)
        ee = robot.end_effector
        if ee is None:
            return robot.replace(end_effector=RigidBody(m2, c2, np.zeros((3, 3))))
        m1, c1 = ee.mass_kg, ee.com_m
        m = m1 + m2
        c = (m1 * c1 + m2 * c2) / m

        def shift(mass: float, d: FloatArray) -> FloatArray:
            return mass * (float(d @ d) * np.eye(3) - np.outer(d, d))

        inertia = ee.inertia_kgm2 + shift(m1, c1 - c) + shift(m2, c2 - c)
        return robot.replace(end_effector=RigidBody(m, c, inertia))


@dataclass(frozen=True)
class JointStiffness(Effect):
    """One joint's stiffness scaled by a factor (a calibration error).

    ``k_joint <- factor * k_joint``: frequency shifts concentrated in the modes
    that strain that joint.

    Parameters
    ----------
    joint : int
        1..6.
    factor : float
        Dimensionless, 0.01 <= factor <= 100.
    """

    name: ClassVar[str] = "joint_stiffness"
    stage: ClassVar[int] = 0
    joint: int = 1
    factor: float = 1.0

    def __post_init__(self) -> None:
        _set(self, "joint", _joint(self.name, "joint", self.joint))
        f = _num(self.name, "factor", self.factor, 0.01, 100.0, "-")
        _set(self, "factor", f)

    def apply_robot(self, robot: Robot) -> Robot:
        """Scale the joint's stiffness."""
        k = np.array(robot.stiffness)
        k[self.joint - 1] *= self.factor
        return robot.with_stiffness(k)


@dataclass(frozen=True)
class JointDamping(Effect):
    """One joint's viscous damping scaled by a factor.

    Parameters
    ----------
    joint : int
        1..6.
    factor : float
        Dimensionless, 0.01 <= factor <= 100.
    """

    name: ClassVar[str] = "joint_damping"
    stage: ClassVar[int] = 0
    joint: int = 1
    factor: float = 1.0

    def __post_init__(self) -> None:
        _set(self, "joint", _joint(self.name, "joint", self.joint))
        _set(self, "factor", _num(self.name, "factor", self.factor, 0.01, 100.0, "-"))

    def apply_robot(self, robot: Robot) -> Robot:
        """Scale the joint's damping."""
        c = np.array(robot.damping)
        c[self.joint - 1] *= self.factor
        return robot.with_damping(c)


# ----------------------------------------------------------- stages 1-2
@dataclass(frozen=True)
class GravityStiffening(Effect):
    """Load-dependent gear stiffness driven by the gravity torque.

    ``k_i = k0_i (1 + beta |tau_g,i(q)| / tau_ref)`` on the controller axes,
    with ``tau_g`` the gravity torque of links 1..6 and the end effector
    (g = 9.81 m/s^2 along world -z, :func:`robolobe.twin.dynamics.gravity_torques`).
    Gears are softer near zero load (backlash, soft zone), so the frequency
    shift correlates with each joint's gravity torque. Only ``beta / tau_ref``
    is identifiable: fit ``beta`` with ``tau_ref`` fixed.

    Parameters
    ----------
    beta : float
        Dimensionless hardening, 0 <= beta <= 20.
    tau_ref_Nm : float
        Reference torque [N m], > 0 (default 1e4).
    joints : tuple of int
        Joints it acts on (1..6), default all.
    """

    name: ClassVar[str] = "gravity_stiffening"
    stage: ClassVar[int] = 1
    beta: float = 0.2
    tau_ref_Nm: float = 1.0e4
    joints: tuple[int, ...] = (1, 2, 3, 4, 5, 6)

    def __post_init__(self) -> None:
        _set(self, "beta", _num(self.name, "beta", self.beta, 0.0, 20.0, "-"))
        _set(self, "tau_ref_Nm", _pos(self.name, "tau_ref_Nm", self.tau_ref_Nm, 1e9, "N m"))
        if not isinstance(self.joints, tuple | list) or not self.joints:
            raise InputError(
                f"{self.name}.joints: expected a list of joints 1..6, found {self.joints!r}"
            )
        js = tuple(_joint(self.name, "joints", j) for j in self.joints)
        if len(set(js)) != len(js):
            raise InputError(f"{self.name}.joints: expected distinct joints, found {js}")
        _set(self, "joints", js)

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Add ``k0_i beta |tau_g,i| / tau_ref`` to the joint diagonal."""
        tau = gravity_torques(mats.robot, mats.q, mats.bodies)
        k0 = mats.robot.stiffness
        idx = np.array(self.joints) - 1
        big_k = mats.K.copy()
        s = self.beta / self.tau_ref_Nm
        big_k[..., idx, idx] += load_stiffened(k0[idx], s, tau[..., idx]) - k0[idx]
        return mats.replace(K=big_k)


@dataclass(frozen=True)
class CoupledJointStiffness(Effect):
    """An off-diagonal stiffness between two joints (parallelogram, balancer).

    ``K[i, j] = K[j, i] += k_coupling``: changes the shapes of the modes that
    strain joints i and j, which no diagonal change explains. The resulting
    K must stay positive definite (checked at each posture).

    Parameters
    ----------
    k_coupling_Nm_per_rad : float
        Coupling stiffness [N m/rad], |k| <= 1e9, may be negative.
    joints : tuple of 2 ints
        The joint pair, default (2, 3).
    """

    name: ClassVar[str] = "coupled_joint_stiffness"
    stage: ClassVar[int] = 1
    k_coupling_Nm_per_rad: float = 1.0e5
    joints: tuple[int, int] = (2, 3)

    def __post_init__(self) -> None:
        k = _num(
            self.name, "k_coupling_Nm_per_rad", self.k_coupling_Nm_per_rad, -1e9, 1e9, "N m/rad"
        )
        _set(self, "k_coupling_Nm_per_rad", k)
        if not isinstance(self.joints, tuple | list) or len(self.joints) != 2:
            raise InputError(f"{self.name}.joints: expected two joints 1..6, found {self.joints!r}")
        i, j = (_joint(self.name, "joints", x) for x in self.joints)
        if i == j:
            raise InputError(f"{self.name}.joints: expected two different joints, found {i}, {j}")
        _set(self, "joints", (i, j))

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Add the symmetric off-diagonal term; InputError if K loses definiteness."""
        i, j = self.joints[0] - 1, self.joints[1] - 1
        big_k = mats.K.copy()
        big_k[..., i, j] += self.k_coupling_Nm_per_rad
        big_k[..., j, i] += self.k_coupling_Nm_per_rad
        sub = big_k[..., [i, j], :][..., :, [i, j]]
        if np.any(np.linalg.eigvalsh(sub) <= 0.0):
            raise InputError(
                f"{self.name}.k_coupling_Nm_per_rad: expected |k| < sqrt(k_{i + 1} k_{j + 1}) "
                f"so that K stays positive definite, found {self.k_coupling_Nm_per_rad:g}"
            )
        return mats.replace(K=big_k)


@dataclass(frozen=True)
class FrictionDamping(Effect):
    """Coulomb friction in the joints, linearised at the hammer's force level.

    Describing function of a friction torque ``T_c`` under harmonic joint
    motion of amplitude ``X_i`` at frequency ``w``: an equivalent viscous
    damping ``c_eq,i = c0_i + 4 T_c / (pi w X_i)``. ``w`` is the lowest natural
    frequency at the posture and ``X_i = F ||(K^-1 J^T)_i||`` the joint
    deflection under the hammer force ``F`` at the TCP (the row norm over the
    three directions), so that damping falls as the force level rises. A
    joint the force hardly moves would stick: its added damping is capped at
    30 % of its critical damping ``2 sqrt(k_i M_ii)``. Only ``T_c / F`` is
    identifiable from tests at one force level.

    Parameters
    ----------
    torque_Nm : float
        Coulomb friction torque [N m] per joint, 0 <= T_c <= 1e5.
    force_N : float
        Hammer force level [N] (peak), 0 < F <= 1e5.
    joints : tuple of int
        Joints with friction (1..6), default all.
    """

    name: ClassVar[str] = "friction_damping"
    stage: ClassVar[int] = 2
    torque_Nm: float = 10.0
    force_N: float = 500.0
    joints: tuple[int, ...] = (1, 2, 3, 4, 5, 6)

    STICK_LIMIT: ClassVar[float] = 0.3

    def __post_init__(self) -> None:
        _set(self, "torque_Nm", _num(self.name, "torque_Nm", self.torque_Nm, 0.0, 1e5, "N m"))
        _set(self, "force_N", _pos(self.name, "force_N", self.force_N, 1e5, "N"))
        if not isinstance(self.joints, tuple | list) or not self.joints:
            raise InputError(
                f"{self.name}.joints: expected a list of joints 1..6, found {self.joints!r}"
            )
        js = tuple(_joint(self.name, "joints", j) for j in self.joints)
        if len(set(js)) != len(js):
            raise InputError(f"{self.name}.joints: expected distinct joints, found {js}")
        _set(self, "joints", js)

    def added_damping(self, mats: SystemMatrices) -> FloatArray:
        """Equivalent viscous damping added to each joint [N m s/rad], shape (..., 6)."""
        k6 = mats.K[..., :6, :6]
        m6 = mats.M[..., :6, :6]
        w0, _ = undamped_modes(m6, k6)
        w1 = w0[..., :1]
        defl = np.linalg.solve(k6, np.swapaxes(mats.J[..., :, :6], -1, -2))  # (..., 6, 3)
        amp = self.force_N * np.linalg.norm(defl, axis=-1)  # (..., 6) rad
        k_diag = np.diagonal(k6, axis1=-2, axis2=-1)
        m_diag = np.diagonal(m6, axis1=-2, axis2=-1)
        cap = self.STICK_LIMIT * 2.0 * np.sqrt(k_diag * m_diag)
        if self.torque_Nm == 0.0:
            return np.zeros_like(cap)
        with np.errstate(divide="ignore"):
            dc = 4.0 * self.torque_Nm / (np.pi * w1 * amp)  # amp = 0: inf, capped below
        dc = np.minimum(dc, cap)
        mask = np.zeros(6, dtype=bool)
        mask[np.array(self.joints) - 1] = True
        return np.where(mask, dc, 0.0)

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Add the equivalent viscous damping to the joint diagonal."""
        dc = self.added_damping(mats)
        big_c = mats.C.copy()
        idx = np.arange(6)
        big_c[..., idx, idx] += dc
        return mats.replace(C=big_c)


# ----------------------------------------------------------- stage 3
@dataclass(frozen=True)
class BaseCompliance(Effect):
    """An elastic base/floor: the whole robot rocks on a rotational spring.

    Two extra DOFs, small rotations [rad] of the base about its own x and y
    axes through the base origin (``base_rx``, ``base_ry``), and optionally
    three translations [m] (``base_x``, ``base_y``, ``base_z``). Every body and
    the TCP move rigidly with them; the base itself is a body of
    ``mass_kg`` at the base origin with radius of gyration 0.4 m. Each base
    DOF has a dashpot for 5 % damping of its own oscillator
    (``c = 2 zeta sqrt(k M_jj)``). Lowers the lowest modes everywhere, more at
    long reach, and adds a low mode.

    Parameters
    ----------
    stiffness_Nm_per_rad : float
        Rotational stiffness about each tilt axis [N m/rad], 1e4 .. 1e12.
    mass_kg : float
        Moving base mass [kg], 0 < m <= 1e5.
    translational_stiffness_N_per_m : float or None
        Stiffness of each translation [N/m], 1e4 .. 1e13; None keeps the base
        fixed in translation (default).
    """

    name: ClassVar[str] = "base_compliance"
    stage: ClassVar[int] = 3
    stiffness_Nm_per_rad: float = 5.0e7
    mass_kg: float = 300.0
    translational_stiffness_N_per_m: float | None = None

    ZETA: ClassVar[float] = 0.05
    RADIUS_OF_GYRATION_M: ClassVar[float] = 0.4

    def __post_init__(self) -> None:
        k = _num(self.name, "stiffness_Nm_per_rad", self.stiffness_Nm_per_rad, 1e4, 1e12, "N m/rad")
        _set(self, "stiffness_Nm_per_rad", k)
        _set(self, "mass_kg", _pos(self.name, "mass_kg", self.mass_kg, 1e5, "kg"))
        if self.translational_stiffness_N_per_m is not None:
            kt = _num(
                self.name,
                "translational_stiffness_N_per_m",
                self.translational_stiffness_N_per_m,
                1e4,
                1e13,
                "N/m",
            )
            _set(self, "translational_stiffness_N_per_m", kt)

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Append the base DOFs and the base body."""
        rb = mats.robot.base
        o = rb[:3, 3]
        axes = rb[:3, :3].T  # rows: base x, y, z in the world
        rot_axes = axes[:2]
        names: tuple[str, ...] = ("base_rx", "base_ry")
        stiff = [self.stiffness_Nm_per_rad] * 2
        com = mats.bodies.com_m  # (..., nb, 3)
        # rotation columns: e x (p - o); angular: e
        jv_rot = np.cross(rot_axes[None, :, :], (com - o)[..., :, None, :])  # (..., nb, 2, 3)
        jw_rot = np.broadcast_to(rot_axes, jv_rot.shape)
        tcp_v_rot = np.cross(rot_axes, (mats.tcp_position - o)[..., None, :])  # (..., 2, 3)
        tcp_w_rot = np.broadcast_to(rot_axes, tcp_v_rot.shape)
        jv_cols, jw_cols = [jv_rot], [jw_rot]
        tv_cols, tw_cols = [tcp_v_rot], [tcp_w_rot]
        if self.translational_stiffness_N_per_m is not None:
            names = (*names, "base_x", "base_y", "base_z")
            stiff += [self.translational_stiffness_N_per_m] * 3
            jv_cols.append(np.broadcast_to(axes, (*com.shape[:-1], 3, 3)))
            jw_cols.append(np.zeros((*com.shape[:-1], 3, 3)))
            tv_cols.append(np.broadcast_to(axes, (*com.shape[:-2], 3, 3)))
            tw_cols.append(np.zeros((*com.shape[:-2], 3, 3)))
        # stacked as (..., nb, m, 3) -> (..., nb, 3, m)
        body_jv = np.swapaxes(np.concatenate(jv_cols, axis=-2), -1, -2)
        body_jw = np.swapaxes(np.concatenate(jw_cols, axis=-2), -1, -2)
        tcp_jv = np.swapaxes(np.concatenate(tv_cols, axis=-2), -1, -2)
        tcp_jw = np.swapaxes(np.concatenate(tw_cols, axis=-2), -1, -2)
        n_old = mats.n_dof
        out = mats.add_dofs(names, body_jv, body_jw, tcp_jv, tcp_jw, np.array(stiff))
        # the base body: moved only by the base DOFs
        batch = mats.q.shape[:-1]
        m_new = len(names)
        jv_b = np.zeros((*batch, 3, n_old + m_new))
        jw_b = np.zeros((*batch, 3, n_old + m_new))
        jw_b[..., :, n_old : n_old + 2] = rot_axes.T
        if m_new == 5:
            jv_b[..., :, n_old + 2 :] = axes.T
        inertia = self.mass_kg * self.RADIUS_OF_GYRATION_M**2 * np.eye(3)
        bodies = out.bodies.with_body("base", self.mass_kg, o, inertia, jv_b, jw_b)
        return out.replace(bodies=bodies).with_dof_damping(n_old, self.ZETA)


@dataclass(frozen=True)
class LinkFlexibility(Effect):
    """An elastic hinge inside a link (e.g. forearm bending), one extra DOF.

    The hinge sits on the axis of joint ``link + 1`` (the distal end of link
    ``link``, ``joint_axes`` point of that axis) and rotates the bodies distal
    to it (links ``link+1``..6, the end effector) and the TCP about ``axis``,
    a direction fixed in DH frame ``link`` (the frame link ``link``'s body is
    given in). With standard DH (robot A), x_i is the common normal of joints
    i and i+1, so ``link=3, axis=(1, 0, 0)`` is lateral bending of the
    forearm; ``link=2, axis=(0, 1, 0)`` lateral bending of the upper arm. The
    DOF ``flex<link>`` [rad] has a dashpot for 2 % damping of its own
    oscillator. Adds mid-band modes with weak gravity correlation.

    Parameters
    ----------
    link : int
        1..5.
    stiffness_Nm_per_rad : float
        Hinge stiffness [N m/rad], 1e3 .. 1e11.
    axis : tuple of 3 floats
        Bending axis in DH frame ``link`` (normalised).
    """

    name: ClassVar[str] = "link_flexibility"
    stage: ClassVar[int] = 3
    link: int = 3
    stiffness_Nm_per_rad: float = 2.0e7
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)

    ZETA: ClassVar[float] = 0.02

    def __post_init__(self) -> None:
        _set(self, "link", _joint(self.name, "link", self.link, hi=5))
        k = _num(self.name, "stiffness_Nm_per_rad", self.stiffness_Nm_per_rad, 1e3, 1e11, "N m/rad")
        _set(self, "stiffness_Nm_per_rad", k)
        _set(self, "axis", _vec3(self.name, "axis", self.axis, "-", unit_norm=True))

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Append the hinge DOF."""
        zs, pts = joint_axes(mats.robot, mats.frames)
        hinge = pts[..., self.link, :]  # point on joint link+1's axis, (..., 3)
        a = mats.frames[..., self.link, :3, :3] @ np.array(self.axis)  # (..., 3)
        # about joint link+1's own axis the hinge moves exactly as that joint does:
        # two equal Jacobian columns, a singular mass matrix
        par = np.abs(np.sum(a * zs[..., self.link, :], axis=-1))
        if np.any(par > 1.0 - 1e-6):
            raise InputError(
                f"{self.name}.axis: {self.axis} is joint {self.link + 1}'s axis in DH frame "
                f"{self.link}; a hinge about it is that joint's series compliance "
                "(joint_stiffness or servo_mode), not a bending: choose an axis across it "
                "(link_bending_axes)"
            )
        distal = np.array(
            [
                nm == "end_effector" or (nm.startswith("link") and int(nm[4:]) > self.link)
                for nm in mats.bodies.names
            ]
        )
        lever = mats.bodies.com_m - hinge[..., None, :]
        jv = np.cross(a[..., None, :], lever) * distal[:, None]  # (..., nb, 3)
        jw = np.broadcast_to(a[..., None, :], jv.shape) * distal[:, None]
        tcp_v = np.cross(a, mats.tcp_position - hinge)
        n_old = mats.n_dof
        out = mats.add_dofs(
            (f"flex{self.link}",),
            jv[..., None],
            jw[..., None],
            tcp_v[..., None],
            a[..., None],
            np.array([self.stiffness_Nm_per_rad]),
        )
        return out.with_dof_damping(n_old, self.ZETA)


def link_bending_axes(robot: Robot, link: int) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """Two bending axes of ``link`` in its DH frame, across joint ``link + 1``'s axis.

    The DH frame's x and y axes, each with its component along joint
    ``link + 1``'s axis removed (that joint's axis is fixed in the link's
    frame); if one of them lies along the joint axis, the other and their
    common normal. With standard DH (joint i+1 along z_i) these are x and y.

    Returns
    -------
    (tuple of 3 floats, tuple of 3 floats)
        Unit axes in DH frame ``link``, orthogonal to each other.
    """
    from robolobe.robots.kinematics import link_frames

    _joint("link_flexibility", "link", link, hi=5)
    frames = link_frames(robot, np.zeros(6))
    zs, _ = joint_axes(robot, frames)
    z = frames[link, :3, :3].T @ zs[link]  # joint link+1's axis in frame `link`
    out: list[FloatArray] = []
    for e in np.eye(3)[:2]:
        v = e - float(e @ z) * z
        if np.linalg.norm(v) > 1e-3:
            out.append(v / np.linalg.norm(v))
    if len(out) == 1:
        out.append(np.cross(z, out[0]))
    a1, a2 = out[0], out[1] - float(out[1] @ out[0]) * out[0]
    a2 = a2 / np.linalg.norm(a2)
    return tuple(float(x) for x in a1), tuple(float(x) for x in a2)


# ----------------------------------------------------------- stage 4
_DIRECTIONS = {"x": (0,), "y": (1,), "z": (2,), "xyz": (0, 1, 2)}


@dataclass(frozen=True)
class ToolMode(Effect):
    """A local spindle/bracket/tool mode between the flange side and the tool point.

    The measured (and hit) TCP point becomes a point mass ``mass_kg`` on a
    spring ``k = m (2 pi f)^2`` with dashpot ``c = 2 zeta m (2 pi f)`` along
    the TCP axis ``direction`` (or all three: ``"xyz"``), attached to the
    robot's TCP: extra DOFs ``tool_<d>`` [m], relative displacements. On a
    rigid robot it resonates at ``f_hz``; on the real one it shows as an extra
    peak at nearly the same frequency in every posture.

    A physics effect of the twin (a model change a diagnosis may locate), not
    modal parameters: the robot's modes come from the twin
    (:meth:`robolobe.twin.modes.Modes.parameters`); a job's tool modes are
    :class:`robolobe.plan.job.ToolMode`.

    Parameters
    ----------
    f_hz : float
        Natural frequency on a rigid support [Hz], 1 .. 5000.
    zeta : float
        Damping ratio, 0.0005 .. 0.5.
    mass_kg : float
        Modal mass [kg], 0.01 .. 1000.
    direction : {"x", "y", "z", "xyz"}
        TCP axis (axes) of the spring.
    mass_in_file : bool
        Whether the robot file already holds the sprung mass in its end
        effector (a local tool/bracket mode of a spindle the file models as
        rigid): the mass then moves from the rigid end effector onto the
        spring (a point mass of ``-mass_kg`` at the TCP rides with the arm), so
        the arm's total mass is unchanged. False (default): the mass is extra.
    """

    name: ClassVar[str] = "tool_mode"
    stage: ClassVar[int] = 4
    f_hz: float = 80.0
    zeta: float = 0.03
    mass_kg: float = 5.0
    direction: Literal["x", "y", "z", "xyz"] = "xyz"
    mass_in_file: bool = False

    def __post_init__(self) -> None:
        _set(self, "f_hz", _num(self.name, "f_hz", self.f_hz, 1.0, 5000.0, "Hz"))
        _set(self, "zeta", _num(self.name, "zeta", self.zeta, 0.0005, 0.5, "-"))
        _set(self, "mass_kg", _num(self.name, "mass_kg", self.mass_kg, 0.01, 1000.0, "kg"))
        if self.direction not in _DIRECTIONS:
            raise InputError(
                f"{self.name}.direction: expected one of {sorted(_DIRECTIONS)}, "
                f"found {self.direction!r}"
            )
        if not isinstance(self.mass_in_file, bool | np.bool_):
            raise InputError(
                f"{self.name}.mass_in_file: expected true or false, found {self.mass_in_file!r}"
            )
        _set(self, "mass_in_file", bool(self.mass_in_file))

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Append the tool DOFs and the tool mass; the TCP rides on the spring."""
        batch = mats.q.shape[:-1]
        sel = _DIRECTIONS[self.direction]
        m = len(sel)
        e = mats.tcp_rotation[..., :, list(sel)]  # (..., 3, m) world directions
        nb = len(mats.bodies.names)
        k = self.mass_kg * (2.0 * np.pi * self.f_hz) ** 2
        out = mats.add_dofs(
            tuple(f"tool_{'xyz'[i]}" for i in sel),
            np.zeros((*batch, nb, 3, m)),
            np.zeros((*batch, nb, 3, m)),
            e,
            np.zeros((*batch, 3, m)),
            np.full(m, k),
        )
        bodies = out.bodies.with_body(
            "tool_mass",
            self.mass_kg,
            mats.tcp_position,
            np.zeros((3, 3)),
            out.tcp_jv,
            np.zeros_like(out.tcp_jw),
        )
        if self.mass_in_file:
            ee = mats.robot.end_effector
            if ee is None or ee.mass_kg <= self.mass_kg:
                raise InputError(
                    f"{self.name}.mass_kg: with mass_in_file the end effector must hold more "
                    f"than the sprung mass, found {self.mass_kg:g} kg against "
                    f"{0.0 if ee is None else ee.mass_kg:g} kg"
                )
            rigid_jv = np.concatenate([mats.tcp_jv, np.zeros((*batch, 3, m))], axis=-1)
            bodies = bodies.with_body(
                "tool_mass_in_file",
                -self.mass_kg,
                mats.tcp_position,
                np.zeros((3, 3)),
                rigid_jv,
                np.zeros_like(rigid_jv),
            )
        # the tool DOF's own mass entry is m, so this dashpot is 2 zeta m (2 pi f)
        return out.replace(bodies=bodies).with_dof_damping(mats.n_dof, self.zeta)


# ----------------------------------------------------------- stage 5
@dataclass(frozen=True)
class _AxesRotation(Effect):
    """Three rotation angles ``R = Rz(rz) Ry(ry) Rx(rx)`` [rad], each |angle| <= pi/2."""

    rx_rad: float = 0.0
    ry_rad: float = 0.0
    rz_rad: float = 0.0

    def __post_init__(self) -> None:
        for f in ("rx_rad", "ry_rad", "rz_rad"):
            _set(self, f, _num(self.name, f, getattr(self, f), -np.pi / 2, np.pi / 2, "rad"))

    def rotation(self) -> FloatArray:
        """``R``, shape (3, 3)."""
        return rotation_from_zyx([self.rz_rad, self.ry_rad, self.rx_rad])


@dataclass(frozen=True)
class SensorMisalignment(_AxesRotation):
    """Accelerometer axes rotated against the TCP frame.

    The sensor frame is the TCP frame rotated by ``R = Rz(rz) Ry(ry) Rx(rx)``;
    the hammer still hits along the TCP axes, so the measured receptance is
    ``H_meas = R^T H``: driving-point FRFs pick up the other directions' peaks
    and reciprocity (``H = H^T``) breaks.

    Parameters
    ----------
    rx_rad, ry_rad, rz_rad : float
        Rotation angles [rad], each |angle| <= pi/2.
    """

    name: ClassVar[str] = "sensor_misalignment"
    stage: ClassVar[int] = 5

    def modify_frf(self, H: ComplexArray, freq_hz: FloatArray) -> ComplexArray:
        """``R^T H``."""
        out: ComplexArray = self.rotation().T @ H
        return out


@dataclass(frozen=True)
class SensorDelay(Effect):
    """A time delay of the response channel against the force channel.

    ``H_meas(w) = H(w) exp(-i w tau)``: magnitude unchanged, phase error
    linear in frequency (anti-aliasing filter or channel mismatch).

    Parameters
    ----------
    delay_s : float
        Delay [s], |tau| <= 0.1 (negative: the force channel lags).
    """

    name: ClassVar[str] = "sensor_delay"
    stage: ClassVar[int] = 5
    delay_s: float = 0.0

    def __post_init__(self) -> None:
        _set(self, "delay_s", _num(self.name, "delay_s", self.delay_s, -0.1, 0.1, "s"))

    def modify_frf(self, H: ComplexArray, freq_hz: FloatArray) -> ComplexArray:
        """``H exp(-i w tau)``."""
        phase = np.exp(-2j * np.pi * np.asarray(freq_hz) * self.delay_s)
        out: ComplexArray = H * phase[:, None, None]
        return out


@dataclass(frozen=True)
class ServoMode(Effect):
    """A joint's servo (position-loop) compliance in series with its gear: a holding mode.

    A controlled axis is not clamped: the position loop holds the motor with a
    finite stiffness ``k_servo``, in series with the gear stiffness of the
    joint. One extra DOF ``servo<j>`` [rad] turns everything distal to joint
    ``j`` about that joint's axis (like the joint DOF itself) against the
    spring ``k_servo``. The servo DOF also turns the motor's rotor (its
    inertia reflected through the gear, ``rotor_inertia_kgm2`` about the
    joint axis), which sits between the servo spring and the gear spring:
    without it the two springs in series would have no mass between them. A
    soft loop gives a low "holding" mode of the whole arm (a few hertz) and
    lowers the joint's effective stiffness to ``k k_s / (k + k_s)``. The loop
    damps the motor: a dashpot ``c = 2 zeta sqrt(k_servo J_rotor)`` on the
    servo DOF, the same at every posture (a dashpot scaled with the arm's
    inertia about the axis, as other extra DOFs have, changed the holding
    mode's damping with the reach: a two-mass drive simulated on its own
    could then not be fitted within the noise,
    tests/diagnose/test_independent_generator.py).

    Parameters
    ----------
    joint : int
        1..6.
    stiffness_Nm_per_rad : float
        Servo holding stiffness [N m/rad], 1e2 .. 1e11.
    zeta : float
        Damping ratio of the rotor on the servo spring (the velocity loop's
        damping, ``c = 2 zeta sqrt(k_servo J_rotor)``), 0.001 .. 0.9.
    rotor_inertia_kgm2 : float
        Motor rotor inertia reflected to the joint [kg m^2], 1e-3 .. 1e5.
    """

    name: ClassVar[str] = "servo_mode"
    stage: ClassVar[int] = 3
    joint: int = 1
    stiffness_Nm_per_rad: float = 1.0e6
    zeta: float = 0.1
    rotor_inertia_kgm2: float = 20.0

    def __post_init__(self) -> None:
        _set(self, "joint", _joint(self.name, "joint", self.joint))
        k = _num(self.name, "stiffness_Nm_per_rad", self.stiffness_Nm_per_rad, 1e2, 1e11, "N m/rad")
        _set(self, "stiffness_Nm_per_rad", k)
        _set(self, "zeta", _num(self.name, "zeta", self.zeta, 0.001, 0.9, "-"))
        r = _pos(self.name, "rotor_inertia_kgm2", self.rotor_inertia_kgm2, 1e5, "kg m^2")
        if r < 1e-3:
            raise InputError(f"{self.name}.rotor_inertia_kgm2: expected >= 0.001, found {r:g}")
        _set(self, "rotor_inertia_kgm2", r)

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """Append the servo DOF (the joint's own Jacobian column) and the rotor."""
        j = self.joint - 1
        bj = mats.bodies
        n_old = mats.n_dof
        out = mats.add_dofs(
            (f"servo{self.joint}",),
            bj.jv[..., j : j + 1],
            bj.jw[..., j : j + 1],
            mats.tcp_jv[..., j : j + 1],
            mats.tcp_jw[..., j : j + 1],
            np.array([self.stiffness_Nm_per_rad]),
        )
        zs, pts = joint_axes(mats.robot, mats.frames)
        a = zs[..., j, :]  # (..., 3)
        batch = mats.q.shape[:-1]
        jw = np.zeros((*batch, 3, n_old + 1))
        jw[..., :, n_old] = a
        inertia = self.rotor_inertia_kgm2 * a[..., :, None] * a[..., None, :]
        bodies = out.bodies.with_body(
            f"rotor{self.joint}", 0.0, pts[..., j, :], inertia, np.zeros_like(jw), jw
        )
        # the velocity loop damps the motor: a dashpot to ground on the servo DOF, the
        # same at every posture (not scaled with the arm's inertia about the axis)
        big_c = out.C.copy()
        big_c[..., n_old, n_old] = (
            2.0 * self.zeta * np.sqrt(self.stiffness_Nm_per_rad * self.rotor_inertia_kgm2)
        )
        return out.replace(bodies=bodies, C=big_c)


@dataclass(frozen=True)
class TcpOffset(Effect):
    """The measured and hit point is not the file's TCP (a tool longer or shifted).

    The point ``p = tcp + R d`` (``d`` in the TCP frame) moves with
    ``v_p = v_tcp + w x (R d)``: the translational TCP Jacobian becomes
    ``Jv - [R d]_x Jw`` over every DOF, so a longer tool sees more of the
    wrist's rotations. Structural DOFs added by other effects are included
    (they are assembled before this stage); a tool mode's spring DOFs carry
    no rotation and are unchanged.

    Parameters
    ----------
    offset_m : tuple of 3 floats
        Offset in the TCP frame [m], each |component| <= 1 m.
    """

    name: ClassVar[str] = "tcp_offset"
    stage: ClassVar[int] = 4
    offset_m: tuple[float, float, float] = (0.0, 0.0, 0.05)

    def __post_init__(self) -> None:
        off = _vec3(self.name, "offset_m", self.offset_m, "m")
        if max(abs(x) for x in off) > 1.0:
            raise InputError(f"{self.name}.offset_m: expected |components| <= 1 m, found {off}")
        _set(self, "offset_m", off)

    def modify(self, mats: SystemMatrices) -> SystemMatrices:
        """``tcp_jv <- tcp_jv - [R d]_x tcp_jw``."""
        r = mats.tcp_rotation @ np.array(self.offset_m)  # (..., 3)
        return mats.replace(tcp_jv=mats.tcp_jv - skew(r) @ mats.tcp_jw)


@dataclass(frozen=True)
class SensorGain(Effect):
    """Wrong sensitivity of the response channels (a calibration or cable error).

    ``H_meas = diag(g_x, g_y, g_z) H``: every FRF measured by channel ``i`` is
    scaled by ``g_i`` (a level offset, no frequency shift).

    Parameters
    ----------
    gain : tuple of 3 floats
        Gain of the x, y, z response channel, each 0.1 .. 10.
    """

    name: ClassVar[str] = "sensor_gain"
    stage: ClassVar[int] = 5
    gain: tuple[float, float, float] = (1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        g = _vec3(self.name, "gain", self.gain, "-")
        if not all(0.1 <= x <= 10.0 for x in g):
            raise InputError(f"{self.name}.gain: expected 0.1 <= each <= 10, found {g}")
        _set(self, "gain", g)

    def modify_frf(self, H: ComplexArray, freq_hz: FloatArray) -> ComplexArray:
        """``diag(g) H``."""
        out: ComplexArray = np.asarray(self.gain)[:, None] * H
        return out


@dataclass(frozen=True)
class HammerDirection(_AxesRotation):
    """The hammer hits off the nominal axes (the input side, not the sensor).

    The hit meant along TCP axis ``j`` goes along ``R e_j`` with
    ``R = Rz(rz) Ry(ry) Rx(rx)``, so the measured receptance is ``H R``
    (columns mixed; a rotated sensor mixes rows, ``R^T H``). With ``hit``
    set, only that hit is off (each direction is hit by hand on its own, so
    its error is its own): column ``j`` becomes ``H R e_j``, the others stay.

    Parameters
    ----------
    rx_rad, ry_rad, rz_rad : float
        Rotation angles [rad], each |angle| <= pi/2.
    hit : {"", "x", "y", "z"}
        The one hit direction that is off ("": all hits, one rotation).
    """

    name: ClassVar[str] = "hammer_direction"
    stage: ClassVar[int] = 5

    hit: str = ""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.hit not in ("", "x", "y", "z"):
            raise InputError(f"{self.name}.hit: expected '', 'x', 'y' or 'z', found {self.hit!r}")

    def modify_frf(self, H: ComplexArray, freq_hz: FloatArray) -> ComplexArray:
        """``H R``, or only column ``hit`` replaced by ``H R e_hit``."""
        R = self.rotation()
        if not self.hit:
            out: ComplexArray = H @ R
            return out
        j = "xyz".index(self.hit)
        one = np.array(H, copy=True)
        one[..., :, j] = H @ R[:, j]
        return one


# ------------------------------------------------------------ registry
EFFECTS: dict[str, type[Effect]] = {
    cls.name: cls
    for cls in (
        AddedMass,
        JointStiffness,
        JointDamping,
        GravityStiffening,
        CoupledJointStiffness,
        FrictionDamping,
        BaseCompliance,
        LinkFlexibility,
        ToolMode,
        SensorMisalignment,
        SensorDelay,
        ServoMode,
        TcpOffset,
        SensorGain,
        HammerDirection,
    )
}
"""Effect classes by name."""


def effect_to_dict(effect: Effect) -> dict[str, Any]:
    """Plain-data form of an effect: ``{"name": ..., <field>: <value>, ...}``.

    Tuples become lists, so the result writes to TOML/JSON as is.
    """
    if not isinstance(effect, Effect) or effect.name not in EFFECTS:
        raise InputError(f"effect: expected a robolobe.twin.effects effect, found {effect!r}")
    return {"name": effect.name, **effect.params()}


def effect_from_dict(d: dict[str, Any], source: str | None = None) -> Effect:
    """Build an effect from :func:`effect_to_dict`'s output.

    Parameters
    ----------
    d : dict
        ``name`` and the effect's fields (missing ones take their defaults).
    source : str, optional
        Where ``d`` came from (file and key), for error messages.

    Raises
    ------
    InputError
        Unknown name, unknown field, or a parameter out of range.
    """
    if not isinstance(d, dict) or "name" not in d:
        raise InputError(f"effect: expected a table with a 'name' key, found {d!r}", source)
    name = d["name"]
    cls = EFFECTS.get(name) if isinstance(name, str) else None
    if cls is None:
        raise InputError(f"effect.name: expected one of {sorted(EFFECTS)}, found {name!r}", source)
    fields = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    kwargs = {k: v for k, v in d.items() if k != "name"}
    unknown = sorted(set(kwargs) - fields)
    if unknown:
        raise InputError(
            f"{name}: unknown parameter(s) {unknown}; expected some of {sorted(fields)}", source
        )
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in kwargs.items()}
    try:
        return cls(**kwargs)
    except InputError as exc:
        if source is None:
            raise
        raise InputError(exc.detail, source) from None
