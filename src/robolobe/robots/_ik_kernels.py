"""Compiled (numba) inverse kinematics: closed-form branches, nearest-branch continuity.

The continuity loop over waypoints is sequential by nature (each pose takes
the valid solution nearest the previous one); compiled, one waypoint costs a
few hundred nanoseconds. Same arithmetic as the numpy reference in
:func:`robolobe.robots.ik._continuity_numpy` (tested equal). The closed form
(:func:`closed_form`) is :func:`robolobe.robots.ik._closed_form` pose by pose
without its (n, 2, 2, 2, 3, 3) temporaries: ~2 us per pose instead of ~15 us,
equal to rounding (tested: 1e-9 rad, angles modulo 2*pi).
Import only after :func:`robolobe._jit.available`; caching: :mod:`robolobe._jit`.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robolobe._jit import njit

FloatArray = NDArray[np.float64]

_TWO_PI = 2.0 * math.pi


@njit()
def continuity(
    base: FloatArray,
    count: NDArray[np.int64],
    exists: NDArray[np.bool_],
    wts: FloatArray,
    coeffs: FloatArray,
    lo: FloatArray,
    hi: FloatArray,
    tol: float,
    prev: FloatArray,
    out: FloatArray,
    good: NDArray[np.bool_],
    branch: NDArray[np.int64],
) -> None:
    """Nearest valid solution per waypoint, each relative to the previous one.

    Parameters
    ----------
    base, count : ndarray, shape (n, 8, 6)
        Lowest in-limit 2*pi turn [rad] and number of turns per branch and joint.
    exists : ndarray of bool, shape (n, 8)
    wts : ndarray, shape (6,)
        Joint weights of the squared distance.
    coeffs, lo, hi : ndarray, shapes (m, 6), (m,), (m,)
        Linear constraints ``lo - tol <= coeffs @ q <= hi + tol`` [rad].
    prev : ndarray, shape (6,)
        Posture before the first waypoint [rad] (updated in place).
    out : ndarray, shape (n, 6)
        Chosen postures [rad] (NaN where none is valid).
    good : ndarray of bool, shape (n,)
        Whether a valid solution existed; a failing waypoint leaves ``prev``.
    branch : ndarray of int, shape (n,)
        Branch (index along axis 1 of ``base``) of each chosen posture; -1 where none.
    """
    n = base.shape[0]
    nc = coeffs.shape[0]
    cand = np.empty(6)
    best = np.empty(6)
    for i in range(n):
        dbest = np.inf
        found = False
        bbest = -1
        for b in range(base.shape[1]):
            if not exists[i, b]:
                continue
            for j in range(6):
                kmax = max(count[i, b, j] - 1, 0)
                k = np.rint((prev[j] - base[i, b, j]) / _TWO_PI)
                k = min(max(k, 0.0), float(kmax))
                cand[j] = base[i, b, j] + _TWO_PI * k
            valid = True
            for m in range(nc):
                v = 0.0
                for j in range(6):
                    v += cand[j] * coeffs[m, j]
                if not (v >= lo[m] - tol and v <= hi[m] + tol):
                    valid = False
                    break
            if not valid:
                continue
            d = 0.0
            for j in range(6):
                d += wts[j] * (cand[j] - prev[j]) ** 2
            if not found or d < dbest:
                found = True
                dbest = d
                bbest = b
                best[:] = cand
        good[i] = found
        branch[i] = bbest
        if found:
            out[i] = best
            prev[:] = best
        else:
            out[i] = np.nan


@njit()
def _rot(k: FloatArray, kk: FloatArray, angle: float, out: FloatArray) -> None:
    """Rodrigues rotation about unit ``k`` (3,) by ``angle`` into ``out`` (3, 3); ``kk`` = K @ K."""
    s = math.sin(angle)
    c1 = 1.0 - math.cos(angle)
    out[0, 0] = (1.0 + s * 0.0) + c1 * kk[0, 0]
    out[0, 1] = (0.0 + s * -k[2]) + c1 * kk[0, 1]
    out[0, 2] = (0.0 + s * k[1]) + c1 * kk[0, 2]
    out[1, 0] = (0.0 + s * k[2]) + c1 * kk[1, 0]
    out[1, 1] = (1.0 + s * 0.0) + c1 * kk[1, 1]
    out[1, 2] = (0.0 + s * -k[0]) + c1 * kk[1, 2]
    out[2, 0] = (0.0 + s * -k[1]) + c1 * kk[2, 0]
    out[2, 1] = (0.0 + s * k[0]) + c1 * kk[2, 1]
    out[2, 2] = (1.0 + s * 0.0) + c1 * kk[2, 2]


@njit()
def _sp1(axis: FloatArray, a: FloatArray, b: FloatArray) -> float:
    """Angle rotating ``a`` onto ``b`` about unit ``axis`` (subproblem 1); no allocation."""
    da = a[0] * axis[0] + a[1] * axis[1] + a[2] * axis[2]
    db = b[0] * axis[0] + b[1] * axis[1] + b[2] * axis[2]
    ap0, ap1, ap2 = a[0] - axis[0] * da, a[1] - axis[1] * da, a[2] - axis[2] * da
    bp0, bp1, bp2 = b[0] - axis[0] * db, b[1] - axis[1] * db, b[2] - axis[2] * db
    cx = ap1 * bp2 - ap2 * bp1
    cy = ap2 * bp0 - ap0 * bp2
    cz = ap0 * bp1 - ap1 * bp0
    return math.atan2(axis[0] * cx + axis[1] * cy + axis[2] * cz, ap0 * bp0 + ap1 * bp1 + ap2 * bp2)


@njit()
def _norm_cross(a: FloatArray, b: FloatArray) -> float:
    """|a x b| for 3-vectors."""
    cx = a[1] * b[2] - a[2] * b[1]
    cy = a[2] * b[0] - a[0] * b[2]
    cz = a[0] * b[1] - a[1] * b[0]
    return math.sqrt(cx * cx + cy * cy + cz * cz)


@njit()
def _mat3(a: FloatArray, b: FloatArray, out: FloatArray) -> None:
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@njit()
def _mat3t(a: FloatArray, b: FloatArray, out: FloatArray) -> None:
    """``a.T @ b``."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[0, i] * b[0, j] + a[1, i] * b[1, j] + a[2, i] * b[2, j]


@njit()
def closed_form(
    poses: FloatArray,
    base_inv: FloatArray,
    m_inv: FloatArray,
    w: FloatArray,
    kk: FloatArray,
    p: FloatArray,
    wrist: FloatArray,
    consts: FloatArray,
    perp: FloatArray,
    th_ref: FloatArray,
    offset: FloatArray,
    theta: FloatArray,
) -> None:
    """The 8 closed-form branches of each pose, as DH angles (NaN where none).

    The arithmetic of :func:`robolobe.robots.ik._closed_form` (its reference),
    pose by pose without (n, 2, 2, 2, 3, 3) temporaries; equal to rounding.

    Parameters
    ----------
    poses : ndarray, shape (n, 4, 4)
        TCP poses in the world.
    base_inv, m_inv : ndarray, shape (4, 4)
        Inverse of the robot base and of the TCP pose at DH angles 0.
    w, p : ndarray, shape (6, 3)
        Joint axes and points on them at DH angles 0 (base frame).
    kk : ndarray, shape (6, 3, 3)
        Per axis ``K @ K`` of its cross-product matrix ``K``.
    wrist : ndarray, shape (3,)
        Wrist centre at DH angles 0.
    consts : ndarray, shape (8,)
        ``scale, nu, nv, th0, w2 . (u - v), a45, w5 . w6, usual wrist (1.0 or 0.0)``.
    perp : ndarray, shape (3,)
        Unit vector perpendicular to axis 6.
    th_ref : ndarray, shape (6,)
        DH angles taken for free angles at singularities.
    offset : ndarray, shape (6,)
        DH angle offsets (the branches are wrapped to (-pi, pi] around them).
    theta : ndarray, shape (n, 8, 6)
        Output; branch index = shoulder + 2 * elbow + 4 * wrist.
    """
    scale, nu, nv, th0, w2uv, a45, w5u, usual = (
        consts[0], consts[1], consts[2], consts[3], consts[4], consts[5], consts[6], consts[7]
    )  # fmt: skip
    w0, w1, w2, w4, w5, w6 = w[0], w[1], w[2], w[3], w[4], w[5]
    cr = np.cross(w4, w5)
    ncr = math.sqrt(cr[0] ** 2 + cr[1] ** 2 + cr[2] ** 2)
    den = a45**2 - 1.0
    u = wrist - p[2]
    gm = np.empty((4, 4))
    tmp = np.empty((4, 4))
    r1 = np.empty((3, 3))
    r1i = np.empty((3, 3))
    r2 = np.empty((3, 3))
    r3 = np.empty((3, 3))
    r12 = np.empty((3, 3))
    r123 = np.empty((3, 3))
    rw = np.empty((3, 3))
    r4 = np.empty((3, 3))
    r5 = np.empty((3, 3))
    r45 = np.empty((3, 3))
    r6 = np.empty((3, 3))
    th1 = np.empty(2)
    th3 = np.empty(2)
    qw = np.empty(3)
    x = np.empty(3)
    y = np.empty(3)
    vw = np.empty(3)
    cvec = np.empty(3)
    rp = np.empty(3)
    row = np.empty(6)
    v = np.empty(3)
    v_par = np.empty(3)
    v_perp = np.empty(3)
    xp = np.empty(3)
    yp = np.empty(3)
    two_pi = 2.0 * math.pi
    for i in range(poses.shape[0]):
        for a in range(4):
            for b in range(4):
                tmp[a, b] = (
                    base_inv[a, 0] * poses[i, 0, b] + base_inv[a, 1] * poses[i, 1, b]
                    + base_inv[a, 2] * poses[i, 2, b] + base_inv[a, 3] * poses[i, 3, b]
                )  # fmt: skip
        for a in range(4):
            for b in range(4):
                gm[a, b] = (
                    tmp[a, 0] * m_inv[0, b] + tmp[a, 1] * m_inv[1, b]
                    + tmp[a, 2] * m_inv[2, b] + tmp[a, 3] * m_inv[3, b]
                )  # fmt: skip
        rg = gm[:3, :3]
        for a in range(3):
            qw[a] = rg[a, 0] * wrist[0] + rg[a, 1] * wrist[1] + rg[a, 2] * wrist[2] + gm[a, 3]
        # theta1
        for a in range(3):
            v[a] = qw[a] - p[0, a]
        dv = v[0] * w0[0] + v[1] * w0[1] + v[2] * w0[2]
        for a in range(3):
            v_par[a] = dv * w0[a]
            v_perp[a] = v[a] - v_par[a]
        a_ = v_perp[0] * w1[0] + v_perp[1] * w1[1] + v_perp[2] * w1[2]
        cx = w0[1] * v_perp[2] - w0[2] * v_perp[1]
        cy = w0[2] * v_perp[0] - w0[0] * v_perp[2]
        cz = w0[0] * v_perp[1] - w0[1] * v_perp[0]
        b_ = -(cx * w1[0] + cy * w1[1] + cz * w1[2])
        c0 = 0.0
        for a in range(3):
            c0 += ((v_par[a] + p[0, a]) - wrist[a]) * w1[a]
        r_ = math.hypot(a_, b_)
        phi = math.atan2(b_, a_)
        cos1 = -c0 / r_
        d1 = math.acos(min(max(cos1, -1.0), 1.0)) if abs(cos1) <= 1.0 + 1e-12 else np.nan
        th1[0], th1[1] = phi + d1, phi - d1
        if r_ < 1e-9 * scale and abs(c0) < 1e-9 * scale:
            th1[0], th1[1] = th_ref[0], th_ref[0] + math.pi
        for s in range(2):
            _rot(w0, kk[0], -th1[s], r1i)
            _rot(w0, kk[0], th1[s], r1)
            for a in range(3):
                x[a] = r1i[a, 0] * v[0] + r1i[a, 1] * v[1] + r1i[a, 2] * v[2] + p[0, a]
            for a in range(3):
                xp[a] = x[a] - p[1, a]
            delta2 = xp[0] ** 2 + xp[1] ** 2 + xp[2] ** 2 - w2uv**2
            cos3 = (nu**2 + nv**2 - delta2) / (2.0 * nu * nv)
            if abs(cos3) <= 1.0 + 1e-10:
                cos3 = min(max(cos3, -1.0), 1.0)
                d3 = math.acos(cos3)
            else:
                d3 = np.nan
            th3[0], th3[1] = th0 - d3, th0 + d3
            for e in range(2):
                _rot(w2, kk[2], th3[e], r3)
                for a in range(3):
                    y[a] = r3[a, 0] * u[0] + r3[a, 1] * u[1] + r3[a, 2] * u[2] + p[2, a]
                for a in range(3):
                    yp[a] = y[a] - p[1, a]
                th2 = _sp1(w1, yp, xp)
                _rot(w1, kk[1], th2, r2)
                _mat3(r1, r2, r12)
                _mat3(r12, r3, r123)
                _mat3t(r123, rg, rw)
                for a in range(3):
                    vw[a] = rw[a, 0] * w6[0] + rw[a, 1] * w6[1] + rw[a, 2] * w6[2]
                vw4 = vw[0] * w4[0] + vw[1] * w4[1] + vw[2] * w4[2]
                al = (a45 * w5u - vw4) / den
                be = (a45 * vw4 - w5u) / den
                if usual > 0.5:
                    gam = _norm_cross(w4, vw) / ncr
                else:
                    g2 = (1.0 - al**2 - be**2 - 2.0 * al * be * a45) / (ncr**2)
                    gam = math.sqrt(max(g2, 0.0))
                for ws in range(2):
                    gs = gam if ws == 0 else -gam
                    for a in range(3):
                        cvec[a] = al * w4[a] + be * w5[a] + gs * cr[a]
                    th5 = _sp1(w5, w6, cvec)
                    wm = _norm_cross(w4, cvec)
                    th4 = _sp1(w4, cvec, vw)
                    if wm < 1e-9:
                        th4 = th_ref[3]
                    _rot(w4, kk[3], th4, r4)
                    _rot(w5, kk[4], th5, r5)
                    _mat3(r4, r5, r45)
                    _mat3t(r45, rw, r6)
                    for a in range(3):
                        rp[a] = r6[a, 0] * perp[0] + r6[a, 1] * perp[1] + r6[a, 2] * perp[2]
                    th6 = _sp1(w6, perp, rp)
                    row[0], row[1], row[2] = th1[s], th2, th3[e]
                    row[3], row[4], row[5] = th4, th5, th6
                    k = s + 2 * e + 4 * ws
                    for j in range(6):
                        t = row[j] - offset[j]
                        theta[i, k, j] = ((t + math.pi) % two_pi - math.pi) + offset[j]
