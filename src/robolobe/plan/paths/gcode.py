"""G-code (ISO 6983 word-address) reader with modal state.

Supported (Fanuc/Haas/Siemens-ISO style milling programs as CAM posts write them):

- comments ``( ... )`` and ``;`` to the end of the line, ``%`` lines, program
  numbers ``O1234`` / ``:1234``, line numbers ``N10``, block delete ``/``
  (those blocks are skipped unless ``block_delete=False``), several words
  per block with or without spaces (``G0G90X0.Y-12.5``), numbers like
  ``X0.``, ``X.5``, ``X+10``; lower case.
- motion G0 (rapid), G1, G2/G3 (arcs by I/J/K centre offsets, incremental
  unless G90.1, or by R, R < 0 for more than half a turn; full circles;
  helical), linearised within ``arc_tol_mm``; planes G17/G18/G19;
  G90/G91; G20/G21 (G70/G71 too); G94 feed per minute, G95 per revolution;
  F, S, M3/M4/M5, M30/M2 (end).
- 5-axis: I/J/K words in a G0/G1 block are the tool axis vector (tip to
  spindle, normalised); rotary words A/B/C (degrees) give the tool axis
  ``Rz(C) @ Ry(B) @ Rx(A) @ [0, 0, 1]`` (head kinematics, angles as
  programmed); a program uses one or the other.
- ignored on purpose: G4 dwell, G10, G15, G40, G43/G43.4/G49, G54-G59.9,
  G61/G64, G80, G98/G99, G5.1, G17.1; T, H, D words; M words other than
  the ones above; G28/G30/G53 (moves to a machine reference: they leave the
  path, which resumes at the next move; their G91/G90 words still count).

Anything else (macros ``#``, expressions ``[ ]``, ``IF``/``GOTO``/``WHILE``,
canned cycles G81-G89, cutter compensation G41/G42, inverse-time feed G93,
polar/rotated coordinates G16/G68, subprograms M98, Heidenhain conversational)
raises :class:`~robolobe.errors.InputError` naming ``file:line``.
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_points
from robolobe.plan.paths._table import WaypointBuilder

__all__ = ["parse_gcode", "read_gcode"]

logger = logging.getLogger(__name__)

_WORD = re.compile(r"([A-Z])\s*=?\s*([+-]?\s*(?:\d+\.?\d*|\.\d+))")
_UNSUPPORTED_TEXT = (
    ("#", "macro variables (#)"),
    ("[", "expressions ([ ])"),
    ("BEGIN PGM", "Heidenhain conversational programs (post the path as ISO G-code)"),
    ("TRAORI", "Siemens TRAORI (post the path with tool vectors or A/B/C words)"),
    ("CYCLE", "Siemens cycles"),
)
_UNSUPPORTED_KEYWORDS = re.compile(r"\b(IF|GOTO|WHILE|DO|END\d|THEN|ELSE|ENDIF|REPEAT)\b")

# G codes accepted without effect on the geometry
_G_IGNORED = {4.0, 5.1, 10.0, 15.0, 17.1, 40.0, 43.0, 43.4, 44.0, 49.0, 61.0, 61.1, 64.0, 80.0}
_G_IGNORED |= {98.0, 99.0, 54.1} | {float(g) for g in range(54, 60)}
_G_UNSUPPORTED = {
    41.0: "cutter radius compensation G41 (post the path with compensation applied)",
    42.0: "cutter radius compensation G42 (post the path with compensation applied)",
    93.0: "inverse-time feed G93",
    16.0: "polar coordinates G16",
    68.0: "coordinate rotation G68",
    68.2: "tilted working plane G68.2",
    51.0: "scaling G51",
    51.1: "mirroring G51.1",
    65.0: "macro call G65",
    66.0: "macro call G66",
}
_G_UNSUPPORTED |= {float(g): f"canned cycle G{g}" for g in range(73, 90) if g != 80}


@dataclass
class _State:
    motion: int | None = None
    plane: int = 17
    absolute: bool = True
    arc_abs: bool = False
    scale: float = 1.0  # mm per program unit
    per_rev: bool = False
    feed: float = math.nan  # program units per min (or per rev)
    rpm: float = math.nan
    spindle_on: bool = False
    pos: np.ndarray = field(default_factory=lambda: np.zeros(3))  # mm
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    rot_deg: np.ndarray = field(default_factory=lambda: np.zeros(3))
    vector_mode: str | None = None  # "ijk" | "abc"


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


def _tokenize(text: str, where: str) -> list[tuple[str, float, str]]:
    """Words of one block (comments already removed): (letter, value, raw)."""
    s = text.upper()
    for needle, what in _UNSUPPORTED_TEXT:
        if needle in s:
            raise InputError(f"unsupported construct: {what}", source=where)
    m = _UNSUPPORTED_KEYWORDS.search(s)
    if m:
        raise InputError(f"unsupported construct: control flow {m.group(1)!r}", source=where)
    words: list[tuple[str, float, str]] = []
    pos = 0
    for mt in _WORD.finditer(s):
        gap = s[pos : mt.start()]
        if gap.strip():
            raise InputError(f"expected address words like X10.5, found {gap.strip()!r}", where)
        num = mt.group(2).replace(" ", "")
        words.append((mt.group(1), float(num), num))
        pos = mt.end()
    rest = s[pos:]
    if rest.strip():
        raise InputError(f"expected address words like X10.5, found {rest.strip()!r}", where)
    return words


def parse_gcode(
    text: str,
    source: str = "<gcode>",
    *,
    arc_tol_mm: float = 0.01,
    block_delete: bool = True,
    default_units: str = "mm",
    no_decimal_scale: float = 1.0,
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
    default_units : {"mm", "inch"}
        Units before any G20/G21.
    no_decimal_scale : float
        Factor for axis words written without a decimal point (1: ``X10`` is
        10 units; 0.001: classic Fanuc, ``X10`` is 0.010 mm).

    Returns
    -------
    pandas.DataFrame
        The waypoint table (:mod:`robolobe.plan.paths._table`).

    Raises
    ------
    InputError
        Unsupported or malformed constructs, naming ``source:line``.
    """
    if default_units not in ("mm", "inch"):
        raise InputError(f"default_units: expected 'mm' or 'inch', found {default_units!r}")
    st = _State(scale=1.0 if default_units == "mm" else 25.4)
    out = WaypointBuilder(source)
    for lineno, raw in enumerate(text.splitlines(), start=1):
        where = f"{source}:{lineno}"
        line = raw.strip()
        if not line or line.startswith("%"):
            continue
        line = _strip_comments(line, where).strip()
        if not line:
            continue
        # block delete may follow a line number: "N10 /G1 ..."
        m = re.match(r"^(N\s*\d+\s*)?/", line, flags=re.IGNORECASE)
        if m:
            if block_delete:
                continue
            line = line[m.end() :]
        upper = line.upper().lstrip()
        if re.match(r"^(O\s*\d+|:\s*\d+)", upper):  # program number (maybe with a name)
            upper = re.sub(r"^(O\s*\d+|:\s*\d+)", "", upper).strip()
            if not upper:
                continue
        words = _tokenize(upper, where)
        if not words:
            continue
        if _block(words, st, out, where, lineno, arc_tol_mm, no_decimal_scale):
            break
    return out.table()


def _axis_from_abc(abc_deg: np.ndarray) -> np.ndarray:
    a, b, c = np.radians(abc_deg)
    ca, sa, cb, sb, cc, sc = (
        math.cos(a),
        math.sin(a),
        math.cos(b),
        math.sin(b),
        math.cos(c),
        math.sin(c),
    )
    # Rz(c) Ry(b) Rx(a) @ ez
    v = np.array([sb * ca * cc + sa * sc, sb * ca * sc - sa * cc, cb * ca])
    return v


def _block(
    words: list[tuple[str, float, str]],
    st: _State,
    out: WaypointBuilder,
    where: str,
    lineno: int,
    arc_tol: float,
    nodec: float,
) -> bool:
    """Apply one block; return True at program end."""
    g_codes: list[float] = []
    m_codes: list[float] = []
    vals: dict[str, float] = {}
    for letter, value, raw in words:
        if letter == "G":
            g_codes.append(round(value, 1))
        elif letter == "M":
            m_codes.append(round(value, 1))
        elif letter == "N":
            continue
        else:
            if letter in vals:
                raise InputError(f"word {letter} appears twice in the block", source=where)
            if letter in "XYZIJKR" and "." not in raw:
                value *= nodec
            vals[letter] = value
    # --- G words
    dwell = False
    home = False
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
        elif g == 91.1:
            st.arc_abs = False
        elif g in (20.0, 70.0):
            st.scale = 25.4
        elif g in (21.0, 71.0):
            st.scale = 1.0
        elif g == 94.0:
            st.per_rev = False
        elif g == 95.0:
            st.per_rev = True
        elif g in (28.0, 30.0, 53.0):
            home = True
        elif g == 4.0:
            dwell = True
        elif g in _G_IGNORED:
            continue
        elif g in _G_UNSUPPORTED:
            raise InputError(f"unsupported construct: {_G_UNSUPPORTED[g]}", source=where)
        else:
            raise InputError(f"unsupported G code G{g:g}", source=where)
    # --- M words
    end = False
    for mc in m_codes:
        if mc in (3.0, 4.0):
            st.spindle_on = True
            if mc == 4.0:
                logger.warning("%s: M4 (counter-clockwise spindle) planned as M3", where)
        elif mc == 5.0:
            st.spindle_on = False
        elif mc in (2.0, 30.0):
            end = True
        elif mc in (98.0, 99.0, 97.0):
            raise InputError(f"unsupported construct: subprogram M{mc:g}", source=where)
    if "F" in vals:
        st.feed = vals.pop("F")
    if "S" in vals:
        st.rpm = vals.pop("S")
    for bad in ("L", "E"):
        if bad in vals:
            raise InputError(f"unsupported word {bad} (repeat count / extruder)", source=where)
    for ignored in ("T", "H", "D", "P", "Q"):
        vals.pop(ignored, None)
    if dwell:
        return end
    for bad in ("U", "V", "W"):
        if bad in vals:
            raise InputError(f"unsupported axis word {bad} (only X Y Z A B C)", source=where)
    moving = any(k in vals for k in "XYZABC") or (
        st.motion is not None and any(k in vals for k in "IJKR")
    )
    if home:  # leaves the path for a machine reference; the next absolute move resumes it
        return end
    if not moving:
        if "R" in vals or any(k in vals for k in "IJK"):
            raise InputError("arc words I/J/K/R without an arc move", source=where)
        return end
    if st.motion is None:
        raise InputError("axis words before any motion mode (G0/G1/G2/G3)", source=where)
    target = _target(vals, st)
    axis = st.axis
    if any(k in vals for k in "ABC"):
        if st.vector_mode == "ijk":
            raise InputError("rotary words A/B/C in a program that uses I/J/K tool vectors", where)
        st.vector_mode = "abc"
        for n, k in enumerate("ABC"):
            if k in vals:
                st.rot_deg[n] = vals[k] if st.absolute else st.rot_deg[n] + vals[k]
        axis = _axis_from_abc(st.rot_deg)
    if st.motion in (0, 1):
        if any(k in vals for k in "IJK"):
            if st.vector_mode == "abc":
                raise InputError("I/J/K tool vectors in a program that uses A/B/C words", where)
            st.vector_mode = "ijk"
            v = np.array([vals.get("I", 0.0), vals.get("J", 0.0), vals.get("K", 0.0)])
            if np.linalg.norm(v) < 1e-9:
                raise InputError("I/J/K tool vector of zero length", source=where)
            axis = v / np.linalg.norm(v)
        if "R" in vals:
            raise InputError("word R in a linear move", source=where)
        _emit_line(st, out, target, axis, lineno, rapid=st.motion == 0)
    else:
        _emit_arc(vals, st, out, target, axis, lineno, arc_tol, where)
    return end


def _target(vals: dict[str, float], st: _State) -> np.ndarray:
    t = st.pos.copy()
    for n, k in enumerate("XYZ"):
        if k in vals:
            v = vals[k] * st.scale
            t[n] = v if st.absolute else t[n] + v
    return t


def _feed_mm_per_min(st: _State) -> float:
    if math.isnan(st.feed):
        return math.nan
    f = st.feed * st.scale
    if st.per_rev:
        return f * st.rpm if st.spindle_on and not math.isnan(st.rpm) else math.nan
    return f


def _emit_line(
    st: _State, out: WaypointBuilder, target: np.ndarray, axis: np.ndarray, lineno: int, rapid: bool
) -> None:
    rpm = st.rpm if st.spindle_on else math.nan
    out.add(
        target * 1e-3,
        axis,
        line=lineno,
        rapid=rapid,
        feed_mm_per_min=math.nan if rapid else _feed_mm_per_min(st),
        rpm=rpm,
    )
    st.pos = target
    st.axis = axis


_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


def _emit_arc(
    vals: dict[str, float],
    st: _State,
    out: WaypointBuilder,
    target: np.ndarray,
    axis: np.ndarray,
    lineno: int,
    tol: float,
    where: str,
) -> None:
    ia, ib, ic = _PLANES[st.plane]
    normal = np.zeros(3)
    normal[ic] = 1.0
    start = st.pos
    cw = st.motion == 2
    if "R" in vals:
        if any(k in vals for k in "IJK"):
            raise InputError("arc with both R and I/J/K", source=where)
        r = vals["R"] * st.scale
        d = np.array([target[ia] - start[ia], target[ib] - start[ib]])
        chord = float(np.linalg.norm(d))
        if chord < 1e-9:
            raise InputError("R-form arc with coincident start and end", source=where)
        if chord > 2 * abs(r) * (1 + 1e-6) + 1e-3:
            raise InputError(
                f"arc radius R{abs(r):g} too small for a chord of {chord:.4g}", source=where
            )
        h = math.sqrt(max(r * r - chord * chord / 4, 0.0))
        mid = (np.array([start[ia], start[ib]]) + np.array([target[ia], target[ib]])) / 2
        perp = np.array([-d[1], d[0]]) / chord  # left of the chord (CCW side)
        # CW with a short arc (R > 0): centre to the right of the chord
        sign = (-1.0 if cw else 1.0) * (1.0 if r > 0 else -1.0)
        c2 = mid + sign * h * perp
        centre = start.copy()
        centre[ia], centre[ib] = c2
        full = False
    else:
        off = np.array([vals.get("I", 0.0), vals.get("J", 0.0), vals.get("K", 0.0)]) * st.scale
        if st.arc_abs:
            centre = start.copy()
            for n, k in enumerate("IJK"):
                if k in vals:
                    centre[n] = off[n]
        else:
            centre = start + off
        if not any(k in vals for k in "IJK"):
            raise InputError("arc without I/J/K or R", source=where)
        full = True
    centre[ic] = start[ic]
    pts = arc_points(
        start, target, centre, normal, clockwise=cw, tol=tol, full_circle=full, where=where
    )
    feed = _feed_mm_per_min(st)
    rpm = st.rpm if st.spindle_on else math.nan
    for p in pts:
        out.add(p * 1e-3, axis, line=lineno, rapid=False, feed_mm_per_min=feed, rpm=rpm)
    st.pos = target
    st.axis = axis


def read_gcode(path: str | Path, **options: float | bool | str) -> pd.DataFrame:
    """Read a G-code file (see :func:`parse_gcode` for ``options``)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8", errors="strict")
    except UnicodeDecodeError:
        text = p.read_text(encoding="latin-1")
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc}", source=str(p)) from None
    return parse_gcode(text, p.name, **options)  # type: ignore[arg-type]
