"""Batch planning: local pool, failures isolated, one table with provenance, Dask."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest

from robolobe.plan.batch import BATCH_COLUMNS, batch_plan, plan_one, write_batch
from robolobe.plan.job import load_job

from .conftest import example


@pytest.fixture(scope="module")
def job():
    return load_job(example("job_A_pocket.toml")).replace(model="twin")


@pytest.fixture
def paths(tmp_path, data_dir):
    good = tmp_path / "pocket.nc"
    shutil.copy(example("pocket.nc"), good)
    bad = tmp_path / "bad.nc"
    bad.write_text("G0 X0 Y0\nG1 X10 #5=1\n", encoding="utf-8")
    far = tmp_path / "far.csv"
    far.write_text("x_m,y_m,z_m\n3,0,0\n3.1,0,0\n", encoding="utf-8")
    return [str(good), str(bad), str(far)]


def test_failures_do_not_stop_the_batch(tmp_path, job, paths):
    rows = list(batch_plan(paths, job, workers=1, refine=False))
    by = {r["path"].rsplit("/", 1)[-1]: r for r in rows}
    assert by["pocket.nc"]["status"] == "ok"
    assert by["bad.nc"]["status"] == "error"
    assert "bad.nc:2" in by["bad.nc"]["message"]
    assert by["far.csv"]["status"] == "unreachable"
    assert by["pocket.nc"]["path_sha256"]
    assert by["pocket.nc"]["job_sha256"]
    for fmt in ("parquet", "csv"):
        out = write_batch(rows, tmp_path / fmt, fmt=fmt)
        t = pd.read_parquet(out) if fmt == "parquet" else pd.read_csv(out)
        assert list(t.columns) == list(BATCH_COLUMNS)
        assert len(t) == 3
        assert sorted(t["status"]) == ["error", "ok", "unreachable"]


@pytest.mark.slow
def test_process_pool_matches_sequential(tmp_path, job, paths):
    # two different plannable paths, so a mix-up of rows between workers shows
    half = tmp_path / "pocket_half.nc"
    lines = Path(paths[0]).read_text(encoding="utf-8").splitlines()
    half.write_text("\n".join(lines[: len(lines) // 2]) + "\nM30\n", encoding="utf-8")
    two = [paths[0], str(half)]
    seq = {r["path"]: r for r in batch_plan(two, job, workers=1, refine=False)}
    par = list(batch_plan(two, job, workers=2, refine=False))
    assert [r["status"] for r in par] == ["ok", "ok"]
    assert sorted(r["path"] for r in par) == sorted(two)
    assert seq[two[0]]["n_waypoints"] != seq[two[1]]["n_waypoints"]
    for r in par:
        for key in ("n_waypoints", "depth_mm", "mrr_cm3_per_min", "cycle_time_s", "min_margin"):
            assert r[key] == seq[r["path"]][key], key


@pytest.mark.slow
def test_per_path_outputs(tmp_path, job, paths):
    row = plan_one(paths[0], job, out_dir=str(tmp_path / "o"), refine=False)
    assert row["status"] == "ok"
    assert (tmp_path / "o" / "pocket" / "waypoints.csv").exists()


@pytest.mark.slow
def test_dask_local_cluster_on_loopback(job, paths):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, host="127.0.0.1",
        protocol="tcp://", dashboard_address=None,
    ) as cluster:  # fmt: skip
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        rows = list(batch_plan(paths, job, scheduler=cluster.scheduler_address, refine=False))
    by = {r["path"].rsplit("/", 1)[-1]: r["status"] for r in rows}
    assert by == {"pocket.nc": "ok", "bad.nc": "error", "far.csv": "unreachable"}
