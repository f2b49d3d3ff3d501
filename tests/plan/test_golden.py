"""Golden headline numbers of the bundled example plans (regression guard).

What ``robolobe plan`` gives on the bundled jobs today (robot twins as mode
source, default settings), with tolerances: a change that moves a depth,
speed, removal rate or cycle time by more than a few percent, changes the
path's geometry or lets a waypoint below its safety factor must be
explained (and this table updated with the reason in the commit). Values
from robolobe 0.1.0 (recorded 2026-11-23).
"""

from __future__ import annotations

from importlib import resources

import pytest

import robolobe as rl

EXAMPLES = resources.files("robolobe.data").joinpath("examples")

#: job, path, n_waypoints, n_cut, cut length [m], depth [mm], rpm min, rpm max,
#: MRR [cm^3/min], cycle time [s], safety factor, passes of the deepest section
GOLDEN = [
    # issue 26: each move at its own engagement on the stock (default stock; the contour
    # job's raw plate), the program's own depth in passes, the program's chip load, the
    # material table's vc range, the passes planned with the lobes' 0.5 % tolerance as
    # headroom (before, one width and a free depth: pocket 2.6034 mm at
    # 24,000 rpm, contour 2.0369 mm, face 1.6142 mm at 7,202.8 rpm, slot 1.0692 mm at
    # 12,000 rpm, face in Ti 0.1145 mm at 2,500 rpm)
    (
        "job_A_pocket",
        "pocket.nc",
        168,
        165,
        0.7859,
        1.6667,
        20665.4,
        20665.4,
        162.036,
        24.973,
        1.3,
        3,
    ),
    ("job_B_contour", "contour.apt", 75, 72, 0.7158, 2.0, 24000.0, 24000.0, 42.162, 26.324, 1.3, 4),
    ("job_C_face_steel", "face.mod", 24, 23, 2.4315, 0.3, 3740.9, 3740.9, 5.399, 812.474, 1.5, 5),
    (
        "job_C_face_ti_lowspeed",
        "face.mod",
        24,
        23,
        2.4315,
        0.0208,
        1527.9,
        1527.9,
        0.204,
        21484.076,
        1.5,
        # 71 since material thinner than the one-height tolerance (10 um) counts as air
        71,
    ),
    ("job_A_slot_steel", "slot.src", 46, 44, 0.4515, 0.5, 5968.3, 5968.3, 8.638, 136.309, 1.5, 6),
]
#: relative tolerance of depth, speed, MRR and cycle time (the optimizer's
#: refinement and lobe sharing may move them a little; the geometry may not)
REL = 0.03


def _check(row: tuple) -> None:
    job_name, path, n_wp, n_cut, length, depth, rpm_lo, rpm_hi, mrr, cycle, sf, passes = row
    job = rl.load_job(EXAMPLES.joinpath(f"{job_name}.toml"))
    s = rl.plan_path(EXAMPLES.joinpath(path), job).summary.to_dict()  # summary.json
    assert (s["n_waypoints"], s["n_cut"]) == (n_wp, n_cut)
    assert s["cut_length_m"] == pytest.approx(length, rel=1e-3)
    assert s["safety_factor"] == sf
    assert s["min_margin"] >= sf * (1 - 1e-6)
    assert s["depth_mm"] == pytest.approx(depth, rel=REL)
    assert s["rpm_min"] == pytest.approx(rpm_lo, rel=REL)
    assert s["rpm_max"] == pytest.approx(rpm_hi, rel=REL)
    assert s["mrr_cm3_per_min"] == pytest.approx(mrr, rel=REL)
    assert s["cycle_time_s"] == pytest.approx(cycle, rel=REL)
    assert max(r["passes"] for r in s["passes"]) == passes


def test_bundled_pocket_headline_numbers() -> None:
    _check(GOLDEN[0])


@pytest.mark.slow
@pytest.mark.parametrize("row", GOLDEN[1:], ids=[r[0] for r in GOLDEN[1:]])
def test_bundled_jobs_headline_numbers(row: tuple) -> None:
    _check(row)
