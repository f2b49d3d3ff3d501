"""ModalPredictor: fit/predict, transfer with frozen layers, spread, save/load."""

from __future__ import annotations

import inspect
import zipfile

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.tl.dataset import TrustWarning
from robolobe.tl.estimator import ModalPredictor, transfer_network

from .conftest import HI, LO, smooth_modal

FAST = {"epochs": 40, "n_members": 3, "augment_copies": 1, "hidden": (16, 16, 16, 16, 16)}


@pytest.fixture(scope="module")
def source():
    rng = np.random.default_rng(0)
    q = rng.uniform(LO, HI, size=(80, 6))
    return ModalPredictor(
        **FAST, features="trig", target_transform="log", calibration="holdout", robot="S"
    ).fit(q, smooth_modal(q))


def test_parameters_are_keyword_only_and_validated():
    sig = inspect.signature(ModalPredictor.__init__)
    assert all(
        p.kind is inspect.Parameter.KEYWORD_ONLY for n, p in sig.parameters.items() if n != "self"
    )
    q = np.zeros((10, 6))
    y = np.ones((10, 2, 5, 3))
    with pytest.raises(InputError, match="features"):
        ModalPredictor(features="raw").fit(q, y)
    with pytest.raises(InputError, match=r"y: expected shape \(10, 2, 5, 3\)"):
        ModalPredictor().fit(q, y[:, :1])
    with pytest.raises(InputError, match="at least 5 postures"):
        ModalPredictor().fit(q[:3], y[:3])
    with pytest.raises(InputError, match="positive"):
        ModalPredictor().fit(q, -y)
    with pytest.raises(InputError, match="not fitted"):
        ModalPredictor().predict(q)


def test_fit_learns_a_smooth_map(source):
    rng = np.random.default_rng(5)
    q = rng.uniform(LO + 0.1 * (HI - LO), HI - 0.1 * (HI - LO), size=(40, 6))
    pred = source.predict(q)
    err = np.abs(pred.values / smooth_modal(q) - 1)
    # a 40-epoch toy run: loose bounds, but far below what an untrained net gives
    assert np.median(err[..., 0]) < 0.05
    assert np.median(err[..., 2]) < 0.25
    assert pred.std.shape == pred.center.shape
    assert np.all(pred.std > 0)


def test_transfer_keeps_the_first_three_layers_bitwise(source):
    rng = np.random.default_rng(1)
    q = rng.uniform(LO, HI, size=(12, 6))
    tgt = transfer_network(source, q, smooth_modal(q, 0.3), robot="T", epochs=20)
    assert tgt.n_frozen_used_ == 3
    assert tgt.lineage_ == ["S", "T"]
    src_w = source.net_.to_arrays()
    tgt_w = tgt.net_.to_arrays()
    for i in range(3):  # every member starts from the source member it copies
        np.testing.assert_array_equal(tgt_w[f"W{i}"], src_w[f"W{i}"])
        np.testing.assert_array_equal(tgt_w[f"b{i}"], src_w[f"b{i}"])
    for i in (3, 4, 5):  # and the rest did train
        assert not np.array_equal(tgt_w[f"W{i}"], src_w[f"W{i}"])


def test_same_seed_same_model_and_save_load_round_trip(tmp_path, source):
    rng = np.random.default_rng(2)
    q = rng.uniform(LO, HI, size=(10, 6))
    y = smooth_modal(q, 0.2)
    a = transfer_network(source, q, y, epochs=10, random_state=7)
    b = transfer_network(source, q, y, epochs=10, random_state=7)
    np.testing.assert_array_equal(a.net_.to_arrays()["W5"], b.net_.to_arrays()["W5"])
    path = a.save(tmp_path / "m.npz")
    with zipfile.ZipFile(path) as z:  # plain arrays only: loadable without pickle
        assert all(n.endswith(".npy") for n in z.namelist())
    back = ModalPredictor.load(path)
    qq = rng.uniform(LO, HI, size=(4, 6))
    p1, p2 = a.predict(qq, warn=False), back.predict(qq, warn=False)
    np.testing.assert_array_equal(p1.center, p2.center)
    np.testing.assert_array_equal(p1.std, p2.std)
    assert back.lineage_ == a.lineage_
    (tmp_path / "bad.npz").write_bytes(b"not a model")
    with pytest.raises(InputError, match=r"bad\.npz"):
        ModalPredictor.load(tmp_path / "bad.npz")


def test_extrapolation_warns(source):
    q = (HI + 0.5 * (HI - LO))[None, :]
    with pytest.warns(TrustWarning, match="outside the training range"):
        source.predict(q)


def test_missing_values_masked_or_interpolated():
    rng = np.random.default_rng(3)
    q = rng.uniform(LO, HI, size=(20, 6))
    y = smooth_modal(q)
    y[::3, 1, 4, :] = np.nan
    for missing in ("mask", "interpolate"):
        m = ModalPredictor(**FAST, missing=missing, calibration="none").fit(q, y)
        assert np.all(np.isfinite(m.predict(q, warn=False).values))


def test_interval_levels_and_cv_calibration_factor(source):
    rng = np.random.default_rng(4)
    q = rng.uniform(LO, HI, size=(15, 6))
    m = transfer_network(source, q, smooth_modal(q, 0.1), epochs=15)
    assert m.calibration_.shape == (2, 3)
    assert np.all(m.calibration_ > 0)
    # the factor makes exactly ~90 % of the cross-validated values fall inside
    np.testing.assert_allclose(m.calibration_coverage_, 0.9, atol=0.05)
    p = m.predict(q[:3], warn=False)
    lo50, hi50 = p.interval(0.5)
    lo90, hi90 = p.interval(0.9)
    assert np.all(lo90 <= lo50)
    assert np.all(hi50 <= hi90)
    assert np.all((p.values >= lo90) & (p.values <= hi90))


def test_single_member_has_no_spread_and_cv_needs_enough_postures():
    rng = np.random.default_rng(6)
    q = rng.uniform(LO, HI, size=(8, 6))
    y = smooth_modal(q)
    m = ModalPredictor(**{**FAST, "n_members": 1}).fit(q, y)
    p = m.predict(q, warn=False)
    assert np.all(p.std == 0)
    np.testing.assert_array_equal(m.calibration_, 1.0)
    with pytest.raises(InputError, match="at least 5 postures"):
        ModalPredictor(**FAST).fit(q[:4], y[:4])


@pytest.mark.parametrize("kind", ["minmax", "log", "flex"])
def test_log_std_is_the_relative_spread(kind):
    from robolobe.tl.estimator import ModalPrediction
    from robolobe.tl.preprocess import MinMax, TargetTransform

    y = np.array([[[[10.0, 0.02, 2e6]]]])
    tt = TargetTransform(kind, MinMax(np.zeros(1), np.ones(1)))
    center = tt.pre(y)
    eps = 1e-4
    p = ModalPrediction(("xx",), center, np.full(center.shape, eps), kind)
    bumped = tt.post(center + eps)
    np.testing.assert_allclose(p.log_std, np.abs(np.log(bumped / y)), rtol=5e-3)


def test_bare_estimator_is_the_shipped_preset():
    """`robolobe train` (default preset) and a bare ModalPredictor() make the same model."""
    from robolobe.tl.presets import DEFAULT_PRESET, PRESETS

    bare = ModalPredictor().get_params()
    for key, value in PRESETS[DEFAULT_PRESET].items():
        assert bare[key] == value, key
    paper = ModalPredictor(**PRESETS["paper"]).get_params()
    assert paper["features"] == "angles"
    assert paper["augment_copies"] == 4
