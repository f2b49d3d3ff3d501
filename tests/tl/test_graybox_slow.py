"""Issue 5's accuracy goals with the twin calibration, on robots whose files are wrong.

Marked slow (~30 s). A concealed "real" B and C are drawn from their robot
files as in ``studies/tl_graybox.py`` (joint stiffness, damping, spindle mass,
link masses, centres of mass 5 cm off per axis, and inertia-shape errors the
calibration does not model). Trained on the seed paper's 20 postures, scored
at its 5 test postures against the truth's modes and the measured FRFs.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from robolobe.robots import load_robot

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))
from concealed_robots import concealed_robot

from robolobe.tl.dataset import dataset_from_frame
from robolobe.tl.evaluate import evaluate_prediction
from robolobe.tl.graybox import PRIOR_STD, TwinCalibration, twin_values
from robolobe.tl.twin_data import measured_frfs, twin_modal_dataset, twin_modal_values
from robolobe.twin import Twin
from robolobe.twin.designs import design_arrays, seed_design
from robolobe.twin.params import PARAMETER_GROUPS


def _truth(key: str, seed: int):
    """The robot file and a concealed real robot (physically valid, through the loader)."""
    base = load_robot(key)
    return base, concealed_robot(base, np.random.default_rng(seed))


def _goals(values, y_true, freq, h, decay):
    ev = evaluate_prediction(values, y_true, freq_hz=freq, h_measured=h, window_decay_per_s=decay)
    e = ev.median_errors()
    return e, float(np.min(ev.frac)), float(np.max(ev.nrmse))


@pytest.mark.slow
def test_calibration_meets_the_goals_on_b_with_a_wrong_file():
    ids, q, roles = design_arrays(seed_design("B"))
    roles = np.asarray(roles)
    base, truth = _truth("B", 11)
    twin = Twin(truth)
    rng = np.random.default_rng(5)
    ds = twin_modal_dataset(twin, ids, q, rng=rng)
    test = roles == "test"
    freq, h, decay = measured_frfs(
        twin, [ids[i] for i in np.flatnonzero(test)], q[test], robot="B", rng=rng
    )
    y, seen = twin_modal_values(twin, q[test])
    y = np.where(seen[..., None], y, np.nan)
    cal = TwinCalibration(robot=base).fit_dataset(ds.subset(roles == "train"))
    e, frac_min, nrmse_max = _goals(cal.predict(q[test]).values, y, freq, h, decay)
    np.testing.assert_array_less(e, [1.0, 10.0, 5.0])  # median % errors f, zeta, k
    assert frac_min >= 0.95
    assert nrmse_max <= 0.15
    # the robot file itself misses them (this is what the calibration fixes)
    e0, frac0, _ = _goals(twin_values(base, q[test]), y, freq, h, decay)
    assert e0[0] > 2.0
    assert frac0 < 0.9


@pytest.mark.slow
def test_calibration_on_identified_hammer_tests_of_c():
    from robolobe.modal.identify import identify_campaign
    from robolobe.twin.campaign import simulate_campaign

    ids, q, roles = design_arrays(seed_design("C"))
    ids = [str(i) for i in ids]
    roles = np.asarray(roles)
    base, truth = _truth("C", 12)
    twin = Twin(truth)
    camp = simulate_campaign(
        twin.receptance, "C", ids, q, rng=np.random.default_rng(6), dirs=("xx", "yy")
    )
    ds = dataset_from_frame(identify_campaign(camp).table, directions=("xx", "yy"), n_modes=5)
    train = [i for i, r in zip(ids, roles, strict=True) if r == "train"]
    cal = TwinCalibration(robot=base).fit_dataset(ds.select_ids(train))
    test = roles == "test"
    pos = [camp.index(i) for i in np.asarray(ids)[test]]
    h = np.stack([[camp.frfs[i].H[:, a, a] for a in (0, 1)] for i in pos])
    decay = -np.log(float(camp.test["window_end"])) / float(camp.test["duration_s"])
    y, seen = twin_modal_values(twin, q[test])
    y = np.where(seen[..., None], y, np.nan)
    e, frac_min, nrmse_max = _goals(cal.predict(q[test]).values, y, camp.frfs[0].freq_hz, h, decay)
    np.testing.assert_array_less(e, [1.0, 10.0, 5.0])  # median % errors f, zeta, k
    assert frac_min >= 0.95
    assert nrmse_max <= 0.15


@pytest.mark.slow
@pytest.mark.parametrize("key", ["B", "C"])
def test_identified_tests_of_the_exact_file_keep_it(key):
    """Identified hammer tests of the robot the file describes: no parameter wanders."""
    from robolobe.modal.identify import identify_campaign
    from robolobe.twin.campaign import simulate_campaign

    ids, q, roles = design_arrays(seed_design(key))
    ids = [str(i) for i in ids]
    base = load_robot(key)
    camp = simulate_campaign(
        Twin(base).receptance, key, ids, q, rng=np.random.default_rng(5), dirs=("xx", "yy")
    )
    ds = dataset_from_frame(identify_campaign(camp).table, directions=("xx", "yy"), n_modes=5)
    train = [i for i, r in zip(ids, roles, strict=True) if r == "train" and i in ds.posture_ids]
    fit = TwinCalibration(robot=base).fit_dataset(ds.select_ids(train))
    sd = np.concatenate([np.full(PARAMETER_GROUPS[g], PRIOR_STD[g]) for g in fit.groups_])
    scaled = np.abs(fit.theta_) / sd
    # identification biases (k 2.5-4.5 %, zeta 2-7 % at p90) may pull a weakly seen
    # parameter to about one prior standard deviation, never to its bound
    assert scaled.max() < 1.25, fit.param_names_[int(scaled.argmax())]
    assert fit.at_bounds_ == ()
    np.testing.assert_allclose(fit.factors_["stiffness"], 1.0, atol=0.03)
