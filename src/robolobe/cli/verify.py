"""``robolobe verify``: an existing plan evaluated on another robot, model or campaign."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from robolobe._text import count
from robolobe.cli._common import console, err_console, labelled, shown, status

__all__ = ["EXIT_CHATTER", "register"]

#: Exit code when a waypoint of the plan is beyond its limit on the verifying modes.
EXIT_CHATTER = 4


def register(app: typer.Typer) -> None:
    """Add the ``verify`` command to ``app``."""

    @app.command("verify")
    def verify_command(
        plan_dir: Annotated[
            Path,
            typer.Argument(help="Plan folder (robolobe plan -o DIR: waypoints.csv, summary.json)."),
        ],
        robot: Annotated[
            str | None,
            typer.Option("--robot", help="Robot (A, B, C or a robot .toml): its twin's modes."),
        ] = None,
        effects: Annotated[
            Path | None,
            typer.Option("--effects", help="effects.toml added to the --robot twin."),
        ] = None,
        model: Annotated[
            str | None,
            typer.Option("--model", help="tl model file (.npz) or A, B, C (shipped networks)."),
        ] = None,
        campaign: Annotated[
            Path | None,
            typer.Option(
                "--campaign",
                help="Hammer-test campaign folder: identified, its robot file calibrated to it.",
            ),
        ] = None,
        job: Annotated[
            Path | None,
            typer.Option(
                "--job", "-j", help="The plan's job (default: the one summary.json names)."
            ),
        ] = None,
        output: Annotated[
            Path | None,
            typer.Option(
                "-o",
                "--output",
                help="Output folder (default PLAN_DIR/verify): verify.csv, "
                "verify.json, plots/verify_margin.png.",
            ),
        ] = None,
        plots: Annotated[bool, typer.Option("--plots/--no-plots", help="Write the plot.")] = True,
    ) -> None:
        """Evaluate a plan on other robot modes with the planner's own modelling.

        Give one of --robot, --model or --campaign. Reports the true margin
        (limit / depth) at every cutting waypoint and the waypoints predicted to
        chatter with their file:line. Exit code 0: no waypoint beyond its limit;
        4: some are; 2: bad input (nothing written).
        """
        from robolobe._atomic import check_output_dir
        from robolobe.plan.verify import VERIFY_FILES

        check_output_dir(
            output if output is not None else plan_dir / "verify", "--output", writes=VERIFY_FILES
        )

        from robolobe.plan.verify import verify_plan, write_verify

        with status("verifying ..."):
            res = verify_plan(
                plan_dir, robot=robot, effects=effects, model=model, campaign=campaign, job=job
            )
        out = output if output is not None else plan_dir / "verify"
        write_verify(res, out, plots=plots)
        s = res.summary
        console.print(
            f"{shown(plan_dir)} on {shown(res.mode_source)} (plan made on "
            f"{shown(s['plan_mode_source'])}): {s['n_beyond_limit']} of "
            f"{count(s['n_bounded'], 'cutting waypoint')} beyond the limit, "
            f"{s['n_inside_safety_factor']} inside the safety factor {res.safety_factor:g}; "
            "minimum margin "
            + (f"{res.min_margin:.3f} at {shown(res.min_margin_at)}" if s["min_margin"] else "-"),
            highlight=False,
        )
        for where in res.chatter[:20]:
            err_console.print(labelled("chatter predicted:", "red", where))
        if len(res.chatter) > 20:
            err_console.print(f"... and {len(res.chatter) - 20} more (verify.csv)")
        console.print(f"outputs in {shown(out)}/ (verify.csv, verify.json, plots/)")
        if not res.ok:
            raise typer.Exit(EXIT_CHATTER)
