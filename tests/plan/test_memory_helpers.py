"""The memory savings of long paths change no result: each against a plain reference."""

from __future__ import annotations

import hashlib
import weakref

import numpy as np
import pandas as pd
import pytest

from robolobe._memory import RELEASE_MIN_ROWS, release_free_memory
from robolobe.plan.job import load_job
from robolobe.plan.paths._table import feed_directions, label_column, segment_lengths
from robolobe.plan.pipeline import _hash_joined, _shared_labels, plan_path, waypoints_hash
from robolobe.plan.program import _labels

from .conftest import example


def _directions_reference(pos: np.ndarray) -> np.ndarray:
    """Unit move directions, rows without one back- then forward-filled (pandas)."""
    n = len(pos)
    out = np.full((n, 3), np.nan)
    for i in range(1, n):
        d = pos[i] - pos[i - 1]
        ln = float(np.sqrt(d @ d))
        if ln > 1e-12:
            out[i] = d / ln
    return pd.DataFrame(out).bfill().ffill().to_numpy()


def test_feed_directions_match_a_filled_reference() -> None:
    rng = np.random.default_rng(7)
    for _ in range(300):
        n = int(rng.integers(0, 14))
        # coarse integer positions: many zero-length moves, at the start, the end, in runs
        pos = rng.integers(0, 2, (n, 3)).astype(float) * rng.choice([0.0, 1.0], (n, 1))
        got = feed_directions(pos)
        ref = _directions_reference(pos) if n >= 2 else np.full((n, 3), np.nan)
        assert got.shape == (n, 3)
        np.testing.assert_array_equal(got, ref)


def test_a_path_that_never_moves_has_no_direction() -> None:
    assert np.all(np.isnan(feed_directions(np.zeros((5, 3)))))


def test_segment_lengths_column_by_column_are_the_norms_to_the_bit() -> None:
    """Positions, a table's columns or some rows only: np.linalg.norm of each move."""
    rng = np.random.default_rng(5)
    for scale in (1e-6, 1.0, 1e3):
        pos = rng.normal(size=(2000, 3)) * scale
        pos[7] = pos[6]  # a move of length 0
        ref = np.zeros(len(pos))
        ref[1:] = np.linalg.norm(np.diff(pos, axis=0), axis=1)
        table = pd.DataFrame(pos, columns=["x_m", "y_m", "z_m"])
        rows = np.r_[0, np.sort(rng.choice(np.arange(1, len(pos)), 300, replace=False))]
        np.testing.assert_array_equal(segment_lengths(pos), ref)
        np.testing.assert_array_equal(segment_lengths(table), ref)
        np.testing.assert_array_equal(segment_lengths(table, rows), ref[rows])
    assert segment_lengths(np.zeros((1, 3))).tolist() == [0.0]


@pytest.mark.parametrize("block", [1, 3, 7, 1000])
def test_hash_in_blocks_is_the_hash_of_the_joined_column(block: int) -> None:
    col = pd.Series(["a.nc", "b.nc", "a.nc", "long name.nc", "c", "", "d"] * 3, dtype="str")
    one = hashlib.sha256("\n".join(col.tolist()).encode()).hexdigest()
    h = hashlib.sha256()
    _hash_joined(h, col, block=block)
    assert h.hexdigest() == one


def test_waypoints_hash_as_written_in_one_piece() -> None:
    n = 70_000  # more than one block
    rng = np.random.default_rng(3)
    t = pd.DataFrame(
        {
            "source": pd.Series(np.where(rng.random(n) < 0.5, "p.nc", "q.nc"), dtype="str"),
            "line": np.arange(n) + 10,
            "x_mm": rng.normal(size=n),
            "y_mm": rng.normal(size=n),
            "z_mm": rng.normal(size=n),
            "motion": pd.Series(np.where(rng.random(n) < 0.1, "rapid", "cut"), dtype="str"),
        }
    )
    h = hashlib.sha256()
    h.update("\n".join(map(str, t["source"].tolist())).encode())
    h.update(np.asarray(t["line"], dtype=np.int64).tobytes())
    h.update((np.round(t[["x_mm", "y_mm", "z_mm"]].to_numpy(), 6) + 0.0).tobytes())
    h.update("\n".join(map(str, t["motion"].tolist())).encode())
    assert waypoints_hash(t) == h.hexdigest()


def test_shared_labels_same_values_one_object_per_label() -> None:
    rng = np.random.default_rng(5)
    names = np.array(["stability", "power", "rpm_max", "schedule", "plunge"])
    lab = names[rng.integers(0, names.size, 5000)]
    got = _shared_labels(lab)
    assert got.dtype == object
    assert got.tolist() == lab.astype(object).tolist()
    assert all(type(v) is str for v in got)
    assert len({id(v) for v in got}) == len(set(lab.tolist()))
    assert _shared_labels(np.array([], dtype="<U3")).shape == (0,)


def test_check_labels_same_values() -> None:
    col = pd.Series(["cut", "rapid", "cut", None, "cut"], dtype="str")
    got = _labels(col)
    ref = col.to_numpy()
    assert got.dtype == object
    assert [str(v) for v in got] == [str(v) for v in ref]
    assert np.array_equal(got != ref, col.to_numpy() != ref)


def test_release_free_memory_small_jobs_untouched() -> None:
    assert release_free_memory(RELEASE_MIN_ROWS - 1) is False
    assert isinstance(release_free_memory(), bool)


@pytest.mark.parametrize("names", [("cut", "rapid"), ("a.nc",), ("", "x", "long label")])
def test_label_column_as_pandas_makes_it(names: tuple[str, ...]) -> None:
    rng = np.random.default_rng(11)
    codes = rng.integers(0, len(names), 500).astype(np.int8)
    got = pd.DataFrame({"c": label_column(codes, names)}, copy=False)["c"]
    ref = pd.DataFrame({"c": np.asarray(names)[codes]})["c"]  # written independently
    assert got.dtype == ref.dtype
    assert got.tolist() == ref.tolist()
    assert label_column(np.zeros(0, np.int8), names).shape == (0,)


class _Handed(Exception):
    """Raised by the spy below once it knows whether the caller kept the features."""


def test_streamed_lobes_hand_the_features_over(monkeypatch: pytest.MonkeyPatch) -> None:
    """The caller keeps no reference to the grouping features it gives waypoint_lobes,
    which drops them after grouping (not held through the leaders' lobes: at a million
    waypoints 600 MB, the lobe stage's peak, when a ``**`` call kept them)."""
    from robolobe.plan import pipeline

    path = example("pocket.nc")
    job = load_job(example("job_A_pocket.toml")).replace(model="twin")
    monkeypatch.setattr(pipeline, "_STREAM_MIN", 40)
    monkeypatch.setattr(pipeline, "_STREAM_CHUNK", 30)
    kept: list[bool] = []

    def spy(models, **kw):  # type: ignore[no-untyped-def]
        feats = kw.pop("features")
        assert isinstance(feats, np.ndarray)
        assert feats.shape[0] > 40
        ref = weakref.ref(feats)
        del feats
        kept.append(ref() is not None)
        raise _Handed

    monkeypatch.setattr(pipeline, "waypoint_lobes", spy)
    with pytest.raises(_Handed):
        plan_path(path, job)
    assert kept == [False]


@pytest.mark.parametrize(("block", "per_release"), [(1, 1), (7, 2), (64, 4)])
def test_reader_blocks_make_the_table_of_the_program(
    block: int, per_release: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A program read in blocks of a few waypoints: every row as the program states it."""
    from robolobe.plan.paths import _table
    from robolobe.plan.paths.gcode import parse_gcode

    rng = np.random.default_rng(block)
    n = 300
    xyz = np.round(rng.uniform(-200.0, 200.0, (n, 3)), 3)
    rapid = rng.random(n) < 0.2
    text = ["%", "G90 G21 G17", "S12000 M3"]
    for (x, y, z), r in zip(xyz, rapid, strict=True):
        text.append(f"{'G0' if r else 'G1'} X{x:.3f} Y{y:.3f} Z{z:.3f}" + ("" if r else " F900."))
    text += ["M30", "%"]
    program = "\n".join(text) + "\n"
    whole = parse_gcode(program, "p.nc")  # one block: the table as before blocks
    monkeypatch.setattr(_table, "_BLOCK_ROWS", block)
    monkeypatch.setattr(_table, "_BLOCKS_PER_RELEASE", per_release)
    got = parse_gcode(program, "p.nc")
    assert len(got) == n
    np.testing.assert_array_equal(got[["x_m", "y_m", "z_m"]].to_numpy(), xyz * 1e-3)
    assert got["line"].tolist() == list(range(4, 4 + n))
    assert (got["motion"] == "rapid").tolist() == rapid.tolist()
    f = got["feed_mm_per_min"].to_numpy()
    assert np.all(f[~rapid] == 900.0)
    pd.testing.assert_frame_equal(got, whole)
