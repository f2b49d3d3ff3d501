"""What a program writer changes: per-move spindle speed, feed and passes.

Every dialect writer (``write_gcode``, ``write_apt``, ``write_krl``,
``write_rapid``, ``write_table_program``) takes the text of the program it
read and one :class:`ProgramEdit`, in the manner of a CAM post processor: one
interface, one module per controller dialect. The edit is indexed by the
rows of the waypoint table the dialect's reader made of that text, so a
writer knows which source line each move came from.

Passes: the cutting moves of a *section* (a maximal run of consecutive
cutting waypoints) are repeated ``n`` times, shifted along the (constant)
tool axis by ``(n - k) * depth / n`` for pass ``k = 1 .. n``; the last pass
is the program's own moves. Between passes the tool leaves along the tool
axis to ``retract_mm`` above the highest point of the section, moves across
at that height and comes down along the axis to the next pass's start
(rapids: the program's own approach reached the section's start point with
a rapid, and every link point lies above it or above the section).
:func:`expected_table` is the waypoint table the written program must read
back to; every writer's output is checked against it before it is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = [
    "ProgramEdit",
    "Section",
    "expected_table",
    "fmt_num",
    "line_values",
    "link_moves",
    "modal_values",
    "sections",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

#: The tool axis of a section with passes must stay within this of constant (unit vector).
_AXIS_TOL = 1e-9


@dataclass(frozen=True)
class ProgramEdit:
    """Per-move changes to a program, indexed by its waypoint table's rows.

    Attributes
    ----------
    waypoints : pandas.DataFrame
        The program's waypoint table as its reader made it (n rows).
    rpm : ndarray, shape (n,)
        Spindle speed [rpm] of each cutting move (whole numbers); NaN on
        rapids. All rows of one source line (a linearised arc) carry one value.
    feed_mm_per_min : ndarray, shape (n,)
        Feed [mm/min] of each cutting move; NaN on rapids.
    margin : ndarray, shape (n,)
        Stability margin at ``rpm`` (for the comments; NaN where unknown).
    passes : ndarray of int, shape (n,)
        Passes of each move (1: as programmed).
    depth_mm : ndarray, shape (n,)
        Depth [mm] the passes of a move divide (NaN where ``passes`` is 1).
    retract_mm : float
        Clearance [mm] above a section's highest point for the links between passes.
    options : dict
        Dialect settings (analog output scaling, synchronisation).
    """

    waypoints: pd.DataFrame
    rpm: FloatArray
    feed_mm_per_min: FloatArray
    margin: FloatArray
    passes: IntArray
    depth_mm: FloatArray
    retract_mm: float = 5.0
    options: dict[str, Any] = field(default_factory=dict)

    @property
    def cut(self) -> NDArray[np.bool_]:
        """Rows of cutting moves, shape (n,)."""
        return (self.waypoints["motion"] == "cut").to_numpy()


@dataclass(frozen=True)
class Section:
    """A maximal run of cutting rows ``start .. stop - 1`` with its passes."""

    start: int
    stop: int
    passes: int
    depth_mm: float
    axis: tuple[float, float, float]

    def offsets_mm(self) -> list[float]:
        """Shift [mm] of each pass along the tool axis, first pass first (last: 0)."""
        n = self.passes
        return [(n - k) * self.depth_mm / n for k in range(1, n + 1)]


def sections(edit: ProgramEdit) -> list[Section]:
    """The runs of cutting rows that have more than one pass.

    Raises
    ------
    InputError
        A section whose moves disagree on the pass count or depth, whose tool
        axis changes, that starts the program (no start point to come back
        to), or with a depth that is not positive.
    """
    wp = edit.waypoints
    cut = edit.cut
    out: list[Section] = []
    n = len(wp)
    src = wp["source"].to_numpy()
    line = wp["line"].to_numpy()
    axis = wp[["i", "j", "k"]].to_numpy(dtype=np.float64)
    i = 0
    while i < n:
        if not cut[i]:
            i += 1
            continue
        j = i
        while j < n and cut[j]:
            j += 1
        p = edit.passes[i:j]
        if np.any(p > 1):
            where = f"{src[i]}:{line[i]}"
            if np.any(p != p[0]):
                raise InputError(
                    f"passes: expected one pass count for the run of cutting moves from line "
                    f"{line[i]} to {line[j - 1]}, found {sorted(set(p.tolist()))}",
                    source=where,
                )
            d = edit.depth_mm[i:j]
            if not np.all(np.isfinite(d)) or np.any(d <= 0) or np.ptp(d) > 1e-9:
                raise InputError(
                    f"passes: expected one positive depth for the run of cutting moves from line "
                    f"{line[i]} to {line[j - 1]}, found {sorted(set(np.round(d, 6).tolist()))} mm",
                    source=where,
                )
            a = axis[i:j]
            if np.max(np.abs(a - a[0])) > _AXIS_TOL:
                raise InputError(
                    "passes: the tool axis changes within the run of cutting moves from line "
                    f"{line[i]} to {line[j - 1]}; passes along a changing axis are not defined",
                    source=where,
                )
            if i == 0:
                raise InputError(
                    "passes: the program starts with a cutting move (no start point to come "
                    "back to between passes)",
                    source=where,
                )
            ax = (float(a[0, 0]), float(a[0, 1]), float(a[0, 2]))
            out.append(Section(i, j, int(p[0]), float(d[0]), ax))
        i = j
    return out


def _link_points(edit: ProgramEdit, sec: Section, pos_mm: FloatArray) -> tuple[float, FloatArray]:
    """Safe height along the axis [mm] and the section's start point [mm] (row before it)."""
    a = np.asarray(sec.axis)
    pts = pos_mm[sec.start - 1 : sec.stop]
    return float(np.max(pts @ a)) + edit.retract_mm, pos_mm[sec.start - 1]


def link_moves(
    edit: ProgramEdit, sec: Section, pos_mm: FloatArray, end: FloatArray, offset_mm: float
) -> list[FloatArray]:
    """Rapid link points [mm] from ``end`` to the start of the pass at ``offset_mm``.

    Retract along the tool axis to the safe height, across at that height,
    down along the axis to the section's start point shifted by the pass's
    offset. From the program's start point itself (before the first pass):
    one move straight up along the axis.
    """
    a = np.asarray(sec.axis)
    safe, start = _link_points(edit, sec, pos_mm)
    target = start + offset_mm * a
    if np.allclose(end, start, atol=1e-9, rtol=0):
        return [target] if offset_mm != 0 else []
    up = end + (safe - float(end @ a)) * a
    over = start + (safe - float(start @ a)) * a
    return [up, over, target]


def expected_table(edit: ProgramEdit) -> pd.DataFrame:
    """The waypoint table the written program must read back to (positions, motion, S, F).

    Columns ``x_mm y_mm z_mm motion rpm feed_mm_per_min`` (S and F NaN on
    rapids; link moves between passes are rapids), then ``i j k ox oy oz``
    and the ``source`` and ``line`` each move was copied from.
    """
    wp = edit.waypoints
    pos = wp[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
    extra = wp[["i", "j", "k", "ox", "oy", "oz"]].to_numpy(dtype=np.float64)
    where = wp[["source", "line"]].to_numpy(dtype=object)
    parts_extra: list[FloatArray] = []
    parts_where: list[NDArray[np.object_]] = []
    motion = wp["motion"].to_numpy()
    rpm = np.where(edit.cut, edit.rpm, np.nan)
    feed = np.where(edit.cut, edit.feed_mm_per_min, np.nan)
    parts_pos: list[FloatArray] = []
    parts_mot: list[NDArray[np.object_]] = []
    parts_rpm: list[FloatArray] = []
    parts_feed: list[FloatArray] = []

    def put(sl: slice, shift: FloatArray | None = None) -> None:
        p = pos[sl]
        parts_pos.append(p + shift if shift is not None else p)
        parts_mot.append(motion[sl].astype(object))
        parts_rpm.append(rpm[sl])
        parts_feed.append(feed[sl])
        parts_extra.append(extra[sl])
        parts_where.append(where[sl])

    def put_links(points: list[FloatArray], sec: Section) -> None:
        if points:
            k = len(points)
            e = np.full((k, 6), np.nan)
            e[:, :3] = sec.axis
            parts_extra.append(e)
            parts_where.append(np.repeat(where[sec.start : sec.start + 1], k, axis=0))
            parts_pos.append(np.array(points))
            parts_mot.append(np.array(["rapid"] * k, dtype=object))
            parts_rpm.append(np.full(k, np.nan))
            parts_feed.append(np.full(k, np.nan))

    prev = 0
    for sec in sections(edit):
        put(slice(prev, sec.start))
        end = pos[sec.start - 1]
        a = np.asarray(sec.axis)
        for off in sec.offsets_mm():
            put_links(link_moves(edit, sec, pos, end, off), sec)
            put(slice(sec.start, sec.stop), off * a if off else None)
            end = pos[sec.stop - 1] + off * a
        prev = sec.stop
    put(slice(prev, len(wp)))
    p = np.concatenate(parts_pos)
    e = np.concatenate(parts_extra)
    w = np.concatenate(parts_where)
    return pd.DataFrame(
        {
            "x_mm": p[:, 0],
            "y_mm": p[:, 1],
            "z_mm": p[:, 2],
            "motion": np.concatenate(parts_mot),
            "rpm": np.concatenate(parts_rpm),
            "feed_mm_per_min": np.concatenate(parts_feed),
            **{c: e[:, n] for n, c in enumerate(("i", "j", "k", "ox", "oy", "oz"))},
            "source": w[:, 0],
            "line": w[:, 1].astype(np.int64),
        }
    )


def line_values(edit: ProgramEdit) -> dict[int, tuple[float, float, float]]:
    """Per source line of a cutting move: (rpm, feed [mm/min], lowest margin).

    Only rows of the program's main file (the ``source`` of its first row).
    """
    wp = edit.waypoints
    cut = edit.cut
    main = wp["source"].iloc[0]
    sel = cut & (wp["source"] == main).to_numpy()
    out: dict[int, tuple[float, float, float]] = {}
    lines = wp["line"].to_numpy()[sel]
    r, f, m = edit.rpm[sel], edit.feed_mm_per_min[sel], edit.margin[sel]
    for ln, ri, fi, mi in zip(lines.tolist(), r.tolist(), f.tolist(), m.tolist(), strict=True):
        got = out.get(ln)
        if got is None:
            out[ln] = (ri, fi, mi)
        else:
            low = mi if math.isnan(got[2]) else (got[2] if math.isnan(mi) else min(got[2], mi))
            out[ln] = (got[0], got[1], low)
    return out


def fmt_num(v: float, decimals: int = 6) -> str:
    """A number as a program writes it: fixed point, trailing zeros dropped, ``"10."`` style."""
    s = f"{v:.{decimals}f}"
    if "." in s:
        s = s.rstrip("0")
    if s in ("-0.", "-0"):
        s = "0."
    return s


def modal_values(
    setters: dict[int, str | None], want: dict[int, str]
) -> tuple[dict[int, str], dict[int, str]]:
    """Where a modal value (a speed, a feed) is set and where it must be set anew.

    Parameters
    ----------
    setters : dict of int to str or None
        Lines of the program's own statements that set the value: their text
        (editable) or None (set to something the writer does not edit: a
        variable, another form).
    want : dict of int to str
        The value each cutting line needs (text as the writer writes it).

    Returns
    -------
    edits, inserts : dict of int to str
        New text for an editable setter (the value of the first cutting line
        it governs, when it governs one and differs), and the value to set
        anew before a cutting line where the value in effect differs.
    """
    events = sorted({*setters, *want})
    first_after: dict[int, int] = {}
    last: int | None = None
    for ln in events:
        if ln in setters:
            last = ln
        if ln in want and last is not None and last not in first_after:
            first_after[last] = ln
    edits: dict[int, str] = {}
    inserts: dict[int, str] = {}
    cur: str | None = None
    for ln in events:
        if ln in setters:
            old = setters[ln]
            if old is None:
                cur = None
            else:
                new = want[first_after[ln]] if ln in first_after else old
                if ln in first_after and _differs(old, new):
                    edits[ln] = new
                cur = new
        if ln in want and (cur is None or _differs(cur, want[ln])):
            inserts[ln] = want[ln]
            cur = want[ln]
    return edits, inserts


def _differs(a: str, b: str) -> bool:
    try:
        return float(a) != float(b)
    except ValueError:
        return a != b
