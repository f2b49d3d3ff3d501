"""CLI messages print user text as written; --version."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

import robolobe
from robolobe.cli.main import app


def test_version() -> None:
    r = CliRunner().invoke(app, ["--version"])
    assert r.exit_code == 0
    assert r.output.strip() == f"robolobe {robolobe.__version__}"


def test_emoji_codes_in_user_text_are_not_interpreted(tmp_path: Path) -> None:
    modes = tmp_path / "modes.csv"
    modes.write_text("root:x:0:0:root:/root:/bin/bash\n")
    r = subprocess.run(
        [sys.executable, "-m", "robolobe.cli.main", "sld", "--modes", str(modes),
         "--teeth", "2", "--immersion", "0.5", "--rpm", "5000:6000",
         "--material", "Al7075-T6", "-o", str(tmp_path / "l.csv")],
        capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert r.returncode == 2
    assert "root:x:0:0" in r.stderr
    assert "\u274c" not in r.stderr
