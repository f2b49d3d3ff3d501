"""The waypoint table every toolpath reader returns.

One row per waypoint (the end point of one move; arcs are linearised into
several rows that share the source line). Columns, in this order:

==================  =======  ==========================================================
column              unit     meaning
==================  =======  ==========================================================
``x_m y_m z_m``     m        tool tip position in the workpiece (path) frame
``i j k``           1        tool axis, unit vector from the tip towards the spindle
``ox oy oz``        1        TCP x axis where the path fixes the rotation about the
                             tool axis (KRL, RAPID, CSV); NaN where it is free
``fx fy fz``        1        feed direction: unit vector of the move that ends here
                             (the first waypoint takes the next move's direction)
``feed_mm_per_min`` mm/min   programmed feed rate (NaN: none programmed)
``rpm_programmed``  rpm      programmed spindle speed (NaN: none programmed)
``motion``          -        ``"cut"`` or ``"rapid"`` (the move that ends here)
``source``          -        file name the waypoint came from
``line``            -        1-based line number in that file
==================  =======  ==========================================================
"""

from __future__ import annotations

import logging
import math
from array import array
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from robolobe._memory import release_free_memory
from robolobe.errors import InputError
from robolobe.plan.paths._edit import ProgramEdit, expected_table

__all__ = [
    "COLUMNS",
    "WaypointBuilder",
    "feed_directions",
    "program_table",
    "segment_lengths",
    "validate_waypoints",
]

COLUMNS: tuple[str, ...] = (
    "x_m",
    "y_m",
    "z_m",
    "i",
    "j",
    "k",
    "ox",
    "oy",
    "oz",
    "fx",
    "fy",
    "fz",
    "feed_mm_per_min",
    "rpm_programmed",
    "motion",
    "source",
    "line",
)

FloatArray = NDArray[np.float64]

logger = logging.getLogger(__name__)

_WIDTH = 10  # numbers per waypoint in WaypointBuilder._rows
#: Waypoints per block of a reader's buffer (5.2 MB). A long program is collected in
#: blocks of this size, never as one buffer grown by reallocation: each move of a grown
#: buffer left a freed copy in the heap (a million-line program read after a plan, as the
#: written program's check does: ~100 bytes a waypoint above the buffer itself).
_BLOCK_ROWS = 8_192
#: Blocks copied into the table between two releases of their freed memory (:meth:`table`).
_BLOCKS_PER_RELEASE = 8
_MAX_POS_M = 1e4  # 10 km: anything beyond is a corrupt or mis-scaled file


@dataclass
class WaypointBuilder:
    """Collects waypoints while a reader walks a file (positions in metres).

    Per-waypoint work is pure Python (no numpy call per line): a 1e6-line
    program is read in seconds.

    Parameters
    ----------
    source : str
        File name written into the ``source`` column.
    """

    source: str
    # one row per waypoint, flat: x y z [m], i j k, feed, rpm, rapid (0/1), line (80 bytes a
    # row: a list of tuples would take ~380 at a million waypoints)
    _rows: array = field(default_factory=lambda: array("d"))
    # the full blocks of ``_BLOCK_ROWS`` rows before ``_rows``, in order
    _blocks: list[array] = field(default_factory=list)
    # TCP x axes where the path fixes them, flat: row index, x, y, z
    _ref: array = field(default_factory=lambda: array("d"))
    warnings: list[str] = field(default_factory=list)
    _seen: dict[str, int] = field(default_factory=dict)
    _zero_speed_moves: set[tuple[int, int]] = field(default_factory=set)

    def feed_at_zero_speed(self, line: int, zero: tuple[int, str]) -> None:
        """Warn of a feed move while a robot program's spindle output is at 0.

        On a robot the analog output is the spindle's only switch: 0 is the
        spindle off (a retract after it is common), read as no programmed
        speed, but a cut there would be a program error. One warning per
        zero-setting statement, counted over the feed moves (source lines)
        it covers.

        Parameters
        ----------
        line : int
            Source line of the feed move.
        zero : tuple of (int, str)
            Line and text of the statement that set the output to 0.
        """
        if (zero[0], line) in self._zero_speed_moves:
            return
        self._zero_speed_moves.add((zero[0], line))
        self.warn(
            f"feed move with the spindle output at 0 ({zero[1]}, line {zero[0]}): read as the "
            "spindle off, no programmed speed; if it cuts, program the speed it cuts at",
            line,
            key=f"spindle-zero:{zero[0]}",
        )

    def warn(self, message: str, line: int | None = None, *, key: str | None = None) -> None:
        """Record a reader warning (logged now, repeated in the plan summary).

        Warnings with the same ``key`` are counted; the first is kept with
        its line, later ones raise the count shown by :meth:`table`.
        """
        k = key or message
        if k in self._seen:
            self._seen[k] += 1
            return
        self._seen[k] = 1
        text = (
            f"{self.source}:{line}: {message}" if line is not None else f"{self.source}: {message}"
        )
        logger.warning("%s", text)
        self.warnings.append(k + "\x00" + text)

    def add(
        self,
        pos_m: FloatArray | tuple[float, float, float] | list[float],
        axis: FloatArray | tuple[float, float, float] | list[float],
        *,
        line: int,
        rapid: bool,
        feed_mm_per_min: float = math.nan,
        rpm: float = math.nan,
        ref: FloatArray | tuple[float, float, float] | None = None,
    ) -> None:
        """Append one waypoint (the end of a move).

        Parameters
        ----------
        pos_m : array, shape (3,)
            Tip position [m]; finite, each coordinate within 10 km.
        axis : array, shape (3,)
            Tool axis (tip to spindle); normalised here.
        line : int
            1-based source line.
        rapid : bool
            Whether the move that ends here is a rapid.
        feed_mm_per_min, rpm : float
            Programmed feed [mm/min] and speed [rpm]; NaN when none.
        ref : array, shape (3,), optional
            TCP x axis where the path fixes it.
        """
        ax, ay, az = float(axis[0]), float(axis[1]), float(axis[2])
        n = math.sqrt(ax * ax + ay * ay + az * az)
        if not math.isfinite(n) or n < 1e-9:
            raise InputError(
                f"expected a non-zero tool axis, found {[ax, ay, az]}",
                source=f"{self.source}:{line}",
            )
        ax, ay, az = ax / n, ay / n, az / n
        if ref is not None:
            rx, ry, rz = float(ref[0]), float(ref[1]), float(ref[2])
            d = rx * ax + ry * ay + rz * az
            rx, ry, rz = rx - d * ax, ry - d * ay, rz - d * az
            rn = math.sqrt(rx * rx + ry * ry + rz * rz)
            if rn > 1e-9:
                self._ref.extend((len(self), rx / rn, ry / rn, rz / rn))
        self._rows.extend(
            (
                float(pos_m[0]),
                float(pos_m[1]),
                float(pos_m[2]),
                ax,
                ay,
                az,
                float(feed_mm_per_min),
                float(rpm),
                1.0 if rapid else 0.0,
                int(line),
            )
        )
        if len(self._rows) >= _BLOCK_ROWS * _WIDTH:
            self._blocks.append(self._rows)
            self._rows = array("d")

    def add_unit(
        self,
        pos_m: tuple[float, float, float],
        axis: tuple[float, float, float],
        line: int,
        rapid: bool,
        feed_mm_per_min: float,
        rpm: float,
    ) -> None:
        """:meth:`add` for a reader that already holds a unit tool axis and no TCP x axis.

        The per-line fast path of the G-code reader (no normalisation, no
        reference axis); positions are checked, vectorised, by :meth:`table`.
        """
        self._rows.extend(
            (pos_m[0], pos_m[1], pos_m[2], axis[0], axis[1], axis[2], feed_mm_per_min, rpm,
             1.0 if rapid else 0.0, line)
        )  # fmt: skip
        if len(self._rows) >= _BLOCK_ROWS * _WIDTH:
            self._blocks.append(self._rows)
            self._rows = array("d")

    def __len__(self) -> int:
        return len(self._blocks) * _BLOCK_ROWS + len(self._rows) // _WIDTH

    @property
    def last_position(self) -> FloatArray | None:
        """The last position [m], or None."""
        last = self._rows or (self._blocks[-1] if self._blocks else None)
        return np.array(last[-_WIDTH : -_WIDTH + 3]) if last else None

    def notes(self) -> list[str]:
        """The warnings, each once, with ``(n times)`` where it repeated."""
        out = []
        for item in self.warnings:
            k, text = item.split("\x00", 1)
            n = self._seen.get(k, 1)
            out.append(text + (f" ({n} times)" if n > 1 else ""))
        return out

    def table(self) -> pd.DataFrame:
        """The waypoint table (see the module docstring).

        Reader warnings are in ``df.attrs["warnings"]`` (list of str).

        Raises
        ------
        InputError
            When the file holds no move at all.
        """
        n = len(self)
        if n == 0:
            raise InputError("expected at least one move, found none", source=self.source)
        # handed over (the builder is empty now)
        blocks = [*self._blocks, self._rows] if self._rows else self._blocks
        self._blocks, self._rows = [], array("d")
        # the table's eight number columns, views of one block of their own, its line
        # numbers and whether each move is a rapid: filled block by block, each block
        # freed once copied, the freed ones given back every few blocks (a long program's
        # blocks and its table are not resident whole side by side)
        rows = np.empty((n, 8))
        line = np.empty(n, np.int64)
        rapid = np.empty(n, bool)
        at = 0
        for k in range(len(blocks)):
            flat = np.frombuffer(blocks[k], dtype=np.float64).reshape(-1, _WIDTH)
            blocks[k] = array("d")  # the block goes with ``flat``
            m = len(flat)
            rows[at : at + m] = flat[:, :8]
            line[at : at + m] = flat[:, 9]  # whole numbers: exact
            np.greater(flat[:, 8], 0, out=rapid[at : at + m])
            at += m
            del flat
            if k % _BLOCKS_PER_RELEASE == _BLOCKS_PER_RELEASE - 1:
                release_free_memory(n)
        del blocks
        pos = rows[:, 0:3]
        axis = rows[:, 3:6]
        bad = ~np.all(np.abs(pos) <= _MAX_POS_M, axis=1)
        if np.any(bad):
            r = int(np.argmax(bad))
            raise InputError(
                f"expected a finite position within {_MAX_POS_M * 1e3:g} mm, found "
                f"{(pos[r] * 1e3).tolist()} mm",
                source=f"{self.source}:{line[r]}",
            )
        if self._ref:
            ref = np.full((len(rows), 3), np.nan)
            rr = np.frombuffer(self._ref, dtype=np.float64).reshape(-1, 4)
            ref[rr[:, 0].astype(np.int64)] = rr[:, 1:]
            ox, oy, oz = ref[:, 0], ref[:, 1], ref[:, 2]
        else:  # free everywhere: one NaN array in the three columns (pandas copies on write)
            ox = oy = oz = np.full(len(rows), np.nan)
        f = feed_directions(pos, axis)
        df = pd.DataFrame(
            {
                "x_m": pos[:, 0],
                "y_m": pos[:, 1],
                "z_m": pos[:, 2],
                "i": axis[:, 0],
                "j": axis[:, 1],
                "k": axis[:, 2],
                "ox": ox,
                "oy": oy,
                "oz": oz,
                "fx": f[:, 0],
                "fy": f[:, 1],
                "fz": f[:, 2],
                "feed_mm_per_min": rows[:, 6],
                "rpm_programmed": rows[:, 7],
                "motion": label_column(rapid.view(np.int8), ("cut", "rapid")),
                "source": self.source,
                "line": line,
            },
            # the columns as they are: views of the rows read (80 bytes a waypoint, held by
            # the table) and of ``ref`` and ``f``, not consolidated into a block (a copy of
            # 14 columns: on a million-line program the reader's peak)
            copy=False,
        )
        df.attrs["warnings"] = self.notes()
        return df


def label_column(codes: NDArray[np.int8], names: tuple[str, ...]) -> Any:
    """A string column of a few distinct labels, ``names[codes]``, without a str per row.

    Where pandas stores strings in Arrow (its default with pyarrow) the column
    is made there by one take (11 bytes a row for "cut"/"rapid"); otherwise an
    object array whose equal entries share one ``str``. Either way the same
    values and dtype as ``np.asarray(names)[codes]`` given to pandas.

    Parameters
    ----------
    codes : ndarray of int8, shape (n,)
        Index into ``names`` of each row.
    names : tuple of str

    Returns
    -------
    pandas ExtensionArray or ndarray of object, shape (n,)
    """
    dtype = pd.Series(list(names)).dtype  # what pandas makes of these strings
    if isinstance(dtype, pd.StringDtype) and dtype.storage == "pyarrow":
        import pyarrow as pa

        taken = pa.array(list(names), type=pa.large_string()).take(pa.array(codes))
        return pd.array(taken, dtype=dtype)
    return np.asarray(list(names), dtype=object)[codes]


def _length3(dx: FloatArray, dy: FloatArray, dz: FloatArray) -> FloatArray:
    """``sqrt(dx^2 + dy^2 + dz^2)``, the squares summed x, y, z in that order:
    ``np.linalg.norm(d, axis=1)``'s values to the bit, a column at a time (no (n, 3)
    temporary). A new array."""
    acc = dx * dx
    sq = np.empty_like(acc)
    for c in (dy, dz):
        np.multiply(c, c, out=sq)
        acc += sq
    np.sqrt(acc, out=acc)
    return acc


def segment_lengths(pos: Any, rows: NDArray[np.int64] | None = None) -> FloatArray:
    """Length [m] of the move ending at each waypoint (0 for the first).

    Parameters
    ----------
    pos : ndarray, shape (n, 3), or DataFrame with ``x_m y_m z_m``
        Positions [m] (a table's columns are read as they are: no (n, 3) copy).
    rows : ndarray of int, optional
        Only these waypoints' moves.

    Returns
    -------
    ndarray, shape (n,) or (len(rows),)
        ``np.linalg.norm`` of each move's difference, to the bit.
    """
    if isinstance(pos, pd.DataFrame):
        cols = [pos[c].to_numpy(dtype=np.float64) for c in ("x_m", "y_m", "z_m")]
    else:
        cols = [pos[:, j] for j in range(3)]
    if rows is not None:
        prev = np.maximum(rows - 1, 0)  # row 0: its own position, length 0
        return _length3(*(c[rows] - c[prev] for c in cols))
    d = np.zeros(len(cols[0]))
    if len(d) > 1:
        d[1:] = _length3(*(c[1:] - c[:-1] for c in cols))
    return d


def feed_directions(pos: FloatArray, axis: FloatArray | None = None) -> FloatArray:
    """Unit feed direction of the move ending at each waypoint.

    Zero-length moves (and the first waypoint) take the direction of the
    next move that has a length, or failing that the previous one; a path
    that never moves gets NaN.

    Parameters
    ----------
    pos : ndarray, shape (n, 3)
        Positions [m].
    axis : ndarray, shape (n, 3), optional
        Unused; kept for symmetry with the table (directions are 3-D).

    Returns
    -------
    ndarray, shape (n, 3)
    """
    n = len(pos)
    out = np.full((n, 3), np.nan)
    if n < 2:
        return out
    # the moves' differences and unit directions made in ``out`` itself (no (n, 3)
    # temporaries: a long program's reader peak)
    d = out[1:]
    np.subtract(pos[1:], pos[:-1], out=d)
    ln = _length3(d[:, 0], d[:, 1], d[:, 2])
    ok = ln > 1e-12
    np.divide(d, ln[:, None], out=d, where=ok[:, None])
    d[~ok] = np.nan
    del d, ln
    has = np.r_[False, ok]
    del ok
    hr = np.flatnonzero(has)
    if not hr.size:
        return out
    # each row without a direction takes the next row's that has one, else the last one's
    # (only those rows are looked at: a long path has a few)
    miss = np.flatnonzero(~has)
    j = np.searchsorted(hr, miss)
    out[miss] = out[np.where(j < hr.size, hr[np.minimum(j, hr.size - 1)], hr[-1])]
    return out


def validate_waypoints(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """Check a waypoint table from outside (CSV/Parquet) and complete it.

    Required columns: ``x_m y_m z_m``. Optional: ``i j k`` (default: +z),
    ``ox oy oz``, ``fx fy fz`` (recomputed when absent), ``feed_mm_per_min``,
    ``rpm_programmed``, ``motion`` (default ``"cut"``), ``source``, ``line``
    (default: the file's data line, header = line 1).

    Raises
    ------
    InputError
        Missing columns, non-numeric or non-finite values (naming the line),
        unknown ``motion`` values, zero tool axes.
    """
    missing = [c for c in ("x_m", "y_m", "z_m") if c not in df.columns]
    if missing:
        raise InputError(
            f"expected columns x_m, y_m, z_m, found {list(df.columns)} (missing {missing})",
            source=source,
        )
    if len(df) == 0:
        raise InputError("expected at least one waypoint, found none", source=source)
    n = len(df)
    file_line = np.arange(n, dtype=np.int64) + 2  # header is line 1

    def numeric(col: str, default: float | None) -> FloatArray:
        if col not in df.columns:
            return np.full(n, np.nan if default is None else default)
        vals = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=np.float64)
        bad = np.isnan(vals) & df[col].notna().to_numpy()
        if np.any(bad):
            r = int(np.argmax(bad))
            raise InputError(
                f"column {col}: expected a number, found {df[col].iloc[r]!r}",
                source=f"{source}:{file_line[r]}",
            )
        return vals

    def rate(col: str, cap: float, unit: str) -> FloatArray:
        """A programmed rate: absent (NaN) or within (0, cap] (a negative feed is no feed)."""
        vals = numeric(col, np.nan)
        bad = ~np.isnan(vals) & ~((vals > 0) & (vals <= cap))
        if np.any(bad):
            r = int(np.argmax(bad))
            raise InputError(
                f"column {col}: expected a rate > 0 and <= {cap:g} {unit} (or empty), "
                f"found {vals[r]:g}",
                source=f"{source}:{file_line[r]}",
            )
        return vals

    pos = np.stack([numeric(c, None) for c in ("x_m", "y_m", "z_m")], 1)
    bad_rows = ~np.all(np.isfinite(pos), axis=1)
    if np.any(bad_rows):
        r = int(np.argmax(bad_rows))
        raise InputError(
            f"expected finite x_m, y_m, z_m, found {pos[r].tolist()}",
            source=f"{source}:{file_line[r]}",
        )
    has_axis = all(c in df.columns for c in ("i", "j", "k"))
    if has_axis:
        axis = np.stack([numeric(c, None) for c in ("i", "j", "k")], 1)
    else:
        axis = np.tile([0.0, 0.0, 1.0], (n, 1))
    norm = np.linalg.norm(axis, axis=1)
    bad_rows = ~(np.isfinite(norm) & (norm > 1e-9))
    if np.any(bad_rows):
        r = int(np.argmax(bad_rows))
        raise InputError(
            f"expected a non-zero tool axis i, j, k, found {axis[r].tolist()}",
            source=f"{source}:{file_line[r]}",
        )
    axis = axis / norm[:, None]
    ref = np.stack([numeric(c, np.nan) for c in ("ox", "oy", "oz")], 1)
    ref = ref - np.sum(ref * axis, 1, keepdims=True) * axis
    rn = np.linalg.norm(ref, axis=1)
    ok = np.isfinite(rn) & (rn > 1e-9)
    ref = np.where(ok[:, None], ref / np.where(ok, rn, 1.0)[:, None], np.nan)
    if "motion" in df.columns:
        motion = df["motion"].astype(str).str.strip().str.lower().to_numpy()
        bad = ~np.isin(motion, ["cut", "rapid"])
        if np.any(bad):
            r = int(np.argmax(bad))
            raise InputError(
                f"column motion: expected 'cut' or 'rapid', found {df['motion'].iloc[r]!r}",
                source=f"{source}:{file_line[r]}",
            )
    else:
        motion = np.full(n, "cut")
    f = feed_directions(pos, axis)
    if all(c in df.columns for c in ("fx", "fy", "fz")):
        given = np.stack([numeric(c, np.nan) for c in ("fx", "fy", "fz")], 1)
        gn = np.linalg.norm(given, axis=1)
        okg = np.isfinite(gn) & (gn > 1e-9)
        f = np.where(okg[:, None], given / np.where(okg, gn, 1.0)[:, None], f)
    src = df["source"].astype(str).to_numpy() if "source" in df.columns else np.full(n, source)
    if "line" in df.columns:
        given_line = numeric("line", None)
        line = np.where(np.isfinite(given_line), given_line, file_line).astype(np.int64)
    else:
        line = file_line
    return pd.DataFrame(
        {
            "x_m": pos[:, 0],
            "y_m": pos[:, 1],
            "z_m": pos[:, 2],
            "i": axis[:, 0],
            "j": axis[:, 1],
            "k": axis[:, 2],
            "ox": ref[:, 0],
            "oy": ref[:, 1],
            "oz": ref[:, 2],
            "fx": f[:, 0],
            "fy": f[:, 1],
            "fz": f[:, 2],
            "feed_mm_per_min": rate("feed_mm_per_min", 1e6, "mm/min"),
            "rpm_programmed": rate("rpm_programmed", 1e6, "rpm"),
            "motion": motion,
            "source": src,
            "line": line,
        }
    )


def program_table(edit: ProgramEdit) -> str:
    """A waypoint table (CSV text) with the plan's rpm and feed per move, passes included.

    The columns of :data:`COLUMNS`; ``rpm_programmed`` and
    ``feed_mm_per_min`` hold the new values on cutting moves (the spindle
    speed of the move before on rapids); every number at full precision.
    """
    exp = expected_table(edit)
    pos = exp[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=np.float64) * 1e-3
    ax = exp[["i", "j", "k"]].to_numpy(dtype=np.float64)
    rpm = pd.Series(exp["rpm"].to_numpy()).ffill().to_numpy()
    df = pd.DataFrame(
        {
            "x_m": pos[:, 0],
            "y_m": pos[:, 1],
            "z_m": pos[:, 2],
            "i": ax[:, 0],
            "j": ax[:, 1],
            "k": ax[:, 2],
            "ox": exp["ox"].to_numpy(),
            "oy": exp["oy"].to_numpy(),
            "oz": exp["oz"].to_numpy(),
            "feed_mm_per_min": exp["feed_mm_per_min"].to_numpy(),
            "rpm_programmed": rpm,
            "motion": exp["motion"].to_numpy(),
            "source": exp["source"].to_numpy(),
            "line": exp["line"].to_numpy(),
        }
    )
    return str(df.to_csv(index=False, float_format="%.17g"))
