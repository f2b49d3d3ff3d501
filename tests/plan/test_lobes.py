"""Grouping of equal dynamics and per-waypoint lobes against direct ZOA calls."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.plan.lobes import DynamicsTolerance, _features, group_dynamics, waypoint_lobes
from robolobe.sld.conditions import engagement_angles
from robolobe.sld.directional import directional_factors
from robolobe.sld.frf import ModalModel
from robolobe.sld.zoa import zoa_lobes

RPM = np.linspace(6000.0, 24000.0, 120)


def models(n: int, spread: float, seed: int = 0) -> ModalModel:
    rng = np.random.default_rng(seed)
    f = np.stack([np.full(n, 1800.0), 20.0 * (1 + spread * rng.uniform(-1, 1, n))], axis=1)
    f = np.concatenate([f, f * [1.0, 1.3]], axis=1)
    z = np.full((n, 4), 0.03)
    k = np.tile([2e7, 5e5, 2e7, 8e5], (n, 1))
    return ModalModel.from_directional(f, z, k, ["xx", "xx", "yy", "yy"], dim=2)


def test_exact_grouping_only_merges_identical_models():
    m = models(6, 0.1)
    rep = ModalModel(
        np.r_[m.omega, m.omega[:2]], np.r_[m.zeta, m.zeta[:2]], np.r_[m.residues, m.residues[:2]]
    )
    group, leader = group_dynamics(rep, DynamicsTolerance(0.0, 0.0, 0.0))
    assert leader.size == 6
    assert group[6] == group[0]
    assert group[7] == group[1]
    assert len(set(group[:6])) == 6


def test_members_are_within_tolerance_of_their_leader():
    m = models(300, 0.05)
    tol = DynamicsTolerance(0.003, 0.03, 0.02)
    group, leader = group_dynamics(m, tol)
    f = _features(m, tol)
    d = np.abs(f - f[leader[group]]).max(axis=1)
    assert d.max() <= 1.0 + 1e-9
    assert 1 < leader.size < 300
    # leaders lead their own group
    assert np.array_equal(group[leader], np.arange(leader.size))


def test_waypoint_lobes_equal_direct_zoa_per_waypoint():
    m = models(5, 0.2, seed=2)
    st, ex = engagement_angles(0.5, "down")
    gl = waypoint_lobes(
        [m], teeth=3, kt=767e6, kr=0.22, phi_entry=st, phi_exit=ex, rpm=RPM, immersion=0.5,
        tol=DynamicsTolerance(0.0, 0.0, 0.0),
    )  # fmt: skip
    alpha = directional_factors(st, ex, 0.22)
    grids = m.frequency_grid(shared=False)  # the batch's grids, one row per waypoint
    for i in range(5):
        mi = m.take(np.array([i]))
        w = grids[i : i + 1]
        ref = zoa_lobes(
            w, mi.frf(w), alpha=alpha, teeth=3, kt=767e6, rpm=RPM, max_lobe=None, immersion=0.5
        )
        row = gl.table.a_lim[gl.table.group[i]]
        assert np.allclose(row, ref.a_lim[0], rtol=1e-12)
        speeds = np.array([7123.0, 15555.5, 23001.0])
        got = gl.table.query_shared(speeds)[i]
        assert np.allclose(got, ref.query(speeds[None, :])[0], rtol=1e-12)


def test_plunges_are_unbounded_and_robust_takes_the_minimum():
    m = models(4, 0.1)
    softer = ModalModel(m.omega, m.zeta * 0.7, m.residues * 1.4)
    st, ex = engagement_angles(0.5, "down")
    kw = dict(teeth=3, kt=767e6, kr=0.22, phi_entry=st, phi_exit=ex, rpm=RPM, immersion=0.5)
    unb = np.array([False, True, False, False])
    nominal = waypoint_lobes([m], unbounded=unb, **kw)
    robust = waypoint_lobes([m, softer], unbounded=unb, **kw)
    assert np.all(np.isinf(nominal.table.a_lim[nominal.table.group[1]]))
    assert np.all(np.isinf(nominal.table.query(np.full(4, 12000.0))[1]))
    for i in (0, 2, 3):
        a_n = nominal.table.a_lim[nominal.table.group[i]]
        a_r = robust.table.a_lim[robust.table.group[i]]
        assert np.all(a_r <= a_n * (1 + 1e-12))
        assert np.any(a_r < a_n * 0.99)
    assert nominal.valid
    assert nominal.message == ""
    low = waypoint_lobes([m], **{**kw, "immersion": 0.1})
    assert not low.valid
    assert "unreliable" in low.message


def test_query_padding_with_uneven_groups():
    m = models(6, 0.2, seed=5)
    st, ex = engagement_angles(1.0, "down")
    gl = waypoint_lobes(
        [m], teeth=2, kt=600e6, kr=0.3, phi_entry=st, phi_exit=ex, rpm=RPM, immersion=1.0,
        tol=DynamicsTolerance(0.0, 0.0, 0.0),
    )  # fmt: skip
    speeds = np.array([6500.0, 9000.0, 9000.0, 12000.0, 20000.0, 23999.0])
    got = gl.table.query(speeds)
    ref = np.array([gl.table.query_shared(speeds[[i]])[i, 0] for i in range(6)])
    assert got == pytest.approx(ref, rel=1e-12)
