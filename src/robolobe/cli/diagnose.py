"""``robolobe diagnose``: find, name and fit the physics a robot model leaves out."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from robolobe._workers import MAX_WORKERS
from robolobe.errors import InputError

__all__ = ["parse_band", "parse_families", "register"]


def parse_band(text: str) -> tuple[float, float]:
    """``"2,40"`` -> (2.0, 40.0) Hz (InputError if bad)."""
    try:
        lo, hi = (float(x) for x in text.split(","))
    except ValueError:
        raise InputError(
            f"expected two frequencies 'low,high' in Hz, e.g. 2,40; found {text!r}",
            source="--band-hz",
        ) from None
    if not 0 <= lo < hi:
        raise InputError(f"expected 0 <= low < high, found {text!r}", source="--band-hz")
    return lo, hi


def parse_families(text: str | None) -> tuple[str, ...] | None:
    """``"added_mass,tool_mode"`` -> names (None: all); InputError on unknown names."""
    if text is None:
        return None
    from robolobe.diagnose.library import FAMILIES

    names = tuple(t.strip() for t in text.split(",") if t.strip())
    bad = [n for n in names if n not in FAMILIES]
    if not names or bad:
        raise InputError(
            f"expected a comma list of {', '.join(FAMILIES)}; found {text!r}", source="--candidates"
        )
    return names


def register(app: typer.Typer) -> None:
    """Add the ``diagnose`` command to ``app``."""

    @app.command("diagnose")
    def diagnose_cmd(
        campaign: Annotated[
            Path, typer.Argument(help="Campaign folder (campaign.toml, postures.csv, frf.csv).")
        ],
        json_out: Annotated[
            Path, typer.Option("--json", help="Write the diagnosis (JSON) to this file.")
        ],
        report: Annotated[
            Path | None,
            typer.Option("--report", help="Write an HTML report with figures to this folder."),
        ] = None,
        updated_model: Annotated[
            Path | None,
            typer.Option(
                "--updated-model",
                help="Write the corrected model (robot.toml + effects.toml) to this folder.",
            ),
        ] = None,
        robot: Annotated[
            str | None,
            typer.Option(
                "--robot", help="Nominal robot (A, B, C or .toml) instead of the campaign's."
            ),
        ] = None,
        band_hz: Annotated[
            str | None,
            typer.Option(
                "--band-hz",
                help="Analysis band 'low,high' in Hz (default: the whole recorded band from 1 Hz).",
            ),
        ] = None,
        candidates: Annotated[
            str | None,
            typer.Option(
                "--candidates", help="Comma list of candidate families to test (default: all)."
            ),
        ] = None,
        folds: Annotated[
            int,
            typer.Option(
                "--folds",
                help="Cross-validation folds over postures (at most one per posture).",
            ),
        ] = 5,
        jobs: Annotated[
            int,
            typer.Option(
                "--jobs",
                "-j",
                help="Worker processes that fit each round's candidates (2 on a 2-core "
                "machine: x1.5, the same fits to 1e-9).",
            ),
        ] = 1,
    ) -> None:
        """Compare a campaign with its nominal robot model, name the missing physics, fit it.

        Locates the mismatch (posture x frequency) over the whole recorded
        band, fits every candidate (the robot file's own values off, added
        mass, joint stiffness/damping, gravity stiffening, coupled joints,
        base compliance, tool/bracket modes, servo holding modes, TCP offset,
        sensor rotation/gain/delay, hammer direction, link flexibility,
        friction) to all postures at once, and names candidates one after
        another while each beats the noise on held-out postures. If the
        best model still misses the held-out postures by more than 1.5x the
        noise, the verdict is 'unexplained' and the candidates are listed
        only as the closest ones. Exponential-window settings come from the
        campaign's [test] table (window_end, duration_s); hammer force levels
        from an optional force_N column of postures.csv.
        """
        from robolobe._atomic import check_output_dir, check_output_file
        from robolobe.diagnose.report import REPORT_FILES
        from robolobe.diagnose.updated_model import UPDATED_MODEL_FILES

        check_output_file(json_out, "--json")
        if report is not None:
            check_output_dir(report, "--report", writes=REPORT_FILES)
        if updated_model is not None:
            check_output_dir(updated_model, "--updated-model", writes=UPDATED_MODEL_FILES)

        import dataclasses

        from robolobe._atomic import atomic_write_text
        from robolobe.cli._common import Outputs, console, labelled, progress, shown
        from robolobe.diagnose.pipeline import DiagnoseSettings, diagnose
        from robolobe.diagnose.report import write_report
        from robolobe.diagnose.schema import to_report
        from robolobe.diagnose.selection import SelectionSettings
        from robolobe.diagnose.updated_model import write_updated_model
        from robolobe.robots import load_robot

        if folds < 2:
            raise InputError(f"expected at least 2 folds, found {folds}", source="--folds")
        if not 1 <= jobs <= MAX_WORKERS:
            raise InputError(
                f"expected 1 to {MAX_WORKERS} worker processes, found {jobs}", source="--jobs"
            )
        settings = DiagnoseSettings(
            band_hz=None if band_hz is None else parse_band(band_hz),
            families=parse_families(candidates),
            selection=dataclasses.replace(SelectionSettings(), n_folds=folds),
            n_jobs=jobs,
        )
        nominal = load_robot(robot) if robot is not None else None
        with progress() as bar:
            task = bar.add_task("diagnosing", total=None)

            def tick(stage: str, done: int, total: int) -> None:
                bar.update(task, description=stage, completed=done, total=total)

            result = diagnose(campaign, robot=nominal, settings=settings, progress=tick)
        rep = to_report(result)
        with Outputs() as out:
            out.write(
                json_out, "--json", atomic_write_text, json_out, rep.model_dump_json(indent=2)
            )
            if report is not None:
                out.write(report, "--report", write_report, result, report)
            if updated_model is not None:
                out.write(
                    updated_model,
                    "--updated-model",
                    write_updated_model,
                    updated_model,
                    result.robot,
                    result.effects,
                    note=result.summary,
                )
        if updated_model is not None and result.unexplained and result.effects:
            console.print(
                "the updated model holds partial corrections only (the recordings are unexplained)",
                style="yellow",
            )
        console.print(labelled("verdict:", "bold", rep.verdict_label))
        console.print(result.summary, soft_wrap=True)
        outs = [shown(json_out)] + [shown(p) for p in (report, updated_model) if p is not None]
        console.print(f"wrote {', '.join(outs)} ({result.elapsed_s:.0f} s)")
