"""What every toolpath reader does to a file before it parses it, and to its numbers.

- :func:`read_text`: one decoding rule for every reader (UTF-8 with or
  without a byte-order mark, else Latin-1), binary files refused, line
  endings ``\\r\\n``, ``\\r`` and ``\\n`` all accepted (also mixed in one file).
- :func:`lines`: the lines of a text, numbered as an editor numbers them
  (``str.splitlines`` would also split at form feeds and ``\\x85``).
- :func:`finite`: a number from a file, refusing ``nan``/``inf`` and values
  beyond :data:`MAX_ABS` (a coordinate of 1e300 mm is a corrupt file, not a
  path).
- :data:`UNIT_CHOICES`, :data:`TOOL_DIRECTIONS`, :func:`check_choice`: the
  reader options shared by several readers.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = [
    "MAX_ABS",
    "TOOL_DIRECTIONS",
    "TRUNCATED",
    "UNIT_CHOICES",
    "check_choice",
    "finite",
    "iter_lines",
    "lines",
    "read_text",
    "strip_bom",
    "tool_axes",
]

#: Words of every reader's warning that a program has no end (END, FINI, M30, ...): read
#: tolerantly, such a program is refused when written back (a controller rejects it).
TRUNCATED = "the file may be truncated"

#: Largest magnitude accepted for any number in a toolpath (mm, deg, mm/min, rpm).
MAX_ABS = 1e7

#: ``units`` option: ``auto`` (the file's own statement, else detected with a warning).
UNIT_CHOICES = ("auto", "mm", "inch")

#: ``tool_direction`` option of the robot readers: the tool-frame axis along
#: the working direction (spindle to tip).
TOOL_DIRECTIONS = ("z", "x")


def check_choice(name: str, value: object, choices: tuple[str, ...]) -> str:
    """``value`` if it is one of ``choices``, else an :class:`InputError` naming ``name``."""
    if not isinstance(value, str) or value not in choices:
        raise InputError(f"{name}: expected one of {list(choices)}, found {value!r}")
    return value


def strip_bom(text: str) -> str:
    """``text`` without a leading UTF-8 byte-order mark."""
    return text[1:] if text.startswith("\ufeff") else text


def read_text(path: str | Path) -> str:
    """The text of a toolpath file (a trailing DOS end-of-file mark ``^Z`` dropped).

    Raises
    ------
    InputError
        Unreadable, empty or binary file (NUL bytes or mostly control
        characters in the first 64 KiB).
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc}", source=str(p)) from None
    if not data.strip():
        raise InputError("expected a toolpath, found an empty file", source=p.name)
    head = data[:65536]
    ctrl = sum(1 for b in head if b < 32 and b not in (9, 10, 12, 13, 26))
    if b"\x00" in head or ctrl > 0.05 * len(head):
        raise InputError(
            "expected a text toolpath, found a binary file (NUL or control bytes)", source=p.name
        )
    data = data.rstrip(b"\x1a")  # DOS end-of-file mark of old NC files
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("latin-1")
    return text


def lines(text: str) -> list[str]:
    """Lines of ``text`` split at ``\\r\\n``, ``\\r`` or ``\\n`` only (BOM removed)."""
    t = strip_bom(text)
    if "\r" in t:
        t = t.replace("\r\n", "\n").replace("\r", "\n")
    out = t.split("\n")
    if out and out[-1] == "":
        out.pop()
    return out


def iter_lines(text: str) -> Iterator[str]:
    """The lines of :func:`lines`, one at a time (a million-line program never as one list)."""
    t = strip_bom(text)
    if "\r" in t:
        t = t.replace("\r\n", "\n").replace("\r", "\n")
    start = 0
    n = len(t)
    while start < n:
        end = t.find("\n", start)
        if end < 0:
            yield t[start:]
            return
        yield t[start:end]
        start = end + 1


def finite(text: str, where: str, what: str) -> float:
    """Parse a number; refuse non-numbers, ``nan``, ``inf`` and ``|v| > MAX_ABS``."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        raise InputError(f"{what}: expected a number, found {text!r}", source=where) from None
    if not math.isfinite(v) or abs(v) > MAX_ABS:
        raise InputError(
            f"{what}: expected a finite number of magnitude at most {MAX_ABS:g}, found {text!r}",
            source=where,
        )
    return v


def tool_axes(
    rot: NDArray[np.float64], tool_direction: str
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Tool axis (tip to spindle) and TCP x axis from a tool frame's rotation.

    Parameters
    ----------
    rot : ndarray, shape (..., 3, 3)
        Tool frame(s) in the path frame (columns: x, y, z axes).
    tool_direction : {"z", "x"}
        Tool-frame axis along the working direction (spindle to tip): ``z``
        (ABB, RoboDK and most offline programming) or ``x`` (KUKA's factory
        ``$TOOL_DIRECTION``).

    Returns
    -------
    axis, ref : ndarray, shape (..., 3)
        ``-working`` and the next tool-frame axis (``x`` for ``z``, ``y``
        for ``x``), so the TCP z axis is the working direction.
    """
    if tool_direction == "x":
        work, ref = rot[..., :, 0], rot[..., :, 1]
    else:
        work, ref = rot[..., :, 2], rot[..., :, 0]
    return -work, ref
