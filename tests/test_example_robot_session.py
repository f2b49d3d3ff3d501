"""The README's campaign-to-plan session on the example user robot (issue 27).

``examples/robots/my_robot.toml`` is heavily damped (an overdamped wrist mode
at about a fifth of its postures, close pairs of complex modes): the session
of README.md (the block that starts with ``design-tests B``) runs with the
robot file in place of ``B``: design-tests, simulate, identify, transfer
(default: calibrated twin + correction), plan on the model, verify against
the hammer tests. The cross-robot ``compare`` line is left out (it names the
built-in robots).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
MY_ROBOT = ROOT / "examples" / "robots" / "my_robot.toml"


def _session() -> str:
    """The README block with ``design-tests B``, robot B replaced by the example file."""
    from tests.test_readme import _blocks

    (script,) = [s for _, s in _blocks() if "design-tests B" in s]
    lines = [ln for ln in script.splitlines() if not ln.startswith("robolobe compare")]
    out = "\n".join(lines)
    rob = str(MY_ROBOT)
    for old, new in (
        ("design-tests B ", f"design-tests {rob} "),
        ("simulate B ", f"simulate {rob} "),
        ("--robot B ", f"--robot {rob} "),
    ):
        assert old in out, f"README session changed: no {old!r}"
        out = out.replace(old, new)
    # the job names the robot file too (the bundled job is robot B's)
    job = "job_B_contour.toml > job.toml"
    assert job in out, "README session changed: no job.toml line"
    return out.replace(
        job, f'job_B_contour.toml | sed \'s|^name = "B"|name = "{rob}"|\' > job.toml'
    )


@pytest.mark.slow
def test_readme_session_runs_on_the_example_robot(tmp_path: Path) -> None:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    proc = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", _session()],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
        check=False,
    )
    assert proc.returncode == 0, f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    assert not re.search(r"Traceback \(most recent call last\)", proc.stderr)
    ex = tmp_path / "ex"
    job = (ex / "job.toml").read_text()
    assert f'name = "{MY_ROBOT}"' in job
    # identification: where the rows fit worse, the identification's own fit (with
    # residual terms) is good and modes outside the band carry the difference
    modal = pd.read_csv(ex / "modal.csv")
    assert modal["k_N_per_m"].gt(0).all()
    out = proc.stdout + proc.stderr
    for m in re.finditer(r"FRAC ([0-9.]+), NRMSE ([0-9.]+)( \(fit with residual)?", out):
        if float(m.group(1)) < 0.8:
            assert m.group(3), f"a poor fit not explained by the band: {m.group(0)}"
    # the plan ran on the transferred model and the hammer tests find no waypoint
    # beyond its limit
    summary = json.loads((ex / "out" / "summary.json").read_text())
    assert summary
    verify = json.loads((ex / "out-verified" / "verify.json").read_text())
    assert verify["n_cut"] > 0
    assert verify["n_beyond_limit"] == 0
    assert verify["min_margin"] >= 1.0
    assert "calibrated to camp" in verify["mode_source"]
