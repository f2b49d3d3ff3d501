"""ModalDataset <-> modal.csv frames, gaps, and bad-input checks."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.modal_csv import read_modal_csv, write_modal_csv
from robolobe.tl.dataset import (
    ModalDataset,
    TrustWarning,
    check_dataset,
    dataset_from_frame,
    interpolate_gaps,
)

from .conftest import smooth_modal


def _ds(n=12, seed=0):
    rng = np.random.default_rng(seed)
    q = np.radians(rng.uniform(-40, 40, size=(n, 6)))
    return ModalDataset(tuple(f"P{i}" for i in range(n)), q, ("xx", "yy"), smooth_modal(q))


def test_round_trip_through_modal_csv(tmp_path):
    ds = _ds()
    write_modal_csv(tmp_path / "modal.csv", ds.to_frame())
    back = dataset_from_frame(read_modal_csv(tmp_path / "modal.csv"))
    assert back.posture_ids == ds.posture_ids
    np.testing.assert_allclose(back.q_rad, ds.q_rad, rtol=1e-12)
    np.testing.assert_allclose(back.y, ds.y, rtol=1e-12)


def test_missing_modes_become_nan_and_are_interpolated_like_the_paper():
    ds = _ds(5)
    df = ds.to_frame()
    drop = (df["posture_id"] == "P2") & (df["dir"] == "yy") & (df["mode"] == 3)
    got = dataset_from_frame(df.loc[~drop])
    assert np.all(np.isnan(got.y[2, 1, 2]))
    assert np.isfinite(got.y).sum() == got.y.size - 3
    filled = interpolate_gaps(got)
    # linear along the posture order: midway between postures P1 and P3
    np.testing.assert_allclose(filled.y[2, 1, 2], 0.5 * (got.y[1, 1, 2] + got.y[3, 1, 2]))


def test_direction_absent_is_an_error():
    df = _ds(4).to_frame()
    with pytest.raises(InputError, match="direction 'zz'"):
        dataset_from_frame(df, directions=("xx", "zz"))


def test_check_dataset_errors_and_warnings():
    ds = _ds(6)
    with pytest.raises(InputError, match="at least 8 postures"):
        check_dataset(ds, min_postures=8)
    with pytest.raises(InputError, match="outside the joint range"):
        check_dataset(ds, min_postures=3, q_min_rad=np.zeros(6), q_max_rad=np.ones(6))
    dup = ds.concat(ds.subset([0]).__class__(("Z",), ds.q_rad[:1], ds.directions, ds.y[:1]))
    with pytest.raises(InputError, match="repeat the joint angles"):
        check_dataset(dup, min_postures=3)
    y = np.array(ds.y)
    y[:, 0, 4] = np.nan
    with pytest.raises(InputError, match="mode 5: no posture has a value"):
        check_dataset(ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y), min_postures=3)
    # the twin methods pair modes by frequency: a direction may see fewer modes (no
    # error, and its modes beyond the ones it has are not "missing values")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_dataset(
            ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y),
            min_postures=3,
            every_mode=False,
        )
    y[:, 0] = np.nan
    with pytest.raises(InputError, match="direction 'xx': no posture has a mode"):
        check_dataset(
            ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y),
            min_postures=3,
            every_mode=False,
        )
    y = np.array(ds.y)
    y[1, 1, 2] = np.nan
    with pytest.warns(TrustWarning, match=r"P1/yy/mode 3"):
        check_dataset(ModalDataset(ds.posture_ids, ds.q_rad, ds.directions, y), min_postures=3)
    with pytest.warns(TrustWarning, match="only 6 postures"):
        check_dataset(ds, min_postures=5)
