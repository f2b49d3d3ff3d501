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
from pathlib import Path

import numpy as np

from robolobe._atomic import atomic_write_text, check_input_file
from robolobe._frf_checks import MODAL_K_MIN_N_PER_M
from robolobe.errors import InputError
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram

__all__ = ["MODES_COLUMNS", "SAFETY_RANGE", "read_modes_csv", "write_lobes_csv"]

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


def read_modes_csv(path: str | os.PathLike[str]) -> ModalModel:
    """Read a tool-point modes file into a 2-D (feed x, normal y) model.

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
        f_hz.append(f)
        zeta.append(z)
        k.append(kk)
        dirs.append("xy" if d == "yx" else d)
    if not any(d in ("xx", "yy") for d in dirs):
        raise InputError("expected at least one xx or yy mode, found none", source=name)
    return ModalModel.from_directional(np.array(f_hz), np.array(zeta), np.array(k), dirs, dim=2)


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
