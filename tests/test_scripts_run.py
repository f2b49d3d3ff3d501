"""Every benchmark, and every study no other test exercises, runs to the end at a small size.

The README's speed figures come from ``benchmarks/`` and its accuracy figures
from ``studies/``; they are not timed or checked here, but a script that no
longer runs against the current API (as ``bench_plan.py`` once did after the
plan summary became typed) must fail CI, not the next person who measures.
The studies with their own tests (tests/tl, tests/diagnose, tests/modal,
tests/twin) are not repeated here; ``make_models.py`` retrains the shipped
networks (minutes) and is covered by tests/tl/test_models.py through the
models it made.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

BENCHMARKS = {
    "bench_plan.py path": "bench_plan.py --part path --waypoints-path 300 --sources twin,builtin",
    "bench_plan.py batch": "bench_plan.py --part batch --paths 2 --waypoints 80",
    "bench_plan.py long": "bench_plan.py --part long --waypoints-long 3000",
    "bench_diagnose.py": "bench_diagnose.py --postures 6",
    "bench_engagement.py": "bench_engagement.py --moves 2000 --pocket",
    "bench_ik.py": "bench_ik.py --n 2000 --loop 50",
    "bench_jit.py": "bench_jit.py --kernel group --sizes 200",
    "bench_load.py": "bench_load.py --busy 1 --reps 1",
    "bench_modal.py": "bench_modal.py --n 6 --repeat 2",
    "bench_paths.py": "bench_paths.py --lines 2000 --others 500",
    "bench_sld.py": "bench_sld.py --batch 40 --loop 5 --repeat 1",
    "bench_tl.py": "bench_tl.py --threads 1",
    "bench_transfer.py": "bench_transfer.py --draws B1",
}

STUDIES = {
    "engagement": "--max-moves 40",
    "planner_receptance": "--robots A --postures 5",
    "plan_safety": "--draws 1 --robots user --jobs al --out {tmp}/plan_safety.json",
    # the face plan only: tests/plan/test_converged_plans.py checks all three (minutes)
    "sld_validation": "--plans face",
    "tl_schedule_cv": "--epochs 20 --repeats 1 --out {tmp}/cv.png",
}


def _run(script: Path, args: list[str], cwd: Path) -> None:
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    res = subprocess.run(
        [sys.executable, str(script), *args],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    assert res.stdout.strip()


def test_every_benchmark_is_listed() -> None:
    scripts = {p.name for p in (REPO / "benchmarks").glob("bench_*.py")}
    assert scripts == {v.split()[0] for v in BENCHMARKS.values()}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(BENCHMARKS))
def test_benchmark_runs(name: str) -> None:
    script, *args = BENCHMARKS[name].split()
    _run(REPO / "benchmarks" / script, args, REPO)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(STUDIES))
def test_study_runs(name: str, tmp_path: Path) -> None:
    _run(REPO / "studies" / f"{name}.py", STUDIES[name].format(tmp=tmp_path).split(), tmp_path)
