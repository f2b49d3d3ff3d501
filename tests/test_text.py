"""Counts with their noun in the singular or plural (robolobe._text.count)."""

from __future__ import annotations

import re

import pytest

from robolobe._text import count


@pytest.mark.parametrize(
    ("n", "noun", "expected"),
    [
        (1, "cutting move", "1 cutting move"),
        (2, "cutting move", "2 cutting moves"),
        (0, "posture", "0 postures"),
        (1.0, "FRF", "1 FRF"),
        (21, "FRF", "21 FRFs"),
        (3, "pass", "3 passes"),
        (2, "entry", "2 entries"),
        (2, "day", "2 days"),
        (2, "axis", "2 axes"),
        (45, "direction x mode output", "45 direction x mode outputs"),
    ],
)
def test_count(n, noun, expected):
    assert count(n, noun) == expected


def test_count_with_a_given_plural():
    assert count(1, "person", "people") == "1 person"
    assert count(4, "person", "people") == "4 people"


def _hand_made_plurals(path) -> list[str]:
    """f-strings of ``path`` that put a count before "noun(s)" or build the "s" by hand."""
    import ast

    bad = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if not isinstance(node, ast.JoinedStr):
            continue
        for a, b in zip(node.values, node.values[1:], strict=False):
            if (
                isinstance(a, ast.FormattedValue)
                and isinstance(b, ast.Constant)
                and re.match(r"\s+[\w ]*\w\(s\)", str(b.value))
            ):
                bad.append(f"{path.name}:{node.lineno} count + '(s)'")
        for v in node.values:
            if (
                isinstance(v, ast.FormattedValue)
                and isinstance(v.value, ast.IfExp)
                and "s"
                in (getattr(v.value.body, "value", None), getattr(v.value.orelse, "value", None))
            ):
                bad.append(f"{path.name}:{node.lineno} plural 's' by hand")
    return bad


def test_cli_output_counts_through_the_one_helper():
    from pathlib import Path

    cli = Path(__file__).resolve().parents[1] / "src" / "robolobe" / "cli"
    assert [b for p in sorted(cli.glob("*.py")) for b in _hand_made_plurals(p)] == []


def test_the_plural_check_sees_both_forms(tmp_path):
    src = tmp_path / "m.py"
    src.write_text(
        "n = 2\na = f\"{n} mode(s) left\"\nb = f\"{n} waypoint{'s' if n != 1 else ''}\"\n"
        'ok = f"{n} of the (s) terms"\n',
        encoding="utf-8",
    )
    assert _hand_made_plurals(src) == ["m.py:2 count + '(s)'", "m.py:3 plural 's' by hand"]
