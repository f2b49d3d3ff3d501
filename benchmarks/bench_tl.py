"""Speed of the transfer-learning predictor against the issue's budgets.

* pretraining on robot A (254 postures, 5 members x 2 directions, 500 epochs,
  batch 8, holdout calibration): budget 120 s;
* one transfer to robot B (20 postures, 5-fold cross-validated spread: 60
  networks trained in one vectorized pass): budget 20 s;
* 10,000 posture predictions with spread: budget 1 s;
* one twin calibration of robot B (20 postures of a B whose stiffness,
  damping, masses and centres of mass differ from its file; 37 parameters):
  held to the transfer's budget, 20 s;
* the learned correction on top of that calibration
  (:class:`robolobe.tl.residual.CorrectedTwin` with ``prefit``): 5 s;
* 10,000 posture predictions of the corrected twin with spread: 10 s.

Run: ``python benchmarks/bench_tl.py [--preset improved|paper] [--threads 2]``.
Prints each time, its budget and the ratio (time / budget; < 1 is within).
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import torch

from robolobe.robots import load_robot
from robolobe.tl.estimator import ModalPredictor
from robolobe.tl.presets import PRESETS
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin.designs import design_arrays, seed_design
from robolobe.twin.model import Twin


def _data(key: str, roles: tuple[str, ...]):
    ids, q, role = design_arrays(seed_design(key))
    keep = np.isin(np.asarray(role), roles)
    return twin_modal_dataset(
        Twin(load_robot(key)),
        [i for i, k in zip(ids, keep, strict=True) if k],
        q[keep],
        rng=np.random.default_rng(0),
    )


def _calibration_seconds() -> tuple[float, float, float]:
    """Seconds of one calibration, of the correction on top, of 10,000 predictions."""
    from robolobe.tl.graybox import TwinCalibration
    from robolobe.twin.params import apply_parameters

    ids, q, role = design_arrays(seed_design("B"))
    base = load_robot("B")
    theta = np.random.default_rng(3).normal(0.0, 0.12, 37)  # factors ~ +-12 %, offsets ~ 1.2 cm
    truth = apply_parameters(
        base, ("stiffness", "damping", "ee_mass", "link_mass", "link_com"), theta
    )
    train = np.asarray(role) == "train"
    ds = twin_modal_dataset(Twin(truth), ids, q, rng=np.random.default_rng(0)).subset(train)
    t = time.perf_counter()
    cal = TwinCalibration(robot=base).fit_dataset(ds)
    t_cal = time.perf_counter() - t
    from robolobe.tl.residual import CorrectedTwin

    t = time.perf_counter()
    model = CorrectedTwin(robot=base, prefit=cal).fit_dataset(ds)
    t_corr = time.perf_counter() - t
    q10k = np.tile(q, (10_000 // len(q) + 1, 1))[:10_000]
    t = time.perf_counter()
    model.predict(q10k, warn=False)
    return t_cal, t_corr, time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="improved", choices=sorted(PRESETS))
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    params = dict(PRESETS[args.preset])
    ds_a, ds_b = _data("A", ("train",)), _data("B", ("train",))
    rows = []
    t = time.perf_counter()
    src = ModalPredictor(**params, calibration="holdout", robot="A").fit_dataset(ds_a)
    rows.append(("pretrain A (254 postures)", time.perf_counter() - t, 120.0))
    t = time.perf_counter()
    ModalPredictor(**params, source=src, calibration="cv", robot="B").fit_dataset(ds_b)
    rows.append(("transfer to B (20 postures, CV spread)", time.perf_counter() - t, 20.0))
    t_cal, t_corr, t_pred = _calibration_seconds()
    rows.append(("twin calibration of B (20 postures)", t_cal, 20.0))
    rows.append(("its learned correction (CorrectedTwin)", t_corr, 5.0))
    rows.append(("corrected twin: 10,000 postures, spread", t_pred, 10.0))
    q = np.random.default_rng(1).uniform(-1.0, 1.0, size=(10_000, 6))
    src.predict(q[:10], warn=False)  # warm-up
    best = np.inf
    for _ in range(5):
        t = time.perf_counter()
        pred = src.predict(q, warn=False)
        _ = pred.interval(0.9)
        best = min(best, time.perf_counter() - t)
    rows.append(("predict 10,000 postures with spread", best, 1.0))
    print(
        f"preset {args.preset}, torch threads {args.threads} (training: 1), "
        f"{os.cpu_count()} CPUs, load {os.getloadavg()[0]:.1f}"
    )
    print(f"{'task':42s} {'time [s]':>9s} {'budget':>7s} {'ratio':>6s}")
    for name, sec, budget in rows:
        print(f"{name:42s} {sec:9.2f} {budget:7.0f} {sec / budget:6.2f}")


if __name__ == "__main__":
    main()
