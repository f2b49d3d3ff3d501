"""The one direction vocabulary: TCP axes and FRF directions.

A direction is two letters from x, y, z: the response axis, then the
excitation axis (``"xy"``: x response to a y force), in the TCP frame.
Arrays of FRFs are indexed ``[..., response, excitation]`` with x, y, z =
0, 1, 2. This module imports no robolobe package, so every layer may use it.
"""

from __future__ import annotations

from robolobe.errors import InputError

__all__ = ["ALL_DIRS", "AXES", "DRIVING", "dir_index", "dir_name"]

AXES = "xyz"
"""TCP axes in array order."""
ALL_DIRS: tuple[str, ...] = tuple(r + e for r in AXES for e in AXES)
"""The nine directions in array order (row-major: response, excitation)."""
DRIVING: tuple[str, ...] = ("xx", "yy", "zz")
"""The driving-point directions."""


def dir_index(name: str) -> tuple[int, int]:
    """(response, excitation) axis indices of a direction such as ``"xy"``.

    Raises
    ------
    InputError
        If ``name`` is not two letters from x, y, z (lower case).

    Examples
    --------
    >>> dir_index("xy"), dir_name(2, 2)
    ((0, 1), 'zz')
    """
    if len(name) != 2 or name[0] not in AXES or name[1] not in AXES:
        raise InputError(f"direction: expected two letters of x, y, z, found {name!r}")
    return AXES.index(name[0]), AXES.index(name[1])


def dir_name(i: int, j: int) -> str:
    """Direction of response axis ``i`` and excitation axis ``j`` (0, 1, 2 = x, y, z)."""
    return AXES[i] + AXES[j]
