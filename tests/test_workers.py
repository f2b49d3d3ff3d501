"""The worker pool: results in order, whatever the chunking, and progress counted."""

from __future__ import annotations

import functools

import pytest

from robolobe._workers import map_chunks


def _affine(x: int, a: int = 1, b: int = 0) -> int:
    return a * x + b


@pytest.mark.slow
@pytest.mark.parametrize(("chunk", "parts"), [(3, None), (8, None), (1, 5), (1, 100)])
def test_map_chunks_keeps_the_order_over_workers(chunk, parts):
    items = list(range(23))
    fn = functools.partial(_affine, a=3, b=-2)
    seen: list[int] = []
    got = map_chunks(fn, items, 2, chunk=chunk, parts=parts, progress=seen.append)
    assert got == [3 * x - 2 for x in items]
    assert sum(seen) == len(items)


def test_map_chunks_in_process_below_four_items_or_one_job():
    seen: list[int] = []
    assert map_chunks(_affine, [5, 6, 7], 2, progress=seen.append) == [5, 6, 7]
    assert map_chunks(_affine, list(range(6)), 1) == list(range(6))
    assert seen == [1, 1, 1]
