"""The default transfer on a robot outside the twin's form (issue 27).

The campaign is the out-of-form study's robot B, draw 6 (``studies/out_of_form.py``:
a servo mode, a spindle bracket, load-dependent joints, file values off), whose
calibration has an ill-conditioned Jacobian: the saved model must load again.
"""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))


@pytest.mark.slow
def test_out_of_form_transfer_saves_a_model_that_loads(tmp_path):
    from out_of_form import draw_truth

    from robolobe.modal.identify import identify_campaign
    from robolobe.robots import load_robot
    from robolobe.tl.design import design_postures
    from robolobe.tl.models import load_model
    from robolobe.tl.residual import SPREAD_CONFIDENCE, CorrectedTwin
    from robolobe.tl.transfer import transfer
    from robolobe.twin.campaign import simulate_campaign
    from robolobe.twin.designs import TESTED_RANGES_DEG

    base = load_robot("B")
    truth = draw_truth(base, "B", 6)
    q = design_postures(
        base, 20, rng=np.random.default_rng(506), ranges_deg=TESTED_RANGES_DEG["B"]
    ).q_rad
    ids = [f"T{i + 1:02d}" for i in range(len(q))]
    camp = simulate_campaign(
        truth.receptance, "B", ids, q, rng=np.random.default_rng(7006), fmax_hz=150.0
    )
    modal = identify_campaign(camp).table
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = transfer(modal, robot="B")
    cov = model.calibration_.covariance_
    np.testing.assert_array_equal(cov, cov.T)
    back = load_model(model.save(tmp_path / "B_pred.npz"))  # was: 'expected a symmetric matrix'
    assert isinstance(back, CorrectedTwin)
    # the spread is calibrated on the campaign's held-out tests: as stated, cross-validated
    assert np.all(np.abs(back.spread_cover_ - SPREAD_CONFIDENCE) < 0.05)
