"""``robolobe sld``: stability lobes of a tool point from a modes file."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from robolobe.cli._common import Outputs, console, err_console, labelled, shown, status
from robolobe.errors import InputError

__all__ = ["parse_rpm", "register"]

_DEFAULT_N = {"zoa": 1000, "sdm": 200}
#: Cap on the speed grid: 100k speeds resolve any lobe of a milling
#: spindle; more only costs memory and time.
MAX_RPM_POINTS = 100_000
#: Cap on the teeth of a milling cutter (large face mills have a few dozen).
MAX_TEETH = 200
#: Largest tool diameter and stick-out [mm] (the job file's bounds).
MAX_TOOL_DIAMETER_MM = 500.0
MAX_STICKOUT_MM = 1000.0


def parse_rpm(text: str, method: str) -> np.ndarray:
    """``MIN:MAX`` or ``MIN:MAX:N`` -> a uniform speed grid [rpm]."""
    parts = text.split(":")
    if len(parts) not in (2, 3):
        raise InputError(f"--rpm: expected MIN:MAX or MIN:MAX:N, found {text!r}")
    try:
        lo, hi = float(parts[0]), float(parts[1])
        n = int(parts[2]) if len(parts) == 3 else _DEFAULT_N[method]
    except ValueError:
        raise InputError(f"--rpm: expected numbers MIN:MAX[:N], found {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi <= 1e6):
        raise InputError(f"--rpm: expected 0 < MIN < MAX <= 1e6 rpm, found {text!r}")
    if not 2 <= n <= MAX_RPM_POINTS:
        raise InputError(f"--rpm: expected 2 <= N <= {MAX_RPM_POINTS} speeds, found {n}")
    return np.linspace(lo, hi, n)


def _tool_size(diameter_mm: float | None, stickout_mm: float | None) -> tuple[float, float] | None:
    """``--tool-diameter`` and ``--stickout`` [mm] -> (diameter, stick-out) [m], or None."""
    if diameter_mm is None and stickout_mm is None:
        return None
    if diameter_mm is None or stickout_mm is None:
        given = "--tool-diameter" if diameter_mm is not None else "--stickout"
        raise InputError(
            f"--tool-diameter and --stickout: expected both (mm) or neither, found only {given}"
        )
    if not (math.isfinite(diameter_mm) and 0 < diameter_mm <= MAX_TOOL_DIAMETER_MM):
        raise InputError(
            f"--tool-diameter: expected a diameter in (0, {MAX_TOOL_DIAMETER_MM:g}] mm, found "
            f"{diameter_mm:g}"
        )
    from robolobe.plan.job import STICKOUT_MIN_SHARE

    least = STICKOUT_MIN_SHARE * diameter_mm
    if not (math.isfinite(stickout_mm) and least <= stickout_mm <= MAX_STICKOUT_MM):
        raise InputError(
            f"--stickout: expected {least:g} to {MAX_STICKOUT_MM:g} mm (at least a quarter of "
            f"the {diameter_mm:g} mm diameter), found {stickout_mm:g}"
        )
    return diameter_mm * 1e-3, stickout_mm * 1e-3


def register(app: typer.Typer) -> None:
    """Add the ``sld`` command to ``app``."""

    @app.command("sld")
    def sld_command(
        modes: Annotated[
            Path,
            typer.Option(
                "--modes",
                help=(
                    "Tool-point modes CSV: dir,mode,f_hz,zeta,k_N_per_m "
                    "(dir xx = feed, yy = normal; xy cross terms allowed)."
                ),
            ),
        ],
        teeth: Annotated[int, typer.Option("--teeth", help="Number of teeth N.")],
        immersion: Annotated[
            float, typer.Option("--immersion", help="Radial immersion a_e/D in (0, 1].")
        ],
        rpm: Annotated[
            str,
            typer.Option(
                "--rpm", help="Speed grid MIN:MAX[:N] in rpm (N: 1000 for zoa, 200 for sdm)."
            ),
        ],
        output: Annotated[
            Path, typer.Option("-o", "--output", help="Output CSV with columns rpm,a_lim_mm.")
        ],
        kt: Annotated[
            float | None,
            typer.Option(
                "--kt", help="Tangential cutting coefficient Kt in N/m^2 (e.g. 7e8, not 700)."
            ),
        ] = None,
        kr: Annotated[
            float | None, typer.Option("--kr", help="Kr = Kn/Kt (radial over tangential).")
        ] = None,
        material: Annotated[
            str | None,
            typer.Option(
                "--material",
                help="Built-in material (e.g. Al7075-T6) for Kt/Kr; --kt/--kr override it.",
            ),
        ] = None,
        milling: Annotated[
            str, typer.Option("--milling", help="down (climb) or up (conventional).")
        ] = "down",
        method: Annotated[
            str,
            typer.Option(
                "--method", help="zoa (zero-order, fast) or sdm (semi-discretization, reference)."
            ),
        ] = "zoa",
        plot: Annotated[
            Path | None, typer.Option("--plot", help="Also write a PNG lobe plot.")
        ] = None,
        max_lobe: Annotated[
            int | None,
            typer.Option(
                "--max-lobe", help="Highest ZOA lobe number (default: enough for the lowest speed)."
            ),
        ] = None,
        intervals: Annotated[
            int, typer.Option("--intervals", help="SDM intervals per tooth period (2 to 400).")
        ] = 40,
        safety: Annotated[
            float | None,
            typer.Option("--safety", help="Draw a_lim/SAFETY as a safety line in the plot."),
        ] = None,
        tool_diameter: Annotated[
            float | None,
            typer.Option(
                "--tool-diameter",
                help="Cutter diameter in mm (with --stickout): each mode is checked against "
                "what a tool of that size can be (a stiffness in N/mm is refused).",
            ),
        ] = None,
        stickout: Annotated[
            float | None,
            typer.Option("--stickout", help="Tool stick-out from the holder in mm."),
        ] = None,
    ) -> None:
        """Stability lobes (limiting axial depth vs spindle speed) of one tool point."""
        from robolobe._atomic import check_output_file
        from robolobe.sld import (
            CuttingConditions,
            Material,
            get_material,
            stability_lobes,
        )
        from robolobe.sld.io import (
            SAFETY_RANGE,
            check_lobe_depth,
            check_modes_on_tool,
            read_modes_table,
            write_lobes_csv,
        )
        from robolobe.sld.sdm import MAX_SDM_INTERVALS

        check_output_file(output, "--output")
        if plot is not None:
            check_output_file(plot, "--plot")

        if method not in ("zoa", "sdm"):
            raise InputError(f"--method: expected zoa or sdm, found {method!r}")
        if milling not in ("down", "up"):
            raise InputError(f"--milling: expected down or up, found {milling!r}")
        if not 1 <= teeth <= MAX_TEETH:
            raise InputError(f"--teeth: expected an integer 1 to {MAX_TEETH}, found {teeth}")
        if safety is not None and not SAFETY_RANGE[0] <= safety <= SAFETY_RANGE[1]:
            raise InputError(
                f"--safety: expected a factor of {SAFETY_RANGE[0]:g} to {SAFETY_RANGE[1]:g}, "
                f"found {safety:g}"
            )
        if method == "sdm" and not 2 <= intervals <= MAX_SDM_INTERVALS:
            raise InputError(
                f"--intervals: expected an integer 2 to {MAX_SDM_INTERVALS}, found {intervals}"
            )
        try:
            if material is not None:
                mat = get_material(material, kt=kt, kr=kr)
            elif kt is None or kr is None:
                given = (
                    "only --kt" if kt is not None else "only --kr" if kr is not None else "neither"
                )
                raise InputError(
                    f"--kt and --kr: expected both (or --material NAME), found {given}"
                )
            else:
                mat = Material(name="user", kt=kt, kr=kr)
        except InputError as exc:  # name the option, not the library's argument
            for name, option in (("material: ", "--material"), ("Kt: ", "--kt"), ("Kr: ", "--kr")):
                if exc.source is None and exc.detail.startswith(name):
                    raise InputError(exc.detail.removeprefix(name), option) from None
            raise
        tool = _tool_size(tool_diameter, stickout)
        grid = parse_rpm(rpm, method)
        model, rows = read_modes_table(modes)
        if tool is not None:
            check_modes_on_tool(rows, *tool, str(modes))
        conditions = CuttingConditions.from_immersion(immersion, milling)
        with status(f"computing {method.upper()} lobes on {grid.size} speeds"):
            lobes = stability_lobes(
                model,
                cutter=teeth,
                material=mat,
                conditions=conditions,
                rpm=grid,
                method=method,  # type: ignore[arg-type]
                max_lobe=max_lobe,
                intervals=intervals,
            )
        a_min, n_min = lobes.minimum()
        shallow = check_lobe_depth(
            float(a_min), float(n_min), rows, str(modes), tool_checked=tool is not None
        )
        with Outputs() as out:
            out.write(output, "--output", write_lobes_csv, output, lobes)
            if plot is not None:
                from robolobe.sld.plot import save_lobe_plot

                out.write(
                    plot,
                    "--plot",
                    save_lobe_plot,
                    lobes,
                    plot,
                    safety_factor=safety,
                    title=f"{method.upper()}: N={teeth}, a/D={immersion:g}, {milling} milling",
                )
        console.print(
            f"{method.upper()} lobes: {grid.size} speeds {grid[0]:g}-{grid[-1]:g} rpm, "
            f"Kt={mat.kt:.4g} N/m^2, Kr={mat.kr:.4g}, a/D={immersion:g} ({milling} milling)",
            highlight=False,
            soft_wrap=True,
        )
        if math.isfinite(float(a_min)):
            console.print(
                f"minimum a_lim = {float(a_min) * 1e3:.6g} mm at {float(n_min):.6g} rpm",
                highlight=False,
                soft_wrap=True,
            )
            if shallow is not None:
                err_console.print(labelled("warning:", "yellow", shallow), soft_wrap=True)
        else:
            console.print("no lobe crosses this speed range: a_lim = inf everywhere")
        if not lobes.valid:
            err_console.print(labelled("warning:", "yellow", lobes.message), soft_wrap=True)
        if lobes.complete_above_rpm is not None and float(lobes.complete_above_rpm) > grid[0]:
            err_console.print(
                labelled(
                    "warning:",
                    "yellow",
                    f"lobes above k={lobes.max_lobe} are left out; the envelope "
                    f"below {float(lobes.complete_above_rpm):.6g} rpm may be too high "
                    "(raise --max-lobe)",
                ),
                soft_wrap=True,
            )
        console.print(
            f"wrote {shown(output)}" + (f" and {shown(plot)}" if plot is not None else ""),
            highlight=False,
            soft_wrap=True,
        )
