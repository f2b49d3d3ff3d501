"""KUKA KRL reader (``.src`` with its ``.dat``).

Positions are aggregates ``{X 100, Y 20, Z 5, A 0, B 90, C 0}`` in mm and
degrees, A/B/C the ZYX Euler angles of the tool frame (``R = Rz(A) Ry(B)
Rx(C)``), given in the active base, which is the workpiece (path) frame.
KUKA's tool convention makes the tool **X** axis the working direction
(spindle to tip), so the tool axis (tip to spindle) is ``-x_tool``; with
``tool_direction="z"`` the tool Z axis is taken instead (frames defined the
ABB/RoboDK way). The TCP x axis the planner uses is the tool frame's next
axis (``y_tool`` for X, ``x_tool`` for Z), so ``z_tcp = working direction``.

Supported: ``LIN``, ``SLIN``, ``LIN_REL`` (base frame), ``CIRC``/``SCIRC``
(auxiliary and end point), ``PTP``/``SPTP``/``PTP_REL`` (rapid), targets as
aggregates (partial aggregates keep the other components), ``E6POS``/
``POS``/``FRAME`` variables declared in the ``.src`` or the ``.dat`` beside
it (``DECL E6POS XP1={...}``, ``E6POS P2={...}``), approximation words
``C_DIS``/``C_VEL``/``C_ORI``/``C_PTP``, ``$VEL.CP = 0.2`` (m/s),
``$VEL = {CP 0.2, ...}``, ``BAS(#CP_PARAMS, v)`` / ``BAS(#VEL_CP, v)``
(inline forms, m/s), ``;`` comments and folds, ``&`` header lines, ``DEF``/
``END``/``DEFDAT``/``ENDDAT``, ``SPLINE``/``ENDSPLINE`` brackets.

Ignored on purpose: other ``$`` system variables (``$APO``, ``$ACC``,
``$BASE``, ``$TOOL``, ``$OUT``, ``$ANOUT``, ...; the path is taken in the
active base), other ``BAS`` calls, ``DECL`` of other types, ``WAIT``,
``HALT``, ``INTERRUPT``, ``TRIGGER``, assignments to plain variables, PTP
to axis-specific targets (``{A1 0, ...}``, ``HOME``; they leave the
Cartesian path, which resumes at the next absolute target). Calls of other
subprograms ``NAME(...)`` are ignored with a warning (their motions are not
followed).

Control flow (``IF``, ``FOR``, ``WHILE``, ``LOOP``, ``REPEAT``, ``SWITCH``,
``GOTO``), ``CIRC`` with ``CA``, relative moves in the tool frame and
expressions in targets raise :class:`~robolobe.errors.InputError` with
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
from robolobe.plan.paths._arcs import arc_through
from robolobe.plan.paths._table import WaypointBuilder
from robolobe.robots.transforms import rotation_from_zyx

__all__ = ["parse_krl", "read_krl"]

logger = logging.getLogger(__name__)

_POS_KEYS = ("X", "Y", "Z", "A", "B", "C")
_CONTROL = re.compile(
    r"^(IF|ELSE|ENDIF|FOR|ENDFOR|WHILE|ENDWHILE|LOOP|ENDLOOP|REPEAT|UNTIL|SWITCH|CASE|"
    r"DEFAULT|ENDSWITCH|GOTO|EXIT|RETURN)\b"
)
_IGNORED = re.compile(
    r"^(WAIT|HALT|INTERRUPT|TRIGGER|CONTINUE|BRAKE|RESUME|PULSE|ANIN|ANOUT|EXT|EXTFCT|"
    r"GLOBAL|PUBLIC|SIGNAL|CHANNEL|CONST)\b"
)
_MOTION = re.compile(r"^(LIN_REL|PTP_REL|LIN|SLIN|PTP|SPTP|CIRC|SCIRC)\b\s*(.*)$")
_APPROX = re.compile(r"\s+(C_DIS|C_VEL|C_ORI|C_PTP|C_SPL)\s*$")


def _strip(line: str) -> str:
    cut = line.find(";")
    return line[:cut] if cut >= 0 else line


def _aggregate(text: str, where: str) -> dict[str, float | None]:
    """Parse ``{[TYPE:] K v, K v, ...}``; non-numeric values (S 'B110') become None."""
    t = text.strip()
    if not (t.startswith("{") and t.endswith("}")):
        raise InputError(f"expected an aggregate {{X 1, Y 2, ...}}, found {text.strip()!r}", where)
    body = t[1:-1].strip()
    if ":" in body.split(",")[0]:
        body = body.split(":", 1)[1]
    out: dict[str, float | None] = {}
    if not body.strip():
        return out
    for part in body.split(","):
        m = re.match(r"^\s*([A-Z_][A-Z0-9_]*)\s+(.+?)\s*$", part.strip().upper())
        if not m:
            raise InputError(
                f"expected 'KEY value' in the aggregate, found {part.strip()!r}", where
            )
        key, val = m.group(1), m.group(2)
        try:
            out[key] = float(val)
        except ValueError:
            if key in _POS_KEYS:
                raise InputError(
                    f"unsupported construct: expression {val!r} for {key} in a target", where
                ) from None
            out[key] = None
    return out


def _tool_axes(abc_deg: np.ndarray, tool_direction: str) -> tuple[np.ndarray, np.ndarray]:
    rot = rotation_from_zyx(np.radians(abc_deg))
    if tool_direction == "x":
        work, ref = rot[:, 0], rot[:, 1]
    else:
        work, ref = rot[:, 2], rot[:, 0]
    return -work, ref


class _Reader:
    def __init__(self, source: str, tool_direction: str, arc_tol_mm: float) -> None:
        self.source = source
        self.tool_direction = tool_direction
        self.tol = arc_tol_mm
        self.vars: dict[str, dict[str, float | None]] = {}
        self.pose: np.ndarray | None = None  # X Y Z A B C (mm, deg)
        self.vel_m_per_s = math.nan
        self.out = WaypointBuilder(source)

    # ------------------------------------------------------------ helpers
    def declare(self, stmt: str, where: str) -> bool:
        """Handle declarations/assignments of position variables; True if handled."""
        m = re.match(
            r"^(?:DECL\s+)?(?:GLOBAL\s+)?(E6POS|POS|FRAME|E6AXIS|AXIS)\s+([A-Z_][A-Z0-9_]*)\s*(=\s*(.*))?$",
            stmt,
        )
        if m:
            typ, name, _, value = m.groups()
            agg = _aggregate(value, where) if value is not None else {}
            self.vars[name] = {"__axis__": 1.0} if typ in ("E6AXIS", "AXIS") else agg
            return True
        if stmt.startswith("DECL "):
            return True  # other declarations (INT, REAL, LDAT, FDAT, ...)
        m = re.match(r"^([A-Z_][A-Z0-9_]*)\s*=\s*(\{.*\})$", stmt)
        if m and m.group(1) in self.vars:
            if "__axis__" not in self.vars[m.group(1)]:
                self.vars[m.group(1)] = _aggregate(m.group(2), where)
            return True
        return False

    def target(self, text: str, where: str, *, relative: bool = False) -> np.ndarray | None:
        """Absolute target X..C, or None for an axis-specific target."""
        t = text.strip()
        if t.startswith("{"):
            agg = _aggregate(t, where)
        else:
            name = t.split()[0] if t else ""
            if name not in self.vars:
                if name in ("HOME", "XHOME", "$H_POS", "$POS_ACT") or name.startswith("XHOME"):
                    return None
                raise InputError(f"unknown position variable {name!r}", source=where)
            agg = self.vars[name]
        if "__axis__" in agg or any(k.startswith("A") and k[1:].isdigit() for k in agg):
            return None
        vals = {k: v for k, v in agg.items() if k in _POS_KEYS and v is not None}
        if relative:
            if self.pose is None:
                raise InputError("relative move before any absolute position", source=where)
            new = self.pose.copy()
            for n, k in enumerate(_POS_KEYS):
                if k in vals:
                    new[n] += vals[k]
            return new
        if self.pose is None:
            missing = [k for k in _POS_KEYS if k not in vals]
            if missing:
                raise InputError(
                    f"first Cartesian target must give X, Y, Z, A, B, C; missing {missing}", where
                )
            return np.array([vals[k] for k in _POS_KEYS])
        new = self.pose.copy()
        for n, k in enumerate(_POS_KEYS):
            if k in vals:
                new[n] = vals[k]
        return new

    def emit(self, pose: np.ndarray, lineno: int, rapid: bool) -> None:
        axis, ref = _tool_axes(pose[3:], self.tool_direction)
        feed = math.nan if rapid else self.vel_m_per_s * 6e4
        self.out.add(pose[:3] * 1e-3, axis, line=lineno, rapid=rapid, feed_mm_per_min=feed, ref=ref)
        self.pose = pose

    # ------------------------------------------------------------- statements
    def statement(self, stmt: str, lineno: int, in_dat: bool) -> None:
        where = f"{self.source}:{lineno}"
        s = stmt.strip().upper()
        if not s or s.startswith("&"):
            return
        if re.match(r"^(GLOBAL\s+)?(DEF|DEFDAT|END|ENDDAT|ENDFCT|SPLINE|ENDSPLINE)\b", s):
            if s.startswith(("DEFFCT", "GLOBAL DEFFCT")):
                raise InputError("unsupported construct: function definitions DEFFCT", where)
            return
        if s.startswith("DEFFCT"):
            raise InputError("unsupported construct: function definitions DEFFCT", where)
        if self.declare(s, where):
            return
        if in_dat:
            return  # other data in a .dat file
        m = _CONTROL.match(s)
        if m:
            raise InputError(f"unsupported construct: control flow {m.group(1)}", source=where)
        if s.startswith("$"):
            self.system_var(s, where)
            return
        if s.startswith("BAS"):
            m = re.match(r"^BAS\s*\(\s*#(CP_PARAMS|VEL_CP)\s*,\s*([-+0-9.E]+)\s*\)$", s)
            if m:
                self.vel_m_per_s = float(m.group(2))
            return
        if _IGNORED.match(s):
            return
        m = _MOTION.match(s)
        if m:
            self.motion(m.group(1), m.group(2), lineno, where)
            return
        m = re.match(r"^([A-Z_][A-Z0-9_]*)\s*\(.*\)$", s)
        if m:
            logger.warning(
                "%s: call to %s ignored (its motions are not followed)", where, m.group(1)
            )
            return
        if re.match(r"^[A-Z_][A-Z0-9_.\[\]]*\s*=", s):
            return  # assignment to a plain variable (LDAT_ACT=..., counters)
        raise InputError(f"unsupported KRL statement {stmt.strip()!r}", source=where)

    def system_var(self, s: str, where: str) -> None:
        m = re.match(r"^\$VEL\.CP\s*=\s*(.+)$", s)
        if m:
            try:
                self.vel_m_per_s = float(m.group(1))
            except ValueError:
                raise InputError(
                    f"unsupported construct: expression {m.group(1)!r} for $VEL.CP", where
                ) from None
            return
        m = re.match(r"^\$VEL\s*=\s*(\{.*\})$", s)
        if m:
            agg = _aggregate(m.group(1), where)
            if agg.get("CP") is not None:
                self.vel_m_per_s = float(agg["CP"])  # type: ignore[arg-type]
            return
        if s.startswith(("$BASE", "$TOOL")):
            logger.info("%s: %s not applied (the path is taken in the active base)", where, s[:5])

    def motion(self, word: str, rest: str, lineno: int, where: str) -> None:
        rest = _APPROX.sub("", rest).strip()
        rapid = word in ("PTP", "SPTP", "PTP_REL")
        if word in ("CIRC", "SCIRC"):
            if re.search(r"\bCA\b", rest):
                raise InputError("unsupported construct: CIRC with circular angle CA", where)
            parts = _split_top(rest)
            if len(parts) != 2:
                raise InputError(f"CIRC: expected auxiliary and end point, found {rest!r}", where)
            aux = self.target(parts[0], where)
            end = self.target(parts[1], where)
            if aux is None or end is None or self.pose is None:
                raise InputError("CIRC needs Cartesian points after a known position", where)
            pts = arc_through(self.pose[:3], aux[:3], end[:3], tol=self.tol, where=where)
            for p in pts[:-1]:
                self.emit(np.concatenate([p, end[3:]]), lineno, rapid=False)
            self.emit(end, lineno, rapid=False)
            return
        if "#TOOL" in rest:
            raise InputError(
                "unsupported construct: relative move in the tool frame (#TOOL)", where
            )
        rest = re.sub(r",?\s*#BASE\s*$", "", rest).strip()
        tgt = self.target(rest, where, relative=word.endswith("_REL"))
        if tgt is None:
            if not rapid:
                raise InputError("LIN to an axis-specific target has no Cartesian position", where)
            logger.info("%s: PTP to an axis-specific target left out of the path", where)
            return
        self.emit(tgt, lineno, rapid=rapid)


def _split_top(text: str) -> list[str]:
    """Split at commas outside braces."""
    parts: list[str] = []
    cur: list[str] = []
    depth = 0
    for ch in text:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append("".join(cur).strip())
            cur = []
        else:
            cur.append(ch)
    if "".join(cur).strip():
        parts.append("".join(cur).strip())
    return parts


def _lines(text: str) -> list[tuple[int, str]]:
    out = []
    for lineno, raw in enumerate(text.splitlines(), start=1):
        s = _strip(raw).strip()
        if s:
            out.append((lineno, s))
    return out


def parse_krl(
    text: str,
    source: str = "<krl>",
    *,
    dat: str | None = None,
    tool_direction: str = "x",
    arc_tol_mm: float = 0.01,
) -> pd.DataFrame:
    """Read KRL text into the waypoint table.

    Parameters
    ----------
    text : str
        The ``.src`` program.
    source : str
        File name for the ``source`` column and messages.
    dat : str, optional
        Text of the matching ``.dat`` file (position variables).
    tool_direction : {"x", "z"}
        Tool frame axis along the working direction (KUKA default: x).
    arc_tol_mm : float
        Chord tolerance of linearised arcs [mm].

    Returns
    -------
    pandas.DataFrame
        The waypoint table.

    Raises
    ------
    InputError
        Unsupported or malformed statements, naming ``source:line``.
    """
    if tool_direction not in ("x", "z"):
        raise InputError(f"tool_direction: expected 'x' or 'z', found {tool_direction!r}")
    rd = _Reader(source, tool_direction, arc_tol_mm)
    if dat is not None:
        dat_name = re.sub(r"\.src$", ".dat", source, flags=re.IGNORECASE)
        rd_dat = _Reader(dat_name, tool_direction, arc_tol_mm)
        for lineno, stmt in _lines(dat):
            rd_dat.statement(stmt, lineno, in_dat=True)
        rd.vars.update(rd_dat.vars)
    for lineno, stmt in _lines(text):
        rd.statement(stmt, lineno, in_dat=False)
    return rd.out.table()


def read_krl(path: str | Path, **options: float | str) -> pd.DataFrame:
    """Read a KRL ``.src`` file and the ``.dat`` beside it (if any)."""
    p = Path(path)

    def text_of(q: Path) -> str:
        try:
            return q.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            return q.read_text(encoding="latin-1")
        except OSError as exc:
            raise InputError(f"cannot read the file: {exc}", source=str(q)) from None

    if p.suffix.lower() == ".dat":
        src = p.with_suffix(".src")
        if not src.exists():
            src = p.with_suffix(".SRC")
        if not src.exists():
            raise InputError("a .dat file holds no motions; give the .src program", str(p))
        p = src
    dat_path = next((q for q in (p.with_suffix(".dat"), p.with_suffix(".DAT")) if q.exists()), None)
    dat = text_of(dat_path) if dat_path is not None else None
    return parse_krl(text_of(p), p.name, dat=dat, **options)  # type: ignore[arg-type]
