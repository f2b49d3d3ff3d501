"""Read and write the modal dataset ``modal.csv`` (docs/guide/modal.md).

One row per posture, direction and mode::

    posture_id,q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,dir,mode,f_hz,zeta,k_N_per_m

``mode`` counts from 1 by rising frequency, ``zeta`` is a fraction and
``k_N_per_m`` is the modal stiffness of the mode at that direction, so that
``H_dd(w) ~ sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``.

Extra columns (e.g. spread columns written by the learning side) are allowed
and kept; a column whose name looks like a typo of a required one is logged.
Every problem raises :class:`robolobe.errors.InputError` naming the file, the
line (the header is line 1) and the column, with what was expected and found.
"""

from __future__ import annotations

import csv
import difflib
import logging
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from robolobe._atomic import atomic_path, check_input_file
from robolobe._directions import ALL_DIRS, DRIVING
from robolobe._frf_checks import MODAL_K_MIN_N_PER_M
from robolobe._modal_parameters import Q_COLUMNS, ModalParameters
from robolobe.errors import InputError

__all__ = [
    "DIRECTIONS",
    "MODAL_COLUMNS",
    "Q_COLUMNS",
    "read_modal_csv",
    "read_modal_parameters",
    "validate_modal_frame",
    "write_modal_csv",
]

_log = logging.getLogger(__name__)

MODAL_COLUMNS: tuple[str, ...] = (
    "posture_id",
    *Q_COLUMNS,
    "dir",
    "mode",
    "f_hz",
    "zeta",
    "k_N_per_m",
)
#: Valid ``dir`` values in canonical order (driving points first).
DIRECTIONS: tuple[str, ...] = DRIVING + tuple(d for d in ALL_DIRS if d not in DRIVING)
_DIR_RANK = {d: i for i, d in enumerate(DIRECTIONS)}

#: Joint angles of one posture must agree within this tolerance, degrees.
_Q_TOL_DEG = 1e-6


def _parse_float(text: str, source: str, column: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(
            f"column {column!r}: expected a number, found {text!r}", source=source
        ) from None
    if not math.isfinite(value):
        raise InputError(
            f"column {column!r}: expected a finite number, found {text!r}", source=source
        )
    return value


def _check_row(
    values: Mapping[str, object], source: str
) -> tuple[str, tuple[float, ...], str, int, float, float, float]:
    """Validate one row given as raw values (strings or numbers); return typed fields."""
    pid = values["posture_id"]
    pid_s = "" if pid is None or (isinstance(pid, float) and math.isnan(pid)) else str(pid)
    pid_s = pid_s.strip()
    if not pid_s:
        raise InputError("column 'posture_id': expected a non-empty id, found ''", source=source)
    q = tuple(_parse_float(str(values[c]), source, c) for c in Q_COLUMNS)
    d = str(values["dir"]).strip().lower()
    if d not in _DIR_RANK:
        raise InputError(
            f"column 'dir': expected two letters from x, y, z (one of {', '.join(DIRECTIONS)}), "
            f"found {values['dir']!r}",
            source=source,
        )
    mode_f = _parse_float(str(values["mode"]), source, "mode")
    if mode_f != int(mode_f) or mode_f < 1:
        raise InputError(
            f"column 'mode': expected an integer >= 1, found {values['mode']!r}", source=source
        )
    f = _parse_float(str(values["f_hz"]), source, "f_hz")
    if f <= 0.0:
        raise InputError(f"column 'f_hz': expected > 0, found {values['f_hz']!r}", source=source)
    z = _parse_float(str(values["zeta"]), source, "zeta")
    if not 0.0 < z < 1.0:
        raise InputError(
            f"column 'zeta': expected a damping ratio as a fraction, 0 < zeta < 1, "
            f"found {values['zeta']!r}",
            source=source,
        )
    k = _parse_float(str(values["k_N_per_m"]), source, "k_N_per_m")
    if d[0] == d[1]:
        if k <= 0.0:
            raise InputError(
                f"column 'k_N_per_m': expected > 0 at the driving point {d!r}, "
                f"found {values['k_N_per_m']!r}",
                source=source,
            )
        if k < MODAL_K_MIN_N_PER_M:
            raise InputError(
                f"column 'k_N_per_m': expected a modal stiffness >= {MODAL_K_MIN_N_PER_M:g} N/m "
                f"(10 N/mm), found {values['k_N_per_m']!r}: a value in N/mm?",
                source=source,
            )
    elif k == 0.0:
        raise InputError(
            f"column 'k_N_per_m': expected a non-zero value for cross direction {d!r}, found 0",
            source=source,
        )
    return pid_s, q, d, int(mode_f), f, z, k


def _check_header(header: Sequence[str], source: str) -> None:
    names = [h.strip() for h in header]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError(f"duplicate column(s) {dup} in the header", source=source)
    missing = [c for c in MODAL_COLUMNS if c not in names]
    if missing:
        raise InputError(
            f"expected columns {', '.join(MODAL_COLUMNS)}; missing {', '.join(missing)}; "
            f"found {', '.join(names) if names else '(empty header)'}",
            source=source,
        )
    for extra in (n for n in names if n not in MODAL_COLUMNS):
        close = difflib.get_close_matches(extra, MODAL_COLUMNS, n=1, cutoff=0.85)
        if close:
            _log.warning("%s: extra column %r kept; did you mean %r?", source, extra, close[0])


def _build_frame(
    rows: list[tuple[str, tuple[float, ...], str, int, float, float, float]],
    sources: list[str],
    extras: dict[str, list[object]],
    where: str,
) -> pd.DataFrame:
    """Cross-row checks (q per posture, duplicates) and assembly of the typed frame."""
    if not rows:
        raise InputError("expected at least one data row, found none", source=where)
    first_q: dict[str, tuple[tuple[float, ...], str]] = {}
    seen: dict[tuple[str, str, int], str] = {}
    for (pid, q, d, mode, *_), src in zip(rows, sources, strict=True):
        if pid in first_q:
            q0, src0 = first_q[pid]
            diff = max(abs(a - b) for a, b in zip(q, q0, strict=True))
            if diff > _Q_TOL_DEG:
                raise InputError(
                    f"posture {pid!r}: joint angles differ from those at {src0} "
                    f"(expected {list(q0)}, found {list(q)})",
                    source=src,
                )
        else:
            first_q[pid] = (q, src)
        key = (pid, d, mode)
        if key in seen:
            raise InputError(
                f"duplicate row for posture {pid!r}, dir {d!r}, mode {mode} (first at {seen[key]})",
                source=src,
            )
        seen[key] = src
    data: dict[str, object] = {
        "posture_id": pd.Series([r[0] for r in rows], dtype=str),
    }
    qarr = np.array([r[1] for r in rows], dtype=float)
    for j, c in enumerate(Q_COLUMNS):
        data[c] = qarr[:, j]
    data["dir"] = pd.Series([r[2] for r in rows], dtype=str)
    data["mode"] = np.array([r[3] for r in rows], dtype=np.int64)
    data["f_hz"] = np.array([r[4] for r in rows], dtype=float)
    data["zeta"] = np.array([r[5] for r in rows], dtype=float)
    data["k_N_per_m"] = np.array([r[6] for r in rows], dtype=float)
    df = pd.DataFrame(data)
    for name, vals in extras.items():
        col = pd.Series(vals, dtype=object)
        num = pd.to_numeric(col, errors="coerce")
        blank = col.map(lambda v: v is None or (isinstance(v, str) and v.strip() == ""))
        # numeric when every non-blank cell parses as a number
        df[name] = num if bool((num.notna() | blank).all()) else col
    return df


def read_modal_csv(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read and validate a modal dataset.

    Parameters
    ----------
    path : path-like
        The ``modal.csv`` file.

    Returns
    -------
    pandas.DataFrame
        One row per posture, direction and mode, in file order: the columns of
        :data:`MODAL_COLUMNS` (``posture_id`` and ``dir`` as ``str``, ``mode``
        as ``int64``, the rest ``float64``; angles in degrees, ``f_hz`` in Hz,
        ``zeta`` a fraction, ``k_N_per_m`` in N/m) followed by any extra
        columns of the file (numeric where every cell is a number).

    Raises
    ------
    InputError
        On a missing or duplicated column, a row with the wrong number of
        fields, a value that is not a finite number, ``dir`` not two letters
        from x/y/z, ``mode`` not an integer >= 1, ``f_hz <= 0``, ``zeta``
        outside (0, 1), ``k_N_per_m <= 0`` at a driving point (or 0 for a
        cross direction), joint angles that differ between rows of the same
        posture, a duplicated (posture, dir, mode), or no data rows. The
        message names ``file:line`` and the column.
    """
    name = str(path)
    path = check_input_file(path, "a modal dataset (CSV file)", name)
    try:
        fh = path.open(newline="", encoding="utf-8-sig")
    except OSError as exc:
        raise InputError(f"cannot read the modal dataset: {exc.strerror}", source=name) from None
    with fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise InputError(
                f"empty file; expected the header {','.join(MODAL_COLUMNS)}", source=f"{name}:1"
            ) from None
        except (csv.Error, UnicodeDecodeError) as exc:
            raise InputError(f"not a readable CSV file ({exc})", source=f"{name}:1") from None
        _check_header(header, f"{name}:1")
        names = [h.strip() for h in header]
        extra_names = [n for n in names if n not in MODAL_COLUMNS]
        rows: list[tuple[str, tuple[float, ...], str, int, float, float, float]] = []
        sources: list[str] = []
        extras: dict[str, list[object]] = {n: [] for n in extra_names}
        try:
            for fields in reader:
                line = reader.line_num
                if not fields or all(not f.strip() for f in fields):
                    continue
                src = f"{name}:{line}"
                if len(fields) != len(names):
                    raise InputError(
                        f"expected {len(names)} fields (as in the header), found {len(fields)}",
                        source=src,
                    )
                values = dict(zip(names, fields, strict=True))
                rows.append(_check_row(values, src))
                sources.append(src)
                for n in extra_names:
                    extras[n].append(values[n].strip())
        except (csv.Error, UnicodeDecodeError) as exc:
            raise InputError(
                f"not a readable CSV file ({exc})", source=f"{name}:{reader.line_num}"
            ) from None
    return _build_frame(rows, sources, extras, name)


def read_modal_parameters(
    path: str | os.PathLike[str],
    *,
    directions: Sequence[str] | None = None,
    n_modes: int | None = None,
) -> ModalParameters:
    """Read and validate a modal dataset as :class:`~robolobe._modal_parameters.ModalParameters`.

    :func:`read_modal_csv` then
    :meth:`~robolobe._modal_parameters.ModalParameters.from_frame`.

    Parameters
    ----------
    path : path-like
        The ``modal.csv`` file.
    directions : sequence of str, optional
        Driving points to keep (default: every one with rows, ``xx, yy, zz`` order).
    n_modes : int, optional
        Modes per direction (default: the highest mode number in the file).

    Returns
    -------
    ModalParameters
        Shape (n_postures, n_directions, n_modes), with the posture ids and
        joint angles; a mode a posture does not list is absent (NaN).
    """
    df = read_modal_csv(path)
    return ModalParameters.from_frame(
        df, directions=directions, n_modes=n_modes, source=str(Path(path))
    )


def validate_modal_frame(df: pd.DataFrame, where: str = "modal dataset") -> pd.DataFrame:
    """Validate a modal dataset held in memory and return it with canonical dtypes.

    Applies the same rules as :func:`read_modal_csv`; problems name
    ``where`` and the frame's row label.

    Parameters
    ----------
    df : pandas.DataFrame
        Must hold the columns of :data:`MODAL_COLUMNS`; other columns are kept.
    where : str
        Name used in error messages.

    Returns
    -------
    pandas.DataFrame
        A new frame with a fresh ``RangeIndex``.
    """
    if not isinstance(df, pd.DataFrame):
        raise InputError(f"expected a pandas DataFrame, found {type(df).__name__}", source=where)
    _check_header([str(c) for c in df.columns], where)
    extra_names = [str(c) for c in df.columns if c not in MODAL_COLUMNS]
    rows = []
    sources = []
    records = df.to_dict(orient="records")
    for label, rec in zip(df.index, records, strict=True):
        src = f"{where} (row {label!r})"
        rows.append(_check_row({str(k): v for k, v in rec.items()}, src))
        sources.append(src)
    out = _build_frame(rows, sources, {}, where)
    for n in extra_names:
        out[n] = df[n].to_numpy()
    return out


def write_modal_csv(path: str | os.PathLike[str], df: pd.DataFrame) -> Path:
    """Validate and write a modal dataset atomically.

    Rows are sorted by posture (in order of first appearance), direction
    (``xx, yy, zz`` then cross directions) and mode. Floats are written with
    the shortest representation that reads back exactly.

    Parameters
    ----------
    path : path-like
        Target file; it is replaced only when the whole file was written.
    df : pandas.DataFrame
        The dataset (columns of :data:`MODAL_COLUMNS` plus optional extras).

    Returns
    -------
    pathlib.Path
        The written path.
    """
    path = Path(path)
    out = validate_modal_frame(df, where=f"data for {path}")
    order = {pid: i for i, pid in enumerate(dict.fromkeys(out["posture_id"]))}
    key = pd.DataFrame(
        {
            "p": out["posture_id"].map(order).to_numpy(),
            "d": out["dir"].map(_DIR_RANK).to_numpy(),
            "m": out["mode"].to_numpy(),
        }
    )
    idx = np.lexsort((key["m"].to_numpy(), key["d"].to_numpy(), key["p"].to_numpy()))
    out = out.iloc[idx]
    cols = list(MODAL_COLUMNS) + [c for c in out.columns if c not in MODAL_COLUMNS]
    with atomic_path(path) as tmp:
        out.to_csv(tmp, columns=cols, index=False, lineterminator="\n")
    return path
