"""Outputs: checked before any work, written atomically, honouring the umask.

A failed run leaves no half-written result (docs/guide/physics.md, conventions): files
are written to a temporary name beside the target and renamed; a folder of
results is assembled in a temporary folder and moved in as a set. Output
paths are checked before a command starts its work
(:func:`check_output_file`, :func:`check_output_dir`), so a bad ``-o`` costs
one line and exit code 2, not a finished computation.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from robolobe.errors import InputError

__all__ = [
    "atomic_dir",
    "atomic_path",
    "atomic_write_text",
    "check_input_file",
    "check_output_dir",
    "check_output_file",
    "not_a_file",
]


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _nearest_existing(path: Path) -> Path:
    p = path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def _writable(folder: Path) -> bool:
    """Whether a file can be created in ``folder`` (tried, not guessed: root, /proc)."""
    try:
        fd, probe = tempfile.mkstemp(prefix=".robolobe-probe.", dir=folder)
    except OSError:
        return False
    os.close(fd)
    os.unlink(probe)
    return True


def _check_parent(path: Path, option: str) -> None:
    """The folders above ``path`` are folders (or can be made) and writable."""
    anc = _nearest_existing(path.parent if path.parent != path else path)
    if not anc.is_dir():
        raise InputError(
            f"{anc} is a file, so {path} cannot be created in it: "
            "expected a folder path (or a new one)",
            source=option,
        )
    if not _writable(anc):
        raise InputError(f"cannot create {path}: {anc} is not writable", source=option)


def not_a_file(path: str | os.PathLike[str]) -> str:
    """What an input path that should be a file is instead, for ``found ...`` in a message.

    ``"a directory"``, ``"no such file"`` or ``"not a regular file"`` (a
    device, a socket).
    """
    p = Path(path)
    if p.is_dir():
        return "a directory"
    if not p.exists():
        return "no such file"
    if p.is_fifo():
        return "a named pipe (FIFO), not a regular file"
    return "not a regular file"


def check_input_file(path: str | os.PathLike[str], what: str, source: str | None = None) -> Path:
    """The one check of an input path that must be a regular file, before it is opened.

    A folder, a missing path, a FIFO (opening it would wait for a writer
    forever) or a device is refused as ``expected <what>, found <what it is>``.

    Parameters
    ----------
    path : path-like
    what : str
        What the file should be (``"a CSV file"``).
    source : str, optional
        The name in the message (default: the path).

    Returns
    -------
    pathlib.Path
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(
            f"expected {what}, found {not_a_file(p)}", source=source or os.fspath(path)
        )
    return p


def check_output_file(path: str | os.PathLike[str], option: str = "-o") -> Path:
    """Check that ``path`` can be written as a file, before any work is done.

    Parameters
    ----------
    path : path-like
        Output file to be written (it may exist; it is then replaced).
    option : str
        The command-line option (or job key) that named it, for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        ``path`` is an existing folder, lies below a file, or its folder is
        not writable.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p} is a directory; expected a file path", source=option)
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"cannot replace {p}: permission denied", source=option)
    _check_parent(p, option)
    return p


def check_output_dir(path: str | os.PathLike[str], option: str = "-o") -> Path:
    """Check that ``path`` can be used as an output folder, before any work.

    Parameters
    ----------
    path : path-like
        Output folder (created if missing; an existing one is reused).
    option : str
        The command-line option (or job key) that named it, for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        ``path`` is an existing file, lies below a file, or is not writable.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p} is a file; expected a folder path", source=option)
    if p.is_dir():
        if not _writable(p):
            raise InputError(f"cannot write into {p}: the folder is not writable", source=option)
    else:
        _check_parent(p, option)
    return p


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path; on success it is renamed onto ``target``.

    On an exception the temporary file is removed and ``target`` is untouched.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        yield tmp_path
        # mkstemp creates 0600; a result file gets the mode any new file gets.
        os.chmod(tmp_path, 0o666 & ~_umask())
        os.replace(tmp_path, target)
    finally:
        if tmp_path.exists():
            tmp_path.unlink()


def atomic_write_text(target: str | os.PathLike[str], text: str) -> None:
    """Write ``text`` (UTF-8) to ``target`` atomically."""
    with atomic_path(target) as tmp:
        tmp.write_text(text, encoding="utf-8")


@contextlib.contextmanager
def atomic_dir(target: str | os.PathLike[str], managed: Iterable[str] = ()) -> Iterator[Path]:
    """Yield a temporary directory; on success it replaces ``target``.

    The new files are moved in one by one after the block succeeds, each
    with an atomic rename; on an exception nothing in ``target`` changes.

    Parameters
    ----------
    target : path-like
        The output folder.
    managed : iterable of str
        Top-level names (files or folders) that belong to this kind of
        output. Those the run did not write are removed from ``target`` on
        success, so a re-run replaces the whole set (no ``report.html`` of an
        earlier job beside a new summary). Other files in ``target`` are kept.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
    mask = _umask()
    try:
        yield tmp
        target.mkdir(parents=True, exist_ok=True)
        written = {p.name for p in tmp.iterdir()}
        for name in managed:
            stale = target / name
            if name in written or not (stale.exists() or stale.is_symlink()):
                continue
            if stale.is_dir() and not stale.is_symlink():
                shutil.rmtree(stale)
            else:
                stale.unlink()
        for src in sorted(tmp.rglob("*")):
            rel = src.relative_to(tmp)
            dst = target / rel
            if src.is_dir():
                dst.mkdir(mode=0o777 & ~mask, parents=True, exist_ok=True)
            else:
                dst.parent.mkdir(parents=True, exist_ok=True)
                os.chmod(src, 0o666 & ~mask)
                os.replace(src, dst)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
