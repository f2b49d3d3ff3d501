"""What a program writer changes: per-move spindle speed, feed and passes.

Every dialect writer (``write_gcode``, ``write_apt``, ``write_krl``,
``write_rapid``, ``write_table_program``) takes the text of the program it
read and one :class:`ProgramEdit`, in the manner of a CAM post processor: one
interface, one module per controller dialect. The edit is indexed by the
rows of the waypoint table the dialect's reader made of that text, so a
writer knows which source line each move came from.

Passes: the cutting moves of a *section* (a maximal run of consecutive
cutting waypoints) are repeated ``n`` times, whole, shifted along the
(constant) tool axis by ``(n - k) * depth / n`` for pass ``k = 1 .. n``
(``depth``: the total, ``depth / n`` per pass); the last pass is the
program's own moves. :func:`pass_layout` lays the passes out once for every
writer (each dialect formats its lines only). Between passes the tool leaves along the tool
axis to ``retract_mm`` above the highest point of the section, moves across
at that height and comes down along the axis to the next pass's start
(rapids: the program's own approach reached the section's start point with
a rapid, and every link point lies above it or above the section).
:func:`expected_table` is the waypoint table the written program must read
back to; every writer's output is checked against it before it is kept.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = [
    "ClRecord",
    "LineValues",
    "Pass",
    "ProgramEdit",
    "Section",
    "cl_records",
    "expected_table",
    "fmt_num",
    "line_values",
    "modal_values",
    "pass_layout",
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
    out: list[Section] = []
    # the columns as they are: a few entries are read (to_numpy() of the labels makes a
    # str per row, of the axes an (n, 3) copy: a long program's writer and check peaks)
    src = wp["source"].array
    line = wp["line"].to_numpy()
    axes = wp[["i", "j", "k"]]
    rows = np.flatnonzero(edit.cut)
    cuts = np.flatnonzero(np.diff(cut_runs(rows))) + 1
    for run in np.split(rows, cuts) if rows.size else []:
        i, j = int(run[0]), int(run[-1]) + 1
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
            a = axes.iloc[i:j].to_numpy(dtype=np.float64)
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
    return out


def cut_runs(cut_rows: NDArray[np.int64]) -> NDArray[np.int64]:
    """Run (section) of each cutting move: runs of consecutive rows of the waypoint table.

    The one definition of a section, for the planner's passes and the writers.

    Parameters
    ----------
    cut_rows : ndarray of int, shape (n_cut,)
        Row of each cutting move in the waypoint table (increasing).

    Returns
    -------
    ndarray of int, shape (n_cut,)
        0, 1, ... numbering the runs in program order.
    """
    rows = np.asarray(cut_rows, dtype=np.int64)
    if rows.size == 0:
        return np.zeros(0, dtype=np.int64)
    return np.cumsum(np.r_[True, np.diff(rows) != 1]).astype(np.int64) - 1


@dataclass(frozen=True)
class Pass:
    """One pass of a :class:`Section`, as :func:`pass_layout` lays it out.

    Attributes
    ----------
    index, count : int
        Pass ``index`` of ``count`` (1-based; the last is the program's own moves).
    offset_mm : float
        Shift [mm] along the tool axis above the programmed depth:
        ``(count - index) * depth_per_pass``; 0 for the last pass.
    shift_mm : ndarray, shape (3,)
        ``offset_mm`` times the tool axis [mm].
    links : tuple of (ndarray, int)
        The rapid link points [mm] into this pass's start, in order, each
        with the row it lies above along the tool axis (the section's last
        row: above where the pass before ended; the row before the section:
        above the section's start point). Empty where the pass starts where
        the program already is.
    restate : bool
        Whether the spindle speed and feed in effect at the pass start must
        be set anew: a pass after the first, in a section whose S or F
        changes along it (the pass before ended with other values).
    """

    index: int
    count: int
    offset_mm: float
    shift_mm: FloatArray
    links: tuple[tuple[FloatArray, int], ...]
    restate: bool

    @property
    def own(self) -> bool:
        """The last pass: the program's own moves, written where they are."""
        return self.index == self.count


def pass_layout(edit: ProgramEdit, sec: Section, pos_mm: FloatArray) -> Iterator[Pass]:
    """The passes of ``sec`` in program order, with their rapid links (module notes).

    Every dialect writer takes this one layout and formats its lines: the
    link moves, the restated S and F, then the section's lines shifted by
    ``shift_mm`` (nothing to copy for the last pass, the program's own).

    Parameters
    ----------
    edit : ProgramEdit
    sec : Section
    pos_mm : ndarray, shape (n, 3)
        The waypoints' positions [mm].

    Yields
    ------
    Pass
    """
    a = np.asarray(sec.axis)
    start_row, end_row = sec.start - 1, sec.stop - 1
    start = pos_mm[start_row]
    safe = float(np.max(pos_mm[start_row : sec.stop] @ a)) + edit.retract_mm
    rpm = edit.rpm[sec.start : sec.stop]
    feed = edit.feed_mm_per_min[sec.start : sec.stop]
    varies = bool(np.ptp(rpm) > 0 or np.ptp(feed) > 0)
    offs = sec.offsets_mm()
    end = start
    for k, off in enumerate(offs, start=1):
        target = start + off * a
        links: list[tuple[FloatArray, int]] = []
        if k == 1:  # from the section's own start point: straight up along the axis
            if off != 0:
                links.append((target, start_row))
        else:  # retract, across at the safe height (where the pass ended elsewhere), down
            up = end + (safe - float(end @ a)) * a
            over = start + (safe - float(start @ a)) * a
            links.append((up, end_row))
            if np.max(np.abs(over - up)) > 1e-9:
                links.append((over, start_row))
            links.append((target, start_row))
        yield Pass(k, len(offs), off, off * a, tuple(links), varies and k > 1)
        end = pos_mm[end_row] + off * a


def expected_table(edit: ProgramEdit, *, full: bool = True) -> pd.DataFrame:
    """The waypoint table the written program must read back to (positions, motion, S, F).

    Columns ``x_mm y_mm z_mm motion rpm feed_mm_per_min`` (S and F NaN on
    rapids; link moves between passes are rapids); with ``full`` also
    ``i j k ox oy oz`` and the ``source`` and ``line`` each move was copied
    from.
    """
    wp = edit.waypoints
    secs = sections(edit)
    cut = edit.cut
    rpm = np.where(cut, edit.rpm, np.nan)
    feed = np.where(cut, edit.feed_mm_per_min, np.nan)
    if not secs and not full:  # the program's own moves: no copies (a million rows: 40 MB)
        return pd.DataFrame(
            {
                # column by column (no (n, 3) copy of the positions beside them)
                **{f"{c}_mm": wp[f"{c}_m"].to_numpy(dtype=np.float64) * 1e3 for c in "xyz"},
                # the waypoint table's own labels (to_numpy(): a str object per row)
                "motion": wp["motion"].array,
                "rpm": rpm,
                "feed_mm_per_min": feed,
            },
            copy=False,
        )
    pos = wp[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
    # each expected row: the original row it copies (links: the section's first row),
    # its position and whether it is a link (a rapid without S and F)
    parts_row: list[IntArray] = []
    parts_pos: list[FloatArray] = []
    parts_link: list[NDArray[np.bool_]] = []

    def put(lo: int, hi: int, shift: FloatArray | None = None) -> None:
        parts_row.append(np.arange(lo, hi, dtype=np.int64))
        parts_pos.append(pos[lo:hi] + shift if shift is not None else pos[lo:hi])
        parts_link.append(np.zeros(hi - lo, bool))

    prev = 0
    for sec in secs:
        put(prev, sec.start)
        for ps in pass_layout(edit, sec, pos):
            if ps.links:
                parts_row.append(np.full(len(ps.links), sec.start, np.int64))
                parts_pos.append(np.array([p for p, _ in ps.links]))
                parts_link.append(np.ones(len(ps.links), bool))
            put(sec.start, sec.stop, None if ps.own else ps.shift_mm)
        prev = sec.stop
    put(prev, len(wp))
    row = np.concatenate(parts_row) if len(parts_row) > 1 else parts_row[0]
    p = np.concatenate(parts_pos) if len(parts_pos) > 1 else parts_pos[0]
    link = np.concatenate(parts_link) if len(parts_link) > 1 else parts_link[0]
    motion = wp["motion"].to_numpy()[row]
    if link.any():
        motion = np.where(link, "rapid", motion)
    cols: dict[str, object] = {
        "x_mm": p[:, 0],
        "y_mm": p[:, 1],
        "z_mm": p[:, 2],
        "motion": motion,
        "rpm": np.where(link, np.nan, rpm[row]),
        "feed_mm_per_min": np.where(link, np.nan, feed[row]),
    }
    if full:
        extra = wp[["i", "j", "k", "ox", "oy", "oz"]].to_numpy(dtype=np.float64)[row]
        if link.any():
            extra[link, 3:] = np.nan
        for n, c in enumerate(("i", "j", "k", "ox", "oy", "oz")):
            cols[c] = extra[:, n]
        cols["source"] = wp["source"].to_numpy()[row]
        cols["line"] = wp["line"].to_numpy()[row]
    return pd.DataFrame(cols)


@dataclass(frozen=True)
class ClRecord:
    """One record of a translated program (:func:`cl_records`).

    ``kind``: ``"spindle"`` (``value``: rpm), ``"feed"`` (``value``: mm/min),
    ``"rapid"`` or ``"cut"`` (a move to ``xyz`` [mm] with tool axis ``ijk``,
    copied from ``where``, the source's ``file:line``).
    """

    kind: str
    value: float = math.nan
    xyz: tuple[float, float, float] = (math.nan, math.nan, math.nan)
    ijk: tuple[float, float, float] = (0.0, 0.0, 1.0)
    where: str = ""


def cl_records(table: pd.DataFrame) -> Iterator[ClRecord]:
    """The moves of ``expected_table(edit)`` as cutter-location records, in order.

    What a translation writes, whatever its dialect: the spindle speed of
    the first cutting move before the first move (the spindle runs up before
    the approach), a new speed before each cutting move whose S differs from
    the one in effect, a new feed likewise, then the move. Each dialect
    formats these records only.
    """
    cut = (table["motion"] == "cut").to_numpy()
    rpm = table["rpm"].to_numpy(dtype=np.float64)
    feed = table["feed_mm_per_min"].to_numpy(dtype=np.float64)
    xyz = table[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=np.float64)
    ijk = table[["i", "j", "k"]].to_numpy(dtype=np.float64)
    where = (table["source"].astype(str) + ":" + table["line"].astype(str)).to_numpy()
    s_cur = math.nan
    f_cur = math.nan
    if cut.any():
        s_cur = float(rpm[int(np.argmax(cut))])
        yield ClRecord("spindle", s_cur)
    for r in range(len(table)):
        if cut[r]:
            if rpm[r] != s_cur:
                s_cur = float(rpm[r])
                yield ClRecord("spindle", s_cur)
            if feed[r] != f_cur:
                f_cur = float(feed[r])
                yield ClRecord("feed", f_cur)
        yield ClRecord(
            "cut" if cut[r] else "rapid",
            xyz=(float(xyz[r, 0]), float(xyz[r, 1]), float(xyz[r, 2])),
            ijk=(float(ijk[r, 0]), float(ijk[r, 1]), float(ijk[r, 2])),
            where=str(where[r]),
        )


class LineValues:
    """Per source line of a cutting move: (rpm, feed [mm/min], lowest margin).

    A mapping from line number to that tuple, held in arrays indexed by line
    (a million-line program costs 25 bytes a line, not a dict of tuples).
    The values of a line are those of its first cutting row (all rows of a
    block carry one S and F); the margin is the lowest of its rows.
    """

    def __init__(self, line: IntArray, rpm: FloatArray, feed: FloatArray, margin: FloatArray):
        n = int(line.max()) + 1 if len(line) else 1
        self._has = np.zeros(n, bool)
        self._rpm = np.full(n, np.nan)
        self._feed = np.full(n, np.nan)
        self._margin = np.full(n, np.nan)
        uniq, first = np.unique(line, return_index=True)
        self._has[uniq] = True
        self._rpm[uniq] = rpm[first]
        self._feed[uniq] = feed[first]
        np.fmin.at(self._margin, line, margin)

    def __contains__(self, ln: object) -> bool:
        if not isinstance(ln, int | np.integer) or not 0 <= ln < len(self._has):
            return False
        return bool(self._has[ln])

    def __getitem__(self, ln: int) -> tuple[float, float, float]:
        if ln not in self:
            raise KeyError(ln)
        return float(self._rpm[ln]), float(self._feed[ln]), float(self._margin[ln])

    def __iter__(self) -> Iterator[int]:
        return iter(np.flatnonzero(self._has).tolist())

    def __len__(self) -> int:
        return int(self._has.sum())

    def lists(self) -> tuple[bytes, array[int], list[float], array[int], list[float]]:
        """The values per line for writers that visit every line of a long program.

        Returns
        -------
        has : bytes
            ``has[ln]`` nonzero where line ``ln`` has a cutting move (lines at or
            past ``len(has)`` have none).
        rpm_code, rpm_values : array.array of int, list of float
            The line's speed [rpm] is ``rpm_values[rpm_code[ln]]``.
        feed_code, feed_values : array.array of int, list of float
            The same for its feed [mm/min].

        A list index costs a fraction of ``in`` and ``[]`` on this mapping,
        and the codes take 4 bytes a line (a program has few distinct values),
        not a float object each. The margin stays with ``[]`` (needed on few lines).
        """
        out: list[Any] = [self._has.tobytes()]
        for v in (self._rpm, self._feed):
            values, code = np.unique(v, return_inverse=True)
            codes = array("i")
            codes.frombytes(code.ravel().astype(np.intc).tobytes())
            out += [codes, values.tolist()]
        return out[0], out[1], out[2], out[3], out[4]

    def items(self) -> Iterator[tuple[int, tuple[float, float, float]]]:
        return ((ln, self[ln]) for ln in self)

    def values(self) -> Iterator[tuple[float, float, float]]:
        return (self[ln] for ln in self)


def line_values(edit: ProgramEdit) -> LineValues:
    """Per source line of a cutting move: (rpm, feed [mm/min], lowest margin).

    Only rows of the program's main file (the ``source`` of its first row).
    """
    wp = edit.waypoints
    main = wp["source"].iloc[0]
    sel = edit.cut & (wp["source"] == main).to_numpy()
    return LineValues(
        wp["line"].to_numpy()[sel].astype(np.int64),
        edit.rpm[sel],
        edit.feed_mm_per_min[sel],
        edit.margin[sel],
    )


def fmt_num(v: float, decimals: int = 6, *, point: bool = True) -> str:
    """A number as a program writes it: fixed point, trailing zeros dropped.

    ``point``: whole numbers keep their decimal point (``"10."``, as CNC posts
    write them); without it they are written as integers (``"10"``: KRL and
    RAPID, whose grammars want digits after a point).
    """
    s = f"{v:.{decimals}f}"
    if "." in s:
        s = s.rstrip("0")
    if s in ("-0.", "-0"):
        s = "0."
    return s if point else s.rstrip(".")


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
