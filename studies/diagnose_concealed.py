"""Study: does the diagnosis name concealed physics, and only when it is there?

For each robot (built-in A, B, C and a user-style robot file), each effect
of the library at three realistic magnitudes, and null campaigns, a hammer
campaign is simulated with the effect concealed in the twin (seed test:
1024 Hz, 4 s, 5 impacts, exponential window, noise on both channels) and
diagnosed without being told the effect. Prints the confusion matrix, the
detection rate per effect and magnitude, false discoveries on nulls and the
held-out FRAC/NRMSE before and after the correction; writes the per-case
table (CSV) and figures.

Run (about 30 s per case on one core)::

    python studies/diagnose_concealed.py --out studies/out/diagnose
    python studies/diagnose_concealed.py --robots B --magnitudes medium   # quicker

Options: ``--robots A,B,C,examples/robots/my_robot.toml``, ``--families``,
``--magnitudes small,medium,large``, ``--seeds 0``, ``--nulls 2``,
``--postures 30``, ``--noise 1`` (test noise x the default), ``--jobs 2`` (cases in
parallel processes).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd


def _plot(tables: dict[str, pd.DataFrame], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conf = tables["confusion"]
    fig, ax = plt.subplots(figsize=(9, 7))
    labels = sorted(set(conf.index) | set(conf.columns))
    m = conf.reindex(index=labels, columns=labels, fill_value=0).to_numpy()
    ax.imshow(m, cmap="Blues")
    ax.set_xticks(range(len(labels)), labels, rotation=60, ha="right", fontsize=8)
    ax.set_yticks(range(len(labels)), labels, fontsize=8)
    for i in range(len(labels)):
        for j in range(len(labels)):
            if m[i, j]:
                ax.text(
                    j,
                    i,
                    str(m[i, j]),
                    ha="center",
                    va="center",
                    fontsize=8,
                    color="white" if m[i, j] > m.max() / 2 else "black",
                )
    ax.set_xlabel("diagnosis")
    ax.set_ylabel("concealed effect")
    ax.set_title("Concealed-effect study: confusion matrix")
    fig.tight_layout()
    fig.savefig(out / "confusion.png", dpi=110)
    plt.close(fig)

    cases = tables["cases"]
    eff = cases[cases["truth"] != "none"]
    fig, ax = plt.subplots(figsize=(6, 5))
    ok = eff["correct"].to_numpy(bool)
    ax.plot(eff["frac_before"][ok], eff["frac_after"][ok], "o", ms=4, label="named correctly")
    ax.plot(eff["frac_before"][~ok], eff["frac_after"][~ok], "x", ms=6, label="misnamed")
    ax.plot([0, 1], [0, 1], "k-", lw=0.5)
    ax.axhline(0.98, color="0.5", ls="--", lw=0.8)
    ax.set_xlabel("held-out FRAC, nominal model")
    ax.set_ylabel("held-out FRAC, after the correction")
    lo = float(min(eff["frac_before"].min(), eff["frac_after"].min(), 0.9)) if len(eff) else 0.5
    ax.set_xlim(lo - 0.02, 1.005)
    ax.set_ylim(lo - 0.02, 1.005)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "frac_before_after.png", dpi=110)
    plt.close(fig)


def _one(args: tuple[object, object]) -> object:
    from robolobe.diagnose.concealed import run_case

    case, settings = args
    res, _ = run_case(case, settings=settings)  # type: ignore[arg-type]
    return res


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--robots", default="A,B,C,examples/robots/my_robot.toml")
    p.add_argument("--families", default=None, help="comma list (default: all effects)")
    p.add_argument("--magnitudes", default="small,medium,large")
    p.add_argument("--seeds", default="0")
    p.add_argument("--nulls", type=int, default=2, help="null campaigns per robot and seed")
    p.add_argument("--postures", type=int, default=30)
    p.add_argument("--noise", type=float, default=1.0, help="test noise x the default")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--out", type=Path, default=Path("studies/out/diagnose"))
    p.add_argument(
        "--from-csv",
        type=Path,
        nargs="+",
        default=None,
        help="only tabulate and plot these cases.csv files (no new runs)",
    )
    a = p.parse_args(argv)

    from robolobe.diagnose.concealed import results_frame, standard_cases, study_tables

    a.out.mkdir(parents=True, exist_ok=True)
    if a.from_csv:
        frame = pd.concat([pd.read_csv(f) for f in a.from_csv], ignore_index=True)
        _report(study_tables(frame), a.out, time.perf_counter())
        return 0

    robots = [r.strip() for r in a.robots.split(",") if r.strip()]
    robots = [r for r in robots if r in ("A", "B", "C") or Path(r).is_file()]
    cases = standard_cases(
        robots,
        n_postures=a.postures,
        seeds=[int(s) for s in a.seeds.split(",")],
        magnitudes=[m.strip() for m in a.magnitudes.split(",")],
        n_null=a.nulls,
        families=None if a.families is None else [f.strip() for f in a.families.split(",")],
        noise=a.noise,
    )
    print(f"{len(cases)} cases on robots {', '.join(robots)}", flush=True)
    t0 = time.perf_counter()
    results = []
    work = [(c, None) for c in cases]
    if a.jobs > 1:
        from joblib import Parallel, delayed

        results = Parallel(n_jobs=a.jobs, verbose=5)(delayed(_one)(w) for w in work)
    else:
        for i, w in enumerate(work):
            r = _one(w)
            results.append(r)
            results_frame(results).to_csv(a.out / "cases.csv", index=False)  # progress survives
            c = w[0]
            print(
                f"[{i + 1}/{len(cases)}] {c.robot_label} {c.truth}/{c.magnitude}: "
                f"{r.verdict_label} ({'ok' if r.correct else 'WRONG'}), "  # type: ignore[attr-defined]
                f"FRAC {r.frac_before:.3f} -> {r.frac_after:.3f}, {r.seconds:.0f} s",  # type: ignore[attr-defined]
                flush=True,
            )
    tables = study_tables(results)  # type: ignore[arg-type]
    tables["cases"].to_csv(a.out / "cases.csv", index=False)
    _report(tables, a.out, t0)
    return 0


def _report(tables: dict[str, pd.DataFrame], out: Path, t0: float) -> None:
    pd.set_option("display.width", 200)
    pd.set_option("display.max_columns", 30)
    cases_df = tables["cases"]
    eff = cases_df[cases_df["truth"] != "none"]
    nul = cases_df[cases_df["truth"] == "none"]
    print("\nConfusion matrix (rows: concealed effect, columns: diagnosis)")
    print(tables["confusion"].to_string())
    print("\nDetection rate per effect and magnitude")
    print(tables["detection"].round(2).to_string())
    print("\nFalse discoveries on null campaigns")
    print(tables["nulls"].to_string())
    print("\nHeld-out fit of correctly named effect campaigns (means)")
    print(tables["fit"].round(3).to_string())
    print(
        f"\nNamed correctly: {eff['correct'].mean():.1%} of {len(eff)} effect campaigns; "
        f"false discoveries: {int((~nul['correct']).sum())} of {len(nul)} null campaigns; "
        f"held-out FRAC after >= 0.98 in {np.mean(eff[eff['correct']]['frac_after'] >= 0.98):.0%} "
        f"of correctly named; median time {cases_df['seconds'].median():.0f} s per case; "
        f"total {time.perf_counter() - t0:.0f} s"
    )
    _plot(tables, out)
    print(f"wrote {out}/cases.csv, confusion.png, frac_before_after.png")


if __name__ == "__main__":
    sys.exit(main())
