"""Files of the ``sld`` command: tool-point modes in, lobe envelopes out.

Modes file (CSV, one row per mode term)::

    dir,mode,f_hz,zeta,k_N_per_m
    xx,1,922.0,0.011,1.34e6
    yy,1,922.0,0.011,1.34e6

``dir`` is ``xx`` (feed) or ``yy`` (normal) for driving-point modes, or
``xy`` / ``yx`` for a cross term (one row per term: it fills both ``xy``
and ``yx``, reciprocity; its ``k_N_per_m`` may be negative). ``mode`` counts
from 1 within each ``dir``; ``f_hz`` is the natural frequency [Hz], ``zeta``
the damping ratio (fraction) and ``k_N_per_m`` the modal stiffness [N/m], so
that ``H_dd(w) = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``
(docs/guide/modal.md). Blank lines and lines starting with ``#`` are
skipped; extra columns are ignored.

Lobes file (CSV): ``rpm,a_lim_mm`` (the envelope; ``inf`` where no lobe
crosses the speed).
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from robolobe._atomic import atomic_write_text, check_input_file
from robolobe._frf_checks import MODAL_K_MIN_N_PER_M, soft_tool_mode_problem
from robolobe.errors import InputError
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram

__all__ = [
    "MIN_PLAUSIBLE_A_LIM_M",
    "MODES_COLUMNS",
    "SAFETY_RANGE",
    "SHALLOW_A_LIM_M",
    "ModeRow",
    "check_lobe_depth",
    "check_modes_on_tool",
    "read_modes_csv",
    "read_modes_table",
    "write_lobes_csv",
]

#: Required columns of a modes file.
MODES_COLUMNS = ("dir", "mode", "f_hz", "zeta", "k_N_per_m")
_DIRS = ("xx", "yy", "xy", "yx")
#: Plausible natural frequencies of a robot or tool-point mode [Hz]: below
#: 1 Hz is no structural mode of a milling robot (often kHz given as Hz).
F_RANGE_HZ = (1.0, 1.0e5)
#: Plausible magnitude of a modal stiffness [N/m]: from 10 N/mm
#: (:data:`robolobe._frf_checks.MODAL_K_MIN_N_PER_M`; a value in N/mm reads
#: 1000 times too soft) to a mode barely seen at the tool point (~1e13).
K_RANGE_N_PER_M = (MODAL_K_MIN_N_PER_M, 1.0e13)
#: A limiting depth [m] below which lobes are refused as a unit slip (10 um: no
#: milling cut is that shallow; a stiffness in N/mm makes every depth 1000
#: times shallower), unless the modes were checked against their tool.
MIN_PLAUSIBLE_A_LIM_M = 1e-5
#: A limiting depth [m] below which lobes are warned (the textbook slot of
#: REFERENCES.md section 3, a 1.34e6 N/m mode at 1.1 % damping, reaches 48 um).
SHALLOW_A_LIM_M = 3e-5
#: Safety factors on the limiting depth (depth <= a_lim / factor): from 1 (at the
#: limit) to 10 (a tenth of it; more is no plan but a unit or typing slip).
SAFETY_RANGE = (1.0, 10.0)


def _num(text: str, where: str, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{column}: expected a number, found {text!r}", source=where) from None
    if not math.isfinite(value):
        raise InputError(f"{column}: expected a finite number, found {text!r}", source=where)
    return value


@dataclass(frozen=True)
class ModeRow:
    """One row of a modes file, with its line (for messages).

    Attributes
    ----------
    line : int
        Line number in the file (from 1).
    direction : {"xx", "yy", "xy"}
        ``yx`` rows are stored as ``xy``.
    mode : int
    f_hz, zeta, k_N_per_m : float
        As in the file [Hz, fraction, N/m].
    """

    line: int
    direction: str
    mode: int
    f_hz: float
    zeta: float
    k_N_per_m: float


def read_modes_csv(path: str | os.PathLike[str]) -> ModalModel:
    """Read a tool-point modes file into a 2-D (feed x, normal y) model.

    See :func:`read_modes_table` (the same, with the rows and their lines).

    Parameters
    ----------
    path : path-like
        The CSV file (format in the module docstring).

    Returns
    -------
    ModalModel
        One mode per row, ``dim == 2``.

    Raises
    ------
    InputError
        Naming ``file:line`` and the column for a missing file or column, a
        bad value, a duplicate ``(dir, mode)``, a cross term given both as
        ``xy`` and ``yx``, or a file without any ``xx``/``yy`` mode.
    """
    return read_modes_table(path)[0]


def read_modes_table(path: str | os.PathLike[str]) -> tuple[ModalModel, list[ModeRow]]:
    """Read a tool-point modes file: the 2-D model and its rows with their lines.

    Parameters
    ----------
    path : path-like
        The CSV file (format in the module docstring).

    Returns
    -------
    model : ModalModel
        One mode per row, ``dim == 2``.
    rows : list of ModeRow
        The rows in file order, for checks that name a line.

    Raises
    ------
    InputError
        As :func:`read_modes_csv`.
    """
    p = Path(path)
    name = str(path)
    check_input_file(p, "a modes CSV file", name)
    try:
        text = p.read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the file: {exc}", source=name) from None
    numbered = [
        (i + 1, ln)
        for i, ln in enumerate(text.splitlines())
        if ln.strip() and not ln.lstrip().startswith("#")
    ]
    if not numbered:
        raise InputError(
            f"expected a header {','.join(MODES_COLUMNS)} and rows, found an empty file",
            source=name,
        )
    header_line, header = numbered[0]
    cols = [c.strip() for c in next(csv.reader([header]))]
    missing = [c for c in MODES_COLUMNS if c not in cols]
    if missing:
        raise InputError(
            f"expected columns {','.join(MODES_COLUMNS)}, missing {', '.join(missing)} "
            f"(found {','.join(cols)})",
            source=f"{name}:{header_line}",
        )
    pos = {c: cols.index(c) for c in MODES_COLUMNS}
    f_hz: list[float] = []
    zeta: list[float] = []
    k: list[float] = []
    dirs: list[str] = []
    seen: dict[tuple[str, int], int] = {}
    rows: list[ModeRow] = []
    for lineno, line in numbered[1:]:
        where = f"{name}:{lineno}"
        row = [c.strip() for c in next(csv.reader(io.StringIO(line)))]
        if len(row) < len(cols):
            raise InputError(f"expected {len(cols)} columns, found {len(row)}", source=where)
        d = row[pos["dir"]].lower()
        if d not in _DIRS:
            raise InputError(
                f"dir: expected one of {', '.join(_DIRS)}, found {row[pos['dir']]!r}", source=where
            )
        mode_text = row[pos["mode"]]
        try:
            mode = int(mode_text)
        except ValueError:
            raise InputError(
                f"mode: expected an integer >= 1, found {mode_text!r}", source=where
            ) from None
        if mode < 1:
            raise InputError(f"mode: expected an integer >= 1, found {mode_text!r}", source=where)
        f = _num(row[pos["f_hz"]], where, "f_hz")
        z = _num(row[pos["zeta"]], where, "zeta")
        kk = _num(row[pos["k_N_per_m"]], where, "k_N_per_m")
        if not F_RANGE_HZ[0] <= f <= F_RANGE_HZ[1]:
            hint = " (kHz? give f_hz in Hz)" if 0 < f < F_RANGE_HZ[0] else ""
            raise InputError(
                f"f_hz: expected a natural frequency of {F_RANGE_HZ[0]:g} to "
                f"{F_RANGE_HZ[1]:g} Hz, found {f:g}{hint}",
                source=where,
            )
        if not 0 < z < 1:
            raise InputError(
                f"zeta: expected a damping ratio in (0, 1) (fraction), found {z:g}", source=where
            )
        if d in ("xx", "yy") and kk <= 0:
            raise InputError(
                f"k_N_per_m: expected a stiffness > 0 N/m for dir {d}, found {kk:g}", source=where
            )
        if kk != 0 and not K_RANGE_N_PER_M[0] <= abs(kk) <= K_RANGE_N_PER_M[1]:
            raise InputError(
                f"k_N_per_m: expected a modal stiffness of {K_RANGE_N_PER_M[0]:g} to "
                f"{K_RANGE_N_PER_M[1]:g} N/m in magnitude, found {kk:g} "
                "(a truncated number or N/mm?)",
                source=where,
            )
        if kk == 0:
            raise InputError(
                "k_N_per_m: expected a non-zero stiffness for a cross term, found 0", source=where
            )
        key = ("xy" if d in ("xy", "yx") else d, mode)
        if key in seen:
            other = seen[key]
            what = "cross term (give it once, as xy)" if key[0] == "xy" else f"dir {d}"
            raise InputError(f"duplicate {what}, mode {mode}: also on line {other}", source=where)
        seen[key] = lineno
        rows.append(ModeRow(lineno, key[0], mode, f, z, kk))
        f_hz.append(f)
        zeta.append(z)
        k.append(kk)
        dirs.append("xy" if d == "yx" else d)
    if not any(d in ("xx", "yy") for d in dirs):
        raise InputError("expected at least one xx or yy mode, found none", source=name)
    model = ModalModel.from_directional(np.array(f_hz), np.array(zeta), np.array(k), dirs, dim=2)
    return model, rows


def check_modes_on_tool(
    rows: list[ModeRow], diameter_m: float, stickout_m: float, source: str
) -> None:
    """Refuse a driving-point mode softer than a tool of this size can be (N/mm for N/m).

    Each ``xx``/``yy`` mode's stiffness against
    :func:`robolobe._frf_checks.tool_mode_k_floor` (a mode that moves the
    spindle, or one that bends the tool on its spindle), as the job file's
    tool modes; cross terms are not modal masses and are left out.

    Parameters
    ----------
    rows : list of ModeRow
        From :func:`read_modes_table`.
    diameter_m, stickout_m : float
        The cutter's diameter and stick-out [m].
    source : str
        The modes file's name, for ``file:line``.

    Raises
    ------
    InputError
        ``file:line: k_N_per_m: expected ..., found ...``.
    """
    for r in rows:
        if r.direction == "xy":
            continue
        problem = soft_tool_mode_problem(r.f_hz, r.k_N_per_m, diameter_m, stickout_m, "--stickout")
        if problem is not None:
            raise InputError(
                f"k_N_per_m ({r.direction} mode {r.mode}): {problem}", source=f"{source}:{r.line}"
            )


def check_lobe_depth(
    a_min_m: float, rpm_at_min: float, rows: list[ModeRow], source: str, *, tool_checked: bool
) -> str | None:
    """Refuse lobes too shallow for any cut unless the modes were checked on a tool.

    A modes file alone cannot tell a stiff mode in N/mm from a soft one in
    N/m (a 5e7 N/m spindle mode read as 5e4 N/m looks like a 3 mm end mill's
    bending mode), but its lobes can: every limiting depth scales with the
    stiffness, and a slip makes it 1000 times shallower. Without a tool to
    check the modes against (:func:`check_modes_on_tool`), a minimum below
    :data:`MIN_PLAUSIBLE_A_LIM_M` is refused, one below
    :data:`SHALLOW_A_LIM_M` warned; with the modes checked on their tool,
    both are warned.

    Parameters
    ----------
    a_min_m, rpm_at_min : float
        The envelope's minimum [m] and its speed [rpm].
    rows : list of ModeRow
        The modes (the softest driving-point one is named).
    source : str
        The modes file's name.
    tool_checked : bool
        The modes passed :func:`check_modes_on_tool`.

    Returns
    -------
    str or None
        A warning, or None.

    Raises
    ------
    InputError
        ``file:line`` of the mode with the least dynamic stiffness ``2 zeta k``.
    """
    if not math.isfinite(a_min_m) or a_min_m >= SHALLOW_A_LIM_M:
        return None
    soft = min((r for r in rows if r.direction != "xy"), key=lambda r: r.zeta * r.k_N_per_m)
    mass_g = 1e3 * soft.k_N_per_m / (2.0 * math.pi * soft.f_hz) ** 2
    found = (
        f"a minimum a_lim of {a_min_m * 1e3:.3g} mm at {rpm_at_min:.6g} rpm; the softest mode "
        f"({soft.direction} mode {soft.mode}, line {soft.line}: {soft.k_N_per_m:g} N/m at "
        f"{soft.f_hz:g} Hz, a modal mass of {mass_g:.3g} g)"
    )
    if a_min_m < MIN_PLAUSIBLE_A_LIM_M and not tool_checked:
        raise InputError(
            f"k_N_per_m: expected lobes no shallower than {MIN_PLAUSIBLE_A_LIM_M * 1e3:g} mm "
            f"(no milling cut is), found {found}: stiffnesses in N/mm? (x1000 for N/m); if "
            "they are right, give --tool-diameter and --stickout to check them against the tool",
            source=f"{source}:{soft.line}",
        )
    why = (
        "modes checked against the tool"
        if tool_checked
        else "--tool-diameter and --stickout check the modes against the tool"
    )
    return (
        f"{source}: lobes shallower than any practical cut: {found}; check that k_N_per_m is "
        f"in N/m, not N/mm (1000 times shallower lobes) and --kt in N/m^2 ({why})"
    )


def write_lobes_csv(path: str | os.PathLike[str], diagram: LobeDiagram) -> None:
    """Write the envelope as ``rpm,a_lim_mm`` (atomically).

    Parameters
    ----------
    path : path-like
        Target file.
    diagram : LobeDiagram
        Unbatched lobes.
    """
    if diagram.batch_shape:
        raise InputError(
            f"write_lobes_csv: expected one diagram, found a batch {diagram.batch_shape}"
        )
    lines = ["rpm,a_lim_mm"]
    for n, a in zip(diagram.rpm, diagram.a_lim * 1e3, strict=True):
        lines.append(f"{n:.10g},{a:.9g}" if math.isfinite(a) else f"{n:.10g},inf")
    atomic_write_text(path, "\n".join(lines) + "\n")
