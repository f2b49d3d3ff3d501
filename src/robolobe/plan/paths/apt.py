"""APT / CL data reader (CATIA, NX, Mastercam APT-source style).

Statements are ``WORD/arg, arg, ...`` or a bare ``WORD``; ``$`` at the end of
a line continues the statement on the next line, ``$$`` starts a comment.
Numbers may carry spaces around them (``GOTO  /  -12.5000,  30.0000, 5.0``).

Supported: ``GOTO/x,y,z[,i,j,k]`` (tool axis tip to spindle), ``FROM/``,
``GODLTA/dx,dy,dz`` (or ``GODLTA/d`` along the tool axis), ``RAPID`` (the
next move only), ``FEDRAT/f[,MMPM|IPM|MMPR|IPR]`` (also ``FEDRAT/MMPM,f``),
``SPINDL/[RPM,]s[,CLW|CCLW]`` and ``SPINDL/OFF|ON``, ``UNITS/MM|INCHES``,
``MULTAX[/ON|OFF]``, ``TLAXIS/i,j,k``, ``CIRCLE/cx,cy,cz,ax,ay,az,r,...``
followed by the ``GOTO`` that ends the arc (counter-clockwise about the
given axis, the NX/CATIA convention), ``MSYS/x,y,z,xi,xj,xk,yi,yj,yk`` (the
points are given in that system; it is applied), ``CUTCOM/OFF``, ``CYCLE/OFF``.

Ignored on purpose (no effect on the geometry): PARTNO, MACHIN, CUTTER,
LOADTL, TLDATA, TOOL PATH, END-OF-PATH, COOLNT, PPRINT, TPRINT, INSERT,
CLEARP, OPSKIP, OPSTOP, STOP, END, FINI, INTOL, OUTTOL, TOLER, DISPLY,
SELECT, PAINT, SEQNO, AUXFUN, PREFUN, DELAY, HEAD, MODE, GOHOME, OPNAME,
OPERATION, TOOLNO, TURRET, RETRCT, THICK, LINTOL, NOPS, CATIA0, PITCH,
PROFIL.

Anything else (CUTCOM/ON, cycles, CALSUB, INDIRV/TLON/GOFWD surface
motion, unknown words) raises :class:`~robolobe.errors.InputError` with
``file:line``.
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_points
from robolobe.plan.paths._table import WaypointBuilder

__all__ = ["parse_apt", "read_apt"]

logger = logging.getLogger(__name__)

_IGNORED = {
    "PARTNO", "MACHIN", "CUTTER", "LOADTL", "TLDATA", "TOOL PATH", "END-OF-PATH", "COOLNT",
    "PPRINT", "TPRINT", "INSERT", "CLEARP", "OPSKIP", "OPSTOP", "STOP", "END", "FINI",
    "INTOL", "OUTTOL", "TOLER", "DISPLY", "SELECT", "PAINT", "SEQNO", "AUXFUN", "PREFUN",
    "DELAY", "HEAD", "MODE", "GOHOME", "OPNAME", "OPERATION", "TOOLNO", "TURRET", "RETRCT",
    "THICK", "LINTOL", "NOPS", "CATIA0", "PITCH", "PROFIL",
}  # fmt: skip
_MINOR = {"MMPM", "IPM", "MMPR", "IPR", "RPM", "SFM", "SMM", "CLW", "CCLW", "ON", "OFF"}
_STMT = re.compile(r"^\s*([A-Z][A-Z0-9 _\-]*?)\s*(?:/(.*))?$")


def _statements(text: str) -> list[tuple[int, str]]:
    """Join continuation lines, drop comments; (first line, statement)."""
    out: list[tuple[int, str]] = []
    buf: list[str] = []
    start = 0
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.rstrip()
        cut = line.find("$$")
        if cut >= 0:
            line = line[:cut]
        line = line.strip()
        if not buf:
            start = lineno
        if line.endswith("$"):
            buf.append(line[:-1])
            continue
        buf.append(line)
        stmt = " ".join(b.strip() for b in buf).strip()
        buf = []
        if stmt:
            out.append((start, stmt))
    if buf and " ".join(buf).strip():
        out.append((start, " ".join(buf).strip()))
    return out


def _numbers(args: list[str], where: str, word: str) -> list[float]:
    vals = []
    for a in args:
        try:
            vals.append(float(a))
        except ValueError:
            raise InputError(f"{word}: expected numbers, found {a!r}", source=where) from None
    return vals


def parse_apt(
    text: str, source: str = "<apt>", *, arc_tol_mm: float = 0.01, default_units: str = "mm"
) -> pd.DataFrame:
    """Read APT/CL text into the waypoint table.

    Parameters
    ----------
    text : str
        CL data.
    source : str
        File name for the ``source`` column and messages.
    arc_tol_mm : float
        Chord tolerance of linearised arcs [mm].
    default_units : {"mm", "inch"}
        Units before any ``UNITS`` statement.

    Returns
    -------
    pandas.DataFrame
        The waypoint table.

    Raises
    ------
    InputError
        Unsupported or malformed statements, naming ``source:line``.
    """
    scale = 1.0 if default_units == "mm" else 25.4
    feed = math.nan
    feed_per_rev = False
    rpm = math.nan
    spindle_on = False
    rapid_next = False
    pos: np.ndarray | None = None
    axis = np.array([0.0, 0.0, 1.0])
    circle: tuple[np.ndarray, np.ndarray, int] | None = None
    msys_r = np.eye(3)
    msys_o = np.zeros(3)
    out = WaypointBuilder(source)

    def feed_now() -> float:
        if math.isnan(feed):
            return math.nan
        if feed_per_rev:
            return feed * scale * rpm if spindle_on and not math.isnan(rpm) else math.nan
        return feed * scale

    for lineno, stmt in _statements(text):
        where = f"{source}:{lineno}"
        up = stmt.upper()
        head = re.split(r"[\s/]", up, maxsplit=1)[0]
        if head in _IGNORED or up.startswith(("TOOL PATH", "END-OF-PATH")):
            continue
        m = _STMT.match(up)
        if not m:
            raise InputError(f"expected an APT statement WORD/args, found {stmt!r}", source=where)
        word = m.group(1).strip()
        args = [a.strip() for a in (m.group(2) or "").split(",")] if m.group(2) is not None else []
        args = [a for a in args if a != ""]
        if word == "UNITS":
            if not args or args[0] not in ("MM", "INCHES", "INCH"):
                raise InputError(f"UNITS: expected MM or INCHES, found {args}", source=where)
            scale = 1.0 if args[0] == "MM" else 25.4
        elif word == "MULTAX":
            continue
        elif word == "RAPID":
            rapid_next = True
        elif word == "FEDRAT":
            mode = [a for a in args if a in _MINOR]
            nums = _numbers([a for a in args if a not in _MINOR], where, "FEDRAT")
            if len(nums) != 1:
                raise InputError(f"FEDRAT: expected one feed value, found {args}", source=where)
            feed = nums[0]
            feed_per_rev = bool(mode) and mode[0] in ("MMPR", "IPR")
        elif word == "SPINDL":
            if args and args[0] == "OFF":
                spindle_on = False
                continue
            if args and args[0] == "ON":
                spindle_on = True
                continue
            nums = _numbers([a for a in args if a not in _MINOR], where, "SPINDL")
            if len(nums) < 1:
                raise InputError(f"SPINDL: expected a speed, found {args}", source=where)
            if any(a in ("SFM", "SMM") for a in args):
                raise InputError("SPINDL: surface speed (SFM/SMM) is not supported", where)
            rpm = nums[0]
            spindle_on = True
        elif word == "TLAXIS":
            tv = np.array(_numbers(args, where, "TLAXIS")[:3])
            if tv.size != 3 or np.linalg.norm(tv) < 1e-9:
                raise InputError(f"TLAXIS: expected i,j,k, found {args}", source=where)
            axis = msys_r @ (tv / np.linalg.norm(tv))
        elif word == "MSYS":
            v = _numbers(args, where, "MSYS")
            if len(v) != 9:
                raise InputError(f"MSYS: expected 9 numbers, found {len(v)}", source=where)
            xa, ya = np.array(v[3:6]), np.array(v[6:9])
            if (
                abs(np.linalg.norm(xa) - 1) > 1e-3
                or abs(np.linalg.norm(ya) - 1) > 1e-3
                or abs(xa @ ya) > 1e-3
            ):
                raise InputError("MSYS: expected unit, orthogonal x and y axes", source=where)
            msys_r = np.column_stack([xa, ya, np.cross(xa, ya)])
            msys_o = np.array(v[:3])
        elif word in ("CUTCOM", "CYCLE"):
            if args and args[0] == "OFF":
                continue
            raise InputError(f"unsupported construct: {word}/{','.join(args)}", source=where)
        elif word == "CIRCLE":
            v = _numbers(args, where, "CIRCLE")
            if len(v) < 7:
                raise InputError(f"CIRCLE: expected at least 7 numbers, found {len(v)}", where)
            c = msys_r @ np.array(v[:3]) + msys_o
            n = msys_r @ np.array(v[3:6])
            if np.linalg.norm(n) < 1e-9:
                raise InputError("CIRCLE: zero axis vector", source=where)
            circle = (c * scale, n / np.linalg.norm(n), lineno)
        elif word in ("GOTO", "FROM", "GODLTA"):
            v = _numbers(args, where, word)
            if word == "GODLTA":
                if pos is None:
                    raise InputError("GODLTA before any position", source=where)
                if len(v) == 1:
                    target = pos + axis * v[0] * scale
                elif len(v) == 3:
                    target = pos + msys_r @ np.array(v) * scale
                else:
                    raise InputError(f"GODLTA: expected 1 or 3 numbers, found {len(v)}", where)
                new_axis = axis
            else:
                if len(v) not in (3, 6):
                    raise InputError(
                        f"{word}: expected x,y,z[,i,j,k], found {len(v)} numbers", where
                    )
                target = (msys_r @ np.array(v[:3]) + msys_o) * scale
                new_axis = axis
                if len(v) == 6:
                    a = msys_r @ np.array(v[3:6])
                    if np.linalg.norm(a) < 1e-9:
                        raise InputError(f"{word}: zero tool axis vector", source=where)
                    new_axis = a / np.linalg.norm(a)
            is_rapid = rapid_next or word == "FROM"
            rapid_next = False
            f = math.nan if is_rapid else feed_now()
            s = rpm if spindle_on else math.nan
            if circle is not None and pos is not None and not is_rapid:
                centre, nrm, _ = circle
                pts = arc_points(
                    pos, target, centre, nrm, clockwise=False, tol=arc_tol_mm, where=where
                )
                for p in pts:
                    out.add(p * 1e-3, new_axis, line=lineno, rapid=False, feed_mm_per_min=f, rpm=s)
            else:
                out.add(
                    target * 1e-3, new_axis, line=lineno, rapid=is_rapid, feed_mm_per_min=f, rpm=s
                )
            circle = None
            pos = target
            axis = new_axis
        elif word in (
            "INDIRV",
            "TLON",
            "GOFWD",
            "GOLFT",
            "GORGT",
            "GOBACK",
            "GOUP",
            "GODOWN",
            "PSIS",
        ):
            raise InputError(
                f"unsupported construct: surface motion {word} (output CL points with GOTO)", where
            )
        elif word == "CALSUB":
            raise InputError("unsupported construct: subroutine call CALSUB", source=where)
        else:
            raise InputError(f"unsupported APT statement {word!r}", source=where)
    return out.table()


def read_apt(path: str | Path, **options: float | str) -> pd.DataFrame:
    """Read an APT/CL file (see :func:`parse_apt` for ``options``)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        text = p.read_text(encoding="latin-1")
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc}", source=str(p)) from None
    return parse_apt(text, p.name, **options)  # type: ignore[arg-type]
