"""Posture design: feasibility, coverage, augmentation of a one-sided set."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.robots.limits import within_limits
from robolobe.tl.design import coverage, design_box_deg, design_postures, feasible_postures
from robolobe.twin.designs import TESTED_RANGES_DEG, design_arrays, seed_design


@pytest.fixture(scope="module")
def robot_c():
    return load_robot("C")


@pytest.mark.slow
def test_designed_postures_are_feasible_and_cover_better_than_random(robot_c):
    box = design_box_deg(robot_c, TESTED_RANGES_DEG["C"])
    d = design_postures(
        robot_c, 20, rng=np.random.default_rng(0), ranges_deg=TESTED_RANGES_DEG["C"]
    )
    assert d.q_rad.shape == (20, 6)
    assert np.all(within_limits(robot_c, d.q_rad))
    deg = np.degrees(d.q_rad)
    assert np.all((deg >= box[:, 0] - 1e-9) & (deg <= box[:, 1] + 1e-9))
    ref = feasible_postures(robot_c, 2000, np.random.default_rng(99), box_deg=box)
    rand = feasible_postures(robot_c, 20, np.random.default_rng(1), box_deg=box)
    assert coverage(d.q_rad, ref, box).mean_distance < coverage(rand, ref, box).mean_distance
    # and better than the paper's own 24 postures of robot C
    _ids, q, roles = design_arrays(seed_design("C"))
    paper24 = q[np.isin(np.asarray(roles), ["train", "added"])]
    assert (
        coverage(d.q_rad, ref, box).covered_fraction > coverage(paper24, ref, box).covered_fraction
    )


@pytest.mark.slow
def test_augmenting_a_one_sided_set_fills_the_other_side(robot_c):
    _ids, q, roles = design_arrays(seed_design("C"))
    one_sided = q[np.asarray(roles) == "train"]
    assert np.all(np.degrees(one_sided[:, 0]) <= 0.0)
    d = design_postures(
        robot_c,
        4,
        rng=np.random.default_rng(0),
        existing_rad=one_sided,
        ranges_deg=TESTED_RANGES_DEG["C"],
    )
    assert np.sum(np.degrees(d.q_rad[:, 0]) > 0) >= 3  # the gap is q1 > 0
    assert d.coverage_before is not None
    assert d.coverage.mean_distance < d.coverage_before.mean_distance


def test_bad_requests(robot_c):
    with pytest.raises(InputError, match="at least one"):
        design_postures(robot_c, 0, rng=np.random.default_rng(0))
    with pytest.raises(InputError, match="needs a fitted model"):
        design_postures(robot_c, 3, rng=np.random.default_rng(0), criterion="spread")


@pytest.mark.slow
def test_spread_criterion_uses_the_model(robot_c):
    from robolobe.tl.models import load_model

    model = load_model("C")
    kw = {"rng": np.random.default_rng(3), "ranges_deg": TESTED_RANGES_DEG["C"]}
    by_cov = design_postures(robot_c, 5, **kw)
    kw["rng"] = np.random.default_rng(3)
    by_spread = design_postures(robot_c, 5, criterion="spread", model=model, **kw)
    assert by_spread.q_rad.shape == (5, 6)
    assert not np.allclose(by_cov.q_rad, by_spread.q_rad)
    # the picks sit where the model is less sure than at the coverage picks
    sd = lambda q: np.mean(model.predict(q, warn=False).std)  # noqa: E731
    assert sd(by_spread.q_rad) > sd(by_cov.q_rad)
