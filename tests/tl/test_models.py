"""The shipped models (src/robolobe/data/models): load and basic accuracy on the twin.

Reference: robot B's twin (robolobe.twin) at the paper's Table 3 test
postures, which the shipped B model never saw. Tolerances are looser than
the accuracy study's goals (tl_accuracy: median f error <= 1 %): this test
only guards against a broken or stale shipped file.
"""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.robots import load_robot
from robolobe.tl.evaluate import percent_errors
from robolobe.tl.models import SHIPPED, load_model, shipped_info
from robolobe.tl.twin_data import twin_modal_values
from robolobe.twin.designs import B_TEST_DEG, C_TEST_DEG
from robolobe.twin.model import Twin


@pytest.mark.parametrize("key", SHIPPED)
def test_shipped_models_load(key):
    m = load_model(key)
    assert m.robot == key
    assert m.lineage_[-1] == key
    assert m.n_frozen_used_ == (0 if key == "A" else 3)
    assert key in shipped_info()["models"]


@pytest.mark.parametrize(("key", "test_deg"), [("B", B_TEST_DEG), ("C", C_TEST_DEG)])
def test_shipped_transfer_predicts_unseen_test_postures(key, test_deg):
    q = np.radians(np.asarray(test_deg, dtype=float))
    y, seen = twin_modal_values(Twin(load_robot(key)), q)
    pred = load_model(key).predict(q, warn=False)
    err = percent_errors(pred.values, np.where(seen[..., None], y, np.nan))
    med = np.nanmedian(err.reshape(-1, 3), axis=0)
    assert med[0] < 2.0  # natural frequency, %
    assert med[1] < 15.0  # damping, %
    assert med[2] < 15.0  # modal stiffness, %
