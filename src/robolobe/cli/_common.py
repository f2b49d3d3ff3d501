"""Shared helpers of the CLI: console, progress display, error exit.

Progress shows as rich bars and spinners on a terminal; elsewhere (CI logs,
``nohup``, a pipe) as plain timestamped lines on stderr every
:data:`LOG_EVERY_S` seconds once a step has run that long, so a long run
never leaves an empty log and a short one (or a one-line error) stays quiet.
"""

from __future__ import annotations

import contextlib
import shutil
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    ProgressColumn,
    SpinnerColumn,
    Task,
    TaskID,
    TimeElapsedColumn,
)
from rich.text import Text

from robolobe._text import visible

__all__ = [
    "LOG_EVERY_S",
    "Outputs",
    "console",
    "err_console",
    "error_line",
    "labelled",
    "progress",
    "shown",
    "status",
]


class _Console(Console):
    """A console that shows every string as written: the one gate to the terminal.

    User text (file names, robot names, job titles, file contents quoted in
    messages) reaches the terminal only through :meth:`render_str` (``print``
    arguments, table cells and titles) or the :class:`~rich.text.Text` that
    :func:`labelled` builds. Markup is off (``[bold]`` in a file name is text,
    not a style, and ``[/]`` cannot raise), emoji codes and colour guessing are
    off, and control or bidi characters (ANSI escapes, a right-to-left
    override) show as their escapes. Newlines written by robolobe stay line
    breaks; a user value interpolated into a line goes through :func:`shown`,
    which makes its newlines visible too, so it cannot forge an ``error:`` line.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(markup=False, emoji=False, highlight=False, **kwargs)

    def render_str(self, text: str, **kwargs: Any) -> Text:
        kwargs["markup"] = False
        kwargs["emoji"] = False
        return super().render_str(visible(text, newlines=True), **kwargs)


console = _Console()
err_console = _Console(stderr=True)


def shown(value: object) -> str:
    """A user value (path, name, quoted text) for a message line: one line, as written."""
    return visible(value)


def labelled(label: str, style: str, message: object) -> Text:
    """``label`` in ``style`` followed by ``message`` (shown as written, one line)."""
    return Text.assemble((label, style), " ", visible(message))


def error_line(message: object) -> Text:
    """The CLI's one-line error: ``error: <message>``."""
    return labelled("error:", "bold red", message)


class _Description(ProgressColumn):
    """The task description, as written (no markup, control characters escaped)."""

    def render(self, task: Task) -> Text:
        return Text(visible(task.description), style="progress.description")


#: Seconds between progress lines when stderr is not a terminal.
LOG_EVERY_S = 10.0


def _log(message: str) -> None:
    err_console.print(f"{time.strftime('%H:%M:%S')} {shown(message)}", soft_wrap=True)


class _LogProgress:
    """The part of :class:`rich.progress.Progress` the CLI uses, as log lines."""

    def __init__(self) -> None:
        self._tasks: dict[TaskID, dict[str, Any]] = {}
        self._t0 = time.monotonic()

    def __enter__(self) -> _LogProgress:
        return self

    def __exit__(self, *exc: object) -> None:
        for task in self._tasks.values():
            if exc[0] is None and task["logged"]:
                self._emit(task, final=True)

    def add_task(self, description: str, total: float | None = None, **_: Any) -> TaskID:
        tid = TaskID(len(self._tasks))
        self._tasks[tid] = {
            "description": description,
            "total": total,
            "completed": 0.0,
            "last": time.monotonic(),
            "logged": False,
        }
        return tid

    def advance(self, task_id: TaskID, advance: float = 1) -> None:
        self.update(task_id, advance=advance)

    def update(
        self,
        task_id: TaskID,
        *,
        description: str | None = None,
        completed: float | None = None,
        total: float | None = None,
        advance: float | None = None,
        **_: Any,
    ) -> None:
        task = self._tasks[task_id]
        if description is not None:
            task["description"] = description
        if total is not None:
            task["total"] = total
        if completed is not None:
            task["completed"] = completed
        if advance is not None:
            task["completed"] += advance
        if time.monotonic() - task["last"] >= LOG_EVERY_S:
            self._emit(task)

    def _emit(self, task: dict[str, Any], final: bool = False) -> None:
        task["last"] = time.monotonic()
        task["logged"] = True
        done = f"{task['completed']:g}" + (f"/{task['total']:g}" if task["total"] else "")
        elapsed = task["last"] - self._t0
        _log(f"{task['description']}: {done} {'done' if final else ''} ({elapsed:.0f} s)")


def progress() -> Progress | _LogProgress:
    """Progress on stderr: a rich bar on a terminal, periodic log lines elsewhere."""
    if not err_console.is_terminal:
        return _LogProgress()
    return Progress(
        SpinnerColumn(),
        _Description(),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=err_console,
        transient=True,
    )


@contextlib.contextmanager
def status(message: str) -> Iterator[None]:
    """A spinner with ``message`` on stderr while the block runs.

    Not on a terminal: a line every :data:`LOG_EVERY_S` seconds while the
    block runs, and one when it ends if any was written.
    """
    if err_console.is_terminal:
        with err_console.status(Text(visible(message))):
            yield
        return
    t0 = time.monotonic()
    stop = threading.Event()

    logged = threading.Event()

    def heartbeat() -> None:
        while not stop.wait(LOG_EVERY_S):
            logged.set()
            _log(f"{message} (still running, {time.monotonic() - t0:.0f} s)")

    thread = threading.Thread(target=heartbeat, daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()
    if logged.is_set():
        _log(f"{message} done in {time.monotonic() - t0:.1f} s")


class Outputs:
    """The outputs of one command: all of them, or none that this run created.

    Each output is written atomically by its writer; this adds the set: when
    a later output fails (a full disk, a signal), the ones this run created
    before it are removed again, so a failed run leaves no new file behind
    (an output that existed before was replaced by then and stays, new).
    A file-system refusal becomes one line naming the output's option. Use:
    ``with Outputs() as out: out.write(path, "--json", writer, *args)`` for
    each output, in the order they are written.
    """

    def __init__(self) -> None:
        self._created: list[Path] = []

    def __enter__(self) -> Outputs:
        return self

    def __exit__(self, kind: type[BaseException] | None, *rest: object) -> None:
        if kind is not None:
            self.undo()

    def write(
        self, path: Any, option: str, writer: Callable[..., Any], *args: Any, **kw: Any
    ) -> Any:
        """Run ``writer(*args, **kw)``, which writes ``path``; remember it if it is new."""
        from robolobe.errors import InputError

        target = Path(path)
        existed = target.exists()
        try:
            result = writer(*args, **kw)
        except OSError as exc:
            self.undo()
            raise InputError(
                f"cannot write {visible(target)}: {exc.strerror or exc}", source=option
            ) from None
        if not existed and target.exists():
            self._created.append(target)
        return result

    def undo(self) -> None:
        """Remove the outputs this run created (newest first)."""
        for p in reversed(self._created):
            with contextlib.suppress(OSError):
                if p.is_dir() and not p.is_symlink():
                    shutil.rmtree(p)
                else:
                    p.unlink()
        self._created.clear()
