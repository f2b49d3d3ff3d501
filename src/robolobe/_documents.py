"""The one boundary for structured text: TOML and JSON documents from files.

Robot, job, campaign and effects files (TOML) and model metadata and plan
records (JSON) are parsed here, with the guards every reader needs before it
looks at a key: a size cap, a nesting cap (a deeply nested document would
otherwise end in ``RecursionError`` in the parser or in the code that walks
it), a syntax error with its line, and the top level's type (a table, not a
list). Each problem is one :class:`~robolobe.errors.InputError` naming the
file.
"""

from __future__ import annotations

import json
import re
import tomllib
from typing import Any

from robolobe.errors import InputError

__all__ = ["MAX_DEPTH", "MAX_DOCUMENT_BYTES", "parse_json", "parse_toml"]

#: Deepest nesting of tables and arrays any robolobe document uses, with room.
MAX_DEPTH = 32
#: Largest TOML or JSON document read (robot files are a few kB; model metadata < 1 MB).
MAX_DOCUMENT_BYTES = 16 * 2**20


def _check_size(text: str, where: str, kind: str) -> None:
    if len(text) > MAX_DOCUMENT_BYTES:
        raise InputError(
            f"expected a {kind} document of at most {MAX_DOCUMENT_BYTES // 2**20} MiB, "
            f"found {len(text) / 2**20:.0f} MiB",
            source=where,
        )


def _too_deep(where: str) -> InputError:
    return InputError(
        f"expected tables and arrays nested at most {MAX_DEPTH} deep, found deeper nesting",
        source=where,
    )


def _check_depth(doc: object, where: str) -> None:
    stack: list[tuple[object, int]] = [(doc, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise _too_deep(where)
        if isinstance(node, dict):
            stack.extend((v, depth + 1) for v in node.values())
        elif isinstance(node, list):
            stack.extend((v, depth + 1) for v in node)


def parse_toml(text: str, where: str) -> dict[str, Any]:
    """A TOML document as a dict, guarded (size, nesting, syntax with its line).

    Parameters
    ----------
    text : str
        The file's content.
    where : str
        The file's name in messages.

    Raises
    ------
    InputError
        Too large, nested deeper than :data:`MAX_DEPTH`, or a syntax error
        (the source names the line).
    """
    _check_size(text, where, "TOML")
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"line (\d+)", msg)
        raise InputError(
            f"TOML syntax error: {msg}", source=f"{where}:{m.group(1)}" if m else where
        ) from None
    except RecursionError:
        raise _too_deep(where) from None
    _check_depth(doc, where)
    return doc


def parse_json(text: str, where: str, *, expect: type = dict) -> Any:
    """A JSON document, guarded (size, nesting, syntax, the top level's type).

    Parameters
    ----------
    text : str
        The document.
    where : str
        Its name in messages (a file, or ``model.npz[meta]``).
    expect : type
        The top level's type: ``dict`` (an object) or ``list`` (an array).

    Raises
    ------
    InputError
        Too large, nested deeper than :data:`MAX_DEPTH`, not JSON (with the
        line), NaN/Infinity constants, or another top-level type.
    """
    _check_size(text, where, "JSON")

    def no_constant(name: str) -> Any:
        raise InputError(f"expected JSON numbers, found {name}", source=where)

    try:
        doc = json.loads(text, parse_constant=no_constant)
    except json.JSONDecodeError as exc:
        raise InputError(f"not JSON: {exc.msg} (line {exc.lineno})", source=where) from None
    except RecursionError:
        raise _too_deep(where) from None
    if not isinstance(doc, expect):
        kinds: dict[type, str] = {dict: "an object", list: "an array"}
        found = kinds.get(type(doc), type(doc).__name__)
        raise InputError(f"expected {kinds.get(expect, expect.__name__)}, found {found}", where)
    _check_depth(doc, where)
    return doc
