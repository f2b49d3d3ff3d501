"""APT / CL data reader (CATIA, NX, Mastercam APT-source style).

Statements are ``WORD/arg, arg, ...`` or a bare ``WORD``; ``$`` at the end of
a line continues the statement on the next line, ``$$`` starts a comment.
Numbers may carry spaces around them (``GOTO  /  -12.5000,  30.0000, 5.0``).

Supported: ``GOTO/x,y,z[,i,j,k]`` (tool axis tip to spindle), ``FROM/``,
``GODLTA/dx,dy,dz`` (or ``GODLTA/d`` along the tool axis), ``RAPID`` (the
next move only), ``FEDRAT/f[,MMPM|IPM|MMPR|IPR]`` (also ``FEDRAT/IPM,f``;
the unit word wins over the coordinate units), ``SPINDL/[RPM,]s[,CLW|CCLW]``
and ``SPINDL/OFF|ON``, ``UNITS/MM|INCHES`` (without it: reader option
``units``, detected with a warning), ``MULTAX[/ON|OFF]``, ``TLAXIS/i,j,k``,
``CIRCLE/cx,cy,cz,i,j,k,r,...[,TIMES,n]`` followed by the ``GOTO`` that
ends the arc: clockwise about ``i,j,k`` as Siemens NX documents it (reader
option ``circle_axis``), ``TIMES,n`` adds ``n`` full turns (NX helices);
``MSYS/x,y,z,xi,xj,xk,yi,yj,yk`` (applied only with ``coordinates =
"machine"``; by default the points stay in the MCS as written),
``LOAD/TOOL`` (tool change), ``CUTCOM/LEFT|RIGHT`` on data marked ``$$
centerline data`` (warned: the points are the tool centre), ``CUTCOM/OFF``,
``CYCLE/OFF``. ``FINI`` or ``END-OF-PATH`` ends the data; without either a
truncation warning is given.

Ignored on purpose (no effect on the geometry): PARTNO, MACHIN, CUTTER,
LOADTL, TLDATA, TOOL PATH, COOLNT, PPRINT, TPRINT, INSERT, CLEARP, OPSKIP,
OPSTOP, STOP, INTOL, OUTTOL, TOLER, DISPLY, SELECT, PAINT, SEQNO, AUXFUN,
PREFUN, DELAY, HEAD, MODE, GOHOME, OPNAME, OPERATION, TOOLNO, TURRET,
RETRCT, THICK, LINTOL, NOPS, CATIA0, PITCH, PROFIL.

Refused with :class:`~robolobe.errors.InputError` naming ``file:line`` and
the construct: ``NURBS``/``KNOT``/``CNTRL`` spline motion, ``CUTCOM`` on
contact data, cycles, ``CALSUB``, ``INDIRV``/``TLON``/``GOFWD`` surface
motion, non-positive feeds, negative spindle speeds, a feed move while a
``SPINDL`` at 0 rpm is in force (``SPINDL/0`` starts the spindle at no
speed; rapids and ``SPINDL/OFF`` moves read as no programmed speed),
non-finite numbers, unknown words.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_points, arc_start_tangent
from robolobe.plan.paths._edit import (
    ProgramEdit,
    Section,
    cl_records,
    fmt_num,
    line_values,
    pass_layout,
    sections,
)
from robolobe.plan.paths._table import WaypointBuilder
from robolobe.plan.paths._text import (
    TRUNCATED,
    UNIT_CHOICES,
    check_choice,
    finite,
    iter_lines,
    lines,
    read_text,
)

__all__ = ["apt_setup", "parse_apt", "read_apt", "translate_apt", "write_apt"]

logger = logging.getLogger(__name__)

_IGNORED = {
    "PARTNO", "MACHIN", "CUTTER", "LOADTL", "TLDATA", "TOOL PATH", "END-OF-PATH", "COOLNT",
    "PPRINT", "TPRINT", "INSERT", "CLEARP", "OPSKIP", "OPSTOP", "STOP",
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
    for lineno, raw in enumerate(iter_lines(text), start=1):
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
    return [finite(a, where, word) for a in args]


def _first_units(stmts: list[tuple[int, str]]) -> tuple[str | None, str | None]:
    """Units of a UNITS record before the first motion, and the first FEDRAT unit word."""
    units: str | None = None
    feed_word: str | None = None
    for _, stmt in stmts:
        up = stmt.upper().replace(" ", "")
        if up.startswith("UNITS/") and units is None:
            units = "mm" if up[6:].startswith("MM") else "inch"
        elif up.startswith("FEDRAT/") and feed_word is None:
            for w in ("IPM", "IPR", "MMPM", "MMPR"):
                if w in up.split("/", 1)[1].split(","):
                    feed_word = w
    return units, feed_word


def parse_apt(
    text: str,
    source: str = "<apt>",
    *,
    arc_tol_mm: float = 0.01,
    units: str = "auto",
    circle_axis: str = "auto",
    coordinates: str = "workpiece",
    _tally: dict[str, int] | None = None,
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
    units : {"auto", "mm", "inch"}
        Units of coordinates where the file has no ``UNITS`` record. ``auto``:
        inch when the feeds say ``IPM``/``IPR``, else mm; both with a warning
        (and one more when an mm read looks like inch data: extents within
        one inch cube and feeds below 100 mm/min).
    circle_axis : {"auto", "cw", "ccw"}
        Sense of ``CIRCLE`` arcs about their axis ``i,j,k``: ``cw`` (Siemens
        NX documentation: the axis "assuming a clockwise direction") or
        ``ccw`` (CATIA and other APT posts). CAM systems disagree, so
        ``auto`` (default) reads the file both ways and keeps the sense in
        which arcs leave their start along the incoming move (a toolpath is
        tangent there; the other sense turns back by ~180 deg); the choice
        is stated as a reader warning. Where no arc follows a lateral move
        ``auto`` cannot tell, takes ``cw`` and says so. With ``cw``/``ccw``
        a warning names the arcs that leave their start against the incoming
        move (the other convention's signature).
    coordinates : {"workpiece", "machine"}
        ``workpiece``: points as written (NX writes them in the MCS, the
        part's program zero). ``machine``: ``MSYS`` applied, i.e. points in
        the CAM system's absolute frame.

    Returns
    -------
    pandas.DataFrame
        The waypoint table; reader warnings in ``attrs["warnings"]``.

    Raises
    ------
    InputError
        Unsupported or malformed statements, naming ``source:line``.
    """
    check_choice("units", units, UNIT_CHOICES)
    check_choice("circle_axis", circle_axis, ("auto", "cw", "ccw"))
    check_choice("coordinates", coordinates, ("workpiece", "machine"))
    if circle_axis == "auto":
        return _parse_auto_sense(
            text, source, arc_tol_mm=arc_tol_mm, units=units, coordinates=coordinates
        )
    out = WaypointBuilder(source)
    stmts = _statements(text)
    if not stmts:
        raise InputError("expected APT/CL statements, found none", source=source)
    file_units, feed_word = _first_units(stmts)
    inferred = ""
    if file_units is not None:
        unit0 = "mm"
    elif units != "auto":
        unit0 = units
    elif feed_word in ("IPM", "IPR"):
        unit0 = "inch"
        inferred = f"no UNITS record; FEDRAT/{feed_word} says inch: coordinates read as inch"
    elif feed_word in ("MMPM", "MMPR"):
        unit0 = "mm"  # the feeds say mm
    else:
        unit0 = "mm"
        inferred = "no UNITS record: coordinates read as mm"
    if inferred:
        out.warn(inferred + " (set the reader option units to override)")
    centreline = re.search(r"\$\$\s*CENTER\s*LINE\s+DATA", text, re.IGNORECASE) is not None
    scale = 1.0 if unit0 == "mm" else 25.4
    feed = math.nan  # mm/min or mm/rev
    feed_per_rev = False
    rpm = math.nan
    spindle_on = False
    rpm_zero = (0, "")  # (line, statement) of a SPINDL at 0 rpm in force (0: none)
    rapid_next = False
    pos: np.ndarray | None = None
    prev_dir: np.ndarray | None = None
    axis = np.array([0.0, 0.0, 1.0])
    circle: tuple[np.ndarray, np.ndarray, int, int] | None = None
    msys_r = np.eye(3)
    msys_o = np.zeros(3)
    ended = False
    max_feed = 0.0
    msys_seen: list[float] | None = None

    def feed_now() -> float:
        if math.isnan(feed):
            return math.nan
        if feed_per_rev:
            return feed * rpm if spindle_on and not math.isnan(rpm) else math.nan
        return feed

    for lineno, stmt in stmts:
        where = f"{source}:{lineno}"
        up = stmt.upper()
        head = re.split(r"[\s/]", up, maxsplit=1)[0]
        if head in ("FINI", "END") or up.startswith("END-OF-PATH"):
            ended = True
            continue
        if head in _IGNORED or up.startswith("TOOL PATH"):
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
        elif word == "LOAD":
            if args and args[0] == "TOOL":
                continue  # tool change: no effect on the path
            raise InputError(f"unsupported construct: LOAD/{','.join(args)}", source=where)
        elif word == "RAPID":
            rapid_next = True
        elif word == "FEDRAT":
            mode = [a for a in args if a in _MINOR]
            nums = _numbers([a for a in args if a not in _MINOR], where, "FEDRAT")
            if len(nums) != 1:
                raise InputError(f"FEDRAT: expected one feed value, found {args}", source=where)
            if nums[0] <= 0:
                raise InputError(f"FEDRAT: expected a positive feed, found {nums[0]:g}", where)
            unit = mode[0] if mode else ""
            per = {"IPM": 25.4, "IPR": 25.4, "MMPM": 1.0, "MMPR": 1.0}.get(unit, scale)
            feed = nums[0] * per
            feed_per_rev = unit in ("MMPR", "IPR")
            if not feed_per_rev:
                max_feed = max(max_feed, feed)
        elif word == "SPINDL":
            if args and args[0] == "OFF":
                spindle_on = False
                continue
            if args and args[0] == "ON":
                spindle_on = True
                continue
            if any(a in ("SFM", "SMM") for a in args):
                raise InputError("unsupported construct: SPINDL surface speed (SFM/SMM)", where)
            nums = _numbers([a for a in args if a not in _MINOR], where, "SPINDL")
            if len(nums) < 1:
                raise InputError(f"SPINDL: expected a speed, found {args}", source=where)
            if nums[0] < 0:
                raise InputError(
                    f"SPINDL: expected a speed >= 0 rpm (direction by CLW/CCLW), found {nums[0]:g}",
                    where,
                )
            rpm = nums[0] if nums[0] > 0 else math.nan
            spindle_on = True  # SPINDL with a speed starts the spindle, at 0 rpm too
            rpm_zero = (0, "") if nums[0] > 0 else (lineno, f"SPINDL/{','.join(args)}")
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
            if coordinates == "machine":
                msys_r = np.column_stack([xa, ya, np.cross(xa, ya)])
                msys_o = np.array(v[:3])
            elif msys_seen is not None and v != msys_seen and len(out):
                out.warn(
                    "MSYS changes between operations: their points are in different MCS "
                    "(set coordinates = 'machine' to place them in one frame)",
                    lineno,
                    key="msys-change",
                )
            msys_seen = v
        elif word == "CUTCOM":
            if args and args[0] == "OFF":
                continue
            if args and args[0] in ("LEFT", "RIGHT", "ON") and centreline:
                out.warn(
                    f"CUTCOM/{args[0]} on centre-line data: read as the tool centre "
                    "(compensation at the machine adds only wear offsets)",
                    lineno,
                    key=f"cutcom-{args[0]}",
                )
                continue
            raise InputError(
                f"unsupported construct: CUTCOM/{','.join(args)} on points that are not "
                "marked '$$ centerline data' (output tool centre-line CL data)",
                source=where,
            )
        elif word == "CYCLE":
            if args and args[0] == "OFF":
                continue
            raise InputError(f"unsupported construct: CYCLE/{','.join(args)}", source=where)
        elif word in ("NURBS", "KNOT", "CNTRL", "BSPLINE"):
            raise InputError(
                f"unsupported construct: {word} spline motion; regenerate the CL data with "
                "line/arc output (NX: Machine Control > Motion Output Type = Line/Arc)",
                source=where,
            )
        elif word == "CIRCLE":
            turns = 0
            if "TIMES" in args:
                k = args.index("TIMES")
                if k + 1 >= len(args):
                    raise InputError("CIRCLE: TIMES without a count", source=where)
                t = finite(args[k + 1], where, "CIRCLE TIMES")
                if t < 0 or t != int(t):
                    raise InputError(f"CIRCLE: TIMES expects a whole count, found {t:g}", where)
                turns = int(t)
                args = args[:k] + args[k + 2 :]
            v = _numbers(args, where, "CIRCLE")
            if len(v) < 7:
                raise InputError(f"CIRCLE: expected at least 7 numbers, found {len(v)}", where)
            c = msys_r @ np.array(v[:3]) + msys_o
            n = msys_r @ np.array(v[3:6])
            if np.linalg.norm(n) < 1e-9:
                raise InputError("CIRCLE: zero axis vector", source=where)
            circle = (c * scale, n / np.linalg.norm(n), lineno, turns)
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
            if spindle_on and rpm_zero[0] and not is_rapid:
                raise InputError(
                    f"expected a spindle speed > 0 rpm on a feed move, found {rpm_zero[1]} "
                    f"(line {rpm_zero[0]}) with the spindle on: program the speed it cuts at",
                    source=where,
                )
            f = math.nan if is_rapid else feed_now()
            s = rpm if spindle_on else math.nan
            if circle is not None and pos is not None and not is_rapid:
                centre, nrm, _, turns = circle
                cw = circle_axis == "cw"
                _check_tangent(out, pos, prev_dir, centre, nrm, cw, circle_axis, lineno, _tally)
                pts = arc_points(
                    pos, target, centre, nrm, clockwise=cw, tol=arc_tol_mm, turns=turns,
                    full_circle=True, where=where,
                )  # fmt: skip
                for p in pts:
                    out.add(p * 1e-3, new_axis, line=lineno, rapid=False, feed_mm_per_min=f, rpm=s)
                last = pts[-2] if len(pts) > 1 else pos
            else:
                out.add(
                    target * 1e-3, new_axis, line=lineno, rapid=is_rapid, feed_mm_per_min=f, rpm=s
                )
                last = pos
            if last is not None:
                d = target - last
                nd = float(np.linalg.norm(d))
                prev_dir = d / nd if nd > 1e-9 else prev_dir
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
    df = out.table()
    if not ended:
        out.warn(
            f"no FINI or END-OF-PATH at the end: {TRUNCATED} (the path read so far is planned)"
        )
    if file_units is None and unit0 == "mm" and units == "auto":
        cut = (df["motion"] == "cut").to_numpy()
        p = df[["x_m", "y_m", "z_m"]].to_numpy()[cut] * 1e3
        span = float(np.max(np.ptp(p, axis=0))) if len(p) else 0.0
        if len(p) and span < 25.4 and 0.0 < max_feed < 100.0:
            out.warn(
                f"no UNITS record and the cut spans only {span:.3g} mm at feeds up to "
                f"{max_feed:.3g} mm/min: the data look like inches (set units = 'inch')"
            )
    df.attrs["warnings"] = out.notes()
    return df


def _check_tangent(
    out: WaypointBuilder,
    start: np.ndarray,
    prev_dir: np.ndarray | None,
    centre: np.ndarray,
    nrm: np.ndarray,
    cw: bool,
    circle_axis: str,
    lineno: int,
    tally: dict[str, int] | None = None,
) -> None:
    """Warn when an arc leaves its start against the incoming move (wrong sense).

    ``tally`` (optional) counts arcs that leave ``along`` / ``against`` it.
    """
    if prev_dir is None:
        return
    d = prev_dir - float(prev_dir @ nrm) * nrm
    nd = float(np.linalg.norm(d))
    if nd < 0.5:  # incoming move mostly along the arc axis (plunge, helix entry)
        return
    t = arc_start_tangent(start, centre, nrm, clockwise=cw)
    c = float(t @ d) / nd
    if tally is not None:
        if c > 0.7:
            tally["along"] = tally.get("along", 0) + 1
        elif c < -0.7:
            tally["against"] = tally.get("against", 0) + 1
    if c < -0.7:
        other = "ccw" if circle_axis == "cw" else "cw"
        out.warn(
            f"CIRCLE leaves its start at {math.degrees(math.acos(max(-1.0, c))):.0f} deg to "
            f"the incoming move: the CL data look like the other arc convention "
            f"(set circle_axis = '{other}')",
            lineno,
            key="circle-kink",
        )


def _parse_auto_sense(
    text: str, source: str, *, arc_tol_mm: float, units: str, coordinates: str
) -> pd.DataFrame:
    """:func:`parse_apt` with the ``CIRCLE`` sense the file's own moves imply.

    The trial read in ``cw`` is the answer when ``cw`` wins (no second read).
    """

    def read(sense: str, tally: dict[str, int] | None = None) -> pd.DataFrame:
        return parse_apt(
            text, source, arc_tol_mm=arc_tol_mm, units=units, circle_axis=sense,
            coordinates=coordinates, _tally=tally,
        )  # fmt: skip

    if "CIRCLE" not in text.upper():
        return read("cw")
    tally: dict[str, int] = {}
    table_log = logging.getLogger("robolobe.plan.paths._table")
    level = table_log.level
    table_log.setLevel(logging.ERROR)  # logged below, once the sense is chosen
    try:
        df = read("cw", tally)
    finally:
        table_log.setLevel(level)
    along, against = tally.get("along", 0), tally.get("against", 0)
    sense = "ccw" if against > along else "cw"
    if sense == "ccw":
        df = read("ccw")
    else:
        for w in df.attrs.get("warnings", []):
            table_log.warning("%s", w)
    if along + against and min(along, against) == 0:
        # every checkable arc agrees: the reading is unambiguous
        logger.info(
            "%s: CIRCLE sense %s about i,j,k (all %d checkable arcs tangent)",
            source, sense, along + against,
        )  # fmt: skip
        return df
    if along + against:
        note = (
            f"CIRCLE sense taken as {sense} about i,j,k: in it {max(along, against)} of "
            f"{along + against} arcs that follow a lateral move leave their start along it, "
            "the others turn back: check the CL data (set circle_axis to force one)"
        )
    else:
        note = (
            "CIRCLE sense could not be checked (no arc follows a lateral move); taken as cw "
            "(Siemens NX); set circle_axis = 'ccw' for CATIA-style CL data"
        )
    df.attrs["warnings"] = [f"{source}: {note}", *df.attrs.get("warnings", [])]
    return df


def read_apt(path: str | Path, **options: float | str) -> pd.DataFrame:
    """Read an APT/CL file (see :func:`parse_apt` for ``options``)."""
    p = Path(path)
    return parse_apt(read_text(p), p.name, **options)  # type: ignore[arg-type]


# ------------------------------------------------------------------ writer
# APT/CL conventions (ANSI X3.37 / ISO 4343 CL data, as NX and CATIA posts
# read it): SPINDL/ and FEDRAT/ are modal records that apply to the GOTOs
# after them; a CIRCLE/ record belongs to the GOTO after it, so a new record
# goes before the CIRCLE. Values keep the units the program gave (MMPM, IPM,
# MMPR, IPR or the UNITS of the file). Changes are announced by a "$$
# ROBOLOBE ..." comment line before them.

_FIRST_NUM = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[Ee][-+]?\d+)?")


def _apt_head(stmt: str) -> str:
    m = _STMT.match(stmt.upper())
    return m.group(1).strip() if m else re.split(r"[\s/]", stmt.upper(), maxsplit=1)[0]


def _apt_args(stmt: str) -> list[str]:
    m = _STMT.match(stmt.upper())
    if not m or m.group(2) is None:
        return []
    return [a.strip() for a in m.group(2).split(",") if a.strip()]


def write_apt(text: str, source: str, edit: ProgramEdit, *, coordinates: str = "workpiece") -> str:
    """Write APT/CL data with the speeds, feeds and passes of ``edit``.

    Parameters
    ----------
    text : str
        The CL data as read (:func:`parse_apt` made ``edit.waypoints`` of it).
    source : str
        Its file name (messages).
    edit : ProgramEdit
    coordinates : {"workpiece", "machine"}
        As the reader was told: with ``machine`` the points were read through
        ``MSYS``, and a pass's shift is not written in the file's frame.

    Returns
    -------
    str
        The new CL data.

    Raises
    ------
    InputError
        Passes in data whose ``MSYS`` records were applied, or a SPINDL/FEDRAT
        record continued over several lines.
    """
    src = lines(text)
    stmts = _statements(text)
    vals = line_values(edit)
    # the statement a move's new records go before: its CIRCLE/ when it has one
    insert_at: dict[int, int] = {}
    for k, (ln, _) in enumerate(stmts):
        if ln in vals:
            prev = stmts[k - 1] if k else None
            insert_at[ln] = prev[0] if prev and _apt_head(prev[1]) == "CIRCLE" else ln
    scale = 1.0
    feed_unit = ""
    direction = "CLW"
    cur_s: float | None = None
    cur_f: float | None = None
    # governing records: the first cutting move after each SPINDL / FEDRAT record
    gov: dict[int, int] = {}
    pending: list[int] = []
    for ln, stmt in stmts:
        h = _apt_head(stmt)
        if h in ("SPINDL", "FEDRAT"):
            pending = [p for p in pending if _apt_head(dict(stmts)[p]) != h] + [ln]
        elif ln in vals:
            for p in pending:
                gov[p] = ln
            pending = []
    before: dict[int, list[str]] = {}
    replace: dict[int, str] = {}

    def fed_value(ln: int, unit: str) -> float:
        rpm, f, _ = vals[ln]
        if unit in ("IPM", "IPR"):
            f /= 25.4
        elif unit == "":
            f /= scale
        return f / rpm if unit in ("MMPR", "IPR") else f

    for ln, stmt in stmts:
        h = _apt_head(stmt)
        args = _apt_args(stmt)
        if h == "UNITS" and args:
            scale = 1.0 if args[0] == "MM" else 25.4
        elif h == "SPINDL" and args and args[0] not in ("OFF", "ON"):
            direction = "CCLW" if "CCLW" in args else "CLW"
            old = float(_FIRST_NUM.search(stmt.split("/", 1)[1]).group(0))  # type: ignore[union-attr]
            new = vals[gov[ln]][0] if ln in gov else old
            cur_s = new
            if new != old:
                replace[ln] = _apt_number(stmt, fmt_num(new, 0))
                before.setdefault(ln, []).append(
                    f"$$ ROBOLOBE SPINDL {fmt_num(old, 3)} > {fmt_num(new, 0)} RPM"
                )
        elif h == "FEDRAT":
            unit = next((a for a in args if a in _MINOR), "")
            feed_unit = unit
            old = float(_FIRST_NUM.search(stmt.split("/", 1)[1]).group(0))  # type: ignore[union-attr]
            new = float(fmt_num(fed_value(gov[ln], unit), 6)) if ln in gov else old
            cur_f = new
            if new != old:
                replace[ln] = _apt_number(stmt, fmt_num(new, 6))
                before.setdefault(ln, []).append(
                    f"$$ ROBOLOBE FEDRAT {fmt_num(old, 6)} > {fmt_num(new, 6)} {unit}".rstrip()
                )
        elif ln in vals:
            rpm, _, margin = vals[ln]
            at = insert_at[ln]
            m_txt = f", MARGIN {margin:.2f}" if math.isfinite(margin) else ""
            if cur_s is None or rpm != cur_s:
                before.setdefault(at, []).extend(
                    [
                        f"$$ ROBOLOBE SPINDLE SPEED{m_txt}",
                        f"SPINDL/ {fmt_num(rpm, 0)},RPM,{direction}",
                    ]
                )
                cur_s = rpm
            f = float(fmt_num(fed_value(ln, feed_unit), 6))
            if cur_f is None or f != cur_f:
                unit_txt = f",{feed_unit}" if feed_unit else ""
                before.setdefault(at, []).extend(
                    [f"$$ ROBOLOBE FEED{m_txt}", f"FEDRAT/ {fmt_num(f, 6)}{unit_txt}"]
                )
                cur_f = f
    secs = sections(edit)
    if secs:
        if coordinates == "machine" and any(_apt_head(s) == "MSYS" for _, s in stmts):
            raise InputError(
                "passes in APT data read with coordinates = 'machine' through MSYS records are "
                "not written (the shift along the tool axis would need the MSYS frame); plan "
                "with coordinates = 'workpiece'",
                source=source,
            )
        _apt_passes(stmts, src, edit, secs, insert_at, before, replace, scale, source,
                    feed_unit, fed_value, direction)  # fmt: skip
    out: list[str] = []
    skip_to = 0
    for ln in range(1, len(src) + 1):
        out.extend(before.get(ln, []))
        if ln <= skip_to:
            continue
        if ln in replace:
            out.append(replace[ln])
            skip_to = _record_end(src, ln)
            continue
        out.append(src[ln - 1])
    return "\n".join(out) + "\n"


def _record_end(src: list[str], ln: int) -> int:
    """Last line of the record starting at ``ln`` (``$`` continuations)."""
    k = ln
    while k <= len(src) and src[k - 1].split("$$")[0].rstrip().endswith("$"):
        k += 1
    return k


def _apt_number(stmt: str, new: str) -> str:
    """``stmt`` (one record) with its first number after ``/`` replaced."""
    head, rest = stmt.split("/", 1)
    m = _FIRST_NUM.search(rest)
    assert m is not None
    return f"{head}/{rest[: m.start()]}{new}{rest[m.end() :]}"


def _apt_passes(
    stmts: list[tuple[int, str]],
    src: list[str],
    edit: ProgramEdit,
    secs: list[Section],
    insert_at: dict[int, int],
    before: dict[int, list[str]],
    replace: dict[int, str],
    scale: float,
    source: str,
    feed_unit: str,
    fed_value: Callable[[int, str], float],
    direction: str,
) -> None:
    """Insert the shallower passes of each section before it (module notes of ``_edit``)."""
    wp_lines = edit.waypoints["line"].to_numpy()
    pos_mm = edit.waypoints[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
    for sec in secs:
        first, last = int(wp_lines[sec.start]), int(wp_lines[sec.stop - 1])
        at = insert_at[first]
        body = [(ln, s) for ln, s in stmts if at <= ln <= last]
        block: list[str] = []
        rpm0 = line_values(edit)[first][0]
        f0 = fed_value(first, feed_unit)
        unit_txt = f",{feed_unit}" if feed_unit else ""
        for ps in pass_layout(edit, sec, pos_mm):
            for p, _ in ps.links:
                q = p / scale
                block += [
                    f"$$ ROBOLOBE LINK TO PASS {ps.index} OF {ps.count}",
                    "RAPID",
                    f"GOTO  / {fmt_num(q[0], 8)}, {fmt_num(q[1], 8)}, {fmt_num(q[2], 8)}",
                ]
            block += [
                f"SPINDL/ {fmt_num(rpm0, 0)},RPM,{direction}",
                f"FEDRAT/ {fmt_num(f0, 6)}{unit_txt}",
            ]
            if ps.own:
                break
            block.append(
                f"$$ ROBOLOBE PASS {ps.index} OF {ps.count}: {fmt_num(ps.offset_mm, 4)} MM "
                "ABOVE THE PROGRAMMED DEPTH"
            )
            d = ps.shift_mm / scale
            for ln, stmt in body:
                block.extend(x for x in before.get(ln, []) if not x.startswith("$$"))
                h = _apt_head(stmt)
                text = replace.get(ln, stmt)
                if h in ("GOTO", "CIRCLE"):
                    args = _apt_args(text)
                    v = [float(a) for a in args[:3]]
                    rest = args[3:]
                    v = [v[0] + d[0], v[1] + d[1], v[2] + d[2]]
                    text = f"{h}/ " + ", ".join([*(fmt_num(x, 8) for x in v), *rest])
                block.append(text)
        before.setdefault(at, [])[0:0] = block


# ------------------------------------------------------------------ translation
def apt_setup(text: str) -> tuple[set[str], list[str]]:
    """The spindle directions (``"CLW"``, ``"CCLW"``) and tools (``LOADTL``, ``LOAD/TOOL``) used."""
    directions: set[str] = set()
    tools: list[str] = []
    for _, stmt in _statements(text):
        h = _apt_head(stmt)
        args = _apt_args(stmt)
        if h == "SPINDL" and args and args[0] not in ("OFF", "ON"):
            directions.add("CCLW" if "CCLW" in args else "CLW")
        elif (h == "LOADTL" and args) or (h == "LOAD" and len(args) > 1 and args[0] == "TOOL"):
            t = args[0] if h == "LOADTL" else args[1]
            if t not in tools:
                tools.append(t)
    return directions, tools


def translate_apt(
    table: pd.DataFrame, source: str, *, direction: str, tool: str | None, note: list[str]
) -> str:
    """APT/CL data (mm, ``GOTO/x,y,z,i,j,k``) of a waypoint table, a translation.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`~robolobe.plan.paths._edit.expected_table` with ``full``.
    source : str
        The program translated (messages).
    direction : {"CLW", "CCLW"}
        The spindle's direction.
    tool : str, optional
        The tool number (``LOADTL/`` at the start).
    note : list of str
        Comment lines for the head.
    """
    out = [f"$$ {t}" for t in note]
    out += [f"PARTNO {Path(source).stem.upper()}", "UNITS/MM", "MULTAX"]
    if tool is not None:
        out.append(f"LOADTL/{tool}")
    for rec in cl_records(table):
        if rec.kind == "spindle":
            out.append(f"SPINDL/ {fmt_num(rec.value, 0)},RPM,{direction}")
        elif rec.kind == "feed":
            out.append(f"FEDRAT/ {fmt_num(rec.value, 6)},MMPM")
        else:
            if rec.kind == "rapid":
                out.append("RAPID")
            nums = [fmt_num(v, 8) for v in rec.xyz] + [fmt_num(v, 9) for v in rec.ijk]
            out.append("GOTO  / " + ", ".join(nums))
    out.append("FINI")
    return "\n".join(out) + "\n"
