"""``robolobe check``: a program checked as written, every move at its own S, F and engagement."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.table import Table

from robolobe._text import count
from robolobe.cli._common import console, err_console, labelled, shown, status
from robolobe.cli.verify import EXIT_CHATTER

__all__ = ["register"]

#: Lines at risk printed on the terminal (all are in check.csv / check.json).
SHOWN_LINES = 20


def register(app: typer.Typer) -> None:
    """Add the ``check`` command to ``app``."""

    @app.command("check")
    def check_command(
        program: Annotated[
            Path,
            typer.Argument(
                help="Program (G-code, APT, KRL, RAPID, CSV), e.g. a plan's OUT/program.<ext>."
            ),
        ],
        job: Annotated[
            Path,
            typer.Option("--job", "-j", help="Job file (robot, tool, material, spindle, [stock])."),
        ],
        output: Annotated[
            Path,
            typer.Option(
                "-o",
                "--output",
                help="Output folder: check.csv, check.json, check_margin.png, check_report.html.",
            ),
        ],
        rpm: Annotated[
            float | None,
            typer.Option("--rpm", help="Spindle speed [rpm] where the program states no S."),
        ] = None,
        feed: Annotated[
            float | None,
            typer.Option("--feed", help="Feed [mm/min] where the program states no F."),
        ] = None,
        plots: Annotated[bool, typer.Option("--plots/--no-plots", help="Write the plot.")] = True,
    ) -> None:
        """Check every cutting move of a program at its own S, F, depth and engagement.

        The limit of each move comes from the planner's own modelling (robot
        modes at its posture, tool modes, converged lobes at the move's
        engagement, queried at the programmed S); the depth and the radial
        engagement from the job's [stock] (without it, the stock the program
        implies, with a note). Exit code 0: no move beyond its limit; 4: some
        are; 2: bad input (nothing written).
        """
        from robolobe._atomic import check_output_dir
        from robolobe.plan.check import CHECK_FILES

        check_output_dir(output, "--output", writes=CHECK_FILES)

        from robolobe.plan.check import check_program, write_check

        with status("checking the program ..."):
            res = check_program(program, job, rpm=rpm, feed=feed)
        write_check(res, output, plots=plots)
        s = res.summary
        c = s["counts"]
        table = Table(title=f"{shown(Path(s['program']).name)} as written", title_justify="left")
        table.add_column("feed moves", justify="right")
        table.add_column("ok", justify="right")
        table.add_column(f"inside SF {res.safety_factor:g}", justify="right")
        table.add_column("beyond limit", justify="right")
        table.add_column("air", justify="right")
        table.add_column("plunge", justify="right")
        table.add_column("min margin")
        table.add_row(
            str(s["n_feed_moves"]),
            str(c["ok"]),
            str(c["inside SF"]),
            str(c["beyond limit"]),
            str(c["air"]),
            str(c["plunge"]),
            f"{res.min_margin:.3f}" if s["min_margin"] is not None else "-",
        )
        console.print(table)
        for note in res.notes:
            err_console.print(labelled("note:", "cyan", note))
        t = res.table
        risk = t[t["status"].isin(["beyond limit", "inside SF"])].sort_values("margin")
        for r in risk.head(SHOWN_LINES).itertuples():
            label = "beyond limit:" if r.status == "beyond limit" else "inside SF:"
            style = "red" if r.status == "beyond limit" else "yellow"
            err_console.print(
                labelled(
                    label,
                    style,
                    f"{r.source}:{r.line} S{r.rpm:g} F{r.feed_mm_per_min:g} a_e/D "
                    f"{r.ae_over_D:.2f} a_p {r.depth_mm:.3g} mm a_lim {r.a_lim_mm:.3g} mm "
                    f"margin {r.margin:.3f}",
                )
            )
        if len(risk) > SHOWN_LINES:
            err_console.print(
                f"... and {count(len(risk) - SHOWN_LINES, 'more move')} at risk (check.csv)"
            )
        if s["min_margin"] is not None:
            console.print(f"minimum margin {res.min_margin:.3f} at {shown(res.min_margin_at)}")
        console.print(
            f"{count(res.n_beyond, 'move')} beyond the limit; outputs in {shown(output)}/ "
            f"({', '.join(CHECK_FILES if plots else CHECK_FILES[:2] + CHECK_FILES[3:])})"
        )
        if not res.ok:
            raise typer.Exit(EXIT_CHATTER)
