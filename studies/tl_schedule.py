"""Repeated k-fold cross-validation of the training schedule (seed Figure 9).

The seed chose batch 8 and 500 epochs from the mean validation loss of
repeated 5-fold cross-validation on robot A: smaller batches gave lower loss,
and the loss fell until ~500 epochs and rose after. :func:`schedule_cv`
repeats that: for each batch size, every (repeat, fold, direction) network
trains in one vectorized pass (:func:`robolobe.tl.training.train_ensemble`)
and its held-out fold's loss (MSE of the scaled targets) is recorded after
every epoch, giving both panels of the figure.

Scalers and the augmentation follow the model's parameters; the scalers are
fitted on all postures (the folds only decide which rows train), which
leaks the ranges but not the values into the validation folds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from robolobe.errors import InputError
from robolobe.tl.dataset import ModalDataset, interpolate_gaps
from robolobe.tl.network import EnsembleMLP
from robolobe.tl.preprocess import (
    MinMax,
    TargetTransform,
    augment_angles,
    features,
    n_features,
)
from robolobe.tl.training import train_ensemble

__all__ = ["ScheduleCV", "schedule_cv"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ScheduleCV:
    """Validation loss of repeated k-fold cross-validation.

    Attributes
    ----------
    batch_sizes : tuple of int
    curves : ndarray, shape (n_batch_sizes, epochs)
        Mean validation loss over repeats, folds and directions after each epoch.
    spread : ndarray, shape (n_batch_sizes, epochs)
        Standard deviation of that loss over repeats and folds.
    """

    batch_sizes: tuple[int, ...]
    curves: FloatArray
    spread: FloatArray

    def final_loss(self) -> FloatArray:
        """Loss after the last epoch per batch size (Figure 9, left)."""
        return np.asarray(self.curves[:, -1])

    def best_epochs(self) -> NDArray[np.int_]:
        """Epoch (1-based) of the lowest mean loss per batch size (Figure 9, right)."""
        return np.asarray(np.argmin(self.curves, axis=1) + 1)


def schedule_cv(
    ds: ModalDataset,
    params: dict[str, Any],
    *,
    batch_sizes: Sequence[int] = (8, 16, 32, 64),
    epochs: int = 500,
    n_splits: int = 5,
    n_repeats: int = 2,
    random_state: int = 0,
) -> ScheduleCV:
    """Cross-validate the batch size and the number of epochs.

    Parameters
    ----------
    ds : ModalDataset
    params : dict
        :class:`~robolobe.tl.estimator.ModalPredictor` parameters (a preset):
        ``features``, ``target_transform``, ``missing``, ``hidden``,
        ``learning_rate``, ``augment_delta``, ``augment_copies``, ``n_modes``.
    batch_sizes, epochs, n_splits, n_repeats, random_state
        The grid and the folds.

    Returns
    -------
    ScheduleCV
    """
    n = ds.n_postures
    if n < 2 * n_splits:
        raise InputError(f"expected at least {2 * n_splits} postures, found {n}")
    nm = int(params.get("n_modes", 5))
    y = np.array(ds.y[:, :, :nm])
    if params.get("missing", "interpolate") == "interpolate":
        y = np.array(interpolate_gaps(ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y)).y)
    nd = len(ds.directions)
    kind = str(params.get("features", "angles"))
    dh = None
    if params.get("coupling") is not None:
        dh = (params["coupling"], params["theta_offset_rad"])
    rng = np.random.default_rng(random_state)
    scaler = MinMax.fit(ds.q_rad)
    tt = TargetTransform.fit(y, str(params.get("target_transform", "minmax")))
    ys = tt.transform(y).reshape(n, nd, nm * 3)
    delta = float(params.get("augment_delta", 0.10))
    copies = int(params.get("augment_copies", 4)) if delta > 0 else 0
    post = np.tile(np.arange(n), 1 + copies)
    folds = np.stack([rng.permutation(n) % n_splits for _ in range(n_repeats)])  # (R, n)
    n_models = n_repeats * n_splits * nd
    rep = np.arange(n_models) // (n_splits * nd)
    fold = (np.arange(n_models) // nd) % n_splits
    dirn = np.arange(n_models) % nd
    x = np.stack(
        [
            features(
                augment_angles(ds.q_rad, scaler, delta=delta, copies=copies, rng=rng),
                kind,
                scaler,
                dh,
            )
            for _ in range(n_models)
        ]
    ).astype(np.float32)
    yy = ys[post][:, dirn, :].transpose(1, 0, 2)
    mask = np.isfinite(yy)
    yy = np.where(mask, yy, 0.0)
    held = folds[rep][:, post] == fold[:, None]  # (M, n_aug)
    rows = ~held
    # validation: the held-out fold's original postures, padded to equal length
    n_val = max(int((folds[r] == k).sum()) for r in range(n_repeats) for k in range(n_splits))
    xv = np.zeros((n_models, n_val, x.shape[2]), dtype=np.float32)
    yv = np.zeros((n_models, n_val, nm * 3), dtype=np.float32)
    mv = np.zeros((n_models, n_val, nm * 3), dtype=np.float32)
    x_plain = features(ds.q_rad, kind, scaler, dh)
    for m in range(n_models):
        idx = np.flatnonzero(folds[rep[m]] == fold[m])
        xv[m, : len(idx)] = x_plain[idx]
        t = ys[idx, dirn[m]]
        ok = np.isfinite(t)
        yv[m, : len(idx)] = np.where(ok, t, 0.0)
        mv[m, : len(idx)] = ok
    sizes = (n_features(kind), *map(int, params.get("hidden", (32,) * 5)), nm * 3)
    curves = np.empty((len(batch_sizes), epochs))
    spread = np.empty((len(batch_sizes), epochs))
    for b, bs in enumerate(batch_sizes):
        gen = torch.Generator().manual_seed(random_state + b)
        net = EnsembleMLP(n_models, sizes, gen)
        hist = train_ensemble(
            net,
            torch.from_numpy(x),
            torch.from_numpy(yy.astype(np.float32)),
            torch.from_numpy(mask.astype(np.float32)),
            rows=torch.from_numpy(rows),
            epochs=epochs,
            batch_size=int(bs),
            learning_rate=float(params.get("learning_rate", 1e-3)),
            generator=gen,
            x_val=torch.from_numpy(xv),
            y_val=torch.from_numpy(yv),
            mask_val=torch.from_numpy(mv),
        )
        assert hist.val_loss is not None
        per_fold = hist.val_loss.reshape(epochs, n_repeats * n_splits, nd).mean(axis=2)
        curves[b] = per_fold.mean(axis=1)
        spread[b] = per_fold.std(axis=1)
    return ScheduleCV(tuple(int(b) for b in batch_sizes), curves, spread)
