"""A plan with ``[stock]``: the stock is checked against the program and the moves
engaged wider than the job's radial width are named in the plan's notes."""

from __future__ import annotations

import copy
import time
import tomllib
from importlib import resources
from typing import Any

import pytest

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict
from robolobe.plan.pipeline import plan_path

EX = resources.files("robolobe.data.examples")


def _job(stock: dict[str, Any]) -> Any:
    d = copy.deepcopy(tomllib.loads(EX.joinpath("job_A_pocket.toml").read_text()))
    d["stock"] = stock
    return job_from_dict(d, source="job_A_pocket.toml")


def test_pocket_slot_is_named_as_engaged_wider_than_planned() -> None:
    job = _job({"box_min_mm": [-60.0, -40.0, -10.0], "box_max_mm": [60.0, 40.0, 0.0]})
    with resources.as_file(EX.joinpath("pocket.nc")) as p:
        res = plan_path(p, job)
    notes = " ".join(res.summary.notes)
    assert "[stock]: engagement of every move computed on the box x -60..60" in notes
    # pocket.nc:12 is the full-width centre slot, planned at a_e/D 0.5 today
    assert "moves engage wider, up to a_e/D 1.00" in notes
    assert "up to a_e/D 1.00 at pocket.nc:12 (first: pocket.nc:12 a_e/D 1.00 (slot)" in notes


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
