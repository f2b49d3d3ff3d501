"""``robolobe plan``, ``robolobe compare``, ``robolobe batch``: chatter-free toolpath plans."""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer
from rich.table import Table

from robolobe._text import count
from robolobe.cli._common import console, err_console, labelled, progress, shown, status
from robolobe.errors import EXIT_INPUT, InfeasibleError, InputError

if TYPE_CHECKING:
    from robolobe.plan._summary import PlanSummary

__all__ = ["EXAMPLE_JOB", "EXAMPLE_PATH", "example_files", "register"]

#: The bundled example that ``robolobe plan`` runs without arguments.
EXAMPLE_PATH = "pocket.nc"
EXAMPLE_JOB = "job_A_pocket.toml"


def example_files() -> tuple[Path, Path]:
    """Paths of the bundled example toolpath and job."""
    base = resources.files("robolobe.data").joinpath("examples")
    return Path(str(base.joinpath(EXAMPLE_PATH))), Path(str(base.joinpath(EXAMPLE_JOB)))


def _print_summary(s: PlanSummary, out: Path) -> None:
    t = Table(title=f"robolobe plan: {Path(s.path).name}", show_header=False)
    t.add_column("", style="bold")
    t.add_column("")
    t.add_row("robot / modes", f"{s.robot} / {s.mode_source}")
    t.add_row("waypoints (cutting)", f"{s.n_waypoints} ({s.n_cut})")
    if s.passes:
        deep = [r for r in s.passes if r["program_depth_mm"] > 0]
        t.add_row(
            "engagement",
            f"each move's own ({s.engagement}); {count(len(deep), 'cutting section')}",
        )
        for r in deep[:6]:
            t.add_row(
                f"  {r['lines']}",
                f"{r['passes']} x {r['depth_per_pass_mm']:.3f} mm of {r['program_depth_mm']:.3f} "
                f"mm at {r['rpm_min']:.0f}-{r['rpm_max']:.0f} rpm"
                + (f" (set by {r['set_by']})" if r["set_by"] else ""),
            )
        if len(deep) > 6:
            t.add_row("", f"... {len(deep) - 6} more sections in summary.json")
    else:
        t.add_row("depth per pass", f"{s.depth_mm:.3f} mm (cut.radial_width_mm)")
    t.add_row("speed", f"{s.rpm_min:.0f} - {s.rpm_max:.0f} rpm ({s.speed_mode}, {s.method})")
    t.add_row("MRR", f"{s.mrr_cm3_per_min:.1f} cm^3/min")
    t.add_row("cycle time", f"{s.cycle_time_s:.2f} s")
    at = s.min_margin_at
    t.add_row("minimum margin", f"{s.min_margin:.3f} at {at.source} (waypoint {at.waypoint})")
    for g, name in (
        (s.vs_best_constant_speed, "vs best constant speed"),
        (s.vs_programmed_speed, "vs programmed speed"),
    ):
        if g is not None:
            gain = g.mrr_gain_pct
            txt = f"MRR {gain:+.1f} %" if gain is not None else "baseline infeasible"
            t.add_row(name, f"{txt} ({g.depth_mm:.3f} mm at {g.rpm_mean:.0f} rpm)")
    console.print(t)
    for note in s.notes:
        err_console.print(labelled("note:", "yellow", note))
    from robolobe.plan.report import OUTPUTS

    written = [n for n in OUTPUTS if (Path(out) / n).exists()]
    names = ", ".join(n + "/" if (Path(out) / n).is_dir() else n for n in written)
    console.print(f"outputs in {shown(out)}/ ({names})", highlight=False)


# Toolpath reader options (job section [path]); a flag given here overrides the job.
_Units = Annotated[
    str | None,
    typer.Option(
        help="Units where the file states none: auto, mm, inch (G-code, APT).", show_default=False
    ),
]
_ToolDirection = Annotated[
    str | None,
    typer.Option(
        help="Tool-frame axis along the working direction: z or x (KRL, RAPID).", show_default=False
    ),
]
_Coordinates = Annotated[
    str | None,
    typer.Option(
        help="workpiece (as written) or machine (APT MSYS, KRL $BASE, RAPID wobjdata).",
        show_default=False,
    ),
]
_RotaryAxes = Annotated[
    str | None,
    typer.Option(
        help="G-code A/B/C words: auto (refused without TCP), head or table.", show_default=False
    ),
]
_CircleAxis = Annotated[
    str | None,
    typer.Option(help="APT CIRCLE sense about its axis: auto (from tangency, default), "
                      "cw (Siemens NX) or ccw (CATIA).",
                 show_default=False),
]  # fmt: skip


def _path_opts(**given: str | None) -> dict[str, str]:
    """Reader options given on the command line (validated against their choices)."""
    from robolobe.plan.paths import READER_OPTIONS

    out = {}
    for key, value in given.items():
        if value is None:
            continue
        choices = READER_OPTIONS[key] or ()
        if value not in choices:
            flag = "--" + key.replace("_", "-")
            raise InputError(f"{flag}: expected one of {list(choices)}, found {value!r}")
        out[key] = value
    return out


def _with_path_opts(j: Any, opts: dict[str, str]) -> Any:
    return j.replace(path_options={**j.path_options, **opts}) if opts else j


#: The compare command's table: (header, column of Comparison.table, number format or None).
_COMPARE_COLUMNS: tuple[tuple[str, str, str | None], ...] = (
    ("robot", "robot", None),
    ("status", "status", None),
    ("depth\nmm", "depth_mm", "{:.2f}"),
    ("speed\nrpm", "rpm_min", None),
    ("MRR\ncm3/min", "mrr_cm3_per_min", "{:.1f}"),
    ("cycle\ns", "cycle_time_s", "{:.1f}"),
    ("passes", "passes", "{:.0f}"),
    ("part\ns", "part_time_s", "{:.1f}"),
    ("min\nmargin", "min_margin", "{:.2f}"),
    ("worst\nwaypoint", "worst_source", None),
)


def _compare_table(table: Any, title: str) -> Table:
    """The terminal table of a comparison: one row per robot, one format per column."""
    import pandas as pd
    from rich import box

    # per part when the job gives the stock (passes x cycle), else per pass: one of the two
    per_part = "part_time_s" in table and bool(pd.notna(table["part_time_s"]).any())
    skip = {"cycle_time_s"} if per_part else {"passes", "part_time_s"}
    cols = [c for c in _COMPARE_COLUMNS if c[1] not in skip]
    t = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False, collapse_padding=True)
    for label, _, fmt in cols:
        numeric = fmt is not None or label.startswith("speed")
        t.add_column(
            label, justify="right" if numeric else "left", no_wrap=numeric, overflow="fold"
        )
    for r in table.to_dict(orient="records"):
        t.add_row(*[_compare_cell(r, key, fmt) for _, key, fmt in cols])
    return t


def _compare_cell(row: dict[str, Any], key: str, fmt: str | None) -> str:
    """One cell of the compare table: numbers in their column's format, blank when absent."""
    v = row.get(key)
    ok = row.get("status") == "ok"
    if key == "status" and ok and bool(row.get("placement_adjusted")):
        return "ok, moved"  # the workpiece is not where the job puts it: see the note
    if v is None or (isinstance(v, float) and v != v):
        return ""
    if key == "rpm_min":  # the speed range in one cell
        lo, hi = float(v), float(row.get("rpm_max", v))
        return f"{lo:.0f}" if round(lo) == round(hi) else f"{lo:.0f}-{hi:.0f}"
    if fmt is not None and isinstance(v, (int, float)):
        return fmt.format(v)
    return shown(v)


def register(app: typer.Typer) -> None:
    """Add the ``plan``, ``compare`` and ``batch`` commands to ``app``."""

    @app.command("plan")
    def plan_command(
        path: Annotated[
            Path | None,
            typer.Argument(
                help="Toolpath: G-code (.nc, .ngc, .tap, ...), APT/CL (.apt, .cl), KUKA KRL "
                "(.src), ABB RAPID (.mod), or a waypoint table (.csv, .parquet). Without "
                "PATH and --job: the bundled example (pocket on robot A).",
            ),
        ] = None,
        job: Annotated[
            Path | None,
            typer.Option("--job", "-j", help="Job file (TOML, robolobe-job/1; units in the keys)."),
        ] = None,
        output: Annotated[
            Path, typer.Option("-o", "--output", help="Output directory (created; files replaced).")
        ] = Path("robolobe-out"),
        plots: Annotated[
            bool, typer.Option("--plots/--no-plots", help="Write the PNG plots.")
        ] = True,
        html: Annotated[bool, typer.Option("--html/--no-html", help="Write report.html.")] = True,
        robust: Annotated[
            bool | None,
            typer.Option(
                "--robust/--nominal",
                help="Plan on the lower bound of the prediction spread (overrides the job).",
            ),
        ] = None,
        refine: Annotated[
            bool,
            typer.Option("--refine/--no-refine", help="casadi/IPOPT refinement of the search."),
        ] = True,
        waypoints: Annotated[
            str,
            typer.Option(
                "--waypoints",
                help="The per-waypoint table: csv (waypoints.csv), parquet "
                "(waypoints.parquet; needs pyarrow) or none (long paths). `robolobe verify` "
                "reads the full waypoints.csv.",
            ),
        ] = "csv",
        waypoints_every: Annotated[
            int,
            typer.Option(
                "--waypoints-every",
                min=1,
                help="Thin the table: one row per block of K waypoints, the one with the "
                "smallest margin (1: every waypoint).",
            ),
        ] = 1,
        units: _Units = None,
        tool_direction: _ToolDirection = None,
        coordinates: _Coordinates = None,
        rotary_axes: _RotaryAxes = None,
        circle_axis: _CircleAxis = None,
        program_format: Annotated[
            str | None,
            typer.Option(
                "--program-format",
                help="Write OUT/program.<ext> in this dialect (gcode, apt, krl, rapid, table; "
                "default: the one read; another only where a translation is defined).",
            ),
        ] = None,
        program: Annotated[
            bool,
            typer.Option(
                "--program/--no-program",
                help="Write the program back with the plan's speeds, feeds and passes.",
            ),
        ] = True,
    ) -> None:
        """Plan spindle speed and depth along a toolpath (chatter-free, per waypoint).

        Reads the path and the job, solves the robot's posture at every waypoint,
        predicts its modes, builds stability lobes per waypoint and picks one depth
        per pass and a speed schedule with the best material removal rate that
        stays stable (depth <= a_lim / safety factor) within the spindle's speed,
        power and torque limits. Writes waypoints.csv, summary.json, plots and
        report.html. Exit code 3 when no feasible plan exists.
        """
        from robolobe.plan._plots import PlotWorker

        # started first: it imports matplotlib on the other core while we plan
        with PlotWorker(None if plots or html else 0) as worker:
            from robolobe._atomic import check_output_dir
            from robolobe.plan.job import load_job
            from robolobe.plan.pipeline import plan_path
            from robolobe.plan.report import (
                WAYPOINT_FORMATS,
                output_files,
                require_pyarrow,
                write_outputs,
            )

            check_output_dir(
                output,
                "--output",
                writes=output_files(plots=plots, html_report=html, waypoints=waypoints),
            )
            from robolobe.plan.program import check_program_format

            check_program_format(program_format)
            if waypoints not in WAYPOINT_FORMATS:
                expected = ", ".join(WAYPOINT_FORMATS)
                raise InputError(f"--waypoints: expected one of {expected}, found {waypoints!r}")
            if waypoints == "parquet":
                require_pyarrow("--waypoints parquet")
            if path is None and job is None:
                path, job = example_files()
                err_console.print(f"running the bundled example: {path.name} with {job.name}")
            elif path is None or job is None:
                raise InputError("give both PATH and --job (or neither, for the bundled example)")
            check_program_format(program_format, path)
            j = _with_path_opts(
                load_job(job),
                _path_opts(units=units, tool_direction=tool_direction, coordinates=coordinates,
                           rotary_axes=rotary_axes, circle_axis=circle_axis),
            )  # fmt: skip
            if robust is not None:
                import dataclasses

                j = j.replace(plan=dataclasses.replace(j.plan, robust=robust))
            with status("planning ..."):
                res = plan_path(path, j, refine=refine)
            with status("writing outputs ..."):
                write_outputs(
                    res,
                    output,
                    plots=plots,
                    html_report=html,
                    waypoints=waypoints,
                    waypoints_every=waypoints_every,
                    worker=worker,
                    option="--output",
                    program=program,
                    program_format=program_format,
                )
            _print_summary(res.summary, output)

    @app.command(
        "compare",
        context_settings={"allow_extra_args": False},
    )
    def compare_command(
        path: Annotated[Path, typer.Argument(help="Toolpath (any supported format).")],
        more_robots: Annotated[
            list[str] | None,
            typer.Argument(help="More robots after --robots (--robots A B C).", show_default=False),
        ] = None,
        job: Annotated[
            Path | None,
            typer.Option("--job", "-j", help="Job file (TOML, robolobe-job/1). Required."),
        ] = None,
        robots: Annotated[
            list[str] | None,
            typer.Option(
                "--robots",
                help="Robots: A, B, C or robot files; --robots A B C, --robots A,B,C or repeated. "
                "Default: A B C.",
            ),
        ] = None,
        output: Annotated[Path, typer.Option("-o", "--output", help="Output directory.")] = Path(
            "robolobe-compare"
        ),
        refine: Annotated[
            bool,
            typer.Option("--refine/--no-refine", help="casadi/IPOPT refinement of the search."),
        ] = True,
        units: _Units = None,
        tool_direction: _ToolDirection = None,
        coordinates: _Coordinates = None,
        rotary_axes: _RotaryAxes = None,
        circle_axis: _CircleAxis = None,
    ) -> None:
        """Plan the same job on several robots, side by side.

        Where the job's placement does not reach the path on a robot, a placement
        in front of that robot that reaches it is searched (or the robot is
        reported unreachable). Writes compare.csv/json/png and each robot's plan.
        """
        from robolobe._atomic import check_output_dir
        from robolobe.plan.compare import (
            COMPARE_FILES,
            compare_robots,
            robot_folder_notes,
            write_comparison,
        )
        from robolobe.plan.job import load_job

        check_output_dir(output, "--output", writes=COMPARE_FILES)
        if job is None:
            raise InputError("--job: expected a job file, found none")
        names: list[str] = []
        for item in [*(robots or []), *(more_robots or [])]:
            names += [p for p in item.replace(",", " ").split() if p]
        if more_robots and not robots:
            raise InputError(f"unexpected arguments {more_robots}; robots go after --robots")
        names = names or ["A", "B", "C"]
        j = _with_path_opts(
            load_job(job),
            _path_opts(units=units, tool_direction=tool_direction, coordinates=coordinates,
                       rotary_axes=rotary_axes, circle_axis=circle_axis),
        )  # fmt: skip
        with status(f"planning on {', '.join(names)} ..."):
            cmp = compare_robots(path, j, names, refine=refine)
        any_ok = bool((cmp.table["status"] == "ok").any())
        if any_ok:
            with status("writing outputs ..."):
                write_comparison(cmp, output)
        console.print(_compare_table(cmp.table, f"robolobe compare: {path.name}"))
        from robolobe.plan.compare import moved_note

        for r in cmp.table.to_dict(orient="records"):
            if r.get("status") == "ok" and bool(r.get("placement_adjusted")):
                note = moved_note(str(r["robot"]), r["placement_xyz_m"])
                console.print(labelled("note:", "yellow", note))
        for r in cmp.table.to_dict(orient="records"):
            if r.get("status") != "ok":
                robot, msg = str(r["robot"]), str(r.get("message", ""))
                msg = msg.removeprefix(f"{robot}: ")  # the row names the robot already
                err_console.print(labelled(f"{shown(robot)} ({r['status']}):", "yellow", msg))
        if not any_ok:
            # no robot can do the job: a failure, not a comparison (nothing written)
            err = InfeasibleError if (cmp.table["status"] == "infeasible").all() else InputError
            raise err(f"no robot of {', '.join(names)} can run this job (see the table above)")
        for note in robot_folder_notes([str(r) for r in cmp.table["robot"]]):
            err_console.print(labelled("note:", "yellow", note))
        console.print(
            f"outputs in {shown(output)}/ (compare.csv, compare.json, compare.png, "
            "one folder per robot)",
            highlight=False,
        )

    @app.command("batch")
    def batch_command(
        paths: Annotated[list[Path], typer.Argument(help="Toolpaths (any supported format).")],
        job: Annotated[
            Path | None,
            typer.Option("--job", "-j", help="Job file (TOML, robolobe-job/1). Required."),
        ] = None,
        output: Annotated[Path, typer.Option("-o", "--output", help="Output directory.")] = Path(
            "robolobe-batch"
        ),
        scheduler: Annotated[
            str | None,
            typer.Option(
                "--scheduler",
                help="Dask scheduler address (tcp://host:8786); default: a local process pool.",
            ),
        ] = None,
        workers: Annotated[
            int | None,
            typer.Option("--workers", "-w", min=1, help="Local worker processes (default: CPUs)."),
        ] = None,
        per_path: Annotated[
            bool,
            typer.Option("--per-path/--table-only", help="Also write each path's plan outputs."),
        ] = False,
        fmt: Annotated[
            str,
            typer.Option(
                "--format", help="auto (Parquet if pyarrow is installed), parquet or csv."
            ),
        ] = "auto",
        refine: Annotated[
            bool,
            typer.Option("--refine/--no-refine", help="casadi/IPOPT refinement of the search."),
        ] = True,
        units: _Units = None,
        tool_direction: _ToolDirection = None,
        coordinates: _Coordinates = None,
        rotary_axes: _RotaryAxes = None,
        circle_axis: _CircleAxis = None,
    ) -> None:
        """Plan many toolpaths with one job, in parallel; one results table.

        A failing path (bad file, unreachable, infeasible) is reported in the table
        and does not stop the others; the exit code is 2 when any path failed.
        """
        from robolobe.plan.batch import BATCH_FILES, batch_plan, path_folders, write_batch
        from robolobe.plan.job import load_job

        if job is None:
            raise InputError("--job: expected a job file, found none")
        if fmt not in ("auto", "parquet", "csv"):
            raise InputError(f"--format: expected auto, parquet or csv, found {fmt!r}")
        from robolobe._atomic import check_output_dir, not_a_file

        check_output_dir(output, "--output", writes=BATCH_FILES)
        for p in paths:  # a missing file is a typo, not a row after hours of planning
            if not p.is_file():
                hint = (
                    " (a shell pattern that matched nothing?)" if set("*?[") & set(str(p)) else ""
                )
                raise InputError(f"expected a toolpath file, found {not_a_file(p)}{hint}", str(p))
        if fmt == "parquet":
            try:
                import pyarrow  # noqa: F401
            except ImportError:
                raise InputError(
                    "--format parquet needs pyarrow (pip install 'robolobe[parquet]'), "
                    "found it missing; use --format csv"
                ) from None
        j = _with_path_opts(
            load_job(job),
            _path_opts(units=units, tool_direction=tool_direction, coordinates=coordinates,
                       rotary_axes=rotary_axes, circle_axis=circle_axis),
        )  # fmt: skip
        rows = []
        with progress() as bar:
            task = bar.add_task("planning", total=len(paths))
            for row in batch_plan(
                [str(p) for p in paths],
                j,
                scheduler=scheduler,
                workers=workers,
                out_dir=str(output) if per_path else None,
                refine=refine,
            ):
                rows.append(row)
                bar.advance(task)
                if row["status"] != "ok":
                    where, msg = str(row["path"]), str(row["message"])
                    msg = msg.removeprefix(f"{where}: ")  # the line names the path already
                    err_console.print(
                        labelled(f"{row['status']}:", "yellow", f"{where}: {msg}"),
                        highlight=False,
                    )
        table = write_batch(rows, output, fmt=fmt)
        if per_path:
            for note in path_folders([str(p) for p in paths]).notes:
                err_console.print(labelled("note:", "yellow", note))
        ok = sum(r["status"] == "ok" for r in rows)
        console.print(f"{ok} of {count(len(rows), 'path')} planned; table: {shown(table)}")
        if ok < len(rows):
            raise typer.Exit(code=EXIT_INPUT)
