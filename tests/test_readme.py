"""The README's shell sessions run exactly as written (issue: every command shown must run).

Blocks marked ``<!-- readme-test -->`` on the line before their opening fence
are run, each in a fresh folder, with ``bash -e``; the install commands of
the quick start are not (CI has just run them).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
MARK = "<!-- readme-test -->"


def _blocks() -> list[tuple[int, str]]:
    lines = README.read_text(encoding="utf-8").splitlines()
    out = []
    for i, line in enumerate(lines):
        if line.strip() == MARK:
            assert lines[i + 1].startswith("```bash"), f"README.md:{i + 2}: expected ```bash"
            end = next(j for j in range(i + 2, len(lines)) if lines[j].startswith("```"))
            out.append((i + 3, "\n".join(lines[i + 2 : end])))
    return out


def test_readme_has_tested_sessions() -> None:
    assert len(_blocks()) >= 1


@pytest.mark.slow
@pytest.mark.parametrize(("line", "script"), _blocks(), ids=lambda v: str(v)[:20])
def test_readme_session_runs_as_written(tmp_path: Path, line: int, script: str) -> None:
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    # comments and line continuations stay as written: bash runs the block itself
    proc = subprocess.run(
        ["bash", "-e", "-o", "pipefail", "-c", script],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
        check=False,
    )
    assert proc.returncode == 0, (
        f"README.md:{line}: block failed (exit {proc.returncode})\n"
        f"{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    )
    assert not re.search(r"Traceback \(most recent call last\)", proc.stderr)
