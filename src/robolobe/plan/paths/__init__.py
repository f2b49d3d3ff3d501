"""Toolpath readers: one waypoint table from G-code, APT/CL, KRL, RAPID, CSV or Parquet.

:func:`read_toolpath` picks the reader from the file extension (or the
content when the extension says nothing) and returns the waypoint table
documented in :mod:`robolobe.plan.paths._table` (:data:`COLUMNS`).

==========  =========================================================
format      extensions
==========  =========================================================
``table``   .csv, .parquet, .pq
``gcode``   .nc, .ngc, .gcode, .tap, .cnc, .mpf, .spf, .iso, .eia, .ptp
``apt``     .apt, .cl, .cls, .clsf, .aptsource, .clt
``krl``     .src, .dat
``rapid``   .mod, .modx, .prg, .sys
==========  =========================================================
"""

from __future__ import annotations

import inspect
import os
import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pandas as pd

from robolobe._atomic import not_a_file
from robolobe.errors import InputError
from robolobe.plan.paths._table import (
    COLUMNS,
    feed_directions,
    segment_lengths,
    validate_waypoints,
)
from robolobe.plan.paths.apt import parse_apt, read_apt
from robolobe.plan.paths.gcode import parse_gcode, read_gcode
from robolobe.plan.paths.krl import parse_krl, read_krl
from robolobe.plan.paths.rapid import parse_rapid, read_rapid

__all__ = [
    "COLUMNS",
    "FORMATS",
    "READER_OPTIONS",
    "detect_format",
    "feed_directions",
    "parse_apt",
    "parse_gcode",
    "parse_krl",
    "parse_rapid",
    "read_apt",
    "read_gcode",
    "read_krl",
    "read_rapid",
    "read_table",
    "read_toolpath",
    "reader_options",
    "segment_lengths",
    "validate_waypoints",
    "write_table",
]

FORMATS: dict[str, tuple[str, ...]] = {
    "table": (".csv", ".parquet", ".pq"),
    "gcode": (".nc", ".ngc", ".gcode", ".tap", ".cnc", ".mpf", ".spf", ".iso", ".eia", ".ptp"),
    "apt": (".apt", ".cl", ".cls", ".clsf", ".aptsource", ".clt"),
    "krl": (".src", ".dat"),
    "rapid": (".mod", ".modx", ".prg", ".sys"),
}


def detect_format(path: str | os.PathLike[str]) -> str:
    """The reader for ``path``: from the extension, else from the first lines.

    Raises
    ------
    InputError
        When neither says which format the file is.
    """
    p = Path(path)
    ext = p.suffix.lower()
    for fmt, exts in FORMATS.items():
        if ext in exts:
            return fmt
    try:
        with p.open("r", encoding="utf-8", errors="replace") as fh:
            head = fh.read(20000).upper()
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc}", source=str(p)) from None
    if "GOTO/" in head.replace(" ", "") or "FEDRAT" in head:
        return "apt"
    if "MOVEL" in head or "MODULE " in head:
        return "rapid"
    if "DEF " in head and ("LIN " in head or "PTP " in head):
        return "krl"
    if "X_M" in head.split("\n", 1)[0]:
        return "table"
    if re.search(r"\bG0*[0-3]\b|\bG0*[0-3](?=[A-Z])", head):
        return "gcode"
    raise InputError(
        f"cannot tell the toolpath format from the extension {ext!r} or the content; "
        f"expected one of {', '.join(e for v in FORMATS.values() for e in v)}",
        source=str(p),
    )


def read_table(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a waypoint table from CSV or Parquet (see :func:`validate_waypoints`)."""
    p = Path(path)
    try:
        if p.suffix.lower() in (".parquet", ".pq"):
            df = pd.read_parquet(p)
        else:
            df = pd.read_csv(p, comment="#", skipinitialspace=True, encoding="utf-8-sig")
    except (OSError, ValueError, ImportError) as exc:
        raise InputError(f"cannot read the table: {exc}", source=p.name) from None
    return validate_waypoints(df, p.name)


def write_table(df: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write a waypoint table atomically as CSV or Parquet (by the extension)."""
    from robolobe._atomic import atomic_path

    p = Path(path)
    with atomic_path(p) as tmp:
        if p.suffix.lower() in (".parquet", ".pq"):
            df.to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)
    return p


#: Reader options a job file (``[path]``) or the CLI may set, with their choices
#: (None: a number). Each reader takes those that apply to it (:func:`reader_options`).
READER_OPTIONS: dict[str, tuple[str, ...] | None] = {
    "units": ("auto", "mm", "inch"),
    "tool_direction": ("z", "x"),
    "coordinates": ("workpiece", "machine"),
    "rotary_axes": ("auto", "head", "table"),
    "circle_axis": ("auto", "cw", "ccw"),
    "arc_tol_mm": None,
    "cutter_radius_mm": None,
    "arc_centres": ("incremental", "absolute"),
}


def reader_options(fmt: str, options: dict[str, Any]) -> dict[str, Any]:
    """The subset of ``options`` that the ``fmt`` reader takes (others do not apply to it)."""
    if fmt == "table":
        return {}
    return {k: v for k, v in options.items() if k in _reader_keywords(fmt)}


# format -> (file reader, text parser whose keyword-only parameters are the options)
_READERS: dict[str, tuple[Callable[..., pd.DataFrame], Callable[..., pd.DataFrame]]] = {
    "gcode": (read_gcode, parse_gcode),
    "apt": (read_apt, parse_apt),
    "krl": (read_krl, parse_krl),
    "rapid": (read_rapid, parse_rapid),
}


def _reader_keywords(fmt: str) -> set[str]:
    if fmt not in _READERS:
        raise InputError(f"expected a format in {sorted([*_READERS, 'table'])}, found {fmt!r}")
    return {
        name
        for name, par in inspect.signature(_READERS[fmt][1]).parameters.items()
        if par.kind is inspect.Parameter.KEYWORD_ONLY and name != "dat"
    }


def read_toolpath(
    path: str | os.PathLike[str],
    fmt: str | None = None,
    *,
    applicable_only: bool = False,
    **options: Any,
) -> pd.DataFrame:
    """Read any supported toolpath into the waypoint table.

    Parameters
    ----------
    path : path-like
        The toolpath file.
    fmt : {"table", "gcode", "apt", "krl", "rapid"}, optional
        Force a reader; default: :func:`detect_format`.
    applicable_only : bool
        Drop the options the reader does not take (a job's ``[path]`` options
        serve every format) instead of refusing them.
    **options
        Passed to the reader (:data:`READER_OPTIONS`, ``block_delete``,
        ``no_decimal_scale``).

    Returns
    -------
    pandas.DataFrame
        Columns :data:`COLUMNS`.

    Raises
    ------
    InputError
        Missing file, unknown format, or a problem in the file (``file:line``).
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"expected a toolpath file, found {not_a_file(p)}", source=str(p))
    fmt = fmt or detect_format(p)
    if applicable_only:
        options = reader_options(fmt, options)
    if fmt == "table":
        if options:
            raise InputError(f"the table reader takes no options, found {sorted(options)}")
        return read_table(p)
    known = _reader_keywords(fmt)
    unknown = sorted(set(options) - known)
    if unknown:
        raise InputError(
            f"the {fmt} reader options are {sorted(known)}, found {unknown}", source=p.name
        )
    return _READERS[fmt][0](p, **options)
