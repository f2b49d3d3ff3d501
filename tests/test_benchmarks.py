"""Every benchmark script runs to the end at a small size.

The benchmarks are the source of the README's speed figures; they are not
timed here (timings are for ``benchmarks/``), but a benchmark that no longer
runs against the current API (as ``bench_plan.py`` once did after the plan
summary became typed) must fail CI, not the next person who measures.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

SMALL = {
    "bench_plan.py path": "bench_plan.py --part path --waypoints-path 300 --sources twin,builtin",
    "bench_plan.py batch": "bench_plan.py --part batch --paths 2 --waypoints 80",
    "bench_plan.py long": "bench_plan.py --part long --waypoints-long 3000",
    "bench_diagnose.py": "bench_diagnose.py --postures 6",
    "bench_ik.py": "bench_ik.py --n 2000 --loop 50",
    "bench_modal.py": "bench_modal.py --n 6 --repeat 2",
    "bench_paths.py": "bench_paths.py --lines 2000 --others 500",
    "bench_sld.py": "bench_sld.py --batch 40 --loop 5 --repeat 1",
    "bench_tl.py": "bench_tl.py --threads 1",
}


def test_every_benchmark_is_listed() -> None:
    scripts = {p.name for p in (REPO / "benchmarks").glob("bench_*.py")}
    assert scripts == {v.split()[0] for v in SMALL.values()}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SMALL))
def test_benchmark_runs(name: str) -> None:
    script, *args = SMALL[name].split()
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    res = subprocess.run(
        [sys.executable, str(REPO / "benchmarks" / script), *args],
        cwd=REPO,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    assert res.stdout.strip()
