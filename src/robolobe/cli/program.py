"""``robolobe program``: a plan folder's program written with its speeds, feeds and passes."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.markup import escape

from robolobe.cli._common import console, status

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``program`` command to ``app``."""

    @app.command("program")
    def program_command(
        plan_dir: Annotated[
            Path,
            typer.Argument(help="Plan folder (robolobe plan -o DIR: waypoints.csv, summary.json)."),
        ],
        output: Annotated[
            Path,
            typer.Option(
                "-o", "--output", help="Program file to write (.nc, .apt, .src, .mod, .csv)."
            ),
        ],
        job: Annotated[
            Path | None,
            typer.Option(
                "--job", "-j", help="The plan's job (default: the one summary.json names)."
            ),
        ] = None,
        program_format: Annotated[
            str | None,
            typer.Option(
                "--program-format",
                help="Dialect (gcode, apt, krl, rapid, table; default: the one the plan read).",
            ),
        ] = None,
    ) -> None:
        """Write the program a plan read, with the plan's spindle speed and feed per move.

        The source program must be where the plan read it, unchanged (its
        SHA-256 is in summary.json). The written program is read back and
        must reproduce every move; the speed follows the plan's at every
        move (a plan folder holds no lobes to check a held speed against).
        Exit code 0: written; 2: bad input (nothing written, an earlier file
        left as it was).
        """
        from robolobe.plan.program import write_program

        with status("writing the program ..."):
            out = write_program(plan_dir, output, job=job, fmt=program_format)
        console.print(f"program written: {escape(str(out))}")
