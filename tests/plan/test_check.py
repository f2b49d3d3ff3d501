"""``check_program``: every move of a program at its own S, F and engagement.

The synthetic slot is checked against an independent textbook ZOA
(tests/sld/zoa_reference.py) on a modal model whose feed-frame receptance
is known in closed form: one isotropic mode in x and y (the same in every
feed direction and posture) and no tool modes.
"""

from __future__ import annotations

import copy
import json
import math
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError
from robolobe.plan.check import check_program, write_check
from robolobe.plan.job import job_from_dict
from robolobe.plan.modes import ParametersSource
from robolobe.sld.material import get_material
from tests.sld.zoa_reference import alphas, reference_envelope

EX = resources.files("robolobe.data.examples")

# the isotropic mode (x and y, and z which the 2-D cut does not see)
F_HZ, ZETA, K = 900.0, 0.03, 2.0e7

SLOT = """G90 G21 G17
S12000 M3
G0 X-40. Y0. Z5.
G1 Z-2. F300. (plunge beside the stock: air)
G1 X0. F1200. (slot)
S15000
G1 X30. F1500. (slot at another speed)
G1 Z5.
G1 X-40. (air above the stock)
M30
"""


def _job(**stock: Any) -> Any:
    d = copy.deepcopy(tomllib.loads(EX.joinpath("job_A_pocket.toml").read_text()))
    d["tool"].pop("modes")  # the robot's one mode only
    if stock:
        d["stock"] = stock
    return job_from_dict(d, source="slot_job.toml")


def _source() -> ParametersSource:
    shape = (1, 3, 1)
    p = ModalParameters(
        np.full(shape, F_HZ), np.full(shape, ZETA), np.full(shape, K), ("xx", "yy", "zz")
    )
    return ParametersSource(p, "one isotropic mode")


def _reference_mm(rpm: float, entry: float = 0.0, exit_: float = math.pi) -> float:
    mat = get_material("Al7075-T6")
    a = (2 * math.pi * F_HZ) ** 2 / K  # mass-normalised residue 1/m
    val = reference_envelope(
        [F_HZ],
        [ZETA],
        [np.diag([a, a])],
        alphas(entry, exit_, mat.kr),
        teeth=3,
        kt=mat.kt,
        rpm=[rpm],
    )
    return float(val[0]) * 1e3


@pytest.fixture
def slot(tmp_path: Path) -> Path:
    p = tmp_path / "slot.nc"
    p.write_text(SLOT, encoding="utf-8")
    return p


STOCK = {"box_min_mm": [-20.0, -30.0, -10.0], "box_max_mm": [40.0, 30.0, 0.0]}


def test_straight_slot_at_its_own_speeds_matches_the_reference_zoa(slot: Path) -> None:
    res = check_program(slot, _job(**STOCK), source=_source())
    t = res.table.set_index("line")
    for line, rpm, feed in ((5, 12000.0, 1200.0), (7, 15000.0, 1500.0)):
        row = t.loc[line]
        assert row["rpm"] == rpm
        assert row["feed_mm_per_min"] == feed
        assert row["feed_per_tooth_mm"] == pytest.approx(feed / (3 * rpm))
        assert row["ae_over_D"] == pytest.approx(1.0)
        assert (row["phi_entry_deg"], row["phi_exit_deg"]) == pytest.approx((0.0, 180.0), abs=0.2)
        assert row["depth_mm"] == pytest.approx(2.0, abs=1e-6)
        ref = _reference_mm(rpm)
        assert row["a_lim_mm"] == pytest.approx(ref, rel=0.01)
        assert row["margin"] == pytest.approx(row["a_lim_mm"] / 2.0)
        want = "beyond limit" if ref < 2.0 else ("inside SF" if ref < 2.6 else "ok")
        assert row["status"] == want
    # the two speeds give different limits (each move at its own S)
    assert abs(t.loc[5, "a_lim_mm"] - t.loc[7, "a_lim_mm"]) > 0.01 * t.loc[5, "a_lim_mm"]


def test_air_moves_have_no_limit(slot: Path) -> None:
    res = check_program(slot, _job(**STOCK), source=_source())
    t = res.table.set_index("line")
    for line in (4, 8, 9):  # beside the stock, the retract out of the cut slot, above
        assert t.loc[line, "status"] == "air"
        assert np.isnan(t.loc[line, "a_lim_mm"])
        assert np.isnan(t.loc[line, "margin"])
        assert t.loc[line, "depth_mm"] == 0.0
    assert res.summary["counts"]["air"] == 3
    # the bounded moves alone decide the minimum margin and the exit
    assert res.min_margin_at in ("slot.nc:5", "slot.nc:7")
    assert res.ok == (res.n_beyond == 0)


def test_without_stock_the_default_stock_is_used_and_said(slot: Path) -> None:
    res = check_program(slot, _job(), source=_source())
    assert res.summary["stock_given"] is False
    assert any("no [stock] in the job" in n for n in res.notes)
    assert "out_of_range" in res.summary  # vc, chip load and path speed are judged (test_limits)


def test_missing_spindle_speed_is_refused_with_file_line(tmp_path: Path) -> None:
    p = tmp_path / "nos.nc"
    p.write_text("G90 G21\nG0 X-40. Y0. Z5.\nG1 Z-2. F300.\nG1 X30. F1200.\nM30\n")
    with pytest.raises(InputError, match=r"nos\.nc:4: expected a positive spindle speed S"):
        check_program(p, _job(**STOCK), source=_source())
    res = check_program(p, _job(**STOCK), source=_source(), rpm=12000.0)
    row = res.table.set_index("line").loc[4]
    assert row["rpm"] == 12000.0
    assert row["a_lim_mm"] == pytest.approx(_reference_mm(12000.0), rel=0.01)


def test_write_check_refuses_a_foreign_file_and_writes_the_set(slot: Path, tmp_path: Path) -> None:
    res = check_program(slot, _job(**STOCK), source=_source())
    out = tmp_path / "out"
    out.mkdir()
    (out / "check.csv").write_text("mine\n")
    with pytest.raises(InputError, match=r"check\.csv"):
        write_check(res, out, plots=False)
    assert (out / "check.csv").read_text() == "mine\n"
    out2 = tmp_path / "out2"
    write_check(res, out2)
    for name in ("check.csv", "check.json", "check_margin.png", "check_report.html"):
        assert (out2 / name).is_file(), name
    s = json.loads((out2 / "check.json").read_text())
    assert s["n_beyond_limit"] == res.n_beyond
    assert s["beyond_limit_at"] == list(res.beyond)
    write_check(res, out2)  # a re-run replaces its own set


def test_user_text_is_escaped_in_the_report(tmp_path: Path) -> None:
    p = tmp_path / "<b>x.nc"
    p.write_text(SLOT, encoding="utf-8")
    res = check_program(p, _job(**STOCK), source=_source())
    write_check(res, tmp_path / "o", plots=False)
    html = (tmp_path / "o" / "check_report.html").read_text()
    assert "<b>x" not in html
    assert "&lt;b&gt;x" in html


@pytest.fixture(scope="module")
def pocket() -> Any:
    with (
        resources.as_file(EX.joinpath("pocket.nc")) as p,
        resources.as_file(EX.joinpath("job_A_pocket.toml")) as j,
    ):
        return check_program(p, j)


def test_bundled_pocket_first_move_is_a_full_slot_at_its_own_speed(pocket: Any) -> None:
    t = pocket.table
    row = t[t["line"] == 12].iloc[0]  # N45 X20. F5400. (CENTRE SLOT), 20 mm 3-flute cutter
    assert row["ae_over_D"] == pytest.approx(1.0, abs=1e-3)
    assert (row["phi_entry_deg"], row["phi_exit_deg"]) == pytest.approx((0.0, 180.0), abs=0.2)
    assert row["depth_mm"] == pytest.approx(5.0, abs=1e-6)  # ZMIN=-5. from the default stock
    assert row["rpm"] == 18000
    assert row["feed_per_tooth_mm"] == pytest.approx(0.1)
    assert row["margin"] == pytest.approx(row["a_lim_mm"] / 5.0)
    m = row["margin"]
    assert row["status"] == ("beyond limit" if m < 1 else "inside SF" if m < 1.3 else "ok")
    # the pocket as written has moves beyond their limit (exit 4), each named
    assert pocket.n_beyond > 0
    assert not pocket.ok
    assert pocket.min_margin < 1.0
    assert all(s.startswith("pocket.nc:") for s in pocket.beyond)
    assert pocket.summary["counts"]["plunge"] == 1  # N40 Z-5. (no lateral limit)


def test_pocket_slot_at_the_plans_speed_is_the_engagement_studys_limit(tmp_path: Path) -> None:
    # issue 26: re-planned at immersion 1 at the default plan's speed (~22,514 rpm) the
    # slot's limit is 1.45 mm, a margin of about 0.5 against the plan's 2.879 mm
    text = EX.joinpath("pocket.nc").read_text().replace("S18000", "S22514")
    p = tmp_path / "pocket.nc"
    p.write_text(text)
    with resources.as_file(EX.joinpath("job_A_pocket.toml")) as j:
        res = check_program(p, j)
    row = res.table[res.table["line"] == 12].iloc[0]
    assert row["a_lim_mm"] == pytest.approx(1.45, rel=0.02)
    assert row["a_lim_mm"] / 2.879 == pytest.approx(0.5, abs=0.02)
    assert row["status"] == "beyond limit"
    assert "pocket.nc:12" in res.beyond
