"""Study: does the diagnosis make false claims on physics outside robolobe's model form?

Campaigns from ``studies/diagnose_independent.py`` (own kinematics and
dynamics, physics in forms the library does not hold: a two-mass servo
drive, a spindle rotating on its bracket, load-dependent damping and
stiffness, link bending, base tilting, per-direction hammer errors, a
lateral TCP offset) on robot B and on robot D, which the project does not
ship. Scored against the truth: ``found_all`` (every family the library
holds exactly is named), ``false_claim`` (a family that is not there, or a
claim whose held-out misfit exceeds 2x the *true* noise), ``unexplained``
(with the direction/bands where the residual stays).

Run::

    nice -n 10 python studies/diagnose_independent_study.py --subset held \
        --out studies/out/independent
    python studies/diagnose_independent_study.py --subset dev --postures 12      # quicker

Options: ``--subset dev,held``, ``--postures 30``, ``--jobs 1`` (workers of
each diagnosis), ``--limit N``, ``--skip N``, ``--from-csv a.csv ...`` (tables only).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))

from diagnose_independent import frame, independent_cases, run_independent_case

from robolobe.diagnose import DiagnoseSettings


def summary(df: pd.DataFrame) -> pd.DataFrame:
    """Per physics class: effects, how many the library holds exactly, named, missed, false claims.

    An effect is *named* when its family is among the claims (``named``), the
    verdict neither ``unexplained`` nor ``ambiguous`` for it; *missed* when the
    library holds it exactly and it is not named. False claims are counted
    per case (a case with two classes counts for both).
    """
    rows: dict[str, dict[str, int]] = {}
    for r in df.itertuples():
        kinds = str(r.classes).split("+")
        fams = str(r.families).split("+") if r.families != "-" else []
        exact = str(r.exact).split("+") if r.exact != "-" else []
        named = set(str(r.named).split("+")) if r.named != "-" else set()
        fams = fams or [""] * len(kinds)
        exact = exact or ["0"] * len(kinds)
        for k, fam, ex in zip(kinds, fams, exact, strict=True):
            row = rows.setdefault(
                k,
                {
                    "effects": 0,
                    "exact": 0,
                    "named": 0,
                    "missed": 0,
                    "false claims": 0,
                    "unexplained": 0,
                },
            )
            row["effects"] += 1
            row["exact"] += int(ex == "1")
            got = fam in named
            row["named"] += int(got)
            row["missed"] += int(ex == "1" and not got)
            row["false claims"] += int(bool(r.false_claim))
            row["unexplained"] += int(bool(r.unexplained))
    out = pd.DataFrame([{"class": k, **v} for k, v in rows.items()])
    tot = out.drop(columns="class").sum()
    out.loc[len(out)] = ["all", *tot.tolist()]
    return out


def _read(path: Path) -> pd.DataFrame:
    """A ``cases.csv`` ("null" is a case label, not a missing value)."""
    return pd.read_csv(path, keep_default_na=False, na_values=[""])


def _complete(df: pd.DataFrame) -> pd.DataFrame:
    """Columns a CSV written before they existed lacks, from the case table and the verdict."""
    cases = {(c.subset, c.robot, c.label): c for c in independent_cases()}
    df = df.copy()
    if "families" not in df:
        ex = [cases[(r.subset, r.robot, r.case)].extras for r in df.itertuples()]
        df["families"] = ["+".join(str(x.family) for x in e) or "-" for e in ex]
        df["exact"] = ["+".join(str(int(x.exact)) for x in e) or "-" for e in ex]
    if "named" not in df:
        bad = ("unexplained", "ambiguous", "none")
        df["named"] = [v if v not in bad else "-" for v in df["verdict"]]
    return df


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--subset", default="held")
    p.add_argument("--postures", type=int, default=30)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--limit", type=int, default=None)
    p.add_argument("--skip", type=int, default=0)
    p.add_argument("--only", default=None, help="comma-separated case indices")
    p.add_argument("--out", type=Path, default=Path("studies/out/independent"))
    p.add_argument("--from-csv", type=Path, nargs="+", default=None)
    a = p.parse_args(argv)
    pd.set_option("display.width", 250)
    pd.set_option("display.max_columns", 30)
    pd.set_option("display.max_colwidth", 70)
    if a.from_csv:
        df = _complete(pd.concat([_read(f) for f in a.from_csv], ignore_index=True))
        print(df.to_string(index=False))
        print("\n" + summary(df).to_string(index=False))
        return 0
    a.out.mkdir(parents=True, exist_ok=True)
    cases = independent_cases([s.strip() for s in a.subset.split(",")], n_postures=a.postures)
    if a.only:
        cases = [cases[int(i)] for i in a.only.split(",")]
    cases = cases[a.skip :]
    if a.limit is not None:
        cases = cases[: a.limit]
    st = DiagnoseSettings(n_jobs=a.jobs)
    print(f"{len(cases)} cases, {a.postures} postures; load {os.getloadavg()[0]:.1f}", flush=True)
    res = []
    t0 = time.perf_counter()
    for i, c in enumerate(cases):
        r, _ = run_independent_case(c, settings=st)
        res.append(r)
        frame(res).to_csv(a.out / "cases.csv", index=False)
        tag = "FALSE CLAIM" if r.false_claim else ("ok" if r.found_all else "-")
        print(
            f"[{i + 1}/{len(cases)}] {c.subset} {c.robot} {c.label}: {r.verdict} "
            f"[{'; '.join(r.closest) or '-'}] {tag}; misfit {r.misfit_x_noise:.2f}x own noise, "
            f"{r.true_misfit_x_noise:.2f}x true noise; where: {r.where or '-'}; "
            f"{r.seconds:.0f} s wall, {r.cpu_seconds:.0f} s CPU",
            flush=True,
        )
    df = frame(res)
    print("\n" + summary(df).to_string(index=False))
    print(f"total {time.perf_counter() - t0:.0f} s; load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
