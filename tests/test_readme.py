"""The README's shell sessions run exactly as written (issue: every command shown must run).

Blocks marked ``<!-- readme-test -->`` on the line before their opening fence
are run, each in a fresh folder, with ``bash -e``; the install commands of
the quick start are not (CI has just run them).
"""

from __future__ import annotations

import os
import re
import shlex
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


def _after(lines: list[str], marker: str, where: str) -> str:
    """The first command line after the line starting with ``marker`` (fences skipped)."""
    i = next((i for i, ln in enumerate(lines) if ln.startswith(marker)), None)
    assert i is not None, f"{where}: no line starting with {marker!r}"
    return next(ln for ln in lines[i + 1 :] if ln.strip() and not ln.startswith("```"))


def test_ci_runs_the_readme_test_command() -> None:
    """``.ci/run`` runs exactly the README's test command (the docs' home page shows it
    too), and that command runs every test: the parallel run all but the ``serial``
    ones, then those alone."""
    root = README.parent
    shown = _after(
        README.read_text(encoding="utf-8").splitlines(),
        "**Install and run the tests**",
        "README.md",
    )
    install = 'pip install -e ".[test]" && '
    assert install in shown, f"README.md: expected {install!r} before the test command"
    command = shown.split(install, 1)[1]
    ci = _after(
        (root / ".ci" / "run").read_text(encoding="utf-8").splitlines(),
        "# The README's test command",
        ".ci/run",
    )
    assert ci == command
    docs = _after(
        (root / "docs" / "index.md").read_text(encoding="utf-8").splitlines(),
        "**Run the tests**",
        "docs/index.md",
    )
    assert docs.split(install, 1)[-1] == command
    runs = [shlex.split(part) for part in command.split(" && ")]
    assert len(runs) == 2, command
    parallel, alone = runs
    assert parallel[:3] == ["python", "-m", "pytest"] == alone[:3], command
    assert "-n" in parallel, command
    assert "-n" not in alone, command
    assert parallel[parallel.index("-m", 3) + 1] == "(slow or not slow) and not serial", command
    assert alone[alone.index("-m", 3) + 1] == "serial", command
