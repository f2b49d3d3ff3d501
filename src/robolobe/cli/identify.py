"""``robolobe identify``: modal identification of a hammer-test campaign -> modal.csv."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from robolobe._text import count
from robolobe._workers import MAX_WORKERS
from robolobe.errors import InputError

__all__ = ["register"]


def register(app: typer.Typer) -> None:
    """Add the ``identify`` command to ``app``."""

    @app.command("identify")
    def identify(
        campaign: Annotated[
            Path,
            typer.Argument(
                help="Campaign folder (campaign.toml, postures.csv, frf.csv or frf/*.uff), "
                "or one UFF file of FRFs between numbered points (a measurement)."
            ),
        ],
        output: Annotated[
            Path,
            typer.Option(
                "--output",
                "-o",
                help="Modal dataset to write (modal.csv; for a UFF file: one row per FRF "
                "and mode).",
            ),
        ],
        plots: Annotated[
            Path | None,
            typer.Option(
                "--plots",
                help="Folder for PNG stabilization diagrams and measured-vs-synthesized FRFs.",
            ),
        ] = None,
        modes: Annotated[
            int | None,
            typer.Option(
                "--modes",
                help="Most modes per direction (campaigns; the seed: 5). Default: every mode "
                "the stabilization diagram selects that the driving point sees.",
            ),
        ] = None,
        fmin: Annotated[
            float | None,
            typer.Option(
                "--fmin",
                help="Lower edge of the analysis band [Hz] (campaign: 4; UFF file: 2 % of "
                "the top line).",
            ),
        ] = None,
        fmax: Annotated[
            float | None,
            typer.Option(
                "--fmax",
                help="Upper edge of the analysis band [Hz] (default: the top line every posture "
                "measured; UFF file: the top line).",
            ),
        ] = None,
        window_end: Annotated[
            float | None,
            typer.Option(
                "--window-end",
                help="Exponential window value at the record end (default: campaign.toml "
                "[test] window_end; none: no window).",
            ),
        ] = None,
        record_s: Annotated[
            float | None,
            typer.Option(
                "--record-s",
                help="Record length T [s] for the window and truncation corrections "
                "(default: campaign.toml [test] duration_s).",
            ),
        ] = None,
        numbering: Annotated[
            str,
            typer.Option(
                "--numbering",
                help="rank: visible modes numbered by rising frequency per posture; "
                "track: by tracks across postures.",
            ),
        ] = "rank",
        recover: Annotated[
            bool,
            typer.Option("--recover/--no-recover", help="Recover modes seen at neighbours."),
        ] = True,
        jobs: Annotated[int, typer.Option("--jobs", "-j", help="Parallel workers.")] = 1,
        fit_report: Annotated[
            Path | None,
            typer.Option("--fit-report", help="CSV with FRAC and NRMSE per posture and direction."),
        ] = None,
        all_issues: Annotated[
            bool, typer.Option("--all-issues", help="Print every data-quality finding.")
        ] = False,
        verbose: Annotated[
            bool,
            typer.Option(
                "--verbose",
                "-v",
                help="Also print the sign convention of k (always printed when a sign is "
                "negative).",
            ),
        ] = False,
    ) -> None:
        """Identify the modes of every posture of CAMPAIGN (or of one UFF file) and write them.

        pLSCF (PolyMAX-style) poles over a range of model orders on all
        directions of a posture together, stabilization diagram, automatic
        selection by clustering the stable poles, nonlinear refinement, LSFD
        residues with residual terms, exponential-window correction, mode
        tracking and neighbour recovery. Writes posture_id, q1_deg..q6_deg,
        dir, mode, f_hz, zeta, k_N_per_m (plus source, visibility, k_rel_std)
        for every driving point measured; prints the data-quality findings and
        FRAC / NRMSE of the FRFs synthesized from the written rows.

        Sign convention: H(w) = sum_r (w_r^2/k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w);
        k > 0 at every mode of a driving point. Modes are identified whatever
        the sign of their residue; a negative driving-point residue (transfer
        FRF or reversed polarity) is reported and the mode left out of
        modal.csv. A UFF file (e.g. a roving-hammer test, FRFs keyed by node
        and direction) gives every mode with its signed k in every FRF.
        """
        import numpy as np
        import pandas as pd

        from robolobe._atomic import atomic_dir, atomic_path, check_output_dir, check_output_file
        from robolobe.campaign import read_campaign
        from robolobe.cli._common import Outputs, console, err_console, labelled, progress, shown
        from robolobe.modal.identify import identify_campaign
        from robolobe.modal.modal_csv import write_modal_csv

        check_output_file(output, "--output")
        if plots is not None:
            check_output_dir(plots, "--plots")
        if fit_report is not None:
            check_output_file(fit_report, "--fit-report")
        if modes is not None and not 1 <= modes <= 20:
            raise InputError(f"expected 1 to 20 modes per direction, found {modes}", "--modes")
        if not 1 <= jobs <= MAX_WORKERS:
            raise InputError(
                f"expected 1 to {MAX_WORKERS} worker processes, found {jobs}", "--jobs"
            )
        if campaign.is_file():
            if fit_report is not None:
                raise InputError(
                    "applies to a campaign folder; a UFF file's fit is in its table",
                    source="--fit-report",
                )
            _identify_measurement(
                campaign, output, plots, fmin, fmax, window_end, record_s, verbose
            )
            return
        fmin = 4.0 if fmin is None else fmin
        if fmax is not None and not (0 < fmin < fmax):
            raise InputError(
                f"expected 0 < fmin < fmax, found fmin={fmin:g}, fmax={fmax:g}", source="--fmin"
            )
        if numbering not in ("rank", "track"):
            raise InputError(f"expected rank or track, found {numbering!r}", source="--numbering")
        from robolobe.campaign import WINDOW_END_MIN

        if window_end is not None and not WINDOW_END_MIN <= window_end <= 1:
            raise InputError(
                f"expected a value in [{WINDOW_END_MIN:g}, 1] (a window that ends lower sets "
                f"the records' decay itself), found {window_end:g}",
                "--window-end",
            )
        if record_s is not None and not record_s > 0:
            raise InputError(f"expected a positive number, found {record_s:g}", "--record-s")

        camp = read_campaign(campaign)
        from robolobe.modal.identify import campaign_band_top
        from robolobe.modal.posture import SIGN_CONVENTION

        if fmax is None:  # the band the campaign measured
            fmax = campaign_band_top([f.freq_hz for f in camp.frfs])
            if not fmin < fmax:
                raise InputError(
                    f"expected the campaign's band to reach above fmin = {fmin:g} Hz, found its "
                    f"top line at {fmax:g} Hz; give --fmin",
                    source=f"{campaign}",
                )

        test: dict[str, Any] = dict(camp.test)
        if record_s is not None:
            test["duration_s"] = record_s
        if window_end is not None:
            test["window_end"] = window_end
            if "duration_s" not in test:
                raise InputError(
                    "--window-end needs the record length: give --record-s or [test] duration_s "
                    "in campaign.toml",
                    source="--window-end",
                )
        overrides = {"fmin_hz": fmin, "fmax_hz": fmax, "n_modes": modes}
        from robolobe.modal.identify import settings_from_test

        settings = settings_from_test(test, **overrides)
        with progress() as bar:
            task = bar.add_task("identifying", total=camp.n_postures)
            result = identify_campaign(
                camp,
                settings=settings,
                n_jobs=jobs,
                numbering=numbering,
                recover=recover,
                progress=lambda k: bar.advance(task, k),
            )

        def plot_dir(folder: Path) -> None:
            from robolobe.modal.plots import save_posture_plots

            with atomic_dir(folder, "identify-plots", option="--plots") as tmp:
                save_posture_plots(result.postures, result.table, tmp)

        def fit_csv(path: Path) -> None:
            with atomic_path(path) as tmp:
                result.fit.to_csv(tmp, index=False, lineterminator="\n", float_format="%.6g")

        with Outputs() as out:
            if plots is not None:
                out.write(plots, "--plots", plot_dir, plots)
            if fit_report is not None:
                out.write(fit_report, "--fit-report", fit_csv, fit_report)
            out.write(output, "--output", write_modal_csv, output, result.table)
        if plots is not None:
            from robolobe.modal.plots import posture_plot_names

            for note in posture_plot_names(result.postures).notes:
                err_console.print(labelled("note:", "yellow", f"--plots: {note}"))

        # ---- summary
        tab = result.table
        console.print(
            f"{count(camp.n_postures, 'posture')}, {count(len(tab), 'row')} "
            f"({int((tab['source'] == 'recovered').sum())} recovered) -> {output}",
            highlight=False,
        )
        corr = []
        if settings.window_decay_per_s > 0:
            corr.append(f"window decay {settings.window_decay_per_s:.3g} 1/s removed")
        if settings.record_length_s is not None:
            corr.append(f"truncation of {settings.record_length_s:g} s records corrected")
        if corr:
            console.print("corrections: " + ", ".join(corr), highlight=False)
        neg = result.negative
        if verbose or len(neg):
            console.print(SIGN_CONVENTION, highlight=False)
        if len(neg):
            have = "has" if len(neg) == 1 else "have"
            err_console.print(
                f"{count(len(neg), 'mode')} at {count(neg['posture_id'].nunique(), 'posture')} "
                f"{have} a negative driving-point residue and are not in modal.csv (dirs "
                f"{', '.join(sorted(neg['dir'].unique()))}): close complex pairs, transfer "
                "FRFs or reversed polarity, "
                "see the sign findings below",
                highlight=False,
            )
        from rich.table import Table

        t = Table(title=f"fit quality, {fmin:g}-{fmax:g} Hz (synthesized from modal.csv rows)")
        for col in (
            "dir",
            "postures",
            "modes per\nposture",
            "FRAC min",
            "FRAC median",
            "NRMSE median",
            "NRMSE max",
        ):
            t.add_column(col, justify="right")
        fit = result.fit
        for d, g in fit.groupby("dir", sort=False):
            t.add_row(
                str(d),
                str(len(g)),
                f"{g['n_modes'].mean():.1f}",
                f"{np.nanmin(g['frac']):.3f}",
                f"{np.nanmedian(g['frac']):.3f}",
                f"{np.nanmedian(g['nrmse']):.3f}",
                f"{np.nanmax(g['nrmse']):.3f}",
            )
        console.print(t)
        worst = fit.sort_values("frac").head(5)
        if len(worst) and float(worst["frac"].iloc[0]) < 0.95:
            console.print("worst postures (FRAC):", highlight=False)
            for _, r in worst.iterrows():
                outside = float(r["outside_share"])
                why = (
                    f" (fit with residual terms: FRAC {r['frac_fit']:.3f}; modes outside "
                    f"{fmin:g}-{fmax:g} Hz carry {100 * outside:.0f} % of this FRF and cannot be "
                    "rows: not a fit error, a band that leaves them out)"
                    if outside >= 0.2 and float(r["frac_fit"]) >= 0.95
                    else ""
                )
                console.print(
                    f"  {r['posture_id']} {r['dir']}: FRAC {r['frac']:.3f}, NRMSE {r['nrmse']:.3f}"
                    + why,
                    highlight=False,
                )
        issues = [i for i in result.issues if i.severity != "info"]
        info = [i for i in result.issues if i.severity == "info"]
        if issues:
            counts = pd.Series([f"{i.severity} {i.check}" for i in issues]).value_counts()
            err_console.print(
                "data quality: " + ", ".join(f"{n} x {k}" for k, n in counts.items()),
                highlight=False,
            )
            listed = issues if all_issues else issues[:20]
            for i in listed:
                err_console.print(f"  {shown(i)}", highlight=False, soft_wrap=True)
            if len(listed) < len(issues):
                err_console.print(
                    f"  ... {len(issues) - len(listed)} more (--all-issues)", highlight=False
                )
        else:
            console.print("data quality: no problems found", highlight=False)
        if info:
            absent = sorted({i.dir for i in info if i.check == "absent"})
            if absent:
                console.print(f"not measured: {', '.join(absent)}", highlight=False)


def _identify_measurement(
    path: Path,
    output: Path,
    plots: Path | None,
    fmin: float | None,
    fmax: float | None,
    window_end: float | None,
    record_s: float | None,
    verbose: bool = False,
) -> None:
    """``robolobe identify FILE.uff``: the modes of one measurement (FRFs between nodes)."""
    import numpy as np

    from robolobe._atomic import atomic_dir, atomic_path
    from robolobe.campaign.uff import common_grid, read_uff_frfs
    from robolobe.cli._common import console, err_console, shown
    from robolobe.modal.identify import settings_from_test
    from robolobe.modal.measurement import identify_measurement
    from robolobe.modal.posture import SIGN_CONVENTION

    if path.suffix.lower() not in (".uff", ".unv"):
        raise InputError(
            "expected a campaign folder or a UFF file (.uff, .unv), found a "
            f"{path.suffix or 'plain'} file",
            source=str(path),
        )
    recs = read_uff_frfs(path)
    grid = common_grid(recs, str(path))
    top = float(grid[-1])
    lo = float(grid[grid > 0][0]) if np.any(grid > 0) else top
    fmax = top if fmax is None else fmax
    fmin = max(lo, 0.02 * fmax) if fmin is None else fmin
    if not (0 < fmin < fmax):
        raise InputError(
            f"expected 0 < fmin < fmax, found fmin={fmin:g}, fmax={fmax:g}", source="--fmin"
        )
    test: dict[str, float] = {}
    if record_s is not None:
        test["duration_s"] = record_s
    if window_end is not None:
        if record_s is None:
            raise InputError("--window-end needs the record length --record-s", "--window-end")
        test["window_end"] = window_end
    settings = settings_from_test(test, fmin_hz=fmin, fmax_hz=fmax)
    mm = identify_measurement(
        grid,
        np.stack([r.H for r in recs], axis=1),
        [r.key for r in recs],
        settings=settings,
        name=path.name,
    )
    if plots is not None:
        from robolobe.modal.plots import plot_measurement

        with atomic_dir(plots, "identify-plots", option="--plots") as tmp:
            plot_measurement(mm, tmp / "stab_measurement.png")
    with atomic_path(output) as tmp:
        mm.table.to_csv(tmp, index=False, lineterminator="\n", float_format="%.10g")
    n_dp = sum(r.driving_point for r in recs)
    console.print(
        f"{path.name}: {count(len(recs), 'FRF')} ({count(n_dp, 'driving point')}, "
        f"{len(recs) - n_dp} transfer), {fmin:g}-{fmax:g} Hz: {count(mm.n_modes, 'mode')} "
        f"-> {output}",
        highlight=False,
    )
    if verbose or np.any(mm.k_N_per_m[mm.visible] < 0):  # the table shows the signs
        console.print(SIGN_CONVENTION, highlight=False)
    from rich.table import Table

    t = Table(title="modes (k sign per FRF: + / -; . not visible)")
    for col in ("mode", "f_hz", "zeta %", *(r.label for r in recs[:8])):
        t.add_column(col, justify="right")
    for m in range(mm.n_modes):
        signs = [
            ("+" if mm.k_N_per_m[j, m] > 0 else "-") if mm.visible[j, m] else "."
            for j in range(min(len(recs), 8))
        ]
        t.add_row(str(m + 1), f"{mm.f_hz[m]:.4g}", f"{100 * mm.zeta[m]:.3g}", *signs)
    console.print(t)
    if mm.issues:
        err_console.print("data quality:", highlight=False)
        for i in mm.issues:
            err_console.print(f"  [{i.check}] {shown(i.message)}", highlight=False, soft_wrap=True)
    else:
        console.print("data quality: no problems found", highlight=False)
