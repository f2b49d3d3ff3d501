"""A robust plan's lobe sharing keeps its promise in every scenario (issue 25, item 4).

A robust plan's stated limit at a waypoint is the smallest over its scenarios
(the nominal modes, and each corner of the bound's joint region held at margin
1, :func:`robolobe.plan.modes.bound_scenario`) of the shared lobes. The
scenarios lower each mode by the spread at its own posture: where the spread
changes along the path, a member and its leader are lowered by different
amounts, so a member whose nominal modes equal its leader's can have a corner's
limit up to the grouping tolerance below the leader's (the damping's: 3 %).
A check of the members on the nominal modes alone cannot see it.

The path: three passes of a 200 mm zig-zag on robot A (the benchmark's
placement), 2 mm between waypoints; the modes: the twin of A with a damping
spread that grows from 0.20 to 0.35 (std of log zeta) with the base joint's
angle over the path (a transferred model's spread grows away from its tested
postures). The reference is each cutting waypoint's own scenario models
(feed frame and tool modes, :func:`robolobe.sld.toolpoint.tool_point_model`;
the bound, :func:`robolobe.plan.modes.plan_bound`) handed to the test's own
textbook ZOA (``tests/sld/zoa_reference.py``) at its planned speed, the
smallest over the scenarios: the stated ``a_lim_mm`` must lie within
[0.99, 1.005] of it. With the members checked on the nominal modes only, 8 of
the 299 waypoints were above 1.005 (up to 1.0068).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import robolobe.plan.modes
from robolobe.plan.job import load_job
from robolobe.plan.lobes import DynamicsTolerance, size_members, waypoint_lobes
from robolobe.plan.modes import TwinSource, bound_scenario, plan_bound
from robolobe.plan.pipeline import _tool_model, material_from_job, plan_path
from robolobe.robots import load_robot
from robolobe.sld.conditions import engagement_angles
from robolobe.sld.converged import LOBE_TOL
from robolobe.sld.frf import ModalModel
from robolobe.sld.material import get_material
from robolobe.sld.toolpoint import feed_frame, tool_point_model

from ..sld.zoa_reference import alphas, reference_envelope
from .conftest import example

#: The base joint's angle [rad] at the two ends of the path's range (from its IK).
Q1_ENDS = (0.0741, 0.0965)
#: Spread (std of log f, log zeta, log k) at either end.
SPREAD_ENDS = ((0.0, 0.20, 0.02), (0.0, 0.35, 0.02))


class _SpreadAlongPath:
    """The twin's modes with a calibrated spread that varies with the base joint."""

    name = "twin with a spread along the path"

    def __init__(self, robot) -> None:
        self.src = TwinSource(robot)

    def predict(self, q):
        m = self.src.predict(q)
        q1 = np.asarray(q, dtype=np.float64).reshape(-1, 6)[:, 0]
        t = np.clip((q1 - Q1_ENDS[0]) / (Q1_ENDS[1] - Q1_ENDS[0]), 0.0, 1.0)
        lo, hi = (np.asarray(s) for s in SPREAD_ENDS)
        std = lo + t[:, None] * (hi - lo)  # (n, 3)
        n, nd, nm = m.f_hz.shape
        log_std = np.broadcast_to(std[:, None, None, :], (n, nd, nm, 3)).copy()
        params = dataclasses.replace(m.parameters, log_std=log_std)
        return dataclasses.replace(m, parameters=params, spread_calibrated=True)


def _zigzag(path, passes: int = 3, per: int = 100, width_mm: float = 200.0) -> None:
    lines = ["%", "O3002", "G90 G21 G17", "S18000 M3", "G0 X0. Y0. Z5.", "G1 Z-1. F1000."]
    for k in range(passes):
        xs = np.linspace(0.0, width_mm, per)[:: -1 if k % 2 else 1]
        lines += [f"Y{10.0 * k:.3f}"] if k else []
        lines += [f"X{x:.3f} F4000." if i == 0 else f"X{x:.3f}" for i, x in enumerate(xs)]
    path.write_text("\n".join([*lines, "G0 Z5.", "M30", "%"]) + "\n", encoding="utf-8")


@pytest.mark.slow
def test_robust_sharing_keeps_its_promise_in_every_scenario(tmp_path, monkeypatch) -> None:
    # every mode lowered by its own k_sigma: the members' scenarios then differ by the
    # spread alone and most waypoints share lobes, which is what is tested here. Under
    # the default joint lowering (plan.modes.MODE_LOWERING) each mode's part of the
    # lowering also follows its share of the compliance, and on this path 298 of 303
    # waypoints get lobes of their own (as on the study's corrected twins under either
    # rule: 162 of 165 on C's pocket)
    monkeypatch.setattr(robolobe.plan.modes, "MODE_LOWERING", "each")
    path = tmp_path / "zigzag.nc"
    _zigzag(path)
    j = load_job(example("job_A_pocket.toml"))
    pl = j.placement.copy()
    pl[:3, 3] = [1.55, -0.15, 0.30]
    j = j.replace(placement=pl, plan=dataclasses.replace(j.plan, robust=True))
    src = _SpreadAlongPath(load_robot("A"))
    res = plan_path(path, j, source=src, refine=False)
    assert res.summary.robust
    sub = res.table[(res.table["motion"] == "cut").to_numpy()]
    q = np.radians(sub[[f"q{k}_deg" for k in range(1, 7)]].to_numpy(np.float64))
    assert q[:, 0].min() == pytest.approx(Q1_ENDS[0], abs=2e-3)
    assert q[:, 0].max() == pytest.approx(Q1_ENDS[1], abs=2e-3)
    # lobes are shared: the promise is that of the members
    assert res.lobes.n_base < 0.6 * len(sub)
    # each waypoint's own scenario models, feed frame as the planner's (plunges skipped)
    modes = src.predict(q)
    bound, robust = plan_bound(j.plan, modes, True)
    assert robust
    assert bound is not None
    fa = np.radians(sub["feed_angle_deg"].to_numpy(np.float64))
    f_tcp = np.stack([np.cos(fa), np.sin(fa), np.zeros_like(fa)], axis=1)
    plunge = (sub["limiting"] == "plunge").to_numpy()
    f_tcp[plunge] = [1.0, 0.0, 0.0]
    rot = feed_frame(f_tcp, (0.0, 0.0, -1.0), rotation="cw")
    tool = _tool_model(j)
    sf = j.plan.safety_factor
    scenarios = [tool_point_model(rot, modes.model, tool)]
    for bm, bw in bound.corners():
        assert np.all(bw == 0.0)  # no frequency spread: no speed windows
        scenarios.append(bound_scenario(tool_point_model(rot, bm, tool), sf))
    mat = material_from_job(j)
    alpha_job = alphas(*engagement_angles(j.radial_immersion, j.cut.milling), mat.kr)
    own_angles = "phi_entry_deg" in sub.columns
    rpm = sub["rpm"].to_numpy(np.float64)
    stated = sub["a_lim_mm"].to_numpy(np.float64) * 1e-3
    ratios, where, by_bound = [], [], 0
    for i in range(len(sub)):
        if plunge[i] or not np.isfinite(stated[i]):
            continue
        alpha = alpha_job
        if own_angles:
            pe, px = np.radians(sub[["phi_entry_deg", "phi_exit_deg"]].iloc[i].to_numpy(float))
            alpha = alphas(float(pe), float(px), mat.kr)
        refs = []
        for m in scenarios:
            mi = m.take(i)
            on = np.any(mi.residues != 0.0, axis=(-1, -2))
            refs.append(
                reference_envelope(
                    mi.f_hz[on], mi.zeta[on], mi.residues[on], alpha, teeth=j.tool.teeth,
                    kt=mat.kt, rpm=[rpm[i]],
                )[0]
            )  # fmt: skip
        by_bound += int(np.argmin(refs) > 0)
        ratios.append(stated[i] / min(refs))
        where.append(f"zigzag.nc:{sub['line'].iloc[i]}")
    r = np.asarray(ratios)
    assert r.size > 250
    assert by_bound > r.size // 2  # the bound's corners set the limit: the case in point
    bad = [(w, round(float(x), 5)) for w, x in zip(where, r, strict=True) if not 0.99 <= x <= 1.005]
    assert not bad, (len(bad), bad[:8])


def test_size_members_checks_every_scenario():
    """:func:`size_members` with one model per scenario, on hand-made groups: three
    waypoints with the same nominal modes (a robot mode at 14 Hz, a tool mode at
    1850 Hz) and a lowered scenario (the robot mode 1.6x softer, held at margin 1 over a
    safety factor of 1.3) in which one member's robot mode is 3 % softer still and
    another's 0.1 %. The reference: each member's own limit, the smallest over the two
    scenarios of the test's own ZOA. The 3 % member is flagged at every checked speed
    where the shared limit lies over its own by more than the promise (0.5 %), at none
    where they agree to 0.1 %; the 0.1 % member never is; the nominal models alone
    (the check before) flag the 3 % member nowhere."""
    mat = get_material("Al7075-T6")
    w = 2 * np.pi * np.array([14.0, 1850.0])
    u = np.array([np.cos(0.5), np.sin(0.5)])
    zeta = np.tile([0.03, 0.035], (3, 1))

    def model(scale):
        res = np.zeros((3, 2, 2, 2))
        for i, s in enumerate(scale):
            res[i, 0] = s * w[0] ** 2 / 1.5e6 * np.outer(u, u)
            res[i, 1] = w[1] ** 2 / 2.2e7 * np.eye(2)
        return ModalModel(np.tile(w, (3, 1)), zeta, res)

    nominal = model([1.0, 1.0, 1.0])
    low = model([1.6, 1.6 * 1.03, 1.6 * 1.001])
    low = ModalModel(low.omega, low.zeta, low.residues / 1.3)  # margin 1 over SF 1.3
    scenarios = [nominal, low]
    rpm = np.linspace(6000.0, 24000.0, 300)
    pe, px = np.radians(90.0), np.pi
    kw = dict(teeth=3, kt=mat.kt, rpm=rpm, immersion=0.5)
    tol = DynamicsTolerance(0.3, 0.3, 0.3, 0.3, 150.0)  # the three share
    shared = waypoint_lobes(scenarios, tol=tol, kr=mat.kr, phi_entry=pe, phi_exit=px, **kw)
    assert shared.n_groups == 1
    assert shared.leader[0] == 0  # the first of equal nominal modes (hand-made: checked)
    cut = dict(teeth=3, kt=mat.kt, kr=mat.kr, phi_entry=pe, phi_exit=px)
    speeds = rpm[::6]
    alpha = alphas(pe, px, mat.kr)
    own = np.full((3, speeds.size), np.inf)
    for i in (1, 2):
        for m in scenarios:
            mi = m.take(i)
            ref = reference_envelope(
                mi.f_hz, mi.zeta, mi.residues, alpha, teeth=3, kt=mat.kt, rpm=speeds
            )
            own[i] = np.minimum(own[i], ref)
    n_far = n_missed = 0
    for s_i, r in enumerate(speeds):
        at = np.full(3, r)
        flag = size_members(shared, scenarios, at, **cut)
        before = size_members(shared, nominal, at, **cut)
        stated = shared.table.query(at)
        ratio = stated[1:] / own[1:, s_i]
        assert not flag[0]
        assert not flag[2], (r, ratio)  # 0.1 % apart: inside the promise
        assert not before[1]
        if ratio[0] > 1.0 + LOBE_TOL:
            assert flag[1], (r, ratio)
            n_far += 1
            n_missed += int(not before[1])
        if abs(ratio[0] - 1.0) < 1e-3:
            assert not flag[1], (r, ratio)
    assert n_far > 0
    assert n_missed == n_far
