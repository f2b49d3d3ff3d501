"""KUKA KRL reader (``.src`` with its ``.dat``).

Positions are aggregates ``{X 100, Y 20, Z 5, A 0, B 90, C 0}`` in mm and
degrees, A/B/C the ZYX Euler angles of the tool frame (``R = Rz(A) Ry(B)
Rx(C)``), given in the active base, which is the workpiece (path) frame
(reader option ``coordinates = "machine"`` applies a literal ``$BASE``).
Which tool-frame axis is the working direction (spindle to tip) is a
convention of the cell, not of the file: reader option ``tool_direction``,
default ``"z"`` (RoboDK and other offline programming systems, and ABB: the
same program posted as KRL and as RAPID gives one tool axis); ``"x"`` is
KUKA's factory ``$TOOL_DIRECTION`` for programs taught that way. The tool
axis (tip to spindle) is minus that axis; the TCP x axis the planner uses
is the tool frame's next axis (``x_tool`` for z, ``y_tool`` for x).

Supported: ``LIN``, ``SLIN``, ``LIN_REL`` (base frame), ``CIRC``/``SCIRC``
(auxiliary and end point; ``CA angle`` sweeps that angle on the circle;
the tool turns from the start to the end orientation by arc length),
``SPL`` (spline points, joined by straight lines, warned), ``PTP``/
``SPTP``/``PTP_REL`` (rapid), ``WITH $VEL = SVEL_CP(v, ...)`` (that
motion's velocity, m/s), targets as aggregates (partial aggregates keep the
other components), ``E6POS``/``POS``/``FRAME`` variables declared in the
``.src`` or the ``.dat`` beside it, approximation words
``C_DIS``/``C_VEL``/``C_ORI``/``C_PTP``/``C_SPL``, ``$VEL.CP = 0.2``
(m/s), ``$VEL = {CP 0.2, ...}``, ``BAS(#CP_PARAMS, v)`` / ``BAS(#VEL_CP,
v)``, ``;`` comments and folds, ``&`` header lines,
``SPLINE``/``ENDSPLINE`` brackets. The program is the first ``DEF ...
END``; routines after its ``END`` (``DEF``, ``GLOBAL DEFFCT``) are not main
code: a ``DEF`` routine of the same file is followed where it is called,
other calls are warned and skipped. A ``DEF`` without ``END`` is warned as
truncated.

Ignored on purpose: other ``$`` system variables (``$APO``, ``$ACC``,
``$TOOL``, ``$OUT``, ``$ANOUT``, ...), other ``BAS`` calls, ``DECL`` of
other types, ``WAIT``, ``HALT``, ``INTERRUPT``, ``TRIGGER``, assignments to
plain variables, PTP to axis-specific or actual-position targets
(``{A1 0, ...}``, ``HOME``, ``$AXIS_ACT``, ``$POS_ACT``; they leave the
Cartesian path, which resumes at the next absolute target).

Refused with :class:`~robolobe.errors.InputError` naming ``file:line``:
control flow (``IF``, ``FOR``, ``WHILE``, ``LOOP``, ``REPEAT``, ``SWITCH``,
``GOTO``), relative moves in the tool frame, expressions in targets, a
motion to a position variable set at run time (``P1 = $POS_ACT``),
non-positive or non-numeric velocities, non-finite numbers.

A zero on the spindle output (``spindle_output``) is the spindle off, as
``M5`` in G-code: the motions after it have no programmed speed, and each
``LIN``/``CIRC`` among them is warned (a retract is common there, a cut
would be a program error).
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import (
    arc_points,
    arc_through,
    circle_through,
    orientations_along,
)
from robolobe.plan.paths._edit import (
    ProgramEdit,
    Section,
    fmt_num,
    line_values,
    modal_values,
    pass_layout,
    sections,
)
from robolobe.plan.paths._table import WaypointBuilder
from robolobe.plan.paths._text import (
    TOOL_DIRECTIONS,
    TRUNCATED,
    check_choice,
    finite,
    lines,
    read_text,
    tool_axes,
)
from robolobe.robots.transforms import pose_from_xyz_zyx, rotation_from_zyx, zyx_from_rotation

__all__ = ["parse_krl", "read_krl", "write_krl"]

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
_MOTION = re.compile(r"^(LIN_REL|PTP_REL|LIN|SLIN|PTP|SPTP|CIRC|SCIRC|SPL)\b\s*(.*)$")
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
            v = float(val)
        except ValueError:
            if key in _POS_KEYS:
                raise InputError(
                    f"unsupported construct: expression {val!r} for {key} in a target", where
                ) from None
            out[key] = None
            continue
        if key in _POS_KEYS:
            v = finite(val, where, f"aggregate component {key}")
        out[key] = v if math.isfinite(v) else None
    return out


class _Reader:
    def __init__(
        self,
        source: str,
        tool_direction: str,
        arc_tol_mm: float,
        coordinates: str = "workpiece",
        spindle: tuple[int, float] | None = None,
    ) -> None:
        self.source = source
        self.spindle = spindle  # ($ANOUT index, rpm per unit) of the spindle speed output
        self.rpm = math.nan
        self.rpm_zero: tuple[int, str] | None = None  # the statement that set the output to 0
        self.tool_direction = tool_direction
        self.coordinates = coordinates
        self.tol = arc_tol_mm
        self.vars: dict[str, dict[str, float | None]] = {}
        self.unresolved: dict[str, str] = {}  # variables set at run time
        self.pose: np.ndarray | None = None  # X Y Z A B C (mm, deg), as programmed
        self.vel_m_per_s = math.nan
        self.base: np.ndarray | None = None  # $BASE literal (4x4, mm)
        self.base_text: str | None = None
        self.out = WaypointBuilder(source)
        self.pending: list[
            tuple[float, float, float, float, float, float, float, int, bool, float]
        ] = []
        self.pending_base: list[np.ndarray] = []
        # for the writer's pass copies: external-axis components of the last target, and
        # per row ending a CIRC its programmed auxiliary and end point (X..C, as written)
        self.extra: dict[str, float] = {}
        self.row_extra: dict[int, dict[str, float]] = {}
        self.circ: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    # ------------------------------------------------------------ helpers
    def declare(self, stmt: str, where: str) -> bool:
        """Handle declarations/assignments of position variables; True if handled.

        A position variable set from anything but a literal aggregate
        (``$POS_ACT``, a function, another variable) is marked as set at run
        time: a motion to it is refused, not read with a stale value.
        """
        m = re.match(
            r"^(?:DECL\s+)?(?:GLOBAL\s+)?(E6POS|POS|FRAME|E6AXIS|AXIS)\s+([A-Z_][A-Z0-9_]*)\s*(=\s*(.*))?$",
            stmt,
        )
        if m:
            typ, name, _, value = m.groups()
            if typ in ("E6AXIS", "AXIS"):
                self.vars[name] = {"__axis__": 1.0}
            elif value is not None and not value.strip().startswith("{"):
                self.vars[name] = {}
                self.unresolved[name] = value.strip()
            else:
                self.vars[name] = _aggregate(value, where) if value is not None else {}
            return True
        if stmt.startswith("DECL "):
            return True  # other declarations (INT, REAL, LDAT, FDAT, ...)
        m = re.match(r"^([A-Z_][A-Z0-9_]*)(\.[A-Z][A-Z0-9]*)?\s*=\s*(.+)$", stmt)
        if m and m.group(1) in self.vars and "__axis__" not in self.vars[m.group(1)]:
            name, comp, value = m.group(1), m.group(2), m.group(3).strip()
            if comp is None and value.startswith("{"):
                self.vars[name] = _aggregate(value, where)
                self.unresolved.pop(name, None)
            elif comp is not None and re.fullmatch(r"[-+]?(\d+\.?\d*|\.\d+)(E[-+]?\d+)?", value):
                self.vars[name] = {**self.vars[name], comp[1:]: finite(value, where, stmt)}
            else:
                self.unresolved[name] = value
            return True
        return m is not None and m.group(1) in self.vars

    def target(self, text: str, where: str, *, relative: bool = False) -> np.ndarray | None:
        """Absolute target X..C, or None for an axis-specific or actual-position target."""
        t = text.strip()
        if t.startswith("{"):
            agg = _aggregate(t, where)
        else:
            name = t.split()[0] if t else ""
            if name not in self.vars:
                if name in ("HOME", "XHOME", "$H_POS", "$POS_ACT", "$AXIS_ACT", "$AXIS_HOME") or (
                    name.startswith("XHOME")
                ):
                    return None
                raise InputError(f"unknown position variable {name!r}", source=where)
            if name in self.unresolved:
                raise InputError(
                    f"position variable {name} is set at run time ({self.unresolved[name]!r}): "
                    "expected a literal aggregate",
                    source=where,
                )
            agg = self.vars[name]
        if "__axis__" in agg or any(k.startswith("A") and k[1:].isdigit() for k in agg):
            return None
        self.extra = {
            k: v for k, v in agg.items() if v is not None and re.fullmatch(r"E[1-6]|S|T", k)
        }
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

    def emit(
        self, pose: np.ndarray, lineno: int, rapid: bool, *, at: np.ndarray | None = None,
        vel: float | None = None,
    ) -> None:  # fmt: skip
        """Queue a waypoint; tool frames are computed for all of them in :meth:`finish`."""
        base = np.eye(4)
        if self.coordinates == "machine":
            if self.base is None and self.base_text is not None:
                raise InputError(
                    f"coordinates = 'machine' needs $BASE as a literal frame, found "
                    f"{self.base_text!r}",
                    f"{self.source}:{lineno}",
                )
            if self.base is not None:
                base = self.base
        v = self.vel_m_per_s if vel is None else vel
        if self.rpm_zero is not None and not rapid:
            self.out.feed_at_zero_speed(lineno, self.rpm_zero)
        xyz = pose[:3] if at is None else at
        self.pending.append(
            (float(xyz[0]), float(xyz[1]), float(xyz[2]), float(pose[3]), float(pose[4]),
             float(pose[5]), math.nan if rapid else v * 6e4, lineno, rapid, self.rpm)
        )  # fmt: skip
        self.pending_base.append(base)
        if at is None:
            self.pose = pose
            if self.extra:
                self.row_extra[len(self.pending) - 1] = self.extra

    def finish(self) -> pd.DataFrame:
        """The waypoint table: all tool frames at once (one rotation call, not one per line)."""
        if self.pending:
            rows = np.array([r[:7] for r in self.pending], dtype=np.float64)
            rot = rotation_from_zyx(np.radians(rows[:, 3:6]))
            pos = rows[:, :3]
            if self.coordinates == "machine":
                bases = np.array(self.pending_base)
                pos = np.einsum("nij,nj->ni", bases[:, :3, :3], pos) + bases[:, :3, 3]
                rot = bases[:, :3, :3] @ rot
            axis, ref = tool_axes(rot, self.tool_direction)
            for k, r in enumerate(self.pending):
                self.out.add(
                    pos[k] * 1e-3, axis[k], line=r[7], rapid=r[8], feed_mm_per_min=r[6],
                    ref=ref[k], rpm=r[9],
                )  # fmt: skip
        df = self.out.table()
        df.attrs["warnings"] = self.out.notes()
        return df

    # ------------------------------------------------------------- statements
    def statement(self, stmt: str, lineno: int, in_dat: bool) -> str | None:
        """Apply one statement; return the name of a called local routine, if any."""
        where = f"{self.source}:{lineno}"
        s = stmt.strip().upper()
        if not s or s.startswith("&"):
            return None
        if re.match(r"^(GLOBAL\s+)?(DEF|DEFDAT|END|ENDDAT|ENDFCT|SPLINE|ENDSPLINE)\b", s):
            if s.startswith(("DEFFCT", "GLOBAL DEFFCT")):
                raise InputError("unsupported construct: function definitions DEFFCT", where)
            return None
        if s.startswith("DEFFCT"):
            raise InputError("unsupported construct: function definitions DEFFCT", where)
        if self.declare(s, where):
            return None
        if in_dat:
            return None  # other data in a .dat file
        m = _CONTROL.match(s)
        if m:
            raise InputError(
                f"unsupported construct: control flow {m.group(1)} (the path depends on "
                "run-time conditions; export the motions as a straight sequence)",
                source=where,
            )
        if self.spindle is not None and "$ANOUT" in s and self.analog(s, where):
            return None
        if s.startswith("$"):
            self.system_var(s, where)
            return None
        if s.startswith("BAS"):
            m = re.match(r"^BAS\s*\(\s*#(CP_PARAMS|VEL_CP)\s*,\s*([-+0-9.E]+)\s*\)$", s)
            if m:
                self.vel_m_per_s = _velocity(m.group(2), where)
            return None
        if _IGNORED.match(s):
            return None
        m = _MOTION.match(s)
        if m:
            self.motion(m.group(1), m.group(2), lineno, where)
            return None
        m = re.match(r"^([A-Z_][A-Z0-9_]*)\s*\(.*\)$", s)
        if m:
            return m.group(1)
        if re.match(r"^[A-Z_][A-Z0-9_.\[\]]*\s*=", s):
            return None  # assignment to a plain variable (LDAT_ACT=..., counters)
        raise InputError(f"unsupported KRL statement {stmt.strip()!r}", source=where)

    def analog(self, s: str, where: str) -> bool:
        """``$ANOUT[n] = v`` or ``TRIGGER WHEN DISTANCE=0 DELAY=0 DO $ANOUT[n] = v`` on the
        spindle output: the speed of the motions from the next one on. True if handled."""
        assert self.spindle is not None
        n, per_unit = self.spindle
        m = re.match(r"^(TRIGGER\s+WHEN\s+(.*?)\s+DO\s+)?\$ANOUT\s*\[\s*(\d+)\s*\]\s*=\s*(.+)$", s)
        if not m or int(m.group(3)) != n:
            return False
        if m.group(1):
            cond = re.sub(r"\s+", "", m.group(2))
            if cond != "DISTANCE=0DELAY=0":
                raise InputError(
                    f"spindle output $ANOUT[{n}] switched at {m.group(2).strip()!r}: expected "
                    "DISTANCE=0 DELAY=0 (the start of the next motion)",
                    where,
                )
        v = finite(m.group(4).strip(), where, f"$ANOUT[{n}]")
        self.rpm = v * per_unit if v > 0 else math.nan
        line = int(where.rsplit(":", 1)[1])
        self.rpm_zero = None if v > 0 else (line, f"$ANOUT[{n}] = {v:g}")
        return True

    def system_var(self, s: str, where: str) -> None:
        m = re.match(r"^\$VEL\.CP\s*=\s*(.+)$", s)
        if m:
            self.vel_m_per_s = _velocity(m.group(1), where)
            return
        m = re.match(r"^\$VEL\s*=\s*(\{.*\})$", s)
        if m:
            agg = _aggregate(m.group(1), where)
            if agg.get("CP") is not None:
                self.vel_m_per_s = _velocity(str(agg["CP"]), where)
            return
        m = re.match(r"^\$BASE\s*=\s*(.+)$", s)
        if m:
            text = m.group(1).strip()
            base = None
            if text.startswith("{"):
                agg = _aggregate(text, where)
                v = [agg.get(k) for k in _POS_KEYS]
                if all(x is not None for x in v):
                    xyzabc = np.array(v, dtype=np.float64)
                    base = pose_from_xyz_zyx(xyzabc[:3], np.radians(xyzabc[3:]))
            if self.base_text is not None and text != self.base_text and self.pending:
                self.out.warn(
                    f"$BASE changes between moves ({self.base_text} -> {text}): positions are "
                    "taken as programmed in each base",
                    int(where.rsplit(":", 1)[1]),
                    key="base-change",
                )
            self.base, self.base_text = base, text
            return
        if s.startswith("$TOOL"):
            logger.info("%s: $TOOL not applied (the path is the TCP's)", where)

    def motion(self, word: str, rest: str, lineno: int, where: str) -> None:
        vel: float | None = None
        mw = re.search(r"\bWITH\b", rest)
        if mw:
            clause = rest[mw.end() :]
            vel = _with_velocity(clause, where)
            if vel is not None and math.isnan(vel):
                self.out.warn(
                    "WITH $VEL = SVEL_CP(...) with a velocity that is not a number: no "
                    "programmed feed for that motion",
                    lineno,
                    key="with-vel",
                )
            # inline forms select the FDAT's base and tool (SBASE/STOOL2): the active base;
            # anything else would move the frame of this one motion
            for m_frame in re.finditer(r"\$(BASE|TOOL)\s*=\s*([A-Z_0-9]+)", clause):
                if m_frame.group(2) not in ("SBASE", "STOOL2", "STOOL"):
                    self.out.warn(
                        f"WITH ${m_frame.group(1)} = {m_frame.group(2)}... not applied: the "
                        "target is taken in the active base",
                        lineno,
                        key="with-frame",
                    )
            rest = rest[: mw.start()]
        rest = _APPROX.sub("", rest).strip()
        rapid = word in ("PTP", "SPTP", "PTP_REL")
        if word in ("CIRC", "SCIRC"):
            parts = _split_top(rest)
            ca: float | None = None
            if len(parts) == 3:
                mca = re.match(r"^CA\s+(.+)$", parts[2].strip())
                if not mca:
                    raise InputError(f"CIRC: expected 'CA angle', found {parts[2]!r}", where)
                ca = finite(mca.group(1), where, "CIRC CA")
                parts = parts[:2]
            if len(parts) != 2:
                raise InputError(f"CIRC: expected auxiliary and end point, found {rest!r}", where)
            aux = self.target(parts[0], where)
            end = self.target(parts[1], where)
            if aux is None or end is None or self.pose is None:
                raise InputError("CIRC needs Cartesian points after a known position", where)
            start = self.pose[:3]
            if ca is None:
                pts = arc_through(start, aux[:3], end[:3], tol=self.tol, where=where)
            else:
                pts = _arc_by_angle(start, aux[:3], end[:3], ca, self.tol, where)
                end = np.concatenate([pts[-1], end[3:]])
            rots = orientations_along(
                start,
                rotation_from_zyx(np.radians(self.pose[3:])),
                rotation_from_zyx(np.radians(end[3:])),
                np.asarray(pts),
            )
            abc = np.degrees(zyx_from_rotation(rots))
            for p, a in zip(pts[:-1], abc[:-1], strict=True):
                self.emit(np.concatenate([p, a]), lineno, rapid=False, at=p, vel=vel)
            programmed_end = self.target(parts[1], where)
            self.emit(end, lineno, rapid=False, vel=vel)
            assert programmed_end is not None
            self.circ[len(self.pending) - 1] = (aux[:3].copy(), programmed_end)
            return
        if word == "SPL":
            self.out.warn(
                "SPL spline points joined by straight lines (the spline passes through them)",
                lineno,
                key="SPL",
            )
        if "#TOOL" in rest:
            raise InputError(
                "unsupported construct: relative move in the tool frame (#TOOL)", where
            )
        rest = re.sub(r",?\s*#BASE\s*$", "", rest).strip()
        tgt = self.target(rest, where, relative=word.endswith("_REL"))
        if tgt is None:
            if not rapid:
                raise InputError(
                    f"{word} to an axis-specific or actual-position target has no Cartesian "
                    "position",
                    where,
                )
            logger.info("%s: PTP to an axis-specific target left out of the path", where)
            return
        self.emit(tgt, lineno, rapid=rapid, vel=vel)


def _velocity(text: str, where: str) -> float:
    """A CP velocity [m/s] from a file: a positive number."""
    try:
        v = float(text)
    except ValueError:
        raise InputError(
            f"unsupported construct: expression {text.strip()!r} for the path velocity", where
        ) from None
    if not math.isfinite(v) or v <= 0 or v > 100:
        raise InputError(
            f"expected a path velocity in (0, 100] m/s, found {text.strip()!r}", source=where
        )
    return v


def _with_velocity(text: str, where: str) -> float | None:
    """The velocity [m/s] a ``WITH`` clause sets for one spline motion, if any.

    NaN when it is a variable or an expression (``SVEL_CP(gArcVel, ...)``):
    the motion then has no programmed feed.
    """
    m = re.search(r"\$VEL\s*=\s*SVEL_CP\s*\(\s*([^,)]*)", text)
    if m:
        arg = m.group(1).strip()
        if not arg:
            return None
        try:
            float(arg)
        except ValueError:
            return math.nan
        return _velocity(arg, where)
    m = re.search(r"\$VEL\.CP\s*=\s*([^,]+)", text)
    if m:
        return _velocity(m.group(1), where)
    return None


def _arc_by_angle(
    start: np.ndarray, aux: np.ndarray, end: np.ndarray, ca_deg: float, tol: float, where: str
) -> np.ndarray:
    """KRL ``CIRC aux, end, CA angle``: the circle through the three points, swept by ``CA``.

    Positive ``CA`` runs start -> aux -> end, negative the other way; the
    motion ends where the angle says, not at ``end``.
    """
    if not 0 < abs(ca_deg) <= 360.0:
        raise InputError(f"CIRC CA: expected 0 < |CA| <= 360 deg, found {ca_deg:g}", where)
    circ = circle_through(start, aux, end, where)
    if circ is None:
        raise InputError("CIRC with CA: start, auxiliary and end point are collinear", where)
    centre, nrm = circ
    a = math.radians(ca_deg)
    v = start - centre
    rot = (
        v * math.cos(a) + np.cross(nrm, v) * math.sin(a) + nrm * float(nrm @ v) * (1 - math.cos(a))
    )
    stop = centre + rot
    return arc_points(
        start, stop, centre, nrm, clockwise=ca_deg < 0, tol=tol,
        full_circle=abs(abs(ca_deg) - 360.0) < 1e-9, where=where,
    )  # fmt: skip


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
    for lineno, raw in enumerate(lines(text), start=1):
        s = _strip(raw).strip()
        if s:
            out.append((lineno, s))
    return out


_DEF = re.compile(
    r"^(?:GLOBAL\s+)?(DEF|DEFFCT)\s+(?:[A-Z_][A-Z0-9_]*\s+)?([A-Z_][A-Z0-9_]*)\s*\(", re.I
)


def _routines(
    stmts: list[tuple[int, str]], source: str
) -> tuple[list[tuple[str, list[tuple[int, str]]]], list[str]]:
    """Split a .src into routines ``DEF name(...) ... END``; also names left unterminated."""
    routines: list[tuple[str, list[tuple[int, str]]]] = []
    open_: list[str] = []
    cur: list[tuple[int, str]] | None = None
    name = ""
    for lineno, st in stmts:
        up = st.upper()
        m = _DEF.match(up)
        if m and cur is None:
            name = m.group(2) if m.group(1).upper() == "DEF" else "DEFFCT " + m.group(2)
            cur = [(lineno, st)]
            continue
        if cur is None:
            if up.startswith("&"):
                continue
            routines.append(("", [(lineno, st)]))  # statements outside DEF ... END
            continue
        cur.append((lineno, st))
        if re.match(r"^(END|ENDFCT)\s*$", up):
            routines.append((name, cur))
            cur = None
    if cur is not None:
        routines.append((name, cur))
        open_.append(name)
    return routines, open_


def parse_krl(
    text: str,
    source: str = "<krl>",
    *,
    dat: str | None = None,
    tool_direction: str = "z",
    arc_tol_mm: float = 0.01,
    coordinates: str = "workpiece",
    spindle_output: str | None = None,
    spindle_rpm_per_unit: float | None = None,
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
    tool_direction : {"z", "x"}
        Tool frame axis along the working direction (spindle to tip): ``z``
        (default: RoboDK and other offline programming, and ABB, so the same
        path posted as KRL and as RAPID gives one tool axis) or ``x``
        (KUKA's factory ``$TOOL_DIRECTION``, for programs taught that way).
    arc_tol_mm : float
        Chord tolerance of linearised arcs [mm].
    coordinates : {"workpiece", "machine"}
        ``workpiece``: targets as programmed in the active base. ``machine``:
        the literal ``$BASE`` frame applied (robot world/base coordinates).
    spindle_output, spindle_rpm_per_unit : optional
        The ``$ANOUT`` index that sets the spindle speed and the rpm per
        unit of it (job section ``[program]``: ``analog_output``,
        ``analog_rpm_full_scale / analog_full_scale``); with both, ``$ANOUT[n]
        = v`` and ``TRIGGER WHEN DISTANCE=0 DELAY=0 DO $ANOUT[n] = v`` set
        the programmed speed of the motions after them.

    Returns
    -------
    pandas.DataFrame
        The waypoint table; reader warnings in ``attrs["warnings"]``.

    Raises
    ------
    InputError
        Unsupported or malformed statements, naming ``source:line``.
    """
    check_choice("tool_direction", tool_direction, TOOL_DIRECTIONS)
    check_choice("coordinates", coordinates, ("workpiece", "machine"))
    spindle = None
    if spindle_output is not None and spindle_rpm_per_unit is not None:
        spindle = (_anout_index(spindle_output), float(spindle_rpm_per_unit))
    return _run_krl(text, source, dat, _Reader(source, tool_direction, arc_tol_mm, coordinates,
                                              spindle)).finish()  # fmt: skip


def _run_krl(text: str, source: str, dat: str | None, rd: _Reader) -> _Reader:
    """Run the program's main routine through ``rd`` (:func:`parse_krl`); ``rd`` returned."""
    tool_direction, arc_tol_mm = rd.tool_direction, rd.tol
    if dat is not None:
        dat_name = re.sub(r"\.src$", ".dat", source, flags=re.IGNORECASE)
        rd_dat = _Reader(dat_name, tool_direction, arc_tol_mm)
        for lineno, stmt in _lines(dat):
            rd_dat.statement(stmt, lineno, in_dat=True)
        rd.vars.update(rd_dat.vars)
        rd.unresolved.update(rd_dat.unresolved)
    stmts = _lines(text)
    if not stmts:
        raise InputError("expected a KRL program, found no statements", source=source)
    routines, unterminated = _routines(stmts, source)
    local = {name: body for name, body in routines if name and not name.startswith("DEFFCT")}
    mains = [(name, body) for name, body in routines if name]
    if not mains:
        raise InputError("expected a program DEF name() ... END, found none", source=source)
    main_name, main_body = mains[0]
    if main_name.startswith("DEFFCT"):
        raise InputError(
            "unsupported construct: the first routine is a function DEFFCT", source=source
        )
    for name, body in routines:
        if not name:  # statements outside any DEF ... END
            ln, st = body[0]
            raise InputError(f"statement outside DEF ... END: {st!r}", source=f"{source}:{ln}")
    if unterminated:
        rd.out.warn(
            f"DEF {unterminated[0]} has no END: {TRUNCATED} (the path read so far is planned)"
        )

    def run(body: list[tuple[int, str]], depth: int) -> None:
        for lineno, stmt in body:
            called = rd.statement(stmt, lineno, in_dat=False)
            if called is None:
                continue
            if called in local and called != main_name:
                if depth > 20:
                    raise InputError(
                        f"calls nested deeper than 20 levels ({called})", f"{source}:{lineno}"
                    )
                if (
                    re.search(r"\(\s*\S", stmt.split("(", 1)[1].rstrip(") "))
                    if "(" in stmt
                    else False
                ):
                    rd.out.warn(
                        f"call to {called} with arguments: its body is followed with the "
                        "arguments ignored",
                        lineno,
                        key=f"call-args-{called}",
                    )
                run(local[called], depth + 1)
            else:
                rd.out.warn(
                    f"call to {called} ignored (not defined in this file: its motions are "
                    "not followed)",
                    lineno,
                    key=f"call-{called}",
                )

    run(main_body, 0)
    return rd


def _anout_index(value: object) -> int:
    """The ``$ANOUT`` index of the job key ``[program] analog_output`` (1 to 32)."""
    m = re.fullmatch(r"\s*(?:\$ANOUT\s*\[\s*)?(\d+)\s*\]?\s*", str(value), re.I)
    if not m or not 1 <= int(m.group(1)) <= 32:
        raise InputError(
            f"[program] analog_output: expected a KRL $ANOUT index 1 to 32, found {value!r}"
        )
    return int(m.group(1))


def read_krl(path: str | Path, **options: float | str) -> pd.DataFrame:
    """Read a KRL ``.src`` file and the ``.dat`` beside it (if any)."""
    p = Path(path)
    if p.suffix.lower() == ".dat":
        src = p.with_suffix(".src")
        if not src.exists():
            src = p.with_suffix(".SRC")
        if not src.exists():
            raise InputError("a .dat file holds no motions; give the .src program", str(p))
        p = src
    dat_path = next((q for q in (p.with_suffix(".dat"), p.with_suffix(".DAT")) if q.exists()), None)
    dat = read_text(dat_path) if dat_path is not None else None
    return parse_krl(read_text(p), p.name, dat=dat, **options)  # type: ignore[arg-type]


# ------------------------------------------------------------------ writer
# KUKA conventions (KUKA System Software 8.x operating and programming
# manual: $VEL.CP, TRIGGER WHEN DISTANCE, $ANOUT): the path velocity is the
# modal $VEL.CP [m/s] (or WITH $VEL = SVEL_CP(v, ...) on a motion); the
# spindle speed is an analog output ($ANOUT[n], -1.0 .. 1.0) scaled by the
# job keys, set once before the first motion (the spindle is at speed before
# the cut) and changed path-synchronously by TRIGGER WHEN DISTANCE=0 DELAY=0
# DO $ANOUT[n] = v before the motion it applies to (switched at its start
# point, without stopping the advance run). A module's name is its file
# name: DEF and DEFDAT are renamed to the written file's stem.


def _krl_insert_note(raw: str, note: str) -> str:
    return (
        f"{raw.rstrip()} ; ROBOLOBE {note}" if ";" not in raw else f"{raw.rstrip()} ROBOLOBE {note}"
    )


def write_krl(
    text: str,
    source: str,
    edit: ProgramEdit,
    *,
    name: str,
    dat: str | None = None,
    options: dict[str, object] | None = None,
) -> tuple[str, str | None]:
    """Write a KRL program (and its ``.dat``) with the speeds and feeds of ``edit``.

    Parameters
    ----------
    text : str
        The ``.src`` as read (:func:`parse_krl` made ``edit.waypoints`` of it).
    source : str
        Its file name (messages).
    edit : ProgramEdit
        ``edit.options``: ``analog_output`` ($ANOUT index),
        ``analog_rpm_full_scale``, ``analog_full_scale``.
    name : str
        Stem of the written files: the DEF and DEFDAT names.
    dat : str, optional
        The ``.dat`` as read.
    options : dict, optional
        The reader options ``edit.waypoints`` was read with (``arc_tol_mm``,
        ``tool_direction``, ``coordinates``): the pass copies are written
        from the program's own targets, read again with them.

    Returns
    -------
    src, dat : str, str or None

    Raises
    ------
    InputError
        Analog scaling keys missing; passes over a run of moves that is not
        in file order, holds a routine call or a spline block, or changes
        ``$BASE``.
    """
    opt = edit.options
    if opt.get("analog_output") is None or opt.get("analog_rpm_full_scale") is None:
        raise InputError(
            "KRL output sets the spindle speed by an analog output: expected the job keys "
            "[program] analog_output ($ANOUT index) and analog_rpm_full_scale (rpm at full "
            "scale), found "
            + ", ".join(k for k in ("analog_output", "analog_rpm_full_scale") if opt.get(k) is None)
            + " missing",
            source=source,
        )
    n = _anout_index(opt["analog_output"])
    per_unit = float(opt["analog_rpm_full_scale"]) / float(opt.get("analog_full_scale", 1.0))
    src = lines(text)
    vals = line_values(edit)
    s_want = {ln: fmt_num(v[0] / per_unit, 12, point=False) for ln, v in vals.items()}
    f_want = {ln: fmt_num(v[1] / 6e4, 12, point=False) for ln, v in vals.items()}
    if any(float(v) > 1.0 for v in s_want.values()):
        top = max(v[0] for v in vals.values())
        raise InputError(
            f"[program] analog_rpm_full_scale: {top:g} rpm needs $ANOUT[{n}] > 1.0 (full scale "
            f"{per_unit * 1.0:g} rpm)",
            source=source,
        )
    s_set: dict[int, str | None] = {}
    f_set: dict[int, str | None] = {}
    with_vel: dict[int, tuple[int, int]] = {}
    first_motion: int | None = None
    an = re.compile(
        r"^(?:TRIGGER\s+WHEN\s+.*?\s+DO\s+)?\$ANOUT\s*\[\s*" + str(n) + r"\s*\]\s*=\s*(.+)$", re.I
    )
    for ln, raw in enumerate(src, start=1):
        st = _strip(raw).strip()
        up = st.upper()
        if not st:
            continue
        m = an.match(up)
        if m:
            s_set[ln] = m.group(1).strip() if _is_number(m.group(1)) else None
            continue
        m = re.match(r"^\$VEL\.CP\s*=\s*(.+)$", up)
        if m:
            f_set[ln] = m.group(1).strip() if _is_number(m.group(1)) else None
            continue
        if re.match(r"^\$VEL\s*=", up) or re.match(r"^BAS\s*\(\s*#(CP_PARAMS|VEL_CP)", up):
            f_set[ln] = None
            continue
        mm = _MOTION.match(up)
        if mm:
            if first_motion is None:
                first_motion = ln
            w = re.search(r"SVEL_CP\s*\(\s*([-+0-9.E]+)", raw, re.I)
            if w and ln in vals:
                with_vel[ln] = (w.start(1), w.end(1))
    f_plain = {ln: v for ln, v in f_want.items() if ln not in with_vel}
    s_edits, s_ins = modal_values(s_set, s_want)
    f_edits, f_ins = modal_values(f_set, f_plain)
    before: dict[int, list[str]] = {}
    out_lines: dict[int, str] = {}
    # the first speed before the first motion, not path-synchronous: the spindle runs up first
    first_cut = min(vals) if vals else None
    if first_cut is not None and first_cut in s_ins and first_motion is not None:
        indent = re.match(r"^\s*", src[first_motion - 1]).group(0)  # type: ignore[union-attr]
        before.setdefault(first_motion, []).append(
            f"{indent}$ANOUT[{n}] = {s_ins.pop(first_cut)} ; ROBOLOBE spindle speed "
            f"{fmt_num(vals[first_cut][0], 0, point=False)} rpm "
            f"({fmt_num(per_unit, 6, point=False)} rpm per unit)"
        )
    for ln, v in s_ins.items():
        indent = re.match(r"^\s*", src[ln - 1]).group(0)  # type: ignore[union-attr]
        mg = vals[ln][2]
        m_txt = f", margin {mg:.2f}" if math.isfinite(mg) else ""
        before.setdefault(ln, []).append(
            f"{indent}TRIGGER WHEN DISTANCE=0 DELAY=0 DO $ANOUT[{n}] = {v} ; ROBOLOBE spindle "
            f"speed {fmt_num(vals[ln][0], 0, point=False)} rpm{m_txt}"
        )
    for ln, v in f_ins.items():
        indent = re.match(r"^\s*", src[ln - 1]).group(0)  # type: ignore[union-attr]
        before.setdefault(ln, []).append(
            f"{indent}$VEL.CP = {v} ; ROBOLOBE path speed "
            f"{fmt_num(vals[ln][1], 3, point=False)} mm/min"
        )
    for edits, what in ((s_edits, "spindle speed"), (f_edits, "path speed")):
        for ln, v in edits.items():
            raw = src[ln - 1]
            code = _strip(raw)
            k = code.rfind("=")
            new = code[: k + 1] + " " + v
            out_lines[ln] = _krl_insert_note(
                new + raw[len(code) :], f"{what}: was {code[k + 1 :].strip()}"
            )
    for ln, (a, b) in with_vel.items():
        raw = src[ln - 1]
        if _is_number(raw[a:b]) and float(raw[a:b]) != float(f_want[ln]):
            out_lines[ln] = _krl_insert_note(
                raw[:a] + f_want[ln] + raw[b:], f"path speed: was {raw[a:b]}"
            )
    secs = sections(edit)
    if secs:
        rd = _Reader(
            source,
            str((options or {}).get("tool_direction", "z")),
            float((options or {}).get("arc_tol_mm", 0.01)),  # type: ignore[arg-type]
            str((options or {}).get("coordinates", "workpiece")),
        )
        _run_krl(text, source, dat, rd)
        if len(rd.pending) != len(edit.waypoints):
            raise InputError(
                f"passes in KRL: the program reads to {len(rd.pending)} moves, the plan's "
                f"table has {len(edit.waypoints)} (other reader options?)",
                source=source,
            )
        speeds = (n, s_want, f_plain)
        for sec in secs:
            _krl_pass_block(edit, sec, src, rd, out_lines, before, speeds, source)
    # module name = file name
    for ln, raw in enumerate(src, start=1):
        m = _DEF.match(_strip(raw).strip())
        if m and m.group(1).upper() == "DEF":
            k = raw.upper().find(m.group(2).upper(), raw.upper().find("DEF") + 3)
            out_lines[ln] = _krl_insert_note(
                raw[:k] + name + raw[k + len(m.group(2)) :], f"renamed from {m.group(2)}"
            )
            break
    res: list[str] = []
    for ln in range(1, len(src) + 1):
        res.extend(before.get(ln, []))
        res.append(out_lines.get(ln, src[ln - 1]))
    dat_out = None
    if dat is not None:
        d = lines(dat)
        for k, raw in enumerate(d):
            m = re.match(r"^(\s*DEFDAT\s+)([A-Za-z_][A-Za-z0-9_]*)", raw, re.I)
            if m:
                d[k] = _krl_insert_note(
                    m.group(1) + name + raw[m.end() :], f"renamed from {m.group(2)}"
                )
                break
        dat_out = "\n".join(d) + "\n"
    return "\n".join(res) + "\n", dat_out


_NOT_IN_PASSES = re.compile(
    r"^((GLOBAL\s+)?DEF|DEFFCT|END|ENDFCT|SPLINE|ENDSPLINE|SPL|SLIN|SCIRC)\b|^[A-Z_][A-Z0-9_]*\s*\(.*\)$"
)


def _krl_agg(xyz: np.ndarray, abc: np.ndarray, extra: dict[str, float]) -> str:
    """A literal target aggregate ``{X .., Y .., Z .., A .., B .., C ..[, E1 ..]}``."""
    parts = [
        f"{k} {fmt_num(float(v), 9, point=False)}"
        for k, v in zip(_POS_KEYS, [*xyz, *abc], strict=True)
    ]
    parts += [f"{k} {fmt_num(v, 9, point=False)}" for k, v in sorted(extra.items())]
    return "{" + ", ".join(parts) + "}"


def _krl_pass_block(
    edit: ProgramEdit,
    sec: Section,
    src: list[str],
    rd: _Reader,
    out_lines: dict[int, str],
    before: dict[int, list[str]],
    speeds: tuple[int, dict[int, str], dict[int, str]],
    source: str,
) -> None:
    """The shallower passes of one section, inserted before it (module notes of ``_edit``).

    Each motion of a pass copy goes to a literal target: the program's own
    target (as read, with its orientation and external axes) shifted along
    the tool axis in the base it is programmed in; links are ``PTP`` to
    literal targets with the orientation of the point they lie above. The
    ``.dat`` needs no new points.
    """
    n_out, s_want, f_plain = speeds
    wp_lines = edit.waypoints["line"].to_numpy()
    pos_mm = edit.waypoints[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
    first, last = int(wp_lines[sec.start]), int(wp_lines[sec.stop - 1])
    prev = int(wp_lines[sec.start - 1])
    where = f"{source}:{first}"
    seq = wp_lines[sec.start : sec.stop]
    if np.any(np.diff(seq) < 0) or prev >= first:
        raise InputError(
            "passes in KRL: the run of cutting moves must follow the move before it in the "
            "file (no routine calls inside)",
            where,
        )
    opened = 0
    for ln in range(1, last + 1):
        code = _strip(src[ln - 1]).strip().upper()
        if re.match(r"^SPLINE\b", code):
            opened += 1
        elif re.match(r"^ENDSPLINE\b", code):
            opened -= 1
        if ln >= first and code and _NOT_IN_PASSES.match(code):
            raise InputError(
                f"passes in KRL: {code.split()[0]} within the run of cutting moves is not "
                "repeated (routine calls and spline blocks cannot take the PTP links)",
                f"{source}:{ln}",
            )
        if ln == first - 1 and opened > 0:
            raise InputError(
                "passes in KRL: the run of cutting moves is inside a SPLINE block", where
            )
    bases = np.array(rd.pending_base[sec.start - 1 : sec.stop])
    if np.max(np.abs(bases - bases[0])) > 1e-12:
        raise InputError("passes in KRL: $BASE changes within the run of cutting moves", where)
    rot, org = bases[0][:3, :3], bases[0][:3, 3]
    pose = np.array([r[:6] for r in rd.pending], dtype=np.float64)  # as programmed

    def programmed(p: np.ndarray) -> np.ndarray:  # a point [mm] of the table in the base
        return np.asarray(rot.T @ (p - org))

    end_row = {int(wp_lines[r]): r for r in range(sec.start, sec.stop)}
    indent = re.match(r"^\s*", src[first - 1]).group(0)  # type: ignore[union-attr]
    plain = [ln for ln in range(first, last + 1) if ln in f_plain]
    restate = [f"{indent}TRIGGER WHEN DISTANCE=0 DELAY=0 DO $ANOUT[{n_out}] = {s_want[first]} "
               "; ROBOLOBE spindle speed at the pass start"]  # fmt: skip
    if plain:
        restate.append(
            f"{indent}$VEL.CP = {f_plain[plain[0]]} ; ROBOLOBE path speed at the pass start"
        )
    block: list[str] = []
    for ps in pass_layout(edit, sec, pos_mm):
        for p, row in ps.links:
            agg = _krl_agg(programmed(p), pose[row, 3:6], rd.row_extra.get(row, {}))
            block.append(f"{indent}PTP {agg} ; ROBOLOBE link to pass {ps.index} of {ps.count}")
        if ps.restate:
            block.extend(restate)
        if ps.own:
            break
        block.append(
            f"{indent}; ROBOLOBE pass {ps.index} of {ps.count}: "
            f"{fmt_num(ps.offset_mm, 4, point=False)} mm above the programmed depth"
        )
        d = rot.T @ ps.shift_mm
        for ln in range(first, last + 1):
            block.extend(x for x in before.get(ln, []) if not x.lstrip().startswith(";"))
            raw = out_lines.get(ln, src[ln - 1])
            code = _strip(raw)
            if not code.strip():
                continue  # comments and folds are not repeated
            m = _MOTION.match(code.strip().upper())
            if m:
                raw = _krl_shifted(raw, code, m, end_row[ln], pose, rd, d, where)
            block.append(raw)
    before.setdefault(first, [])[0:0] = block


def _krl_shifted(
    raw: str,
    code: str,
    m: re.Match[str],
    row: int,
    pose: np.ndarray,
    rd: _Reader,
    d: np.ndarray,
    where: str,
) -> str:
    """A motion line with its target(s) replaced by literal aggregates shifted by ``d`` [mm]."""
    word = m.group(1)
    lead = len(code) - len(code.lstrip())
    rest_at = lead + m.start(2)
    rest = code[rest_at:]
    up = rest.upper()
    mw = re.search(r"\bWITH\b", up)
    head = rest[: mw.start()] if mw else rest
    ma = _APPROX.search(head.upper())
    tgt = head[: ma.start()] if ma else head
    tail = rest[len(tgt.rstrip()) :]
    extra = rd.row_extra.get(row, {})
    if word in ("CIRC", "SCIRC"):
        aux, end = rd.circ[row]
        parts = _split_top(tgt)
        ca = f", {parts[2].strip()}" if len(parts) == 3 else ""
        new_t = (
            "{" + ", ".join(f"{k} {fmt_num(float(v), 9, point=False)}"
                            for k, v in zip("XYZ", aux + d, strict=True)) + "}, "
            + _krl_agg(end[:3] + d, end[3:6], extra) + ca
        )  # fmt: skip
    elif word in ("LIN", "LIN_REL"):
        new_t = _krl_agg(pose[row, :3] + d, pose[row, 3:6], extra)
        word = "LIN"
    else:
        raise InputError(f"passes in KRL: {word} within the run of cutting moves", where)
    return (
        raw[:lead] + word + " " + new_t + tail + raw[len(code) :]
    ).rstrip() + " ; ROBOLOBE pass copy" * (";" not in raw[len(code) :])


def _is_number(text: str) -> bool:
    try:
        float(text.strip())
    except ValueError:
        return False
    return True
