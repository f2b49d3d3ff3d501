"""Arc linearisation shared by the readers (G2/G3, APT CIRCLE, KRL CIRC, RAPID MoveC)."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = [
    "arc_point_list",
    "arc_points",
    "arc_start_tangent",
    "arc_through",
    "circle_through",
    "orientations_along",
]

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


Vec = tuple[float, float, float]


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
    pts = arc_point_list(
        _vec(start), _vec(end), _vec(centre), _vec(normal), clockwise=clockwise, tol=tol,
        full_circle=full_circle, turns=turns, where=where,
    )  # fmt: skip
    return np.array(pts, dtype=np.float64).reshape(-1, 3)


def _vec(a: FloatArray | Vec) -> Vec:
    return (float(a[0]), float(a[1]), float(a[2]))


def arc_point_list(
    start: Vec,
    end: Vec,
    centre: Vec,
    normal: Vec,
    *,
    clockwise: bool,
    tol: float,
    full_circle: bool = False,
    turns: int = 0,
    where: str = "",
) -> list[Vec]:
    """:func:`arc_points` on tuples, in pure Python (no numpy call per arc).

    The readers call it once per arc of a program that may hold a million
    of them; numpy's per-call overhead on 3-vectors would dominate.
    """
    for v in (start, end, centre):
        if not all(math.isfinite(c) and abs(c) <= 1e7 for c in v):
            raise InputError(
                f"arc point {list(v)}: expected finite coordinates within 1e7 mm", source=where
            )
    nn = math.sqrt(normal[0] ** 2 + normal[1] ** 2 + normal[2] ** 2)
    n0, n1, n2 = normal[0] / nn, normal[1] / nn, normal[2] / nn
    sx, sy, sz = start[0] - centre[0], start[1] - centre[1], start[2] - centre[2]
    ex, ey, ez = end[0] - centre[0], end[1] - centre[1], end[2] - centre[2]
    h0 = sx * n0 + sy * n1 + sz * n2
    h1 = ex * n0 + ey * n1 + ez * n2
    sx, sy, sz = sx - h0 * n0, sy - h0 * n1, sz - h0 * n2
    ex, ey, ez = ex - h1 * n0, ey - h1 * n1, ez - h1 * n2
    r0 = math.sqrt(sx * sx + sy * sy + sz * sz)
    r1 = math.sqrt(ex * ex + ey * ey + ez * ez)
    if r0 < 1e-12:
        raise InputError("arc of zero radius (start point at the centre)", source=where)
    if abs(r1 - r0) > max(0.01, 1e-3 * r0, 2 * tol):
        raise InputError(
            f"arc end point is not on the circle: radius at start {r0:.4g}, at end {r1:.4g}",
            source=where,
        )
    ux, uy, uz = sx / r0, sy / r0, sz / r0
    vx, vy, vz = n1 * uz - n2 * uy, n2 * ux - n0 * uz, n0 * uy - n1 * ux  # n x u
    ang = math.atan2(ex * vx + ey * vy + ez * vz, ex * ux + ey * uy + ez * uz)  # CCW from start
    two_pi = 2 * math.pi
    sweep = -(-ang % two_pi) if clockwise else ang % two_pi
    if abs(sweep) < 1e-12 and full_circle:
        sweep = -two_pi if clockwise else two_pi
    if turns:
        sweep += (-two_pi if clockwise else two_pi) * turns
    n = _n_segments(r0, sweep, tol, where)
    cx, cy, cz = centre
    out: list[Vec] = []
    for k in range(1, n):
        t = k / n
        th = sweep * t
        r = r0 + (r1 - r0) * t
        c, s = r * math.cos(th), r * math.sin(th)
        h = h0 + (h1 - h0) * t
        out.append(
            (
                cx + c * ux + s * vx + h * n0,
                cy + c * uy + s * vy + h * n1,
                cz + c * uz + s * vz + h * n2,
            )
        )
    out.append((float(end[0]), float(end[1]), float(end[2])))
    return out


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


def orientations_along(
    start: FloatArray, rot0: FloatArray, rot1: FloatArray, pts: FloatArray
) -> FloatArray:
    """Tool orientations at the points of a move, slerped by travelled length.

    Robot controllers turn the tool from the start to the end orientation
    along a circular move (KUKA ``$ORI_TYPE = #VAR``, ABB's default); the
    end orientation at every point would tilt the tool early.

    Parameters
    ----------
    start : ndarray, shape (3,)
        Start point of the move [mm].
    rot0, rot1 : ndarray, shape (3, 3)
        Tool orientation at the start and at the end.
    pts : ndarray, shape (n, 3)
        The move's points after the start (the last one is the end) [mm].

    Returns
    -------
    ndarray, shape (n, 3, 3)
    """
    from scipy.spatial.transform import Rotation, Slerp

    seg = np.linalg.norm(np.diff(np.vstack([start, pts]), axis=0), axis=1)
    total = float(seg.sum())
    frac = np.cumsum(seg) / total if total > 0 else np.ones(len(pts))
    key = Rotation.from_matrix(np.stack([rot0, rot1]))
    return np.asarray(Slerp([0.0, 1.0], key)(np.clip(frac, 0.0, 1.0)).as_matrix())
