"""Predictions to files: modal.csv with spread columns, FRF campaigns."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike

from robolobe.tl.dataset import PARAMETERS, ModalDataset
from robolobe.tl.estimator import ModalPrediction
from robolobe.tl.evaluate import rebuild_frf

__all__ = ["SPREAD_COLUMNS", "prediction_frame", "write_frf_campaign"]

#: Extra columns of a predicted modal.csv, per parameter: std and 90 % interval.
SPREAD_COLUMNS: tuple[str, ...] = tuple(
    f"{p}_{s}" for p in PARAMETERS for s in ("std", "lo90", "hi90")
)


def prediction_frame(
    posture_ids: Sequence[str], q_rad: ArrayLike, pred: ModalPrediction
) -> pd.DataFrame:
    """The predicted ``modal.csv`` frame (docs/guide/modal.md + :data:`SPREAD_COLUMNS`)."""
    q = np.asarray(q_rad, dtype=float)
    ds = ModalDataset(tuple(posture_ids), q, pred.directions, pred.values)
    lo, hi = pred.interval(0.9)
    sd = pred.std_physical
    extra = {}
    for i, p in enumerate(PARAMETERS):
        extra[f"{p}_std"] = sd[..., i]
        extra[f"{p}_lo90"] = lo[..., i]
        extra[f"{p}_hi90"] = hi[..., i]
    return ds.to_frame(extra=extra)


def write_frf_campaign(
    folder: str | os.PathLike[str],
    robot: str,
    posture_ids: Sequence[str],
    q_rad: ArrayLike,
    pred: ModalPrediction,
    fmax_hz: float = 40.0,
    df_hz: float = 0.25,
) -> Path:
    """Write the FRFs rebuilt from the predictions as a campaign folder (docs/guide/campaign.md).

    Driving points only (the predicted directions); receptance in m/N on
    ``0, df, ..., fmax``.
    """
    from robolobe.campaign import Campaign, write_campaign

    freq = np.arange(0.0, fmax_hz + 0.5 * df_hz, df_hz)
    q = np.asarray(q_rad, dtype=float)
    h = np.full((len(q), freq.size, 3, 3), np.nan, dtype=complex)
    hp = rebuild_frf(pred.values, freq)  # (n, n_dir, n_freq)
    axis = {"xx": 0, "yy": 1, "zz": 2}
    for j, d in enumerate(pred.directions):
        a = axis[d]
        h[:, :, a, a] = hp[:, j]
    camp = Campaign.from_arrays(
        robot,
        list(posture_ids),
        q,
        freq,
        h,
        dirs=list(pred.directions),
        notes="FRFs rebuilt from modal parameters predicted by robolobe.tl",
    )
    return write_campaign(folder, camp)
