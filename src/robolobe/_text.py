"""User text made safe to show: control and bidi characters as visible escapes.

File names, robot names, job titles and file contents quoted in messages
reach a terminal (through rich) and HTML reports. A control character there
can move the cursor, recolour or clear the terminal (ANSI escapes), forge a
line (a newline followed by ``error:``), or reorder what is shown (a
right-to-left override). :func:`visible` replaces each such character by its
Python escape (``\\x1b``, ``\\n``, ``\\u202e``) so the text shows as written,
one character for one escape; :func:`html_text` adds HTML escaping for the
reports. Markup (rich's ``[bold]``) is not this module's concern: the CLI's
consoles do not parse markup at all.
"""

from __future__ import annotations

import re

__all__ = ["hidden_character", "html_text", "plot_text", "visible"]

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


def plot_text(text: object) -> str:
    """``text`` for a matplotlib label or title: :func:`visible`, ``$`` escaped.

    A pair of ``$`` starts mathtext; a file name like ``a$\\frac$b.toml``
    would otherwise fail the plot (``ParseSyntaxException``).
    """
    return visible(text).replace("$", r"\$")


def hidden_character(value: str) -> str | None:
    """The first character of ``value`` that :func:`visible` would escape, as its escape.

    For readers that refuse such characters in names and titles (a robot's
    ``name``, a job's ``name``): ``None`` when there is none.
    """
    match = _HIDDEN.search(value)
    return None if match is None else _escape(match)
