"""The studies that no other test exercises run to the end at a small size.

The README's accuracy figures come from ``studies/``; a study that no longer
runs against the current API must fail CI. The studies with their own tests
(tests/tl, tests/diagnose, tests/modal, tests/twin) are not repeated here;
``make_models.py`` retrains the shipped networks (minutes) and is covered by
tests/tl/test_models.py through the models it made.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]

SMALL = {
    "planner_receptance": "--robots A --postures 5",
    "plan_safety": "--draws 1 --robots user --jobs al --out {tmp}/plan_safety.json",
    "sld_validation": "",
    "tl_schedule_cv": "--epochs 20 --repeats 1 --out {tmp}/cv.png",
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SMALL))
def test_study_runs(name: str, tmp_path: Path) -> None:
    args = SMALL[name].format(tmp=tmp_path).split()
    env = {**os.environ, "PYTHONPATH": str(REPO / "src")}
    res = subprocess.run(
        [sys.executable, str(REPO / "studies" / f"{name}.py"), *args],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    assert res.stdout.strip()
