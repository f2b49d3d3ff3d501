"""``robolobe simulate``: simulated hammer-test campaigns from the twin."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from robolobe._directions import AXES
from robolobe._text import count
from robolobe.errors import InputError

__all__ = ["parse_dirs", "register"]

_ALL = tuple(r + e for r in AXES for e in AXES)


#: Most postures of one simulated test campaign (each is a hammer test of minutes).
MAX_POSTURES = 1000
#: Most impacts per direction (averaging beyond a few dozen changes nothing).
MAX_IMPACTS = 100
#: Largest noise multiple (100 times the default noise is noise alone).
MAX_NOISE = 100.0


def parse_dirs(text: str) -> tuple[str, ...]:
    """``"xx,yy,zz"`` or ``"all"`` -> directions in array order (InputError if bad)."""
    t = text.strip().lower()
    if t in ("all", "*"):
        return _ALL
    items = [d.strip() for d in t.split(",") if d.strip()]
    bad = [d for d in items if d not in _ALL]
    if not items or bad:
        raise InputError(
            "expected 'all' or a comma list of two letters from x, y, z (response, excitation), "
            f"e.g. xx,yy,zz; found {text!r}",
            source="--dirs",
        )
    return tuple(d for d in _ALL if d in items)


#: HammerTestSettings fields set from options, for messages that name the option.
_SETTINGS_OPTIONS = {
    "HammerTestSettings.impacts": "--impacts",
    "HammerTestSettings.double_hit_probability": "--double-hits",
    "HammerTestSettings.window_end": "--window-end",
    "HammerTestSettings.force_noise_n": "--noise",
    "HammerTestSettings.accel_noise_m_per_s2": "--noise",
}


def register(app: typer.Typer) -> None:
    """Add the ``simulate`` command to ``app``."""

    @app.command("simulate")
    def simulate(
        robot: Annotated[str, typer.Argument(help="Robot: A, B, C or a robot .toml file.")],
        output: Annotated[Path, typer.Option("--output", "-o", help="Campaign folder to write.")],
        postures: Annotated[
            Path | None,
            typer.Option("--postures", help="postures.csv (posture_id,q1_deg,...,q6_deg) to test."),
        ] = None,
        design: Annotated[
            str | None,
            typer.Option(
                "--design",
                help="Instead of --postures: 'seed' (the seed paper's design for A, B, C) "
                "or 'random' (uniform within the limits; needs --n).",
            ),
        ] = None,
        n: Annotated[int | None, typer.Option("--n", help="Postures for --design random.")] = None,
        exact: Annotated[
            bool,
            typer.Option(
                "--exact", help="Write the noise-free nominal receptance, not a simulated test."
            ),
        ] = False,
        seed: Annotated[
            int,
            typer.Option("--seed", min=0, max=2**32 - 1, help="Random seed (test noise, design)."),
        ] = 0,
        fmt: Annotated[
            str, typer.Option("--format", help="csv (frf.csv) or uff (frf/<posture_id>.uff).")
        ] = "csv",
        dirs: Annotated[
            str,
            typer.Option("--dirs", help="Directions: 'all' (3x3) or a list like xx,yy,zz."),
        ] = "all",
        fmax: Annotated[
            float, typer.Option("--fmax", help="Upper end of the written band [Hz].")
        ] = 40.0,
        noise: Annotated[
            float,
            typer.Option(
                "--noise",
                help="Noise level as a multiple of the default (0.05 N force, 5e-4 m/s^2 "
                "acceleration, RMS); 0: noise-free test.",
            ),
        ] = 1.0,
        impacts: Annotated[int, typer.Option("--impacts", help="Impacts per direction.")] = 5,
        double_hits: Annotated[
            float, typer.Option("--double-hits", help="Probability of a double hit per impact.")
        ] = 0.0,
        window_end: Annotated[
            float,
            typer.Option(
                "--window-end",
                help="Exponential window value at the end of the 4 s record (1: no window).",
            ),
        ] = 0.05,
        effects: Annotated[
            Path | None,
            typer.Option(
                "--effects",
                help="effects.toml (robolobe-effects/1): physics effects added to the robot's "
                "nominal model, e.g. the updated model written by `robolobe diagnose "
                "--updated-model DIR` (use DIR/robot.toml as ROBOT and DIR/effects.toml here).",
            ),
        ] = None,
    ) -> None:
        """Simulate a hammer-test campaign of ROBOT and write it as a campaign folder.

        Each posture is hit in the requested excitation directions (the
        second letters of --dirs) with the seed paper's test (1024 Hz, 4 s,
        0.25 Hz, 5 impacts, exponential window); the H1 receptance from 0 to
        --fmax Hz is written. With --exact the twin's receptance itself is
        written on the same 0.25 Hz grid.
        """
        from robolobe._atomic import check_output_dir

        check_output_dir(output, "--output")
        from robolobe.campaign import read_postures, write_campaign
        from robolobe.cli._common import console, progress
        from robolobe.robots import load_robot
        from robolobe.twin.campaign import simulate_campaign
        from robolobe.twin.hammer import HammerTestSettings
        from robolobe.twin.model import Twin

        if fmt not in ("csv", "uff"):
            raise InputError(f"expected csv or uff, found {fmt!r}", source="--format")
        if not 0 <= noise <= MAX_NOISE:
            raise InputError(
                f"expected a noise multiple 0 to {MAX_NOISE:g}, found {noise:g}", source="--noise"
            )
        if impacts > MAX_IMPACTS:  # below 1: the settings' own message
            raise InputError(
                f"expected 1 to {MAX_IMPACTS} impacts per direction, found {impacts}", "--impacts"
            )
        if n is not None and not 1 <= n <= MAX_POSTURES:
            raise InputError(f"expected 1 to {MAX_POSTURES} postures, found {n}", source="--n")
        want = parse_dirs(dirs)
        try:
            settings = HammerTestSettings(
                impacts=impacts,
                force_noise_n=HammerTestSettings.force_noise_n * noise,
                accel_noise_m_per_s2=HammerTestSettings.accel_noise_m_per_s2 * noise,
                double_hit_probability=double_hits,
                window_end=window_end,
            )
        except InputError as exc:  # name the option, not the settings field
            option = _SETTINGS_OPTIONS.get(str(exc.source), exc.source)
            raise InputError(exc.detail.removesuffix(".0"), option) from None
        if not 1.0 <= fmax <= settings.sample_rate_hz / 2:
            raise InputError(
                f"expected 1 <= fmax <= {settings.sample_rate_hz / 2:g} Hz, found {fmax:g}",
                source="--fmax",
            )
        if (postures is None) == (design is None):
            raise InputError("give exactly one of --postures FILE and --design seed|random")

        builtin = robot.upper() in ("A", "B", "C") and not Path(robot).exists()
        robot_model = load_robot(robot)
        rng = np.random.default_rng(seed)
        if postures is not None:
            ids, q = read_postures(postures, robot=robot_model)
            if len(ids) > MAX_POSTURES:  # a campaign of hours per posture: a wrong file
                raise InputError(
                    f"expected 1 to {MAX_POSTURES} postures, found {len(ids)}", source=str(postures)
                )
            source = str(postures)
        else:
            from robolobe.twin.designs import design_arrays, load_seed_design, random_design

            if design == "seed":
                if not builtin:
                    raise InputError(
                        "the seed design exists for robots A, B, C only; use --design random --n N",
                        source="--design",
                    )
                frame = load_seed_design(robot)
            elif design == "random":
                if n is None or n < 1:
                    raise InputError(f"expected --n >= 1 with --design random, found {n}")
                frame = random_design(robot_model, n, rng)
            else:
                raise InputError(f"expected seed or random, found {design!r}", source="--design")
            ids, q, _ = design_arrays(frame)
            source = f"design {design}"

        from robolobe.twin.effects_file import read_effects

        twin = Twin(robot_model, read_effects(effects) if effects is not None else ())
        with progress() as bar:
            task = bar.add_task("receptance" if exact else "simulating", total=len(ids))
            campaign = simulate_campaign(
                twin.receptance,
                robot.upper() if builtin else str(Path(robot).resolve()),
                ids,
                q,
                rng=rng,
                settings=settings,
                exact=exact,
                dirs=want,
                fmax_hz=fmax,
                on_posture=lambda _i: bar.advance(task),
            )
        campaign = dataclasses.replace(
            campaign, notes=f"{campaign.notes}; robolobe simulate --seed {seed} ({source})"
        )
        freq = campaign.frfs[0].freq_hz
        out = write_campaign(output, campaign, fmt=fmt, copy_robot=True)  # type: ignore[arg-type]
        console.print(
            f"{'exact receptance' if exact else 'simulated test'}: {count(len(ids), 'posture')} "
            f"({source}), directions {','.join(want)}, {freq[0]:g}-{freq[-1]:g} Hz "
            f"step {freq[1] - freq[0]:g} Hz -> {out} ({fmt})",
            highlight=False,
            soft_wrap=True,
        )
