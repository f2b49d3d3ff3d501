"""ABB RAPID reader (``.mod`` / ``.modx`` / ``.prg``).

``robtarget`` = ``[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx],
[eax_a, ...]]`` in mm in the work object, which is the workpiece (path)
frame; the quaternion is scalar first (q1 = w). ABB's tool convention makes
the tool **Z** axis the working direction (spindle to tip), so the tool axis
(tip to spindle) is ``-z_tool`` and the TCP x axis is ``x_tool`` (reader
option ``tool_direction = "x"`` for a tool frame defined the KUKA way).

Supported: ``MoveL``, ``MoveJ`` (rapid), ``MoveC`` (circle point and end
point; the tool turns from the start to the end orientation by arc
length), their ``Trigg``/``DO``/``Sync`` variants (first arguments are
the targets), targets as literals, as ``CONST``/``PERS``/``VAR robtarget``
names (``LOCAL`` too), and ``Offs(p, dx, dy, dz)``; ``speeddata`` ``vN``
(N mm/s), ``vmax`` (5000 mm/s), user ``speeddata`` declarations (first
component, mm/s) and the ``\\V:=`` argument; optional switches such as
``\\Conc``; ``!`` comments; ``%%%`` headers; statements spanning lines.
The program runs from ``PROC main`` (or the only procedure); calls of
procedures of the same module are followed where they are called (others
are warned and skipped). ``\\WObj:=``: positions stay in their work object
(a warning when moves use different ones); with ``coordinates =
"machine"`` the module's literal ``wobjdata`` (uframe, oframe) is applied.
A ``PROC`` without ``ENDPROC`` or a ``MODULE`` without ``ENDMODULE`` is
warned as truncated; a statement without ``;`` at the end is an error.

Ignored on purpose: ``MODULE``/``ENDMODULE``/``PROC``/``ENDPROC``,
declarations of other types (tooldata, zonedata, num, ...), ``MoveAbsJ``
(a joint target: it leaves the Cartesian path, which resumes at the next
target) and the usual non-motion instructions (ConfL, ConfJ, SingArea,
AccSet, VelSet, SetDO, SetAO, SetGO, PulseDO, WaitTime, WaitDI, WaitDO,
WaitUntil, TPWrite, TPErase, Stop, Set, Reset, CorrClear, PathAccLim, ...).

Refused with :class:`~robolobe.errors.InputError` naming ``file:line``:
control flow (``IF``, ``FOR``, ``WHILE``, ``TEST``, ``GOTO``: the path
would depend on run-time conditions), ``RelTool``, ``CRobT`` and other
functions in targets (also a move to a robtarget variable assigned one:
``p := CRobT(); MoveL p, ...``; ``p := Offs(q, ...)`` is followed),
non-positive speeds, non-finite numbers.

A zero on the spindle output (``spindle_output``, by ``SetAO`` or
``TriggIO``) is the spindle off, as ``M5`` in G-code: the moves after it
have no programmed speed, and each ``MoveL``/``MoveC`` among them is warned
(a retract is common there, a cut would be a program error).
"""

from __future__ import annotations

import json
import logging
import math
import re
from pathlib import Path
from typing import Any, cast

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_through, orientations_along
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

__all__ = ["parse_rapid", "quaternion_to_rotation", "read_rapid", "write_rapid"]

logger = logging.getLogger(__name__)

_BLOCK_WORDS = re.compile(
    r"^(MODULE|ENDMODULE|(LOCAL\s+)?PROC|ENDPROC|(LOCAL\s+)?TRAP|ENDTRAP|ERROR|BACKWARD|UNDO)\b",
    re.IGNORECASE,
)
_CONTROL = re.compile(
    r"^(IF|ELSEIF|ELSE|ENDIF|FOR|ENDFOR|WHILE|ENDWHILE|TEST|CASE|DEFAULT|ENDTEST|GOTO|"
    r"(LOCAL\s+)?FUNC|ENDFUNC|RETRY|TRYNEXT|RAISE)\b",
    re.IGNORECASE,
)
_IGNORED = {
    "CONFL", "CONFJ", "SINGAREA", "ACCSET", "VELSET", "SETDO", "SETAO", "SETGO", "PULSEDO",
    "WAITTIME", "WAITDI", "WAITDO", "WAITUNTIL", "WAITAI", "TPWRITE", "TPERASE", "STOP",
    "SET", "RESET", "CORRCLEAR", "CORRCON", "CORRDISCON", "PATHACCLIM", "SOFTACT",
    "SOFTDEACT", "GRIPLOAD", "MOTIONSUP", "STOPMOVE", "STARTMOVE", "CLEARPATH",
    "WORLDACCLIM", "TUNESERVO", "RETURN", "EXIT", "BREAK", "SETSYSDATA", "ERRWRITE",
    "TRIGGIO", "TRIGGEQUIP", "TRIGGINT", "IDELETE", "CONNECT", "ISIGNALDI", "ISIGNALDO",
}  # fmt: skip
_MOVES = {
    "MOVEL": "L", "MOVEJ": "J", "MOVEC": "C", "TRIGGL": "L", "TRIGGJ": "J", "TRIGGC": "C",
    "MOVELDO": "L", "MOVEJDO": "J", "MOVECDO": "C", "MOVELSYNC": "L", "MOVEJSYNC": "J",
    "MOVECSYNC": "C", "MOVELGO": "L", "MOVEJGO": "J", "MOVECGO": "C", "MOVELAO": "L",
    "MOVEJAO": "J", "MOVECAO": "C",
}  # fmt: skip


def quaternion_to_rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix of a unit quaternion ``[w, x, y, z]`` (normalised here); shape (3, 3)."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _strip_comment(line: str) -> str:
    if "!" not in line:
        return line
    in_str = False
    for n, ch in enumerate(line):
        if ch == '"':
            in_str = not in_str
        elif ch == "!" and not in_str:
            return line[:n]
    return line


def _statements(text: str, source: str) -> list[tuple[int, str]]:
    out: list[tuple[int, str]] = []
    buf: list[str] = []
    start = 0
    in_header = False
    for lineno, raw in enumerate(lines(text), start=1):
        s = raw.strip()
        if s.startswith("%%%"):
            in_header = not in_header
            continue
        if in_header:
            continue
        s = _strip_comment(s).strip()
        if not s:
            continue
        if not buf:
            start = lineno
            if _BLOCK_WORDS.match(s) or _CONTROL.match(s):
                out.append((lineno, s.rstrip(";")))
                continue
        buf.append(s)
        joined = " ".join(buf)
        # a statement ends at a ';' outside strings
        in_str = False
        ends = False
        for ch in joined:
            if ch == '"':
                in_str = not in_str
        if not in_str and joined.rstrip().endswith(";"):
            ends = True
        if ends:
            body = joined.rstrip()[:-1].strip()
            if ";" in _no_strings(body):
                for part in _no_strings(body).split(";"):
                    if part.strip():
                        out.append((start, part.strip()))
            else:
                out.append((start, body))
            buf = []
    if buf:
        raise InputError(
            "statement not terminated by ';' (is the file truncated?)", source=f"{source}:{start}"
        )
    return out


def _no_strings(s: str) -> str:
    return re.sub(r'"[^"]*"', '""', s)


def _split_args(text: str) -> list[str]:
    """Split at commas outside brackets/parentheses/strings."""
    if '"' not in text:
        # no strings: join comma pieces until their brackets balance (C-speed counts)
        out: list[str] = []
        acc = ""
        depth = 0
        for piece in text.split(","):
            acc = piece if not acc and depth == 0 else acc + "," + piece
            depth += piece.count("[") + piece.count("(") - piece.count("]") - piece.count(")")
            if depth == 0:
                if acc.strip():
                    out.append(acc.strip())
                acc = ""
        if acc.strip():
            out.append(acc.strip())
        return out
    parts: list[str] = []
    cur: list[str] = []
    depth, in_str = 0, False
    for ch in text:
        if ch == '"':
            in_str = not in_str
        if not in_str:
            if ch in "[(":
                depth += 1
            elif ch in "])":
                depth -= 1
            if ch == "," and depth == 0:
                parts.append("".join(cur).strip())
                cur = []
                continue
        cur.append(ch)
    if "".join(cur).strip():
        parts.append("".join(cur).strip())
    return parts


_JSONISH = re.compile(r"\[[\[\]0-9eE+\-.,\s]*\]")


def _no_constant(name: str) -> float:
    raise ValueError(name)


def _nested(text: str, where: str) -> list[Any]:
    """Parse a RAPID aggregate literal ``[[1,2,3],[...]]`` into nested lists of floats."""
    t = text.strip()
    if _JSONISH.fullmatch(t):
        try:  # the common all-numeric literal, parsed in C
            return cast(list[Any], json.loads(t, parse_constant=_no_constant, parse_int=float))
        except ValueError:
            pass
    if not (t.startswith("[") and t.endswith("]")):
        raise InputError(f"expected a literal [...], found {text.strip()!r}", source=where)
    items = _split_args(t[1:-1])
    out: list[Any] = []
    for it in items:
        if it.startswith("["):
            out.append(_nested(it, where))
        else:
            try:
                v = float(it)
            except ValueError:
                raise InputError(
                    f"unsupported construct: expression {it!r} in a literal", source=where
                ) from None
            out.append(v)
    return out


class _Reader:
    def __init__(
        self,
        source: str,
        tol: float,
        tool_direction: str = "z",
        coordinates: str = "workpiece",
        spindle: tuple[str, float] | None = None,
    ) -> None:
        self.source = source
        # (analog output signal, rpm per unit) that sets the spindle speed
        self.spindle = (spindle[0].upper(), spindle[1]) if spindle is not None else None
        self.rpm = math.nan
        self.rpm_zero: tuple[int, str] | None = None  # the statement that set the output to 0
        # triggdata -> spindle speed it switches to, and the statement that set it
        self.triggs: dict[str, tuple[float, tuple[int, str] | None]] = {}
        self.tol = tol
        self.tool_direction = tool_direction
        self.coordinates = coordinates
        self.targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # pos mm, quaternion
        self.robtargets: set[str] = set()  # declared robtarget names
        self.unresolved: dict[str, str] = {}  # robtargets set at run time (CRobT(), ...)
        self.speeds: dict[str, float] = {}
        self.wobjs: dict[str, np.ndarray] = {"WOBJ0": np.eye(4)}  # uframe @ oframe (mm)
        self.wobj_used: str | None = None
        self.pos: np.ndarray | None = None
        self.rot: np.ndarray | None = None  # tool orientation at self.pos
        self.out = WaypointBuilder(source)

    def robtarget(self, text: str, where: str) -> tuple[np.ndarray, np.ndarray] | None:
        t = text.strip()
        if t.startswith("["):
            lit = _nested(t, where)
            try:
                pos = np.array(lit[0], dtype=np.float64)
                quat = np.array(lit[1], dtype=np.float64)
            except (IndexError, TypeError, ValueError):
                raise InputError(
                    "expected a robtarget [[x,y,z],[q1,q2,q3,q4],...]", where
                ) from None
            if pos.shape != (3,) or quat.shape != (4,):
                raise InputError("expected a robtarget [[x,y,z],[q1,q2,q3,q4],...]", where)
            if not np.all(np.isfinite(pos)) or float(np.max(np.abs(pos))) > 1e7:
                raise InputError(
                    f"robtarget position {pos.tolist()}: expected finite mm within 1e7", where
                )
            if not np.all(np.isfinite(quat)) or abs(np.linalg.norm(quat) - 1) > 1e-3:
                raise InputError(
                    f"quaternion {quat.tolist()} is not normalised "
                    f"(|q| = {np.linalg.norm(quat):.5f})",
                    where,
                )
            return pos, quat
        m = re.match(r"^OFFS\s*\((.*)\)$", t, re.IGNORECASE) if "(" in t else None
        if m:
            args = _split_args(m.group(1))
            if len(args) != 4:
                raise InputError(
                    f"Offs: expected (point, dx, dy, dz), found {len(args)} args", where
                )
            base = self.robtarget(args[0], where)
            if base is None:
                raise InputError("Offs of an unknown point", source=where)
            try:
                d = np.array([float(a) for a in args[1:]])
            except ValueError:
                raise InputError("Offs: expected numeric offsets", source=where) from None
            if not np.all(np.isfinite(d)):
                raise InputError("Offs: expected finite offsets", source=where)
            return base[0] + d, base[1]
        if "(" in t and re.match(r"^[A-Z_][A-Z0-9_]*\s*\(", t, re.IGNORECASE):
            fn = t.split("(")[0].strip()
            raise InputError(f"unsupported construct: function {fn} in a target", source=where)
        name = t.upper()
        if name in self.unresolved:
            raise InputError(
                f"robtarget {t} is set at run time ({self.unresolved[name]!r}): expected a "
                "literal or Offs() of one",
                source=where,
            )
        if name not in self.targets:
            raise InputError(f"unknown robtarget {t!r}", source=where)
        return self.targets[name]

    def assign(self, name: str, value: str, where: str) -> None:
        """``name := value`` for a robtarget variable (a failure marks it as run-time)."""
        try:
            tgt = self.robtarget(value, where)
        except InputError:
            self.unresolved[name] = value.strip()
            return
        assert tgt is not None
        self.targets[name] = tgt
        self.unresolved.pop(name, None)

    def speed(self, args: list[str], where: str) -> float:
        """TCP speed [mm/s] from the speeddata argument and an optional \\V:=."""
        v = math.nan
        pieces = [
            p.strip() for a in args for p in (re.split(r"(?=\\)", a) if "\\" in a else (a,))
            if p.strip()
        ]  # fmt: skip
        for a in pieces:
            m = re.match(r"^\\V\s*:=\s*(\S+)$", a, re.IGNORECASE)
            if m:
                return _speed(m.group(1), where)
        for a in pieces:
            u = a.strip().upper()
            m = re.match(r"^V(\d+(?:\.\d*)?)$", u)
            if m:
                return _speed(m.group(1), where)
            if u == "VMAX":
                return 5000.0
            if u in self.speeds:
                return _speed(str(self.speeds[u]), where)
        return v

    def wobj(self, args: list[str], where: str) -> np.ndarray:
        """The work object frame of a move (``\\WObj:=name``; default wobj0)."""
        name = "WOBJ0"
        for a in args:
            if "\\" not in a:
                continue
            for piece in re.split(r"(?=\\)", a):
                m = re.match(r"^\\WOBJ\s*:=\s*([A-Za-z_]\w*)\s*$", piece.strip(), re.IGNORECASE)
                if m:
                    name = m.group(1).upper()
        if self.wobj_used is not None and name != self.wobj_used and self.coordinates != "machine":
            self.out.warn(
                f"moves in different work objects ({self.wobj_used} and {name}): positions are "
                "taken as programmed in each (set coordinates = 'machine' to apply them)",
                int(where.rsplit(":", 1)[1]),
                key="wobj-mix",
            )
        self.wobj_used = name
        if self.coordinates != "machine":
            return np.eye(4)
        if name not in self.wobjs:
            raise InputError(
                f"coordinates = 'machine' needs the work object {name} as a literal wobjdata "
                "in this module",
                where,
            )
        return self.wobjs[name]

    def statement(self, lineno: int, stmt: str) -> str | None:
        """Apply one statement; return the name of a called procedure, if any."""
        where = f"{self.source}:{lineno}"
        s = stmt.strip()
        if _BLOCK_WORDS.match(s):
            return None
        if _CONTROL.match(s):
            raise InputError(
                f"unsupported construct: control flow {s.split()[0].upper()} (the path depends "
                "on run-time conditions; export the moves as a straight sequence)",
                source=where,
            )
        m = re.match(
            r"^(?:LOCAL\s+|TASK\s+)?(CONST|PERS|VAR)\s+([A-Za-z_]\w*)\s+([A-Za-z_]\w*)\s*(?::=\s*(.*))?$",
            s,
            re.DOTALL,
        )
        if m:
            _, typ, name, value = m.groups()
            typ = typ.lower()
            if typ == "robtarget":
                self.robtargets.add(name.upper())
                if value is not None:
                    self.assign(name.upper(), value, where)
            elif typ == "speeddata" and value is not None:
                lit = _nested(value, where)
                self.speeds[name.upper()] = float(lit[0])
            elif typ == "wobjdata" and value is not None:
                self.wobjs[name.upper()] = _wobj_frame(value, where)
            elif typ == "tooldata":
                logger.info("%s: tooldata %s not applied (the path is the TCP's)", where, name)
            return None
        head = re.match(r"^([A-Za-z_]\w*)\s*(.*)$", s, re.DOTALL)
        if not head:
            raise InputError(f"unsupported RAPID statement {s!r}", source=where)
        word, rest = head.group(1).upper(), head.group(2).strip()
        if rest.startswith(":=") or (rest.startswith(".") and ":=" in rest):
            if word in self.robtargets:
                if rest.startswith(":="):
                    self.assign(word, rest[2:], where)
                else:  # a component (p.trans.x := ...): the value is now the program's
                    self.unresolved[word] = word + rest
            return None  # assignment
        if self.spindle is not None and word in ("SETAO", "TRIGGIO"):
            self.analog(word, rest, where)
            return None
        if word in _MOVES:
            self.move(_MOVES[word], rest, lineno, where)
            return None
        if word == "MOVEABSJ" or word == "MOVEEXTJ":
            logger.info("%s: %s to a joint target left out of the path", where, word)
            return None
        if word in _IGNORED:
            return None
        return word

    def analog(self, word: str, rest: str, where: str) -> None:
        """``SetAO sig, v`` (the speed from the next move on) or ``TriggIO t, 0 \\Start
        \\AOp:=sig, v`` (the speed from the start of the next move that uses ``t``)."""
        assert self.spindle is not None
        sig, per_unit = self.spindle
        args = [a.strip() for a in _split_args(rest) if a.strip()]
        if word == "SETAO":
            if len(args) == 2 and args[0].upper() == sig:
                v = finite(args[1], where, f"SetAO {args[0]}")
                self.rpm = v * per_unit if v > 0 else math.nan
                self.rpm_zero = None if v > 0 else (_line(where), f"SetAO {args[0]}, {v:g}")
            return
        joined = " ".join(args)
        m = re.search(r"\\AOP\s*:=\s*([A-Za-z_]\w*)", joined, re.IGNORECASE)
        if not m or m.group(1).upper() != sig:
            return
        if len(args) < 3:
            raise InputError(
                f"TriggIO: expected triggdata, distance and value, found {rest!r}", where
            )
        dist = re.split(r"\\", args[1])[0].strip()
        if finite(dist, where, "TriggIO distance") != 0 or not re.search(
            r"\\START\b", joined, re.IGNORECASE
        ):
            raise InputError(
                f"TriggIO on the spindle output {m.group(1)}: expected distance 0 \\Start (the "
                f"start of the move), found {args[1]!r}",
                where,
            )
        v = finite(args[-1], where, f"TriggIO {m.group(1)}")
        zero = None if v > 0 else (_line(where), f"TriggIO {args[0]} to {m.group(1)} = {v:g}")
        self.triggs[args[0].upper()] = (v * per_unit if v > 0 else math.nan, zero)

    def move(self, kind: str, rest: str, lineno: int, where: str) -> None:
        args = [a for a in _split_args(rest) if a]
        for a in args:
            t = re.split(r"\\", a.strip())[0].strip().upper()
            if t in self.triggs:
                self.rpm, self.rpm_zero = self.triggs[t]
        # leading optional switches like \Conc
        while args and args[0].startswith("\\"):
            args.pop(0)
        n_pts = 2 if kind == "C" else 1
        if len(args) < n_pts + 1:
            raise InputError(f"Move{kind}: expected target(s) and speeddata, found {rest!r}", where)
        pts = []
        for a in args[:n_pts]:
            t = self.robtarget(a, where)
            assert t is not None
            pts.append(t)
        rapid = kind == "J"
        v = self.speed(args[n_pts:], where)
        frame = self.wobj(args[n_pts:], where)
        feed = math.nan if rapid else v * 60.0
        if self.rpm_zero is not None and not rapid:
            self.out.feed_at_zero_speed(lineno, self.rpm_zero)
        r_w, o_w = frame[:3, :3], frame[:3, 3]
        end_pos = r_w @ pts[-1][0] + o_w
        rot = r_w @ quaternion_to_rotation(pts[-1][1])
        axis, ref = tool_axes(rot, self.tool_direction)
        if kind == "C":
            if self.pos is None:
                raise InputError("MoveC before any position", source=where)
            via = r_w @ pts[0][0] + o_w
            arc = arc_through(self.pos, via, end_pos, tol=self.tol, where=where)
            rot0 = self.rot if self.rot is not None else rot
            ax_k, ref_k = tool_axes(
                orientations_along(self.pos, rot0, rot, arc), self.tool_direction
            )
            for p, a, r in zip(arc, ax_k, ref_k, strict=True):
                self.out.add(
                    p * 1e-3, a, line=lineno, rapid=False, feed_mm_per_min=feed, ref=r, rpm=self.rpm
                )
        else:
            self.out.add(
                end_pos * 1e-3, axis, line=lineno, rapid=rapid, feed_mm_per_min=feed, ref=ref,
                rpm=self.rpm,
            )  # fmt: skip
        self.pos = end_pos
        self.rot = rot


def _line(where: str) -> int:
    """The line number of a ``file:line`` location."""
    return int(where.rsplit(":", 1)[1])


def _speed(text: str, where: str) -> float:
    v = finite(text, where, "speed")
    if v <= 0:
        raise InputError(f"expected a positive TCP speed [mm/s], found {text!r}", source=where)
    return v


def _wobj_frame(value: str, where: str) -> np.ndarray:
    """uframe @ oframe of a wobjdata literal [robhold, ufprog, ufmec, uframe, oframe] (mm)."""
    lit = _nested_loose(value, where)
    try:
        frames = [x for x in lit if isinstance(x, list)]
        uf, of = frames[0], frames[1]
        out = np.eye(4)
        for fr in (uf, of):
            t = np.eye(4)
            t[:3, :3] = quaternion_to_rotation(np.array(fr[1], dtype=np.float64))
            t[:3, 3] = np.array(fr[0], dtype=np.float64)
            out = out @ t
    except (IndexError, TypeError, ValueError):
        raise InputError(
            "expected a wobjdata [b, b, s, [[x,y,z],[q]], [[x,y,z],[q]]]", where
        ) from None
    return out


def _nested_loose(text: str, where: str) -> list[Any]:
    """Like :func:`_nested`, keeping non-numeric items (TRUE, strings) as text."""
    t = text.strip()
    if not (t.startswith("[") and t.endswith("]")):
        raise InputError(f"expected a literal [...], found {text.strip()!r}", source=where)
    out: list[Any] = []
    for it in _split_args(t[1:-1]):
        if it.startswith("["):
            out.append(_nested_loose(it, where))
        else:
            try:
                out.append(float(it))
            except ValueError:
                out.append(it)
    return out


def _procedures(
    stmts: list[tuple[int, str]],
) -> tuple[list[tuple[int, str]], dict[str, list[tuple[int, str]]], list[str], bool]:
    """Module-level statements, procedure bodies by name, procedure order, ENDMODULE seen."""
    top: list[tuple[int, str]] = []
    procs: dict[str, list[tuple[int, str]]] = {}
    order: list[str] = []
    cur: list[tuple[int, str]] | None = None
    ended = False
    skipping = ""  # FUNC or TRAP routines: not motion code (function calls in targets are refused)
    for lineno, st in stmts:
        if skipping:
            if re.match(rf"^END{skipping}\b", st, re.IGNORECASE):
                skipping = ""
            continue
        mf = re.match(r"^(?:LOCAL\s+)?(FUNC|TRAP)\b", st, re.IGNORECASE)
        if mf and cur is None:
            skipping = mf.group(1).upper()
            continue
        m = re.match(r"^(?:LOCAL\s+)?PROC\s+([A-Za-z_]\w*)", st, re.IGNORECASE)
        if m and cur is None:
            name = m.group(1).upper()
            cur = procs.setdefault(name, [])
            order.append(name)
            continue
        if re.match(r"^ENDPROC\b", st, re.IGNORECASE):
            cur = None
            continue
        if re.match(r"^ENDMODULE\b", st, re.IGNORECASE):
            ended = True
            continue
        if cur is None:
            top.append((lineno, st))
        else:
            cur.append((lineno, st))
    if cur is not None:
        order.append("\x00open")
    return top, procs, order, ended


def parse_rapid(
    text: str,
    source: str = "<rapid>",
    *,
    arc_tol_mm: float = 0.01,
    tool_direction: str = "z",
    coordinates: str = "workpiece",
    spindle_output: str | None = None,
    spindle_rpm_per_unit: float | None = None,
) -> pd.DataFrame:
    """Read RAPID text into the waypoint table.

    Parameters
    ----------
    text : str
        Module text.
    source : str
        File name for the ``source`` column and messages.
    arc_tol_mm : float
        Chord tolerance of linearised arcs [mm].
    tool_direction : {"z", "x"}
        Tool frame axis along the working direction: ``z`` (ABB's convention)
        or ``x`` (a tool frame defined the KUKA way).
    coordinates : {"workpiece", "machine"}
        ``workpiece``: targets as programmed in their work object (a warning
        when moves use different ones). ``machine``: each move's ``\\WObj``
        (uframe and oframe of a literal wobjdata in the module) applied.
    spindle_output, spindle_rpm_per_unit : optional
        The analog output signal that sets the spindle speed and the rpm per
        unit of its value (job section ``[program]``); with both, ``SetAO``
        and ``TriggIO ... \\AOp`` on that signal set the programmed speed.

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
        spindle = (str(spindle_output), float(spindle_rpm_per_unit))
    rd = _Reader(source, arc_tol_mm, tool_direction, coordinates, spindle)
    stmts = _statements(text, source)
    if not stmts:
        raise InputError("expected a RAPID module, found no statements", source=source)
    top, procs, order, ended = _procedures(stmts)
    if "\x00open" in order:
        rd.out.warn(
            f"PROC {order[-2]} has no ENDPROC: {TRUNCATED} (the path read so far is planned)"
        )
        order = order[:-1]
    elif not ended and any(re.match(r"^MODULE\b", s, re.IGNORECASE) for _, s in stmts):
        rd.out.warn(f"MODULE without ENDMODULE: {TRUNCATED}")
    for lineno, st in top:
        called = rd.statement(lineno, st)
        if called is not None:
            raise InputError(f"statement outside a PROC: {st!r}", source=f"{source}:{lineno}")

    def run(body: list[tuple[int, str]], depth: int, name: str) -> None:
        for lineno, st in body:
            called = rd.statement(lineno, st)
            if called is None:
                continue
            if called in procs and called != name:
                if depth > 20:
                    raise InputError(
                        f"procedure calls nested deeper than 20 levels ({called})",
                        f"{source}:{lineno}",
                    )
                run(procs[called], depth + 1, called)
            else:
                rd.out.warn(
                    f"call to {called} ignored (not a procedure of this module: its motions "
                    "are not followed)",
                    lineno,
                    key=f"call-{called}",
                )

    if "MAIN" in procs:
        run(procs["MAIN"], 0, "MAIN")
    elif len(order) == 1:
        run(procs[order[0]], 0, order[0])
    elif order:
        rd.out.warn(f"no PROC main: the procedures are read in file order ({', '.join(order)})")
        for name in order:
            run(procs[name], 0, name)
    df = rd.out.table()
    df.attrs["warnings"] = rd.out.notes()
    return df


def read_rapid(path: str | Path, **options: float | str) -> pd.DataFrame:
    """Read a RAPID module file (see :func:`parse_rapid`)."""
    p = Path(path)
    return parse_rapid(read_text(p), p.name, **options)  # type: ignore[arg-type]


# ------------------------------------------------------------------ writer
# ABB conventions (RAPID Instructions, Functions and Data Types reference:
# speeddata, SetAO, TriggIO, TriggL, TriggC): the TCP speed is the first
# component of the move's speeddata [mm/s]: each new feed gets a speeddata of
# its own (its other components copied from the speeddata it replaces) and
# the move names it. The spindle speed is an analog output: set by SetAO
# before the first motion (the spindle runs up before the cut), changed
# either path-synchronously ("triggio": TriggIO trig, 0 \Start \AOp:=sig,
# value; and the move as TriggL/TriggC with that triggdata, so the output
# switches at the move's start point) or by SetAO before the move ("setao":
# the output switches when the program pointer gets there, which in a zone
# is ahead of the robot). Changed statements are announced by "! ROBOLOBE"
# comments.

_PREDEFINED_V = re.compile(r"^V(\d+(?:\.\d*)?)$", re.IGNORECASE)
_TRIGG = "trRobolobeSpindle"


def write_rapid(
    text: str, source: str, edit: ProgramEdit, *, coordinates: str = "workpiece"
) -> str:
    """Write a RAPID module with the speeds and feeds of ``edit``.

    Parameters
    ----------
    text : str
        The module as read (:func:`parse_rapid` made ``edit.waypoints`` of it).
    source : str
        Its file name (messages).
    edit : ProgramEdit
        ``edit.options``: ``analog_output`` (signal name),
        ``analog_rpm_full_scale``, ``analog_full_scale``, ``rapid_sync``
        (``"triggio"`` or ``"setao"``).
    coordinates : {"workpiece", "machine"}
        As the reader was told: with ``machine`` the points were read through
        the work objects, whose frame ``Offs`` shifts a pass in.

    Returns
    -------
    str

    Raises
    ------
    InputError
        Analog scaling keys missing; passes over a run of moves that is not
        one statement per line in file order; a move that cannot carry a
        trigger (``rapid_sync = "triggio"`` on other than
        MoveL/MoveC); a move whose speed argument is not on its first line.
    """
    opt = edit.options
    missing = [k for k in ("analog_output", "analog_rpm_full_scale") if opt.get(k) is None]
    if missing:
        raise InputError(
            "RAPID output sets the spindle speed by an analog output: expected the job keys "
            "[program] analog_output (signal name) and analog_rpm_full_scale (rpm at full "
            f"scale), found {', '.join(missing)} missing",
            source=source,
        )
    sig = str(opt["analog_output"])
    if not re.fullmatch(r"[A-Za-z_]\w*", sig):
        raise InputError(f"[program] analog_output: expected a RAPID signal name, found {sig!r}")
    per_unit = float(opt["analog_rpm_full_scale"]) / float(opt.get("analog_full_scale", 1.0))
    sync = str(opt.get("rapid_sync", "triggio"))
    src = lines(text)
    vals = line_values(edit)
    stmts = _statements(text, source)
    s_want = {ln: fmt_num(v[0] / per_unit, 12, point=False) for ln, v in vals.items()}
    full_scale = float(opt.get("analog_full_scale", 1.0))
    top = max((v[0] for v in vals.values()), default=0.0)
    if top / per_unit > full_scale * (1 + 1e-12):
        raise InputError(
            f"[program] analog_rpm_full_scale: {top:g} rpm is beyond the output's full scale "
            f"({per_unit * full_scale:g} rpm at {full_scale:g})",
            source=source,
        )
    # the module's speeddata literals (to copy their orientation and external-axis speeds)
    sdata: dict[str, list[str]] = {}
    for _, st in stmts:
        m = re.match(
            r"^(?:LOCAL\s+|TASK\s+)?(?:CONST|PERS|VAR)\s+speeddata\s+([A-Za-z_]\w*)\s*:=\s*\[(.*)\]$",
            st,
            re.IGNORECASE | re.DOTALL,
        )
        if m:
            sdata[m.group(1).upper()] = [x.strip() for x in m.group(2).split(",")]
    s_set: dict[int, str | None] = {}
    moves: dict[int, tuple[str, list[str], str]] = {}
    all_moves: dict[int, tuple[str, list[str]]] = {}
    first_motion: int | None = None
    first_proc: int | None = None
    for ln, st in stmts:
        head = re.match(r"^([A-Za-z_]\w*)\s*(.*)$", st, re.DOTALL)
        if not head:
            continue
        word, rest = head.group(1).upper(), head.group(2)
        if first_proc is None and re.match(r"^(LOCAL\s+)?PROC\b", st, re.IGNORECASE):
            first_proc = ln
        if word == "SETAO":
            args = [a.strip() for a in _split_args(rest) if a.strip()]
            if args and args[0].upper() == sig.upper():
                s_set[ln] = args[1] if len(args) == 2 and _is_number(args[1]) else None
        elif word == "TRIGGIO" and re.search(r"\\AOP\s*:=\s*" + sig + r"\b", rest, re.I):
            s_set[ln] = None
        elif word in _MOVES:
            all_moves[ln] = (word, [a for a in _split_args(rest) if a])
            if first_motion is None:
                first_motion = ln
            if ln in vals:
                moves[ln] = (word, [a for a in _split_args(rest) if a], st)
    s_edits, s_ins = modal_values(s_set, s_want)
    before: dict[int, list[str]] = {}
    out_lines: dict[int, str] = {}
    decls: list[str] = []
    names: dict[tuple[str, str], str] = {}
    first_cut = min(vals) if vals else None
    if first_cut is not None and first_cut in s_ins and first_motion is not None:
        before.setdefault(first_motion, []).append(
            f"{_indent(src[first_motion - 1])}SetAO {sig}, {s_ins.pop(first_cut)}; "
            f"! ROBOLOBE spindle speed {fmt_num(vals[first_cut][0], 0, point=False)} rpm "
            f"({fmt_num(per_unit, 6, point=False)} rpm per unit)"
        )
    for ln, v in s_edits.items():
        raw = src[ln - 1]
        m = re.search(r"(SetAO\s+\w+\s*,\s*)([-+0-9.Ee]+)", raw, re.IGNORECASE)
        if m is None:
            raise InputError(
                "SetAO on the spindle output: expected it on one line", f"{source}:{ln}"
            )
        out_lines[ln] = (
            raw[: m.start(2)] + v + raw[m.end(2) :] + f" ! ROBOLOBE spindle speed: was {m.group(2)}"
        )
    trigg_used = False
    for ln, (word, args, _) in moves.items():
        rpm, f, margin = vals[ln]
        raw = src[ln - 1]
        n_pts = 2 if word.endswith("C") or word in ("TRIGGC",) else 1
        k0 = 0
        while k0 < len(args) and args[k0].startswith("\\"):
            k0 += 1
        if len(args) < k0 + n_pts + 1:
            raise InputError(f"{word}: expected targets and speeddata", f"{source}:{ln}")
        speed_arg = args[k0 + n_pts].strip()
        base = re.split(r"\\", speed_arg)[0].strip()
        tail = "".join(
            "\\" + p for p in re.split(r"\\", speed_arg)[1:] if not p.upper().startswith("V")
        )
        comps = sdata.get(base.upper())
        if comps is None:
            mv = _PREDEFINED_V.match(base)
            comps = [mv.group(1) if mv else base, "500", "5000", "1000"]
        v_tcp = fmt_num(f / 60.0, 9, point=False)
        key = (v_tcp, ",".join(comps[1:]))
        if key not in names:
            names[key] = f"vRl{len(names) + 1}"
            decls.append(
                f"    CONST speeddata {names[key]}:=[{v_tcp},{','.join(comps[1:])}]; "
                f"! ROBOLOBE {fmt_num(f, 3, point=False)} mm/min"
            )
        new_speed = names[key] + tail
        note = [f"speed {base} -> {names[key]}"]
        pos = raw.find(speed_arg)
        if pos < 0:
            raise InputError(
                f"{word}: the speed argument is not on the statement's first line; "
                "join the statement on one line",
                f"{source}:{ln}",
            )
        new_raw = raw[:pos] + new_speed + raw[pos + len(speed_arg) :]
        if ln in s_ins:
            m_txt = f", margin {margin:.2f}" if math.isfinite(margin) else ""
            note.append(f"spindle {fmt_num(rpm, 0, point=False)} rpm{m_txt}")
            if sync == "setao":
                before.setdefault(ln, []).append(
                    f"{_indent(raw)}SetAO {sig}, {s_ins[ln]}; ! ROBOLOBE spindle speed "
                    f"{fmt_num(rpm, 0, point=False)} rpm{m_txt}"
                )
            else:
                if word not in ("MOVEL", "MOVEC"):
                    raise InputError(
                        f"{word}: a path-synchronous spindle change needs MoveL or MoveC "
                        "(becoming TriggL/TriggC); set [program] rapid_sync = 'setao'",
                        f"{source}:{ln}",
                    )
                trigg_used = True
                before.setdefault(ln, []).append(
                    f"{_indent(raw)}TriggIO {_TRIGG}, 0 \\Start \\AOp:={sig}, {s_ins[ln]}; "
                    f"! ROBOLOBE spindle speed {fmt_num(rpm, 0, point=False)} rpm{m_txt}"
                )
                kw = re.search(r"\bMove([LC])\b", new_raw, re.IGNORECASE)
                assert kw is not None
                new_raw = (
                    new_raw[: kw.start()] + "Trigg" + kw.group(1).upper() + new_raw[kw.end() :]
                )
                p2 = new_raw.find(new_speed)
                new_raw = (
                    new_raw[: p2 + len(new_speed)] + f", {_TRIGG}" + new_raw[p2 + len(new_speed) :]
                )
        out_lines[ln] = new_raw.rstrip() + " ! ROBOLOBE " + "; ".join(note)
    secs = sections(edit)
    if secs and coordinates == "machine" and re.search(r"\\WObj\s*:=", text, re.IGNORECASE):
        raise InputError(
            "passes in RAPID read with coordinates = 'machine' through work objects are not "
            "written (Offs shifts in the work object's frame); plan with coordinates = "
            "'workpiece'",
            source=source,
        )
    if secs:
        stmt_lines = {ln for ln, _ in stmts}
        per_unit_sig = (sig, per_unit)
        for sec in secs:
            _rapid_pass_block(
                edit, sec, src, stmt_lines, all_moves, out_lines, before, per_unit_sig, source
            )
    if trigg_used:
        decls.insert(0, f"    VAR triggdata {_TRIGG};")
    if decls:
        if first_proc is None:
            raise InputError("expected a PROC in the module", source=source)
        before.setdefault(first_proc, [])[0:0] = [*decls, ""]
    res: list[str] = []
    for ln in range(1, len(src) + 1):
        res.extend(before.get(ln, []))
        res.append(out_lines.get(ln, src[ln - 1]))
    return "\n".join(res) + "\n"


def _targets(word: str, args: list[str]) -> tuple[list[str], int]:
    """The target arguments of a move (after optional switches) and where its speed is."""
    k0 = 0
    while k0 < len(args) and args[k0].startswith("\\"):
        k0 += 1
    n_pts = 2 if word.endswith("C") else 1
    return [a.strip() for a in args[k0 : k0 + n_pts]], k0 + n_pts


def _offs(target: str, d: np.ndarray) -> str:
    x, y, z = (fmt_num(float(v), 9, point=False) for v in d)
    return f"Offs({target},{x},{y},{z})"


def _rapid_pass_block(
    edit: ProgramEdit,
    sec: Section,
    src: list[str],
    stmt_lines: set[int],
    all_moves: dict[int, tuple[str, list[str]]],
    out_lines: dict[int, str],
    before: dict[int, list[str]],
    spindle: tuple[str, float],
    source: str,
) -> None:
    """The shallower passes of one section, inserted before it: its moves with their targets
    in ``Offs(target, shift along the tool axis)``, MoveJ links between them."""
    wp_lines = edit.waypoints["line"].to_numpy()
    pos_mm = edit.waypoints[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64) * 1e3
    first, last = int(wp_lines[sec.start]), int(wp_lines[sec.stop - 1])
    prev = int(wp_lines[sec.start - 1])
    where = f"{source}:{first}"
    seq = wp_lines[sec.start : sec.stop]
    if np.any(np.diff(seq) < 0) or prev not in all_moves or prev >= first:
        raise InputError(
            "passes in RAPID: the run of cutting moves must follow the move before it in the "
            "file (no procedure calls inside)",
            where,
        )
    for ln in range(first, last + 1):
        code = _strip_comment(src[ln - 1]).strip()
        if code and (ln not in stmt_lines or not code.endswith(";")):
            raise InputError(
                "passes in RAPID: expected one statement per line in the run of cutting moves",
                f"{source}:{ln}",
            )
    (start_t,), _ = _targets(*all_moves[prev])
    end_word, end_args = all_moves[last]
    end_ts, _ = _targets(end_word, end_args)
    end_t = end_ts[-1]
    w0, a0 = all_moves[first]
    _, ks = _targets(w0, a0)
    tail = ", ".join(a.strip() for a in a0[ks + 2 :])
    pw, pa = all_moves[prev]
    _, kp = _targets(pw, pa)
    link_speed = pa[kp].strip()
    # the target each link point is written from, by the row it lies above
    anchor = {sec.start - 1: start_t, sec.stop - 1: end_t}
    sig, per_unit = spindle
    restate = (
        f"    SetAO {sig}, {fmt_num(edit.rpm[sec.start] / per_unit, 12, point=False)}; "
        "! ROBOLOBE spindle speed at the pass start"
    )
    block: list[str] = []
    for ps in pass_layout(edit, sec, pos_mm):
        for p, row in ps.links:
            block.append(
                f"    MoveJ {_offs(anchor[row], p - pos_mm[row])}, {link_speed}, fine, {tail}; "
                f"! ROBOLOBE link to pass {ps.index} of {ps.count}"
            )
        if ps.restate:
            block.append(restate)
        if ps.own:
            break
        block.append(
            f"    ! ROBOLOBE pass {ps.index} of {ps.count}: "
            f"{fmt_num(ps.offset_mm, 4, point=False)} mm above the programmed depth"
        )
        for ln in range(first, last + 1):
            block.extend(x for x in before.get(ln, []) if not x.lstrip().startswith("!"))
            raw = out_lines.get(ln, src[ln - 1])
            if ln in all_moves:
                word, args = all_moves[ln]
                ts, _ = _targets(word, args)
                pos = raw.upper().find(word) + len(word)
                for t in ts:
                    j = raw.find(t, pos)
                    if j < 0:
                        raise InputError("passes in RAPID: target not found on its line", where)
                    new = _offs(t, ps.shift_mm)
                    raw = raw[:j] + new + raw[j + len(t) :]
                    pos = j + len(new)
            block.append(raw)
    before.setdefault(first, [])[0:0] = block


def _indent(raw: str) -> str:
    m = re.match(r"^\s*", raw)
    return m.group(0) if m else ""


def _is_number(text: str) -> bool:
    try:
        float(text.strip())
    except ValueError:
        return False
    return True
