"""FRFs of one posture as UFF (universal file format) dataset 58 files.

A hammer campaign may come as ``frf/<posture_id>.uff`` files beside
``postures.csv`` (docs/guide/campaign.md), one file per posture holding one
dataset 58 record per direction. Reading and writing go through `pyuff`.

What is written
---------------
One ASCII dataset 58 per direction present: function type 4 (frequency
response function), response node 1 and reference node 1 (the TCP),
response / reference direction codes 1 = +X, 2 = +Y, 3 = +Z (TCP axes),
complex double-precision ordinates, abscissa data type 18 (frequency, Hz),
ordinate numerator data type 8 (displacement; receptance m/N, the default),
11 (velocity; mobility (m/s)/N) or 12 (acceleration; accelerance
(m/s^2)/N), denominator data type 13 (force). Evenly spaced grids are
stored as minimum and increment, others with their abscissa values; UFF 58
keeps abscissas to 6 significant digits (format E13.5).

What is read
------------
Every dataset 58 / 58b of the file (:func:`read_uff_frfs`); other dataset
types are ignored. Each record must be an FRF (function type 4) between a
response and a reference degree of freedom, each a node number and a
translational direction code (+-1..+-3 = X, Y, Z; a negative code flips the
sign of the record). Direction 0 (a scalar channel with no direction) is
refused: the identification needs to know which FRFs are driving points.
Records are keyed by (response node, direction, reference node, direction):
a multi-reference file (a roving hammer or a roving accelerometer) holds one
record per pair, and a pair may appear once.

The response quantity comes from the ordinate unit label when it has one
(``m/N``, ``mm/N``, ``(m/s^2)/N``, ``m/s2/N``, ``(1/N)*(m/s²)``, ``g/N``,
``in/lbf``, ... with the denominator label when the ordinate label has no
force), else from the ordinate data type (8 displacement, 11 velocity,
12 acceleration, SI assumed). Labels that are not a length, velocity or
acceleration per force are refused by name, as are labels that contradict
the data type. Mobility is divided by ``i w`` and accelerance by ``-w^2`` to
give receptance [m/N]; for those the 0 Hz bin (where the division is
undefined) is dropped. Header text may be UTF-8 or Latin-1 (a byte-order mark
is skipped). Errors name the file, the line where the record starts and the
record number.

A posture of a campaign (:func:`read_uff_frf`) is the TCP: every record must
have one response node equal to one reference node, and share one grid.
"""

from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._atomic import check_input_file
from robolobe._directions import AXES
from robolobe._frf_checks import frf_value_problem
from robolobe.errors import InputError

__all__ = [
    "UFF_QUANTITIES",
    "UffFrf",
    "UffQuantity",
    "common_grid",
    "interpret_frf_units",
    "read_uff_frf",
    "read_uff_frfs",
    "write_uff_frf",
]

logger = logging.getLogger(__name__)

UffQuantity = Literal["displacement", "velocity", "acceleration"]
UFF_QUANTITIES: dict[str, int] = {"displacement": 8, "velocity": 11, "acceleration": 12}
"""Ordinate (numerator) specific data type codes of UFF 58 per response quantity."""

_UNITS = {"displacement": "m/N", "velocity": "m/s/N", "acceleration": "m/s^2/N"}


def _sci_exact(v: float) -> bool:
    return float(f"{v:13.5e}") == v


def write_uff_frf(
    path: str | os.PathLike[str],
    freq_hz: ArrayLike,
    H: ArrayLike,
    *,
    quantity: UffQuantity = "displacement",
    name: str = "",
) -> None:
    """Write one posture's FRFs as UFF 58 records (one per direction present).

    Parameters
    ----------
    path : path-like
        Output file (overwritten; write to a temporary path for atomicity).
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], strictly increasing.
    H : array_like, shape (n_freq, 3, 3), complex
        Receptance [m/N] (rows response, columns excitation, TCP axes);
        directions whose column entries are NaN are not written.
    quantity : {"displacement", "velocity", "acceleration"}
        Response quantity stored: receptance, mobility (``i w H``) or
        accelerance (``-w^2 H``).
    name : str
        Free text stored in the ID lines (e.g. the posture id).
    """
    import pyuff

    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex)
    if quantity not in UFF_QUANTITIES:
        raise InputError(
            f"expected quantity one of {sorted(UFF_QUANTITIES)}, found {quantity!r}",
            source="write_uff_frf",
        )
    if f.ndim != 1 or f.size < 2 or h.shape != (f.size, 3, 3):
        raise InputError(
            f"expected freq_hz (n,) with n >= 2 and H (n, 3, 3), found {f.shape} and {h.shape}",
            source="write_uff_frf",
        )
    w = 2 * np.pi * f
    factor = {"displacement": np.ones_like(w), "velocity": 1j * w, "acceleration": -(w**2)}[
        quantity
    ]
    step = np.diff(f)
    even = bool(
        np.allclose(step, step[0], rtol=1e-12, atol=0) and _sci_exact(f[0]) and _sci_exact(step[0])
    )
    sets: list[dict[str, Any]] = []
    for r in range(3):
        for e in range(3):
            col = h[:, r, e]
            if np.all(np.isnan(col)):
                continue
            if not np.all(np.isfinite(col)):
                raise InputError(
                    f"direction {AXES[r] + AXES[e]}: expected finite values or all NaN",
                    source="write_uff_frf",
                )
            sets.append(
                pyuff.prepare_58(
                    binary=0,
                    id1=f"robolobe FRF {name}"[:80],
                    id2=f"dir {AXES[r]}{AXES[e]} (response, excitation), TCP axes"[:80],
                    func_type=4,
                    rsp_ent_name="TCP",
                    rsp_node=1,
                    rsp_dir=r + 1,
                    ref_ent_name="TCP",
                    ref_node=1,
                    ref_dir=e + 1,
                    abscissa_spacing=1 if even else 0,
                    abscissa_spec_data_type=18,
                    abscissa_axis_units_lab="Hz",
                    ordinate_spec_data_type=UFF_QUANTITIES[quantity],
                    ordinate_axis_units_lab=_UNITS[quantity],
                    orddenom_spec_data_type=13,
                    orddenom_axis_units_lab="N",
                    data=np.ascontiguousarray(col * factor),
                    x=f,
                )
            )
    if not sets:
        raise InputError("no direction to write: every column of H is NaN", source=str(path))
    uff = pyuff.UFF(os.fspath(path))
    uff.write_sets(sets, mode="overwrite")


# ------------------------------------------------------------------ reading

_DIR_NAMES = {1: "+X", 2: "+Y", 3: "+Z", -1: "-X", -2: "-Y", -3: "-Z"}
_QUANTITY_NAMES = {8: "displacement", 11: "velocity", 12: "acceleration"}
_G0 = 9.80665
# unit symbol -> (scale to SI, length exponent, time exponent, force exponent)
_UNIT_SYMBOLS: dict[str, tuple[float, int, int, int]] = {
    "m": (1.0, 1, 0, 0),
    "mm": (1e-3, 1, 0, 0),
    "cm": (1e-2, 1, 0, 0),
    "um": (1e-6, 1, 0, 0),
    "\u00b5m": (1e-6, 1, 0, 0),
    "\u03bcm": (1e-6, 1, 0, 0),
    "micron": (1e-6, 1, 0, 0),
    "in": (0.0254, 1, 0, 0),
    "inch": (0.0254, 1, 0, 0),
    "ft": (0.3048, 1, 0, 0),
    "s": (1.0, 0, 1, 0),
    "sec": (1.0, 0, 1, 0),
    "ms": (1e-3, 0, 1, 0),
    "n": (1.0, 0, 0, 1),
    "kn": (1e3, 0, 0, 1),
    "lbf": (4.4482216152605, 0, 0, 1),
    "g": (_G0, 1, -2, 0),  # standard gravity (an FRF label, not gram)
    "1": (1.0, 0, 0, 0),
}
_SUPERSCRIPTS = str.maketrans({"\u00b2": "^2", "\u00b3": "^3", "\u00b9": "^1", "\u207b": "-"})


@dataclass(frozen=True, eq=False)
class UffFrf:
    """One FRF record of a UFF file, converted to receptance.

    Attributes
    ----------
    record : int
        Position of the dataset in the file (1-based, all dataset types counted).
    line : int
        Line of the file where the record starts (its ``-1`` delimiter), 1-based.
    rsp_node, ref_node : int
        Response and reference (excitation) node numbers.
    rsp_dir, ref_dir : int
        Direction 1, 2, 3 (X, Y, Z); the sign of a negative code is applied to ``H``.
    quantity : str
        ``displacement``, ``velocity`` or ``acceleration``: what the file stored.
    scale : float
        Factor applied to the stored values for SI units (from the unit label).
    freq_hz : ndarray, shape (n_freq,)
    H : ndarray of complex, shape (n_freq,)
        Receptance [m/N].
    """

    record: int
    line: int
    rsp_node: int
    rsp_dir: int
    ref_node: int
    ref_dir: int
    quantity: str
    scale: float
    freq_hz: NDArray[np.float64]
    H: NDArray[np.complex128]

    @property
    def key(self) -> tuple[int, int, int, int]:
        """``(rsp_node, rsp_dir, ref_node, ref_dir)``."""
        return (self.rsp_node, self.rsp_dir, self.ref_node, self.ref_dir)

    @property
    def driving_point(self) -> bool:
        """Response and reference are the same node and direction."""
        return self.rsp_node == self.ref_node and self.rsp_dir == self.ref_dir

    @property
    def label(self) -> str:
        """``"<rsp node><dir>/<ref node><dir>"``, e.g. ``"1+X/3+X"``."""
        return (
            f"{self.rsp_node}{_DIR_NAMES[self.rsp_dir]}/{self.ref_node}{_DIR_NAMES[self.ref_dir]}"
        )


def _parse_unit_factor(text: str) -> tuple[float, int, int, int] | None:
    """Scale and (length, time, force) exponents of a label like ``(m/s^2)/N``; None if unknown."""
    t = text.strip().translate(_SUPERSCRIPTS).replace("**", "^").replace(" ", "")
    t = t.replace("\u00b7", "*")
    if not t:
        return None
    tokens = re.findall(r"\(|\)|\*|/|\^-?\d+|[A-Za-z\u00b5\u03bc]+\d*|\d+", t)
    if "".join(tokens) != t:
        return None
    pos = 0

    def factor() -> tuple[float, int, int, int] | None:
        nonlocal pos
        if pos >= len(tokens):
            return None
        tok = tokens[pos]
        if tok == "(":
            pos += 1
            val = expr()
            if val is None or pos >= len(tokens) or tokens[pos] != ")":
                return None
            pos += 1
        else:
            m = re.fullmatch(r"([A-Za-z\u00b5\u03bc]+)(\d*)|(\d+)", tok)
            if m is None:
                return None
            pos += 1
            if m.group(3) is not None:
                if m.group(3) != "1":
                    return None
                val = (1.0, 0, 0, 0)
            else:
                sym = m.group(1)
                key = sym if sym in ("\u00b5m", "\u03bcm") else sym.lower()
                if key not in _UNIT_SYMBOLS:
                    return None
                val = _UNIT_SYMBOLS[key]
                if m.group(2):  # s2 = s^2
                    val = _power(val, int(m.group(2)))
        if pos < len(tokens) and tokens[pos].startswith("^"):
            val = _power(val, int(tokens[pos][1:]))
            pos += 1
        return val

    def expr() -> tuple[float, int, int, int] | None:
        nonlocal pos
        val = factor()
        while val is not None and pos < len(tokens) and tokens[pos] in ("*", "/"):
            op = tokens[pos]
            pos += 1
            rhs = factor()
            if rhs is None:
                return None
            if op == "/":
                rhs = _power(rhs, -1)
            val = (val[0] * rhs[0], val[1] + rhs[1], val[2] + rhs[2], val[3] + rhs[3])
        return val

    out = expr()
    return out if out is not None and pos == len(tokens) else None


def _power(v: tuple[float, int, int, int], n: int) -> tuple[float, int, int, int]:
    return (v[0] ** n, v[1] * n, v[2] * n, v[3] * n)


def interpret_frf_units(ordinate: str, denominator: str = "") -> tuple[str, float] | None:
    """Quantity and SI scale of an FRF from its UFF unit labels.

    Parameters
    ----------
    ordinate : str
        Ordinate (numerator) unit label, e.g. ``"m/s^2/N"``, ``"(1/N)*(m/s\u00b2)"``,
        ``"g"`` (with ``denominator`` ``"N"``).
    denominator : str
        Ordinate denominator unit label, used when ``ordinate`` has no force.

    Returns
    -------
    (quantity, scale) or None
        ``quantity`` in ``displacement, velocity, acceleration``; ``scale``
        multiplies the stored values to give m/N, (m/s)/N or (m/s^2)/N. None
        when the labels are empty or ``NONE`` (no unit information).

    Raises
    ------
    ValueError
        With a reason, when a label is given but is not a length, velocity or
        acceleration per force.
    """
    num = ordinate.strip()
    den = denominator.strip()
    if num.upper() in ("", "NONE"):
        return None
    val = _parse_unit_factor(num)
    if val is None:
        raise ValueError(f"unknown unit label {num!r}")
    if val[3] == 0 and den.upper() not in ("", "NONE"):
        dv = _parse_unit_factor(den)
        if dv is None:
            raise ValueError(f"unknown denominator unit label {den!r}")
        val = (val[0] / dv[0], val[1] - dv[1], val[2] - dv[2], val[3] - dv[3])
    if val[1] != 1 or val[3] != -1 or val[2] not in (0, -1, -2):
        raise ValueError(
            f"unit label {num!r}{'' if val[3] else f' / {den!r}'} is not a length, velocity or "
            "acceleration per force (expected e.g. m/N, (m/s)/N, (m/s^2)/N, g/N)"
        )
    return {0: "displacement", -1: "velocity", -2: "acceleration"}[val[2]], val[0]


def _decode(raw: bytes) -> str:
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace")


_LINE_END = re.compile(rb"\r\n|\r|\n")
_DELIM = re.compile(rb"    -1(?=\r|\n|$| {74})")


def _scan(data: bytes, where: str) -> tuple[list[int], list[int]]:
    """Start offsets and line numbers of the datasets; refuses a file cut in a record."""
    tags = [m.start() for m in _DELIM.finditer(data)]
    starts = tags[0::2]
    ends = np.searchsorted(np.array([m.start() for m in _LINE_END.finditer(data)]), starts)
    lines = [int(e) + 1 for e in ends]
    if len(tags) % 2:
        raise InputError(
            "truncated file: the dataset that starts here has no closing '    -1' line "
            "(the file was cut short?)",
            source=f"{where}:{lines[-1]}",
        )
    tail = data[tags[-1] + 6 :] if tags else data
    if tail.strip():
        at = int(np.searchsorted(np.array([m.start() for m in _LINE_END.finditer(data)]), tags[-1]))
        raise InputError(
            "text after the last dataset's closing '    -1' line: a dataset cut short "
            "(truncated file) or not UFF",
            source=f"{where}:{at + 2}",
        )
    return starts, lines


#: UFF dataset numbers a file of FRFs may hold (pyuff's and the common ones).
_UFF_DATASETS = frozenset({15, 18, 55, 58, 82, 151, 164, 1858, 2400, 2411, 2412, 2414, 2420, 2429})

_NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?")


def _dataset_bounds(data: bytes) -> list[tuple[int, int]]:
    """Byte ranges between each dataset's opening and closing delimiter lines."""
    tags = [m.start() for m in _DELIM.finditer(data)]
    return [(tags[k] + 6, tags[k + 1]) for k in range(0, len(tags) - 1, 2)]


def _check_value_count(block: bytes, rec_no: int, src: str) -> None:
    """Refuse an ASCII dataset 58 whose data lines hold another count than it declares.

    A record cut short and closed again, or two records merged by a lost
    delimiter, still parses: the reader takes the declared count of values
    and drops or never sees the rest. Counting the numbers after the
    11-line header (line 7 declares the ordinate type, the number of
    points and the abscissa spacing) catches both.
    """
    rows = _LINE_END.split(block.lstrip(b"\r\n"))
    if rows[0].split()[:1] != [b"58"]:
        return  # 58b (binary): pyuff checks its byte count
    if len(rows) < 12:
        raise InputError(
            f"record {rec_no} (dataset 58): expected an 11-line header, found {len(rows) - 1} "
            "lines (truncated?)",
            source=src,
        )
    fields = rows[7].split()
    try:
        ord_type, n_pts, even = int(fields[0]), int(fields[1]), int(fields[2])
    except (IndexError, ValueError):
        return  # the record's own reader names a malformed header line
    per_point = (2 if ord_type in (5, 6) else 1) + (0 if even == 1 else 1)
    want = n_pts * per_point
    found = sum(len(_NUMBER.findall(r)) for r in rows[12:])
    if found != want:
        raise InputError(
            f"record {rec_no} (dataset 58): expected {want} values ({n_pts} points), found "
            f"{found} in its data lines ("
            + ("cut short: a truncated file?" if found < want else "two records run together?")
            + ")",
            source=src,
        )


def _header_lines(data: bytes, start: int, n: int = 12) -> list[str]:
    chunk = data[start : start + 82 * (n + 2)]
    return [_decode(x) for x in _LINE_END.split(chunk)[:n]]


def read_uff_frfs(path: str | os.PathLike[str], *, source: str | None = None) -> tuple[UffFrf, ...]:
    """Read every FRF record (dataset 58 / 58b) of a UFF file, keyed by node and direction.

    Parameters
    ----------
    path : path-like
    source : str, optional
        Name used in error messages (default: the path).

    Returns
    -------
    tuple of UffFrf
        File order.

    Raises
    ------
    InputError
        Naming ``file:line`` and the record: not found, empty, binary that
        is not UFF, truncated, no dataset 58, a record that is not an FRF, a
        direction 0 or rotational code, unknown or contradicting unit labels,
        non-finite or implausible values, a repeated (node, direction) pair.
    """
    import pyuff

    where = source or os.fspath(path)
    p = Path(path)
    check_input_file(p, "a UFF file", where)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise InputError(f"cannot read the file: {exc.strerror}", source=where) from None
    if not data.strip():
        raise InputError(
            "empty file; expected UFF datasets (a '    -1' line, then the dataset number)",
            source=f"{where}:1",
        )
    body = data[3:] if data.startswith(b"\xef\xbb\xbf") else data
    first = _LINE_END.split(body.lstrip(b" \t\r\n")[:200], maxsplit=1)[0]
    if first.strip() != b"-1":
        shown = _decode(first[:40]).encode("ascii", "backslashreplace").decode()
        raise InputError(
            f"not a UFF file: expected '    -1' on the first line, found {shown!r}",
            source=f"{where}:1",
        )
    starts, lines = _scan(data, where)
    try:
        uff = pyuff.UFF(os.fspath(p))
        types = [str(t) for t in np.asarray(uff.get_set_types()).tolist()]
    except Exception as exc:  # pyuff raises bare Exception on malformed files
        raise InputError(f"cannot read the UFF file: {exc}", source=where) from None
    if len(types) != len(starts):
        raise InputError(
            f"cannot split the file into datasets ({len(starts)} found by their delimiters, "
            f"{len(types)} by pyuff)",
            source=where,
        )
    idx = [i for i, t in enumerate(types) if float(t) == 58]
    if not idx:
        raise InputError(
            f"expected dataset 58 (FRF) records, found dataset types {sorted(set(types))}",
            source=where,
        )
    out: list[UffFrf] = []
    seen: dict[tuple[int, int, int, int], int] = {}
    bounds = _dataset_bounds(data)
    for i, (b0, b1) in enumerate(bounds):
        tokens = _LINE_END.split(data[b0:b1].lstrip(b"\r\n"), maxsplit=1)[0].split()
        head = tokens[:1]
        number = re.fullmatch(rb"([1-9]\d*)(b?)", head[0]) if head else None
        if (
            number is None
            or int(number.group(1)) not in _UFF_DATASETS
            or (not number.group(2) and len(tokens) > 1)  # ASCII: the number alone
        ):
            shown = _decode(b" ".join(tokens))[:30]
            raise InputError(
                f"record {i + 1}: expected a dataset number on the line after '    -1', found "
                f"{shown!r} (lines lost or a record cut short?)",
                source=f"{where}:{lines[i] + 1}",
            )
    for i in idx:
        src = f"{where}:{lines[i]}"
        rec_no = i + 1
        _check_value_count(data[bounds[i][0] : bounds[i][1]], rec_no, src)
        try:
            d = uff.read_sets(i)
        except Exception as exc:
            raise InputError(
                f"record {rec_no} (dataset 58): cannot read it ({exc}); truncated or malformed",
                source=src,
            ) from None
        if isinstance(d, list):
            d = d[0]
        rec = _record(d, rec_no, lines[i], src, _header_lines(data, starts[i]))
        if rec.key in seen:
            raise InputError(
                f"record {rec_no}: FRF {rec.label} (response node/direction, reference "
                f"node/direction) already in record {seen[rec.key]}; expected each pair once",
                source=src,
            )
        seen[rec.key] = rec_no
        out.append(rec)
    return tuple(out)


def _record(d: dict[str, Any], rec_no: int, line: int, src: str, head: list[str]) -> UffFrf:
    def bad(msg: str) -> InputError:
        return InputError(f"record {rec_no} (dataset 58): {msg}", source=src)

    ft = int(d.get("func_type", -1))
    if ft != 4:
        kind = {1: "a time response", 2: "an auto spectrum", 3: "a cross spectrum"}.get(ft, "")
        raise bad(
            f"expected function type 4 (frequency response function), found {ft}"
            + (f" ({kind}, channel {str(d.get('rsp_ent_name', '')).strip()!r})" if kind else "")
        )
    rdir, edir = int(d.get("rsp_dir", 0)), int(d.get("ref_dir", 0))
    rnode, enode = int(d.get("rsp_node", 0)), int(d.get("ref_node", 0))
    for name, code, node in (("response", rdir, rnode), ("reference", edir, enode)):
        if code == 0:
            raise bad(
                f"{name} direction 0 (a scalar channel, no direction) at node {node}; "
                "expected a translational direction code +-1, +-2, +-3 (X, Y, Z): which "
                "FRFs are driving points depends on it (set it where the file is written)"
            )
        if not 1 <= abs(code) <= 3:
            raise bad(
                f"expected translational {name} direction (+-1, +-2, +-3 = X, Y, Z), found "
                f"{code} (rotation) at node {node}"
            )
    code = int(d.get("ordinate_spec_data_type", 0))
    denom = int(d.get("orddenom_spec_data_type", 0))
    absc = int(d.get("abscissa_spec_data_type", 0))
    if absc not in (0, 18):
        raise bad(f"expected abscissa data type 18 (frequency), found {absc}")
    # unit labels: pyuff's text where it is plain ASCII, else the raw header line
    o_lab = str(d.get("ordinate_axis_units_lab", ""))
    n_lab = str(d.get("orddenom_axis_units_lab", ""))
    if len(head) > 11:
        o_lab = head[10][47:67] if len(head[10]) > 47 else o_lab
        n_lab = head[11][47:67] if len(head[11]) > 47 else n_lab
    try:
        from_label = interpret_frf_units(o_lab, n_lab)
    except ValueError as exc:
        raise bad(f"{exc}; convert the file to SI units") from None
    if from_label is not None:
        quantity, scale = from_label
        if code in _QUANTITY_NAMES and _QUANTITY_NAMES[code] != quantity:
            raise bad(
                f"ordinate data type {code} ({_QUANTITY_NAMES[code]}) contradicts the unit "
                f"label {o_lab.strip()!r} ({quantity})"
            )
        if code not in (0, 1, *_QUANTITY_NAMES):
            raise bad(
                f"expected ordinate data type 8, 11, 12 (or 0/1 with a unit label), found {code}"
            )
    else:
        if code not in _QUANTITY_NAMES:
            raise bad(
                "expected ordinate data type 8 (displacement), 11 (velocity) or "
                f"12 (acceleration), or a unit label such as (m/s^2)/N; found type {code} "
                "and no unit label"
            )
        quantity, scale = _QUANTITY_NAMES[code], 1.0
    if denom not in (0, 13):
        raise bad(f"expected ordinate denominator data type 13 (force), found {denom}")
    x = np.asarray(d.get("x", []), dtype=float).reshape(-1)
    raw = np.asarray(d.get("data", []))
    if not np.iscomplexobj(raw):
        raise bad("expected complex ordinate data, found real values")
    vals = raw.astype(complex).reshape(-1)
    n_pts = int(d.get("num_pts", vals.size))
    if vals.size != n_pts or x.size != n_pts:
        raise bad(f"expected {n_pts} points (header), found {vals.size}; the record is truncated")
    if x.size < 2:
        raise bad(f"expected at least 2 frequency lines, found {x.size}")
    if not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0) or x[0] < 0:
        raise bad("expected increasing finite frequencies >= 0")
    w = 2 * np.pi * x
    if quantity != "displacement":
        keep = x > 0
        x, w, vals = x[keep], w[keep], vals[keep]
        with np.errstate(all="ignore"):
            vals = vals / (1j * w) if quantity == "velocity" else vals / -(w**2)
    vals = vals * scale * np.sign(rdir) * np.sign(edir)
    prob = frf_value_problem(vals)
    if prob is not None:
        k, why = prob
        raise bad(f"line {k + 1} of the data ({x[k]:g} Hz): {why}")
    return UffFrf(
        record=rec_no,
        line=line,
        rsp_node=rnode,
        rsp_dir=abs(rdir),
        ref_node=enode,
        ref_dir=abs(edir),
        quantity=quantity,
        scale=scale,
        freq_hz=x,
        H=vals.astype(np.complex128),
    )


def common_grid(recs: tuple[UffFrf, ...] | list[UffFrf], where: str) -> NDArray[np.float64]:
    """The frequency grid shared by all records, shape (n_freq,) [Hz].

    Raises
    ------
    InputError
        Naming the first record (and its line) whose grid differs from the first's.
    """
    grid = recs[0].freq_hz
    for r in recs[1:]:
        if r.freq_hz.shape != grid.shape or not np.allclose(r.freq_hz, grid, rtol=1e-9, atol=0):
            raise InputError(
                f"record {r.record}: expected one frequency grid for all records of the file, "
                f"found {r.freq_hz.size} points {r.freq_hz[0]:g}..{r.freq_hz[-1]:g} Hz vs "
                f"{grid.size} points {grid[0]:g}..{grid[-1]:g} Hz",
                source=f"{where}:{r.line}",
            )
    return grid


def read_uff_frf(
    path: str | os.PathLike[str], *, source: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """Read one posture's FRFs (the TCP, one node) from a UFF file.

    Parameters
    ----------
    path : path-like
        The ``.uff`` file.
    source : str, optional
        Name used in error messages (default: the path).

    Returns
    -------
    freq_hz : ndarray, shape (n_freq,)
        Frequencies [Hz].
    H : ndarray, shape (n_freq, 3, 3), complex
        Receptance [m/N], NaN for directions absent from the file.

    Raises
    ------
    InputError
        As :func:`read_uff_frfs`; also records at more than one node (a
        multi-point measurement is not one posture's TCP: identify it on its
        own with ``robolobe identify FILE.uff``), a repeated direction,
        differing grids.
    """
    where = source or os.fspath(path)
    recs = read_uff_frfs(path, source=where)
    nodes = sorted({r.rsp_node for r in recs} | {r.ref_node for r in recs})
    if len(nodes) > 1:
        r = next((x for x in recs if x.rsp_node != x.ref_node), None) or next(
            x for x in recs if x.rsp_node != recs[0].rsp_node
        )
        raise InputError(
            f"record {r.record}: FRF {r.label}; the file has FRFs at nodes {nodes}, a campaign "
            "posture file holds "
            "the FRFs of one node (the TCP: response node = reference node). A multi-point "
            "measurement is identified on its own: robolobe identify FILE.uff",
            source=f"{where}:{r.line}",
        )
    grid = common_grid(recs, where)
    h = np.full((grid.size, 3, 3), np.nan + 0j)
    for r in recs:
        h[:, r.rsp_dir - 1, r.ref_dir - 1] = r.H
    return grid, h
