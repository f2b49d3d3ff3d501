"""Cutter radius compensation (G41/G42) in the XY plane, as a controller applies it.

The programmed contour (lines and arcs, G17) is offset by the cutter radius
to the left (G41) or right (G42) of the direction of travel, in the manner
of the Fanuc "type C" / LinuxCNC interpreters:

- the **entry move** (the motion of the block that switches compensation
  on, or the first one after it) goes straight from the uncompensated
  position to the start of the first contour element offset perpendicular to
  that element;
- at an **outside corner** the tool goes around the programmed corner on an
  arc of the cutter radius; at an **inside corner** both offset elements end
  at their intersection (none within them: the cutter does not fit, refused);
- an arc's radius grows or shrinks by the cutter radius (refused where it
  would vanish: the cutter is larger than an inside arc);
- the **exit move** (the motion of the block with G40, or the first one
  after it) goes straight from the offset end of the last element to its
  programmed, uncompensated end point;
- moves along Z only (no XY motion) stay at the compensated XY position.

Helical arcs under compensation are refused (their Z would follow a
changed sweep), as are a reversal of direction at a corner.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any

from robolobe.errors import InputError

__all__ = ["Element", "compensate"]

_EPS = 1e-9


@dataclass(frozen=True)
class Element:
    """One programmed (or compensated) move in mm.

    ``kind`` is ``"line"`` or ``"arc"``; ``centre`` (x, y) and ``cw`` for
    arcs, ``full`` for a full circle; ``meta`` is what the reader emits with
    the move (line number, feed, ...).
    """

    kind: str
    p0: tuple[float, float, float]
    p1: tuple[float, float, float]
    meta: Any
    centre: tuple[float, float] = (0.0, 0.0)
    cw: bool = False
    full: bool = False

    @property
    def flat(self) -> bool:
        """No XY motion (a move along Z only)."""
        return (
            self.kind == "line"
            and math.hypot(self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]) < _EPS
        )

    def radius(self) -> float:
        return math.hypot(self.p0[0] - self.centre[0], self.p0[1] - self.centre[1])

    def tangent(self, at_end: bool) -> tuple[float, float]:
        """Unit direction of travel at the start (or end) in XY."""
        if self.kind == "line":
            dx, dy = self.p1[0] - self.p0[0], self.p1[1] - self.p0[1]
        else:
            p = self.p1 if at_end else self.p0
            rx, ry = p[0] - self.centre[0], p[1] - self.centre[1]
            dx, dy = (ry, -rx) if self.cw else (-ry, rx)
        n = math.hypot(dx, dy)
        return dx / n, dy / n


def _normal(d: tuple[float, float], side: float) -> tuple[float, float]:
    return -side * d[1], side * d[0]


def _offset(e: Element, side: float, r: float, where: str) -> Element:
    if e.kind == "line":
        nx, ny = _normal(e.tangent(False), side)
        return replace(
            e,
            p0=(e.p0[0] + r * nx, e.p0[1] + r * ny, e.p0[2]),
            p1=(e.p1[0] + r * nx, e.p1[1] + r * ny, e.p1[2]),
        )
    if abs(e.p1[2] - e.p0[2]) > _EPS:
        raise InputError(
            "unsupported construct: a helical arc under cutter radius compensation", where
        )
    big = e.radius()
    # the left of a counter-clockwise arc is its inside
    new = big - side * r if not e.cw else big + side * r
    if new <= _EPS:
        raise InputError(
            f"cutter radius compensation: the cutter (radius {r:g} mm) does not fit the "
            f"arc of radius {big:g} mm",
            where,
        )
    k = new / big
    cx, cy = e.centre

    def scale(p: tuple[float, float, float]) -> tuple[float, float, float]:
        return (cx + (p[0] - cx) * k, cy + (p[1] - cy) * k, p[2])

    return replace(e, p0=scale(e.p0), p1=scale(e.p1))


def _cross(a: tuple[float, float], b: tuple[float, float]) -> float:
    return a[0] * b[1] - a[1] * b[0]


def _param_line(e: Element, x: float, y: float) -> float:
    dx, dy = e.p1[0] - e.p0[0], e.p1[1] - e.p0[1]
    return ((x - e.p0[0]) * dx + (y - e.p0[1]) * dy) / (dx * dx + dy * dy)


def _on_arc(e: Element, x: float, y: float) -> float:
    """Fraction of the arc's sweep at which (x, y) lies (outside [0, 1]: not on it)."""
    cx, cy = e.centre
    a0 = math.atan2(e.p0[1] - cy, e.p0[0] - cx)
    a1 = math.atan2(e.p1[1] - cy, e.p1[0] - cx)
    a = math.atan2(y - cy, x - cx)
    sgn = -1.0 if e.cw else 1.0
    sweep = (sgn * (a1 - a0)) % (2 * math.pi)
    if e.full or sweep < _EPS:
        sweep = 2 * math.pi
    at = (sgn * (a - a0)) % (2 * math.pi)
    if at > sweep + 1e-9 and 2 * math.pi - at < 1e-9:
        at = 0.0
    return at / sweep


def _frac(e: Element, x: float, y: float) -> float:
    return _param_line(e, x, y) if e.kind == "line" else _on_arc(e, x, y)


def _circle(e: Element) -> tuple[float, float, float]:
    return e.centre[0], e.centre[1], e.radius()


def _intersections(a: Element, b: Element) -> list[tuple[float, float]]:
    if a.kind == "line" and b.kind == "line":
        d1 = (a.p1[0] - a.p0[0], a.p1[1] - a.p0[1])
        d2 = (b.p1[0] - b.p0[0], b.p1[1] - b.p0[1])
        den = _cross(d1, d2)
        if abs(den) < 1e-12:
            return []
        t = _cross((b.p0[0] - a.p0[0], b.p0[1] - a.p0[1]), d2) / den
        return [(a.p0[0] + t * d1[0], a.p0[1] + t * d1[1])]
    if a.kind == "arc" and b.kind == "arc":
        x0, y0, r0 = _circle(a)
        x1, y1, r1 = _circle(b)
        d = math.hypot(x1 - x0, y1 - y0)
        if d < _EPS or d > r0 + r1 + 1e-9 or d < abs(r0 - r1) - 1e-9:
            return []
        m = (r0 * r0 - r1 * r1 + d * d) / (2 * d)
        h = math.sqrt(max(r0 * r0 - m * m, 0.0))
        mx, my = x0 + m * (x1 - x0) / d, y0 + m * (y1 - y0) / d
        ox, oy = -h * (y1 - y0) / d, h * (x1 - x0) / d
        return [(mx + ox, my + oy), (mx - ox, my - oy)]
    line, arc = (a, b) if a.kind == "line" else (b, a)
    cx, cy, rr = _circle(arc)
    dx, dy = line.p1[0] - line.p0[0], line.p1[1] - line.p0[1]
    fx, fy = line.p0[0] - cx, line.p0[1] - cy
    qa = dx * dx + dy * dy
    qb = 2 * (fx * dx + fy * dy)
    qc = fx * fx + fy * fy - rr * rr
    disc = qb * qb - 4 * qa * qc
    if disc < -1e-12:
        return []
    s = math.sqrt(max(disc, 0.0))
    return [
        (line.p0[0] + t * dx, line.p0[1] + t * dy)
        for t in ((-qb - s) / (2 * qa), (-qb + s) / (2 * qa))
    ]


def _z_at(e: Element, frac: float) -> float:
    return e.p0[2] + (e.p1[2] - e.p0[2]) * frac


def compensate(
    entry: Element,
    contour: list[Element],
    exit_move: Element | None,
    side: int,
    radius: float,
    where: str,
) -> list[Element]:
    """The compensated moves (module docstring).

    Parameters
    ----------
    entry : Element
        The entry move (a line, from the uncompensated position).
    contour : list of Element
        The moves with compensation on.
    exit_move : Element or None
        The exit move (a line to an uncompensated point); None: the program
        leaves compensation on (the last move ends offset).
    side : {41, 42}
    radius : float
        Cutter radius [mm] (0: the moves as programmed).
    where : str
        ``file:line`` of the G41/G42 block (messages).

    Returns
    -------
    list of Element
        The moves the tool centre makes, each with its source move's ``meta``.
    """
    if entry.kind != "line":
        raise InputError(
            "cutter radius compensation: expected a straight entry move after G41/G42", where
        )
    if exit_move is not None and exit_move.kind != "line":
        raise InputError(
            "cutter radius compensation: expected a straight exit move with G40", where
        )
    s = 1.0 if side == 41 else -1.0
    real = [k for k, e in enumerate(contour) if not e.flat]
    off = {k: _offset(contour[k], s, radius, where) for k in real}
    # corners between consecutive real elements
    after: dict[int, list[Element]] = {}
    for a, b in itertools.pairwise(real):
        ea, eb = off[a], off[b]
        ta, tb = contour[a].tangent(True), contour[b].tangent(False)
        cr = _cross(ta, tb)
        dot = ta[0] * tb[0] + ta[1] * tb[1]
        if abs(cr) < 1e-9 and dot > 0:
            continue  # tangent
        if abs(cr) < 1e-9:
            raise InputError("cutter radius compensation: the path reverses at a corner", where)
        corner = contour[a].p1
        if s * cr < 0:  # outside corner: around it on the cutter radius
            after.setdefault(a, []).append(
                Element("arc", ea.p1, (eb.p0[0], eb.p0[1], ea.p1[2]), contour[a].meta,
                        centre=(corner[0], corner[1]), cw=s > 0)
            )  # fmt: skip
            continue
        pts = _intersections(ea, eb)
        best = None
        for x, y in pts:
            fa, fb = _frac(ea, x, y), _frac(eb, x, y)
            if -1e-9 <= fa <= 1 + 1e-9 and -1e-9 <= fb <= 1 + 1e-9:
                dist = math.hypot(x - corner[0], y - corner[1])
                if best is None or dist < best[0]:
                    best = (dist, x, y, fa, fb)
        if best is None:
            raise InputError(
                f"cutter radius compensation: the cutter (radius {radius:g} mm) does not fit "
                f"the inside corner at X{corner[0]:g} Y{corner[1]:g} (line {contour[b].meta[0]})",
                where,
            )
        _, x, y, fa, fb = best
        off[a] = replace(ea, p1=(x, y, _z_at(ea, fa)), full=False)
        off[b] = replace(eb, p0=(x, y, _z_at(eb, fb)), full=False)
    out: list[Element] = []
    if real:
        first = off[real[0]]
        out.append(replace(entry, p1=(first.p0[0], first.p0[1], entry.p1[2])))
        pos = out[-1].p1
    else:
        nx, ny = _normal(entry.tangent(False), s) if not entry.flat else (0.0, 0.0)
        out.append(
            replace(entry, p1=(entry.p1[0] + radius * nx, entry.p1[1] + radius * ny, entry.p1[2]))
        )
        pos = out[-1].p1
    for k, e in enumerate(contour):
        if e.flat:
            out.append(replace(e, p0=pos, p1=(pos[0], pos[1], e.p1[2])))
        else:
            o = off[k]
            o = replace(o, p0=(o.p0[0], o.p0[1], pos[2]) if e.kind == "line" else o.p0)
            out.append(o)
            out.extend(after.get(k, []))
        pos = out[-1].p1
    if exit_move is not None:
        out.append(replace(exit_move, p0=pos))
    return out
