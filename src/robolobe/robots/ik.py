"""Inverse kinematics: closed form for ortho-parallel arms with a spherical wrist.

The closed form is convention-free: the robot's joint axes at DH angles
theta = 0 give a product-of-exponentials model, and the pose is solved with
Paden-Kahan subproblems (shoulder angle from the plane of the parallel axes
2 and 3, elbow by subproblem 3, shoulder pitch by subproblem 1, wrist by
subproblems 2 and 1). It covers both DH conventions, lateral offsets along
axes 2/3, any base/tool, and the coupling (solved for DH angles, mapped back
to axis angles with the inverse coupling and offsets). Requirements: axes 2
and 3 parallel, axis 1 not parallel to them, axes 4, 5, 6 meeting in one point
(checked; :func:`is_closed_form`). Other arms fall back to damped least
squares (:func:`ik_numeric`).

Branches: up to 8 per pose (shoulder x elbow x wrist, ``branch`` bits 0, 1, 2)
plus the ±2π multiples of joints whose range exceeds a turn; each is flagged
for joint limits and constraints.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import ConvergenceError, InputError, ReachabilityError, SingularityError
from robolobe.robots.kinematics import joint_transforms, link_frames, tcp_jacobian, tcp_pose
from robolobe.robots.limits import within_constraints, within_joint_limits
from robolobe.robots.model import Robot
from robolobe.robots.transforms import inv_pose, xyz_zyx_from_pose

__all__ = [
    "SINGULAR_TOL",
    "IKResult",
    "ik",
    "ik_batch",
    "ik_branches",
    "ik_numeric",
    "ik_numeric_many",
    "is_closed_form",
    "nearest",
    "pose_error",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

SINGULAR_TOL = 1e-3
"""Default singularity threshold ``tol``: wrist flagged when |sin(bend)| (|sin q5| for the
usual wrist) < tol, elbow when ``1 - |cos|`` of the elbow angle < tol**2 (about tol*sqrt(2)
rad from stretched/folded), shoulder when the wrist centre is < tol [m] from the
shoulder-singular set (axis 1 for arms without lateral offset)."""

_POS_TOL_M = 1e-7
_ROT_TOL_RAD = 1e-7
_TWO_PI = 2.0 * math.pi


# ----------------------------------------------------------------- helpers
def _dot(a: FloatArray, b: FloatArray) -> FloatArray:
    return np.einsum("...i,...i->...", a, b)


def _rot(axis: FloatArray, angle: FloatArray) -> FloatArray:
    """Rodrigues rotation about unit ``axis`` (3,) by ``angle`` (...); (..., 3, 3)."""
    k = axis
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * kx + (1.0 - c) * (kx @ kx)


def _sp1(axis: FloatArray, a: FloatArray, b: FloatArray) -> FloatArray:
    """Angle rotating vector ``a`` onto ``b`` about unit ``axis`` (subproblem 1)."""
    ap = a - axis * _dot(a, axis)[..., None]
    bp = b - axis * _dot(b, axis)[..., None]
    return np.arctan2(_dot(axis, np.cross(ap, bp)), _dot(ap, bp))


def _wrap(x: FloatArray) -> FloatArray:
    return (x + math.pi) % _TWO_PI - math.pi


def pose_error(a: ArrayLike, b: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Position [m] and rotation-angle [rad] difference of poses; shapes (...,)."""
    pa, pb = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    dp = np.linalg.norm(pa[..., :3, 3] - pb[..., :3, 3], axis=-1)
    rel = np.swapaxes(pa[..., :3, :3], -1, -2) @ pb[..., :3, :3]
    cos = np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    # accurate for small angles: use the skew part too
    skew = np.stack(
        [rel[..., 2, 1] - rel[..., 1, 2], rel[..., 0, 2] - rel[..., 2, 0],
         rel[..., 1, 0] - rel[..., 0, 1]], -1
    )  # fmt: skip
    ang = np.arctan2(np.linalg.norm(skew, axis=-1) / 2.0, cos)
    return dp, ang


def _describe_pose(pose: FloatArray) -> str:
    xyz, zyx = xyz_zyx_from_pose(pose)
    return (
        f"pose xyz_mm = [{', '.join(f'{v:.1f}' for v in xyz * 1e3)}], "
        f"zyx_deg = [{', '.join(f'{v:.2f}' for v in np.degrees(zyx))}]"
    )


# ------------------------------------------------------------- geometry
@dataclass(frozen=True, eq=False)
class _Geometry:
    """Product-of-exponentials data at DH angles theta = 0, in the base frame."""

    w: FloatArray  # (6, 3) axis directions
    p: FloatArray  # (6, 3) points on the axes
    m: FloatArray  # (4, 4) TCP at theta = 0 (base frame)
    m_inv: FloatArray
    wrist: FloatArray  # (3,) wrist centre at theta = 0
    scale: float  # length scale [m] of the arm
    closed_form: bool
    reason: str
    c_inv: FloatArray  # (6, 6) inverse coupling
    unimodular: bool  # integer coupling with |det| = 1: 2*pi shifts per axis are exact


def _line_point(ws: FloatArray, ps: FloatArray) -> tuple[FloatArray, float]:
    """Least-squares point nearest to lines (w_k, p_k) and its largest distance."""
    a = np.zeros((3, 3))
    rhs = np.zeros(3)
    for w, p in zip(ws, ps, strict=True):
        proj = np.eye(3) - np.outer(w, w)
        a += proj
        rhs += proj @ p
    x = np.asarray(np.linalg.lstsq(a, rhs, rcond=None)[0], dtype=np.float64)
    dist = max(float(np.linalg.norm((np.eye(3) - np.outer(w, w)) @ (x - p))) for w, p in
               zip(ws, ps, strict=True))  # fmt: skip
    return x, dist


@functools.lru_cache(maxsize=64)
def _geometry(robot: Robot) -> _Geometry:
    tj = joint_transforms(robot, np.zeros(6))
    frames = [np.eye(4)]
    for i in range(6):
        frames.append(frames[-1] @ tj[i])
    axis_frames = frames[0:6] if robot.convention == "standard-dh" else frames[1:7]
    w = np.array([f[:3, 2] for f in axis_frames])
    p = np.array([f[:3, 3] for f in axis_frames])
    m = frames[6] @ robot.tool
    scale = max(1.0, float(np.abs(p).max()))
    reason = ""
    if np.linalg.norm(np.cross(w[1], w[2])) > 1e-9:
        reason = "axes 2 and 3 are not parallel"
    elif np.linalg.norm(np.cross(w[0], w[1])) < 1e-6:
        reason = "axis 1 is parallel to axis 2"
    elif np.linalg.norm(np.cross(w[3], w[4])) < 1e-6 or np.linalg.norm(np.cross(w[4], w[5])) < 1e-6:
        reason = "wrist axes 4/5 or 5/6 are parallel"
    wrist, dist = _line_point(w[3:], p[3:])
    if not reason and dist > 1e-9 * scale:
        reason = f"wrist axes 4, 5, 6 do not meet in one point (off by {dist:.3g} m)"
    if not reason:
        # the wrist centre must not lie on axis 3 (elbow undefined)
        r3 = wrist - p[2]
        if np.linalg.norm(r3 - w[2] * np.dot(r3, w[2])) < 1e-9:
            reason = "the wrist centre lies on axis 3"
    c = robot.coupling
    c_inv = np.asarray(np.linalg.inv(c), dtype=np.float64)
    unimodular = bool(np.allclose(c, np.round(c)) and abs(abs(np.linalg.det(c)) - 1.0) < 1e-9)
    for arr in (w, p, m, wrist, c_inv):
        arr.setflags(write=False)
    return _Geometry(w, p, m, inv_pose(m), wrist, scale, not reason, reason, c_inv, unimodular)


def is_closed_form(robot: Robot) -> bool:
    """Whether the closed-form IK applies (ortho-parallel arm, spherical wrist)."""
    return _geometry(robot).closed_form


# -------------------------------------------------------------- closed form
@dataclass(frozen=True)
class _Branches:
    theta: FloatArray  # (n, 8, 6) DH angles, NaN where no solution
    ok: BoolArray  # (n, 8)
    wrist_measure: FloatArray  # (n, 8)
    elbow_measure: FloatArray  # (n, 8)
    shoulder_measure: FloatArray  # (n,)


def _closed_form(robot: Robot, poses: FloatArray, theta_ref: FloatArray | None = None) -> _Branches:
    """All 8 branches; ``theta_ref`` (n, 6) DH angles fill free angles at singularities."""
    g = _geometry(robot)
    n = poses.shape[0]
    w, p = g.w, g.p
    gm = inv_pose(robot.base) @ poses @ g.m_inv  # (n, 4, 4): product of exponentials
    rg, tg = gm[:, :3, :3], gm[:, :3, 3]
    qw = (rg @ g.wrist) + tg  # (n, 3) target wrist centre

    # --- theta1: bring the wrist centre into the plane of axes 2/3 (perp. to w2)
    v = qw - p[0]
    v_par = np.outer(_dot(v, w[0]), w[0])
    v_perp = v - v_par
    a_ = _dot(v_perp, w[1])
    b_ = -_dot(np.cross(w[0], v_perp), w[1])
    c0 = _dot(v_par + p[0] - g.wrist, w[1])
    r_ = np.hypot(a_, b_)
    shoulder_measure = r_
    phi = np.arctan2(b_, a_)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos1 = -c0 / r_
    cos1 = np.where(np.abs(cos1) <= 1.0 + 1e-12, np.clip(cos1, -1.0, 1.0), np.nan)
    d1 = np.arccos(cos1)
    th1 = np.stack([phi + d1, phi - d1], -1)  # (n, 2)
    free1 = (r_ < 1e-9 * g.scale) & (np.abs(c0) < 1e-9 * g.scale)
    if np.any(free1):  # wrist centre on the shoulder axis: theta1 is free
        t1 = np.zeros(n) if theta_ref is None else theta_ref[:, 0]
        th1 = np.where(free1[:, None], np.stack([t1, t1 + math.pi], -1), th1)

    # --- wrist centre with axis 1 undone, then elbow (subproblem 3) and theta2
    r1inv = _rot(w[0], -th1)  # (n, 2, 3, 3)
    x = (r1inv @ (qw - p[0])[:, None, :, None])[..., 0] + p[0]  # (n, 2, 3)
    u = g.wrist - p[2]
    vv = p[1] - p[2]
    u_p = u - w[2] * np.dot(u, w[2])
    v_p = vv - w[2] * np.dot(vv, w[2])
    delta2 = _dot(x - p[1], x - p[1]) - np.dot(w[2], u - vv) ** 2  # (n, 2)
    nu, nv = np.linalg.norm(u_p), np.linalg.norm(v_p)
    th0 = math.atan2(float(np.dot(w[2], np.cross(u_p, v_p))), float(np.dot(u_p, v_p)))
    if nv < 1e-12:  # axis 2 and 3 coincide: no elbow (not an arm we support)
        raise ReachabilityError("axes 2 and 3 coincide; closed-form IK does not apply")
    cos3 = (nu**2 + nv**2 - delta2) / (2.0 * nu * nv)
    elbow = 1.0 - np.abs(cos3)  # (n, 2)
    cos3 = np.where(np.abs(cos3) <= 1.0 + 1e-10, np.clip(cos3, -1.0, 1.0), np.nan)
    d3 = np.arccos(cos3)
    th3 = np.stack([th0 - d3, th0 + d3], -1)  # (n, 2 shoulder, 2 elbow)
    r3 = _rot(w[2], th3)  # (n, 2, 2, 3, 3)
    y = (r3 @ u[:, None])[..., 0] + p[2]  # wrist centre after theta3
    th2 = _sp1(w[1], y - p[1], x[:, :, None, :] - p[1])  # (n, 2, 2)

    # --- wrist: R4 R5 R6 = (R1 R2 R3)^T R_G
    r123 = _rot(w[0], th1)[:, :, None] @ _rot(w[1], th2) @ r3  # (n, 2, 2, 3, 3)
    rw = np.swapaxes(r123, -1, -2) @ rg[:, None, None]  # (n, 2, 2, 3, 3)
    w4, w5, w6 = w[3], w[4], w[5]
    uw = w6
    vw = rw @ w6  # target direction of axis 6
    a45 = float(np.dot(w4, w5))
    den = a45**2 - 1.0
    al = (a45 * np.dot(w5, uw) - _dot(vw, w4)) / den
    be = (a45 * _dot(vw, w4) - np.dot(w5, uw)) / den
    cr = np.cross(w4, w5)
    if abs(a45) < 1e-12 and abs(float(np.dot(w5, uw))) < 1e-12:
        # usual wrist (4 _|_ 5 _|_ 6): gamma = |sin(bend)|, accurate near the singularity
        gam = np.linalg.norm(np.cross(w4, vw), axis=-1) / np.linalg.norm(cr)
    else:
        g2 = (1.0 - al**2 - be**2 - 2.0 * al * be * a45) / np.dot(cr, cr)
        gam = np.sqrt(np.clip(g2, 0.0, None))
    gam = np.stack([gam, -gam], -1)  # (n, 2, 2, 2)
    cvec = (
        al[..., None, None] * w4 + be[..., None, None] * w5 + gam[..., None] * cr
    )  # (n, 2, 2, 2, 3)
    th5 = _sp1(w5, np.broadcast_to(uw, cvec.shape), cvec)
    wrist_measure = np.linalg.norm(np.cross(w4, cvec), axis=-1)
    vwb = np.broadcast_to(vw[..., None, :], cvec.shape)
    th4 = _sp1(w4, cvec, vwb)
    degenerate = wrist_measure < 1e-9
    if np.any(degenerate):  # wrist singular: theta4 is free; take the reference
        ref = 0.0 if theta_ref is None else theta_ref[:, 3, None, None, None]
        th4 = np.where(degenerate, ref, th4)
    r45 = _rot(w4, th4) @ _rot(w5, th5)
    r6 = np.swapaxes(r45, -1, -2) @ rw[..., None, :, :]
    perp = np.cross(w6, [1.0, 0.0, 0.0])
    if np.linalg.norm(perp) < 0.1:
        perp = np.cross(w6, [0.0, 1.0, 0.0])
    perp /= np.linalg.norm(perp)
    th6 = _sp1(w6, np.broadcast_to(perp, cvec.shape), (r6 @ perp))

    shape = (n, 2, 2, 2)
    theta = np.stack(
        [
            np.broadcast_to(th1[:, :, None, None], shape),
            np.broadcast_to(th2[..., None], shape),
            np.broadcast_to(th3[..., None], shape),
            th4,
            th5,
            th6,
        ],
        -1,
    )
    # branch index = shoulder + 2 * elbow + 4 * wrist
    theta = np.transpose(theta, (0, 3, 2, 1, 4)).reshape(n, 8, 6)
    wm = np.transpose(wrist_measure, (0, 3, 2, 1)).reshape(n, 8)
    em = np.broadcast_to(elbow[:, None, None, :], (n, 2, 2, 2)).reshape(n, 8)
    theta = _wrap(theta - robot.theta_offset) + robot.theta_offset
    ok = np.all(np.isfinite(theta), axis=-1)
    return _Branches(theta, ok, wm, em, shoulder_measure)


def ik_branches(
    robot: Robot, poses: ArrayLike, q_ref: ArrayLike | None = None
) -> tuple[FloatArray, BoolArray]:
    """The 8 closed-form branches of each pose, as axis angles.

    Parameters
    ----------
    robot : Robot
        Must satisfy :func:`is_closed_form`.
    poses : array_like, shape (n, 4, 4)
        TCP poses in the world.
    q_ref : array_like, shape (6,) or (n, 6), optional
        Reference axis angles [rad]: at a wrist singularity (only theta4 +
        theta6 determined) theta4, at a shoulder singularity theta1 is taken
        from it (DH angle 0 if omitted).

    Returns
    -------
    q : ndarray, shape (n, 8, 6)
        Axis angles [rad]: each DH angle wrapped to (-pi, pi] around its
        offset; NaN where a branch does not exist (out of reach).
        Branch index = shoulder + 2 * elbow + 4 * wrist.
    ok : ndarray of bool, shape (n, 8)
        Branch exists and reproduces the pose (checked by FK).
    """
    P = np.asarray(poses, dtype=np.float64)
    q, ok = _branches_unchecked(robot, P, q_ref)
    return q, ok & _reproduces(robot, q, ok, P[:, None])


def _branches_unchecked(
    robot: Robot, P: FloatArray, q_ref: ArrayLike | None, *, compiled: bool = False
) -> tuple[FloatArray, BoolArray]:
    """:func:`ik_branches` before the FK check: ``ok`` says only that a branch exists.

    ``compiled`` (and numba available): :func:`robolobe.robots._ik_kernels.closed_form`
    for one ``q_ref`` (6,) (equal to :func:`_closed_form` to rounding).
    """
    g = _geometry(robot)
    if not g.closed_form:
        raise ReachabilityError(f"closed-form IK does not apply to {robot.name!r}: {g.reason}")
    th_ref = None
    if q_ref is not None:
        qr = np.broadcast_to(np.asarray(q_ref, dtype=np.float64), (P.shape[0], 6))
        th_ref = qr @ robot.coupling.T + robot.theta_offset
    from robolobe import _jit

    if compiled and _jit.available() and (q_ref is None or np.ndim(q_ref) == 1):
        theta = _closed_form_compiled(robot, P, None if th_ref is None else th_ref[0])
        ok = np.all(np.isfinite(theta), axis=-1)
    else:
        br = _closed_form(robot, P, th_ref)
        theta, ok = br.theta, br.ok
    q = (theta - robot.theta_offset) @ g.c_inv.T
    return q, ok


@functools.lru_cache(maxsize=64)
def _kernel_constants(robot: Robot) -> tuple[FloatArray, ...]:
    """The arrays :func:`robolobe.robots._ik_kernels.closed_form` takes besides the poses."""
    g = _geometry(robot)
    w, p = g.w, g.p
    kk = np.empty((6, 3, 3))
    for i in range(6):
        k = w[i]
        kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
        kk[i] = kx @ kx  # as in _rot
    u = g.wrist - p[2]
    vv = p[1] - p[2]
    u_p = u - w[2] * np.dot(u, w[2])
    v_p = vv - w[2] * np.dot(vv, w[2])
    nu, nv = np.linalg.norm(u_p), np.linalg.norm(v_p)
    if nv < 1e-12:  # as in _closed_form
        raise ReachabilityError("axes 2 and 3 coincide; closed-form IK does not apply")
    th0 = math.atan2(float(np.dot(w[2], np.cross(u_p, v_p))), float(np.dot(u_p, v_p)))
    a45 = float(np.dot(w[3], w[4]))
    w5u = float(np.dot(w[4], w[5]))
    usual = abs(a45) < 1e-12 and abs(w5u) < 1e-12
    consts = np.array(
        [g.scale, nu, nv, th0, float(np.dot(w[2], u - vv)), a45, w5u, 1.0 if usual else 0.0]
    )
    perp = np.cross(w[5], [1.0, 0.0, 0.0])
    if np.linalg.norm(perp) < 0.1:
        perp = np.cross(w[5], [0.0, 1.0, 0.0])
    perp /= np.linalg.norm(perp)
    base_inv = np.ascontiguousarray(inv_pose(robot.base))
    return base_inv, np.ascontiguousarray(g.m_inv), np.ascontiguousarray(w), kk, \
        np.ascontiguousarray(p), np.ascontiguousarray(g.wrist), consts, perp  # fmt: skip


def _closed_form_compiled(robot: Robot, P: FloatArray, th_ref: FloatArray | None) -> FloatArray:
    """DH angles (n, 8, 6) of the 8 branches (NaN where none), compiled."""
    from robolobe.robots import _ik_kernels

    base_inv, m_inv, w, kk, p, wrist, consts, perp = _kernel_constants(robot)
    theta = np.empty((P.shape[0], 8, 6))
    _ik_kernels.closed_form(
        np.ascontiguousarray(P, dtype=np.float64),
        base_inv,
        m_inv,
        w,
        kk,
        p,
        wrist,
        consts,
        perp,
        np.zeros(6) if th_ref is None else np.ascontiguousarray(th_ref, dtype=np.float64),
        np.ascontiguousarray(robot.theta_offset, dtype=np.float64),
        theta,
    )
    return theta


def _reproduces(robot: Robot, q: FloatArray, ok: BoolArray, P: FloatArray) -> BoolArray:
    """Which postures ``q`` (..., 6) with ``ok`` reach their poses ``P`` (..., 4, 4) (FK check)."""
    out = np.zeros(ok.shape, dtype=bool)
    if np.any(ok):
        dp, da = pose_error(tcp_pose(robot, np.where(ok[..., None], q, 0.0)), P)
        out = ok & (dp < _POS_TOL_M * max(1.0, _reach(robot))) & (da < _ROT_TOL_RAD)
    return out


def _reach(robot: Robot) -> float:
    g = _geometry(robot)
    return float(np.abs(g.p).max() + np.abs(g.m[:3, 3]).max())


# ------------------------------------------------------ 2*pi multiples
def _expand_turns(robot: Robot, q: FloatArray) -> tuple[FloatArray, NDArray[np.int_]]:
    """All 2*pi shifts of each posture that land inside the joint limits.

    Parameters
    ----------
    q : ndarray, shape (m, 6)

    Returns
    -------
    q_all : ndarray, shape (k, 6)
        Shifted postures; a posture with no in-limit shift for some joint is
        kept once (shift closest to the limits) so it can be reported invalid.
    origin : ndarray of int, shape (k,)
        Row of ``q`` each comes from.
    """
    g = _geometry(robot)
    if not g.unimodular or q.shape[0] == 0:
        return q, np.arange(q.shape[0])
    lo, hi = robot.q_min, robot.q_max
    base = lo + np.mod(q - lo, _TWO_PI)  # smallest value >= lo congruent to q
    base = np.where(base - _TWO_PI >= lo - 1e-9, base - _TWO_PI, base)  # round-off at lo
    counts = np.floor((hi - base) / _TWO_PI + 1e-9).astype(int) + 1  # (m, 6), may be 0
    out, origin = [], []
    for i in range(q.shape[0]):
        choices = []
        for j in range(6):
            k = max(int(counts[i, j]), 0)
            if k == 0:  # no shift fits: keep the value nearest the range, flagged invalid
                below = base[i, j] - _TWO_PI
                vals = [below if abs(below - lo[j]) < abs(base[i, j] - hi[j]) else base[i, j]]
            else:
                vals = list(base[i, j] + _TWO_PI * np.arange(k))
            choices.append(vals)
        grid = np.array(np.meshgrid(*choices, indexing="ij")).reshape(6, -1).T
        out.append(grid)
        origin.append(np.full(grid.shape[0], i))
    return np.concatenate(out), np.concatenate(origin)


# ------------------------------------------------------------- results
@dataclass(frozen=True, eq=False)
class IKResult:
    """All inverse-kinematics solutions of one TCP pose.

    Attributes
    ----------
    pose : ndarray, shape (4, 4)
        The requested TCP pose (world).
    q : ndarray, shape (k, 6)
        Axis angles [rad] of every solution (all branches, all ±2π turns
        within the limits; branches that fit no limit are kept once, invalid).
    branch : ndarray of int, shape (k,)
        Closed-form branch: bit 0 shoulder, bit 1 elbow, bit 2 wrist; -1 for
        numeric solutions.
    within_joint_limits, within_constraints : ndarray of bool, shape (k,)
    wrist_measure : ndarray, shape (k,)
        |sin| of the wrist bend (angle between axes 4 and 6; |sin q5| for
        the usual wrist); 0 = wrist singularity.
    elbow_measure : ndarray, shape (k,)
        ``1 - |cos|`` of the elbow triangle angle; 0 = arm stretched or folded.
    shoulder_measure_m : float
        Distance [m] of the wrist centre from the shoulder-singular set
        (axis 1 for arms without lateral offset); 0 = shoulder singularity.
    singular_tol : float
        Threshold used by :attr:`singular` and :meth:`singular_mask`.
    """

    pose: FloatArray
    q: FloatArray
    branch: NDArray[np.int_]
    within_joint_limits: BoolArray
    within_constraints: BoolArray
    wrist_measure: FloatArray
    elbow_measure: FloatArray
    shoulder_measure_m: float
    singular_tol: float = SINGULAR_TOL

    def singular_mask(self) -> dict[str, BoolArray]:
        """Per-solution singularity flags ``{"wrist", "elbow", "shoulder"}``, each (k,)."""
        tol = self.singular_tol
        return {
            "wrist": self.wrist_measure < tol,
            "elbow": self.elbow_measure < tol**2,
            "shoulder": np.full(self.q.shape[0], self.shoulder_measure_m < tol),
        }

    @property
    def singular(self) -> tuple[str, ...]:
        """Kinds of singularity any solution is within ``singular_tol`` of."""
        return tuple(k for k, v in self.singular_mask().items() if np.any(v))

    @property
    def valid(self) -> BoolArray:
        """Within joint limits and constraints, shape (k,)."""
        return self.within_joint_limits & self.within_constraints

    @property
    def q_valid(self) -> FloatArray:
        """The valid solutions, shape (k_valid, 6)."""
        return self.q[self.valid]

    @property
    def n_branches(self) -> int:
        """Number of distinct closed-form branches found (0..8)."""
        return int(np.unique(self.branch[self.branch >= 0]).size)


def _as_pose(pose: ArrayLike) -> FloatArray:
    P = np.asarray(pose, dtype=np.float64)
    if P.shape != (4, 4):
        raise InputError(f"pose: expected shape (4, 4), found {P.shape}")
    if not np.all(np.isfinite(P)):
        raise InputError("pose: expected finite numbers")
    return P


def ik(
    robot: Robot,
    pose: ArrayLike,
    *,
    q_ref: ArrayLike | None = None,
    singular_tol: float = SINGULAR_TOL,
) -> IKResult:
    """All inverse-kinematics solutions of one TCP pose.

    Parameters
    ----------
    robot : Robot
    pose : array_like, shape (4, 4)
        TCP pose in the world.
    q_ref : array_like, shape (6,), optional
        Reference posture [rad]: at a wrist singularity q4 is taken from it;
        for numeric IK it is the first seed.
    singular_tol : float
        Threshold of the singularity flags (see :data:`SINGULAR_TOL`).

    Returns
    -------
    IKResult
        Solutions sorted: valid first, then by distance to ``q_ref`` (if
        given), then by branch.

    Raises
    ------
    ReachabilityError
        The pose is outside the workspace (no branch exists).
    ConvergenceError
        Numeric IK (non-ortho-parallel robots) found no solution.
    """
    P = _as_pose(pose)
    ref = None if q_ref is None else np.asarray(q_ref, dtype=np.float64)
    g = _geometry(robot)
    if not g.closed_form:
        return _ik_numeric_all(robot, P, ref)
    th_ref = None if ref is None else (robot.coupling @ ref + robot.theta_offset)[None]
    br = _closed_form(robot, P[None], th_ref)
    q8 = (br.theta[0] - robot.theta_offset) @ g.c_inv.T
    ok = br.ok[0].copy()
    if np.any(ok):
        dp, da = pose_error(tcp_pose(robot, np.where(ok[:, None], q8, 0.0)), P)
        ok &= (dp < _POS_TOL_M * max(1.0, _reach(robot))) & (da < _ROT_TOL_RAD)
    if not np.any(ok):
        raise ReachabilityError(f"{_describe_pose(P)} is out of reach of robot {robot.name!r}")
    idx = np.flatnonzero(ok)
    q_all, origin = _expand_turns(robot, q8[idx])
    branch = idx[origin]
    wm = br.wrist_measure[0][branch]
    em = br.elbow_measure[0][branch]
    jl, wc = within_joint_limits(robot, q_all), within_constraints(robot, q_all)
    dist = np.zeros(len(q_all)) if ref is None else np.linalg.norm(q_all - ref, axis=-1)
    order = np.lexsort((branch, dist, ~(jl & wc)))
    return IKResult(
        pose=P,
        q=q_all[order],
        branch=branch[order],
        within_joint_limits=jl[order],
        within_constraints=wc[order],
        wrist_measure=wm[order],
        elbow_measure=em[order],
        shoulder_measure_m=float(br.shoulder_measure[0]),
        singular_tol=singular_tol,
    )


def nearest(
    robot: Robot,
    pose: ArrayLike,
    q_ref: ArrayLike,
    *,
    allow_singular: bool = True,
    singular_tol: float = SINGULAR_TOL,
    weights: ArrayLike | None = None,
) -> FloatArray:
    """The valid solution closest to a reference posture.

    Parameters
    ----------
    robot : Robot
    pose : array_like, shape (4, 4)
        TCP pose in the world.
    q_ref : array_like, shape (6,)
        Reference axis angles [rad].
    allow_singular : bool
        If False, raise :class:`SingularityError` when the pose is within
        ``singular_tol`` of a singularity.
    singular_tol : float
    weights : array_like, shape (6,), optional
        Per-joint weights of the distance (default 1).

    Returns
    -------
    ndarray, shape (6,)

    Raises
    ------
    ReachabilityError
        Out of reach, or no solution within the limits/constraints (the
        message names the closest violation).
    SingularityError
        Only with ``allow_singular=False``.
    """
    P = _as_pose(pose)
    ref = np.asarray(q_ref, dtype=np.float64)
    res = ik(robot, P, q_ref=ref, singular_tol=singular_tol)
    if not np.any(res.valid):
        from robolobe.robots.limits import posture_violations

        probs = posture_violations(robot, res.q[0])
        raise ReachabilityError(
            f"{_describe_pose(P)}: no solution of robot {robot.name!r} within its joint limits "
            f"and constraints ({len(res.q)} candidates; e.g. {probs[0] if probs else '?'})"
        )
    wts = np.ones(6) if weights is None else np.asarray(weights, dtype=np.float64)
    d = np.where(res.valid, np.sum(wts * (res.q - ref) ** 2, axis=-1), np.inf)
    best = int(np.argmin(d))
    kinds = [k for k, v in res.singular_mask().items() if v[best]]
    if kinds and not allow_singular:
        raise SingularityError(
            f"{_describe_pose(P)} is at a {'/'.join(kinds)} singularity of robot "
            f"{robot.name!r} (nearest solution q_deg = "
            f"{np.round(np.degrees(res.q[best]), 3).tolist()})"
        )
    return res.q[best]


def ik_batch(
    robot: Robot,
    poses: ArrayLike,
    q_ref: ArrayLike,
    *,
    continuity: bool = True,
    weights: ArrayLike | None = None,
) -> FloatArray:
    """Inverse kinematics of many poses, nearest solution per pose.

    Parameters
    ----------
    robot : Robot
    poses : array_like, shape (n, 4, 4)
        TCP poses in the world (e.g. the waypoints of a path).
    q_ref : array_like, shape (6,)
        Reference axis angles [rad].
    continuity : bool
        True: along a path, each pose takes the valid solution nearest to the
        previous pose's solution (the first: nearest to ``q_ref``). False:
        every pose takes the solution nearest to ``q_ref``.
    weights : array_like, shape (6,), optional
        Per-joint weights of the distance.

    Returns
    -------
    ndarray, shape (n, 6)
        Axis angles [rad].

    Raises
    ------
    ReachabilityError
        Naming the first pose (index and position) that is out of reach or
        has no valid solution, how many poses failed and the first few
        indices (a failing pose along a path is skipped: the next one is
        taken nearest the last valid solution).
    """
    P = np.asarray(poses, dtype=np.float64)
    if P.ndim != 3 or P.shape[1:] != (4, 4):
        raise InputError(f"poses: expected shape (n, 4, 4), found {P.shape}")
    ref = np.asarray(q_ref, dtype=np.float64)
    wts = np.ones(6) if weights is None else np.asarray(weights, dtype=np.float64)
    n = P.shape[0]
    out = np.empty((n, 6))
    if n == 0:
        return out
    fails: list[tuple[int, str]] = []  # first few failing waypoints and why
    n_fail = 0
    g = _geometry(robot)
    if not g.closed_form:
        prev = ref
        for i in range(n):
            try:
                prev = ik_numeric(robot, P[i], prev if continuity else ref)
            except ConvergenceError as exc:
                n_fail += 1
                if len(fails) < _N_REPORT:
                    fails.append((i, f"no solution ({exc})"))
                out[i] = np.nan
                continue
            out[i] = prev
        _raise_failures(robot, P, fails, n_fail)
        return out
    prev = ref.copy()
    from robolobe import _jit

    compiled = _jit.use_compiled(n, cold=JIT_MIN_POSES, warm=JIT_MIN_POSES_STARTED)
    for c0 in range(0, n, _IK_CHUNK):  # chunks bound the memory (~1 kB per pose)
        c1 = min(n, c0 + _IK_CHUNK)
        pc = P[c0:c1]
        q8, ok = _branches_unchecked(robot, pc, ref, compiled=compiled)
        # Choose among the branches that exist, then FK-check only the chosen one:
        # if it reproduces its pose it is also the nearest of the checked branches
        # (a subset holding it), so the result is that of checking all 8 first. A
        # chunk where a chosen branch fails the check, or a pose has no solution,
        # is chosen again with every branch checked (same ``prev`` to start from).
        prev0 = prev.copy()
        q, good, b = _choose(robot, q8, ok, wts, prev, ref, continuity, compiled)
        rows = np.flatnonzero(good)
        if rows.size < good.size or not np.all(
            _reproduces(robot, q8[rows, b[rows]], ok[rows, b[rows]], pc[rows])
        ):
            prev[:] = prev0
            ok = ok & _reproduces(robot, q8, ok, pc[:, None])
            q, good, _ = _choose(robot, q8, ok, wts, prev, ref, continuity, compiled)
        out[c0:c1] = q
        bad = np.flatnonzero(~good)
        n_fail += bad.size
        for i in bad[: max(0, _N_REPORT - len(fails))]:
            why = "out of reach" if not ok[i].any() else "no solution within the limits/constraints"
            fails.append((c0 + int(i), why))
    _raise_failures(robot, P, fails, n_fail)
    return out


def _raise_failures(robot: Robot, P: FloatArray, fails: list[tuple[int, str]], n_fail: int) -> None:
    """One error naming the first failing waypoint, the count and the first indices."""
    if not n_fail:
        return
    i, why = fails[0]
    more = ", ".join(str(j) for j, _ in fails)
    raise ReachabilityError(
        f"waypoint {i}: {_describe_pose(P[i])}: {why} of robot {robot.name!r} "
        f"({n_fail} of {len(P)} waypoints have no valid solution; the first: {more}"
        f"{', ...' if n_fail > len(fails) else ''})"
    )


_IK_CHUNK = 8192
_N_REPORT = 5
#: Path length from which :func:`ik_batch` takes the compiled closed form and
#: continuity: below, numba's start-up in a fresh process costs more than they save
#: over the numpy closed form and the speculate-and-check continuity. Measured
#: (benchmarks/bench_jit.py --kernel ik, robot A, CPU seconds of a fresh process,
#: 2 cores at load 7): 40,000 poses numpy 0.52 vs compiled 0.73 (start-up ~0.53 s),
#: saving ~5 us per pose: equal at ~80,000.
JIT_MIN_POSES = 80_000
#: The same where numba has started already (:func:`robolobe._jit.started`): 2,000
#: poses numpy 0.057 vs compiled 0.034 (the kernels' cache load included).
JIT_MIN_POSES_STARTED = 2_000


def _pick(
    robot: Robot,
    base: FloatArray,
    count: NDArray[np.int_],
    exists: BoolArray,
    wts: FloatArray,
    target: FloatArray,
) -> tuple[FloatArray, BoolArray, NDArray[np.int_]]:
    """Per pose the valid branch (and in-limit 2*pi turn) nearest ``target`` (m, 6).

    Per joint the turn nearest the target is taken (the distance is separable).
    Returns the postures (m, 6) [rad], whether any branch was valid (m,) and
    the chosen branch (m,) (-1 where none).
    """
    k = np.clip(np.round((target[:, None, :] - base) / _TWO_PI), 0, np.maximum(count - 1, 0))
    cand = base + _TWO_PI * k
    valid = exists & within_constraints(robot, cand)
    d = np.where(valid, np.sum(wts * (cand - target[:, None, :]) ** 2, axis=-1), np.inf)
    best = np.argmin(d, axis=1)
    q = cand[np.arange(len(cand)), best]
    good = np.asarray(valid.any(axis=1), dtype=bool)
    return np.where(good[:, None], q, np.nan), good, np.where(good, best, -1)


def _continuity_numpy(
    robot: Robot,
    base: FloatArray,
    count: NDArray[np.int_],
    exists: BoolArray,
    wts: FloatArray,
    prev: FloatArray,
) -> tuple[FloatArray, BoolArray, NDArray[np.int64]]:
    """Reference of :func:`_continuity`: a Python loop of :func:`_pick` (``prev`` updated)."""
    m = base.shape[0]
    out = np.empty((m, 6))
    good = np.zeros(m, dtype=bool)
    branch = np.full(m, -1, dtype=np.int64)
    for i in range(m):  # sequential by nature; each step is an (8, 6) vector op
        qi, gi, bi = _pick(
            robot, base[i : i + 1], count[i : i + 1], exists[i : i + 1], wts, prev[None]
        )
        out[i], good[i], branch[i] = qi[0], gi[0], bi[0]
        if gi[0]:
            prev[:] = qi[0]
    return out, good, branch


#: Speculation passes per chunk in :func:`_continuity_vectorized` before the rest
#: of the chunk is done pose by pose (a path that switches branches very often).
_MAX_PASSES = 16


def _continuity_vectorized(
    robot: Robot,
    base: FloatArray,
    count: NDArray[np.int_],
    exists: BoolArray,
    wts: FloatArray,
    prev: FloatArray,
) -> tuple[FloatArray, BoolArray, NDArray[np.int64]]:
    """:func:`_continuity_numpy`'s result without its per-pose loop (``prev`` updated).

    Speculate that the path stays on the branch it takes at its first pose,
    each joint on the 2*pi turn that continues the previous pose's (an
    unwrap), then check every pose at once: :func:`_pick` with the speculated
    previous posture as the target. Up to the first pose where the check
    differs, the targets were the true previous postures (by induction), so
    those poses and that one are exact; speculation restarts after it. A path
    that keeps its branch takes one or two passes; after :data:`_MAX_PASSES`
    the rest of the chunk goes pose by pose.
    """
    m = base.shape[0]
    out = np.empty((m, 6))
    good = np.zeros(m, dtype=bool)
    branch = np.full(m, -1, dtype=np.int64)
    s = 0
    passes = 0
    while s < m:
        if passes == _MAX_PASSES:
            o, g, b = _continuity_numpy(robot, base[s:], count[s:], exists[s:], wts, prev)
            out[s:], good[s:], branch[s:] = o, g, b
            break
        passes += 1
        q0, g0, b0 = _pick(robot, base[s : s + 1], count[s : s + 1], exists[s : s + 1], wts,
                           prev[None])  # fmt: skip
        out[s], good[s], branch[s] = q0[0], g0[0], b0[0]
        if not g0[0]:
            s += 1
            continue
        prev[:] = q0[0]
        if s + 1 == m:
            break
        # speculation: branch b0 on, each joint continued by unwrapping from q0
        bb = int(b0[0])
        v = base[s + 1 :, bb]  # (r, 6)
        cont = np.unwrap(np.vstack([q0[0][None], v]), axis=0)[1:]
        kmax = np.maximum(count[s + 1 :, bb] - 1, 0)
        k = np.clip(np.round((cont - v) / _TWO_PI), 0, kmax)
        spec = v + _TWO_PI * k  # (r, 6)
        target = np.vstack([q0[0][None], spec[:-1]])
        qp, gp, bp = _pick(robot, base[s + 1 :], count[s + 1 :], exists[s + 1 :], wts, target)
        same = gp & (bp == bb) & np.all(qp == spec, axis=1)
        r = same.size if bool(same.all()) else int(np.argmin(same)) + 1  # rows settled
        out[s + 1 : s + 1 + r] = qp[:r]
        good[s + 1 : s + 1 + r] = gp[:r]
        branch[s + 1 : s + 1 + r] = bp[:r]
        last = np.flatnonzero(gp[:r])
        if last.size:
            prev[:] = qp[last[-1]]
        s += 1 + r
    return out, good, branch


def _continuity(
    robot: Robot,
    base: FloatArray,
    count: NDArray[np.int_],
    exists: BoolArray,
    wts: FloatArray,
    prev: FloatArray,
    *,
    compiled: bool = True,
) -> tuple[FloatArray, BoolArray, NDArray[np.int64]]:
    """Along a path, each pose's valid solution nearest the previous one (``prev`` updated).

    Returns the postures (m, 6) [rad] (NaN where none is valid; such a pose
    leaves ``prev`` as it was), whether each pose had a valid solution and
    the branch chosen (-1 where none).
    Compiled (``compiled`` and numba available), else :func:`_continuity_vectorized`.
    """
    from robolobe import _jit

    if not (compiled and _jit.available()):
        return _continuity_vectorized(robot, base, count, exists, wts, prev)
    from robolobe.robots import _ik_kernels
    from robolobe.robots.limits import TOL_RAD

    cons = robot.constraints
    m = base.shape[0]
    out = np.empty((m, 6))
    good = np.zeros(m, dtype=bool)
    branch = np.empty(m, dtype=np.int64)
    _ik_kernels.continuity(
        np.ascontiguousarray(base, dtype=np.float64),
        np.ascontiguousarray(count, dtype=np.int64),
        np.ascontiguousarray(exists),
        np.ascontiguousarray(wts, dtype=np.float64),
        np.array([c.coeffs for c in cons], dtype=np.float64).reshape(len(cons), 6),
        np.array([c.lo_rad for c in cons], dtype=np.float64),
        np.array([c.hi_rad for c in cons], dtype=np.float64),
        TOL_RAD,
        prev,
        out,
        good,
        branch,
    )
    return out, good, branch


def _choose(
    robot: Robot,
    q8: FloatArray,
    ok: BoolArray,
    wts: FloatArray,
    prev: FloatArray,
    ref: FloatArray,
    continuity: bool,
    compiled: bool,
) -> tuple[FloatArray, BoolArray, NDArray[np.int_]]:
    """One chunk's postures from its branches ``q8`` (m, 8, 6) with ``ok`` (m, 8).

    Along the path (``continuity``, ``prev`` updated) or each nearest ``ref``;
    returns postures (m, 6), whether each had a valid branch (m,) and the branch (m,).
    """
    base, count = _turn_base(robot, q8, ok)  # (m, 8, 6) each
    exists = ok & np.all(count >= 1, axis=-1)  # (m, 8)
    if continuity:
        return _continuity(robot, base, count, exists, wts, prev, compiled=compiled)
    return _pick(robot, base, count, exists, wts, np.broadcast_to(ref, (q8.shape[0], 6)))


def _turn_base(robot: Robot, q8: FloatArray, ok: BoolArray) -> tuple[FloatArray, NDArray[np.int_]]:
    """Lowest in-limit 2*pi turn of each joint angle and the number of turns that fit.

    Returns ``base`` (..., 6) [rad] and ``count`` (..., 6) (0: no turn fits);
    without a unimodular coupling only the angle itself is a candidate.
    """
    lo, hi = robot.q_min, robot.q_max
    q = np.where(ok[..., None], q8, 0.0)
    if not _geometry(robot).unimodular:
        inside = (q >= lo - 1e-9) & (q <= hi + 1e-9)
        return q, inside.astype(int)
    base = lo + np.mod(q - lo, _TWO_PI)
    base = np.where(base - _TWO_PI >= lo - 1e-9, base - _TWO_PI, base)
    count = np.floor((hi - base) / _TWO_PI + 1e-9).astype(int) + 1
    return base, np.maximum(count, 0)


# ------------------------------------------------------------------ numeric
def _pose_residual(robot: Robot, q: FloatArray, target: FloatArray) -> FloatArray:
    """6-vector [dp; dw] (world frame) from the current TCP to the target; (..., 6)."""
    cur = tcp_pose(robot, q)
    dp = target[..., :3, 3] - cur[..., :3, 3]
    rel = target[..., :3, :3] @ np.swapaxes(cur[..., :3, :3], -1, -2)  # world-frame error
    skew = np.stack(
        [rel[..., 2, 1] - rel[..., 1, 2], rel[..., 0, 2] - rel[..., 2, 0],
         rel[..., 1, 0] - rel[..., 0, 1]], -1
    ) / 2.0  # fmt: skip
    s = np.linalg.norm(skew, axis=-1, keepdims=True)
    c = (np.trace(rel, axis1=-2, axis2=-1)[..., None] - 1.0) / 2.0
    ang = np.arctan2(s, c)
    with np.errstate(divide="ignore", invalid="ignore"):
        scale = np.where(s > 1e-12, ang / s, 1.0)
    return np.concatenate([dp, skew * scale], -1)


def _dls(
    robot: Robot,
    target: FloatArray,
    q0: FloatArray,
    *,
    tol: float,
    max_iter: int,
    damping: float,
) -> tuple[FloatArray, FloatArray]:
    """Batched damped least squares from seeds ``q0`` (m, 6); returns q and |residual|."""
    q = q0.copy()
    length = max(1.0, _reach_any(robot))
    wvec = np.array([1.0, 1.0, 1.0, length, length, length])  # rotation scaled to metres
    for _ in range(max_iter):
        r = _pose_residual(robot, q, target) * wvec
        err = np.linalg.norm(r, axis=-1)
        if np.all(err < tol * length):
            break
        jac = tcp_jacobian(robot, q, "world") * wvec[:, None]
        jt = np.swapaxes(jac, -1, -2)
        a = jt @ jac + (damping * length) ** 2 * np.eye(6)
        dq = np.linalg.solve(a, (jt @ r[..., None]))[..., 0]
        step = np.linalg.norm(dq, axis=-1, keepdims=True)
        q = q + dq * np.minimum(1.0, 0.5 / np.maximum(step, 1e-300))
    r = _pose_residual(robot, q, target) * wvec
    return q, np.linalg.norm(r, axis=-1) / length


def _reach_any(robot: Robot) -> float:
    f = link_frames(robot, np.zeros(6))
    return float(np.linalg.norm(f[7, :3, 3] - f[0, :3, 3]))


def ik_numeric_many(
    robot: Robot,
    pose: ArrayLike,
    seeds: ArrayLike,
    *,
    tol: float = 1e-10,
    max_iter: int = 200,
    damping: float = 1e-4,
) -> tuple[FloatArray, BoolArray]:
    """Damped-least-squares IK of one pose from many start postures at once.

    Parameters
    ----------
    robot : Robot
    pose : array_like, shape (4, 4)
        TCP pose in the world.
    seeds : array_like, shape (m, 6)
        Start axis angles [rad].
    tol, max_iter, damping
        As in :func:`ik_numeric`.

    Returns
    -------
    q : ndarray, shape (m, 6)
        Final axis angles [rad].
    converged : ndarray of bool, shape (m,)
    """
    P = _as_pose(pose)
    q0 = np.asarray(seeds, dtype=np.float64).reshape(-1, 6)
    q, err = _dls(robot, P, q0, tol=tol, max_iter=max_iter, damping=damping)
    return q, err < 10 * tol


def ik_numeric(
    robot: Robot,
    pose: ArrayLike,
    q0: ArrayLike,
    *,
    tol: float = 1e-10,
    max_iter: int = 200,
    damping: float = 1e-4,
) -> FloatArray:
    """Damped-least-squares IK from one start posture (any serial arm).

    Parameters
    ----------
    robot : Robot
    pose : array_like, shape (4, 4)
        TCP pose in the world.
    q0 : array_like, shape (6,)
        Start axis angles [rad].
    tol : float
        Relative pose tolerance (position / reach and rotation [rad]).
    max_iter : int
    damping : float
        Damping factor relative to the reach.

    Returns
    -------
    ndarray, shape (6,)
        Axis angles [rad] (not checked against the limits).

    Raises
    ------
    ConvergenceError
        Naming the pose, the residual and the iteration count.
    """
    P = _as_pose(pose)
    q, err = _dls(robot, P, np.asarray(q0, dtype=np.float64)[None], tol=tol,
                  max_iter=max_iter, damping=damping)  # fmt: skip
    if not err[0] < 10 * tol:
        raise ConvergenceError(
            f"numeric IK of robot {robot.name!r} did not converge for {_describe_pose(P)}: "
            f"residual {err[0]:.3g} after {max_iter} iterations from q0_deg = "
            f"{np.round(np.degrees(np.asarray(q0, float)), 2).tolist()}"
        )
    return q[0]


def _ik_numeric_all(robot: Robot, P: FloatArray, ref: FloatArray | None) -> IKResult:
    mid = 0.5 * (robot.q_min + robot.q_max)
    quart = 0.25 * (robot.q_max - robot.q_min)
    seeds = [mid]
    for s1 in (-1, 1):
        for s3 in (-1, 1):
            for s5 in (-1, 1):
                s = mid.copy()
                s[0] += s1 * quart[0]
                s[2] += s3 * quart[2]
                s[4] += s5 * quart[4]
                seeds.append(s)
    if ref is not None:
        seeds.insert(0, ref)
    q, err = _dls(robot, P, np.array(seeds), tol=1e-10, max_iter=300, damping=1e-4)
    good = q[err < 1e-9]
    if good.shape[0] == 0:
        raise ConvergenceError(
            f"numeric IK of robot {robot.name!r} found no solution for {_describe_pose(P)} "
            f"from {len(seeds)} start postures (closest residual {err.min():.3g}); "
            f"the pose may be out of reach"
        )
    # unique solutions (angles modulo 2*pi), then their turns inside the limits
    keys = np.round(_wrap(good) * 1e6).astype(np.int64)
    _, first = np.unique(keys, axis=0, return_index=True)
    good = good[np.sort(first)]
    q_all, _origin = _expand_turns(robot, good)
    jl, wc = within_joint_limits(robot, q_all), within_constraints(robot, q_all)
    dist = np.zeros(len(q_all)) if ref is None else np.linalg.norm(q_all - ref, axis=-1)
    order = np.lexsort((dist, ~(jl & wc)))
    # singularity measures from the Jacobian: smallest singular value (scaled)
    jac = tcp_jacobian(robot, q_all[order], "world")
    sv = np.asarray(np.linalg.svd(jac, compute_uv=False)[:, -1], dtype=np.float64)
    sv = sv / max(1.0, _reach_any(robot))
    return IKResult(
        pose=P,
        q=q_all[order],
        branch=np.full(len(q_all), -1),
        within_joint_limits=jl[order],
        within_constraints=wc[order],
        wrist_measure=sv,
        elbow_measure=np.full(len(q_all), np.inf),
        shoulder_measure_m=np.inf,
    )
