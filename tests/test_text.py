"""Counts with their noun in the singular or plural (robolobe._text.count)."""

from __future__ import annotations

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
