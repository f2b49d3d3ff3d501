"""``robolobe train | transfer | predict | design-tests``: the transfer-learning predictor."""

from __future__ import annotations

import itertools
import time
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from robolobe._text import count
from robolobe.cli._common import Outputs, console, err_console, labelled, shown, status
from robolobe.errors import InputError

__all__ = ["register"]

_MIN_TRAIN = 15


@contextmanager
def _shown_warnings() -> Iterator[None]:
    """Print library warnings (TrustWarning & co.) as one line each on stderr."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            seen: set[str] = set()
            for w in caught:
                msg = str(w.message)
                if msg not in seen:
                    seen.add(msg)
                    err_console.print(labelled("warning:", "yellow", msg), soft_wrap=True)


def _parse_dirs(text: str) -> tuple[str, ...]:
    items = tuple(d.strip().lower() for d in text.split(",") if d.strip())
    if not items or any(d not in ("xx", "yy", "zz") for d in items):
        raise InputError(
            f"expected driving points like xx,yy (or xx,yy,zz), found {text!r}",
            source="--directions",
        )
    return items


def _robot(spec: str | None) -> Any:
    if spec is None:
        return None
    from robolobe.robots import load_robot

    return load_robot(spec)


#: The arguments of :func:`robolobe.tl.transfer.transfer` and their CLI options.
_TRANSFER_OPTIONS = {"robot": "--robot", "source": "--from", "method": "--method"}


def _as_option_error(exc: InputError) -> InputError:
    """The library's error with the argument named as the command's option."""
    return InputError(exc.detail, _TRANSFER_OPTIONS.get(exc.source or "", exc.source))


def _load_dataset(
    path: Path,
    directions: tuple[str, ...],
    robot_spec: str | None,
    min_postures: int,
    n_modes: int = 5,
) -> Any:
    from robolobe.modal.modal_csv import read_modal_csv
    from robolobe.tl.transfer import checked_dataset

    df = read_modal_csv(path)
    return checked_dataset(df, str(path), directions, n_modes, _robot(robot_spec), min_postures)


def _print_extra_modes(model: Any) -> None:
    """One line per measured mode the base model lacks (robolobe.tl.extra_modes), if any."""
    extra = getattr(model, "extra_", None)
    if extra is None or not extra.n_tracks_:
        return
    console.print(
        f"  {count(extra.n_tracks_, 'measured mode')} the twin lacks, kept as extra modes "
        f"(interpolated over posture, with their spread): {'; '.join(extra.describe())}",
        highlight=False,
    )


def _summary(model: Any, seconds: float, out: Path) -> None:
    cal = np.asarray(model.calibration_)
    console.print(
        f"{shown(out)}: robot {shown(model.robot or '?')} ({' -> '.join(model.lineage_)}), "
        f"{count(len(model.train_q_rad_), 'training posture')}, "
        f"{count(model.n_members, 'member')} x {count(len(model.directions), 'direction')}, "
        f"frozen layers {model.n_frozen_used_}, "
        f"{seconds:.1f} s"
    )
    if model.calibration_coverage_ is not None:
        for j, d in enumerate(model.directions):
            console.print(
                f"  {d}: spread factors f/zeta/k = {cal[j, 0]:.2f}/{cal[j, 1]:.2f}/{cal[j, 2]:.2f}"
            )
    _print_extra_modes(model)


def _calibrate(
    modal_csv: Path,
    output: Path,
    robot: str | None,
    method: str,
    params: str,
    seed: int,
    verbose: bool = False,
) -> None:
    """``transfer --method corrected-twin | twin-calibration``: fit, write, report."""
    from robolobe.tl.graybox import TwinCalibration
    from robolobe.tl.residual import CorrectedTwin
    from robolobe.tl.transfer import transfer

    if robot is None:
        raise InputError(
            "expected the robot file to calibrate (A, B, C or a .toml)", source="--robot"
        )
    suffix = output.suffix.lower()
    if method == "corrected-twin" and suffix != ".npz":
        raise InputError(
            f"expected a .npz model file for the corrected twin, found {output.name!r} (for "
            "the calibrated robot file alone give --method twin-calibration -o OUT.toml)",
            source="--output",
        )
    if method == "twin-calibration" and suffix != ".toml":
        raise InputError(
            f"expected a .toml robot file for twin-calibration, found {output.name!r}",
            source="--output",
        )
    rob = _robot(robot)
    groups = tuple(g.strip() for g in params.split(",") if g.strip())
    with _shown_warnings():
        t0 = time.perf_counter()
        what = (
            "calibrating the twin"
            if method == "twin-calibration"
            else "calibrating the twin and learning its correction"
        )
        with status(what):
            model = transfer(modal_csv, robot=rob, method=method, params=groups, random_state=seed)
        model.save(output)
        cal = model.calibration_ if isinstance(model, CorrectedTwin) else model
        assert isinstance(cal, TwinCalibration)
    what = "a corrected twin" if isinstance(model, CorrectedTwin) else "a calibrated robot file"
    rms = cal.residual_rms_
    console.print(
        f"{shown(output)}: {what} of {shown(robot)} from "
        f"{count(cal.n_postures_, 'posture')} ({count(cal.n_matched_, 'mode')} matched, "
        f"{cal.n_unmatched_} not), {time.perf_counter() - t0:.1f} s",
        highlight=False,
    )
    params_table = cal.summary()
    console.print(
        f"  calibrated twin: residual RMS of log f {rms['f']:.4f}, zeta {rms['zeta']:.3f}, "
        f"k {rms['k']:.3f}; {count(len(params_table), 'parameter')} fitted, the largest "
        f"changes: {_largest_changes(params_table)}{_load_stiffening(params_table)}",
        highlight=False,
    )
    if isinstance(model, CorrectedTwin):
        console.print(f"  learned correction: {_correction_line(model.summary())}", highlight=False)
        console.print(f"  spread (robust plans): {_spread_line(model)}", highlight=False)
        _print_extra_modes(model)
    if verbose:
        _print_calibration(params_table)
        if isinstance(model, CorrectedTwin):
            _print_correction(model.summary())
    else:
        console.print("  (-v: every parameter and the correction per quantity)", highlight=False)
    if isinstance(model, CorrectedTwin):
        advice = f'[robot] name = "{shown(robot)}", model = "{shown(output)}"'
    else:
        advice = f'[robot] name = "{shown(output)}", model = "twin"'
    console.print(f"  plan on it: {advice}", highlight=False)
    if cal.at_bounds_:
        err_console.print(
            labelled(
                "warning:",
                "yellow",
                f"at their bounds: {', '.join(cal.at_bounds_)} (the data "
                "want more change than allowed: check the robot file and the tests)",
            )
        )


#: What the calibration's parameter names stand for (their first letters).
_PARAM_LEGEND = (
    "k1..k6: joint stiffness, d1..d6: joint damping, m_ee: mass at the tool point, "
    "m1..m6: link mass (factors on the robot file's values, x1 = unchanged); "
    "c1x..c6z: link centre-of-mass offset along x, y, z [mm]; l1..l6: joint spring's "
    "stiffening under load (+1 = twice as stiff at 1e4 N m of gravity torque); "
    "+- 1 standard deviation"
)


def _param_text(row: Any) -> str:
    """One fitted parameter: ``k2 x0.988``, ``c4y -11.2 mm`` or ``l2 +1.21``."""
    if row["unit"] == "m":
        return f"{row['param']} {1000 * row['value']:+.1f} mm"
    if row["unit"] != "x":
        return f"{row['param']} {row['value']:+.3f}"
    return f"{row['param']} x{row['value']:.3f}"


def _largest_changes(table: Any, n: int = 3) -> str:
    """The ``n`` factors furthest from 1 (centre-of-mass offsets and load stiffening are
    listed with -v)."""
    factors = table[table["unit"] == "x"]
    if not len(factors):
        return "none (centre-of-mass offsets only, see -v)"
    far = factors.assign(off=np.abs(np.log(factors["value"]))).nlargest(n, "off")
    return ", ".join(_param_text(r) for _, r in far.iterrows())


def _load_stiffening(table: Any, least: float = 0.05) -> str:
    """``; gears stiffer under load: l2 +0.740, l3 +0.180`` for the joints whose fitted
    load stiffening is at least ``least`` (per 1e4 N m), else empty."""
    load = table[(table["unit"] == "per 1e4 N m") & (table["value"] >= least)]
    if not len(load):
        return ""
    return "; gears stiffer under load (per 1e4 N m of gravity torque): " + ", ".join(
        _param_text(r) for _, r in load.iterrows()
    )


def _print_calibration(table: Any) -> None:
    """``-v``: every fitted parameter with its spread."""
    console.print(f"  parameters ({_PARAM_LEGEND}):", highlight=False)
    for _, row in table.iterrows():
        m = row["unit"] == "m"
        spread = f"+- {1000 * row['std']:.1f} mm" if m else f"+- {row['std']:.3f}"
        console.print(f"    {_param_text(row)} ({spread})", highlight=False)


def _correction_by_quantity(summ: Any) -> dict[str, tuple[int, int, float, float]]:
    """Per quantity (f, zeta, k): outputs corrected, outputs, cross-validated RMS of log
    with the correction and of the calibrated twin alone."""
    out = {}
    for q in ("f", "zeta", "k"):
        part = summ[(summ["quantity"] == q) & (summ["n"] > 0)]
        out[q] = (
            int((part["alpha"] > 0).sum()),
            len(part),
            float(np.sqrt(np.mean(part["rms_loo"] ** 2))),
            float(np.sqrt(np.mean(part["rms_twin"] ** 2))),
        )
    return out


def _correction_line(summ: Any) -> str:
    """What the learned correction does, in one line."""
    by_q = _correction_by_quantity(summ)
    used = sum(v[0] for v in by_q.values())
    outputs = count(sum(v[1] for v in by_q.values()), "output")
    if used == 0:
        return (
            f"none (it beat the calibrated twin in cross-validation on none of the {outputs}, "
            "direction x mode x f, zeta, k)"
        )
    loo = "/".join(f"{by_q[q][2]:.4f}" for q in by_q)
    twin = "/".join(f"{by_q[q][3]:.4f}" for q in by_q)
    return (
        f"corrects {used} of {outputs} (direction x mode x f, zeta, k); cross-validated RMS "
        f"of log f/zeta/k {loo} (the calibrated twin alone {twin})"
    )


def _spread_line(model: Any) -> str:
    """How the planning spread was calibrated on held-out tests, and its coverage."""
    from robolobe.tl.residual import SPREAD_CONFIDENCE, SPREAD_SIGMA

    names = ("f", "zeta", "k")
    scale = ", ".join(f"{q} x{v:.2f}" for q, v in zip(names, model.spread_scale_, strict=True))

    def pct(vals: Any) -> str:
        return "/".join("-" if not np.isfinite(v) else f"{100 * v:.0f}" for v in vals)

    return (
        f"calibrated on held-out tests (scale {scale}); cross-validated share of held-out "
        f"tests within {SPREAD_SIGMA:g} sigma, f/zeta/k: {pct(model.spread_cover_)} % "
        f"(stated {100 * SPREAD_CONFIDENCE:.1f} %; before calibration "
        f"{pct(model.spread_cover_raw_)} %)"
    )


def _print_correction(summ: Any) -> None:
    """``-v``: the correction per quantity."""
    for q, (used, n, loo, twin) in _correction_by_quantity(summ).items():
        console.print(
            f"  correction of log {q}: {used} of {count(n, 'direction x mode output')} "
            f"corrected; cross-validated RMS {loo:.4f} (calibrated twin {twin:.4f})",
            highlight=False,
        )


def register(app: typer.Typer) -> None:
    """Add ``train``, ``transfer``, ``predict`` and ``design-tests`` to ``app``."""

    @app.command("train")
    def train(
        modal_csv: Annotated[Path, typer.Argument(help="modal.csv of the source robot (e.g. A).")],
        output: Annotated[Path, typer.Option("--output", "-o", help="Model file to write (.npz).")],
        robot: Annotated[
            str | None,
            typer.Option("--robot", help="Robot (A, B, C or .toml): label and joint-limit check."),
        ] = None,
        preset: Annotated[
            str, typer.Option("--preset", help="'improved' (default) or 'paper' (the seed as is).")
        ] = "improved",
        directions: Annotated[str, typer.Option("--directions", help="e.g. xx,yy")] = "xx,yy",
        epochs: Annotated[int | None, typer.Option("--epochs", min=1, help="Default 500.")] = None,
        members: Annotated[
            int | None, typer.Option("--members", min=1, help="Ensemble size.")
        ] = None,
        seed: Annotated[int, typer.Option("--seed", min=0, max=2**32 - 1, help="Random seed.")] = 0,
    ) -> None:
        """Pretrain the modal predictor on a well-sampled robot (the seed's robot A).

        Holds out 20 % of the postures (the seed's 80:20 split) to calibrate
        the spread and reports it.
        """
        from robolobe._atomic import check_output_file

        check_output_file(output, "--output")

        from robolobe.tl.estimator import ModalPredictor
        from robolobe.tl.presets import PRESETS

        if preset not in PRESETS:
            raise InputError(f"expected one of {sorted(PRESETS)}, found {preset!r}", "--preset")
        dirs = _parse_dirs(directions)
        with _shown_warnings():
            ds = _load_dataset(modal_csv, dirs, robot, _MIN_TRAIN)
            params = {**PRESETS[preset], "directions": dirs}
            if epochs is not None:
                params["epochs"] = epochs
            if members is not None:
                params["n_members"] = members
            model = ModalPredictor(
                **params, calibration="holdout", robot=robot or modal_csv.stem, random_state=seed
            )
            t0 = time.perf_counter()
            with status(f"training on {count(ds.n_postures, 'posture')}"):
                model.fit_dataset(ds)
            model.save(output)
        _summary(model, time.perf_counter() - t0, output)

    @app.command("transfer")
    def transfer_cmd(
        modal_csv: Annotated[Path, typer.Argument(help="modal.csv of the target robot.")],
        output: Annotated[
            Path,
            typer.Option(
                "--output",
                "-o",
                help="Model file to write (.npz; a job's robot.model can name it); with "
                "twin-calibration the calibrated robot (.toml).",
            ),
        ],
        source: Annotated[
            str | None,
            typer.Option(
                "--from",
                help="Source network: A, B, C (shipped) or a model file (implies --method "
                "network).",
            ),
        ] = None,
        robot: Annotated[
            str | None,
            typer.Option(
                "--robot",
                help="Target robot (A, B, C or .toml): the robot file to calibrate; with "
                "network only the label and limit check.",
            ),
        ] = None,
        method: Annotated[
            str | None,
            typer.Option(
                "--method",
                help="'corrected-twin' (default with --robot: calibrated twin plus a learned, "
                "cross-validated correction), 'twin-calibration' (the calibrated robot file "
                "alone) or 'network' (default with --from: the seed's transfer).",
            ),
        ] = None,
        params: Annotated[
            str,
            typer.Option(
                "--params",
                help="twin calibration: comma-separated groups out of stiffness, damping, "
                "ee_mass, link_mass, link_com, load (default: all).",
            ),
        ] = "stiffness,damping,ee_mass,link_mass,link_com,load",
        frozen: Annotated[int, typer.Option("--frozen", help="Frozen layers (seed: 3).")] = 3,
        epochs: Annotated[
            int | None, typer.Option("--epochs", min=1, help="Default: the source's.")
        ] = None,
        seed: Annotated[int, typer.Option("--seed", min=0, max=2**32 - 1, help="Random seed.")] = 0,
        verbose: Annotated[
            bool,
            typer.Option(
                "--verbose", "-v", help="Print every fitted parameter and the correction's detail."
            ),
        ] = False,
    ) -> None:
        """Make a robot's mode predictor from a few hammer tests.

        Default (--robot R, no --method): the best validated predictor, R's
        twin calibrated to the tests plus a learned correction of what it still
        misses; a job plans on it with model = "OUT.npz" in its [robot] table.
        Prints the model's headline figures (-v: every fitted parameter).
        """
        from robolobe._atomic import check_output_file

        check_output_file(output, "--output")

        from robolobe.tl.transfer import default_method, transfer

        try:
            method = default_method(robot, source, method)
        except InputError as exc:
            raise _as_option_error(exc) from None
        if method != "network":
            _calibrate(modal_csv, output, robot, method, params, seed, verbose)
            return
        if source is None:
            raise InputError("expected a source model with --method network", source="--from")
        with _shown_warnings():
            t0 = time.perf_counter()
            with status("transferring the network"):
                try:
                    model = transfer(
                        modal_csv,
                        robot=robot,
                        source=source,
                        method="network",
                        n_frozen=frozen,
                        epochs=epochs,
                        random_state=seed,
                    )
                except InputError as exc:
                    raise _as_option_error(exc) from None
            model.save(output)
        _summary(model, time.perf_counter() - t0, output)

    @app.command("predict")
    def predict(
        model_spec: Annotated[
            str, typer.Argument(metavar="MODEL", help="A, B, C or a model file.")
        ],
        postures: Annotated[Path, typer.Argument(help="postures.csv (posture_id,q1_deg..q6_deg).")],
        output: Annotated[
            Path, typer.Option("--output", "-o", help="predicted modal.csv (+ spread columns).")
        ],
        frf: Annotated[
            Path | None,
            typer.Option("--frf", help="Also write the predicted FRFs as a campaign folder."),
        ] = None,
        robot: Annotated[
            str | None,
            typer.Option("--robot", help="Check the postures against this robot's limits."),
        ] = None,
        fmax: Annotated[float, typer.Option("--fmax", help="FRF band end [Hz].")] = 40.0,
        df: Annotated[float, typer.Option("--df", help="FRF resolution [Hz].")] = 0.25,
    ) -> None:
        """Predict modal parameters (with spread) at postures; optionally their FRFs.

        Columns: those of modal.csv, then per value its standard deviation
        (NAME_std) and 90 % interval (NAME_lo90, NAME_hi90).
        """
        from robolobe._atomic import check_output_dir, check_output_file

        check_output_file(output, "--output")
        if frf is not None:
            check_output_dir(frf, "--frf")

        from robolobe.campaign import read_postures
        from robolobe.modal.modal_csv import write_modal_csv
        from robolobe.tl.models import load_model
        from robolobe.tl.predict_io import prediction_frame, write_frf_campaign

        model = load_model(model_spec)
        label = getattr(model.robot, "name", model.robot)  # a corrected twin holds its Robot
        robot_spec = robot
        if robot_spec is None and str(label).upper() in ("A", "B", "C"):
            robot_spec = str(label).upper()
        rob = _robot(robot_spec)
        if rob is not None:
            from robolobe.tl.models import check_model_robot

            check_model_robot(model, rob, "--robot")
        if rob is None and not isinstance(model.robot, str | type(None)):
            rob = model.robot  # the corrected twin's robot file: its joint limits
        ids, q = read_postures(postures, robot=rob)
        if not (np.isfinite(fmax) and np.isfinite(df) and 0 < df < fmax <= 1e5):
            raise InputError(
                f"expected 0 < df < fmax <= 1e5 Hz, found df={df:g}, fmax={fmax:g}", "--df/--fmax"
            )
        if fmax / df > 1e6:
            raise InputError(
                f"expected at most 1e6 FRF lines (fmax / df), found {fmax / df:.3g}", "--df/--fmax"
            )
        with _shown_warnings():
            pred = model.predict(q)
        table = prediction_frame(ids, q, pred)
        with Outputs() as out:
            out.write(output, "--output", write_modal_csv, output, table)
            if frf is not None:
                out.write(
                    frf, "--frf", write_frf_campaign,
                    frf, robot_spec or str(label), ids, q, pred, fmax, df,
                )  # fmt: skip
        msg = (
            f"{shown(output)}: {count(len(ids), 'posture')} x "
            f"{count(len(pred.directions), 'direction')} x 5 modes"
        )
        if frf is not None:
            msg += f"; FRFs in {shown(frf)}"
        console.print(msg)

    @app.command("design-tests")
    def design_tests(
        robot: Annotated[str, typer.Argument(help="Robot: A, B, C or a robot .toml file.")],
        n: Annotated[int, typer.Option("--n", help="Postures to propose.")],
        output: Annotated[Path, typer.Option("--output", "-o", help="postures.csv to write.")],
        augment: Annotated[
            Path | None,
            typer.Option("--augment", help="postures.csv already tested: propose what adds most."),
        ] = None,
        model_spec: Annotated[
            str | None,
            typer.Option("--model", help="Weight by this model's predicted spread."),
        ] = None,
        seed: Annotated[int, typer.Option("--seed", min=0, max=2**32 - 1, help="Random seed.")] = 0,
    ) -> None:
        """Propose hammer-test postures that cover the feasible workspace."""
        from robolobe._atomic import check_output_file

        check_output_file(output, "--output")

        from robolobe.campaign import read_postures
        from robolobe.tl.design import design_postures
        from robolobe.tl.models import load_model
        from robolobe.twin.designs import TESTED_RANGES_DEG

        rob = _robot(robot)
        if not 1 <= n <= 1000:
            raise InputError(
                f"expected 1 to 1000 postures (each is a hammer test), found {n}", source="--n"
            )
        existing = None
        taken: set[str] = set()
        if augment is not None:
            old_ids, existing = read_postures(augment, robot=rob)
            taken = set(old_ids)
        key = robot.upper()
        ranges = TESTED_RANGES_DEG.get(key) if key in TESTED_RANGES_DEG else None
        model = load_model(model_spec) if model_spec else None
        if model is not None:
            from robolobe.tl.models import check_model_robot

            check_model_robot(model, rob, "--model")
        with status("designing postures"):
            design = design_postures(
                rob,
                n,
                rng=np.random.default_rng(seed),
                existing_rad=existing,
                ranges_deg=ranges,
                criterion="spread" if model is not None else "coverage",
                model=model,
            )
        import pandas as pd

        from robolobe._atomic import atomic_path

        q_out = np.round(np.degrees(design.q_rad), 1)
        # new ids never repeat an existing one (the files are joined for testing)
        fresh = (f"D{i:02d}" for i in itertools.count(1))
        ids = list(itertools.islice((i for i in fresh if i not in taken), len(q_out)))
        table = pd.DataFrame(q_out, columns=[f"q{i}_deg" for i in range(1, 7)])
        table.insert(0, "posture_id", ids)
        with atomic_path(output) as tmp:
            table.to_csv(tmp, index=False, lineterminator="\n")
        if design.coverage_before is not None:
            console.print(
                f"{len(existing) if existing is not None else 0} existing postures: "
                f"{design.coverage_before.describe()}"
            )
        console.print(
            f"{shown(output)}: {count(len(ids), 'posture')}; with them: "
            f"{design.coverage.describe()}"
        )
