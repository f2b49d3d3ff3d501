"""Data model of a serial 6-axis arm with elastic joints (docs/guide/robots.md).

All quantities are SI and radians. Instances are frozen; their arrays are
read-only. Build them with :func:`robolobe.robots.io.load_robot` (files) or
directly (tests, code).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["Convention", "Joint", "LinearConstraint", "RigidBody", "Robot", "robots_allclose"]

Convention = Literal["standard-dh", "modified-dh"]
FloatArray = NDArray[np.float64]

_JOINT_SCALARS = (
    "a_m",
    "alpha_rad",
    "d_m",
    "theta_offset_rad",
    "q_min_rad",
    "q_max_rad",
    "stiffness_Nm_per_rad",
    "damping_Nms_per_rad",
)


def _pair(value: ArrayLike | None) -> tuple[float, float] | None:
    """Two finite floats, or None."""
    if value is None:
        return None
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (2,) or not np.all(np.isfinite(arr)):
        raise InputError(f"expected two finite numbers, found {value!r}")
    return (float(arr[0]), float(arr[1]))


def _frozen_array(value: ArrayLike, shape: tuple[int, ...], name: str) -> FloatArray:
    arr = np.array(value, dtype=np.float64)  # always a copy
    if arr.shape != shape:
        raise InputError(f"{name}: expected shape {shape}, found {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected finite numbers, found {arr.tolist()}")
    arr.setflags(write=False)
    return arr


@dataclass(frozen=True, eq=False)
class RigidBody:
    """A rigid body.

    Parameters
    ----------
    mass_kg : float
        Mass [kg], >= 0.
    com_m : ndarray, shape (3,)
        Centre of mass [m] in the body's frame.
    inertia_kgm2 : ndarray, shape (3, 3)
        Inertia tensor [kg m^2] about the centre of mass, body-frame axes.
    """

    mass_kg: float
    com_m: FloatArray
    inertia_kgm2: FloatArray

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass_kg", float(self.mass_kg))
        object.__setattr__(self, "com_m", _frozen_array(self.com_m, (3,), "com_m"))
        inertia = _frozen_array(self.inertia_kgm2, (3, 3), "inertia_kgm2")
        object.__setattr__(self, "inertia_kgm2", inertia)

    def spatial_inertia(self) -> FloatArray:
        """6x6 spatial inertia about the body-frame origin, [v; w] ordering.

        Returns
        -------
        ndarray, shape (6, 6)
            ``[[m I3, -m [c]x], [m [c]x, I_c - m [c]x [c]x]]``.
        """
        m = self.mass_kg
        c = self.com_m
        cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        out = np.zeros((6, 6))
        out[:3, :3] = m * np.eye(3)
        out[:3, 3:] = -m * cx
        out[3:, :3] = m * cx
        out[3:, 3:] = self.inertia_kgm2 - m * cx @ cx
        return out


@dataclass(frozen=True, eq=False)
class Joint:
    """One revolute joint and the link it moves.

    Parameters
    ----------
    a_m, alpha_rad, d_m, theta_offset_rad : float
        DH parameters [m, rad] (for modified DH, ``a_m``/``alpha_rad`` hold
        a_{i-1}/alpha_{i-1}, docs/guide/robots.md).
    q_min_rad, q_max_rad : float
        Joint limits of the controller axis angle q_i [rad].
    body : RigidBody
        Link i (moved by joint i), given in DH frame i.
    stiffness_Nm_per_rad : float
        Joint stiffness [N m/rad], acting on the controller axis q_i.
    damping_Nms_per_rad : float
        Joint viscous damping [N m s/rad], acting on q_i.
    tilt_stiffness_Nm_per_rad : tuple of 2 floats or None
        Optional tilt compliance of the joint's bearing and gearbox (the
        non-actuated rotations of virtual-joint stiffness models): rotational
        springs [N m/rad] about DH axis x_i (perpendicular to the joint axis)
        and about ``z_joint x x_i``, through the joint axis point; they tilt
        link i and everything distal to it. None: the joint is rigid in tilt
        (the nominal model of docs/guide/robots.md).
    tilt_damping_Nms_per_rad : tuple of 2 floats or None
        Viscous dampers [N m s/rad] of the two tilt springs; given exactly
        when ``tilt_stiffness_Nm_per_rad`` is.
    load_stiffening_per_Nm : float
        Optional load-dependent gear stiffness [1/(N m)], >= 0: at posture q
        the joint spring is ``stiffness_Nm_per_rad (1 + load_stiffening_per_Nm
        |tau_g(q)|)`` with ``tau_g`` the gravity torque on the axis
        (:func:`robolobe.twin.system.load_stiffened`). Reducers are softer
        near zero torque (lost motion, the first segment of Harmonic Drive
        and RV torsional-rigidity curves) and stiffen under load. 0 (the
        default, docs/guide/robots.md): a constant spring.
    """

    a_m: float
    alpha_rad: float
    d_m: float
    theta_offset_rad: float
    q_min_rad: float
    q_max_rad: float
    body: RigidBody
    stiffness_Nm_per_rad: float
    damping_Nms_per_rad: float
    tilt_stiffness_Nm_per_rad: tuple[float, float] | None = None
    tilt_damping_Nms_per_rad: tuple[float, float] | None = None
    load_stiffening_per_Nm: float = 0.0

    def __post_init__(self) -> None:
        for name in _JOINT_SCALARS:
            object.__setattr__(self, name, float(getattr(self, name)))
        ls = float(self.load_stiffening_per_Nm)
        if not (math.isfinite(ls) and ls >= 0.0):
            raise InputError(f"load_stiffening_per_Nm: expected a finite number >= 0, found {ls}")
        object.__setattr__(self, "load_stiffening_per_Nm", ls)
        ks, cs = _pair(self.tilt_stiffness_Nm_per_rad), _pair(self.tilt_damping_Nms_per_rad)
        if (ks is None) != (cs is None):
            raise InputError(
                "tilt_stiffness_Nm_per_rad, tilt_damping_Nms_per_rad: expected both or neither"
            )
        if ks is not None and cs is not None and (min(ks) <= 0 or min(cs) < 0):
            raise InputError(f"tilt: expected stiffness > 0 and damping >= 0, found {ks}, {cs}")
        object.__setattr__(self, "tilt_stiffness_Nm_per_rad", ks)
        object.__setattr__(self, "tilt_damping_Nms_per_rad", cs)

    @property
    def has_tilt(self) -> bool:
        """Whether the joint has tilt compliance (two extra DOFs in the twin)."""
        return self.tilt_stiffness_Nm_per_rad is not None


@dataclass(frozen=True, eq=False)
class LinearConstraint:
    """A linear limit ``lo_rad <= coeffs @ q <= hi_rad`` on the axis angles.

    Parameters
    ----------
    coeffs : ndarray, shape (6,)
        Coefficients (dimensionless).
    lo_rad, hi_rad : float
        Bounds [rad].
    """

    coeffs: FloatArray
    lo_rad: float
    hi_rad: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "coeffs", _frozen_array(self.coeffs, (6,), "coeffs"))
        object.__setattr__(self, "lo_rad", float(self.lo_rad))
        object.__setattr__(self, "hi_rad", float(self.hi_rad))


@dataclass(frozen=True, eq=False, repr=False)
class Robot:
    """A serial 6-axis arm with elastic joints (the nominal model).

    Parameters
    ----------
    name : str
        Free text.
    convention : {"standard-dh", "modified-dh"}
        DH convention of ``joints``.
    joints : tuple of Joint
        Exactly six, base to flange.
    base : ndarray, shape (4, 4)
        Pose of the base (DH frame 0) in the world.
    coupling : ndarray, shape (6, 6)
        DH angle ``theta = coupling @ q + theta_offset`` (q: controller axes).
    tool : ndarray, shape (4, 4)
        TCP frame in the flange (DH frame 6).
    end_effector : RigidBody or None
        Body fixed to the TCP frame (spindle, holder, tool), in the TCP frame.
    constraints : tuple of LinearConstraint
        Linear limits on q (e.g. a parallelogram's relative angle).
    source : str
        File path, or ``"built-in A"`` etc.
    mount_stiffness_Nm_per_rad : tuple of 2 floats or None
        Optional compliant end-effector mount (spindle bracket/flange joint):
        rotational springs [N m/rad] about the flange (DH frame 6) x and y
        axes through the flange centre; they tilt the end effector and the
        TCP. None: rigid mount (docs/guide/robots.md). Needs an end effector.
    mount_damping_Nms_per_rad : tuple of 2 floats or None
        Their viscous dampers [N m s/rad]; given exactly when the stiffness is.
    max_path_speed_m_per_s : float or None
        The TCP path speed [m/s] the robot follows while milling (file key
        ``max_path_speed_mm_per_s``): plans never ask for a feed above it
        (:mod:`robolobe.plan.limits`); None: not stated.
    """

    name: str
    convention: Convention
    joints: tuple[Joint, ...]
    base: FloatArray = field(default_factory=lambda: np.eye(4))
    coupling: FloatArray = field(default_factory=lambda: np.eye(6))
    tool: FloatArray = field(default_factory=lambda: np.eye(4))
    end_effector: RigidBody | None = None
    constraints: tuple[LinearConstraint, ...] = ()
    source: str = "<code>"
    mount_stiffness_Nm_per_rad: tuple[float, float] | None = None
    mount_damping_Nms_per_rad: tuple[float, float] | None = None
    max_path_speed_m_per_s: float | None = None

    def __post_init__(self) -> None:
        v = self.max_path_speed_m_per_s
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(f"max_path_speed: expected a positive speed in m/s, found {v!r}")
        ks, cs = _pair(self.mount_stiffness_Nm_per_rad), _pair(self.mount_damping_Nms_per_rad)
        if (ks is None) != (cs is None):
            raise InputError(
                "mount_stiffness_Nm_per_rad, mount_damping_Nms_per_rad: expected both or neither"
            )
        if ks is not None and cs is not None:
            if min(ks) <= 0 or min(cs) < 0:
                raise InputError(f"mount: expected stiffness > 0, damping >= 0, found {ks}, {cs}")
            if self.end_effector is None or self.end_effector.mass_kg <= 0:
                raise InputError("mount_stiffness_Nm_per_rad: needs an end effector with mass")
        object.__setattr__(self, "mount_stiffness_Nm_per_rad", ks)
        object.__setattr__(self, "mount_damping_Nms_per_rad", cs)
        if self.convention not in ("standard-dh", "modified-dh"):
            raise InputError(
                f"convention: expected 'standard-dh' or 'modified-dh', found {self.convention!r}"
            )
        joints = tuple(self.joints)
        if len(joints) != 6:
            raise InputError(f"joints: expected exactly 6, found {len(joints)}")
        object.__setattr__(self, "joints", joints)
        object.__setattr__(self, "constraints", tuple(self.constraints))
        object.__setattr__(self, "base", _frozen_array(self.base, (4, 4), "base"))
        object.__setattr__(self, "tool", _frozen_array(self.tool, (4, 4), "tool"))
        coupling = _frozen_array(self.coupling, (6, 6), "coupling")
        if abs(np.linalg.det(coupling)) < 1e-9:
            raise InputError("coupling: expected an invertible 6x6 matrix, found a singular one")
        object.__setattr__(self, "coupling", coupling)

    def __repr__(self) -> str:
        return (
            f"Robot(name={self.name!r}, convention={self.convention!r}, "
            f"source={self.source!r}, mass={self.total_mass_kg:.1f} kg)"
        )

    # ---------------------------------------------------------------- views
    def _vec(self, attr: str) -> FloatArray:
        out = np.array([getattr(j, attr) for j in self.joints], dtype=np.float64)
        out.setflags(write=False)
        return out

    @property
    def q_min(self) -> FloatArray:
        """Lower joint limits [rad], shape (6,)."""
        return self._vec("q_min_rad")

    @property
    def q_max(self) -> FloatArray:
        """Upper joint limits [rad], shape (6,)."""
        return self._vec("q_max_rad")

    @property
    def stiffness(self) -> FloatArray:
        """Joint stiffnesses [N m/rad] on the controller axes, shape (6,)."""
        return self._vec("stiffness_Nm_per_rad")

    @property
    def damping(self) -> FloatArray:
        """Joint viscous damping [N m s/rad] on the controller axes, shape (6,)."""
        return self._vec("damping_Nms_per_rad")

    @property
    def a(self) -> FloatArray:
        """DH ``a`` [m], shape (6,)."""
        return self._vec("a_m")

    @property
    def alpha(self) -> FloatArray:
        """DH ``alpha`` [rad], shape (6,)."""
        return self._vec("alpha_rad")

    @property
    def d(self) -> FloatArray:
        """DH ``d`` [m], shape (6,)."""
        return self._vec("d_m")

    @property
    def theta_offset(self) -> FloatArray:
        """DH angle offsets [rad], shape (6,)."""
        return self._vec("theta_offset_rad")

    @property
    def tilt_joints(self) -> tuple[int, ...]:
        """0-based indices of the joints with tilt compliance."""
        return tuple(i for i, j in enumerate(self.joints) if j.has_tilt)

    @property
    def load_stiffening(self) -> FloatArray:
        """Load-dependent stiffening of the joint springs [1/(N m)], shape (6,)."""
        return self._vec("load_stiffening_per_Nm")

    @property
    def has_load_stiffening(self) -> bool:
        """Whether any joint spring depends on the gravity torque (posture)."""
        return any(j.load_stiffening_per_Nm > 0 for j in self.joints)

    @property
    def has_mount(self) -> bool:
        """Whether the end-effector mount is compliant."""
        return self.mount_stiffness_Nm_per_rad is not None

    @property
    def is_flexible_joint_only(self) -> bool:
        """True for the nominal model (six joint springs, nothing else)."""
        return not self.tilt_joints and not self.has_mount

    @property
    def reach_m(self) -> float:
        """Rough reach [m]: an upper bound on the TCP's distance from the shoulder.

        The sum of the DH lengths ``|a_i|``, ``|d_i|`` (i >= 2; ``d_1`` is the
        shoulder height) and the tool offset.
        """
        tool = math.hypot(*(float(v) for v in self.tool[:3, 3]))  # no overflow at 1e300
        return float(np.sum(np.abs(self.a)) + np.sum(np.abs(self.d[1:])) + tool)

    @property
    def total_mass_kg(self) -> float:
        """Mass of the moving links plus the end effector [kg]."""
        m = sum(j.body.mass_kg for j in self.joints)
        return float(m + (self.end_effector.mass_kg if self.end_effector else 0.0))

    def tcp_effective_mass_kg(self) -> FloatArray:
        """The end effector's effective mass [kg] at the TCP along the TCP frame's x, y, z.

        ``1 / (u^T G u)`` with the rigid body's mobility at the TCP
        ``G = I3 / m + [c]x^T I_c^-1 [c]x`` (``c``: its centre of mass from the
        TCP): the kinetic energy of the end effector alone when the TCP moves at
        unit speed along ``u``, so no mode's tip-normalised modal mass along
        ``u`` is smaller. A spindle rocking about its mount shows a fraction of
        its mass (robot A's 150 kg: 22.9, 21.4 and 148 kg).

        Returns
        -------
        ndarray, shape (3,)
            Zeros without an end effector (or with a massless or inertia-free one).
        """
        ee = self.end_effector
        if ee is None or not ee.mass_kg > 0:
            return np.zeros(3)
        c = ee.com_m
        cx = np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])
        try:
            g = np.eye(3) / ee.mass_kg + cx.T @ np.linalg.solve(ee.inertia_kgm2, cx)
        except np.linalg.LinAlgError:
            return np.zeros(3)
        diag = np.diag(g)
        with np.errstate(divide="ignore"):
            out = np.where(np.isfinite(diag) & (diag > 0), 1.0 / diag, 0.0)
        return np.asarray(out, dtype=np.float64)

    # -------------------------------------------------------------- changes
    def replace(self, **changes: Any) -> Robot:
        """Return a copy with fields replaced (:func:`dataclasses.replace`)."""
        return dataclasses.replace(self, **changes)

    def _with_joint_values(self, attr: str, values: ArrayLike) -> Robot:
        v = np.asarray(values, dtype=np.float64)
        if v.shape != (6,):
            raise InputError(f"{attr}: expected shape (6,), found {v.shape}")
        changes: list[dict[str, Any]] = [{attr: float(x)} for x in v]
        joints = tuple(
            dataclasses.replace(j, **c) for j, c in zip(self.joints, changes, strict=True)
        )
        return self.replace(joints=joints)

    def with_stiffness(self, k: ArrayLike) -> Robot:
        """Copy with joint stiffnesses ``k`` [N m/rad], shape (6,)."""
        return self._with_joint_values("stiffness_Nm_per_rad", k)

    def with_damping(self, c: ArrayLike) -> Robot:
        """Copy with joint damping ``c`` [N m s/rad], shape (6,)."""
        return self._with_joint_values("damping_Nms_per_rad", c)

    def with_load_stiffening(self, s: ArrayLike) -> Robot:
        """Copy with load-dependent stiffening ``s`` [1/(N m)] per joint, shape (6,)."""
        return self._with_joint_values("load_stiffening_per_Nm", s)

    def with_tilt(
        self, joint: int, stiffness: ArrayLike | None, damping: ArrayLike | None
    ) -> Robot:
        """Copy with the tilt compliance of joint ``joint`` (0-based) set (None: rigid).

        Parameters
        ----------
        joint : int
            0..5.
        stiffness : array_like, shape (2,), or None
            [N m/rad] about DH x_i and ``z_joint x x_i``.
        damping : array_like, shape (2,), or None
            [N m s/rad].
        """
        joints = list(self.joints)
        joints[joint] = dataclasses.replace(
            joints[joint],
            tilt_stiffness_Nm_per_rad=_pair(stiffness),
            tilt_damping_Nms_per_rad=_pair(damping),
        )
        return self.replace(joints=tuple(joints))

    def with_mount(self, stiffness: ArrayLike | None, damping: ArrayLike | None) -> Robot:
        """Copy with the end-effector mount compliance set (None: rigid mount).

        Parameters
        ----------
        stiffness : array_like, shape (2,), or None
            [N m/rad] about the flange x and y axes.
        damping : array_like, shape (2,), or None
            [N m s/rad].
        """
        return self.replace(
            mount_stiffness_Nm_per_rad=_pair(stiffness), mount_damping_Nms_per_rad=_pair(damping)
        )


def _bodies_close(a: RigidBody | None, b: RigidBody | None, rtol: float, atol: float) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(
        np.isclose(a.mass_kg, b.mass_kg, rtol=rtol, atol=atol)
        and np.allclose(a.com_m, b.com_m, rtol=rtol, atol=atol)
        and np.allclose(a.inertia_kgm2, b.inertia_kgm2, rtol=rtol, atol=atol)
    )


def _pairs_close(
    a: tuple[float, float] | None, b: tuple[float, float] | None, rtol: float, atol: float
) -> bool:
    if a is None or b is None:
        return a is None and b is None
    return bool(np.allclose(a, b, rtol=rtol, atol=atol))


def robots_allclose(a: Robot, b: Robot, *, rtol: float = 1e-9, atol: float = 1e-12) -> bool:
    """Whether two robots are numerically equal (names and sources ignored).

    Parameters
    ----------
    a, b : Robot
    rtol, atol : float
        Tolerances of :func:`numpy.allclose`.
    """
    if a.convention != b.convention or len(a.constraints) != len(b.constraints):
        return False
    for f in ("base", "coupling", "tool"):
        if not np.allclose(getattr(a, f), getattr(b, f), rtol=rtol, atol=atol):
            return False
    for ja, jb in zip(a.joints, b.joints, strict=True):
        if not _bodies_close(ja.body, jb.body, rtol, atol):
            return False
        for name in _JOINT_SCALARS:
            if not np.isclose(getattr(ja, name), getattr(jb, name), rtol=rtol, atol=atol):
                return False
    for ja, jb in zip(a.joints, b.joints, strict=True):
        for name in ("tilt_stiffness_Nm_per_rad", "tilt_damping_Nms_per_rad"):
            if not _pairs_close(getattr(ja, name), getattr(jb, name), rtol, atol):
                return False
        if not np.isclose(
            ja.load_stiffening_per_Nm, jb.load_stiffening_per_Nm, rtol=rtol, atol=atol
        ):
            return False
    for name in ("mount_stiffness_Nm_per_rad", "mount_damping_Nms_per_rad"):
        if not _pairs_close(getattr(a, name), getattr(b, name), rtol, atol):
            return False
    va, vb = a.max_path_speed_m_per_s, b.max_path_speed_m_per_s
    if (va is None) != (vb is None) or (
        va is not None and vb is not None and not np.isclose(va, vb, rtol=rtol, atol=atol)
    ):
        return False
    for ca, cb in zip(a.constraints, b.constraints, strict=True):
        if not (
            np.allclose(ca.coeffs, cb.coeffs, rtol=rtol, atol=atol)
            and np.isclose(ca.lo_rad, cb.lo_rad, rtol=rtol, atol=atol)
            and np.isclose(ca.hi_rad, cb.hi_rad, rtol=rtol, atol=atol)
        ):
            return False
    return _bodies_close(a.end_effector, b.end_effector, rtol, atol)
