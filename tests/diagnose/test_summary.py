"""The summary's shares and calibration sentence."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest

from robolobe.diagnose.forward import forward_select
from robolobe.diagnose.summary import _calibration_effect, _pct, _shares


@pytest.mark.parametrize(
    ("share", "text"),
    [(0.0, "0.0 %"), (0.0004, "< 0.1 %"), (0.003, "0.3 %"), (0.42, "42 %"), (0.9996, "> 99.9 %")],
)
def test_a_small_share_is_not_shown_as_zero(share: float, text: str) -> None:
    assert _pct(share) == text


def test_shares_give_each_steps_misfit_before_and_after(toy: SimpleNamespace) -> None:
    # a large mass and a small stiffness error: the second step's share of the explained
    # misfit is tiny, but it takes what is left down to the noise, and the summary says so
    obs = toy.obs((("mass", 150.0), ("kx", 1.01)))
    fw = forward_select(toy.candidates(), toy.model, obs, obs)
    assert len(fw.steps) == 2
    txt = _shares(fw)
    assert fw.steps[1].share < 0.01
    assert "0 %" not in txt.replace("0.0 %", "")
    x = [np.sqrt(fw.baseline_cv.per_residual)] + [np.sqrt(s.per_residual) for s in fw.steps]
    assert f"{x[0]:.1f} -> {x[1]:.1f} x the noise" in txt
    assert f"{x[1]:.1f} -> {x[2]:.1f} x the noise" in txt


def test_calibration_as_a_later_step_is_compared_with_the_nominal_file(
    toy: SimpleNamespace,
) -> None:
    obs = toy.obs((("mass", 150.0), ("kx", 1.01)))
    fw = forward_select(toy.candidates(), toy.model, obs, obs)
    # present the second step as the file calibration (the sentence depends on its
    # place among the steps and on the misfits only)
    cal = dataclasses.replace(fw.steps[1].candidate, name="file_parameters")
    steps = (fw.steps[0], dataclasses.replace(fw.steps[1], candidate=cal))
    txt = _calibration_effect(dataclasses.replace(fw, steps=steps))
    x0 = np.sqrt(fw.baseline_cv.per_residual)
    x1, x2 = (np.sqrt(s.per_residual) for s in fw.steps)
    assert f"on top of {fw.steps[0].label}" in txt
    assert f"from {x1:.1f} to {x2:.1f} x the noise" in txt
    # against the nominal file too (round 1 of the toy has no calibration to compare)
    assert f"the nominal file misses by {x0:.1f} x)" in txt
