"""Posture designs that mirror the seed paper (REFERENCES.md section 1)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.robots.limits import within_limits
from robolobe.twin.designs import (
    B_TEST_DEG,
    C_ADDED_DEG,
    C_TEST_DEG,
    DESIGN_COLUMNS,
    TESTED_RANGES_DEG,
    design_arrays,
    load_seed_design,
    random_design,
    seed_design,
    space_filling_design,
)

Q_COLS = [f"q{i}_deg" for i in range(1, 7)]


def _q(df: pd.DataFrame) -> np.ndarray:
    return df[Q_COLS].to_numpy(dtype=float)


@pytest.mark.parametrize("key", ["A", "B", "C"])
def test_seed_design_valid_and_within_tested_ranges(key):
    d = seed_design(key)
    assert list(d.columns) == list(DESIGN_COLUMNS)
    assert d["posture_id"].is_unique
    robot = load_robot(key)
    assert within_limits(robot, np.radians(_q(d))).all()
    train = _q(d[d["role"] == "train"])
    lo, hi = np.array(TESTED_RANGES_DEG[key]).T
    assert np.all(train >= lo - 1e-9)
    assert np.all(train <= hi + 1e-9)
    # Whole degrees, like the paper's postures.
    np.testing.assert_array_equal(train, np.round(train))


def test_seed_design_sizes_and_paper_postures():
    a, b, c = seed_design("A"), seed_design("B"), seed_design("C")
    assert len(a) == 254
    assert set(a["role"]) == {"train"}
    assert b["role"].value_counts().to_dict() == {"train": 20, "test": 5}
    np.testing.assert_array_equal(_q(b[b["role"] == "test"]), np.array(B_TEST_DEG, float))
    assert list(b["posture_id"].iloc[-5:]) == ["T1", "T2", "T3", "T4", "T5"]
    assert c["role"].value_counts().to_dict() == {"train": 20, "test": 5, "added": 4}
    np.testing.assert_array_equal(_q(c[c["role"] == "added"]), np.array(C_ADDED_DEG, float))
    np.testing.assert_array_equal(_q(c[c["role"] == "test"]), np.array(C_TEST_DEG, float))
    assert list(c.loc[c["role"] == "added", "posture_id"]) == ["P21", "P22", "P23", "P24"]


def test_c_training_is_one_sided_and_added_fix_it():
    c = seed_design("C")
    q1_train = _q(c[c["role"] == "train"])[:, 0]
    q1_added = _q(c[c["role"] == "added"])[:, 0]
    assert np.all(q1_train <= 0)  # the paper's "left side"
    assert np.all(q1_added > 0)  # Table 5: the other side


def test_a_is_space_filling():
    q = _q(seed_design("A"))
    lo, hi = np.array(TESTED_RANGES_DEG["A"]).T
    u = (q - lo) / (hi - lo)
    # Every tenth of every tested range is visited (a low-discrepancy design; 254
    # uniform-random points miss a bin with probability < 1e-10 per joint anyway,
    # so also check the spread is even: no bin holds more than twice its share).
    counts = np.stack([np.histogram(u[:, j], bins=10, range=(0, 1))[0] for j in range(6)])
    assert counts.min() > 0
    assert counts.max() < 2 * 254 / 10
    # No two postures closer than 2 % of the range diagonal (normalized).
    diff = u[:, None, :] - u[None, :, :]
    dist = np.sqrt((diff**2).sum(-1)) + np.eye(len(u)) * 10
    assert dist.min() > 0.02 * np.sqrt(6)


def test_reproducible_and_seed_dependent():
    b1 = seed_design("B", np.random.default_rng(1))
    b2 = seed_design("B", np.random.default_rng(1))
    b3 = seed_design("B", np.random.default_rng(2))
    pd.testing.assert_frame_equal(b1, b2)
    assert not np.array_equal(_q(b1)[:20], _q(b3)[:20])
    np.testing.assert_array_equal(_q(b1)[20:], _q(b3)[20:])  # the paper's test postures


@pytest.mark.parametrize("key", ["A", "B", "C"])
def test_shipped_design_is_current(key):
    # If this fails after a robot file changed its limits, regenerate with
    # `python -m robolobe.twin.designs src/robolobe/data/designs`.
    pd.testing.assert_frame_equal(load_seed_design(key), seed_design(key))


def test_design_is_a_postures_csv(tmp_path):
    from robolobe.campaign import read_postures

    d = seed_design("B")
    d.to_csv(tmp_path / "postures.csv", index=False)
    ids, q = read_postures(tmp_path / "postures.csv", robot=load_robot("B"))
    ids2, q2, roles = design_arrays(d)
    assert ids == ids2
    np.testing.assert_allclose(q, q2, rtol=1e-15)
    assert roles.count("test") == 5


def test_random_and_space_filling_on_any_robot():
    robot = load_robot("C")
    r = random_design(robot, 12, np.random.default_rng(0))
    assert len(r) == 12
    assert within_limits(robot, np.radians(_q(r))).all()
    s = space_filling_design(robot, 7, np.random.default_rng(0), id_prefix="S", round_deg=None)
    assert list(s["posture_id"]) == [f"S{i:02d}" for i in range(1, 8)]
    assert within_limits(robot, np.radians(_q(s))).all()
    assert not np.array_equal(_q(s), np.round(_q(s)))


def test_bad_requests():
    robot = load_robot("B")
    with pytest.raises(InputError, match="outside the joint limits"):
        space_filling_design(robot, 3, np.random.default_rng(0), ranges_deg=[(500, 600)] * 6)
    with pytest.raises(InputError, match="robot A, B or C"):
        seed_design("D")
    with pytest.raises(InputError, match="n >= 1"):
        space_filling_design(robot, 0, np.random.default_rng(0))
