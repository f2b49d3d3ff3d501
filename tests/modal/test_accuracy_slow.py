"""Accuracy study (smaller version of studies/modal_accuracy.py): simulated campaigns of A, B, C.

Targets of the modal identification issue, against the twin's true modes
(``Twin.modes``), for modes visible at the driving point (5 % of the FRF
peak, measured domain; see :mod:`robolobe.modal.validation`):
90th percentile of |relative error| f < 0.5 %, zeta < 10 %, k < 10 %;
synthesized FRFs FRAC >= 0.95 and NRMSE <= 0.15 for every posture and direction.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

# the study harness (simulated campaigns of the twin) is study code, not library code
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "studies"))
from modal_accuracy import accuracy_study


@pytest.mark.slow
@pytest.mark.parametrize(
    ("robot", "n", "coherence"),
    [("A", 100, True), ("B", 25, True), ("C", 29, True), ("B", 25, False), ("C", 29, False)],
)
def test_accuracy_on_simulated_campaign(robot: str, n: int, coherence: bool) -> None:
    """``coherence=False`` is what ``robolobe identify`` does on a frf.csv campaign."""
    res = accuracy_study(
        robot, n_postures=n, rng=np.random.default_rng(2026), n_jobs=1, use_coherence=coherence
    )
    rep = res.report
    p90 = rep.percentile(90)
    assert p90["f"] < 0.005, p90
    assert p90["zeta"] < 0.10, p90
    assert p90["k"] < 0.10, p90
    assert len(rep.missed) <= 0.05 * rep.n_visible, rep.missed
    assert len(rep.spurious) <= 0.02 * len(rep.matched), rep.spurious
    assert res.fit["frac"].min() >= 0.95
    assert res.fit["nrmse"].max() <= 0.15
