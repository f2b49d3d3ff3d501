"""ABB RAPID reader (``.mod`` / ``.modx`` / ``.prg``).

``robtarget`` = ``[[x, y, z], [q1, q2, q3, q4], [cf1, cf4, cf6, cfx],
[eax_a, ...]]`` in mm in the work object, which is the workpiece (path)
frame; the quaternion is scalar first (q1 = w). ABB's tool convention makes
the tool **Z** axis the working direction (spindle to tip), so the tool axis
(tip to spindle) is ``-z_tool`` and the TCP x axis is ``x_tool``.

Supported: ``MoveL``, ``MoveJ`` (rapid), ``MoveC`` (circle point and end
point), their ``Trigg``/``DO``/``Sync`` variants (first arguments are the
targets), targets as literals, as ``CONST``/``PERS``/``VAR robtarget``
names (``LOCAL`` too), and ``Offs(p, dx, dy, dz)``; ``speeddata`` ``vN``
(N mm/s), ``vmax`` (5000 mm/s), user ``speeddata`` declarations (first
component, mm/s) and the ``\\V:=`` argument; optional switches such as
``\\Conc``; ``!`` comments; ``%%%`` headers; statements spanning lines.

Ignored on purpose: ``MODULE``/``ENDMODULE``/``PROC``/``ENDPROC``,
declarations of other types (tooldata, wobjdata, zonedata, num, ...),
``MoveAbsJ`` (a joint target: it leaves the Cartesian path, which resumes
at the next target) and the usual non-motion instructions (ConfL, ConfJ,
SingArea, AccSet, VelSet, SetDO, SetAO, SetGO, PulseDO, WaitTime, WaitDI,
WaitDO, WaitUntil, TPWrite, TPErase, Stop, Set, Reset, CorrClear,
PathAccLim, ...). Calls of other procedures are ignored with a warning.

Control flow (``IF``, ``FOR``, ``WHILE``, ``TEST``, ``GOTO``), ``RelTool``,
``CRobT`` and other functions in targets raise
:class:`~robolobe.errors.InputError` with ``file:line``.
"""

from __future__ import annotations

import logging
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.paths._arcs import arc_through
from robolobe.plan.paths._table import WaypointBuilder

__all__ = ["parse_rapid", "quaternion_to_rotation", "read_rapid"]

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
    for lineno, raw in enumerate(text.splitlines(), start=1):
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
        raise InputError("statement not terminated by ';'", source=f"{source}:{start}")
    return out


def _no_strings(s: str) -> str:
    return re.sub(r'"[^"]*"', '""', s)


def _split_args(text: str) -> list[str]:
    """Split at commas outside brackets/parentheses/strings."""
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


def _nested(text: str, where: str) -> list[Any]:
    """Parse a RAPID aggregate literal ``[[1,2,3],[...]]`` into nested lists of floats."""
    t = text.strip()
    if not (t.startswith("[") and t.endswith("]")):
        raise InputError(f"expected a literal [...], found {text.strip()!r}", source=where)
    items = _split_args(t[1:-1])
    out: list[Any] = []
    for it in items:
        if it.startswith("["):
            out.append(_nested(it, where))
        else:
            try:
                out.append(float(it))
            except ValueError:
                raise InputError(
                    f"unsupported construct: expression {it!r} in a literal", source=where
                ) from None
    return out


class _Reader:
    def __init__(self, source: str, tol: float) -> None:
        self.source = source
        self.tol = tol
        self.targets: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # pos mm, quaternion
        self.speeds: dict[str, float] = {}
        self.pos: np.ndarray | None = None
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
            if abs(np.linalg.norm(quat) - 1) > 1e-3:
                raise InputError(
                    f"quaternion {quat.tolist()} is not normalised "
                    f"(|q| = {np.linalg.norm(quat):.5f})",
                    where,
                )
            return pos, quat
        m = re.match(r"^OFFS\s*\((.*)\)$", t, re.IGNORECASE)
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
            return base[0] + d, base[1]
        if re.match(r"^[A-Z_][A-Z0-9_]*\s*\(", t, re.IGNORECASE):
            fn = t.split("(")[0].strip()
            raise InputError(f"unsupported construct: function {fn} in a target", source=where)
        name = t.upper()
        if name not in self.targets:
            raise InputError(f"unknown robtarget {t!r}", source=where)
        return self.targets[name]

    def speed(self, args: list[str], where: str) -> float:
        """TCP speed [mm/s] from the speeddata argument and an optional \\V:=."""
        v = math.nan
        pieces = [p.strip() for a in args for p in re.split(r"(?=\\)", a) if p.strip()]
        for a in pieces:
            m = re.match(r"^\\V\s*:=\s*([-+0-9.E]+)$", a, re.IGNORECASE)
            if m:
                return float(m.group(1))
        for a in pieces:
            u = a.strip().upper()
            m = re.match(r"^V(\d+(?:\.\d*)?)$", u)
            if m:
                return float(m.group(1))
            if u == "VMAX":
                return 5000.0
            if u in self.speeds:
                return self.speeds[u]
        return v

    def statement(self, lineno: int, stmt: str) -> None:
        where = f"{self.source}:{lineno}"
        s = stmt.strip()
        if _BLOCK_WORDS.match(s):
            return
        if _CONTROL.match(s):
            raise InputError(
                f"unsupported construct: control flow {s.split()[0].upper()}", source=where
            )
        m = re.match(
            r"^(?:LOCAL\s+|TASK\s+)?(CONST|PERS|VAR)\s+([A-Za-z_]\w*)\s+([A-Za-z_]\w*)\s*(?::=\s*(.*))?$",
            s,
            re.DOTALL,
        )
        if m:
            _, typ, name, value = m.groups()
            typ = typ.lower()
            if typ == "robtarget" and value is not None:
                tgt = self.robtarget(value, where)
                assert tgt is not None
                self.targets[name.upper()] = tgt
            elif typ == "speeddata" and value is not None:
                lit = _nested(value, where)
                self.speeds[name.upper()] = float(lit[0])
            elif typ in ("tooldata", "wobjdata"):
                logger.info(
                    "%s: %s %s not applied (path taken in the work object)", where, typ, name
                )
            return
        head = re.match(r"^([A-Za-z_]\w*)\s*(.*)$", s, re.DOTALL)
        if not head:
            raise InputError(f"unsupported RAPID statement {s!r}", source=where)
        word, rest = head.group(1).upper(), head.group(2).strip()
        if rest.startswith(":="):
            return  # assignment
        if word in _MOVES:
            self.move(_MOVES[word], rest, lineno, where)
            return
        if word == "MOVEABSJ" or word == "MOVEEXTJ":
            logger.info("%s: %s to a joint target left out of the path", where, word)
            return
        if word in _IGNORED:
            return
        logger.warning("%s: call to %s ignored (its motions are not followed)", where, word)

    def move(self, kind: str, rest: str, lineno: int, where: str) -> None:
        args = [a for a in _split_args(rest) if a]
        # leading optional switches like \Conc
        while args and args[0].startswith("\\"):
            args.pop(0)
        n_pts = 2 if kind == "C" else 1
        if len(args) < n_pts + 1:
            raise InputError(f"Move{kind}: expected target(s) and speeddata, found {rest!r}", where)
        pts = []
        for a in args[:n_pts]:
            # an optional argument glued to the target, e.g. p10 \ID:=..., is not RAPID syntax
            t = self.robtarget(a, where)
            assert t is not None
            pts.append(t)
        rapid = kind == "J"
        v = self.speed(args[n_pts:], where)
        feed = math.nan if rapid else v * 60.0
        end_pos, end_q = pts[-1]
        rot = quaternion_to_rotation(end_q)
        axis, ref = -rot[:, 2], rot[:, 0]
        if kind == "C":
            if self.pos is None:
                raise InputError("MoveC before any position", source=where)
            arc = arc_through(self.pos, pts[0][0], end_pos, tol=self.tol, where=where)
            for p in arc:
                self.out.add(
                    p * 1e-3, axis, line=lineno, rapid=False, feed_mm_per_min=feed, ref=ref
                )
        else:
            self.out.add(
                end_pos * 1e-3, axis, line=lineno, rapid=rapid, feed_mm_per_min=feed, ref=ref
            )
        self.pos = end_pos


def parse_rapid(text: str, source: str = "<rapid>", *, arc_tol_mm: float = 0.01) -> pd.DataFrame:
    """Read RAPID text into the waypoint table.

    Parameters
    ----------
    text : str
        Module text.
    source : str
        File name for the ``source`` column and messages.
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
    rd = _Reader(source, arc_tol_mm)
    for lineno, stmt in _statements(text, source):
        rd.statement(lineno, stmt)
    return rd.out.table()


def read_rapid(path: str | Path, **options: float) -> pd.DataFrame:
    """Read a RAPID module file (see :func:`parse_rapid`)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        text = p.read_text(encoding="latin-1")
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc}", source=str(p)) from None
    return parse_rapid(text, p.name, **options)
