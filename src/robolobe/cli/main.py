"""Entry point of the ``robolobe`` command.

Each group of subcommands lives in its own module of this package and exposes
``register(app)``. Errors derived from :class:`robolobe.errors.RobolobeError`
become one readable line on stderr and exit code 2 (3: no feasible plan).
"""

from __future__ import annotations

import importlib
import logging
import os
import sys
from typing import Any

import typer

from robolobe.errors import RobolobeError

__all__ = ["app", "main"]

HELP = """\
robolobe: chatter-free milling plans for industrial robots.

Units: SI inside; files and options say their unit in the name
(q_deg: degrees, depth_mm / a_lim_mm: millimetres, f_hz: hertz, rpm:
spindle revolutions per minute, k_N_per_m: N/m, Kt/Kn: N/m^2, zeta: damping
ratio as a fraction). Files: robot descriptions (TOML, robolobe-robot/1),
hammer-test campaigns (folder with campaign.toml, postures.csv, frf.csv or
frf/*.uff), modal datasets (modal.csv), job files (TOML) and toolpaths
(G-code, APT/CL, KUKA KRL, ABB RAPID, CSV). Each format is described in the
user guide of the documentation site (docs/guide/ in the robolobe source).
"""

#: The settings of the ``robolobe`` command (and of :func:`_app_for`'s one-command apps).
_SETTINGS: dict[str, Any] = {
    "name": "robolobe",
    "help": HELP,
    "no_args_is_help": True,
    "pretty_exceptions_enable": False,
    "add_completion": False,
    "rich_markup_mode": None,
}

app = typer.Typer(**_SETTINGS)


def _print_version(value: bool) -> None:
    if value:
        from robolobe import __version__

        typer.echo(f"robolobe {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False,
        "--version",
        help="Print the robolobe version and exit.",
        callback=_print_version,
        is_eager=True,
    ),
) -> None:
    """robolobe: chatter-free milling plans for industrial robots."""


# Command modules, in the order they appear in --help.
_COMMAND_MODULES = (
    "plan",
    "verify",
    "check",
    "program",
    "simulate",
    "identify",
    "tl",
    "sld",
    "diagnose",
    "examples",
)

for _name in _COMMAND_MODULES:
    try:
        _mod = importlib.import_module(f"robolobe.cli.{_name}")
    except ModuleNotFoundError as exc:  # a command group not built yet
        if exc.name != f"robolobe.cli.{_name}":
            raise
        continue
    _mod.register(app)


class _WarningLines(logging.Handler):
    """Library warnings (file readers, plausibility) as ``warning: ...`` lines on stderr."""

    def emit(self, record: logging.LogRecord) -> None:
        from robolobe.cli._common import err_console, labelled

        err_console.print(labelled("warning:", "yellow", record.getMessage()), soft_wrap=True)


def _show_warnings() -> None:
    log = logging.getLogger("robolobe")
    if not any(isinstance(h, _WarningLines) for h in log.handlers):
        handler = _WarningLines(level=logging.WARNING)
        log.addHandler(handler)


#: Click's usage error (a bad option, value or command), found through typer's public
#: ``BadParameter`` because typer vendors click in a private module. Caught so that it
#: prints one ``error:`` line like every other input error, not click's four lines.
_USAGE_ERROR: Any = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "UsageError")
_ABORT: type[BaseException] = typer.Abort


class _Terminated(BaseException):
    """SIGTERM as an exception: the ``finally`` blocks run (temporary files of
    the atomic writers are removed, worker pools terminate their workers
    instead of waiting for their tasks) before exit 143.

    A :class:`BaseException`, like :class:`KeyboardInterrupt`, so no
    ``except Exception`` on the way swallows it.
    """


def _on_sigterm(signum: int, frame: object) -> None:
    raise _Terminated()


def _app_for(args: list[str]) -> typer.Typer:
    """The app that runs ``args``: where they start with a command's name, one with only
    that command (and the root options), else :data:`app`.

    Typer builds the parameters of every registered command before it runs one
    (about 25 ms for the 15 commands, of a 1.5 s plan); the one-command app
    runs the same function with the same options, help and messages.
    """
    chosen = [c for c in app.registered_commands if args and c.name == args[0]]
    if not chosen:
        return app
    one = typer.Typer(**_SETTINGS)
    one.registered_callback = app.registered_callback
    one.registered_commands = chosen
    return one


def main(argv: list[str] | None = None) -> None:
    """Run the CLI; turn robolobe errors into one line and an exit code.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``robolobe``. None: this process's command line
        (``sys.argv``), as the ``robolobe`` program; the process then ends
        with the command (:func:`_exit`: the exit handlers run, the
        interpreter's teardown of the imported modules, about 0.1 s, does
        not). Given, :class:`SystemExit` is raised as usual.
    """
    code = _run(argv)
    if argv is None:
        _exit(code)
    sys.exit(code)


def _run(argv: list[str] | None) -> int:
    """The command's exit status; errors printed as one line."""
    import signal
    import threading

    from robolobe.cli._common import err_console, error_line

    _show_warnings()
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        # argv None reaches click as None (it reads sys.argv, expanding patterns on Windows)
        one = _app_for(sys.argv[1:] if argv is None else argv)
        code = one(args=argv, prog_name="robolobe", standalone_mode=False)
    except _USAGE_ERROR as exc:
        if type(exc).__name__ == "NoArgsIsHelpError":
            exc.show()  # the help text, as with any command given no arguments
            return 2
        ctx = exc.ctx
        path = ctx.command_path if ctx is not None else "robolobe"
        where, hint = f"{path}: ", f" (see {path} --help)"
        err_console.print(error_line(f"{where}{exc.format_message()}{hint}"), soft_wrap=True)
        return 2
    except _ABORT:
        err_console.print("aborted", style="bold red")
        return 1
    except RobolobeError as exc:
        err_console.print(error_line(exc), soft_wrap=True)
        return exc.exit_code
    except OSError as exc:
        # A file system refusal on a user's path (permission, full disk, a
        # folder where a file was expected) is input, not a bug: one line.
        what = exc.strerror or type(exc).__name__
        where = f": {exc.filename}" if exc.filename else ""
        err_console.print(error_line(f"{what}{where}"), soft_wrap=True)
        return 2
    except _Terminated:
        err_console.print("terminated (SIGTERM)", style="bold red")
        return 143
    except KeyboardInterrupt:
        err_console.print("interrupted", style="bold red")
        return 130
    # As click's standalone mode did: the command's exit status, 0 when it returned.
    return code if isinstance(code, int) else 0


def _exit(code: int) -> None:
    """End the process with ``code`` as the interpreter would, less its teardown.

    What a normal exit does that matters runs (the :mod:`atexit` handlers:
    logging's flush, :class:`weakref.finalize` callbacks such as temporary
    folders, process pools; then the standard streams are flushed), and the
    process ends without the teardown of the imported modules (numpy,
    pandas, pyarrow, ...: about 0.1 s of a 1.5 s plan). Where a thread other
    than this one is still running, which the interpreter would wait for, it
    exits normally.
    """
    import atexit
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, signal.SIG_DFL)  # nothing left to clean up on the way
    run_exit_handlers = getattr(atexit, "_run_exitfuncs", None)
    others = [t for t in threading.enumerate() if t is not threading.current_thread()]
    if run_exit_handlers is None or any(not t.daemon for t in others):
        sys.exit(code)
    run_exit_handlers()
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):  # a closed pipe (| head): as Python says it
            code = code or 120
    os._exit(code)


if __name__ == "__main__":
    main()
