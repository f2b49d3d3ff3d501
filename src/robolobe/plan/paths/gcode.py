"""G-code (ISO 6983 word-address) reader with modal state.

Supported (Fanuc/Haas/Siemens-ISO/LinuxCNC milling programs as CAM posts write them):

- comments ``( ... )`` and ``;`` to the end of the line, ``%`` lines, a UTF-8
  byte-order mark, program names ``O1234``, ``:1234`` and alphanumeric
  ones on a line of their own (``OFLOOR_FACING``, ``O7997A``), line numbers
  ``N10``, a block that starts with ``:`` and no number (ISO 6983's main
  block or alignment mark, ``: G90 G40`` or ``:T1 M6``; a restart point
  for the controller, no effect on the path: the rest of the block is read;
  ``:`` with a number is a program or main-block number, as ``O``/``N``),
  block delete ``/`` (skipped unless ``block_delete=False``), several words
  per block with or without spaces (``G0G90X0.Y-12.5``), numbers like
  ``X0.``, ``X.5``, ``X+10``; lower case.
- motion G0 (rapid), G1, G2/G3 (arcs by I/J/K centre offsets, incremental
  unless G90.1 or the reader option ``arc_centres = "absolute"``, or by R,
  R < 0 for more than half a turn; full circles; helical), linearised
  within ``arc_tol_mm``; planes G17/G18/G19;
  G90/G91; G20/G21 (G70/G71 too; without either: reader option ``units``);
  G94 feed per minute, G95 per revolution; F (> 0), S (>= 0), M3/M4/M5,
  M30/M2 (end; a file without one, or a closing ``%``, is warned as
  possibly truncated).
- G92 X/Y/Z offsets (and G92.1/G92.2 cancelling them) are applied: the
  path stays in the coordinates before the first G92.
- 5-axis: I/J/K words in a G0/G1 block are the tool axis vector (tip to
  spindle, normalised); rotary words A/B/C (degrees) give the tool axis
  ``Rz(C) @ Ry(B) @ Rx(A) @ [0, 0, 1]``, the motion of the tool relative to
  the part in ISO 841's sense (the same for a head and for a table, whose
  positive table rotation is the opposite). X/Y/Z are tip positions in the
  part frame only under tool centre point control (G43.4, G43.5, Haas
  G234 TCPC) or a dynamic work offset (Haas G254); reader option
  ``rotary_axes``: ``auto`` (default) reads rotary words under TCP and
  refuses a move at a non-zero rotary angle without it (a head, or an
  indexing table whose pivot the program does not give?), ``head`` reads
  them as a head tilt anywhere with X/Y/Z taken as the tool tip (a post
  that writes tip positions, as for a robot), ``table`` refuses them
  without TCP.
  A rotary-only rapid without TCP (indexing before TCP is switched on) only
  sets the angles. A program uses I/J/K vectors or A/B/C words, not both.
- cutter radius compensation G41/G42 (G40 cancels) in G17, applied as the
  controller applies it (:mod:`robolobe.plan.paths._compensation`: offset
  lines and arcs, arcs around outside corners, intersections at inside
  ones, straight entry and exit moves) with the radius of the reader option
  ``cutter_radius_mm`` (job ``[path] cutter_radius_mm``: the D register's
  radius, whatever the D word); without it G41/G42 are refused, naming
  that key.
- ignored on purpose (no effect on the path), each with a note in the
  summary where it is unusual: G4 dwell, G10 blocks (offset data; the whole
  block, L2/L10/L20...), G15, G40 without compensation on, G43/G44/G49, G54-G59.9, G54.1/G154 (work
  offsets), G61/G64, G80, G98/G99, G17.1, G5.1 Q.. (Fanuc AI contour
  control, no axis words), G5 P.. (Fanuc high-precision mode), G08 P..
  (look-ahead), G103 (look-ahead limit), G187 (smoothness), G255 (cancel
  DWO); T, H, D words; M words other than the ones above; G28/G30/G53
  (moves to a machine reference: they leave the path, which resumes at the
  next move; their G91/G90 words still count).

Refused with :class:`~robolobe.errors.InputError` naming ``file:line`` and
the construct: macros ``#``, expressions ``[ ]``, ``IF``/``GOTO``/``WHILE``,
O-word subroutines, splines and NURBS (LinuxCNC G5/G5.1/G5.2 with axis
words, Fanuc G6.2), canned cycles G73-G89, G41/G42 without
``cutter_radius_mm`` (or outside G17, with a helical arc, or where the
cutter does not fit an inside corner or arc), inverse-time feed G93,
polar/rotated/cylindrical coordinates G16/G68/G12.1/G7.1, subprograms M98,
Heidenhain conversational, F <= 0, S < 0, non-finite or absurd numbers.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pandas as pd

from robolobe._memory import release_free_memory
from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_point_list
from robolobe.plan.paths._compensation import Element, compensate
from robolobe.plan.paths._edit import (
    ProgramEdit,
    cl_records,
    fmt_num,
    line_values,
    pass_layout,
    sections,
)
from robolobe.plan.paths._table import WaypointBuilder
from robolobe.plan.paths._text import (
    MAX_ABS,
    TRUNCATED,
    UNIT_CHOICES,
    check_choice,
    iter_lines,
    lines,
    read_text,
)

__all__ = ["gcode_setup", "parse_gcode", "read_gcode", "translate_gcode", "write_gcode"]

logger = logging.getLogger(__name__)

_NUM = r"[+-]?\s*(?:\d+\.?\d*|\.\d+)"
_WORD = re.compile(r"([A-Z])\s*=?\s*(" + _NUM + r")")
_BLOCK = re.compile(r"(?:\s*[A-Z]\s*=?\s*" + _NUM + r")*\s*")
_UNSUPPORTED_TEXT = (
    ("#", "macro variables (#)"),
    ("[", "expressions ([ ])"),
    ("BEGIN PGM", "Heidenhain conversational programs (post the path as ISO G-code)"),
    ("TRAORI", "Siemens TRAORI (post the path with tool vectors or A/B/C words)"),
    ("CYCLE", "Siemens cycles"),
)
_UNSUPPORTED_KEYWORDS = re.compile(
    r"\b(IF|GOTO|WHILE|DO|END\d|THEN|ELSE|ENDIF|REPEAT|SUB|ENDSUB|CALL)\b"
)
_PROGRAM_NAME = re.compile(r"^(?:O[A-Z0-9_.\-]+|O\s+\d+|:\s*\d+)\s*")

# G codes accepted without effect on the geometry (no note: routine in posts)
_G_IGNORED = {4.0, 15.0, 17.1, 43.0, 44.0, 49.0, 61.0, 61.1, 64.0, 80.0, 98.0, 99.0}
_G_IGNORED |= (
    {54.1} | {float(g) for g in range(54, 60)} | {round(54 + k / 10, 1) for k in range(1, 10)}
)
# accepted without effect, with a note in the summary
_G_NOTED = {
    8.0: "G08 look-ahead mode",
    103.0: "G103 block look-ahead limit",
    154.0: "G154 extended work offset",
    187.0: "G187 smoothness setting",
    255.0: "G255 cancel dynamic work offset",
}
# mode words whose E/P/Q/R words are their parameters, not axes or arc words
_G_MODE_WORDS = {5.0, 5.1, 8.0, 103.0, 154.0, 187.0}
# tool centre point control / dynamic work offset on: X/Y/Z are tip positions in the part frame
_G_TCP_ON = {43.4: "G43.4 TCP", 43.5: "G43.5 TCP", 234.0: "G234 TCPC", 254.0: "G254 DWO"}
_G_UNSUPPORTED = {
    93.0: "inverse-time feed G93",
    16.0: "polar coordinates G16",
    68.0: "coordinate rotation G68",
    68.2: "tilted working plane G68.2",
    51.0: "scaling G51",
    51.1: "mirroring G51.1",
    65.0: "macro call G65",
    66.0: "macro call G66",
    5.0: "cubic spline G5 (post the path as lines and arcs)",
    5.1: "quadratic spline G5.1 (post the path as lines and arcs)",
    5.2: "NURBS G5.2 (post the path as lines and arcs)",
    5.3: "NURBS G5.3 (post the path as lines and arcs)",
    6.2: "NURBS interpolation G6.2 (post the path as lines and arcs)",
    7.1: "cylindrical interpolation G7.1",
    12.0: "circular pocket G12",
    13.0: "circular pocket G13",
    12.1: "polar coordinate interpolation G12.1",
    13.1: "polar coordinate interpolation G13.1",
    33.0: "threading G33",
    33.1: "rigid tapping G33.1",
    38.2: "probing G38.2",
    38.3: "probing G38.3",
    38.4: "probing G38.4",
    38.5: "probing G38.5",
    31.0: "skip function G31",
    92.3: "G92.3 (restores saved G92 offsets)",
}
_G_UNSUPPORTED |= {float(g): f"canned cycle G{g}" for g in range(73, 90) if g != 80}
_G_UNSUPPORTED[76.0] = "canned cycle G76"

_ROTARY_CHOICES = ("auto", "head", "table")
#: Values of the reader option ``arc_centres`` (job ``[path] arc_centres``).
ARC_CENTRE_CHOICES = ("incremental", "absolute")


@dataclass
class _State:
    motion: int | None = None
    plane: int = 17
    absolute: bool = True
    arc_abs: bool = False
    arc_abs_stated: bool = False  # the program said G90.1 or G91.1
    scale: float = 1.0  # mm per program unit
    units_set: bool = False
    per_rev: bool = False
    feed: float = math.nan  # program units per min (or per rev)
    rpm: float = math.nan
    rpm_zero_line: int = 0  # the line of an S0 in force (0: none)
    spindle_on: bool = False
    pos: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # mm, path frame
    pos_known: bool = False
    offset: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # G92 [mm]
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    rot_deg: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])
    vector_mode: str | None = None  # "ijk" | "abc"
    tcp: bool = False
    wcs: float | None = None  # active work offset (G54 ...)
    ended: bool = False
    comp: int = 0  # cutter radius compensation: 0 off, 41 left, 42 right
    comp_radius: float | None = None  # [mm], reader option cutter_radius_mm
    comp_where: str = ""
    comp_moves: list[Element] = field(default_factory=list)  # entry, then the contour
    comp_exit_next: bool = False  # G40 without motion: the next move is the exit move


def _strip_comments(raw: str, where: str) -> str:
    out = []
    depth = 0
    for ch in raw:
        if ch == "(":
            depth += 1
            continue
        if ch == ")":
            if depth == 0:
                raise InputError("unbalanced ')' in the block", source=where)
            depth -= 1
            continue
        if depth == 0:
            if ch == ";":
                break
            out.append(ch)
    if depth:
        raise InputError("unclosed comment '(' in the block", source=where)
    return "".join(out)


def _tokenize(s: str, where: str) -> list[tuple[str, str]]:
    """Words of one upper-case block (comments removed): (letter, number text)."""
    for needle, what in _UNSUPPORTED_TEXT:
        if needle in s:
            raise InputError(f"unsupported construct: {what}", source=where)
    if _BLOCK.fullmatch(s):
        return _WORD.findall(s)
    m = _UNSUPPORTED_KEYWORDS.search(s)
    if m:
        raise InputError(f"unsupported construct: control flow {m.group(1)!r}", source=where)
    pos = 0
    for mt in _WORD.finditer(s):
        gap = s[pos : mt.start()]
        if gap.strip():
            raise InputError(f"expected address words like X10.5, found {gap.strip()!r}", where)
        pos = mt.end()
    raise InputError(f"expected address words like X10.5, found {s[pos:].strip()!r}", where)


def parse_gcode(
    text: str,
    source: str = "<gcode>",
    *,
    arc_tol_mm: float = 0.01,
    block_delete: bool = True,
    units: str = "auto",
    no_decimal_scale: float = 1.0,
    rotary_axes: str = "auto",
    cutter_radius_mm: float | None = None,
    arc_centres: str = "incremental",
) -> pd.DataFrame:
    """Read G-code text into the waypoint table.

    Parameters
    ----------
    text : str
        Program text.
    source : str
        File name for the ``source`` column and messages.
    arc_tol_mm : float
        Chord tolerance of linearised arcs [mm].
    block_delete : bool
        Skip blocks starting with ``/`` (block delete switch on).
    units : {"auto", "mm", "inch"}
        Units before any G20/G21. ``auto``: mm, with a warning when the
        program never states its units (and one more when the cut spans
        less than an inch at feeds below 100 mm/min: inch data?).
    no_decimal_scale : float
        Factor for axis words written without a decimal point (1: ``X10`` is
        10 units; 0.001: classic Fanuc, ``X10`` is 0.010 mm).
    rotary_axes : {"auto", "head", "table"}
        How A/B/C words are read (see the module docstring).
    cutter_radius_mm : float, optional
        The radius the controller's D register holds for G41/G42 (job key
        ``[path] cutter_radius_mm``): the tool radius where the program is
        the part contour, the wear value where it is the tool centre. Without
        it, G41/G42 are refused.
    arc_centres : {"incremental", "absolute"}
        How I/J/K arc centres are read until the program says G90.1
        (absolute) or G91.1 (incremental): the controller's setting (job key
        ``[path] arc_centres``; Mach3's "IJ mode"). With the default, an arc
        whose centre is inconsistent as an offset from the start but
        consistent as an absolute point is refused naming this key.

    Returns
    -------
    pandas.DataFrame
        The waypoint table (:mod:`robolobe.plan.paths._table`); reader
        warnings in ``attrs["warnings"]``.

    Raises
    ------
    InputError
        Unsupported or malformed constructs, naming ``source:line``.
    """
    check_choice("units", units, UNIT_CHOICES)
    check_choice("rotary_axes", rotary_axes, _ROTARY_CHOICES)
    check_choice("arc_centres", arc_centres, ARC_CENTRE_CHOICES)
    st = _State(scale=25.4 if units == "inch" else 1.0, arc_abs=arc_centres == "absolute")
    if cutter_radius_mm is not None and not (0.0 <= float(cutter_radius_mm) <= 1000.0):
        raise InputError(
            f"cutter_radius_mm: expected a radius 0 to 1000 mm, found {cutter_radius_mm!r}"
        )
    st.comp_radius = None if cutter_radius_mm is None else float(cutter_radius_mm)
    out = WaypointBuilder(source)
    seen_motion = False
    last_pct = False
    strip_comments = _strip_comments
    tokenize = _tokenize
    block = _block
    for lineno, raw in enumerate(iter_lines(text), start=1):
        line = raw.strip()
        if not line:
            continue
        if line[0] == "%":
            last_pct = seen_motion
            continue
        if "(" in line or ";" in line or ")" in line:
            where = f"{source}:{lineno}"
            line = strip_comments(line, where).strip()
            if not line:
                continue
        if line[0] == "/" or (line[0] in "Nn" and "/" in line):
            # block delete may follow a line number: "N10 /G1 ..."
            m = re.match(r"^(N\s*\d+\s*)?/", line, flags=re.IGNORECASE)
            if m:
                if block_delete:
                    continue
                line = line[m.end() :]
        upper = line.upper()
        if upper[0] == ":" and not upper[1:].lstrip()[:1].isdigit():
            # ISO 6983 main block (alignment mark) without a number: read the block
            upper = upper[1:].lstrip()
            if not upper:
                continue
        if upper[0] in "O:":
            m = _PROGRAM_NAME.match(upper)
            if m is None or (m.end() < len(upper) and upper[m.end() :].lstrip()[:1] not in "GMN"):
                raise InputError(
                    f"unsupported construct: O-word {upper.split()[0]!r} with "
                    f"{upper[m.end() if m else 1 :].strip()!r} (subroutine or control flow; "
                    "only a program name may stand on an O line)",
                    source=f"{source}:{lineno}",
                )
            upper = upper[m.end() :]
            if not upper:
                continue
        words = tokenize(upper, f"{source}:{lineno}") if upper else []
        if not words:
            continue
        seen_motion = True
        last_pct = False
        if block(words, st, out, lineno, arc_tol_mm, no_decimal_scale, rotary_axes):
            st.ended = True
            break
    if st.comp:
        out.warn(
            f"G{st.comp} cutter radius compensation not cancelled by G40: the last move ends "
            "offset",
            None,
        )
        _comp_flush(st, out, None, arc_tol_mm)
    df = out.table()
    if not st.ended and not last_pct:
        out.warn(f"no M30/M2 program end: {TRUNCATED} (the path read so far is planned)")
    if not st.units_set and units == "auto":
        cut = (df["motion"] == "cut").to_numpy()
        p = df[["x_m", "y_m", "z_m"]].to_numpy()[cut] * 1e3
        f = df["feed_mm_per_min"].to_numpy()[cut]
        span = float(np.max(np.ptp(p, axis=0))) if len(p) else 0.0
        fmax = float(np.nanmax(f)) if len(f) and np.any(np.isfinite(f)) else 0.0
        hint = ""
        if len(p) and span < 25.4 and 0.0 < fmax < 100.0:
            hint = (
                f"; the cut spans only {span:.3g} mm at feeds up to {fmax:.3g} mm/min: "
                "the program looks like inches"
            )
        out.warn(f"no G20/G21: read as mm{hint} (set the reader option units to override)")
    df.attrs["warnings"] = out.notes()
    return df


def _axis_from_abc(abc_deg: list[float]) -> tuple[float, float, float]:
    a, b, c = (math.radians(v) for v in abc_deg)
    ca, sa, cb, sb, cc, sc = (
        math.cos(a),
        math.sin(a),
        math.cos(b),
        math.sin(b),
        math.cos(c),
        math.sin(c),
    )
    # Rz(c) Ry(b) Rx(a) @ ez
    return (sb * ca * cc + sa * sc, sb * ca * sc - sa * cc, cb * ca)


def _number(letter: str, raw: str, lineno: int, nodec: float, out: WaypointBuilder) -> float:
    value = float(raw.replace(" ", ""))
    if abs(value) > MAX_ABS:
        raise InputError(
            f"word {letter}{raw}: expected a magnitude at most {MAX_ABS:g}",
            source=f"{out.source}:{lineno}",
        )
    if letter in "XYZIJKR" and "." not in raw:
        value *= nodec
    return value


_FAST_G = {"0": 0, "00": 0, "1": 1, "01": 1}
_AXES = {"X": 0, "Y": 1, "Z": 2}


def _fast_line(
    words: list[tuple[str, str]], st: _State, out: WaypointBuilder, lineno: int, nodec: float
) -> bool:
    """The common block (G0/G1 with X/Y/Z/F, N) applied without the general machinery.

    Returns False, having changed nothing, for any other block: :func:`_block`
    then applies it (and gives its errors).
    """
    motion = st.motion
    t = list(st.pos)
    seen = ""
    feed = st.feed
    for letter, raw in words:
        if letter in seen:
            return False
        k = _AXES.get(letter)
        if k is not None:
            v = float(raw)  # raises on inner spaces: the general path handles them
            if not -MAX_ABS <= v <= MAX_ABS:
                return False
            if "." not in raw:
                v *= nodec
            v *= st.scale
            t[k] = v + st.offset[k] if st.absolute else t[k] + v
        elif letter == "F":
            feed = float(raw)
            if not 0 < feed <= MAX_ABS:
                return False
        elif letter == "G":
            g = _FAST_G.get(raw)
            if g is None:
                return False
            motion = g
        elif letter != "N":
            return False
        seen += letter
    if (
        motion not in (0, 1)
        or st.vector_mode == "abc"
        or not ("X" in seen or "Y" in seen or "Z" in seen)
        or st.comp
        or st.comp_exit_next
    ):
        return False
    st.motion = motion
    st.feed = feed
    _emit_line(st, out, t, st.axis, lineno, rapid=motion == 0)
    return True


def _block(
    words: list[tuple[str, str]],
    st: _State,
    out: WaypointBuilder,
    lineno: int,
    arc_tol: float,
    nodec: float,
    rotary_axes: str,
) -> bool:
    """Apply one block; return True at program end."""
    try:
        if _fast_line(words, st, out, lineno, nodec):
            return False
    except ValueError:
        pass
    g_codes: list[float] = []
    m_codes: list[float] = []
    vals: dict[str, float] = {}
    for letter, raw in words:
        if letter == "G":
            g_codes.append(round(float(raw.replace(" ", "")), 1))
        elif letter == "M":
            m_codes.append(round(float(raw.replace(" ", "")), 1))
        elif letter == "N":
            continue
        else:
            if letter in vals:
                raise InputError(
                    f"word {letter} appears twice in the block", source=f"{out.source}:{lineno}"
                )
            vals[letter] = _number(letter, raw, lineno, nodec, out)
    # --- G words
    dwell = False
    home = False
    g92: float | None = None
    comp_word: float | None = None
    for g in g_codes:
        if g in (0.0, 1.0, 2.0, 3.0):
            st.motion = int(g)
        elif g in (17.0, 18.0, 19.0):
            st.plane = int(g)
        elif g == 90.0:
            st.absolute = True
        elif g == 91.0:
            st.absolute = False
        elif g == 90.1:
            st.arc_abs = True
            st.arc_abs_stated = True
        elif g == 91.1:
            st.arc_abs = False
            st.arc_abs_stated = True
        elif g in (20.0, 70.0):
            st.scale = 25.4
            st.units_set = True
        elif g in (21.0, 71.0):
            st.scale = 1.0
            st.units_set = True
        elif g == 94.0:
            st.per_rev = False
        elif g == 95.0:
            st.per_rev = True
        elif g in (28.0, 30.0, 53.0):
            home = True
        elif g == 4.0:
            dwell = True
        elif g in _G_IGNORED:
            if g == 49.0:
                st.tcp = False
            elif 54.0 <= g < 60.0:
                _work_offset(g, st, out, lineno)
            continue
        elif g == 10.0:
            out.warn("G10 blocks (offset data, no motion) ignored", lineno, key="G10")
            return False
        elif g in (92.0, 92.1, 92.2):
            g92 = g
        elif g in (40.0, 41.0, 42.0):
            comp_word = g
        elif g in _G_TCP_ON:
            st.tcp = True
        elif g in _G_NOTED:
            if g == 255.0:
                st.tcp = False
            out.warn(f"{_G_NOTED[g]} ignored (no effect on the path)", lineno, key=f"G{g:g}")
        elif g in (5.0, 5.1) and not any(k in vals for k in "XYZIJABC"):
            # Fanuc: G05 P10000 (high-precision), G05.1 Q1 (AI contour control): modes
            out.warn(f"G{g:g} (Fanuc contour control mode) ignored", lineno, key=f"G{g:g}")
        elif g in _G_UNSUPPORTED:
            raise InputError(
                f"unsupported construct: {_G_UNSUPPORTED[g]}", source=f"{out.source}:{lineno}"
            )
        else:
            raise InputError(f"unsupported G code G{g:g}", source=f"{out.source}:{lineno}")
    if g92 is not None:
        _apply_g92(g92, vals, st, out, lineno)
        return False
    comp_exit = False
    if comp_word is not None:
        where = f"{out.source}:{lineno}"
        if comp_word == 40.0:
            comp_exit = st.comp != 0
        else:
            if st.comp:
                raise InputError(
                    f"G{comp_word:g} while G{st.comp} is on: expected G40 between them", where
                )
            if st.comp_radius is None:
                raise InputError(
                    f"cutter radius compensation G{comp_word:g}: the cutter radius is not known; "
                    "set the job key [path] cutter_radius_mm (the D register's radius: the tool "
                    "radius for a part-contour program, the wear value for a tool-centre one)",
                    where,
                )
            if st.plane != 17:
                raise InputError(
                    f"cutter radius compensation G{comp_word:g} in plane G{st.plane}: only G17 "
                    "is read",
                    where,
                )
            st.comp = int(comp_word)
            st.comp_where = where
            st.comp_moves = []
    if any(g in _G_MODE_WORDS for g in g_codes) and not any(k in vals for k in "XYZABC"):
        for k in "EPQR":  # parameters of a mode word (G187 P2 E0.01, G05.1 Q1 R5)
            vals.pop(k, None)
    # --- M words
    end = False
    for mc in m_codes:
        if mc in (3.0, 4.0):
            st.spindle_on = True
            if mc == 4.0:
                out.warn("M4 (counter-clockwise spindle) planned as M3", lineno, key="M4")
        elif mc == 5.0:
            st.spindle_on = False
        elif mc in (2.0, 30.0):
            end = True
        elif mc in (98.0, 99.0, 97.0):
            raise InputError(
                f"unsupported construct: subprogram M{mc:g}", source=f"{out.source}:{lineno}"
            )
    if "F" in vals:
        f = vals.pop("F")
        if f <= 0:
            raise InputError(
                f"expected a positive feed F, found {f:g}", source=f"{out.source}:{lineno}"
            )
        st.feed = f
    if "S" in vals:
        s = vals.pop("S")
        if s < 0:
            raise InputError(
                f"expected a spindle speed S >= 0 (direction by M3/M4), found {s:g}",
                source=f"{out.source}:{lineno}",
            )
        st.rpm = s if s > 0 else math.nan
        st.rpm_zero_line = 0 if s > 0 else lineno
    for bad in ("L", "E"):
        if bad in vals:
            raise InputError(
                f"unsupported word {bad} (repeat count / extruder)", source=f"{out.source}:{lineno}"
            )
    for ignored in ("T", "H", "D", "P", "Q"):
        vals.pop(ignored, None)
    if dwell:
        return end
    for bad in ("U", "V", "W"):
        if bad in vals:
            raise InputError(
                f"unsupported axis word {bad} (only X Y Z A B C)", source=f"{out.source}:{lineno}"
            )
    if not vals:
        if comp_exit:
            st.comp_exit_next = True
        return end
    where = f"{out.source}:{lineno}"
    moving = "X" in vals or "Y" in vals or "Z" in vals or "A" in vals or "B" in vals or "C" in vals
    if (
        not moving
        and st.motion is not None
        and ("I" in vals or "J" in vals or "K" in vals or "R" in vals)
    ):
        moving = True
    if home:  # leaves the path for a machine reference; the next absolute move resumes it
        st.pos_known = False
        return end
    if not moving:
        if "R" in vals or "I" in vals or "J" in vals or "K" in vals:
            raise InputError("arc words I/J/K/R without an arc move", source=where)
        if comp_exit:
            st.comp_exit_next = True
        return end
    if st.motion is None:
        raise InputError("axis words before any motion mode (G0/G1/G2/G3)", source=where)
    target = _target(vals, st)
    axis = st.axis
    has_xyz = "X" in vals or "Y" in vals or "Z" in vals
    if "A" in vals or "B" in vals or "C" in vals:
        if st.vector_mode == "ijk":
            raise InputError("rotary words A/B/C in a program that uses I/J/K tool vectors", where)
        st.vector_mode = "abc"
        for n, k in enumerate("ABC"):
            if k in vals:
                st.rot_deg[n] = vals[k] if st.absolute else st.rot_deg[n] + vals[k]
        axis = _axis_from_abc(st.rot_deg)
        if not has_xyz and not st.tcp and st.motion == 0 and rotary_axes != "head":
            # indexing the rotary axes before TCP is switched on: no tip motion to plan
            st.axis = axis
            return end
    if (
        st.vector_mode == "abc"
        and rotary_axes != "head"
        and not st.tcp
        and any(abs(v) > 1e-9 for v in st.rot_deg)
    ):
        what = (
            "rotary words A/B/C without tool centre point control (G43.4/G43.5/G234) or a "
            "dynamic work offset (G254)"
        )
        if rotary_axes == "table":
            raise InputError(
                f"{what}: X/Y/Z are machine coordinates of a rotated table whose pivot the "
                "program does not give; post the path with TCP, or as a waypoint table",
                where,
            )
        raise InputError(
            f"{what} are ambiguous: they may index a rotary table (the path is then in "
            "machine coordinates of a rotated part) or tilt a head; set the reader option "
            "rotary_axes = 'head' if they tilt the tool, else post the path with TCP",
            where,
        )
    if st.motion in (0, 1):
        if "I" in vals or "J" in vals or "K" in vals:
            if st.vector_mode == "abc":
                raise InputError("I/J/K tool vectors in a program that uses A/B/C words", where)
            st.vector_mode = "ijk"
            v = (vals.get("I", 0.0), vals.get("J", 0.0), vals.get("K", 0.0))
            nv = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
            if nv < 1e-9:
                raise InputError("I/J/K tool vector of zero length", source=where)
            axis = (v[0] / nv, v[1] / nv, v[2] / nv)
        if "R" in vals:
            raise InputError("word R in a linear move", source=where)
        if st.comp or st.comp_exit_next:
            _comp_line(st, out, target, axis, lineno, st.motion == 0, comp_exit, arc_tol, where)
        else:
            _emit_line(st, out, target, axis, lineno, rapid=st.motion == 0)
    else:
        if st.comp and not comp_exit:
            _comp_arc(vals, st, out, target, axis, lineno, where)
        else:
            if st.comp or st.comp_exit_next:
                raise InputError(
                    "cutter radius compensation: expected a straight exit move with G40", where
                )
            _emit_arc(vals, st, out, target, axis, lineno, arc_tol, where)
    if comp_exit and st.comp:
        st.comp_exit_next = True  # G40 without an XY/Z motion: the next move exits
    return end


def _work_offset(g: float, st: _State, out: WaypointBuilder, lineno: int) -> None:
    """Track the work offset; a change after the first move joins two origins."""
    if st.wcs is not None and g != st.wcs and len(out):
        out.warn(
            f"work offset changes from G{st.wcs:g} to G{g:g}: the coordinates before and after "
            "are relative to different origins (machine data not in the program); read as one "
            "frame",
            lineno,
            key="wcs-change",
        )
    st.wcs = g


def _apply_g92(
    g: float, vals: dict[str, float], st: _State, out: WaypointBuilder, lineno: int
) -> None:
    where = f"{out.source}:{lineno}"
    if g in (92.1, 92.2):
        st.offset = [0.0, 0.0, 0.0]
        return
    if any(k in vals for k in "ABCIJKRUVW"):
        raise InputError("unsupported construct: G92 on axes other than X/Y/Z", source=where)
    if not any(k in vals for k in "XYZ"):
        raise InputError("G92 without X/Y/Z words", source=where)
    if not st.pos_known:
        raise InputError(
            "unsupported construct: G92 where the current position is unknown (before any "
            "move or after G28/G53): the offset it sets cannot be computed",
            source=where,
        )
    for n, k in enumerate("XYZ"):
        if k in vals:
            st.offset[n] = st.pos[n] - vals[k] * st.scale
    out.warn(
        "G92 coordinate offsets applied (path kept in the coordinates before G92)",
        lineno,
        key="G92",
    )


def _target(vals: dict[str, float], st: _State) -> list[float]:
    t = list(st.pos)
    for n, k in enumerate("XYZ"):
        if k in vals:
            v = vals[k] * st.scale
            t[n] = v + st.offset[n] if st.absolute else t[n] + v
    return t


def _feed_mm_per_min(st: _State) -> float:
    if math.isnan(st.feed):
        return math.nan
    f = st.feed * st.scale
    if st.per_rev:
        return f * st.rpm if st.spindle_on and not math.isnan(st.rpm) else math.nan
    return f


def _spindle_rpm(st: _State, out: WaypointBuilder, lineno: int, rapid: bool) -> float:
    """The programmed spindle speed of a move [rpm] (NaN: none); a feed move at S0 is refused."""
    if not st.spindle_on:
        return math.nan
    if st.rpm_zero_line and not rapid:
        raise InputError(
            f"expected a spindle speed S > 0 on a feed move, found S0 (line "
            f"{st.rpm_zero_line}) with the spindle on: program the speed it cuts at",
            source=f"{out.source}:{lineno}",
        )
    return st.rpm


def _emit_line(
    st: _State,
    out: WaypointBuilder,
    target: list[float],
    axis: tuple[float, float, float],
    lineno: int,
    rapid: bool,
) -> None:
    rpm = _spindle_rpm(st, out, lineno, rapid)
    out.add_unit(
        (target[0] * 1e-3, target[1] * 1e-3, target[2] * 1e-3),
        axis,
        lineno,
        rapid,
        math.nan if rapid else _feed_mm_per_min(st),
        rpm,
    )
    st.pos = target
    st.pos_known = True
    st.axis = axis


def _comp_meta(
    st: _State, out: WaypointBuilder, lineno: int, rapid: bool, axis: tuple[float, float, float]
) -> tuple:
    rpm = _spindle_rpm(st, out, lineno, rapid)
    return (lineno, rapid, math.nan if rapid else _feed_mm_per_min(st), rpm, axis)


def _comp_line(
    st: _State,
    out: WaypointBuilder,
    target: list[float],
    axis: tuple[float, float, float],
    lineno: int,
    rapid: bool,
    exit_here: bool,
    arc_tol: float,
    where: str,
) -> None:
    """A straight move with compensation on (or the exit move): buffered."""
    if st.vector_mode is not None:
        raise InputError("cutter radius compensation with tool axis words (5-axis)", where)
    e = Element("line", tuple(st.pos), tuple(target), _comp_meta(st, out, lineno, rapid, axis))  # type: ignore[arg-type]
    st.pos = target
    st.pos_known = True
    st.axis = axis
    if exit_here or st.comp_exit_next:
        _comp_flush(st, out, e, arc_tol)
        return
    st.comp_moves.append(e)


def _comp_arc(
    vals: dict[str, float],
    st: _State,
    out: WaypointBuilder,
    target: list[float],
    axis: tuple[float, float, float],
    lineno: int,
    where: str,
) -> None:
    """An arc with compensation on: its centre (as :func:`_emit_arc` finds it), buffered."""
    if not st.comp_moves:
        raise InputError(
            "cutter radius compensation: expected a straight entry move after G41/G42", where
        )
    start = st.pos
    cw = st.motion == 2
    if "R" in vals:
        r = vals["R"] * st.scale
        da, db = target[0] - start[0], target[1] - start[1]
        chord = math.hypot(da, db)
        if chord < 1e-9 or chord > 2 * abs(r) * (1 + 1e-6) + 1e-3:
            raise InputError(f"arc radius R{abs(r):g} does not fit its chord", source=where)
        h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
        sign = (-1.0 if cw else 1.0) * (1.0 if r > 0 else -1.0)
        centre = (
            (start[0] + target[0]) / 2 + sign * h * (-db / chord),
            (start[1] + target[1]) / 2 + sign * h * (da / chord),
        )
        full = False
    else:
        i, j = vals.get("I", 0.0) * st.scale, vals.get("J", 0.0) * st.scale
        if st.arc_abs:
            centre = (
                (i + st.offset[0]) if "I" in vals else start[0],
                (j + st.offset[1]) if "J" in vals else start[1],
            )
        else:
            centre = (start[0] + i, start[1] + j)
        full = math.hypot(target[0] - start[0], target[1] - start[1]) < 1e-9
    e = Element(
        "arc", tuple(start), tuple(target), _comp_meta(st, out, lineno, False, axis),  # type: ignore[arg-type]
        centre=centre, cw=cw, full=full,
    )  # fmt: skip
    st.comp_moves.append(e)
    st.pos = target
    st.pos_known = True
    st.axis = axis


def _comp_flush(st: _State, out: WaypointBuilder, exit_move: Element | None, tol: float) -> None:
    """Emit the compensated moves of one G41/G42 ... G40 stretch."""
    moves = st.comp_moves
    radius = st.comp_radius or 0.0
    if moves:
        done = compensate(moves[0], moves[1:], exit_move, st.comp, radius, st.comp_where)
    else:  # G41 and G40 with one move between: entry and exit at once
        done = [exit_move] if exit_move is not None else []
    add = out.add_unit
    for e in done:
        lineno, rapid, feed, rpm, axis = e.meta
        if e.kind == "line":
            p = e.p1
            add((p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3), axis, lineno, rapid, feed, rpm)
        else:
            pts = arc_point_list(
                e.p0, e.p1, (e.centre[0], e.centre[1], e.p0[2]), (0.0, 0.0, 1.0),
                clockwise=e.cw, tol=tol, full_circle=e.full, where=f"{out.source}:{lineno}",
            )  # fmt: skip
            for p in pts:
                add((p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3), axis, lineno, False, feed, rpm)
    st.comp = 0
    st.comp_moves = []
    st.comp_exit_next = False


_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


def _emit_arc(
    vals: dict[str, float],
    st: _State,
    out: WaypointBuilder,
    target: list[float],
    axis: tuple[float, float, float],
    lineno: int,
    tol: float,
    where: str,
) -> None:
    ia, ib, ic = _PLANES[st.plane]
    normal = [0.0, 0.0, 0.0]
    normal[ic] = 1.0
    start = st.pos
    cw = st.motion == 2
    if "R" in vals:
        if "I" in vals or "J" in vals or "K" in vals:
            raise InputError("arc with both R and I/J/K", source=where)
        r = vals["R"] * st.scale
        da, db = target[ia] - start[ia], target[ib] - start[ib]
        chord = math.hypot(da, db)
        if chord < 1e-9:
            raise InputError("R-form arc with coincident start and end", source=where)
        if chord > 2 * abs(r) * (1 + 1e-6) + 1e-3:
            raise InputError(
                f"arc radius R{abs(r):g} too small for a chord of {chord:.4g}", source=where
            )
        h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
        # CW with a short arc (R > 0): centre to the right of the chord
        sign = (-1.0 if cw else 1.0) * (1.0 if r > 0 else -1.0)
        centre = list(start)
        centre[ia] = (start[ia] + target[ia]) / 2 + sign * h * (-db / chord)
        centre[ib] = (start[ib] + target[ib]) / 2 + sign * h * (da / chord)
        full = False
    else:
        if not ("I" in vals or "J" in vals or "K" in vals):
            raise InputError("arc without I/J/K or R", source=where)
        off = [
            vals.get("I", 0.0) * st.scale,
            vals.get("J", 0.0) * st.scale,
            vals.get("K", 0.0) * st.scale,
        ]
        if st.arc_abs:
            centre = list(start)
            for n, k in enumerate("IJK"):
                if k in vals:
                    centre[n] = off[n] + st.offset[n]
        else:
            centre = [start[0] + off[0], start[1] + off[1], start[2] + off[2]]
            _check_incremental_centre(st, start, target, off, (ia, ib), tol, where)
        full = True
    centre[ic] = start[ic]
    pts = arc_point_list(
        (start[0], start[1], start[2]), (target[0], target[1], target[2]),
        (centre[0], centre[1], centre[2]), (normal[0], normal[1], normal[2]),
        clockwise=cw, tol=tol, full_circle=full, where=where,
    )  # fmt: skip
    feed = _feed_mm_per_min(st)
    rpm = _spindle_rpm(st, out, lineno, False)
    add = out.add_unit
    for p in pts:
        add((p[0] * 1e-3, p[1] * 1e-3, p[2] * 1e-3), axis, lineno, False, feed, rpm)
    st.pos = target
    st.pos_known = True
    st.axis = axis


def _check_incremental_centre(
    st: _State,
    start: list[float],
    target: list[float],
    off: list[float],
    plane: tuple[int, int],
    tol: float,
    where: str,
) -> None:
    """Refuse an arc whose I/J/K, read as the default incremental offsets, put the start
    and the end at different radii while as absolute centres (G90.1) they agree: the
    controller reads them absolute, and nothing in the program says so."""
    if st.arc_abs_stated:
        return
    ia, ib = plane

    def radii(c: tuple[float, float]) -> tuple[float, float]:
        r0 = math.hypot(start[ia] - c[0], start[ib] - c[1])
        return r0, math.hypot(target[ia] - c[0], target[ib] - c[1])

    def off_by(r: tuple[float, float]) -> float:
        # arc_point_list's own tolerance on the two radii
        return abs(r[1] - r[0]) - max(0.01, 1e-3 * r[0], 2 * tol)

    inc = radii((start[ia] + off[ia], start[ib] + off[ib]))
    if off_by(inc) <= 0.0:
        return
    ab = radii((off[ia] + st.offset[ia], off[ib] + st.offset[ib]))
    if off_by(ab) <= 0.0 and ab[0] > 0.0:
        raise InputError(
            f"arc centre: expected I/J/K as offsets from the arc's start (G91.1, the default), "
            f"found radii {inc[0]:.4g} and {inc[1]:.4g} mm to its start and end; read as an "
            f"absolute centre (G90.1) both are {ab[0]:.4g} mm. The program does not say "
            "G90.1: if the machine reads arc centres absolute, set [path] arc_centres = "
            '"absolute" in the job (or add G90.1 to the program)',
            source=where,
        )


def read_gcode(path: str | Path, **options: float | bool | str) -> pd.DataFrame:
    """Read a G-code file (see :func:`parse_gcode` for ``options``)."""
    p = Path(path)
    return parse_gcode(read_text(p), p.name, **options)  # type: ignore[arg-type]


# ------------------------------------------------------------------ writer
# Controller conventions (Fanuc/Haas/LinuxCNC operator manuals; LinuxCNC's
# interpreter applies S, F and M3 of a block before its motion): a new
# spindle speed goes on a block of its own, "M3 Snnnn" (M4 where the spindle
# turns counter-clockwise), before the move it applies to; F is modal and is
# written on the motion block; no dwell is added. Changed blocks end with a
# "(ROBOLOBE ...)" comment naming the old and new values and the margin.

_SPAN = re.compile(r"([A-Za-z])(\s*=?\s*)(" + _NUM + r")")


def _code_spans(raw: str) -> tuple[list[tuple[str, int, int]], int]:
    """Words outside comments of a raw line: (upper letter, value start, value end).

    Also the index where a ``;`` comment starts (``len(raw)`` when none).
    """
    if "(" not in raw and ";" not in raw:  # the common block: no comment to skip
        return [(m.group(1).upper(), m.start(3), m.end(3)) for m in _SPAN.finditer(raw)], len(raw)
    out: list[tuple[str, int, int]] = []
    depth = 0
    start = 0
    end = len(raw)
    segments: list[tuple[int, int]] = []
    for n, ch in enumerate(raw):
        if ch == "(":
            if depth == 0:
                segments.append((start, n))
            depth += 1
        elif ch == ")":
            depth = max(depth - 1, 0)
            if depth == 0:
                start = n + 1
        elif ch == ";" and depth == 0:
            end = n
            break
    if depth == 0:
        segments.append((start, end))
    for a, b in segments:
        for m in _SPAN.finditer(raw, a, b):
            out.append((m.group(1).upper(), m.start(3), m.end(3)))
    return out, end


def _comment_at_end(raw: str, note: str) -> str:
    """``raw`` with ``(note)`` after its words (before a ``;`` comment)."""
    _, semi = _code_spans(raw)
    note = note.replace("(", "[").replace(")", "]")
    head, tail = raw[:semi].rstrip(), raw[semi:]
    return f"{head} ({note})" + (f" {tail}" if tail else "")


class _Modal(NamedTuple):
    """The modal state :func:`write_gcode` follows, as in effect after a line."""

    scale: float  # mm per program unit
    per_rev: bool  # G95: F in units per revolution
    spindle: str  # "M3" or "M4"
    absolute: bool  # G90
    arc_abs: bool  # G90.1: arc centres absolute
    motion: str  # "G0" .. "G3", "" before any


def write_gcode(text: str, source: str, edit: ProgramEdit, *, block_delete: bool = True) -> str:
    """Write a G-code program with the speeds, feeds and passes of ``edit``.

    Parameters
    ----------
    text : str
        The program as read (:func:`parse_gcode` made ``edit.waypoints`` of it).
    source : str
        Its file name (messages).
    edit : ProgramEdit
        Per move S [rpm], F [mm/min] and passes.
    block_delete : bool
        As the reader was told: blocks starting with ``/`` are not the program's.

    Returns
    -------
    str
        The new program text (line endings ``\\n``).

    Raises
    ------
    InputError
        Passes where the program is incremental (G91), arcs with absolute
        centres (G90.1) or a tool axis other than Z.
    """
    # the per-line values first: their sorting temporaries not beside the program's lines
    vals = line_values(edit)
    # per line lists (a list index per line, not a mapping lookup: a long program's time)
    has, rpm_code, rpm_values, feed_code, feed_values = vals.lists()
    secs = sections(edit)
    # their sorting temporaries given back: the program's lines below are Python objects,
    # which never reuse the freed heap (a long program's peak)
    release_free_memory(len(edit.waypoints))
    src = lines(text)
    wp_lines = edit.waypoints["line"].to_numpy()
    n = len(src)
    spans: dict[int, list[tuple[str, int, int]]] = {}  # words of lines with G/M/S/F letters
    live = bytearray(n + 2)
    sc, pr, sp, ab, aa, mo = 1.0, False, "M3", True, False, ""
    # the modal state of each line: one shared tuple per run of lines in one state
    state = _Modal(sc, pr, sp, ab, aa, mo)
    states = [state] * (n + 2)
    for ln, raw in enumerate(src, start=1):
        s = raw.strip()
        deleted = block_delete and "/" in s and re.match(r"^(N\s*\d+\s*)?/", s, re.I) is not None
        if s and s[0] != "%" and not deleted:
            live[ln] = 1
            up = s.upper()
            if "G" not in up and "M" not in up and "S" not in up and "F" not in up:
                ws: list[tuple[str, int, int]] = []  # axis words only: nothing modal
            else:
                ws, _ = _code_spans(raw)
                spans[ln] = ws
            for letter, a, b in ws:
                if letter == "G":
                    g = round(float(raw[a:b].replace(" ", "")), 1)
                    if g in (20.0, 70.0):
                        sc = 25.4
                    elif g in (21.0, 71.0):
                        sc = 1.0
                    elif g == 94.0:
                        pr = False
                    elif g == 95.0:
                        pr = True
                    elif g == 90.0:
                        ab = True
                    elif g == 91.0:
                        ab = False
                    elif g == 90.1:
                        aa = True
                    elif g == 91.1:
                        aa = False
                    elif g in (0.0, 1.0, 2.0, 3.0):
                        mo = f"G{int(g)}"
                elif letter == "M":
                    m = round(float(raw[a:b].replace(" ", "")), 1)
                    if m in (3.0, 4.0):
                        sp = f"M{int(m)}"
            if ws:
                state = _Modal(sc, pr, sp, ab, aa, mo)
        states[ln] = state
    # states[ln]: the _Modal of line ln (shared tuples: 8 bytes a line, not six lists)
    n_has = len(has)
    f_texts: dict[float, str] = {}  # fmt_num of each feed value met (a program has few)

    def f_text(ln: int) -> str:
        if not (0 <= ln < n_has and has[ln]):
            raise KeyError(ln)
        f = feed_values[feed_code[ln]] / states[ln].scale
        if states[ln].per_rev:
            f /= rpm_values[rpm_code[ln]]
        t = f_texts.get(f)
        if t is None:
            t = f_texts[f] = fmt_num(f, 6)
        return t

    def word_value(ln: int, letter: str) -> str | None:
        for let, a, b in spans.get(ln, []):
            if let == letter:
                return src[ln - 1][a:b].replace(" ", "")
        return None

    # the cutting lines, ascending (an array: not an int object per line of a long program)
    cut_lines = np.flatnonzero(np.frombuffer(has, dtype=np.uint8))
    # S and F words in the file: each governs the cutting lines up to the next such word;
    # the first cutting line it governs sets its new value
    new_word: dict[tuple[int, str], str] = {}
    for letter in ("S", "F"):
        word_lines = [ln for ln in sorted(spans) if word_value(ln, letter) is not None]
        first_cut = np.searchsorted(cut_lines, word_lines).tolist()
        for k, w in enumerate(word_lines):
            i = first_cut[k]
            nxt = word_lines[k + 1] if k + 1 < len(word_lines) else None
            if i == len(cut_lines) or (nxt is not None and cut_lines[i] >= nxt):
                continue  # no cutting line before the next such word
            c = int(cut_lines[i])
            new_word[(w, letter)] = (
                f"{int(rpm_values[rpm_code[c]])}" if letter == "S" else f_text(c)
            )
    out_lines: dict[int, str] = {}
    before: dict[int, list[str]] = {}
    notes: dict[int, list[str]] = {}
    cur_s: str | None = None
    cur_f: str | None = None
    s_texts: dict[float, str] = {}
    for ln in range(1, n + 1):
        if not live[ln]:
            continue
        raw = src[ln - 1]
        edits: list[tuple[int, int, str]] = []
        ws_ln = spans.get(ln, ())
        for letter in ("S", "F") if ws_ln else ():
            for let, a, b in ws_ln:
                if let != letter:
                    continue
                old = raw[a:b].replace(" ", "")
                new = new_word.get((ln, letter), old)
                if letter == "S":
                    cur_s = new
                else:
                    cur_f = new
                if _num_differs(old, new):
                    edits.append((a, b, new))
                    notes.setdefault(ln, []).append(f"{letter}{old}>{new}")
        cuts = ln < n_has and has[ln]
        if cuts:
            rpm = rpm_values[rpm_code[ln]]
            s_new = s_texts.get(rpm)
            if s_new is None:
                s_new = s_texts[rpm] = f"{int(rpm)}"
            if cur_s is None or _new_differs(cur_s, s_new):
                margin = vals[ln][2]
                m_txt = f" MARGIN {margin:.2f}" if math.isfinite(margin) else ""
                before.setdefault(ln, []).append(
                    f"{states[ln].spindle} S{s_new} (ROBOLOBE SPINDLE SPEED{m_txt})"
                )
                cur_s = s_new
            f_new = f_text(ln)
            if cur_f is None or _new_differs(cur_f, f_new):
                edits.append((len(raw[: _code_spans(raw)[1]].rstrip()), -1, f" F{f_new}"))
                notes.setdefault(ln, []).append(f"F{cur_f or '-'}>{f_new}")
                cur_f = f_new
        if edits:
            new_raw = raw
            for a, b, t in sorted(edits, key=lambda e: -e[0]):
                new_raw = new_raw[:a] + t + new_raw[a:] if b < 0 else new_raw[:a] + t + new_raw[b:]
            if cuts and math.isfinite(vals[ln][2]):
                notes[ln].append(f"MARGIN {vals[ln][2]:.2f}")
            out_lines[ln] = _comment_at_end(new_raw, "ROBOLOBE " + " ".join(notes[ln]))
    # passes: copies of each section's lines, shifted along Z, with rapid links
    # (n, 3) positions only where there are passes to write (a long program's peak)
    pos_mm = (
        edit.waypoints[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
        if secs
        else np.empty((0, 3))
    )
    for sec in secs:
        first, last = int(wp_lines[sec.start]), int(wp_lines[sec.stop - 1])
        where = f"{source}:{first}"
        if abs(sec.axis[2] - 1.0) > 1e-9:
            raise InputError(
                "passes in G-code are written along Z; this section's tool axis is "
                f"{[round(v, 6) for v in sec.axis]}",
                source=where,
            )
        for ln in range(first, last + 1):
            if not states[ln].absolute or (ln > 1 and not states[ln - 1].absolute):
                raise InputError(
                    "passes need absolute coordinates (G90); the section is incremental (G91)",
                    source=f"{source}:{ln}",
                )
            if states[ln].arc_abs:
                raise InputError(
                    "passes with absolute arc centres (G90.1) are not written", f"{source}:{ln}"
                )
        block: list[str] = []
        sc0 = states[first].scale
        restate_s = (
            f"{states[first].spindle} S{int(vals[first][0])} "
            "(ROBOLOBE SPINDLE SPEED AT THE PASS START)"
        )
        for ps in pass_layout(edit, sec, pos_mm):
            for p, _ in ps.links:
                block.append(
                    f"G0 X{fmt_num(p[0] / sc0, 8)} Y{fmt_num(p[1] / sc0, 8)} "
                    f"Z{fmt_num(p[2] / sc0, 8)} (ROBOLOBE LINK TO PASS {ps.index} OF {ps.count})"
                )
            if ps.restate:
                block.append(restate_s)
            if ps.own:
                break
            off = ps.offset_mm
            block.append(
                f"(ROBOLOBE PASS {ps.index} OF {ps.count}: {fmt_num(off, 4)} MM ABOVE THE "
                f"PROGRAMMED DEPTH, {fmt_num(sec.depth_mm / ps.count, 4)} MM PER PASS)"
            )
            for ln in range(first, last + 1):
                raw = out_lines.get(ln, src[ln - 1])
                block.extend(before.get(ln, []))
                z_end = pos_mm[sec.start, 2] / states[ln].scale + off / states[ln].scale
                block.append(
                    _pass_copy(raw, off / states[ln].scale, z_end if ln == first else None,
                               states[ln].motion, f_text(first))
                )  # fmt: skip
        # the program's own pass: its first block states motion and feed (links changed them)
        raw = out_lines.get(first, src[first - 1])
        raw = _state_first(raw, states[first].motion, f_text(first))
        out_lines[first] = raw
        before.setdefault(first, [])[0:0] = block
    # the source's lines, edited, with the inserted blocks before theirs
    for ln, t in out_lines.items():
        if 1 <= ln <= n:
            src[ln - 1] = t
    inserts = sorted(k for k in before if 1 <= k <= n)
    if inserts:
        result: list[str] = []
        at = 0
        for ln in inserts:
            result.extend(src[at : ln - 1])
            result.extend(before[ln])
            at = ln - 1
        result.extend(src[at:])
        src = result
    src.append("")  # the last line's end (not a copy of the joined text with it)
    return "\n".join(src)


_MOTION_TEXT = {"0", "00", "1", "01", "2", "02", "3", "03", "0.", "1.", "2.", "3."}


def _num_differs(a: str, b: str) -> bool:
    return float(a) != float(b)


def _new_differs(cur: str, new: str) -> bool:
    """:func:`_num_differs` where ``new`` is the writer's own number text (fast when equal).

    Equal texts differ only as NaN (``fmt_num`` writes NaN as ``"nan"``).
    """
    if cur == new:
        return new == "nan"
    return float(cur) != float(new)


def _prefix(raw: str, word: str) -> str:
    """``raw`` with ``word`` before its first word after a line number."""
    m = re.match(r"^(\s*(?:[Nn]\s*\d+\s*)?)", raw)
    k = m.end() if m else 0
    return raw[:k] + word + " " + raw[k:]


def _has_word(raw: str, letter: str, values: set[str] | None = None) -> bool:
    ws, _ = _code_spans(raw)
    return any(
        w[0] == letter and (values is None or raw[w[1] : w[2]].strip() in values) for w in ws
    )


def _state_first(raw: str, motion: str, f: str) -> str:
    """The first block of a pass with its motion word and F stated."""
    if not _has_word(raw, "F"):
        raw = _comment_free_append(raw, f" F{f}")
    if not _has_word(raw, "G", _MOTION_TEXT):
        raw = _prefix(raw, motion)
    return raw


def _pass_copy(raw: str, off_units: float, z_first: float | None, motion: str, f: str) -> str:
    """A copy of a section's block for a shallower pass: Z raised, no line number.

    ``z_first``: the first block's end Z [program units] (stated with its
    motion word and F: the link before it was a rapid and the pass before
    it ended with another feed).
    """
    ws, _ = _code_spans(raw)
    out = raw
    has_z = False
    for letter, a, b in sorted(ws, key=lambda w: -w[1]):
        if letter == "Z":
            has_z = True
            out = out[:a] + fmt_num(float(raw[a:b].replace(" ", "")) + off_units, 8) + out[b:]
    out = re.sub(r"^\s*[Nn]\s*\d+\s*", "", out)
    if z_first is not None:
        if not has_z:
            out = _comment_free_append(out, f" Z{fmt_num(z_first, 8)}")
        out = _state_first(out, motion, f)
    return out


def _comment_free_append(raw: str, words: str) -> str:
    _, semi = _code_spans(raw)
    # before a trailing (comment): words after a comment are still words, but keep it tidy
    head = raw[:semi].rstrip()
    return head + words + raw[semi:]


# ------------------------------------------------------------------ translation
def gcode_setup(text: str, *, block_delete: bool = True) -> tuple[set[str], list[str]]:
    """The spindle directions (``"M3"``, ``"M4"``) and tool numbers (``T`` words) a program uses."""
    directions: set[str] = set()
    tools: list[str] = []
    for raw in lines(text):
        s = raw.strip()
        if not s or s[0] == "%" or (block_delete and re.match(r"^(N\s*\d+\s*)?/", s, re.I)):
            continue
        ws, _ = _code_spans(raw)
        for letter, a, b in ws:
            v = raw[a:b].replace(" ", "")
            if letter == "M" and float(v) in (3.0, 4.0):
                directions.add(f"M{int(float(v))}")
            elif letter == "T" and v not in tools:
                tools.append(v)
    return directions, tools


def translate_gcode(
    table: pd.DataFrame, source: str, *, spindle: str, tool: str | None, note: list[str]
) -> str:
    """A G-code program (mm, absolute, three axes) of a waypoint table, a translation.

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`~robolobe.plan.paths._edit.expected_table` with ``full``.
    source : str
        The program translated (messages).
    spindle : {"M3", "M4"}
        The spindle's direction.
    tool : str, optional
        The tool number (``T.. M6`` at the start).
    note : list of str
        Comment lines for the head (what was translated, what was not).

    Raises
    ------
    InputError
        A move whose tool axis is not +Z (G-code is written for three axes here).
    """
    ax = table[["i", "j", "k"]].to_numpy(dtype=np.float64)
    off = np.max(np.abs(ax - np.array([0.0, 0.0, 1.0])), axis=1) > 1e-9
    if np.any(off):
        r = int(np.argmax(off))
        raise InputError(
            "a translation to G-code is written for three axes (tool axis +Z); the tool axis "
            f"here is {[round(float(v), 6) for v in ax[r]]}: write APT or a waypoint table",
            source=f"{table['source'].iloc[r]}:{table['line'].iloc[r]}",
        )
    out = ["%", *(f"({t.replace('(', '[').replace(')', ']').upper()})" for t in note)]
    out.append("G21 G90 G94 G17 G40")
    if tool is not None:
        out.append(f"T{tool} M6")
    f_new: str | None = None
    mode = ""
    for rec in cl_records(table):
        if rec.kind == "spindle":
            out.append(f"{spindle} S{fmt_num(rec.value, 0, point=False)}")
        elif rec.kind == "feed":
            f_new = fmt_num(rec.value, 6)
        else:
            g = "G1" if rec.kind == "cut" else "G0"
            words = [g] if g != mode else []
            mode = g
            words += [f"{k}{fmt_num(v, 8)}" for k, v in zip("XYZ", rec.xyz, strict=True)]
            if g == "G1" and f_new is not None:
                words.append(f"F{f_new}")
                f_new = None
            out.append(" ".join(words))
    out += ["M5", "M30", "%"]
    return "\n".join(out) + "\n"
