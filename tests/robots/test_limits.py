"""Joint limits, constraints, seed postures, sampling."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.robots.limits import (
    check_posture,
    posture_violations,
    sample_postures,
    within_limits,
)

# Seed paper (REFERENCES.md section 1): real tested postures, deg
SEED_B_TABLE3 = [
    (-2, 21, -27, 5, 1, -29),
    (-60, 50, -120, 115, -66, -197),
    (23, -28, -101, -82, 124, 168),
    (59, 51, -83, 180, 112, 7),
    (30, 30, -102, -145, 106, -11),
]
SEED_C_TABLES_5_6 = [
    (12, 26, 9, 50, -116, -286),
    (23, 6, -21, -117, -26, -37),
    (32, 36, 35, 143, 46, -18),
    (38, 5, 11, -92, 114, 152),
    (39, 8, 8, 98, -18, -30),
    (47, -10, 36, 74, -89, -13),
    (-3, 48, 20, -129, -57, -2),
    (-2, 20, -21, -167, -66, 180),
    (-6, -6, 36, 83, 100, 29),
]
# Seed Table 2: tested ranges, deg
SEED_RANGES = {
    "A": [(-50, 50), (-90, -50), (70, 150), (-300, 300), (-90, 90), (-300, 300)],
    "B": [(-60, 87), (-28, 56), (-127, -16), (-158, 232), (-93, 124), (-283, 201)],
    "C": [(-59, 47), (-10, 48), (-30, 79), (-184, 190), (-116, 114), (-360, 296)],
}


@pytest.mark.parametrize(("name", "postures"), [("B", SEED_B_TABLE3), ("C", SEED_C_TABLES_5_6)])
def test_seed_postures_are_valid(name: str, postures) -> None:
    r = load_robot(name)
    q = np.radians(postures)
    assert within_limits(r, q).all()
    for i, p in enumerate(q):
        check_posture(r, p, posture_id=i + 1)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_seed_tested_ranges_inside_joint_limits(name: str) -> None:
    r = load_robot(name)
    ranges = np.radians(SEED_RANGES[name])
    assert np.all(ranges[:, 0] >= r.q_min - 1e-12)
    assert np.all(ranges[:, 1] <= r.q_max + 1e-12)


def test_seed_range_a_box_is_valid() -> None:
    # A has no constraints: every posture of its tested box is valid (corners included)
    r = load_robot("A")
    ranges = np.radians(SEED_RANGES["A"])
    corners = np.stack(np.meshgrid(*ranges, indexing="ij"), -1).reshape(-1, 6)
    assert within_limits(r, corners).all()


def test_check_posture_message() -> None:
    r = load_robot("A")
    q = np.radians([0, -90, 170, 0, 0, 0])
    with pytest.raises(InputError) as info:
        check_posture(r, q, posture_id="p05", source="postures.csv:7")
    assert str(info.value).startswith(
        "postures.csv:7: posture 'p05': q3_deg = 170.0 outside [-120, 168]"
    )


def test_constraint_violation_message() -> None:
    c = load_robot("C")
    q = np.radians([0, -10, 79, 0, 0, 0])  # q3 - q2 = 89 > 85
    assert not within_limits(c, q)
    with pytest.raises(InputError, match=r"constraint 1: -q2_deg \+ q3_deg = 89.0 outside"):
        check_posture(c, q, posture_id=3)
    b = load_robot("B")
    msgs = posture_violations(b, np.radians([0, 21, 5, 0, 0, 999]))
    assert len(msgs) == 3  # q3 > -10, q6 > 720, q2 + q3 > -2
    assert any(m.startswith("q6_deg = 999.0") for m in msgs)


def test_within_limits_vectorized(rng: np.random.Generator) -> None:
    r = load_robot("B")
    q = rng.uniform(-4, 4, (3, 50, 6))
    ok = within_limits(r, q)
    assert ok.shape == (3, 50)
    ref = np.array([[not posture_violations(r, p) for p in row] for row in q])
    np.testing.assert_array_equal(ok, ref)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_sample_postures(name: str, rng: np.random.Generator) -> None:
    r = load_robot(name)
    q = sample_postures(r, 400, rng, SEED_RANGES[name])
    assert q.shape == (400, 6)
    assert within_limits(r, q).all()
    ranges = np.radians(SEED_RANGES[name])
    assert np.all(q >= ranges[:, 0])
    assert np.all(q <= ranges[:, 1])
    # uniform: joint 1 mean near the range centre (4 sigma)
    mid, width = ranges[0].mean(), np.ptp(ranges[0])
    assert abs(q[:, 0].mean() - mid) < 4 * width / np.sqrt(12 * 400)


def test_sample_postures_errors(rng: np.random.Generator) -> None:
    r = load_robot("A")
    with pytest.raises(InputError, match="does not overlap"):
        sample_postures(r, 5, rng, [(0, 10)] * 6)
    b = load_robot("B")
    with pytest.raises(InputError, match="too little"):
        # q2 + q3 >= 60 - 16 > -2 everywhere: the constraint removes the whole box
        sample_postures(b, 5, rng, [(-10, 10), (60, 70), (-16, -10), (0, 1), (0, 1), (0, 1)],
                        max_batches=3)  # fmt: skip


@pytest.mark.parametrize(("name", "postures"), [("B", SEED_B_TABLE3), ("C", SEED_C_TABLES_5_6)])
def test_seed_postures_round_trip_through_ik(name: str, postures) -> None:
    from robolobe.robots import nearest, tcp_pose

    r = load_robot(name)
    for q in np.radians(postures):
        np.testing.assert_allclose(nearest(r, tcp_pose(r, q), q), q, atol=1e-8)


def test_as_postures_is_the_one_posture_array_validator() -> None:
    import numpy as np
    import pytest

    from robolobe.errors import InputError
    from robolobe.robots.limits import as_postures

    assert as_postures(np.zeros(6)).shape == (1, 6)
    assert as_postures([[0.1] * 6, [0.2] * 6]).shape == (2, 6)
    with pytest.raises(InputError, match=r"q_rad: .*shape \(n, 6\).*found shape \(2, 5\)"):
        as_postures(np.zeros((2, 5)))
    with pytest.raises(InputError, match="posture 1"):
        as_postures([[0.0] * 6, [0.0, np.nan, 0, 0, 0, 0]])
    with pytest.raises(InputError, match=r"q_samples: .*n >= 1"):
        as_postures(np.zeros((0, 6)), "q_samples")
    with pytest.raises(InputError, match="non-numbers"):
        as_postures([["a"] * 6])
