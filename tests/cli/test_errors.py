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


@pytest.mark.parametrize(
    ("argv", "names"),
    [
        (["simulate", "B", "--design", "seed", "-o", "c", "--seed", "-1"], "--seed"),
        (["plan", "--nonsense"], "--nonsense"),
        (["bogus-command"], "bogus-command"),
        (["sld", "--modes"], "--modes"),
        (["identify", "camp", "-o", "m.csv", "--jobs", "x"], "--jobs"),
    ],
)
def test_usage_errors_are_one_line(
    argv: list[str], names: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:  # fmt: skip
    """Click's usage errors print one ``error:`` line naming the option, exit 2, no files."""
    from robolobe.cli.main import main

    monkeypatch.chdir(tmp_path)
    with pytest.raises(SystemExit) as info:
        main(argv)
    out = capsys.readouterr()
    lines = [ln for ln in out.err.splitlines() if ln.strip()]
    assert info.value.code == 2
    assert len(lines) == 1, out.err
    assert lines[0].startswith("error: robolobe"), out.err
    assert names in lines[0]
    assert "--help" in lines[0]
    assert list(tmp_path.iterdir()) == []
