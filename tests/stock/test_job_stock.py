"""The job's ``[stock]`` section: parsed, written back, and refused with the key named."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources
from typing import Any

import pytest

from robolobe.errors import InputError
from robolobe.plan.job import job_from_dict, job_to_toml


def _base() -> dict[str, Any]:
    text = resources.files("robolobe.data.examples").joinpath("job_A_pocket.toml").read_text()
    return tomllib.loads(text)


def _job(stock: dict[str, Any] | None, **tool: Any) -> Any:
    d = copy.deepcopy(_base())
    if stock is not None:
        d["stock"] = stock
    d["tool"].update(tool)
    return job_from_dict(d, source="job.toml")


def test_box_and_outline_read_and_write_back() -> None:
    j = _job({"box_min_mm": [-60.0, -40.0, -10.0], "box_max_mm": [60.0, 40.0, 0.0]})
    assert j.stock is not None
    assert j.stock.shape is not None
    assert j.stock.shape.bounds() == pytest.approx((-0.06, -0.04, 0.06, 0.04))
    assert (j.stock.shape.z_bottom, j.stock.shape.z_top) == pytest.approx((-0.01, 0.0))
    back = job_from_dict(tomllib.loads(job_to_toml(j)), source="x")
    assert back.stock is not None
    assert back.stock.shape is not None
    assert back.stock.shape.describe() == j.stock.shape.describe()

    j = _job(
        {
            "outline_mm": [[0.0, 0.0], [100.0, 0.0], [100.0, 50.0], [0.0, 50.0]],
            "z_range_mm": [-8.0, 0.0],
            "resolution_mm": 0.25,
        }
    )
    assert j.stock is not None
    assert j.stock.resolution_m == pytest.approx(2.5e-4)
    assert j.stock.shape is not None
    assert j.stock.shape.area_m2 == pytest.approx(0.005)
    back = job_from_dict(tomllib.loads(job_to_toml(j)), source="x")
    assert back.stock is not None
    assert back.stock.resolution_m == pytest.approx(2.5e-4)


def test_no_section_and_an_empty_section() -> None:
    assert _job(None).stock is None
    j = _job({})
    assert j.stock is not None
    assert j.stock.shape is None  # the default stock, derived from the program


@pytest.mark.parametrize(
    ("stock", "tool", "message"),
    [
        (
            {"box_min_mm": [-60.0, -40.0, -10.0], "box_max_mm": [60.0, -50.0, 0.0]},
            {},
            "stock.box_min_mm: box: expected min < max",
        ),
        (
            {"box_min_mm": [-60.0, -40.0, -10.0]},
            {},
            "stock: expected both box_min_mm and box_max_mm",
        ),
        (
            {"outline_mm": [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]], "z_range_mm": [5.0, 0.0]},
            {},
            r"stock.z_range_mm: expected \[bottom, top\] with bottom < top",
        ),
        ({"mesh": "part.stl"}, {}, "stock.mesh: .* mesh stocks \\(STL\\) are not supported"),
        (
            {"resolution_mm": 3.0},
            {},
            "stock.resolution_mm: expected at most the tool diameter / 10 = 2 mm",
        ),
        ({}, {"corner_radius_mm": 10.0}, "tool.corner_radius_mm: .* flat end mills only.*ball-end"),
        ({}, {"corner_radius_mm": 2.0}, "tool.corner_radius_mm: .*bull-nose"),
        (
            {"box_min_mm": [0.0, 0.0, 0.0], "box_max_mm": [1.0, 1.0, 1.0], "resolutoin_mm": 1.0},
            {},
            "unknown key stock.resolutoin_mm; did you mean 'resolution_mm'",
        ),
    ],
)
def test_bad_stock_is_refused_naming_the_key(
    stock: dict[str, Any], tool: dict[str, Any], message: str
) -> None:
    with pytest.raises(InputError, match=f"job.toml: {message}"):
        _job(stock, **tool)
