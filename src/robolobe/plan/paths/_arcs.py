"""Arc linearisation shared by the readers (G2/G3, APT CIRCLE, KRL CIRC, RAPID MoveC)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = ["arc_points", "arc_through"]

FloatArray = NDArray[np.float64]


def _n_segments(radius: float, sweep: float, tol: float) -> int:
    if radius <= tol:
        return 1
    half = math.acos(max(-1.0, 1.0 - tol / radius))
    return max(1, math.ceil(abs(sweep) / (2 * half)))


def arc_points(
    start: FloatArray,
    end: FloatArray,
    centre: FloatArray,
    normal: FloatArray,
    *,
    clockwise: bool,
    tol: float,
    full_circle: bool = False,
    where: str = "",
) -> FloatArray:
    """Points along a (helical) arc, excluding the start, ending exactly at ``end``.

    Parameters
    ----------
    start, end, centre : ndarray, shape (3,)
        Start, end and a point on the arc axis [mm].
    normal : ndarray, shape (3,)
        Unit axis of the arc; counter-clockwise = positive rotation about it.
    clockwise : bool
        Sense of rotation (negative about ``normal`` when True).
    tol : float
        Chord tolerance [mm]. The end may miss the circle by
        ``max(0.01 mm, 0.1 % of the radius, 2 tol)`` (posts round to 3 decimals).
    full_circle : bool
        Sweep 360 degrees when start and end coincide in the plane.
    where : str
        ``file:line`` for errors.

    Returns
    -------
    ndarray, shape (n, 3)

    Raises
    ------
    InputError
        When the end point is not on the circle through the start point.
    """
    nrm = normal / np.linalg.norm(normal)
    rs = start - centre
    re = end - centre
    h0 = float(rs @ nrm)
    h1 = float(re @ nrm)
    rs_p = rs - h0 * nrm
    re_p = re - h1 * nrm
    r0 = float(np.linalg.norm(rs_p))
    r1 = float(np.linalg.norm(re_p))
    if r0 < 1e-12:
        raise InputError("arc of zero radius (start point at the centre)", source=where)
    if abs(r1 - r0) > max(0.01, 1e-3 * r0, 2 * tol):
        raise InputError(
            f"arc end point is not on the circle: radius at start {r0:.4g}, at end {r1:.4g}",
            source=where,
        )
    u = rs_p / r0
    v = np.cross(nrm, u)
    ang = math.atan2(float(re_p @ v), float(re_p @ u))  # (-pi, pi], CCW from start
    sweep = -(-ang % (2 * math.pi)) if clockwise else ang % (2 * math.pi)
    if abs(sweep) < 1e-12 and full_circle:
        sweep = -2 * math.pi if clockwise else 2 * math.pi
    n = _n_segments(r0, sweep, tol)
    t = np.arange(1, n + 1) / n
    th = sweep * t
    r = r0 + (r1 - r0) * t
    pts = (
        centre
        + (r * np.cos(th))[:, None] * u
        + (r * np.sin(th))[:, None] * v
        + (h0 + (h1 - h0) * t)[:, None] * nrm
    )
    pts[-1] = end
    return np.asarray(pts, dtype=np.float64)


def arc_through(
    start: FloatArray, via: FloatArray, end: FloatArray, *, tol: float, where: str = ""
) -> FloatArray:
    """Points along the circular arc from ``start`` through ``via`` to ``end``.

    Excludes the start, ends exactly at ``end``. Collinear points give a
    straight line (two points: via, end).

    Returns
    -------
    ndarray, shape (n, 3)
    """
    a = via - start
    b = end - start
    nrm = np.cross(a, b)
    nn = float(np.linalg.norm(nrm))
    scale = max(float(np.linalg.norm(a)), float(np.linalg.norm(b)), 1e-300)
    if nn < 1e-9 * scale**2:
        return np.stack([via, end])
    nrm = nrm / nn
    # circumcentre of the triangle (start, via, end)
    aa, bb = float(a @ a), float(b @ b)
    ab = float(a @ b)
    den = 2 * (aa * bb - ab * ab)
    s = bb * (aa - ab) / den
    t = aa * (bb - ab) / den
    centre = start + s * a + t * b
    # via lies on the arc: sense is CCW about nrm (nrm = a x b puts via first)
    return arc_points(start, end, centre, nrm, clockwise=False, tol=tol, where=where)
