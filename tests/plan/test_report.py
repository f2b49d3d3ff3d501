"""Plan outputs: files, contents, self-contained HTML, atomic writes."""

from __future__ import annotations

import base64
import json
import re

import pandas as pd
import pytest

from robolobe.plan import report
from robolobe.plan.job import load_job
from robolobe.plan.pipeline import plan_path

from .conftest import example


@pytest.fixture(scope="module")
def result():
    job = load_job(example("job_B_contour.toml")).replace(model="twin")
    return plan_path(example("contour.apt"), job, refine=False)


def test_write_outputs(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "out")
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file())
    assert files == [
        "plots/lobes.png", "plots/path_margin.png", "plots/speed_map.png", "plots/speed_power.png",
        "report.html", "summary.json", "waypoints.csv",
    ]  # fmt: skip
    table = pd.read_csv(out / "waypoints.csv")
    assert len(table) == len(result.table)
    for col in (
        "q1_deg",
        "f1_x_hz",
        "a_lim_mm",
        "rpm",
        "depth_mm",
        "margin",
        "limiting",
        "power_kW",
    ):
        assert col in table.columns
    s = json.loads((out / "summary.json").read_text())
    assert s["mrr_cm3_per_min"] == result.summary["mrr_cm3_per_min"]
    html = (out / "report.html").read_text()
    imgs = re.findall(r'src="data:image/png;base64,([^"]+)"', html)
    assert len(imgs) == 4
    assert all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in imgs)
    assert "http" not in html.replace("http-equiv", "")  # nothing fetched from outside
    assert "Tightest waypoints" in html


def test_no_plots_no_html(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "o2", plots=False, html_report=False)
    assert sorted(p.name for p in out.iterdir()) == ["summary.json", "waypoints.csv"]


def test_failure_leaves_nothing_half_written(tmp_path, result, monkeypatch):
    out = tmp_path / "o3"
    out.mkdir()
    (out / "summary.json").write_text("old", encoding="utf-8")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(report, "render_html", boom)
    with pytest.raises(RuntimeError):
        report.write_outputs(result, out)
    assert [p.name for p in out.iterdir()] == ["summary.json"]
    assert (out / "summary.json").read_text() == "old"
    assert not any(p.name.startswith(".o3.") for p in tmp_path.iterdir())
