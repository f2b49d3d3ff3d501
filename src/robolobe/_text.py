"""User text: shown safely (terminal, HTML, figures) and counted in words.

File names, robot names, job titles and file contents quoted in messages
reach a terminal (through rich), HTML reports and figures. A control
character there can move the cursor, recolour or clear the terminal (ANSI
escapes), forge a line (a newline followed by ``error:``), or reorder what is
shown (a right-to-left override). :func:`visible` replaces each such
character by its Python escape (``\\x1b``, ``\\n``, ``\\u202e``) so the text
shows as written, one character for one escape; :func:`html_text` adds HTML
escaping for the reports and :func:`plot_text` makes a name safe and short on
a figure. Markup (rich's ``[bold]``) is not this module's concern: the CLI's
consoles do not parse markup at all.

:func:`count` is the one place that puts a count and its noun together, so
that no message says "1 postures" or "2 mode(s)". Imports nothing of robolobe
(every layer may use it).
"""

from __future__ import annotations

import re

__all__ = ["count", "hidden_character", "html_text", "plot_text", "visible"]

#: Plurals that are not the noun + "s" (the last word of a noun decides).
_IRREGULAR = {"axis": "axes", "matrix": "matrices", "index": "indices", "analysis": "analyses"}

#: Bidirectional formatting characters (Unicode TR 9): they reorder the text around them.
_BIDI = "\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069"

#: Every character that is not shown as itself: C0/C1 controls and DEL, bidi
#: controls, line/paragraph separators (a new line in some terminals).
_HIDDEN = re.compile(
    "[" + "".join(re.escape(chr(c)) for c in [*range(0x20), *range(0x7F, 0xA0)])
    + re.escape(_BIDI) + "\u2028\u2029\ufeff]"
)  # fmt: skip


def _escape(match: re.Match[str]) -> str:
    return ascii(match.group())[1:-1]  # "\\x1b", "\\n", "\\u202e"


def visible(text: object, *, newlines: bool = False) -> str:
    """``text`` with every control or bidi character as its visible escape.

    Parameters
    ----------
    text : object
        Any value; shown through ``str``.
    newlines : bool
        Keep ``"\\n"`` as a line break (for multi-line text written by
        robolobe itself); by default a newline shows as ``\\n`` so the text
        is one line.

    Returns
    -------
    str
        The text, one escape (``\\x1b``, ``\\n``, ``\\u202e``) per hidden
        character; other characters (accents, CJK, emoji) unchanged.
    """
    s = str(text)
    if newlines:
        return "\n".join(_HIDDEN.sub(_escape, part) for part in s.split("\n"))
    return _HIDDEN.sub(_escape, s)


def html_text(text: object, *, newlines: bool = False) -> str:
    """``text`` for HTML: :func:`visible` then :func:`html.escape` (quotes included)."""
    import html

    return html.escape(visible(text, newlines=newlines))


def plot_text(text: object, max_chars: int | None = None) -> str:
    """``text`` for a matplotlib label or title: :func:`visible`, ``$`` escaped, shortened.

    A pair of ``$`` starts mathtext; a file name like ``a$\\frac$b.toml``
    would otherwise fail the plot (``ParseSyntaxException``), and a
    300-character file name squeezes the axes away.

    Parameters
    ----------
    text : object
        The name as the user wrote it.
    max_chars : int, optional
        Longer names keep their start and end around ``...``.

    Returns
    -------
    str
    """
    shown = visible(text)
    if max_chars is not None and len(shown) > max_chars:
        head = (max_chars - 3) // 2
        shown = shown[:head] + "..." + shown[len(shown) - (max_chars - 3 - head) :]
    return shown.replace("$", r"\$")


def hidden_character(value: str) -> str | None:
    """The first character of ``value`` that :func:`visible` would escape, as its escape.

    For readers that refuse such characters in names and titles (a robot's
    ``name``, a job's ``name``): ``None`` when there is none.
    """
    match = _HIDDEN.search(value)
    return None if match is None else _escape(match)


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
