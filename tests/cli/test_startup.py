"""Start-up and end of the ``robolobe`` program: what it imports, how it exits.

The bundled ``robolobe plan`` takes about 1.5 s, a third of it imports;
these tests keep out of it what a plan does not need (a module imported on
the way costs every run), keep the one-command app of :func:`_app_for`
identical to the full one, and check that the program's fast exit
(:func:`robolobe.cli.main._exit`) still runs the exit handlers and waits for
running threads.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from robolobe import __version__
from robolobe.cli import main as cli_main

COMMANDS = sorted(c.name for c in cli_main.app.registered_commands if c.name)

#: Never imported by the bundled plan without plots: other commands' subpackages, the
#: optional heavy libraries (the plan's numpy paths, refinement not needed by the bundled
#: job), the plotting stack (drawn by workers or not at all).
NOT_ON_THE_PLAN_PATH = (
    "matplotlib",
    "PIL",
    "scipy",
    "casadi",
    "numba",
    "llvmlite",
    "sklearn",
    "torch",
    "dask",
    "distributed",
    "robolobe.tl",
    "robolobe.modal",
    "robolobe.campaign",
    "robolobe.diagnose",
    "robolobe.plan.compare",
    "robolobe.plan.batch",
    "robolobe.plan.verify",
)


def _program(tmp_path: Path, args: list[str], before: str = "") -> subprocess.CompletedProcess[str]:
    """``robolobe ARGS`` as the program runs it (``main()`` on ``sys.argv``), after
    ``before`` (Python lines run first in that process)."""
    code = (
        f"{before}\n"
        "import sys\n"
        f"sys.argv = ['robolobe', *{args!r}]\n"
        "from robolobe.cli.main import main\n"
        "main()\n"
        "raise AssertionError('main() returned')\n"
    )
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=tmp_path
    )


def test_bundled_plan_imports_only_what_it_needs(tmp_path):
    """``robolobe plan --no-plots --no-html`` (the bundled pocket): none of
    :data:`NOT_ON_THE_PLAN_PATH` is imported (listed by an exit handler, which the
    program's fast exit runs)."""
    listed = tmp_path / "modules.json"
    before = (
        "import atexit, json, sys\n"
        f"atexit.register(lambda: open({str(listed)!r}, 'w')"
        ".write(json.dumps(sorted(sys.modules))))"
    )
    out = tmp_path / "out"
    res = _program(tmp_path, ["plan", "-o", str(out), "--no-plots", "--no-html"], before)
    assert res.returncode == 0, res.stderr[-2000:]
    assert (out / "waypoints.csv").stat().st_size > 10_000  # the plan ran
    modules = json.loads(listed.read_text())
    assert "robolobe.plan.pipeline" in modules  # the list is the plan's
    loaded = [
        m for m in modules if any(m == n or m.startswith(n + ".") for n in NOT_ON_THE_PLAN_PATH)
    ]
    assert loaded == []


def test_the_program_runs_exit_handlers_and_passes_the_status(tmp_path):
    """The fast exit keeps what matters of a normal one: exit handlers, the printed output,
    the exit status (2: a bad option, with its one error line)."""
    mark = tmp_path / "handler.txt"
    before = f"import atexit\natexit.register(lambda: open({str(mark)!r}, 'w').write('ran'))"
    ok = _program(tmp_path, ["--version"], before)
    assert (ok.returncode, ok.stdout.strip()) == (0, f"robolobe {__version__}")
    assert mark.read_text() == "ran"
    mark.unlink()
    bad = _program(tmp_path, ["plan", "--no-such-option"], before)
    assert bad.returncode == 2
    assert bad.stderr.startswith("error: robolobe plan: No such option: --no-such-option")
    assert mark.read_text() == "ran"


def test_the_program_waits_for_a_running_thread(tmp_path):
    """A thread still running at the end (which Python waits for) is waited for: the
    program then exits as Python does."""
    mark = tmp_path / "thread.txt"
    before = (
        "import threading, time\n"
        "def late():\n"
        "    time.sleep(0.5)\n"
        f"    open({str(mark)!r}, 'w').write('done')\n"
        "threading.Thread(target=late).start()"
    )
    res = _program(tmp_path, ["--version"], before)
    assert res.returncode == 0, res.stderr
    assert mark.read_text() == "done"


def test_the_program_skips_the_interpreter_teardown(tmp_path):
    """What the fast exit saves (about 0.1 s after a plan): the teardown of the imported
    modules, seen here by a module-level object whose finalizer never runs; with
    ``main(argv)`` (a caller in Python) the interpreter exits normally and it does."""
    mark = tmp_path / "teardown.txt"
    before = (  # bound beforehand: names may be gone by the time of the teardown
        "import os\n"
        f"fd = os.open({str(mark)!r}, os.O_WRONLY | os.O_CREAT)\n"
        "class Witness:\n"
        "    def __del__(self, write=os.write, fd=fd):\n"
        "        write(fd, b'torn down')\n"
        "witness = Witness()"
    )
    fast = _program(tmp_path, ["--version"], before)
    assert fast.returncode == 0, fast.stderr
    assert mark.read_text() == ""
    code = f"{before}\nfrom robolobe.cli.main import main\nmain(['--version'])\n"
    normal = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
    )
    assert normal.returncode == 0, normal.stderr
    assert mark.read_text() == "torn down"


@pytest.mark.parametrize("name", COMMANDS)
def test_the_one_command_app_is_the_command(name):
    """``robolobe NAME ...`` runs on an app with NAME only (typer builds the parameters of
    every registered command first): the same help, the same refusal of a bad option."""
    one = cli_main._app_for([name, "--help"])
    assert one is not cli_main.app
    assert [c.name for c in one.registered_commands] == [name]
    for args in ([name, "--help"], [name, "--no-such-option"]):
        full = CliRunner().invoke(cli_main.app, args, terminal_width=100)
        mine = CliRunner().invoke(one, args, terminal_width=100)
        assert (mine.exit_code, mine.output) == (full.exit_code, full.output), args


@pytest.mark.parametrize("args", [[], ["--help"], ["--version"], ["no-such-command"], ["plan2"]])
def test_anything_else_runs_on_the_full_app(args):
    assert cli_main._app_for(args) is cli_main.app


def test_the_full_app_lists_every_command_module():
    """Every command module registers into the full app (the one-command apps are cut
    from it)."""
    group = typer.main.get_command(cli_main.app)
    assert sorted(group.commands) == COMMANDS  # type: ignore[attr-defined]
    assert {"plan", "compare", "batch", "sld", "diagnose"} <= set(COMMANDS)
