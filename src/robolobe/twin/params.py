"""Robot-file parameters that a twin calibration can fit, and their fast evaluation.

The one parametrised-twin core: the transfer calibration
(:class:`robolobe.tl.graybox.TwinCalibration`), the diagnosis' file
calibration (:mod:`robolobe.diagnose.calibration`), the built-in robots'
seed-table fit (:func:`robolobe.twin.calibration.fit_seed_table`) and the
plan-safety study fit and perturb robot files through this module.

:class:`BodyMassModel` is the shared mechanics: each body's Jacobians at
fixed postures, computed once, and from them the mass matrix, its
derivatives and the gravity torques as functions of the bodies' mass
factors, centre-of-mass offsets (body frame) and principal moments of
inertia. :class:`ParametrizedTwin` and the seed-table fit's model are two
parametrisations on it.

A robot file is a prior: joint stiffnesses and dampings are rarely
published, and link masses, centres of mass and the spindle mass of B and C
are estimates (docs/guide/robots.md). The groups here are what
:class:`robolobe.tl.graybox.TwinCalibration` can correct, each as a vector
``theta`` that is 0 for the robot file:

========== ==== ====================================================
group      size meaning of theta
========== ==== ====================================================
stiffness  6    log factor on each joint stiffness
damping    6    log factor on each joint viscous damping
ee_mass    1    log factor on the end-effector mass and inertia
link_mass  6    log factor on each link's mass and inertia
link_com   18   offset of each link's centre of mass in its own frame,
                in units of 0.1 m (x, y, z per link)
load       6    load stiffening of each joint spring, its relative
                stiffening per 1e4 N m of gravity torque
                (:func:`robolobe.twin.system.load_stiffened`: the joint
                spring ``k (1 + s |tau_g|)``, ``s = theta / 1e4`` added to
                the file's; >= 0)
========== ==== ====================================================

:class:`ParametrizedTwin` evaluates the twin's modes for many ``theta`` at
fixed postures without rebuilding the robot (the mass matrix from
:class:`BodyMassModel`). It gives the same
modes as ``Twin(apply_parameters(robot, groups, theta)).modes(q)`` (tested to
1e-9) about three times faster, which is what makes the 43-parameter fit
quick. A robot file with the optional tilt or mount compliances (docs/guide/robots.md
extension, README "Robot description") keeps those DOFs at their
file values: the groups act on the six joint springs and dampers and on the
bodies, the extra DOFs move the bodies as in the twin.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import DRIVING, dir_index
from robolobe.errors import InputError
from robolobe.robots.model import RigidBody, Robot
from robolobe.twin._poles import overdamped_modes
from robolobe.twin.dynamics import GRAVITY_M_PER_S2
from robolobe.twin.modes import Modes, compute_modes, undamped_modes

if TYPE_CHECKING:
    from robolobe.twin.system import SystemMatrices

__all__ = [
    "COM_UNIT_M",
    "MOMENT_FLOOR",
    "PARAMETER_GROUPS",
    "BodyMassModel",
    "ParametrizedTwin",
    "apply_parameters",
    "body_indices",
    "group_values",
    "modal_values",
    "parameter_names",
]

FloatArray = NDArray[np.float64]

#: Parameter groups and their sizes.
PARAMETER_GROUPS: dict[str, int] = {
    "stiffness": 6,
    "damping": 6,
    "ee_mass": 1,
    "link_mass": 6,
    "link_com": 18,
    "load": 6,
}
LOAD_UNIT_NM = 1.0e4
"""Gravity torque [N m] per unit of a fitted load stiffening (``load``): ``theta = 1`` is a
joint spring twice as stiff at 1e4 N m as at no load."""
COM_UNIT_M = 0.1
"""Length of one unit of a fitted centre-of-mass offset [m] (``link_com`` here, the
seed-table fit's ``shape_bodies``): a ridge on the parameters pulls 0.1 m of offset as
hard as a factor e on a spring or a mass."""
MOMENT_FLOOR = 1e-9
"""Smallest principal moment of inertia of :class:`BodyMassModel` relative to the body's
largest (a point-like body keeps a finite log factor)."""
K_MAX = 1e15  # N/m: modal stiffness of a mode that does not move the TCP along a direction


def parameter_names(groups: Sequence[str]) -> tuple[str, ...]:
    """Names of the parameters of ``groups`` in order (``k1``, ``d1``, ``m_ee``, ``c1x``...).

    Damping factors are ``d1..d6`` so that they do not clash with the
    centre-of-mass offsets ``c1x..c6z``.
    """
    names: list[str] = []
    for g in groups:
        if g == "stiffness":
            names += [f"k{i}" for i in range(1, 7)]
        elif g == "damping":
            names += [f"d{i}" for i in range(1, 7)]
        elif g == "ee_mass":
            names.append("m_ee")
        elif g == "link_mass":
            names += [f"m{i}" for i in range(1, 7)]
        elif g == "link_com":
            names += [f"c{i}{a}" for i in range(1, 7) for a in "xyz"]
        elif g == "load":
            names += [f"l{i}" for i in range(1, 7)]
        else:
            raise InputError(f"params: expected groups from {tuple(PARAMETER_GROUPS)}, found {g!r}")
    return tuple(names)


def group_values(groups: Sequence[str], theta: ArrayLike) -> dict[str, FloatArray]:
    """Each group's fitted values in the robot file's terms.

    Factors (``exp(theta)``) for the stiffness, damping and mass groups; the
    centre-of-mass offsets [m], shape (6, 3); the load stiffening as the
    relative stiffening per 1e4 N m (``theta`` itself, shape (6,)).
    """
    out: dict[str, FloatArray] = {}
    for g, v in _split(groups, theta).items():
        if g == "link_com":
            out[g] = COM_UNIT_M * v.reshape(6, 3)
        elif g == "load":
            out[g] = np.array(v, dtype=np.float64)
        else:
            out[g] = np.exp(v)
    return out


def _split(groups: Sequence[str], theta: ArrayLike) -> dict[str, FloatArray]:
    th = np.asarray(theta, dtype=float)
    n = sum(PARAMETER_GROUPS[g] for g in groups)
    if th.shape != (n,):
        raise InputError(
            f"theta: expected shape ({n},) for groups {tuple(groups)}, found {th.shape}"
        )
    out: dict[str, FloatArray] = {}
    i = 0
    for g in groups:
        out[g] = th[i : i + PARAMETER_GROUPS[g]]
        i += PARAMETER_GROUPS[g]
    return out


def apply_parameters(base: Robot, groups: Sequence[str], theta: ArrayLike) -> Robot:
    """The robot file with the parameters ``theta`` of ``groups`` applied.

    Parameters
    ----------
    base : Robot
    groups : sequence of str
        Keys of :data:`PARAMETER_GROUPS`.
    theta : array_like, shape (n_params,)
        See the module table (0 = the robot file).

    Returns
    -------
    Robot
    """
    parts = _split(groups, theta)
    robot = base
    if "stiffness" in parts:
        robot = robot.with_stiffness(base.stiffness * np.exp(parts["stiffness"]))
    if "damping" in parts:
        robot = robot.with_damping(base.damping * np.exp(parts["damping"]))
    if "ee_mass" in parts:
        ee = base.end_effector
        if ee is None:
            raise InputError(
                "params: 'ee_mass' needs a robot with an end effector", source=base.source
            )
        s = float(np.exp(parts["ee_mass"][0]))
        robot = robot.replace(end_effector=RigidBody(ee.mass_kg * s, ee.com_m, ee.inertia_kgm2 * s))
    scale = np.exp(parts["link_mass"]) if "link_mass" in parts else np.ones(6)
    offset = (
        COM_UNIT_M * parts["link_com"].reshape(6, 3) if "link_com" in parts else np.zeros((6, 3))
    )
    if "link_mass" in parts or "link_com" in parts:
        joints = tuple(
            dataclasses.replace(
                jt,
                body=RigidBody(b.body.mass_kg * s, b.body.com_m + d, b.body.inertia_kgm2 * s),
            )
            for jt, b, s, d in zip(robot.joints, base.joints, scale, offset, strict=True)
        )
        robot = robot.replace(joints=joints)
    if "load" in parts:
        robot = robot.with_load_stiffening(base.load_stiffening + parts["load"] / LOAD_UNIT_NM)
    return robot


def modal_values(modes: Modes, directions: Sequence[str], n_modes: int) -> FloatArray:
    """Lowest modes per driving-point direction as ``(f, zeta, k)``.

    Parameters
    ----------
    modes : Modes
        Batch shape (n,).
    directions : sequence of str
        ``xx``, ``yy``, ``zz``.
    n_modes : int

    Returns
    -------
    ndarray, shape (n, n_dir, n_modes, 3)
        Frequency [Hz], damping ratio, modal stiffness at the direction [N/m]
        (capped at 1e15 for modes that do not move the TCP along it).
    """
    if modes.f_hz.shape[-1] < n_modes:
        raise InputError(f"n_modes: the twin has {modes.f_hz.shape[-1]} modes, asked {n_modes}")
    n = modes.f_hz.shape[0]
    out = np.empty((n, len(directions), n_modes, 3))
    for j, d in enumerate(directions):
        out[:, j, :, 0] = modes.f_hz[:, :n_modes]
        out[:, j, :, 1] = modes.zeta[:, :n_modes]
        k = np.abs(modes.k_N_per_m[:, dir_index(d)[0], :n_modes])
        out[:, j, :, 2] = np.where(np.isfinite(k), np.minimum(k, K_MAX), K_MAX)
    return out


def body_indices(name: str, bodies: Sequence[int], n: int) -> NDArray[np.intp]:
    """``bodies`` as an index array, checked to be distinct indices ``0..n-1``.

    Parameters
    ----------
    name : str
        The argument's name in the error message.
    bodies : sequence of int
        0-based bodies (0-5 links 1-6, 6 the end effector).
    n : int
        Number of bodies (6, or 7 with an end effector).

    Raises
    ------
    InputError
        On a repeated or out-of-range index.
    """
    idx = np.array([int(b) for b in bodies], dtype=np.intp)
    if len(set(idx.tolist())) != idx.size or np.any((idx < 0) | (idx >= n)):
        raise InputError(
            f"{name}: expected distinct body indices 0..{n - 1}, found {tuple(bodies)!r}"
        )
    return idx


class BodyMassModel:
    """Mass matrix and gravity torques of a twin's bodies at fixed postures.

    The shared mechanics of every parametrised twin. A body's Jacobians do not
    depend on its mass or inertia, and the linear Jacobian of its centre of
    mass ``c`` (body frame) is ``Jv(c) = Jv_o + sum_k c_k G_k`` with
    ``G_k = -[R e_k]_x Jw`` (``v = v_o + w x R c``), linear in ``c``. So the
    Jacobians are computed once at the postures, and for mass factors
    ``s_b``, centre-of-mass offsets ``d_b`` from the robot file's ``c0_b`` and
    log factors ``l_b`` on the principal moments

    ``M = sum_b s_b (m_b Jv_b^T Jv_b + Jw_b^T R_b I_b R_b^T Jw_b)``,
    ``Jv_b = Jv_b(c0_b + d_b)``, ``I_b = V_b diag(lam_b exp(l_b)) V_b^T``,
    ``tau_g = sum_b s_b m_b Jv_b[:, :6]^T g``

    with ``m_b``, ``lam_b``, ``V_b`` the robot file's mass, principal moments
    and principal axes (body frame), ``R_b`` the body frame's world rotation
    and ``g = (0, 0, -9.81) m/s^2``: ``tau_g`` are the generalised gravity
    forces on the six axes, as :func:`robolobe.twin.dynamics.gravity_torques`.
    Only the ``com_bodies`` move their centre of mass and only the
    ``moment_bodies`` change their principal moments; a mass factor scales a
    body's mass and inertia together.

    Parameters
    ----------
    system : SystemMatrices
        The twin at the postures (:func:`robolobe.twin.system.nominal_system`
        of the robot file), batch shape (n,).
    com_bodies, moment_bodies : sequence of int
        0-based bodies (0-5 links 1-6, 6 the end effector) whose centre of
        mass, respectively principal moments, are parameters.

    Attributes
    ----------
    mass_kg : ndarray, shape (nb,)
        The robot file's body masses [kg] (nb = 6, or 7 with an end effector).
    n_dof : int
        DOFs of the system (nd: six joints, then its compliances).
    n_postures : int
    com_bodies, moment_bodies : ndarray of int
    com_m : ndarray, shape (nc, 3)
        The file's centres of mass of the ``com_bodies``, body frame [m].
    moments_kgm2 : ndarray, shape (nm, 3)
        The file's principal moments of the ``moment_bodies`` about their
        centres of mass [kg m^2], at least :data:`MOMENT_FLOOR` x the largest.
    principal_axes : ndarray, shape (nm, 3, 3)
        Their principal axes as columns, body frame.
    gravity_m_per_s2 : ndarray, shape (3,)
    """

    def __init__(
        self,
        system: SystemMatrices,
        *,
        com_bodies: Sequence[int] = (),
        moment_bodies: Sequence[int] = (),
    ) -> None:
        robot = system.robot
        b = system.bodies
        if system.q.ndim != 2:
            raise InputError(
                f"postures: expected joint angles of shape (n, 6), found {system.q.shape}"
            )
        files = [jt.body for jt in robot.joints]
        if robot.end_effector is not None:
            files.append(robot.end_effector)
        nr = len(files)
        if b.names[:nr] != tuple(f"link{i + 1}" for i in range(6)) + ("end_effector",) * (nr - 6):
            raise InputError(f"system: expected the robot file's bodies first, found {b.names}")
        self.com_bodies = body_indices("com_bodies", com_bodies, nr)
        self.moment_bodies = body_indices("moment_bodies", moment_bodies, nr)
        self.mass_kg = np.asarray(b.mass_kg, dtype=np.float64)
        self.n_dof = int(system.n_dof)
        self.n_postures = int(system.q.shape[0])
        self.gravity_m_per_s2 = np.array([0.0, 0.0, -GRAVITY_M_PER_S2])
        # per-body parts at the robot file's masses, COMs and inertias, (n, nb, nd, nd)
        self._trans = np.einsum("b,pbki,pbkj->pbij", self.mass_kg, b.jv, b.jv)
        self._rot = np.einsum("pbki,pbkl,pblj->pbij", b.jw, b.inertia_kgm2, b.jw)
        self._parts = self._trans + self._rot
        self._tau = np.einsum("b,k,pbkj->pbj", self.mass_kg, self.gravity_m_per_s2, b.jv[..., :6])
        # body b is given in frame b + 1, (n, 3, 3) each
        rot = [system.frames[:, i + 1, :3, :3] for i in range(nr)]
        self.com_m = np.array([files[i].com_m for i in self.com_bodies]).reshape(-1, 3)
        self._g: list[FloatArray] = []  # d Jv / d c_k = -(R e_k) x Jw, (n, k, 3, nd)
        self._jvo: list[FloatArray] = []  # Jv of the body frame's origin, (n, 3, nd)
        for i, c0 in zip(self.com_bodies, self.com_m, strict=True):
            g = -np.cross(np.swapaxes(rot[i], 1, 2)[:, :, :, None], b.jw[:, i, None], axis=2)
            self._g.append(g)
            self._jvo.append(b.jv[:, i] - np.einsum("pkin,k->pin", g, c0))
        nm = self.moment_bodies.size
        self.moments_kgm2 = np.zeros((nm, 3))
        self.principal_axes = np.zeros((nm, 3, 3))
        self._a: list[FloatArray] = []  # Jw^T R V, (n, nd, 3)
        for n, i in enumerate(self.moment_bodies):
            lam, vec = np.linalg.eigh(files[i].inertia_kgm2)
            self.moments_kgm2[n] = np.maximum(lam, MOMENT_FLOOR * max(lam.max(), MOMENT_FLOOR))
            self.principal_axes[n] = vec
            self._a.append(np.einsum("pki,pkl,lm->pim", b.jw[:, i], rot[i], vec))

    def _offsets(self, offsets_m: ArrayLike | None) -> FloatArray:
        nc = self.com_bodies.size
        if offsets_m is None:
            return np.zeros((nc, 3))
        d = np.asarray(offsets_m, dtype=np.float64)
        if d.shape != (nc, 3):
            raise InputError(f"offsets_m: expected shape ({nc}, 3), found {d.shape}")
        return d

    def coms(self, offsets_m: ArrayLike | None = None) -> FloatArray:
        """Centres of mass of the ``com_bodies`` moved by ``offsets_m`` (nc, 3), body frame
        [m], shape (nc, 3)."""
        out: FloatArray = self.com_m + self._offsets(offsets_m)
        return out

    def moments(self, log_moments: ArrayLike | None = None) -> FloatArray:
        """Principal moments of the ``moment_bodies`` for log factors ``log_moments`` (nm, 3),
        at the file's masses [kg m^2], shape (nm, 3)."""
        if log_moments is None:
            return self.moments_kgm2.copy()
        out: FloatArray = self.moments_kgm2 * np.exp(np.asarray(log_moments, dtype=np.float64))
        return out

    def inertias(self, log_moments: ArrayLike | None = None) -> FloatArray:
        """Inertia tensors of the ``moment_bodies`` about their centres of mass, body
        frame, at the file's masses [kg m^2], shape (nm, 3, 3)."""
        v = self.principal_axes
        lam = self.moments(log_moments)
        return np.array([v[n] @ np.diag(lam[n]) @ v[n].T for n in range(len(v))]).reshape(-1, 3, 3)

    def com_jacobians(self, offsets_m: ArrayLike | None = None) -> list[FloatArray]:
        """World linear velocity of each moved centre of mass per unit DOF velocity.

        Parameters
        ----------
        offsets_m : array_like, shape (nc, 3), optional
            Centre-of-mass offsets of the ``com_bodies`` from the robot file's,
            body frame [m]; None: none.

        Returns
        -------
        list of ndarray, shape (n, 3, nd)
            One per ``com_bodies``.
        """
        return [
            jvo + np.einsum("pkin,k->pin", g, c)
            for jvo, g, c in zip(self._jvo, self._g, self.coms(offsets_m), strict=True)
        ]

    def body_matrices(
        self, offsets_m: ArrayLike | None = None, log_moments: ArrayLike | None = None
    ) -> FloatArray:
        """Each body's part of the mass matrix at the robot file's masses.

        Parameters
        ----------
        offsets_m : array_like, shape (nc, 3), optional
            Centre-of-mass offsets of the ``com_bodies``, body frame [m]; None:
            the file's centres of mass (and the file's parts of the bodies).
        log_moments : array_like, shape (nm, 3), optional
            Log factors on the principal moments of the ``moment_bodies``
            (None: 0).

        Returns
        -------
        ndarray, shape (n, nb, nd, nd)
            ``m_b Jv_b^T Jv_b + Jw_b^T I_b Jw_b``; the mass matrix for mass
            factors ``s`` is ``sum_b s_b`` of them (:meth:`mass_matrix`).
        """
        moved = offsets_m is not None and self.com_bodies.size > 0
        if not moved and not self.moment_bodies.size:
            return self._parts
        trans: dict[int, FloatArray] = {}
        if moved:
            for i, jv in zip(self.com_bodies, self.com_jacobians(offsets_m), strict=True):
                trans[int(i)] = self.mass_kg[i] * np.einsum("pki,pkj->pij", jv, jv)
        rot: dict[int, FloatArray] = {}
        for i, a, lam in zip(self.moment_bodies, self._a, self.moments(log_moments), strict=True):
            rot[int(i)] = np.einsum("pim,m,pjm->pij", a, lam, a)
        out = self._parts.copy()
        for i in set(trans) | set(rot):
            t = trans[i] if i in trans else self._trans[:, i]
            out[:, i] = t + (rot[i] if i in rot else self._rot[:, i])
        return out

    def mass_matrix(
        self,
        scales: ArrayLike,
        offsets_m: ArrayLike | None = None,
        log_moments: ArrayLike | None = None,
        *,
        body_parts: FloatArray | None = None,
    ) -> FloatArray:
        """The mass matrix, shape (n, nd, nd) (symmetric to rounding).

        Parameters
        ----------
        scales : array_like, shape (nb,)
            Factors on each body's mass and inertia (1: the robot file).
        offsets_m, log_moments : array_like, optional
            See :meth:`body_matrices`.
        body_parts : ndarray, shape (n, nb, nd, nd), optional
            :meth:`body_matrices` at ``offsets_m`` and ``log_moments``, where the
            caller has made it already (then those two are not used).
        """
        s = np.asarray(scales, dtype=np.float64)
        if body_parts is None:
            body_parts = self.body_matrices(offsets_m, log_moments)
        out: FloatArray = np.einsum("b,pbij->pij", s, body_parts)
        return out

    def body_gravity(self, offsets_m: ArrayLike | None = None) -> FloatArray:
        """Gravity torque of each body on the six axes at the robot file's masses.

        Parameters
        ----------
        offsets_m : array_like, shape (nc, 3), optional
            Centre-of-mass offsets of the ``com_bodies``, body frame [m].

        Returns
        -------
        ndarray, shape (n, nb, 6)
            ``m_b Jv_b[:, :6]^T g`` [N m]; linear in the mass factors.
        """
        if offsets_m is None or not self.com_bodies.size:
            return self._tau
        out = self._tau.copy()
        g = self.gravity_m_per_s2
        for i, jv in zip(self.com_bodies, self.com_jacobians(offsets_m), strict=True):
            out[:, i] = self.mass_kg[i] * np.einsum("k,pkj->pj", g, jv[..., :6])
        return out

    def gravity_torques(self, scales: ArrayLike, offsets_m: ArrayLike | None = None) -> FloatArray:
        """Gravity torques on the six axes [N m], shape (n, 6), for mass factors ``scales``
        (nb,) and centre-of-mass offsets ``offsets_m`` (nc, 3) [m]."""
        s = np.asarray(scales, dtype=np.float64)
        out: FloatArray = np.einsum("b,pbj->pj", s, self.body_gravity(offsets_m))
        return out

    def com_derivatives(
        self, posture: int | slice, offsets_m: ArrayLike | None = None, unit_m: float = 1.0
    ) -> tuple[FloatArray, FloatArray]:
        """Derivatives with respect to the centre-of-mass offsets.

        Parameters
        ----------
        posture : int or slice
            Index of the postures (``slice(None)``: all).
        offsets_m : array_like, shape (nc, 3), optional
            Where [m] (None: the robot file's centres of mass).
        unit_m : float
            Length of one unit of offset [m] the derivatives are taken per.

        Returns
        -------
        dm : ndarray, shape (..., nc, 3, nd, nd)
            ``d (m_c Jv_c^T Jv_c) / d d_ck`` per unit of offset along body axis
            k of ``com_bodies[c]``, file masses (the only body part it
            changes); ``...`` is () for one posture, (n,) for a slice.
        dtau : ndarray, shape (..., nc, 3, 6)
            ``d tau_c / d d_ck`` [N m per unit] of :meth:`body_gravity`.
        """
        nd = self.n_dof
        batch = np.empty(self.n_postures)[posture].shape
        dm = np.zeros((*batch, self.com_bodies.size, 3, nd, nd))
        dtau = np.zeros((*batch, self.com_bodies.size, 3, 6))
        jvs = self.com_jacobians(offsets_m)
        for n, (i, g, jv) in enumerate(zip(self.com_bodies, self._g, jvs, strict=True)):
            m = self.mass_kg[i]
            gk = g[posture] * unit_m  # (..., 3 (k), 3, nd)
            a = m * np.swapaxes(gk, -1, -2) @ jv[posture][..., None, :, :]
            dm[..., n, :, :, :] = a + np.swapaxes(a, -1, -2)
            dtau[..., n, :, :] = m * self.gravity_m_per_s2 @ gk[..., :6]
        return dm, dtau

    def moment_derivatives(
        self, posture: int | slice, log_moments: ArrayLike | None = None
    ) -> FloatArray:
        """Derivatives with respect to the log factors on the principal moments.

        Parameters
        ----------
        posture : int or slice
            Index of the postures (``slice(None)``: all).
        log_moments : array_like, shape (nm, 3), optional
            Where (None: 0).

        Returns
        -------
        ndarray, shape (..., nm, 3, nd, nd)
            ``d (Jw_b^T I_b Jw_b) / d l_bk`` of ``moment_bodies[b]`` and principal
            axis k, file masses; ``...`` as in :meth:`com_derivatives`.
        """
        lam = self.moments(log_moments)
        nd = self.n_dof
        batch = np.empty(self.n_postures)[posture].shape
        out = np.zeros((*batch, len(self._a), 3, nd, nd))
        for n, a in enumerate(self._a):
            for k in range(3):
                col = a[posture, :, k]  # (..., nd)
                out[..., n, k, :, :] = lam[n, k] * (col[..., :, None] * col[..., None, :])
        return out


@dataclasses.dataclass(frozen=True)
class _State:
    """:class:`ParametrizedTwin` at one theta: mass factors (nb,), COM offsets [m]
    (6, 3) or None, body parts of M (n, nb, nd, nd), M (n, nd, nd), K and C
    (nd, nd), undamped frequencies [rad/s] (n, nd) and mass-normalised shapes
    (n, nd, nd)."""

    scales: FloatArray
    com_off: FloatArray | None
    body_parts: FloatArray
    M: FloatArray
    K: FloatArray
    C: FloatArray
    w0: FloatArray
    phi: FloatArray


class ParametrizedTwin:
    """Modes of a robot file's twin at fixed postures as a function of ``theta``.

    Parameters
    ----------
    base : Robot
        The robot file (its twin has no effects).
    q_rad : array_like, shape (n, 6)
        Joint angles [rad].
    groups : sequence of str
        Parameter groups (:data:`PARAMETER_GROUPS`).
    directions : sequence of str
        Driving points of :meth:`values`.
    n_modes : int
        Modes per direction of :meth:`values`.

    Notes
    -----
    The last theta's matrices and undamped modes, and its values, are kept
    and reused (a fit asks for the values and the Jacobian at the same
    theta); :meth:`values` returns a copy.
    """

    def __init__(
        self,
        base: Robot,
        q_rad: ArrayLike,
        groups: Sequence[str],
        *,
        directions: Sequence[str] = ("xx", "yy"),
        n_modes: int = 5,
    ) -> None:
        from robolobe.twin.system import nominal_system

        self.groups = tuple(groups)
        self.names = parameter_names(self.groups)
        if "ee_mass" in self.groups and base.end_effector is None:
            raise InputError(
                "params: 'ee_mass' needs a robot with an end effector", source=base.source
            )
        bad = [d for d in directions if d not in DRIVING]
        if bad:
            raise InputError(f"directions: expected some of {DRIVING}, found {bad}")
        self.directions = tuple(directions)
        self.n_modes = int(n_modes)
        sys_ = nominal_system(base, q_rad)
        nd = sys_.n_dof
        self._nd = nd
        # diagonal springs/dampers: the six joints (at no load), then the file's
        # compliance DOFs
        self._k0 = np.diagonal(sys_.K.reshape(-1, nd, nd)[0]).copy()
        self._k0[:6] = base.stiffness
        self._c0 = np.diagonal(sys_.C.reshape(-1, nd, nd)[0]).copy()
        # the joint springs' load stiffening per N m: the file's, plus the fitted one
        self._s0 = np.asarray(base.load_stiffening, dtype=np.float64)
        self._loaded = "load" in self.groups or bool(np.any(self._s0 > 0))
        self._bodies = BodyMassModel(sys_, com_bodies=range(6) if "link_com" in self.groups else ())
        self._J = sys_.J
        self._eye = np.eye(nd)
        # the last theta's matrices and undamped modes, and the last values: a fit asks
        # for the values and the Jacobian at the same theta (one entry each, exact reuse)
        self._last_state: tuple[bytes, _State] | None = None
        self._last_values: tuple[tuple[bytes, int, tuple[str, ...]], FloatArray] | None = None

    @property
    def n_params(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def modes(self, theta: ArrayLike) -> Modes:
        """Modes at every posture for parameters ``theta`` (shape (n_params,)).

        An overdamped mode (two real poles) keeps its slot with the natural
        frequency ``sqrt(p1 p2)`` and damping ratio (>= 1) of its pair
        (``overdamped="keep"``): a calibration fits the exact poles of heavily
        damped joints too.
        """
        m, k, c = self._matrices(theta)
        return compute_modes(m, k, c, self._J, overdamped="keep")

    def _mass_parts(self, parts: dict[str, FloatArray]) -> tuple[FloatArray, FloatArray | None]:
        """Mass factors (nb,) and the links' COM offsets [m] (6, 3), None if none."""
        s = np.ones(len(self._bodies.mass_kg))
        if "link_mass" in parts:
            s[:6] = np.exp(parts["link_mass"])
        if "ee_mass" in parts:
            s[6] = np.exp(parts["ee_mass"][0])
        d = None
        if "link_com" in parts and np.any(parts["link_com"]):
            d = COM_UNIT_M * parts["link_com"].reshape(6, 3)
        return s, d

    def _matrices(self, theta: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """M (n, nd, nd), K ((n, nd, nd) with load stiffening, else (nd, nd)) and C
        (nd, nd) for ``theta`` (nd = 6 + compliance DOFs)."""
        parts = _split(self.groups, theta)
        s, d = self._mass_parts(parts)
        return (self._bodies.mass_matrix(s, d), *self._springs(parts, s, d))

    def _state(self, theta: ArrayLike) -> _State:
        """The matrices and undamped modes at ``theta`` (the last theta's reused)."""
        th = np.array(theta, dtype=np.float64)
        key = th.tobytes()
        if self._last_state is not None and self._last_state[0] == key:
            return self._last_state[1]
        parts = _split(self.groups, th)
        s, com_off = self._mass_parts(parts)
        mb = self._bodies.body_matrices(com_off)  # (n, nb, nd, nd): d M / d log(mass factor)
        m = self._bodies.mass_matrix(s, body_parts=mb)
        kmat, cmat = self._springs(parts, s, com_off)
        w0, phi = undamped_modes(m, kmat)
        state = _State(s, com_off, mb, m, kmat, cmat, w0, phi)
        self._last_state = (key, state)
        return state

    def _springs(
        self, parts: dict[str, FloatArray], scales: FloatArray, com_off: FloatArray | None
    ) -> tuple[FloatArray, FloatArray]:
        """K and C for the parameter groups ``parts`` (mass factors ``scales`` and COM
        offsets ``com_off`` give the gravity torques of the load stiffening): K (nd, nd),
        or (n, nd, nd) where the joint springs stiffen with load; C (nd, nd)."""
        k, c = self._k0.copy(), self._c0.copy()
        if "stiffness" in parts:
            k[:6] *= np.exp(parts["stiffness"])
        if "damping" in parts:
            c[:6] *= np.exp(parts["damping"])
        if not self._loaded:
            return self._eye * k, self._eye * c
        kk = np.broadcast_to(k, (self._bodies.n_postures, k.size)).copy()
        kk[:, :6] *= 1.0 + self._load_s(parts) * self._tau(scales, com_off)
        return kk[:, :, None] * self._eye, self._eye * c

    def _load_s(self, parts: dict[str, FloatArray]) -> FloatArray:
        """Load stiffening per N m of each joint (6,): the file's plus the fitted one."""
        return self._s0 + (parts["load"] / LOAD_UNIT_NM if "load" in parts else 0.0)

    def _tau(self, scales: FloatArray, com_off: FloatArray | None) -> FloatArray:
        """|gravity torque| on the six axes [N m], (n, 6), at these masses."""
        return np.abs(self._bodies.gravity_torques(scales, com_off))

    def log_jacobian(self, theta: ArrayLike) -> FloatArray:
        """Derivatives of the log of :meth:`values` with respect to ``theta``.

        From first-order eigen-sensitivities of the undamped problem
        (``d omega^2 = phi^T (dK - omega^2 dM) phi``, shape derivatives by
        modal expansion over all modes); the damping ratio as
        ``phi^T C phi / (2 omega)``. Exact for the undamped quantities; for the
        damped frequency and damping ratio accurate to the order of the
        damping (enough for Gauss-Newton steps; the residuals stay exact).

        Returns
        -------
        ndarray, shape (n, n_dir, n_modes, 3, n_params)
            ``d log(f, zeta, k) / d theta``; 0 where a stiffness is capped
            (a mode that does not move the TCP along the direction).
        """
        st = self._state(theta)
        s, com_off, mb = st.scales, st.com_off, st.body_parts
        n, p, nd = self._bodies.n_postures, self.n_params, self._nd
        k = np.broadcast_to(np.diagonal(st.K, axis1=-2, axis2=-1), (n, nd))
        c = np.diag(st.C)
        # the derivatives of K and of M are zero but for the stiffness and the mass
        # parameters: the products below are taken for those rows alone. With load
        # stiffening the springs hold the gravity torques, which the mass factors scale
        # (a term in K of theirs); the centres of mass move them too: that term is left
        # out (Gauss-Newton steps; the residuals stay exact)
        k_rows: list[int] = []
        m_rows: list[int] = []
        dm_parts: list[FloatArray] = []
        dk = np.zeros((n, p, nd))
        dc = np.zeros((p, nd))
        j6 = np.arange(6)
        dk_mass = None
        if self._loaded:
            parts = _split(self.groups, theta)
            k_free = self._k0[:6] * (np.exp(parts["stiffness"]) if "stiffness" in parts else 1.0)
            tau_b = self._bodies.body_gravity(com_off)  # (n, nb, 6), linear in the factors
            tau = np.einsum("b,pbj->pj", s, tau_b)  # BodyMassModel.gravity_torques, once
            # d K_jj / d log(mass factor b) = k_j s_j sign(tau_j) s_b tau_bj: (n, nb, 6)
            dk_mass = (k_free * self._load_s(parts) * np.sign(tau))[:, None, :] * (
                s[None, :, None] * tau_b
            )
        i0 = 0
        for g in self.groups:
            size = PARAMETER_GROUPS[g]
            rows = list(range(i0, i0 + size))
            if g == "stiffness":
                dk[:, i0 + j6, j6] = k[:, :6]
                k_rows += rows
            elif g == "load":
                dk[:, i0 + j6, j6] = k_free * np.abs(tau) / LOAD_UNIT_NM
                k_rows += rows
            elif g == "damping":
                dc[i0 : i0 + 6, :6] = np.diag(c[:6])
            elif g == "ee_mass":
                dm_parts.append(s[6] * mb[:, 6:7])
                m_rows += rows
                if dk_mass is not None:
                    dk[:, i0, :6] = dk_mass[:, 6]
                    k_rows += rows
            elif g == "link_mass":
                dm_parts.append(s[:6, None, None] * mb[:, :6])
                m_rows += rows
                if dk_mass is not None:
                    dk[:, i0 : i0 + 6, :6] = dk_mass[:, :6]
                    k_rows += rows
            else:  # link_com: one unit is COM_UNIT_M along a link's own axis
                dcom = self._bodies.com_derivatives(slice(None), com_off, COM_UNIT_M)[0]
                dcom = s[None, :6, None, None, None] * dcom  # (n, 6, 3, nd, nd)
                dm_parts.append(dcom.reshape(n, 18, nd, nd))
                m_rows += rows
            i0 += size
        w0, phi = st.w0, st.phi
        lam = w0**2  # (n, r)
        # phi^T dK_p phi and phi^T dM_p phi as batched products (the three-operand
        # einsums, unoptimised, were most of a calibration's time)
        pt = np.swapaxes(phi, -1, -2)[:, None]  # (n, 1, r, i)
        gk = np.zeros((n, p, nd, nd))
        hm = np.zeros((n, p, nd, nd))
        if k_rows:
            gk[:, k_rows] = (pt * dk[:, k_rows, None, :]) @ phi[:, None]
        if m_rows:
            hm[:, m_rows] = pt @ np.concatenate(dm_parts, axis=1) @ phi[:, None]
        a = gk - lam[:, None, None, :] * hm  # (n, p, s, r): phi_s^T (dK - lam_r dM) phi_r
        dlam = np.diagonal(a, axis1=-2, axis2=-1)  # (n, p, r)
        gap = lam[:, None, :] - lam[:, :, None]  # (n, s, r): lam_r - lam_s
        off = ~np.eye(nd, dtype=bool)
        safe = np.where(off & (np.abs(gap) > 1e-12 * lam[:, None, :]), gap, np.inf)
        coef = a / safe[:, None]
        coef[..., ~off] = -0.5 * np.diagonal(hm, axis1=-2, axis2=-1).reshape(n, p, nd)
        u = self._J @ phi  # (n, 3, r)
        du = u[:, None] @ coef  # (n, p, 3, r)
        dlog_w = 0.5 * dlam / lam[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            dlog_k = 2.0 * dlog_w[:, :, None, :] - 2.0 * du / u[:, None]  # (n, p, 3, r)
        cm = (np.swapaxes(phi, -1, -2) * c) @ phi  # (n, r, s)
        cr = np.diagonal(cm, axis1=-2, axis2=-1)  # (n, r)
        dcr = np.einsum("pi,nir->npr", dc, phi * phi) + 2.0 * np.einsum("nrs,npsr->npr", cm, coef)
        dlog_z = dcr / cr[:, None, :] - dlog_w
        nm = self.n_modes
        vals = self.values(theta)
        out = np.zeros((n, len(self.directions), nm, 3, p))
        out[:, :, :, 0] = np.swapaxes(dlog_w[..., :nm], 1, 2)[:, None]
        out[:, :, :, 1] = np.swapaxes(dlog_z[..., :nm], 1, 2)[:, None]
        for j, d in enumerate(self.directions):
            dk_d = np.swapaxes(dlog_k[:, :, dir_index(d)[0], :nm], 1, 2)  # (n, r, p)
            capped = vals[:, j, :, 2] >= K_MAX
            out[:, j, :, 2] = np.where(capped[..., None] | ~np.isfinite(dk_d), 0.0, dk_d)
        return out

    def values(self, theta: ArrayLike) -> FloatArray:
        """:func:`modal_values` of :meth:`modes`, shape (n, n_dir, n_modes, 3).

        Computes only what the values need (pole frequencies and damping from
        the eigenvalues of the state matrix, modal stiffness from the
        undamped shapes), as :func:`robolobe.twin.modes.compute_modes` does;
        an overdamped mode as under ``overdamped="keep"`` (frequency
        ``sqrt(p1 p2) / 2 pi`` and damping ratio >= 1 of its real poles).
        """
        key = (np.array(theta, dtype=np.float64).tobytes(), self.n_modes, self.directions)
        if self._last_values is not None and self._last_values[0] == key:
            return self._last_values[1].copy()
        st = self._state(theta)
        m, k, c, w0, phi = st.M, st.K, st.C, st.w0, st.phi
        u = self._J @ phi  # (n, 3, nm)
        with np.errstate(divide="ignore"):
            k_modal = (w0**2)[:, None, :] / u**2
        nd = m.shape[-1]
        _, w, zeta = overdamped_modes(m, k, c)
        nm = self.n_modes
        if nd < nm:
            raise InputError(f"n_modes: the twin has {nd} modes, asked {nm}")
        out = np.empty((m.shape[0], len(self.directions), nm, 3))
        out[..., 0] = w[:, None, :nm] / (2.0 * np.pi)
        out[..., 1] = zeta[:, None, :nm]
        for j, d in enumerate(self.directions):
            kk = np.abs(k_modal[:, dir_index(d)[0], :nm])
            out[:, j, :, 2] = np.where(np.isfinite(kk), np.minimum(kk, K_MAX), K_MAX)
        self._last_values = (key, out.copy())
        return out
