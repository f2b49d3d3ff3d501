"""CLI messages print user text as written; --version."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import pytest
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


def test_progress_without_a_terminal_is_logged(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from robolobe.cli import _common

    monkeypatch.setattr(_common, "LOG_EVERY_S", 0.01)
    with _common.status("planning"):
        time.sleep(0.05)
    with _common.progress() as bar:
        task = bar.add_task("identifying", total=3)
        for _ in range(3):
            time.sleep(0.02)
            bar.advance(task)
    err = capsys.readouterr().err
    assert "planning (still running" in err
    assert "planning done in" in err
    assert "identifying: 3/3 done" in err
