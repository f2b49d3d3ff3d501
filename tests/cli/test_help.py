"""Every command's --help: every option documented, text printed as written, light imports."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import pytest
import typer
from typer.testing import CliRunner

from robolobe.cli.main import app

_ROOT = typer.main.get_command(app)
COMMANDS = sorted(_ROOT.commands)  # type: ignore[attr-defined]
#: Modules that take seconds to import; --help must not need them.
HEAVY = ("torch", "matplotlib", "casadi", "scipy", "pandas", "sklearn", "numba")


def _flat(text: str) -> str:
    return re.sub(r"\s+", " ", text)


def test_every_command_is_listed() -> None:
    # the commands of the README's table and of main._COMMAND_MODULES
    assert set(COMMANDS) >= {"plan", "compare", "batch", "verify", "simulate", "identify",
                             "train", "transfer", "predict", "design-tests", "sld", "diagnose",
                             "examples"}  # fmt: skip


@pytest.mark.parametrize("name", COMMANDS)
def test_every_option_and_argument_is_documented(name: str) -> None:
    cmd = _ROOT.commands[name]  # type: ignore[attr-defined]
    assert (cmd.help or "").strip(), f"{name}: no command help"
    for p in cmd.params:
        assert (getattr(p, "help", None) or "").strip(), f"{name} {p.opts}: empty help text"


@pytest.mark.parametrize("name", COMMANDS)
def test_help_prints_texts_as_written(name: str) -> None:
    """Brackets ([test], [s], [path]) survive: no markup interpretation of help text."""
    res = CliRunner().invoke(app, [name, "--help"], terminal_width=100)
    assert res.exit_code == 0, res.output
    shown = _flat(res.output)
    cmd = _ROOT.commands[name]  # type: ignore[attr-defined]
    texts = [cmd.help or ""] + [getattr(p, "help", None) or "" for p in cmd.params]
    brackets = [b for t in texts for b in re.findall(r"\[[^\]\n]*\]", t)]
    for b in brackets:
        assert _flat(b) in shown, f"{name} --help lost {b!r}"
    for p in cmd.params:
        for opt in p.opts:
            if opt.startswith("--"):
                assert opt in shown, f"{name} --help does not show {opt}"
    # a flag takes no value: no type placeholder beside it
    assert "<bool>" not in shown
    assert "[default: .]" not in shown


def test_help_brackets_found_somewhere() -> None:
    """The bracket check above has something to check (it cannot pass vacuously)."""
    all_help = " ".join(
        getattr(p, "help", None) or ""
        for c in _ROOT.commands.values()  # type: ignore[attr-defined]
        for p in c.params
    )
    assert "[test]" in all_help
    assert "[s]" in all_help


@pytest.mark.slow
def test_help_imports_no_heavy_module() -> None:
    """``--help`` of every command without torch, matplotlib, casadi & co. (fast help)."""
    code = (
        "import sys, json\n"
        "from robolobe.cli.main import main\n"
        f"for c in [[]] + [[n] for n in {COMMANDS!r}]:\n"
        "    try:\n"
        "        main([*c, '--help'])\n"
        "    except SystemExit as e:\n"
        "        assert e.code in (0, None), (c, e.code)\n"
        f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True
    )
    loaded = json.loads(out.stdout.strip().splitlines()[-1])
    assert loaded == [], f"--help imported {loaded}"


def test_python_dash_m_robolobe_is_the_command() -> None:
    """``python -m robolobe`` runs the ``robolobe`` command (exit status passed on)."""
    ok = subprocess.run(
        [sys.executable, "-m", "robolobe", "--help"], capture_output=True, text=True, timeout=60
    )
    assert ok.returncode == 0
    assert "plan" in ok.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "robolobe", "no-such-command"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert bad.returncode == 2, bad.stderr
