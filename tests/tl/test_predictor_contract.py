"""One contract for every posture -> modal-parameter predictor.

``ModalPredictor`` (the seed's network), ``TwinCalibration`` and
``CorrectedTwin`` are interchangeable mode sources for planning
(``robolobe.plan_path(..., modes=...)``): same ``fit_dataset`` /
``predict`` surface, the same :class:`~robolobe.tl.estimator.ModalPrediction`
(shape ``(n, n_dir, n_modes, 3)``: f [Hz], zeta [-], k [N/m]), the same
errors. Data: exact-file twin modes of robot B at 14 designed postures with
identification-like scatter.
"""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.tl.design import design_postures
from robolobe.tl.estimator import ModalPrediction, ModalPredictor
from robolobe.tl.graybox import TwinCalibration
from robolobe.tl.residual import CorrectedTwin
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin import Twin
from robolobe.twin.designs import TESTED_RANGES_DEG

DIRS = ("xx", "yy")
N_MODES = 3


def _network() -> ModalPredictor:
    return ModalPredictor(
        directions=DIRS, n_modes=N_MODES, hidden=(16, 16), epochs=60, n_members=2, random_state=0
    )


def _calibration() -> TwinCalibration:
    return TwinCalibration(robot="B", params=("stiffness", "damping"), n_starts=1)


def _corrected() -> CorrectedTwin:
    return CorrectedTwin(robot="B", calibration={"params": ("stiffness", "damping"), "n_starts": 1})


FACTORIES = {"network": _network, "twin-calibration": _calibration, "corrected-twin": _corrected}


@pytest.fixture(scope="module")
def data():
    robot = load_robot("B")
    rng = np.random.default_rng(7)
    design = design_postures(robot, 14, rng=rng, ranges_deg=TESTED_RANGES_DEG["B"])
    ds = twin_modal_dataset(
        Twin(robot),
        [f"P{i}" for i in range(len(design.q_rad))],
        design.q_rad,
        directions=DIRS,
        n_modes=N_MODES,
        rng=rng,
    )
    q_new = design_postures(
        robot, 4, rng=np.random.default_rng(8), ranges_deg=TESTED_RANGES_DEG["B"]
    ).q_rad
    return ds, q_new


@pytest.fixture(scope="module")
def fitted(data):
    ds, _ = data
    return {name: make().fit_dataset(ds) for name, make in FACTORIES.items()}


@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_unfitted_predictor_says_so(name: str) -> None:
    with pytest.raises(InputError, match="not fitted"):
        FACTORIES[name]().predict(np.zeros((1, 6)))


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FACTORIES))
def test_prediction_shape_units_and_determinism(name: str, data, fitted) -> None:
    ds, q_new = data
    model = fitted[name]
    pred = model.predict(q_new)
    assert isinstance(pred, ModalPrediction)
    assert tuple(pred.directions) == DIRS
    assert pred.values.shape == (len(q_new), len(DIRS), N_MODES, 3)
    assert pred.std.shape == pred.values.shape
    assert np.all(np.isfinite(pred.std[np.isfinite(pred.center)]))
    assert np.all(pred.std[np.isfinite(pred.std)] >= 0)
    f, z, k = pred.f_hz, pred.zeta, pred.k_N_per_m
    seen = np.isfinite(f)
    assert seen.mean() > 0.8
    # units: robot modes in Hz, damping as a fraction, stiffness in N/m
    assert np.all((f[seen] > 1.0) & (f[seen] < 200.0))
    assert np.all((z[seen] > 0.0) & (z[seen] < 0.5))
    assert np.all((k[seen] > 1e4) & (k[seen] < 1e12))
    # the one modal-parameter type: the same values (physical units) and the log spread
    params = pred.parameters()
    assert params.shape == (len(q_new), len(DIRS), N_MODES)
    assert params.directions == DIRS
    np.testing.assert_array_equal(params.stacked(), pred.values)
    np.testing.assert_array_equal(params.log_std, pred.log_std)
    # close to the data it was fitted on (B's lowest modes are 5-30 Hz)
    fit_f = model.predict(ds.q_rad).f_hz
    rel = np.abs(fit_f / ds.y[..., 0] - 1.0)
    assert np.nanmedian(rel) < 0.1
    # deterministic: the same call twice, and a refit with the same settings
    again = model.predict(q_new)
    np.testing.assert_array_equal(again.center, pred.center)
    refit = FACTORIES[name]().fit_dataset(ds).predict(q_new)
    np.testing.assert_allclose(refit.center, pred.center, rtol=1e-9, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(FACTORIES))
@pytest.mark.parametrize(
    ("q", "what"), [(np.zeros((2, 5)), "shape"), (np.full((1, 6), np.nan), "finite")]
)
def test_bad_postures_are_refused(name: str, fitted, q, what) -> None:
    with pytest.raises(InputError):
        fitted[name].predict(q)


@pytest.mark.filterwarnings("ignore::robolobe.tl.dataset.TrustWarning")
def test_transfer_policy_lives_in_the_library(data) -> None:
    """``robolobe.transfer`` picks the predictor as ``robolobe transfer`` does."""
    import robolobe as rl
    from robolobe.tl.transfer import default_method

    assert default_method("B", None, None) == "corrected-twin"
    assert default_method("B", "A", None) == "network"
    assert default_method(None, None, "twin-calibration") == "twin-calibration"
    with pytest.raises(InputError, match="robot"):
        default_method(None, None, None)
    with pytest.raises(InputError, match="expected one of"):
        default_method("B", None, "gp")
    ds, q_new = data
    df = ds.to_frame()
    with pytest.raises(InputError, match="robot file to calibrate"):
        rl.transfer(df, method="twin-calibration")
    with pytest.raises(InputError, match="at least"):
        rl.transfer(df.iloc[:10], robot="B", method="twin-calibration")
    model = rl.transfer(df, robot="B", method="twin-calibration", params=("stiffness",))
    assert isinstance(model, TwinCalibration)
    assert model.predict(q_new).values.shape == (len(q_new), len(DIRS), N_MODES, 3)
