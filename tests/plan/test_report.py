"""Plan outputs: files, contents, self-contained HTML, atomic writes."""

from __future__ import annotations

import base64
import json
import re
import shutil
import subprocess

import numpy as np
import pandas as pd
import pytest
from matplotlib.image import imread as plt_imread

from robolobe._atomic import MANIFEST
from robolobe.errors import InputError
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
        MANIFEST, "plots/lobes.png", "plots/path_margin.png", "plots/speed_map.png",
        "plots/speed_power.png",
        "program.apt", "report.html", "summary.json", "waypoints.csv",
    ]  # fmt: skip
    assert 'href="program.apt"' in (out / "report.html").read_text()
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
    assert s == result.summary.to_dict()
    assert s["mrr_cm3_per_min"] == result.summary.mrr_cm3_per_min
    html = (out / "report.html").read_text()
    imgs = re.findall(r'src="data:image/png;base64,([^"]+)"', html)
    assert len(imgs) == 4
    assert all(base64.b64decode(i)[:8] == b"\x89PNG\r\n\x1a\n" for i in imgs)
    assert "http" not in html.replace("http-equiv", "")  # nothing fetched from outside
    assert "Tightest waypoints" in html


def test_no_plots_no_html(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "o2", plots=False, html_report=False)
    assert sorted(p.name for p in out.iterdir()) == [
        MANIFEST, "program.apt", "summary.json", "waypoints.csv"
    ]  # fmt: skip


def test_failure_leaves_nothing_half_written(tmp_path, result, monkeypatch):
    out = tmp_path / "o3"
    out.mkdir()
    (out / "summary.json").write_text("old", encoding="utf-8")

    def boom(*a, **k):
        raise RuntimeError("disk full")

    monkeypatch.setattr(report, "_report_parts", boom)  # the report, after the tables
    with pytest.raises(RuntimeError):
        report.write_outputs(result, out)
    assert [p.name for p in out.iterdir()] == ["summary.json"]
    assert (out / "summary.json").read_text() == "old"
    assert [p.name for p in tmp_path.iterdir()] == ["o3"]  # no temporary left beside it


@pytest.mark.slow
def test_rerun_without_plots_replaces_the_whole_set(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "o3")
    (out / "mine.txt").write_text("kept")
    report.write_outputs(result, out, plots=False, html_report=False, program=False)
    assert sorted(p.name for p in out.iterdir()) == [
        MANIFEST,
        "mine.txt",
        "summary.json",
        "waypoints.csv",
    ]


def test_report_is_readable(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "o4")
    html = (out / "report.html").read_text()
    # every figure carries a caption that says what to read from it
    for name in report.PLOTS:
        assert report.CAPTIONS[name][:60] in html
    # no absolute local paths; the bundled example is named as such
    assert "/site-packages/" not in html
    assert str(tmp_path) not in html
    assert "contour.apt (bundled example)" in html
    # the tightest table: one row per position, speeds as whole rpm
    part = html.split("Tightest waypoints")[1].split("<h2>Program")[0]
    header = re.findall(r"<th>([^<]*)</th>", part)
    rows = [re.findall(r"<td>([^<]*)</td>", r) for r in re.findall(r"<tr>(.*?)</tr>", part, re.S)]
    tight = pd.DataFrame([r for r in rows if r], columns=header)
    assert len(tight) >= 2
    assert not tight[["x_mm", "y_mm", "z_mm"]].duplicated().any()
    assert tight["margin"].astype(float).is_monotonic_increasing
    assert "e+0" not in html.split("Tightest waypoints")[1]


def test_lobes_show_distinct_dynamics(result):
    chosen = report._chosen(result)
    groups = result.lobes.table.group[chosen]
    assert len(set(groups.tolist())) == len(chosen)
    best = result.outcome.best
    assert best.margin[chosen[0]] == pytest.approx(np.nanmin(best.margin))


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("chromium") is None, reason="Debian's chromium is not installed")
def test_report_renders_in_a_headless_browser(tmp_path, result):
    out = report.write_outputs(result, tmp_path / "o5")
    shot = tmp_path / "shot.png"
    subprocess.run(
        [
            "chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
            "--no-first-run", "--disable-background-networking", "--disable-component-update",
            "--disable-sync", f"--user-data-dir={tmp_path / 'profile'}", "--window-size=1100,4000",
            f"--screenshot={shot}", (out / "report.html").as_uri(),
        ],
        capture_output=True, timeout=120, check=False,
    )  # fmt: skip
    img = plt_imread(shot)
    assert img.shape[:2] == (4000, 1100)
    # a page of broken images is almost all white; four plots are not
    ink = float(np.mean(img[..., :3].mean(axis=-1) < 0.9))
    assert ink > 0.05, ink


def test_thinned_waypoints_keep_the_tightest_of_each_block(tmp_path, result):
    out = report.write_outputs(
        result, tmp_path / "thin", plots=False, html_report=False, waypoints_every=7
    )
    full = result.table
    got = pd.read_csv(out / "waypoints.csv")
    assert len(got) == -(-len(full) // 7)
    m = full["margin"].to_numpy()
    for b in range(len(got)):  # independent check, block by block
        blk = m[7 * b : 7 * b + 7]
        want = 7 * b + (int(np.nanargmin(blk)) if np.any(np.isfinite(blk)) else 0)
        assert got["line"].iloc[b] == full["line"].iloc[want]
    assert np.nanmin(got["margin"]) == np.nanmin(m)  # the path's tightest waypoint is kept
    # none: no table; a re-run replaces the set (no stale CSV)
    report.write_outputs(
        result, out, plots=False, html_report=False, waypoints="none", program=False
    )
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST, "summary.json"]
    with pytest.raises(InputError):
        report.write_outputs(result, out, waypoints="xlsx")
    with pytest.raises(InputError):
        report.write_outputs(result, out, waypoints_every=0)


def test_parquet_waypoints_or_refusal_before_writing(tmp_path, result):
    out = tmp_path / "pq"
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        with pytest.raises(InputError, match="pyarrow"):
            report.write_outputs(result, out, waypoints="parquet")
        assert not out.exists()
        return
    report.write_outputs(result, out, plots=False, html_report=False, waypoints="parquet")
    got = pd.read_parquet(out / "waypoints.parquet")
    pd.testing.assert_frame_equal(got, result.table.reset_index(drop=True), check_dtype=False)


def test_cli_waypoint_options(tmp_path):
    """``plan --waypoints parquet`` without pyarrow is refused before planning (exit 2,
    nothing written); ``--waypoints-every`` thins the CSV."""
    from typer.testing import CliRunner

    from robolobe.cli.main import app

    job = tmp_path / "job.toml"
    text = example("job_B_contour.toml").read_text(encoding="utf-8")
    job.write_text(text.replace('model = "builtin"', 'model = "twin"'), encoding="utf-8")
    base = ["plan", str(example("contour.apt")), "--job", str(job), "--no-plots", "--no-html"]
    runner = CliRunner()
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        r = runner.invoke(app, [*base, "-o", str(tmp_path / "pq"), "--waypoints", "parquet"])
        assert r.exit_code == 2, r.output
        assert "pyarrow" in r.output
        assert not (tmp_path / "pq").exists()
    r = runner.invoke(app, [*base, "-o", str(tmp_path / "thin"), "--waypoints-every", "5"])
    assert r.exit_code == 0, r.output
    flat = " ".join(r.output.split())  # rich may wrap the line
    assert "(waypoints.csv, summary.json, program.apt)" in flat  # what was written, nothing else
    full = plan_path(example("contour.apt"), load_job(job), refine=True).table
    got = pd.read_csv(tmp_path / "thin" / "waypoints.csv")
    assert len(got) == -(-len(full) // 5)


def test_chosen_lobes_equal_a_candidate_by_candidate_search(result):
    """The vectorised choice of lobes to plot is the plain loop's (the old code)."""
    best, tab = result.outcome.best, result.lobes.table
    g = tab.group
    idx = np.flatnonzero(np.isfinite(best.margin) & (g < result.lobes.n_groups))
    out = [int(idx[np.argmin(best.margin[idx])])]
    order = idx[np.argsort(best.margin[idx], kind="stable")]
    _, first = np.unique(g[order], return_index=True)
    cand = order[np.sort(first)]
    log_a = np.log(np.clip(tab.a_lim, 1e-9, 1e3))
    while len(out) < 3:
        shown = log_a[g[out]]
        dist = np.array([np.min(np.mean(np.abs(shown - log_a[g[c]]), axis=1)) for c in cand])
        j = int(np.argmax(dist))
        if dist[j] < 0.05:
            break
        out.append(int(cand[j]))
    assert report._chosen(result) == out


def test_margin_runs_colour_every_move_as_the_norm_does():
    """The path plot joins moves of one colour class: each move keeps BoundaryNorm's colour."""
    from matplotlib.colors import BoundaryNorm

    from robolobe.plan._plots import margin_classes as _margin_classes
    from robolobe.plan._plots import runs as _runs

    sf = 1.3
    bounds = [0.0, 1.0, sf, 1.1 * sf, 1.5 * sf, 2.0 * sf, 4.0 * sf]
    rng = np.random.default_rng(2)
    m = rng.choice([*bounds, 0.5, 1.2, 1.5, 3.0, 9.0, np.inf, np.nan], 400)
    m[:5] = np.nan
    cls = _margin_classes(m, bounds)
    norm = BoundaryNorm(bounds, 6)
    fin = np.isfinite(m)
    # BoundaryNorm's bin, with values at or above the last bound its 'over' (N) bin
    ref = np.asarray(norm(np.where(fin, m, 0.0)).filled(6))
    np.testing.assert_array_equal(cls[fin], np.minimum(ref[fin], 6))
    assert np.all(cls[~fin] == -1)
    x = np.arange(m.size + 1.0)
    lines, run_cls = _runs(x, 2 * x, cls)
    # expanded back to moves: every drawn move once, in its own class
    per_move = np.full(m.size, -1)
    for line, c in zip(lines, run_cls, strict=True):
        i0 = int(line[0, 0])
        per_move[i0 : i0 + len(line) - 1] = c
        np.testing.assert_array_equal(line[:, 1], 2 * line[:, 0])
    np.testing.assert_array_equal(per_move, cls)


def _awkward_table(n: int, rng: np.random.Generator) -> pd.DataFrame:
    """Floats with NaN, +-inf, -0.0, tiny and huge values; labels, missing ones; ints; flags."""
    x = rng.standard_normal(n) * 10.0 ** rng.integers(-12, 14, n)
    x[rng.random(n) < 0.2] = np.nan
    x[rng.random(n) < 0.05] = np.inf
    x[rng.random(n) < 0.05] = -np.inf
    x[rng.random(n) < 0.05] = -0.0
    labels = np.array(["cut", "rapid", "", 'say "a", b', "x\ny", "ü"], dtype=object)
    lab = labels[rng.integers(0, len(labels), n)]
    late = lab.copy()
    late[: n // 2] = None  # missing in the first blocks only: the type comes from the rest
    return pd.DataFrame(
        {
            "source": pd.Series(["a.nc", "b c.nc", None][i % 3] for i in range(n)).astype("str"),
            "line": np.arange(n, dtype=np.int64) * 7 - 3,
            "x_mm": x,
            "all_nan": np.full(n, np.nan),
            "limiting": lab,
            "late_label": late,
            "flag": rng.random(n) < 0.5,
            "f32": x.astype(np.float32),
        }
    )


@pytest.mark.parametrize("block", [1, 3, 64, 65_536])
@pytest.mark.parametrize("n", [0, 1, 63, 64, 65, 1000])
def test_csv_in_blocks_is_the_one_shot_file(tmp_path, n, block):
    import pyarrow as pa
    import pyarrow.csv as pacsv

    df = _awkward_table(n, np.random.default_rng(n + block))
    one = tmp_path / "one.csv"  # the reference: the whole table converted and written at once
    pacsv.write_csv(
        pa.Table.from_pandas(df, preserve_index=False),
        one,
        write_options=pacsv.WriteOptions(quoting_style="needed"),
    )
    got = tmp_path / "blocks.csv"
    report.write_csv(df, got, block_rows=block)
    assert got.read_bytes() == one.read_bytes()
    if n >= 1000:  # the file holds what the table holds (the comparison is not vacuous)
        back = pd.read_csv(got, keep_default_na=False, na_values=[""])
        assert len(back) == n
        assert np.isinf(back["x_mm"]).any()
        assert back["x_mm"].isna().any()
