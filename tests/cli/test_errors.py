"""The CLI turns robolobe errors into one readable line and exit code 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest


@pytest.mark.slow
def test_error_line_keeps_bracketed_key_paths(tmp_path: Path) -> None:
    robot = tmp_path / "bad.toml"
    robot.write_text(
        'name = "x"\nformat = "robolobe-robot/1"\n[kinematics]\nconvention = "standard-dh"\n'
    )
    out = tmp_path / "campaign"
    proc = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", "simulate", str(robot), "--design", "seed",
         "-o", str(out)],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1
    # rich markup must not swallow the TOML key path "[[joints]]"
    assert "[[joints]]" in lines[0]
    assert "bad.toml" in lines[0]
    assert not out.exists()
