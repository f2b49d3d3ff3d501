"""Baselines: affine correction and GP on residuals recover what they model."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

# study harness (studies/tl_baselines.py), not library code
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))
from tl_baselines import AffineCorrection, GPResidual, SourceOnly, make_baselines

from robolobe.tl.estimator import ModalPredictor

from .conftest import HI, LO, smooth_modal


@pytest.fixture(scope="module")
def source():
    rng = np.random.default_rng(0)
    q = rng.uniform(LO, HI, size=(60, 6))
    return ModalPredictor(
        epochs=30,
        n_members=2,
        augment_copies=1,
        features="trig",
        target_transform="log",
        calibration="none",
    ).fit(q, smooth_modal(q))


def test_affine_recovers_an_exact_affine_shift(source):
    rng = np.random.default_rng(1)
    q = rng.uniform(LO, HI, size=(15, 6))
    base = SourceOnly(source).predict(q).values
    y = base * np.array([1.2, 0.8, 1.5])  # a constant factor per parameter: an offset in log
    m = AffineCorrection(source).fit(q, y)
    np.testing.assert_allclose(m.predict(q).values, y, rtol=1e-6)
    qq = rng.uniform(LO, HI, size=(5, 6))
    np.testing.assert_allclose(
        m.predict(qq).values, SourceOnly(source).predict(qq).values * [1.2, 0.8, 1.5], rtol=1e-6
    )


def test_gp_residual_learns_a_smooth_residual(source):
    rng = np.random.default_rng(2)
    q = rng.uniform(LO, HI, size=(25, 6))
    bump = lambda qq: np.exp(0.1 * np.sin(qq[:, 1:2]))[:, :, None, None]  # noqa: E731
    y = SourceOnly(source).predict(q).values * bump(q)
    gp = GPResidual(source).fit(q, y)
    qt = rng.uniform(LO, HI, size=(20, 6))
    truth = SourceOnly(source).predict(qt).values * bump(qt)
    err_gp = np.abs(np.log(gp.predict(qt).values / truth)).mean()
    err_src = np.abs(np.log(SourceOnly(source).predict(qt).values / truth)).mean()
    assert err_gp < 0.5 * err_src
    assert np.all(gp.predict(qt).std > 0)


def test_make_baselines_names(source):
    names = set(make_baselines(source, {"epochs": 5, "n_members": 2}, 0))
    assert names == {"source-only", "target-only", "affine", "gp-residual", "fine-tune-all"}
