"""Effects files (``effects.toml``, ``format = "robolobe-effects/1"``).

Physics effects added to a robot's nominal model (:mod:`robolobe.twin.effects`)
as ``[[effects]]`` tables in their :func:`~robolobe.twin.effects.effect_to_dict`
form, e.g. what ``robolobe diagnose --updated-model`` found::

    format = "robolobe-effects/1"
    notes = "..."
    [[effects]]
    name = "tool_mode"
    f_hz = 180.0
    ...

``robolobe simulate --effects`` and the job key ``robot.effects`` read them.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import tomli_w

from robolobe._atomic import not_a_file
from robolobe._documents import parse_toml
from robolobe.errors import InputError
from robolobe.twin.effects import Effect, effect_from_dict, effect_to_dict

__all__ = ["EFFECTS_FORMAT", "effects_to_toml", "read_effects"]

EFFECTS_FORMAT = "robolobe-effects/1"


def effects_to_toml(effects: Sequence[Effect], *, note: str = "") -> str:
    """``effects.toml`` text for ``effects``.

    Parameters
    ----------
    effects : sequence of Effect
    note : str
        Free text stored under ``notes``.
    """
    doc: dict[str, Any] = {"format": EFFECTS_FORMAT}
    if note:
        doc["notes"] = note
    doc["effects"] = [effect_to_dict(e) for e in effects]
    return tomli_w.dumps(doc)


def read_effects(path: str | os.PathLike[str]) -> tuple[Effect, ...]:
    """Read an ``effects.toml`` file.

    Raises
    ------
    InputError
        Missing file, bad format key, unknown effect or parameter (naming the
        file and the table index).
    """
    p = Path(path)
    where = os.fspath(path)
    if not p.is_file():
        raise InputError(f"expected an effects file (effects.toml), found {not_a_file(p)}", where)
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the file: {exc}", where) from None
    doc = parse_toml(text, where)
    fmt = doc.get("format")
    if fmt != EFFECTS_FORMAT:
        raise InputError(f"expected format = {EFFECTS_FORMAT!r}, found {fmt!r}", f"{where}[format]")
    tables = doc.get("effects", [])
    if not isinstance(tables, list):
        raise InputError("expected [[effects]] tables", f"{where}[effects]")
    return tuple(effect_from_dict(t, source=f"{where}[effects][{i}]") for i, t in enumerate(tables))
