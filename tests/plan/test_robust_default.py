"""Robust plans on the default predictor's own spread (issue 11).

A job whose ``robot.model`` names a ``robolobe transfer --robot R`` output (a
:class:`robolobe.tl.residual.CorrectedTwin`) plans robustly on that model's
calibrated spread unless the job says otherwise; ``plan.spread_*_pct`` keys
override the source's spread per quantity; summary.json states which spread
was used and at what confidence.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import robolobe.plan.modes
from robolobe._modal_parameters import ModalParameters
from robolobe.plan.job import job_from_dict, job_to_dict, load_job
from robolobe.plan.modes import (
    CorrectedTwinSource,
    RobotModes,
    TwinSource,
    as_mode_source,
    mode_source,
    plan_bound,
)
from robolobe.plan.pipeline import plan_path
from robolobe.robots import load_robot
from robolobe.sld.frf import ModalModel
from robolobe.tl.design import design_postures
from robolobe.tl.graybox import TwinCalibration
from robolobe.tl.residual import CorrectedTwin
from robolobe.tl.twin_data import twin_modal_dataset
from robolobe.twin import Twin
from robolobe.twin.designs import TESTED_RANGES_DEG

from .conftest import example


@pytest.fixture(scope="module")
def corrected_b(tmp_path_factory):
    """A corrected twin of B from 16 noisy hammer tests of a stiffer B, saved to .npz."""
    base = load_robot("B")
    truth = base.replace(
        joints=tuple(
            dataclasses.replace(j, stiffness_Nm_per_rad=1.15 * j.stiffness_Nm_per_rad)
            for j in base.joints
        )
    )
    q = design_postures(
        base, 16, rng=np.random.default_rng(3), ranges_deg=TESTED_RANGES_DEG["B"]
    ).q_rad
    ds = twin_modal_dataset(
        Twin(truth), [f"D{i}" for i in range(16)], q, rng=np.random.default_rng(4)
    )
    cal = TwinCalibration(robot=base, params=("stiffness",), random_state=0).fit_dataset(ds)
    model = CorrectedTwin(robot=base, prefit=cal).fit_dataset(ds)
    path = model.save(tmp_path_factory.mktemp("ct") / "B_pred.npz")
    return {"model": model, "path": path, "q": q, "base": base}


# k_sigma 2, spreads 0.05 (zeta) and 0.02 (k): the product k zeta lowered by
# 2 sqrt(0.05^2 + 0.02^2), the share 0.02^2 / (0.05^2 + 0.02^2) of it on k
K_LOW = 2 * math.sqrt(0.05**2 + 0.02**2) * 0.02**2 / (0.05**2 + 0.02**2)


def _modes(spread, calibrated, k):
    """One posture, 2 coupled modes, given per-direction stiffness (3, 2)."""
    f = np.broadcast_to(np.array([20.0, 40.0]), (1, 3, 2)).copy()
    z = np.full((1, 3, 2), 0.03)
    kk = np.asarray(k, dtype=float)[None]
    u = np.where(kk < 1e11, np.sqrt((2 * np.pi * f) ** 2 / kk), 0.0)[0]  # (3, 2)
    model = ModalModel.from_shapes(2 * np.pi * f[0, 0][None], z[0, 0][None], u.T[None])
    params = ModalParameters(f, z, kk, ("xx", "yy", "zz"), log_std=spread)
    return RobotModes(params, model, None, "test", True, calibrated)


def test_plan_bound_is_robust_by_default_only_on_a_calibrated_spread(monkeypatch):
    # each mode lowered by k_sigma of its own spread (the lowering together is tested in
    # test_mode_lowering.py)
    monkeypatch.setattr(robolobe.plan.modes, "MODE_LOWERING", "each")
    k = [[1e6, 1e12], [2e6, 5e6], [1e12, 1e12]]
    std = np.zeros((1, 3, 2, 3))
    std[..., 0], std[..., 1], std[..., 2] = 0.01, 0.05, 0.02
    plan = load_job(example("job_B_contour.toml")).plan
    auto = dataclasses.replace(plan, robust=None)
    # the twin (no spread, not calibrated): plain unless asked
    bound, robust = plan_bound(auto, _modes(None, False, k))
    assert bound is None
    assert robust is False
    # a calibrated spread: robust by default, on that spread
    bound, robust = plan_bound(auto, _modes(std, True, k))
    assert robust is True
    assert bound is not None
    assert "calibrated" in bound.how
    assert bound.window[0] == pytest.approx(0.02)
    assert bound.describe()["stiffness_lowered_to_pct"] == pytest.approx(
        100 * math.exp(-K_LOW), abs=0.01
    )
    # an uncalibrated source spread (a network's ensemble): plain unless asked
    assert plan_bound(auto, _modes(std, False, k)) == (None, False)
    # the job says no: plain
    assert plan_bound(dataclasses.replace(plan, robust=False), _modes(std, True, k))[0] is None
    # a job key overrides the source's spread of that quantity only
    over = dataclasses.replace(
        auto, assumed_spread=(0.03, 0.05, 0.02), spread_set=(True, False, False)
    )
    bound, _ = plan_bound(over, _modes(std, True, k))
    assert bound.window[0] == pytest.approx(0.06)
    assert "the job's spread for f" in bound.how
    assert bound.describe()["stiffness_lowered_to_pct"] == pytest.approx(
        100 * math.exp(-K_LOW), abs=0.01
    )


def test_coupled_spread_is_that_of_the_direction_that_sees_the_mode(monkeypatch):
    monkeypatch.setattr(robolobe.plan.modes, "MODE_LOWERING", "each")
    # mode 1 is seen along x (k 1e6) and barely along z (k 1e10): the barely-seen
    # direction's huge relative stiffness spread must not soften the mode
    k = [[1e6, 1e12], [1e12, 5e6], [1e10, 1e12]]
    std = np.zeros((1, 3, 2, 3))
    std[..., 2] = 0.02
    std[0, 2, 0, 2] = 5.0
    b = _modes(std, True, k).robust(2.0)
    lowered = b.model.residues[0, 0, 0, 0] / _modes(std, True, k).model.residues[0, 0, 0, 0]
    assert lowered == pytest.approx(math.exp(0.04))
    assert b.describe()["spread_pct_max"]["k"] == pytest.approx(100 * math.expm1(0.02), abs=1e-3)


def test_job_round_trip_keeps_unset_robust_and_set_spreads():
    job = load_job(example("job_B_contour.toml"))
    assert job.plan.robust is None  # the bundled job leaves it unset
    d = job_to_dict(job)
    assert "robust" not in d["plan"]
    assert "spread_k_pct" not in d["plan"]
    d["plan"]["spread_k_pct"] = 7.0
    back = job_from_dict(d)
    assert back.plan.robust is None
    assert back.plan.spread_set == (False, False, True)
    assert back.plan.assumed_spread[2] == pytest.approx(math.log1p(0.07))
    again = job_from_dict(job_to_dict(back))
    assert again.plan.robust is None
    assert again.plan.spread_set == (False, False, True)
    forced = job_to_dict(job.replace(plan=dataclasses.replace(job.plan, robust=False)))
    assert forced["plan"]["robust"] is False


@pytest.mark.slow
def test_corrected_twin_source_is_the_calibrated_twin_with_its_correction(corrected_b):
    ct, q = corrected_b["model"], corrected_b["q"][:5]
    src = as_mode_source(ct)
    assert isinstance(src, CorrectedTwinSource)
    m = src.predict(q)
    assert m.shapes_coupled
    assert m.spread_calibrated
    # per tested direction and mode: the model's own corrected f and k
    pred = ct.predict(q, warn=False, spread=False).values  # (n, dir, mode, 3)
    for j, d in enumerate(ct.directions_):
        ax = "xyz".index(d[0])
        seen = pred[:, j, :, 2] < 1e11
        np.testing.assert_allclose(m.k_N_per_m[:, ax, :5][seen], pred[:, j, :, 2][seen], rtol=1e-6)
        uncorrected = np.all(ct.alpha_[..., 0] == 0, axis=0)  # in every direction
        np.testing.assert_allclose(
            m.f_hz[:, ax, :5][:, uncorrected], pred[:, j, uncorrected, 0], rtol=1e-9
        )

    # the coupled model has the corrected stiffness (omega^2 / u^2 per direction, in the
    # same relation to the stated k as the calibrated twin's own model)
    def k_of(modes):
        res = np.diagonal(modes.model.residues, axis1=-2, axis2=-1).transpose(0, 2, 1)
        return modes.model.omega[:, None, :] ** 2 / res

    tw = TwinSource(ct.robot_).predict(q)
    vis = m.k_N_per_m < 1e11
    np.testing.assert_allclose(
        (k_of(m) / m.k_N_per_m)[vis], (k_of(tw) / tw.k_N_per_m)[vis], rtol=1e-9
    )
    # spread: per posture, finite, positive where the mode is seen
    assert np.all(np.isfinite(m.log_std))
    assert np.all(m.log_std[vis] > 0)


@pytest.mark.slow
def test_a_job_naming_the_transfer_output_plans_robustly_on_its_spread(corrected_b):
    path = corrected_b["path"]
    src, note = mode_source(str(path), load_robot("B"), "B")
    assert isinstance(src, CorrectedTwinSource)
    assert not note
    # the bundled job leaves plan.robust unset, as a user's copy of it does
    auto = load_job(example("job_B_contour.toml")).replace(model=str(path))
    assert auto.plan.robust is None
    res = plan_path(example("contour.apt"), auto, refine=False)
    s = res.summary
    assert s.robust is True
    assert s.robust_by_default is True
    b = s.robust_bound
    assert b is not None
    assert "calibrated prediction-error spread" in b.spread_from
    assert b.confidence_pct == pytest.approx(95.45, abs=0.01)  # the joint region (issue 27)
    assert b.spread_pct_median is not None
    assert b.spread_pct_median.f > 0
    assert any("robust by default" in n for n in s.notes)
    # robust = false in the job plans on the nominal modes
    job = auto.replace(plan=dataclasses.replace(auto.plan, robust=False))
    plain = plan_path(example("contour.apt"), job, refine=False)
    assert plain.summary.robust is False
    assert plain.summary.robust_bound is None
    assert res.outcome.best.depth_m <= plain.outcome.best.depth_m
    # and a twin job with robust unset stays a nominal plan
    twin = auto.replace(model="twin")
    assert plan_path(example("contour.apt"), twin, refine=False).summary.robust is False


@pytest.mark.slow
def test_verify_on_the_transfer_output_reproduces_its_plan(corrected_b, tmp_path):
    from robolobe.plan import write_outputs
    from robolobe.plan.verify import verify_plan

    job = load_job(example("job_B_contour.toml")).replace(model=str(corrected_b["path"]))
    job = job.replace(plan=dataclasses.replace(job.plan, robust=False))
    res = plan_path(example("contour.apt"), job, refine=False)
    write_outputs(res, tmp_path / "p", plots=False, html_report=False)
    v = verify_plan(tmp_path / "p", model=corrected_b["path"], job=job)
    assert v.mode_source.startswith("corrected twin")
    t = v.table
    ok = np.isfinite(t["a_lim_plan_mm"])
    assert ok.sum() > 5
    np.testing.assert_allclose(t["a_lim_mm"][ok], t["a_lim_plan_mm"][ok], rtol=0, atol=1e-9)


class _Lowered:
    """The twin's modes with every residue times ``factor`` (stiffness / factor): a bound
    built here, independently of RobotModes.robust."""

    def __init__(self, robot, factor):
        self.src = TwinSource(robot)
        self.factor = factor
        self.name = "lowered twin"

    def predict(self, q):
        m = self.src.predict(q)
        low = ModalModel(m.model.omega, m.model.zeta, m.model.residues * self.factor)
        return dataclasses.replace(m, model=low)


@pytest.mark.slow
def test_a_robust_plan_gives_no_less_than_a_plain_plan_safe_on_the_bound(tmp_path):
    """Issue 27: the bound is held at margin 1, the safety factor on the prediction.

    Stiffness spread 4 % at 2 sigma lowers every mode's stiffness to exp(-0.08) =
    92.3 %: the plain plan (margin 1.3 on the twin) keeps a margin near 1.2 on that
    bound, so the robust plan is the plain plan (the old rule, the bound divided by
    the safety factor, planned 8 % shallower). A 30 % spread lowers to 55 %: the
    plain plan is beyond that bound, the robust plan is not.
    """
    from robolobe.plan import write_outputs
    from robolobe.plan.verify import verify_plan

    job = load_job(example("job_A_pocket.toml")).replace(model="twin")
    robot = load_robot("A")
    sf = job.plan.safety_factor
    assert sf == pytest.approx(1.3)
    plain = plan_path(example("pocket.nc"), job, refine=False)
    d_plain = tmp_path / "plain"
    write_outputs(plain, d_plain, plots=False, html_report=False)
    for s_k, same in ((0.04, True), (0.45, False)):
        rj = job.replace(
            plan=dataclasses.replace(
                job.plan,
                robust=True,
                k_sigma=2.0,
                assumed_spread=(0.0, 0.0, s_k),
                spread_set=(True, True, True),
            )
        )
        rob = plan_path(example("pocket.nc"), rj, refine=False)
        assert rob.summary.robust
        mrr_p, mrr_r = plain.summary.mrr_cm3_per_min, rob.summary.mrr_cm3_per_min
        bound = _Lowered(robot, math.exp(2.0 * s_k))
        on_bound = verify_plan(d_plain, source=bound, job=job, dynamics_tol=0.0)
        d_rob = tmp_path / f"robust_{s_k}"
        write_outputs(rob, d_rob, plots=False, html_report=False)
        rob_on_bound = verify_plan(d_rob, source=bound, job=job, dynamics_tol=0.0)
        assert rob_on_bound.min_margin >= 1.0 - 0.02  # never beyond its bound
        if same:
            assert on_bound.min_margin >= 1.0  # the plain plan is safe on the bound
            assert mrr_r >= mrr_p * (1 - 1e-6)
        else:
            assert on_bound.min_margin < 1.0
            assert mrr_r < mrr_p


def test_speed_window_is_that_of_the_modes_that_set_the_limit():
    """Issue 27: a weak mode's wide frequency spread does not widen the speed window.

    Two coupled modes seen along x only; peak compliance 1 / (2 k zeta) per mode
    (same damping): the window is k_sigma times the frequency spread of the modes
    with at least half the largest peak, the stated spread that of every mode over 5 %.
    """
    std = np.zeros((1, 3, 2, 3))
    std[0, :, 0, 0] = 0.01  # the strong mode's frequency: well known
    std[0, :, 1, 0] = 0.10  # the weak mode's: poorly
    plan = dataclasses.replace(load_job(example("job_B_contour.toml")).plan, robust=None)
    # the second mode 10x stiffer: a tenth of the peak (matters, does not set the limit)
    weak = [[1e6, 1e7], [1e12, 1e12], [1e12, 1e12]]
    bound, _ = plan_bound(plan, _modes(std, True, weak))
    assert bound.window[0] == pytest.approx(2 * 0.01)
    assert bound.std_max[0] == pytest.approx(0.10)  # stated: every mode that matters
    # 1.5x stiffer: two thirds of the peak, it sets the limit too
    close = [[1e6, 1.5e6], [1e12, 1e12], [1e12, 1e12]]
    bound, _ = plan_bound(plan, _modes(std, True, close))
    assert bound.window[0] == pytest.approx(2 * 0.10)
    # a tiny mode (under 5 %): neither
    tiny = [[1e6, 1e8], [1e12, 1e12], [1e12, 1e12]]
    bound, _ = plan_bound(plan, _modes(std, True, tiny))
    assert bound.window[0] == pytest.approx(2 * 0.01)
    assert bound.std_max[0] == pytest.approx(0.01)


def test_stiffness_and_damping_are_lowered_by_k_sigma_spreads_of_their_product():
    """Issue 27: the bound on k zeta (a mode's peak compliance) is k_sigma spreads of it.

    The lowered model's residues (1 / k) and damping, read back mode by mode.
    """
    k = [[1e6, 1e12], [1e12, 1e12], [1e12, 1e12]]
    plan = dataclasses.replace(load_job(example("job_B_contour.toml")).plan, robust=None)
    for s_z, s_k in ((0.0, 0.1), (0.1, 0.0), (0.06, 0.08)):
        std = np.zeros((1, 3, 2, 3))
        std[..., 1], std[..., 2] = s_z, s_k
        modes = _modes(std, True, k)
        bound, _ = plan_bound(plan, modes)
        z_ratio = bound.model.zeta[0, 0] / modes.model.zeta[0, 0]
        k_ratio = np.trace(modes.model.residues[0, 0]) / np.trace(bound.model.residues[0, 0])
        # the product lowered by exactly 2 sqrt(s_z^2 + s_k^2), shared by variance
        assert math.log(z_ratio * k_ratio) == pytest.approx(-2 * math.hypot(s_z, s_k))
        if s_z == 0.0 or s_k == 0.0:  # one spread: that quantity by 2 spreads, as before
            assert math.log(k_ratio) == pytest.approx(-2 * s_k)
        else:
            assert math.log(k_ratio) / math.log(z_ratio) == pytest.approx(s_k**2 / s_z**2)
        d = bound.describe()
        assert d["stiffness_lowered_to_pct"] == pytest.approx(100 * k_ratio, abs=0.01)
        assert d["damping_lowered_to_pct"] == pytest.approx(100 * z_ratio, abs=0.01)
