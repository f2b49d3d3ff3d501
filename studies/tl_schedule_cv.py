"""Seed Figure 9 on the twin's robot A: batch size and epochs by repeated 5-fold CV.

Run: ``python studies/tl_schedule_cv.py [--preset paper] [--epochs 800] [--repeats 2]``
Prints the final validation loss per batch size and the epoch of the minimum,
and writes ``studies/tl_schedule_cv.png`` (both panels).
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from tl_schedule import schedule_cv

from robolobe.robots import load_robot
from robolobe.tl.presets import PRESETS
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin.designs import design_arrays, seed_design
from robolobe.twin.model import Twin


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="paper")
    ap.add_argument("--epochs", type=int, default=800)
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--batches", default="8,16,32,64")
    ap.add_argument("--out", default="studies/tl_schedule_cv.png")
    args = ap.parse_args()
    ids, q, _ = design_arrays(seed_design("A"))
    ds = twin_modal_dataset(Twin(load_robot("A")), ids, q, rng=np.random.default_rng(0))
    batches = tuple(int(b) for b in args.batches.split(","))
    t0 = time.perf_counter()
    res = schedule_cv(
        ds,
        dict(PRESETS[args.preset]),
        batch_sizes=batches,
        epochs=args.epochs,
        n_repeats=args.repeats,
    )
    print(f"preset {args.preset}, {args.repeats} x 5-fold CV, {time.perf_counter() - t0:.0f} s")
    for b, loss, best, cur in zip(
        res.batch_sizes, res.final_loss(), res.best_epochs(), res.curves, strict=True
    ):
        print(
            f"batch {b:3d}: val loss after {args.epochs} epochs {loss:.5f}, "
            f"at 500 {cur[min(499, len(cur) - 1)]:.5f}, minimum {cur.min():.5f} at epoch {best}"
        )
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.5))
    ax[0].plot(res.batch_sizes, res.final_loss(), "o-")
    ax[0].set_xscale("log", base=2)
    ax[0].set_xlabel("batch size")
    ax[0].set_ylabel(f"mean validation loss after {args.epochs} epochs")
    for b, cur in zip(res.batch_sizes, res.curves, strict=True):
        ax[1].plot(np.arange(1, len(cur) + 1), cur, label=f"batch {b}")
    ax[1].set_xlabel("epoch")
    ax[1].set_ylabel("mean validation loss")
    ax[1].set_yscale("log")
    ax[1].legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=120)


if __name__ == "__main__":
    main()
