"""Arc linearisation shared by the readers (G2/G3, APT CIRCLE, KRL CIRC, RAPID MoveC)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = ["arc_points", "arc_start_tangent", "arc_through", "circle_through"]

_MAX_SEGMENTS = 2_000_000

FloatArray = NDArray[np.float64]


def _n_segments(radius: float, sweep: float, tol: float, where: str) -> int:
    if not (math.isfinite(radius) and math.isfinite(sweep)):
        raise InputError("arc with a non-finite radius or sweep", source=where)
    if radius <= tol:
        return 1
    half = math.acos(max(-1.0, 1.0 - tol / radius))
    n = max(1, math.ceil(abs(sweep) / (2 * half)))
    if n > _MAX_SEGMENTS:
        raise InputError(
            f"arc of radius {radius:.4g} mm sweeping {math.degrees(abs(sweep)):.4g} deg needs "
            f"{n} chords within {tol:g} mm: expected a plausible arc (check the units and the "
            "arc words)",
            source=where,
        )
    return n


def _check_finite(where: str, *vecs: FloatArray) -> None:
    for v in vecs:
        if not np.all(np.isfinite(v)) or float(np.max(np.abs(v))) > 1e7:
            raise InputError(
                f"arc point {np.asarray(v).tolist()}: expected finite coordinates within 1e7 mm",
                source=where,
            )


def arc_start_tangent(
    start: FloatArray, centre: FloatArray, normal: FloatArray, *, clockwise: bool
) -> FloatArray:
    """Unit direction in which an arc leaves ``start`` (in the arc plane); shape (3,)."""
    nrm = normal / np.linalg.norm(normal)
    rs = start - centre
    rs = rs - float(rs @ nrm) * nrm
    t = np.cross(nrm, rs)
    n = float(np.linalg.norm(t))
    if n < 1e-12:
        return np.zeros(3)
    return -t / n if clockwise else t / n


def arc_points(
    start: FloatArray,
    end: FloatArray,
    centre: FloatArray,
    normal: FloatArray,
    *,
    clockwise: bool,
    tol: float,
    full_circle: bool = False,
    turns: int = 0,
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
    turns : int
        Extra full turns before the end (multi-turn helices, ``TIMES,n``).
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
    _check_finite(where, start, end, centre)
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
    if turns:
        sweep += (-2 * math.pi if clockwise else 2 * math.pi) * turns
    n = _n_segments(r0, sweep, tol, where)
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


def circle_through(
    start: FloatArray, via: FloatArray, end: FloatArray, where: str = ""
) -> tuple[FloatArray, FloatArray] | None:
    """Centre and unit normal of the circle through three points (None if collinear).

    The normal is ``(via - start) x (end - start)``: the arc start -> via -> end
    runs counter-clockwise about it.
    """
    _check_finite(where, start, via, end)
    a = via - start
    b = end - start
    nrm = np.cross(a, b)
    nn = float(np.linalg.norm(nrm))
    scale = max(float(np.linalg.norm(a)), float(np.linalg.norm(b)), 1e-300)
    if nn < 1e-9 * scale**2:
        return None
    nrm = nrm / nn
    aa, bb = float(a @ a), float(b @ b)
    ab = float(a @ b)
    den = 2 * (aa * bb - ab * ab)
    s = bb * (aa - ab) / den
    t = aa * (bb - ab) / den
    return start + s * a + t * b, nrm


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
    circ = circle_through(start, via, end, where)
    if circ is None:
        return np.stack([via, end])
    centre, nrm = circ
    # via lies on the arc: sense is CCW about nrm (nrm = a x b puts via first)
    return arc_points(start, end, centre, nrm, clockwise=False, tol=tol, where=where)
