"""Readable messages for pydantic validation errors of TOML files.

Shared by the robot-file and job-file readers: a pydantic error becomes
``key.path[2].name: expected a positive number, found -5``.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from typing import Annotated, Any

from pydantic import AfterValidator

from robolobe._text import hidden_character
from robolobe.errors import InputError

__all__ = ["PrintableText", "check_key_typos", "describe_error", "found", "key_path", "number"]


def _printable(value: str) -> str:
    bad = hidden_character(value)
    if bad is not None:
        raise ValueError(
            f"expected printable text (a name shown in tables and reports), "
            f"found a control character {bad}"
        )
    return value


#: A name or title from a file: no control, bidi or line-separator characters
#: (they would move the cursor, reorder or break the lines where it is shown).
PrintableText = Annotated[str, AfterValidator(_printable)]


def key_path(loc: Sequence[int | str], table_arrays: Sequence[str] = ()) -> str:
    """A pydantic location as a TOML key path, array indices counted from 1.

    Parameters
    ----------
    loc : sequence of int or str
        ``err["loc"]`` of a pydantic error.
    table_arrays : sequence of str
        Top-level keys that are TOML arrays of tables, written ``[[name]]``.
    """
    out = ""
    for i, part in enumerate(loc):
        if isinstance(part, int):
            out += f"[{part + 1}]"
        elif i == 0 and part in table_arrays:
            out += f"[[{part}]]"
        elif part.startswith("function-") or part in ("literal", "float", "int", "str"):
            continue  # pydantic union branch names
        else:
            out += ("." if out else "") + str(part)
    return out or "<file>"


def number(x: float) -> str:
    """A number in a message: ``100000``, ``0.0125``, ``1e12`` (not ``1e+12`` or ``1e12.0``)."""
    v = float(x)
    if v.is_integer() and abs(v) < 1e7:
        return str(int(v))
    return re.sub(r"e\+?(-?)0*(\d)", r"e\1\2", f"{v:.4g}")


def found(value: Any) -> str:
    """How a found value reads in a message."""
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"an array of {len(value)}"
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e15:
        return str(int(value))
    return str(value)


def _bound(value: Any) -> str:
    return (
        number(value)
        if isinstance(value, int | float) and not isinstance(value, bool)
        else str(value)
    )


def describe_error(err: Any) -> str:
    """``expected ..., found ...`` for one pydantic error (a dict of ``exc.errors()``)."""
    kind = err["type"]
    ctx = err.get("ctx") or {}
    inp = err.get("input")
    if kind == "missing":
        return "missing required key"
    if kind in ("float_type", "float_parsing"):
        expected = "a number"
    elif kind in ("int_type", "int_parsing", "int_from_float"):
        expected = "an integer"
    elif kind in ("bool_type", "bool_parsing"):
        expected = "true or false"
    elif kind == "finite_number":
        expected = "a finite number"
    elif kind == "greater_than":
        gt = ctx.get("gt")
        expected = "a positive number" if gt == 0 else f"a number > {_bound(gt)}"
    elif kind == "greater_than_equal":
        ge = ctx.get("ge")
        expected = "a non-negative number" if ge == 0 else f"a number >= {_bound(ge)}"
    elif kind in ("less_than", "less_than_equal"):
        bound = ctx.get("lt", ctx.get("le"))
        expected = f"a number {'<' if kind == 'less_than' else '<='} {_bound(bound)}"
    elif kind in ("too_short", "too_long"):
        n = ctx.get("min_length") if kind == "too_short" else ctx.get("max_length")
        if isinstance(inp, list):
            return f"expected {n} entries, found {len(inp)}"
        expected = f"{n} entries"
    elif kind == "literal_error":
        expected = f"one of {ctx.get('expected')}"
    elif kind == "list_type":
        expected = "an array"
    elif kind in ("model_type", "dict_type", "model_attributes_type"):
        expected = "a table"
    elif kind in ("string_type", "string_too_short"):
        expected = "a non-empty string"
    elif kind == "value_error":
        msg = str(err.get("msg", ""))
        return msg.removeprefix("Value error, ")
    else:
        return str(err.get("msg", kind))
    return f"expected {expected}, found {found(inp)}"


def check_key_typos(tables: Iterable[tuple[Any, Iterable[str], str]], where: str) -> None:
    """Refuse a key that looks like a misspelt known key.

    A misspelt optional key would otherwise be ignored and its default used
    without a word; a misspelt required key would be reported as missing.
    Unknown keys that resemble no known key are allowed (extensions).

    Parameters
    ----------
    tables : iterable of (table, known keys, key-path prefix)
        Each parsed TOML table (anything that is not a dict is skipped), the
        keys it may hold and its path for messages (e.g. ``"plan."``).
    where : str
        File name for the message.

    Raises
    ------
    InputError
        ``where: unknown key plan.safty_factor; did you mean 'safety_factor'?``
    """
    for table, known, prefix in tables:
        if not isinstance(table, dict):
            continue
        names = sorted(known)
        for key in table:
            if key in known:
                continue
            close = difflib.get_close_matches(str(key), names, n=1, cutoff=0.75)
            if close:
                raise InputError(
                    f"unknown key {prefix}{key}; did you mean {close[0]!r}? "
                    "(a misspelt key would be ignored)",
                    source=where,
                )
