"""Outputs: checked before any work, written atomically, kept inside the output folder.

A failed run leaves no half-written result (docs/guide/physics.md, conventions): files
are written to a temporary name beside the target and renamed; a folder of
results is assembled in a temporary folder inside it and moved in as a set.
Output paths are checked before a command starts its work
(:func:`check_output_file`, :func:`check_output_dir`), so a bad ``-o`` costs
one line and exit code 2, not a finished computation.

This module is also the one place that keeps writes inside the output folder
the user named (issue 24, docs/guide/outputs.md):

* every name derived from user input (a robot file's stem, a toolpath's stem,
  a posture id) becomes one safe path component through :func:`safe_name`
  and :func:`unique_names` (no ``.``/``..``, no separators, no control
  characters or terminal escapes, bounded length; collisions made unique and
  reported);
* :func:`atomic_dir` records what it wrote in a manifest
  (:data:`MANIFEST`, ``.robolobe-outputs.json``) and, on a re-run, removes
  only files that manifest lists, each checked to lie strictly inside the
  resolved folder and not reached through a symbolic link. It never removes a
  folder tree, never a file it has no record of writing, and refuses (one
  line, exit 2, nothing touched) to replace a file it did not write.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import json
import os
import re
import shutil
import tempfile
import unicodedata
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from robolobe.errors import InputError

__all__ = [
    "MANIFEST",
    "SafeNames",
    "atomic_dir",
    "atomic_path",
    "atomic_write_text",
    "check_input_file",
    "check_inside",
    "check_output_dir",
    "check_output_file",
    "not_a_file",
    "safe_name",
    "unique_names",
]

#: The manifest robolobe writes into every output folder it fills (:func:`atomic_dir`).
MANIFEST = ".robolobe-outputs.json"
#: Longest name :func:`safe_name` returns, in UTF-8 bytes (file systems allow 255).
MAX_NAME_BYTES = 100
_TMP_PREFIX = ".robolobe-tmp."
_NAME_MAX = 255  # bytes in one path component (ext4, APFS, NTFS in UTF-16 units)
# Terminal escapes (CSI, OSC, two-character ESC sequences), removed whole.
_ANSI = re.compile(r"\x1b(?:\[[0-?]*[ -/]*[@-~]|\][^\x07\x1b]*(?:\x07|\x1b\\)?|[@-Z\\-_])")
# Separators and characters no common file system (or Windows) accepts in a name.
_RESERVED_CHARS = re.compile(r'[/\\:*?"<>|]')
# Device names Windows refuses as a file name, with any extension.
_WINDOWS_DEVICES = re.compile(r"(?i)^(con|prn|aux|nul|com[0-9]|lpt[0-9])(\..*)?$")


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

    ``"a directory"``, ``"no such file"``, a named pipe, a device, or ``"not
    a regular file"`` (a socket).
    """
    p = Path(path)
    if p.is_dir():
        return "a directory"
    if not p.exists():
        return "no such file"
    if p.is_fifo():
        return "a named pipe (FIFO), not a regular file"
    if p.is_char_device() or p.is_block_device():
        return "a device, not a regular file"
    return "not a regular file"


def not_a_folder(path: str | os.PathLike[str]) -> str:
    """What an input path that should be a folder is instead, for ``found ...`` in a message."""
    p = Path(path)
    if not p.exists():
        return "no such folder"
    if p.is_file():
        return "a file"
    if p.is_fifo():
        return "a named pipe (FIFO), not a folder"
    return "not a folder"


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
    _check_replaceable(p, option)
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"cannot replace {p}: permission denied", source=option)
    _check_parent(p, option)
    return p


def check_output_dir(
    path: str | os.PathLike[str], option: str = "-o", writes: Iterable[str] = ()
) -> Path:
    """Check that ``path`` can be used as an output folder, before any work.

    Parameters
    ----------
    path : path-like
        Output folder (created if missing; an existing one is reused).
    option : str
        The command-line option (or job key) that named it, for the message.
    writes : iterable of str
        Files (relative POSIX paths) the command will write there: one that
        exists and that robolobe has no record of writing (:data:`MANIFEST`)
        is refused now, as :func:`atomic_dir` would refuse it after the work.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    InputError
        ``path`` is an existing file, lies below a file, or is not writable;
        or it holds one of ``writes`` that robolobe did not write.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p} is a file; expected a folder path", source=option)
    if p.is_dir():
        if not _writable(p):
            raise InputError(f"cannot write into {p}: the folder is not writable", source=option)
        manifest = _read_manifest(p, option)
        clash = _foreign(p, writes, manifest)
        if clash:
            found = bool(manifest.sets) or (p / MANIFEST).exists()
            raise InputError(_foreign_message(p, clash, found), source=option)
    else:
        _check_parent(p, option)
    return p


#: errno values of a write that the disk refused for want of room (EFBIG: a file
#: size limit, ENOSPC: a full disk, EDQUOT: a quota).
_FULL_ERRNOS = frozenset(
    getattr(errno, n) for n in ("EFBIG", "ENOSPC", "EDQUOT") if hasattr(errno, n)
)


@contextlib.contextmanager
def _full_disk_named(target: Path, option: str | None) -> Iterator[None]:
    """A write refused for want of room names the output.

    Some writers (pyarrow's) raise an ``OSError`` without the file's name or
    ``errno``, with the number in the text; both forms are recognised. With
    ``option`` the refusal becomes one line naming it and the output; without,
    an ``OSError`` with its ``errno`` and the output's name (the caller, e.g.
    the command's output set, names its option).
    """
    try:
        yield
    except OSError as exc:
        text = str(exc)
        code = exc.errno if exc.errno in _FULL_ERRNOS else None
        if code is None:
            code = next((n for n in _FULL_ERRNOS if f"errno {n}]" in text), None)
        if code is None:
            raise
        if option is None:
            raise OSError(code, os.strerror(code), os.fspath(target)) from None
        raise InputError(
            f"cannot write {target}: {os.strerror(code)} (the output was not written)",
            source=option,
        ) from None


def _check_replaceable(target: Path, source: str | None = None) -> None:
    """Refuse to replace anything but a regular file (or a link to one) with an output.

    An output is renamed onto its path: onto a device (``/dev/null``, run as
    root) or a named pipe that would replace the node itself, not write to it.
    """
    if not target.is_symlink() and target.exists() and not target.is_file():
        raise InputError(
            f"expected an output file's path, found {not_a_file(target)} there "
            "(an output replaces the file: give a file's path)",
            source=source or os.fspath(target),
        )


@contextlib.contextmanager
def atomic_path(target: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path; on success it is renamed onto ``target``.

    On an exception the temporary file is removed and ``target`` is untouched.
    ``target`` may not be a device, a named pipe or a folder
    (:func:`_check_replaceable`).
    """
    target = Path(target)
    _check_replaceable(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    try:
        with _full_disk_named(target, None):
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


# ---------------------------------------------------------------------------
# Names derived from user input


def safe_name(raw: str, fallback: str = "output", max_bytes: int = MAX_NAME_BYTES) -> str:
    """One safe path component made from a user-derived name.

    Terminal escape sequences, control and format characters (NUL, newline,
    bidi overrides) are removed, other spaces (no-break, ideographic) become
    a plain space; separators (``/``, ``\\``) and the characters
    Windows refuses (``:*?"<>|``) become ``_``; leading and trailing dots and
    spaces go (so ``.``, ``..``, ``...`` and hidden names cannot result); a
    Windows device name (``con``, ``nul.txt``) gets a leading ``_``; a name
    longer than :data:`MAX_NAME_BYTES` UTF-8 bytes is cut and ends in ``~``
    and 8 hex digits of its SHA-256, so two long names stay apart.

    Parameters
    ----------
    raw : str
        The name as the user wrote it (a file stem, an id).
    fallback : str
        The name used when nothing of ``raw`` is left; it must itself be safe.
    max_bytes : int
        Longest result in UTF-8 bytes (room for a prefix or suffix the
        caller adds; 255 is the file systems' limit).

    Returns
    -------
    str
        A name that is its own single path component (``Path(n).name == n``),
        never ``""``, ``.`` or ``..``.
    """
    name = _ANSI.sub("", unicodedata.normalize("NFC", str(raw)))
    name = "".join(
        " " if cat.startswith("Z") else c
        for c, cat in ((c, unicodedata.category(c)) for c in name)
        if not cat.startswith("C")
    )
    name = _RESERVED_CHARS.sub("_", name).strip(" .")
    if _WINDOWS_DEVICES.match(name):
        name = "_" + name
    if len(name.encode("utf-8")) > max_bytes:
        tag = "~" + hashlib.sha256(str(raw).encode("utf-8", "surrogatepass")).hexdigest()[:8]
        cut = name.encode("utf-8")[: max_bytes - len(tag)].decode("utf-8", "ignore")
        name = cut.rstrip(" .") + tag
    if not name:
        if safe_name(fallback, "output") != fallback:
            raise ValueError(f"fallback {fallback!r} is not a safe name")
        return fallback
    return name


@dataclass(frozen=True)
class SafeNames:
    """Safe, distinct output names for a list of user-derived names (:func:`unique_names`).

    Attributes
    ----------
    names : tuple of str
        One safe name per input, in input order, distinct ignoring case (a
        case-insensitive file system cannot hold ``R1`` beside ``r1``).
    notes : tuple of str
        One line per name that is not the input as written: what it became
        and why; commands print them and keep them in their summary.
    """

    names: tuple[str, ...]
    notes: tuple[str, ...]


def unique_names(
    raws: Sequence[str],
    *,
    what: str,
    fallback: str,
    taken: Iterable[str] = (),
    labels: Sequence[str] | None = None,
) -> SafeNames:
    """Safe (:func:`safe_name`) and distinct output names for ``raws``.

    A name that repeats (``a/r.toml`` and ``b/r.toml`` both give ``r``)
    gets ``-2``, ``-3`` ... in input order; so does one equal to a name in
    ``taken`` (the command's own files, such as ``compare.csv``).

    Parameters
    ----------
    raws : sequence of str
        The names as derived from the user's input (stems, ids).
    what : str
        What each name is, for the notes (``"robot file"``, ``"toolpath"``).
    fallback : str
        The name for an input of which nothing safe is left.
    taken : iterable of str
        Names already used in the output folder.
    labels : sequence of str, optional
        How to name each input in the notes (the file as given, where
        ``raws`` are its stems); default ``raws``.

    Returns
    -------
    SafeNames
    """
    used = {t.casefold() for t in taken}
    names: list[str] = []
    notes: list[str] = []
    for i, raw in enumerate(raws):
        base = safe_name(raw, fallback)
        name, n = base, 1
        while name.casefold() in used:
            n += 1
            name = f"{base}-{n}"
        used.add(name.casefold())
        names.append(name)
        if name != raw:
            why = "not a safe file name" if base != raw else f"{base!r} is already used"
            label = raw if labels is None else labels[i]
            notes.append(f"{what} {label!r}: outputs in {name!r} ({why})")
    return SafeNames(tuple(names), tuple(notes))


def check_inside(root: str | os.PathLike[str], path: str | os.PathLike[str]) -> Path:
    """Check that ``path`` lies strictly inside the folder ``root``, both resolved.

    Symbolic links are followed, so a link inside ``root`` that points out of
    it is refused, and so is ``..``.

    Parameters
    ----------
    root : path-like
        The output folder (it may itself be a link; its target counts).
    path : path-like
        A path to be written, replaced or removed (need not exist).

    Returns
    -------
    pathlib.Path
        ``path`` resolved.

    Raises
    ------
    InputError
        ``path`` is ``root`` itself or lies outside it.
    """
    r = Path(root).resolve()
    p = Path(path).resolve()
    if p == r or not p.is_relative_to(r):
        raise InputError(
            f"{path} is not inside the output folder {root} (it resolves to {p}); "
            "robolobe writes only inside the output folder",
            source=str(root),
        )
    return p


def _is_inside(root: Path, path: Path) -> bool:
    try:
        check_inside(root, path)
    except InputError:
        return False
    return True


# ---------------------------------------------------------------------------
# The manifest: what robolobe wrote into an output folder


def _plain_rel(rel: object) -> str | None:
    """``rel`` if it is a plain relative POSIX path of safe components, else None."""
    if not isinstance(rel, str) or not rel or "\\" in rel or rel.startswith("/"):
        return None
    parts = PurePosixPath(rel).parts
    if "/".join(parts) != rel or any(safe_name(p, "x", _NAME_MAX) != p for p in parts):
        return None
    return rel


@dataclass
class _Manifest:
    """The sets of a folder's manifest: kind -> (files, folders), relative POSIX paths."""

    sets: dict[str, tuple[set[str], set[str]]]

    def recorded_files(self) -> set[str]:
        return {f for files, _ in self.sets.values() for f in files}

    def recorded_folders(self) -> set[str]:
        return {d for _, folders in self.sets.values() for d in folders}

    def to_json(self) -> str:
        from robolobe import __version__

        doc = {
            "written_by": "robolobe",
            "robolobe_version": __version__,
            "about": "What robolobe wrote into this folder, by command. A re-run "
            "replaces and removes only the files listed here; delete this file "
            "and robolobe treats every file here as not its own.",
            "sets": {
                kind: {"files": sorted(files), "folders": sorted(folders)}
                for kind, (files, folders) in sorted(self.sets.items())
                if files or folders
            },
        }
        return json.dumps(doc, indent=2) + "\n"


def _read_manifest(folder: Path, option: str | None) -> _Manifest:
    """The manifest of ``folder`` (empty if there is none); unsafe entries are dropped."""
    path = folder / MANIFEST
    if not (path.exists() or path.is_symlink()):
        return _Manifest({})
    problem = None
    doc: object = None
    if path.is_symlink() or not path.is_file():
        problem = "not a regular file"
    else:
        try:
            doc = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            problem = f"not readable JSON ({type(exc).__name__})"
    if problem is None and not (
        isinstance(doc, dict)
        and doc.get("written_by") == "robolobe"
        and isinstance(doc.get("sets"), dict)
    ):
        problem = "not a robolobe manifest"
    if problem is not None:
        raise InputError(
            f"{path}: expected the list of files robolobe wrote, found {problem}; "
            "remove it (robolobe then replaces nothing it finds there) or choose another folder",
            source=option,
        )
    assert isinstance(doc, dict)
    sets: dict[str, tuple[set[str], set[str]]] = {}
    for kind, entry in doc["sets"].items():
        if not isinstance(entry, dict):
            continue
        lists = [entry.get(k) for k in ("files", "folders")]
        files, folders = (
            {r for r in map(_plain_rel, v) if r} if isinstance(v, list) else set() for v in lists
        )
        sets[str(kind)] = (files, folders)
    return _Manifest(sets)


def _foreign_message(folder: Path, clash: Sequence[str], manifest_found: bool) -> str:
    shown = ", ".join(clash[:3]) + (f" (+{len(clash) - 3} more)" if len(clash) > 3 else "")
    why = (
        f"not listed in {MANIFEST}"
        if manifest_found
        else f"no {MANIFEST} there: someone else's, or an earlier robolobe's that kept no list"
    )
    return (
        f"{folder} already holds {shown}, which robolobe did not write ({why}); "
        "expected an output folder without them: move them away, or choose another folder"
    )


def _foreign(folder: Path, names: Iterable[str], manifest: _Manifest) -> list[str]:
    """Of ``names`` (relative paths this run writes as files), those present but not recorded."""
    own = manifest.recorded_files()
    out = []
    for rel in names:
        p = folder / rel
        if (p.exists() or p.is_symlink()) and rel not in own:
            out.append(rel)
    return sorted(out)


# ---------------------------------------------------------------------------
# A folder of results, replaced as a set


def _tree(tmp: Path) -> tuple[list[str], list[str]]:
    """Files and folders below ``tmp`` as relative POSIX paths, parents first."""
    files: list[str] = []
    folders: list[str] = []
    for p in sorted(tmp.rglob("*")):
        rel = p.relative_to(tmp).as_posix()
        if p.is_symlink():
            raise RuntimeError(f"an output set holds a symbolic link: {rel}")
        (folders if p.is_dir() else files).append(rel)
    return files, folders


def _refuse(folder: Path, message: str, option: str | None) -> InputError:
    return InputError(f"{message}; nothing was written to {folder}", source=option)


@contextlib.contextmanager
def atomic_dir(
    target: str | os.PathLike[str], kind: str, *, option: str | None = None
) -> Iterator[Path]:
    """Yield a temporary folder; on success its files replace the ``kind`` set in ``target``.

    The block writes the whole set into the temporary folder (inside
    ``target``). On success, before anything in ``target`` changes, every
    path is checked: it must lie strictly inside ``target`` resolved, not be
    a symbolic link, and not be a file robolobe has no record of writing
    (:data:`MANIFEST`). Then the manifest is written, the files are moved in
    one by one with an atomic rename, the files the previous ``kind`` set
    listed and this one did not write are removed (and folders of that set
    left empty), and the manifest is written again listing the new set.
    Files robolobe did not write are never removed, nor folder trees; on an
    exception (or a refusal) nothing in ``target`` changes.

    Parameters
    ----------
    target : path-like
        The output folder (created if missing; a symbolic link to a folder is
        followed: its target is the output folder).
    kind : str
        The set's name in the manifest (``"plan"``, ``"compare"``): a re-run
        of the same kind replaces the set whole; other kinds' files stay.
    option : str, optional
        The option that named ``target``, for messages.

    Raises
    ------
    InputError
        A file to be replaced that robolobe did not write (an output folder
        of an earlier version, a user's ``report.html``), a symbolic link or
        a folder in the way, or a manifest that is not robolobe's.
    """
    target = Path(target)
    created = not (target.exists() or target.is_symlink())
    target.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=_TMP_PREFIX, suffix=".tmp", dir=target))
    mask = _umask()
    try:
        with _full_disk_named(target, option):
            yield tmp
            _commit(target, tmp, kind, option, mask)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
        if created:
            with contextlib.suppress(OSError):
                target.rmdir()  # only if the run failed and left it empty


def _commit(target: Path, tmp: Path, kind: str, option: str | None, mask: int) -> None:
    files, folders = _tree(tmp)
    new_files, new_folders = set(files), set(folders)
    manifest = _read_manifest(target, option)
    # Check everything before anything changes.
    for rel in (*folders, *files):
        if _plain_rel(rel) is None:
            raise _refuse(target, f"{rel!r} is not a safe output name", option)
        dst = target / rel
        if dst.is_symlink():
            raise _refuse(
                target,
                f"{dst} is a symbolic link; robolobe replaces only files it wrote",
                option,
            )
        if rel in new_folders and dst.exists() and not dst.is_dir():
            raise _refuse(target, f"{dst} is a file where a folder is to be written", option)
        if rel in new_files and dst.is_dir():
            raise _refuse(target, f"{dst} is a folder where a file is to be written", option)
        if rel in new_files and not dst.is_symlink() and dst.exists() and not dst.is_file():
            what = not_a_file(dst)
            raise _refuse(target, f"{dst} is {what} where a file is to be written", option)
        check_inside(target, dst)
    clash = _foreign(target, files, manifest)
    if clash:
        found = (target / MANIFEST).exists()
        raise _refuse(target, _foreign_message(target, clash, found), option)
    old_files, old_folders = manifest.sets.get(kind, (set(), set()))
    # Claim the new set first: a crash below leaves at most files listed that are gone.
    claim = _Manifest(dict(manifest.sets))
    claim.sets[kind] = (old_files | new_files, old_folders | new_folders)
    atomic_write_text(target / MANIFEST, claim.to_json())
    for rel in folders:
        (target / rel).mkdir(mode=0o777 & ~mask, exist_ok=True)
    for rel in files:
        src = tmp / rel
        os.chmod(src, 0o666 & ~mask)
        os.replace(src, target / rel)
    # A file another set listed now belongs to this one.
    others = {k: (f - new_files, d) for k, (f, d) in manifest.sets.items() if k != kind}
    still = {f for fs, _ in others.values() for f in fs} | new_files
    for rel in sorted(old_files - still):
        stale = target / rel
        # Not a plain file inside any more (a link, a folder, moved out through
        # a linked folder): not what robolobe wrote there, so it stays.
        if not stale.is_symlink() and stale.is_file() and _is_inside(target, stale):
            stale.unlink()
    kept_dirs = {d for _, ds in others.values() for d in ds} | new_folders
    for rel in sorted(old_folders - kept_dirs, key=lambda r: -r.count("/")):
        d = target / rel
        if d.is_dir() and not d.is_symlink() and _is_inside(target, d):
            with contextlib.suppress(OSError):
                d.rmdir()  # only when empty: a user's file in it keeps it
    final = _Manifest(others)
    final.sets[kind] = (new_files, new_folders)
    atomic_write_text(target / MANIFEST, final.to_json())
