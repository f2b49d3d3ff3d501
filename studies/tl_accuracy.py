"""Accuracy study of the transfer-learning modal predictor (robolobe.tl).

The seed paper's protocol on the twin's simulated campaigns:

* robot A: the seed design's 254 postures, identified-like twin data
  (robolobe.tl.twin_data: 5 lowest modes per direction, unseen modes missing,
  identification noise), pretraining with the paper's 80:20 split;
* robot B: 20 training postures, the 5 test postures of the paper's Table 3;
* robot C: 20 one-sided training postures vs. those + the paper's 4 added
  (24) vs. the design tool's own 20 postures, the 5 test postures of Table 6.

Per robot, model variant and seed: median percent error of natural frequency,
damping and modal stiffness over the test postures (known values), FRAC and
NRMSE of the FRF rebuilt from the predictions against the simulated hammer-test
FRF (4-40 Hz), and the coverage of the stated 90 % intervals.

Two kinds of data (``--data``):

* ``twin`` (default): identified-like twin datasets (exact twin modes, unseen
  modes missing, identification noise drawn per seed); the truth at the test
  postures is the twin's exact values;
* ``identified``: the full pipeline, as in the paper: simulated hammer tests
  of every posture (robolobe.twin.campaign), modal identification
  (robolobe.modal.identify: pLSCF, stabilization, tracking) -> modal.csv;
  the reference at the test postures is the identified (EMA) values, as in
  the paper's tables. One campaign per robot (cached in ``--cache``); the
  seeds vary the models.

Run: ``python studies/tl_accuracy.py [--seeds 3] [--data twin|identified] [--baselines]``
``python studies/tl_accuracy.py --summarize studies/tl_accuracy.json --png fig.png``
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import torch
from tl_baselines import make_baselines

from robolobe.robots import load_robot
from robolobe.tl.dataset import TrustWarning
from robolobe.tl.design import design_postures
from robolobe.tl.estimator import ModalPredictor
from robolobe.tl.evaluate import evaluate_prediction
from robolobe.tl.presets import PRESETS
from robolobe.tl.twin_data import measured_frfs, twin_modal_dataset, twin_modal_values
from robolobe.twin.designs import TESTED_RANGES_DEG, design_arrays, seed_design
from robolobe.twin.model import Twin

PARAMS = ("f", "zeta", "k")


def identified(key: str, ids, q, cache: Path, tag: str):
    """Simulated hammer tests + identification -> (dataset, freq, H, decay), cached."""
    from robolobe.campaign import read_campaign, write_campaign
    from robolobe.modal.identify import identify_campaign
    from robolobe.modal.modal_csv import read_modal_csv, write_modal_csv
    from robolobe.tl.dataset import dataset_from_frame
    from robolobe.twin.campaign import simulate_campaign

    folder = cache / f"{key}-{tag}"
    if not (folder / "modal.csv").is_file():
        twin = Twin(load_robot(key))
        camp = simulate_campaign(
            twin.receptance, key, list(ids), q, rng=np.random.default_rng(4242), dirs=("xx", "yy")
        )
        write_campaign(folder / "campaign", camp)
        res = identify_campaign(camp)
        write_modal_csv(folder / "modal.csv", res.table)
    camp = read_campaign(folder / "campaign")
    ds = dataset_from_frame(read_modal_csv(folder / "modal.csv"))
    ds = ds.select_ids([str(i) for i in ids if str(i) in set(ds.posture_ids)])
    return ds, camp


def campaign(key: str, seed: int, data: str = "twin", cache: Path | None = None):
    """Dataset, truth and measured FRFs of a seed design."""
    ids, q, roles = design_arrays(seed_design(key))
    twin = Twin(load_robot(key))
    rng = np.random.default_rng(1000 + seed)
    roles_a = np.asarray(roles)
    if data == "identified":
        assert cache is not None
        ds, camp = identified(key, ids, q, cache, "seed")
        keep = np.isin(np.asarray(ids), ds.posture_ids)
        roles_a = roles_a[keep]
        test = roles_a == "test"
        freq = camp.frfs[0].freq_hz
        axis = {"xx": 0, "yy": 1}
        pos = [camp.index(p) for p in np.asarray(ds.posture_ids)[test]]
        h = (
            np.stack([[camp.frfs[i].H[:, axis[d], axis[d]] for d in ds.directions] for i in pos])
            if pos
            else None
        )
        decay = -np.log(float(camp.test["window_end"])) / float(camp.test["duration_s"])
        return {
            "ds": ds,
            "roles": roles_a,
            "y_true": np.array(ds.y),
            "freq": freq,
            "h": h,
            "twin": twin,
            "decay": decay,
        }
    ds = twin_modal_dataset(twin, ids, q, rng=rng)
    y_true, seen = twin_modal_values(twin, q)
    y_true = np.where(seen[..., None], y_true, np.nan)
    test = roles_a == "test"
    freq, h, decay = (None, None, 0.0)
    if test.any():
        freq, h, decay = measured_frfs(
            twin, [ids[i] for i in np.flatnonzero(test)], q[test], robot=key, rng=rng
        )
    return {
        "ds": ds,
        "roles": roles_a,
        "y_true": y_true,
        "freq": freq,
        "h": h,
        "twin": twin,
        "decay": decay,
    }


def _stat(fn, a) -> float:
    return float(fn(a)) if np.any(np.isfinite(a)) else float("nan")


def evaluate(model, camp, test) -> dict[str, object]:
    ds = camp["ds"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrustWarning)
        pred = model.predict(ds.q_rad[test])
    ev = evaluate_prediction(
        pred.values,
        camp["y_true"][test],
        interval=pred.interval(0.9) if np.any(pred.std > 0) else None,
        freq_hz=camp["freq"],
        h_measured=camp["h"],
        window_decay_per_s=camp["decay"],
    )
    return {
        "median_err_pct": dict(zip(PARAMS, ev.median_errors().round(3).tolist(), strict=True)),
        "coverage90": dict(zip(PARAMS, ev.coverage90().round(3).tolist(), strict=True)),
        "frac_min": _stat(np.nanmin, ev.frac),
        "frac_median": _stat(np.nanmedian, ev.frac),
        "nrmse_max": _stat(np.nanmax, ev.nrmse),
        "nrmse_median": _stat(np.nanmedian, ev.nrmse),
        "frac": ev.frac.round(4).tolist(),
        "nrmse": ev.nrmse.round(4).tolist(),
        "errors_pct_mode": np.nanmedian(ev.errors_pct, axis=(0, 1)).round(3).tolist(),
    }


def summarize(results: list[dict], png: str | None = None) -> str:
    """Markdown table (mean +- std over seeds) and an optional figure."""
    import pandas as pd

    rows = []
    for r in results:
        e, c = r["median_err_pct"], r["coverage90"]
        rows.append(
            {
                "robot": r["robot"],
                "case": r["case"],
                "preset": r["preset"],
                "seed": r["seed"],
                "f": e["f"],
                "zeta": e["zeta"],
                "k": e["k"],
                "cov_f": c["f"],
                "cov_zeta": c["zeta"],
                "cov_k": c["k"],
                "frac_min": r["frac_min"],
                "frac_med": r["frac_median"],
                "nrmse_max": r["nrmse_max"],
                "nrmse_med": r["nrmse_median"],
            }
        )
    df = pd.DataFrame(rows)
    keys = ["robot", "case", "preset"]
    cols = [
        "f",
        "zeta",
        "k",
        "frac_min",
        "frac_med",
        "nrmse_max",
        "nrmse_med",
        "cov_f",
        "cov_zeta",
        "cov_k",
    ]
    g = df.groupby(keys, sort=False)[cols]
    mean, std, n = g.mean(), g.std(ddof=1).fillna(0.0), g.size()
    head = (
        "| robot | case | preset | seeds | f % | zeta % | k % | FRAC min | FRAC med "
        "| NRMSE max | NRMSE med | 90 % cover f/zeta/k |"
    )
    lines = [head, "|" + "---|" * 12]
    for idx in mean.index:
        m, sd = mean.loc[idx], std.loc[idx]

        def pm(c: str, fmt: str = ".1f", m=m, sd=sd) -> str:
            if not np.isfinite(m[c]):
                return "-"
            return f"{m[c]:{fmt}} ± {sd[c]:{fmt}}"

        cov = (
            "-"
            if not np.isfinite(m["cov_f"])
            else (f"{m['cov_f']:.2f}/{m['cov_zeta']:.2f}/{m['cov_k']:.2f}")
        )
        lines.append(
            f"| {idx[0]} | {idx[1]} | {idx[2]} | {n.loc[idx]} | {pm('f')} | {pm('zeta')} | "
            f"{pm('k', '.0f')} | {pm('frac_min', '.2f')} | {pm('frac_med', '.2f')} | "
            f"{pm('nrmse_max', '.2f')} | {pm('nrmse_med', '.2f')} | {cov} |"
        )
    if png:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        main_cases = df[~df["case"].str.contains("baseline")]
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8), sharey=False)
        for ax, par, goal in zip(axes, ("f", "zeta", "k"), (1.0, 10.0, 5.0), strict=True):
            lab = main_cases["robot"] + " " + main_cases["case"]
            for j, (preset, sub) in enumerate(main_cases.groupby("preset", sort=False)):
                gg = sub.groupby(lab[sub.index], sort=False)[par]
                x = np.arange(len(gg)) + 0.38 * j
                ax.bar(x, gg.mean(), 0.38, yerr=gg.std(ddof=1).fillna(0), label=preset)
                ax.set_xticks(
                    np.arange(len(gg)) + 0.19, list(gg.groups), rotation=35, ha="right", fontsize=8
                )
            ax.axhline(goal, color="k", lw=0.8, ls="--")
            ax.set_title(f"median {par} error [%] (dashed: goal)")
        axes[0].legend()
        fig.tight_layout()
        fig.savefig(png, dpi=110)
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--summarize", help="Only print the table of a results JSON file.")
    ap.add_argument("--png", default=None, help="With --summarize: write the figure here.")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--presets", default="paper,improved")
    ap.add_argument("--baselines", action="store_true")
    ap.add_argument("--quick", action="store_true", help="100 epochs (smoke run)")
    ap.add_argument("--out", default="studies/tl_accuracy.json")
    ap.add_argument("--data", default="twin", choices=("twin", "identified"))
    ap.add_argument(
        "--cache",
        default=str(Path(tempfile.gettempdir()) / "robolobe-tl-cache"),
        help="Folder for the identified campaigns (reused between runs).",
    )
    args = ap.parse_args()
    if args.summarize:
        print(summarize(json.loads(Path(args.summarize).read_text()), args.png))
        return
    torch.set_num_threads(1)
    results: list[dict[str, object]] = []
    for seed in range(args.seeds):
        camps = {k: campaign(k, seed, args.data, Path(args.cache)) for k in "ABC"}
        for preset in args.presets.split(","):
            params = dict(PRESETS[preset])
            if args.quick:
                params["epochs"] = 100
            t0 = time.perf_counter()
            src = ModalPredictor(**params, calibration="holdout", robot="A", random_state=seed)
            src.fit_dataset(camps["A"]["ds"])
            t_a = time.perf_counter() - t0
            val = np.asarray(src.validation_["index"])
            rA = evaluate(src, camps["A"], val)
            results.append(
                {"seed": seed, "preset": preset, "robot": "A", "case": "80:20", "time_s": t_a, **rA}
            )
            print(
                f"seed {seed} {preset:9s} A  80:20 {rA['median_err_pct']} "
                f"cov {rA['coverage90']} ({t_a:.0f} s)",
                flush=True,
            )
            cases = {
                "B": {"20": ["train"]},
                "C": {"20 one-sided": ["train"], "24": ["train", "added"]},
            }
            for key, variants in cases.items():
                camp = camps[key]
                test = camp["roles"] == "test"
                for case, roles in variants.items():
                    train = np.isin(camp["roles"], roles)
                    t0 = time.perf_counter()
                    tgt = ModalPredictor(
                        **params, source=src, calibration="cv", robot=key, random_state=seed
                    ).fit_dataset(camp["ds"].subset(train))
                    dt = time.perf_counter() - t0
                    r = evaluate(tgt, camp, test)
                    results.append(
                        {
                            "seed": seed,
                            "preset": preset,
                            "robot": key,
                            "case": case,
                            "time_s": dt,
                            **r,
                        }
                    )
                    print(
                        f"seed {seed} {preset:9s} {key} {case:13s} {r['median_err_pct']} "
                        f"FRAC min {r['frac_min']:.3f} NRMSE max {r['nrmse_max']:.3f} "
                        f"cov {r['coverage90']} ({dt:.1f} s)",
                        flush=True,
                    )
                    if args.baselines and case in ("20", "24"):
                        for name, model in make_baselines(src, params, seed).items():
                            model.fit_dataset(camp["ds"].subset(train))
                            rb = evaluate(model, camp, test)
                            results.append(
                                {
                                    "seed": seed,
                                    "preset": preset,
                                    "robot": key,
                                    "case": f"{case} baseline:{name}",
                                    **rb,
                                }
                            )
                            print(
                                f"   baseline {name:14s} {rb['median_err_pct']} FRAC min "
                                f"{rb['frac_min']:.3f} NRMSE max {rb['nrmse_max']:.3f}",
                                flush=True,
                            )
                if key == "C":
                    qd = design_postures(
                        load_robot("C"),
                        20,
                        rng=np.random.default_rng(seed),
                        ranges_deg=TESTED_RANGES_DEG["C"],
                    ).q_rad
                    ids = [f"D{i + 1:02d}" for i in range(len(qd))]
                    dsd = twin_modal_dataset(
                        camp["twin"], ids, qd, rng=np.random.default_rng(2000 + seed)
                    )
                    tgt = ModalPredictor(
                        **params, source=src, calibration="cv", robot=key, random_state=seed
                    ).fit_dataset(dsd)
                    r = evaluate(tgt, camp, test)
                    results.append(
                        {"seed": seed, "preset": preset, "robot": key, "case": "20 designed", **r}
                    )
                    print(
                        f"seed {seed} {preset:9s} C 20 designed  {r['median_err_pct']} "
                        f"FRAC min {r['frac_min']:.3f} NRMSE max {r['nrmse_max']:.3f}",
                        flush=True,
                    )
    Path(args.out).write_text(json.dumps(results, indent=1))
    print(summarize(results))


if __name__ == "__main__":
    main()
