"""Scaling, features, augmentation and target transforms."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.tl.preprocess import (
    C_MIN,
    K_REF_N_PER_M,
    MinMax,
    TargetTransform,
    augment_angles,
    features,
)


def test_minmax_fit_on_training_data_only_and_round_trip():
    train = np.array([[0.0, 5.0], [2.0, 5.0], [1.0, 5.0]])
    sc = MinMax.fit(train)
    np.testing.assert_allclose(sc.transform(train)[:, 0], [0, 1, 0.5])
    assert np.all(sc.transform(train)[:, 1] == 0)  # constant column -> 0
    other = np.array([[4.0, 6.0]])  # outside the training range: not refitted
    np.testing.assert_allclose(sc.transform(other), [[2.0, 1.0]])
    np.testing.assert_allclose(sc.inverse(sc.transform(other)), other)
    back = MinMax.from_dict(sc.to_dict())
    np.testing.assert_array_equal(back.lo, sc.lo)


def test_augmentation_is_uniform_delta_of_the_scaled_range():
    rng = np.random.default_rng(0)
    q = rng.uniform(-1, 1, size=(50, 6))
    sc = MinMax.fit(q)
    aug = augment_angles(q, sc, delta=0.1, copies=4, rng=rng)
    assert aug.shape == (250, 6)
    np.testing.assert_array_equal(aug[:50], q)  # originals first
    z = (aug[50:].reshape(4, 50, 6) - q) / sc.scale
    assert np.abs(z).max() <= 0.1
    assert np.abs(z).max() > 0.09  # it does use the whole +-delta
    assert abs(z.mean()) < 0.01


def test_features():
    q = np.radians([[10.0, -20.0, 30.0, 0.0, 90.0, 180.0]])
    sc = MinMax(lo=np.zeros(6), hi=np.ones(6))
    assert features(q, "angles", sc).shape == (1, 6)
    f = features(q, "trig", sc)
    np.testing.assert_allclose(f[0, :6] ** 2 + f[0, 6:] ** 2, 1.0)
    with pytest.raises(InputError, match="features"):
        features(q, "raw", sc)


@pytest.mark.parametrize("kind", ["minmax", "log", "flex"])
def test_target_transforms_round_trip(kind):
    rng = np.random.default_rng(1)
    y = np.stack(
        [
            rng.uniform(5, 40, (30, 2, 5)),
            rng.uniform(0.005, 0.07, (30, 2, 5)),
            10 ** rng.uniform(4.5, 6.5, (30, 2, 5)),
        ],
        axis=-1,
    )
    tt = TargetTransform.fit(y, kind)
    z = tt.transform(y)
    assert np.nanmin(z) >= -1e-12
    assert np.nanmax(z) <= 1 + 1e-12
    np.testing.assert_allclose(tt.inverse(z), y, rtol=1e-10)
    back = TargetTransform.from_dict(tt.to_dict())
    np.testing.assert_allclose(back.transform(y), z)


def test_flex_reads_missing_stiffness_as_unseen():
    y = np.array([[[[10.0, 0.02, 4e6], [20.0, 0.03, np.nan]]]])
    t = TargetTransform.fit(y, "flex").pre(y)
    assert t[0, 0, 0, 2] == pytest.approx(np.sqrt(K_REF_N_PER_M / 4e6))
    assert t[0, 0, 1, 2] == 0.0  # unseen: no compliance
    back = TargetTransform("flex", MinMax(np.zeros(1), np.ones(1))).post(t)
    assert back[0, 0, 1, 2] == pytest.approx(K_REF_N_PER_M / C_MIN**2)
