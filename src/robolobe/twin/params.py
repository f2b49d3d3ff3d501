"""Robot-file parameters that a twin calibration can fit, and their fast evaluation.

The one parametrised-twin core: the transfer calibration
(:class:`robolobe.tl.graybox.TwinCalibration`), the diagnosis' file
calibration (:mod:`robolobe.diagnose.calibration`) and the plan-safety study
fit and perturb robot files through these groups.

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
========== ==== ====================================================

:class:`ParametrizedTwin` evaluates the twin's modes for many ``theta`` at
fixed postures without rebuilding the robot: the bodies' Jacobians are
computed once, and the mass matrix is reassembled from them (a moved centre
of mass changes a body's linear Jacobian by ``-[R d]_x Jw``). It gives the same
modes as ``Twin(apply_parameters(robot, groups, theta)).modes(q)`` (tested to
1e-9) about three times faster, which is what makes the 37-parameter fit
quick. A robot file with the optional tilt or mount compliances (docs/guide/robots.md
extension, README "Robot description") keeps those DOFs at their
file values: the groups act on the six joint springs and dampers and on the
bodies, the extra DOFs move the bodies as in the twin.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import DRIVING, dir_index
from robolobe.errors import InputError
from robolobe.robots.model import RigidBody, Robot
from robolobe.robots.transforms import skew
from robolobe.twin.modes import Modes, compute_modes, damped_poles, undamped_modes

__all__ = [
    "COM_UNIT_M",
    "PARAMETER_GROUPS",
    "ParametrizedTwin",
    "apply_parameters",
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
}
COM_UNIT_M = 0.1
"""Length of one unit of a ``link_com`` parameter [m]."""
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
        else:
            raise InputError(f"params: expected groups from {tuple(PARAMETER_GROUPS)}, found {g!r}")
    return tuple(names)


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
        b = sys_.bodies
        nb = len(b.mass_kg)
        nd = sys_.n_dof
        self._nd = nd
        # diagonal springs/dampers: the six joints, then the file's compliance DOFs
        self._k0 = np.diagonal(sys_.K.reshape(-1, nd, nd)[0]).copy()
        self._c0 = np.diagonal(sys_.C.reshape(-1, nd, nd)[0]).copy()
        self._m0 = b.mass_kg  # (nb,)
        self._jv = b.jv  # (n, nb, 3, 6) at the file's COMs
        self._jw = b.jw
        self._rot = sys_.frames[:, 1 : nb + 1, :3, :3]  # body frames, as robot_bodies
        self._mw = np.einsum("nbki,nbkl,nblj->nbij", b.jw, b.inertia_kgm2, b.jw)
        self._mv = np.einsum("nbki,nbkj->nbij", b.jv, b.jv)
        self._J = sys_.J
        self._eye = np.eye(nd)

    @property
    def n_params(self) -> int:
        """Number of parameters."""
        return len(self.names)

    def modes(self, theta: ArrayLike) -> Modes:
        """Modes at every posture for parameters ``theta`` (shape (n_params,))."""
        m, k, c = self._matrices(theta)
        return compute_modes(m, k, c, self._J)

    def _mass_parts(
        self, parts: dict[str, FloatArray]
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Mass scales (nb,), links' COM Jacobians (n, 6, 3, 6) and ``Jv^T Jv`` (n, nb, 6, 6)."""
        s = np.ones(len(self._m0))
        if "link_mass" in parts:
            s[:6] = np.exp(parts["link_mass"])
        if "ee_mass" in parts:
            s[6] = np.exp(parts["ee_mass"][0])
        jv = self._jv[:, :6]
        mv = self._mv
        if "link_com" in parts and np.any(parts["link_com"]):
            d = COM_UNIT_M * parts["link_com"].reshape(6, 3)
            r = np.einsum("nbij,bj->nbi", self._rot[:, :6], d)  # world offsets (n, 6, 3)
            jv = jv - skew(r) @ self._jw[:, :6]  # v = v0 + w x r
            mv = np.concatenate([np.einsum("nbki,nbkj->nbij", jv, jv), self._mv[:, 6:]], axis=1)
        return s, jv, mv

    def _matrices(self, theta: ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """M (n, nd, nd), K and C (nd, nd) for ``theta`` (nd = 6 + compliance DOFs)."""
        parts = _split(self.groups, theta)
        s, _, mv = self._mass_parts(parts)
        m = np.einsum("b,nbij->nij", self._m0 * s, mv) + np.einsum("b,nbij->nij", s, self._mw)
        m = 0.5 * (m + np.swapaxes(m, -1, -2))
        k, c = self._k0.copy(), self._c0.copy()
        if "stiffness" in parts:
            k[:6] *= np.exp(parts["stiffness"])
        if "damping" in parts:
            c[:6] *= np.exp(parts["damping"])
        return m, self._eye * k, self._eye * c

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
        parts = _split(self.groups, theta)
        s, jv, mv = self._mass_parts(parts)
        w = self._m0 * s
        n, p, nd = self._jv.shape[0], self.n_params, self._nd
        m, kmat, cmat = self._matrices(theta)
        k, c = np.diag(kmat), np.diag(cmat)
        dm = np.zeros((n, p, nd, nd))
        dk = np.zeros((p, nd))
        dc = np.zeros((p, nd))
        i0 = 0
        for g in self.groups:
            size = PARAMETER_GROUPS[g]
            if g == "stiffness":
                dk[i0 : i0 + 6, :6] = np.diag(k[:6])
            elif g == "damping":
                dc[i0 : i0 + 6, :6] = np.diag(c[:6])
            elif g == "ee_mass":
                dm[:, i0] = w[6] * mv[:, 6] + s[6] * self._mw[:, 6]
            elif g == "link_mass":
                dm[:, i0 : i0 + 6] = (
                    w[:6, None, None] * mv[:, :6] + s[:6, None, None] * self._mw[:, :6]
                )
            else:  # link_com: d jv_b / d theta_ba = -unit * (R_b e_a) x w_b
                axes = np.swapaxes(self._rot[:, :6], -1, -2)  # (n, 6, a, 3): R_b e_a
                djv = -COM_UNIT_M * skew(axes) @ self._jw[:, :6, None]  # (n, 6, a, 3, 6)
                t = np.einsum("nbakj,nbki->nbaij", djv, jv)  # jv^T djv, symmetrised below
                t = w[None, :6, None, None, None] * (t + np.swapaxes(t, -1, -2))
                dm[:, i0 : i0 + 18] = t.reshape(n, 18, nd, nd)
            i0 += size
        w0, phi = undamped_modes(m, kmat)
        lam = w0**2  # (n, r)
        gk = np.einsum("nir,pi,nis->nprs", phi, dk, phi)
        hm = np.einsum("nir,npij,njs->nprs", phi, dm, phi)
        a = gk - lam[:, None, None, :] * hm  # (n, p, s, r): phi_s^T (dK - lam_r dM) phi_r
        dlam = np.diagonal(a, axis1=-2, axis2=-1)  # (n, p, r)
        gap = lam[:, None, :] - lam[:, :, None]  # (n, s, r): lam_r - lam_s
        off = ~np.eye(nd, dtype=bool)
        safe = np.where(off & (np.abs(gap) > 1e-12 * lam[:, None, :]), gap, np.inf)
        coef = a / safe[:, None]
        coef[..., ~off] = -0.5 * np.diagonal(hm, axis1=-2, axis2=-1).reshape(n, p, nd)
        u = self._J @ phi  # (n, 3, r)
        du = np.einsum("nds,npsr->npdr", u, coef)
        dlog_w = 0.5 * dlam / lam[:, None, :]
        with np.errstate(divide="ignore", invalid="ignore"):
            dlog_k = 2.0 * dlog_w[:, :, None, :] - 2.0 * du / u[:, None]  # (n, p, 3, r)
        cm = np.einsum("nir,i,nis->nrs", phi, c, phi)
        cr = np.diagonal(cm, axis1=-2, axis2=-1)  # (n, r)
        dcr = np.einsum("nir,pi,nir->npr", phi, dc, phi) + 2.0 * np.einsum(
            "nrs,npsr->npr", cm, coef
        )
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
        undamped shapes), as :func:`robolobe.twin.modes.compute_modes` does.
        """
        m, k, c = self._matrices(theta)
        w0, phi = undamped_modes(m, k)
        u = self._J @ phi  # (n, 3, nm)
        with np.errstate(divide="ignore"):
            k_modal = (w0**2)[:, None, :] / u**2
        nd = m.shape[-1]
        lam, _ = damped_poles(m, k, c)
        w = np.abs(lam)
        nm = self.n_modes
        if nd < nm:
            raise InputError(f"n_modes: the twin has {nd} modes, asked {nm}")
        out = np.empty((m.shape[0], len(self.directions), nm, 3))
        out[..., 0] = w[:, None, :nm] / (2.0 * np.pi)
        out[..., 1] = (-lam.real / w)[:, None, :nm]
        for j, d in enumerate(self.directions):
            kk = np.abs(k_modal[:, dir_index(d)[0], :nm])
            out[:, j, :, 2] = np.where(np.isfinite(kk), np.minimum(kk, K_MAX), K_MAX)
        return out
