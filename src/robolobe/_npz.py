"""Safe reading of robolobe's ``.npz`` files (models): arrays only, clear refusals.

Model files are zip archives of plain arrays written by ``numpy.savez``.
Anything else (another file type, a truncated or empty archive, arrays of
Python objects) is refused as "not a robolobe model file" with the reason;
pickled content is never loaded and never suggested.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from robolobe._atomic import check_input_file
from robolobe.errors import InputError

__all__ = ["MAX_NPZ_BYTES", "check_range", "read_npz"]


#: Largest model file's arrays, all together (the bundled networks hold about 1 MB).
MAX_NPZ_BYTES = 2 * 2**30


def _check_declared_sizes(p: Path, what: str, where: str) -> None:
    """Refuse an archive whose arrays declare more bytes than it stores (or a huge total).

    Each member's ``.npy`` header states a shape and dtype; numpy would
    allocate that much before reading a byte. A header claiming more data
    than the member holds is a damaged or forged file.
    """
    total = 0
    with zipfile.ZipFile(p) as zf:
        for info in zf.infolist():
            if not info.filename.endswith(".npy"):
                continue
            with zf.open(info) as fh:
                try:
                    version = np.lib.format.read_magic(fh)
                    read_header = (
                        np.lib.format.read_array_header_1_0
                        if version == (1, 0)
                        else np.lib.format.read_array_header_2_0
                    )
                    shape, _, dtype = read_header(fh, max_header_size=10_000)
                except (ValueError, EOFError, OSError) as exc:
                    raise InputError(
                        f"not a {what}: member {info.filename!r} is no array ({exc})", where
                    ) from None
                header = fh.tell()
            declared = int(np.prod(shape, dtype=object)) * int(dtype.itemsize)
            if dtype.hasobject:
                raise InputError(
                    f"not a {what}: it holds Python objects, which robolobe never loads", where
                )
            if declared > info.file_size - header:
                raise InputError(
                    f"not a {what}: member {info.filename!r} declares {shape} "
                    f"({declared:,} bytes) but holds {info.file_size - header:,} bytes",
                    source=where,
                )
            total += declared
    if total > MAX_NPZ_BYTES:
        raise InputError(
            f"not a {what}: its arrays hold {total / 2**30:.1f} GiB, expected at most "
            f"{MAX_NPZ_BYTES / 2**30:.0f} GiB",
            source=where,
        )


def read_npz(path: str | os.PathLike[str], what: str = "robolobe model file") -> dict[str, Any]:
    """All arrays of an ``.npz`` archive, refusing anything that is not one.

    Parameters
    ----------
    path : path-like
        The archive.
    what : str
        What the file should be, for messages (e.g. ``"robolobe model file"``).

    Returns
    -------
    dict of str to numpy.ndarray

    Raises
    ------
    InputError
        Missing file, a folder, not a zip archive, a truncated or empty
        archive, or arrays of Python objects (pickles are never loaded).
    """
    p = Path(path)
    where = str(path)
    check_input_file(p, f"a {what} (.npz)", where)
    if p.stat().st_size == 0:
        raise InputError(f"not a {what}: the file is empty", source=where)
    if not zipfile.is_zipfile(p):
        with p.open("rb") as fh:
            zip_start = fh.read(4) == b"PK\x03\x04"
        why = (
            "the archive is damaged or truncated (no zip directory at its end)"
            if zip_start
            else "expected a .npz (zip) archive"
        )
        raise InputError(f"not a {what}: {why}", source=where)
    try:
        _check_declared_sizes(p, what, where)
        with np.load(p, allow_pickle=False) as z:
            if not z.files:
                raise InputError(f"not a {what}: the archive holds no arrays", source=where)
            return {k: z[k] for k in z.files}
    except InputError:
        raise
    except MemoryError:  # pragma: no cover - the declared sizes are checked first
        raise InputError(f"not a {what}: its arrays do not fit in memory", source=where) from None
    except ValueError as exc:
        if "pickle" in str(exc).lower():
            raise InputError(
                f"not a {what}: it holds Python objects, which robolobe never loads", source=where
            ) from None
        raise InputError(f"not a {what}: {exc}", source=where) from None
    except (OSError, EOFError, zipfile.BadZipFile, KeyError) as exc:
        raise InputError(
            f"not a {what}: the archive is damaged or truncated ({type(exc).__name__})",
            source=where,
        ) from None


def check_range(
    value: Any,
    name: str,
    where: str,
    *,
    low: float = -np.inf,
    high: float = np.inf,
    open_low: bool = False,
    open_high: bool = False,
    nan_ok: bool = False,
) -> np.ndarray:
    """A model file's array, refused unless every entry is finite and in range.

    A model file that parses can still lie: a negative variance, a
    correlation of 2, an infinite weight. The math downstream would then
    fail (``LinAlgError``) or, worse, give numbers. Checked once, at load.

    Parameters
    ----------
    value : array-like
    name : str
        The entry's name in messages.
    where : str
        The file.
    low, high : float
        Bounds of every entry; ``open_low`` / ``open_high`` exclude them.
    nan_ok : bool
        NaN marks "no value" in this entry (skipped by the check).

    Raises
    ------
    InputError
        Naming the entry, the bound and the offending value.
    """
    a = np.asarray(value, dtype=float)
    v = a[~np.isnan(a)] if nan_ok else a
    bad = ~np.isfinite(v)
    bad |= (v <= low) if open_low else (v < low)
    bad |= (v >= high) if open_high else (v > high)
    if bad.any():
        lo = "" if low == -np.inf else f"{low:g} {'<' if open_low else '<='} "
        hi = "" if high == np.inf else f" {'<' if open_high else '<='} {high:g}"
        bounds = f" {lo}x{hi}" if lo or hi else ""
        raise InputError(
            f"inconsistent model file: {name}: expected finite values{bounds}, "
            f"found {float(v[bad][0]):g}",
            source=where,
        )
    return a
