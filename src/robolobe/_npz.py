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

from robolobe.errors import InputError

__all__ = ["read_npz"]


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
    if p.is_dir():
        raise InputError(f"is a directory; expected a {what} (.npz)", source=where)
    if not p.exists():
        raise InputError("file not found", source=where)
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
        with np.load(p, allow_pickle=False) as z:
            if not z.files:
                raise InputError(f"not a {what}: the archive holds no arrays", source=where)
            return {k: z[k] for k in z.files}
    except InputError:
        raise
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
