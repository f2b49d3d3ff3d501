"""Counts in messages and terminal output: "1 cutting move", "3 cutting moves".

The one place that puts a count and its noun together, so that no message
says "1 postures" or "2 mode(s)". Imports nothing of robolobe (every layer
may use it).
"""

from __future__ import annotations

__all__ = ["count"]

#: Plurals that are not the noun + "s" (the last word of a noun decides).
_IRREGULAR = {"axis": "axes", "matrix": "matrices", "index": "indices", "analysis": "analyses"}


def count(n: int | float, noun: str, plural: str | None = None) -> str:
    """``n`` and ``noun``, the noun in the plural unless ``n`` is 1.

    Parameters
    ----------
    n : int or float
        The count (an integral float prints without decimals).
    noun : str
        Singular noun phrase; its last word is put in the plural ("cutting
        move" -> "cutting moves", "direction x mode output" -> "direction x
        mode outputs").
    plural : str, optional
        The whole plural phrase where the rule does not give it.

    Returns
    -------
    str
        E.g. ``count(1, "posture")`` -> ``"1 posture"``, ``count(3, "pass")``
        -> ``"3 passes"``, ``count(0, "mode")`` -> ``"0 modes"``.
    """
    shown = f"{int(n)}" if float(n).is_integer() else f"{n:g}"
    if n == 1:
        return f"{shown} {noun}"
    return f"{shown} {plural if plural is not None else _plural(noun)}"


def _plural(noun: str) -> str:
    head, _, last = noun.rpartition(" ")
    if last in _IRREGULAR:
        word = _IRREGULAR[last]
    elif last.endswith(("s", "x", "z", "ch", "sh")):
        word = last + "es"
    elif last.endswith("y") and last[-2:-1] not in tuple("aeiou"):
        word = last[:-1] + "ies"
    else:
        word = last + "s"
    return f"{head} {word}" if head else word
