"""User-supplied names (robot files, posture and record ids) as text on a figure.

Matplotlib draws a name as it is: a control character has no glyph (a
warning, a box), a ``$`` starts mathtext (an error on an unbalanced one), and
a 300-character file name squeezes the axes away. :func:`plot_text` shows
control characters as ``?``, a ``$`` as a dollar sign, and shortens long names
in the middle.
"""

from __future__ import annotations

__all__ = ["plot_text"]


def plot_text(name: str, max_chars: int | None = None) -> str:
    """``name`` as figure text: printable, no mathtext, at most ``max_chars`` characters.

    Parameters
    ----------
    name : str
        The name as the user wrote it.
    max_chars : int, optional
        Longer names keep their start and end around ``...``.

    Returns
    -------
    str
    """
    shown = "".join(c if c.isprintable() else "?" for c in str(name))
    if max_chars is not None and len(shown) > max_chars:
        head = (max_chars - 3) // 2
        shown = shown[:head] + "..." + shown[len(shown) - (max_chars - 3 - head) :]
    return shown.replace("$", r"\$")
