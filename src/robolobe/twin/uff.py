"""FRFs of one posture as UFF (universal file format) dataset 58 files.

A hammer campaign may come as ``frf/<posture_id>.uff`` files beside
``postures.csv`` (FORMATS.md section 2), one file per posture holding one
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
Every dataset 58 of the file; other dataset types are ignored. Each must be
an FRF (function type 4) with translational directions (codes +-1..+-3; a
negative code flips the sign of the record), a numerator of data type 8, 11
or 12 and a denominator of type 13 (force) or 0 (unknown). Values are taken
as SI (m, m/s, m/s^2 per N); unit labels and exponents are not
interpreted. Mobility is divided by ``i w`` and accelerance by ``-w^2`` to
give receptance; for those the 0 Hz bin (where the division is undefined)
is dropped. All records of a file must share one frequency grid and each
direction may appear once.
"""

from __future__ import annotations

import logging
import os
from pathlib import Path
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["UFF_QUANTITIES", "UffQuantity", "read_uff_frf", "write_uff_frf"]

logger = logging.getLogger(__name__)

UffQuantity = Literal["displacement", "velocity", "acceleration"]
UFF_QUANTITIES: dict[str, int] = {"displacement": 8, "velocity": 11, "acceleration": 12}
"""Ordinate (numerator) specific data type codes of UFF 58 per response quantity."""

_UNITS = {"displacement": "m/N", "velocity": "m/s/N", "acceleration": "m/s^2/N"}
_AXES = "xyz"


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
                    f"direction {_AXES[r] + _AXES[e]}: expected finite values or all NaN",
                    source="write_uff_frf",
                )
            sets.append(
                pyuff.prepare_58(
                    binary=0,
                    id1=f"robolobe FRF {name}"[:80],
                    id2=f"dir {_AXES[r]}{_AXES[e]} (response, excitation), TCP axes"[:80],
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


def read_uff_frf(
    path: str | os.PathLike[str], *, source: str | None = None
) -> tuple[NDArray[np.float64], NDArray[np.complex128]]:
    """Read one posture's FRFs from a UFF file (dataset 58 records).

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
        Unreadable file, no dataset 58, a record that is not a translational
        FRF of a known quantity, a repeated direction, differing grids.
    """
    import pyuff

    where = source or os.fspath(path)
    p = Path(path)
    if not p.is_file():
        raise InputError("file not found", source=where)
    try:
        uff = pyuff.UFF(os.fspath(p))
        types = np.asarray(uff.get_set_types()).astype(int)
        idx = [int(i) for i in np.flatnonzero(types == 58)]
        raw = uff.read_sets(idx) if idx else []
    except Exception as exc:  # pyuff raises bare Exception on malformed files
        raise InputError(f"cannot read the UFF file: {exc}", source=where) from None
    dsets: list[dict[str, Any]] = raw if isinstance(raw, list) else [raw]
    if not dsets:
        raise InputError(
            f"expected dataset 58 (FRF) records, found dataset types {sorted(set(types.tolist()))}",
            source=where,
        )

    grid: NDArray[np.float64] | None = None
    records: dict[tuple[int, int], NDArray[np.complex128]] = {}
    for k, d in enumerate(dsets, start=1):
        rec = f"{where} [dataset 58 #{k}]"
        if int(d.get("func_type", -1)) != 4:
            raise InputError(
                f"expected function type 4 (frequency response function), "
                f"found {d.get('func_type')}",
                source=rec,
            )
        rdir, edir = int(d.get("rsp_dir", 0)), int(d.get("ref_dir", 0))
        if not (1 <= abs(rdir) <= 3 and 1 <= abs(edir) <= 3):
            raise InputError(
                "expected translational response and reference directions "
                f"(+-1, +-2, +-3 = X, Y, Z), found {rdir} and {edir}",
                source=rec,
            )
        quantity = int(d.get("ordinate_spec_data_type", 0))
        if quantity not in (8, 11, 12):
            raise InputError(
                "expected ordinate data type 8 (displacement), 11 (velocity) or "
                f"12 (acceleration), found {quantity}",
                source=rec,
            )
        denom = int(d.get("orddenom_spec_data_type", 0))
        if denom not in (0, 13):
            raise InputError(
                f"expected ordinate denominator data type 13 (force), found {denom}",
                source=rec,
            )
        absc = int(d.get("abscissa_spec_data_type", 0))
        if absc not in (0, 18):
            raise InputError(
                f"expected abscissa data type 18 (frequency), found {absc}", source=rec
            )
        x = np.asarray(d["x"], dtype=float)
        data = np.asarray(d["data"])
        if not np.iscomplexobj(data):
            raise InputError("expected complex ordinate data, found real values", source=rec)
        data = data.astype(complex)
        if x.shape != data.shape or x.ndim != 1 or x.size < 2:
            raise InputError(
                f"expected matching abscissa and ordinate arrays, found {x.shape} and {data.shape}",
                source=rec,
            )
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(data))):
            raise InputError("expected finite values, found NaN or inf", source=rec)
        if np.any(np.diff(x) <= 0) or x[0] < 0:
            raise InputError("expected increasing frequencies >= 0", source=rec)
        w = 2 * np.pi * x
        if quantity != 8:
            keep = x > 0
            x, w, data = x[keep], w[keep], data[keep]
            data = data / (1j * w) if quantity == 11 else data / -(w**2)
        data = data * np.sign(rdir) * np.sign(edir)
        key = (abs(rdir) - 1, abs(edir) - 1)
        if key in records:
            raise InputError(
                f"direction {_AXES[key[0]]}{_AXES[key[1]]} appears more than once", source=rec
            )
        if grid is None:
            grid = x
        elif x.shape != grid.shape or not np.allclose(x, grid, rtol=1e-9, atol=0):
            raise InputError(
                "expected one frequency grid for all records of the file, found "
                f"{x.size} points {x[0]:g}..{x[-1]:g} Hz vs {grid.size} points "
                f"{grid[0]:g}..{grid[-1]:g} Hz",
                source=rec,
            )
        records[key] = data
    assert grid is not None
    h = np.full((grid.size, 3, 3), np.nan + 0j)
    for (r, e), data in records.items():
        h[:, r, e] = data
    return grid, h
