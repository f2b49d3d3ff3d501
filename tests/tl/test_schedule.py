"""Repeated k-fold cross-validation of the schedule (seed Figure 9) on a toy map."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from robolobe.tl.dataset import ModalDataset
from robolobe.tl.presets import PRESETS

# study harness (studies/tl_schedule.py), not library code
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))
from tl_schedule import schedule_cv

from .conftest import HI, LO, smooth_modal


def test_schedule_cv_curves():
    rng = np.random.default_rng(0)
    q = rng.uniform(LO, HI, size=(40, 6))
    ds = ModalDataset(tuple(map(str, range(40))), q, ("xx", "yy"), smooth_modal(q))
    params = {**PRESETS["improved"], "hidden": (16, 16, 16)}
    res = schedule_cv(ds, params, batch_sizes=(8, 32), epochs=30, n_repeats=1)
    assert res.curves.shape == (2, 30)
    assert np.all(np.isfinite(res.curves))
    # the validation loss falls from its first epoch for both batch sizes
    assert np.all(res.curves[:, -1] < 0.7 * res.curves[:, 0])
    # with the same epochs, batch 8 takes 4x the steps of batch 32: lower loss
    assert res.final_loss()[0] < res.final_loss()[1]
    assert res.best_epochs().shape == (2,)
