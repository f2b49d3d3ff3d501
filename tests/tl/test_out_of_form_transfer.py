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


def test_study_summary_per_robust_variant():
    """The study's figures per plan kind (written for the test): infeasible plans count
    0 MRR, a (robot, job) whose truth has no feasible plan is left out of the MRR, and
    each robust variant (the default, the region alone, the cut's spread, the largest
    spread) is its own row."""
    from out_of_form import summarize

    def plan(src, robust, job, mrr_rel, beyond=0, margin=1.5, draw=0, feasible=True):
        return {
            "robot": "C",
            "draw": draw,
            "transfer": True,
            "job": job,
            "source": src,
            "robust": robust,
            "feasible": feasible,
            "mrr_rel": mrr_rel,
            "n_beyond": beyond,
            "min_true_margin": margin,
        }

    rows = [
        plan("oracle", False, "a", 1.0),
        plan("oracle", False, "b", 1.0),
        plan("oracle", False, "c", 0.0, feasible=False),  # no oracle: MRR not compared
        plan("default", True, "a", 0.6),
        plan("default", True, "b", 0.9, margin=1.2),
        plan("default", True, "c", 0.0, feasible=False),
        plan("cut shifts", True, "a", 1.0, beyond=6, margin=0.93),
        plan("cut shifts", True, "b", 0.8, feasible=False),
        plan("region only", True, "a", 0.7),
        plan("largest shifts", True, "a", 0.4, margin=2.9),
        plan("largest shifts", True, "b", 0.5),
    ]
    s = summarize(rows)
    d = s["default (robust) plans"]
    assert (d["plans"], d["infeasible"], d["beyond"]) == (3, 1, 0)
    assert d["median_mrr_rel"] == pytest.approx(0.75)
    assert d["min_true_margin"] == pytest.approx(1.2)
    c = s["robust, modes shifted by the cut's spread (not the default)"]
    assert (c["beyond"], c["min_true_margin"], c["mrr_rel"]) == (6, 0.93, [1.0, 0.0])
    assert s["robust on the joint region only (no mode shifts)"]["mrr_rel"] == [0.7]
    g = s["robust, modes shifted by their largest spread (the default before)"]
    assert (g["plans"], g["median_mrr_rel"], g["min_true_margin"]) == (2, 0.45, 1.5)
    assert s["no_oracle"] == ["C0 c"]
