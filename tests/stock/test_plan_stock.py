"""A plan with ``[stock]``: the stock is checked against the program and the moves
engaged wider than the job's radial width are named in the plan's notes."""

from __future__ import annotations

import copy
import time
import tomllib
from importlib import resources
from typing import Any

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict
from robolobe.plan.pipeline import plan_path

EX = resources.files("robolobe.data.examples")


def _job(stock: dict[str, Any]) -> Any:
    d = copy.deepcopy(tomllib.loads(EX.joinpath("job_A_pocket.toml").read_text()))
    d["stock"] = stock
    return job_from_dict(d, source="job_A_pocket.toml")


def test_pocket_slot_is_planned_at_its_own_full_engagement() -> None:
    job = _job({"box_min_mm": [-60.0, -40.0, -10.0], "box_max_mm": [60.0, 40.0, 0.0]})
    with resources.as_file(EX.joinpath("pocket.nc")) as p:
        res = plan_path(p, job)
    notes = " ".join(res.summary.notes)
    assert "[stock]: engagement of every move computed on the box x -60..60" in notes
    assert res.summary.engagement == "stock"
    # pocket.nc:12 is the full-width centre slot (the job's cut.radial_width_mm says 0.5):
    # planned at a_e/D 1, 0..180 deg, at the 10 mm the stock holds above the pocket floor
    # (the program cuts at Z-5 in a 10 mm box: 5 mm of it)
    t = res.table
    slot = t[(t["line"] == 12) & (t["motion"] == "cut")]
    assert (slot["ae_over_D"] > 0.999).all()
    assert np.allclose(slot["phi_entry_deg"], 0.0, atol=0.5)
    assert np.allclose(slot["phi_exit_deg"], 180.0, atol=0.5)
    assert np.allclose(slot["program_depth_mm"], 5.0, atol=0.01)
    assert (slot["margin"] >= job.plan.safety_factor * (1 - 1e-9)).all()


def test_a_stock_elsewhere_is_refused_before_planning() -> None:
    job = _job({"box_min_mm": [500.0, 500.0, -10.0], "box_max_mm": [600.0, 600.0, 0.0]})
    t = time.process_time()
    with (
        resources.as_file(EX.joinpath("pocket.nc")) as p,
        pytest.raises(InputError, match=r"job_A_pocket.toml: stock: expected the stock to contain"),
    ):
        plan_path(p, job)
    assert time.process_time() - t < 5.0  # refused before any lobes


@pytest.mark.slow
def test_default_stock_note() -> None:
    job = _job({})
    with resources.as_file(EX.joinpath("pocket.nc")) as p:
        res = plan_path(p, job)
    notes = " ".join(res.summary.notes)
    assert "no [stock] in the job: assumed the box the cutting moves reach" in notes
