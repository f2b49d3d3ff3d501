"""Lobe envelopes: exactness against brute force, queries, completeness."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.sld import (
    ModalModel,
    directional_factors,
    engagement_angles,
    lobe_envelope,
    zoa_depth,
    zoa_eigenvalues,
    zoa_lobes,
)

from .sld_reference import KR, KT, N_TEETH


def _lobe_data(model: ModalModel, immersion: float, milling: str = "down", **grid: int):
    w = model.frequency_grid(**grid)
    alpha = directional_factors(*engagement_angles(immersion, milling), KR)
    depth, eps = zoa_depth(zoa_eigenvalues(model.frf(w), alpha), teeth=N_TEETH, kt=KT)
    return w, depth, eps


def _brute_polyline(w, depth, eps, rpm, max_lobe):
    """Loop over speeds; every lobe polyline piece spanning the speed, interpolated in n."""
    k = np.arange(max_lobe + 1)[:, None, None]
    n = 60.0 * w / (N_TEETH * (eps[None] + 2 * math.pi * k))  # (K, 2, F)
    a = depth[None]
    out = np.full(rpm.size, np.inf)
    n0, n1, a0, a1 = n[..., :-1], n[..., 1:], a[..., :-1], a[..., 1:]
    ok = np.isfinite(a0) & np.isfinite(a1)
    with np.errstate(invalid="ignore", divide="ignore"):
        for i, s in enumerate(rpm):
            hit = ok & (np.minimum(n0, n1) <= s) & (s <= np.maximum(n0, n1))
            t = np.where(n1 != n0, (s - n0) / (n1 - n0), 0.0)
            val = np.where(hit, a0 + t * (a1 - a0), np.inf)
            out[i] = val.min()
    return out


def _brute_phase_crossing(w, depth, eps, rpm, max_lobe):
    """Independent form: lobe k where w T - eps(w) = 2 k pi, interpolated in that phase."""
    out = np.full(rpm.size, np.inf)
    for i, s in enumerate(rpm):
        period = 60.0 / (N_TEETH * s)
        theta = (w * period - eps) / (2 * math.pi)  # (2, F)
        t0, t1 = theta[:, :-1], theta[:, 1:]
        ok = np.isfinite(depth[:, :-1]) & np.isfinite(depth[:, 1:])
        lo = np.ceil(np.minimum(t0, t1))
        hi = np.floor(np.maximum(t0, t1))
        best = np.inf
        for j, f in zip(*np.nonzero(ok & (hi >= lo) & (hi >= 0)), strict=True):
            for k in range(int(max(lo[j, f], 0)), int(min(hi[j, f], max_lobe)) + 1):
                u = (k - t0[j, f]) / (t1[j, f] - t0[j, f])
                best = min(best, depth[j, f] + u * (depth[j, f + 1] - depth[j, f]))
        out[i] = best
    return out


@pytest.mark.parametrize("immersion", [1.0, 0.5])
def test_envelope_equals_brute_force_polyline(iso_2dof: ModalModel, immersion: float) -> None:
    w, depth, eps = _lobe_data(iso_2dof, immersion)
    rpm = np.linspace(4000, 70000, 350)
    got = lobe_envelope(w, depth, eps, teeth=N_TEETH, rpm=rpm, max_lobe=12)
    want = _brute_polyline(w, depth, eps, rpm, 12)
    np.testing.assert_allclose(got, want, rtol=1e-12)


def test_envelope_equals_brute_force_with_cross_terms() -> None:
    model = ModalModel.from_directional(
        [700.0, 1500.0, 760.0, 1400.0, 730.0],
        [0.03, 0.02, 0.025, 0.02, 0.03],
        [3e7, 6e7, 4e7, 5e7, -9e7],
        ["xx", "xx", "yy", "yy", "xy"],
    )
    w, depth, eps = _lobe_data(model, 0.4, "up")
    rpm = np.linspace(3000, 40000, 300)
    got = lobe_envelope(w, depth, eps, teeth=N_TEETH, rpm=rpm, max_lobe=20)
    np.testing.assert_allclose(got, _brute_polyline(w, depth, eps, rpm, 20), rtol=1e-12)


def test_envelope_matches_phase_crossing_on_a_fine_grid(iso_2dof: ModalModel) -> None:
    # two different interpolations of the same curves converge as the grid refines
    w, depth, eps = _lobe_data(iso_2dof, 1.0, points_per_mode=1501, points_per_decade=400)
    rpm = np.linspace(9000, 60000, 60)
    got = lobe_envelope(w, depth, eps, teeth=N_TEETH, rpm=rpm, max_lobe=8)
    want = _brute_phase_crossing(w, depth, eps, rpm, 8)
    np.testing.assert_allclose(got, want, rtol=2e-4)


def test_uniform_and_general_speed_paths_agree(iso_2dof: ModalModel) -> None:
    w, depth, eps = _lobe_data(iso_2dof, 0.5)
    rpm = np.linspace(5000, 60000, 500)
    uniform = lobe_envelope(w, depth, eps, teeth=N_TEETH, rpm=rpm, max_lobe=10)
    jitter = rpm * (1 + 1e-13 * np.arange(rpm.size) % 3)  # not uniform: searchsorted path
    shuffled = np.random.default_rng(0).permutation(rpm.size)
    general = lobe_envelope(w, depth, eps, teeth=N_TEETH, rpm=jitter[shuffled], max_lobe=10)
    np.testing.assert_allclose(general, uniform[shuffled], rtol=1e-6)


def test_query_exact_and_per_row(iso_2dof: ModalModel, one_dof_x: ModalModel) -> None:
    w = iso_2dof.frequency_grid()
    alpha = directional_factors(*engagement_angles(0.5, "down"), KR)
    frf = np.stack([iso_2dof.frf(w), one_dof_x.frf(w)])
    rpm = np.linspace(5000, 60000, 400)
    lobes = zoa_lobes(w, frf, alpha=alpha, teeth=N_TEETH, kt=KT, rpm=rpm)
    # on the grid, the query is the envelope
    np.testing.assert_array_equal(lobes.query(rpm), lobes.a_lim)
    # off the grid it is the exact polyline value, not an interpolation of the grid
    extra = np.array([12345.6, 33333.3])
    per_row = np.array([[12345.6, 40000.0], [33333.3, 7000.0]])
    got = lobes.query(per_row)
    for i in range(2):
        single = zoa_lobes(w, frf[i], alpha=alpha, teeth=N_TEETH, kt=KT, rpm=per_row[i])
        np.testing.assert_allclose(got[i], single.a_lim, rtol=1e-12)
    assert lobes.query(extra).shape == (2, 2)
    assert lobes.take(1).query(12345.6) == pytest.approx(float(lobes.query(extra)[1, 0]))


def test_minimum_and_take(iso_2dof: ModalModel) -> None:
    w = iso_2dof.frequency_grid()
    alpha = directional_factors(0.0, math.pi, KR)
    rpm = np.linspace(5000, 60000, 200)
    lobes = zoa_lobes(w, np.stack([iso_2dof.frf(w)] * 2), alpha=alpha, teeth=2, kt=KT, rpm=rpm)
    a_min, n_min = lobes.minimum()
    assert a_min.shape == (2,)
    assert float(a_min[0]) == float(lobes.a_lim[0].min())
    assert float(n_min[0]) == float(rpm[np.argmin(lobes.a_lim[0])])
    one = lobes.take(0)
    assert one.batch_shape == ()
    np.testing.assert_array_equal(one.a_lim, lobes.a_lim[0])


def test_completeness_speed(iso_2dof: ModalModel) -> None:
    w = iso_2dof.frequency_grid()
    alpha = directional_factors(0.0, math.pi, KR)
    rpm = np.linspace(2000, 60000, 300)
    few = zoa_lobes(w, iso_2dof.frf(w), alpha=alpha, teeth=2, kt=KT, rpm=rpm, max_lobe=3)
    many = zoa_lobes(w, iso_2dof.frf(w), alpha=alpha, teeth=2, kt=KT, rpm=rpm, max_lobe=60)
    cut = float(few.complete_above_rpm)
    above = rpm > cut
    # above the reported speed, the extra lobes change nothing; below, they do
    np.testing.assert_array_equal(few.a_lim[above], many.a_lim[above])
    assert np.any(few.a_lim[~above] > many.a_lim[~above])
    auto = zoa_lobes(w, iso_2dof.frf(w), alpha=alpha, teeth=2, kt=KT, rpm=rpm, max_lobe=None)
    assert float(auto.complete_above_rpm) <= rpm[0]
    np.testing.assert_array_equal(auto.a_lim, many.a_lim)


def _robot_tool_models(n: int, seed: int) -> ModalModel:
    """Robot modes (5-40 Hz, random shapes, seed paper's stiffness range) + spindle modes."""
    from robolobe.sld import feed_frame, tool_point_model

    rng = np.random.default_rng(seed)
    f = rng.uniform(5.0, 40.0, (n, 6))
    z = rng.uniform(0.01, 0.05, (n, 6))
    k = rng.uniform(0.3e5, 27e5, (n, 6, 1))
    w = 2 * math.pi * f
    shapes = rng.normal(size=(n, 6, 3))
    shapes *= w[..., None] / np.sqrt(k) / np.linalg.norm(shapes, axis=-1, keepdims=True)
    robot = ModalModel.from_shapes(w, z, shapes)
    tool = ModalModel.from_directional(
        [700.0, 2200.0, 750.0, 2300.0],
        [0.03, 0.02, 0.03, 0.02],
        [3e7, 5e7, 3.2e7, 5e7],
        ["xx", "xx", "yy", "yy"],
    )
    ang = rng.uniform(0.0, 2 * math.pi, n)
    frame = feed_frame(np.stack([np.cos(ang), np.sin(ang), np.zeros(n)], axis=-1))
    return tool_point_model(frame, robot, tool)


def test_refined_grid_matches_a_dense_grid_for_robot_plus_tool() -> None:
    # robot-mode lobe tails reach high speeds; the refined grid follows them
    # (the static modal grid misses some by up to ~75 % in depth for these entries)
    from robolobe.sld import CuttingConditions, get_material, stability_lobes

    models = _robot_tool_models(24, 1).take(np.array([6, 7, 21, 23]))
    cond = CuttingConditions.from_immersion(0.5, "down")
    mat = get_material("Al7075-T6")
    alpha = directional_factors(cond.phi_entry, cond.phi_exit, mat.kr)
    rpm = np.linspace(2000, 24000, 400)
    dense = np.geomspace(2 * math.pi * 1.0, 2 * math.pi * 6000.0, 100_000)
    want = zoa_lobes(dense, models.frf(dense), alpha=alpha, teeth=3, kt=mat.kt, rpm=rpm).a_lim
    got = stability_lobes(models, cutter=3, material=mat, conditions=cond, rpm=rpm)
    err = np.abs(got.a_lim / want - 1)
    assert np.max(err) < 0.02  # largest at the turning points of folded lobes
    assert np.percentile(err, 99) < 0.01
