"""Zero-order solution: reference depths, symmetries, lobe formulas, branches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.sld import (
    CuttingConditions,
    Material,
    ModalModel,
    critical_depth,
    directional_factors,
    engagement_angles,
    lobe_speeds,
    stability_lobes,
    zoa_depth,
    zoa_eigenvalues,
    zoa_lobes,
)
from robolobe.sld.converged import CHORD_TOL

from .sld_reference import K_MODAL, KR, KT, N_TEETH, ZETA

MAT = Material("benchmark", KT, KR)


# REFERENCES.md section 3: 1-DOF ZOA minimum, tolerance 1e-4 relative.
# "1-DOF" is flexibility in the feed direction x (the numbers say so: with
# y the half-immersion value would be 0.2049 mm).
@pytest.mark.parametrize(
    ("immersion", "want_mm"),
    [(1.0, 0.298054), (0.5, 0.64091), (0.1, 0.99944), (0.05, 1.79158)],
)
def test_one_dof_reference_minima(one_dof_x: ModalModel, immersion: float, want_mm: float) -> None:
    alpha = directional_factors(*engagement_angles(immersion, "down"), KR)
    got = float(critical_depth(one_dof_x, alpha, teeth=N_TEETH, kt=KT).depth) * 1e3
    assert got == pytest.approx(want_mm, rel=1e-4)


@pytest.mark.parametrize("immersion", [1.0, 0.5, 0.1, 0.05])
def test_one_dof_minimum_closed_form(one_dof_x: ModalModel, immersion: float) -> None:
    # a = 2 pi / (N Kt a_xx Re G) at the extreme of Re G: 1/(4 k zeta (1 -/+ zeta))

    axx = directional_factors(*engagement_angles(immersion, "down"), KR)[0, 0]
    re_g = (
        1 / (4 * K_MODAL * ZETA * (1 - ZETA)) if axx > 0 else -1 / (4 * K_MODAL * ZETA * (1 + ZETA))
    )
    want = 2 * math.pi / (N_TEETH * KT * axx * re_g)
    alpha = directional_factors(*engagement_angles(immersion, "down"), KR)
    got = float(critical_depth(one_dof_x, alpha, teeth=N_TEETH, kt=KT).depth)
    assert got == pytest.approx(want, rel=1e-9)


def test_two_dof_slot_reference(iso_2dof: ModalModel) -> None:
    # REFERENCES.md section 3: 2-DOF isotropic slot, ZOA 0.047925 mm
    alpha = directional_factors(0.0, math.pi, KR)
    got = float(critical_depth(iso_2dof, alpha, teeth=N_TEETH, kt=KT).depth) * 1e3
    assert got == pytest.approx(0.047925, rel=1e-4)


def test_depth_formula_equals_altintas_lambda(iso_2dof: ModalModel) -> None:
    # a = -2 pi L_R (1 + kappa^2) / (N Kt), kappa = L_I / L_R, L = -1/mu, and
    # a0 L^2 + a1 L + 1 = 0 with a0 = det(alpha G), a1 = tr(alpha G)
    w = np.linspace(0.9, 1.1, 41) * 2 * math.pi * 922
    g = iso_2dof.frf(w)
    alpha = directional_factors(*engagement_angles(0.5, "down"), KR)
    mu = zoa_eigenvalues(g, alpha)
    lam = -1.0 / mu
    g0 = alpha @ g
    a0 = np.linalg.det(g0)
    a1 = np.trace(g0, axis1=-2, axis2=-1)
    np.testing.assert_allclose(a0 * lam**2 + a1 * lam + 1, 0, atol=1e-9)
    depth, eps = zoa_depth(mu, teeth=N_TEETH, kt=KT)
    kappa = lam.imag / lam.real
    ok = lam.real < 0
    want = -2 * math.pi * lam.real * (1 + kappa**2) / (N_TEETH * KT)
    np.testing.assert_allclose(depth[ok], want[ok], rtol=1e-12)
    assert np.all(np.isinf(depth[~ok]))
    want_eps = math.pi - 2 * np.arctan(kappa)
    np.testing.assert_allclose(eps[ok], want_eps[ok], rtol=1e-12)
    assert np.all((eps[ok] > 0) & (eps[ok] < 2 * math.pi))


def test_up_down_identical_for_isotropic_two_dof(iso_2dof: ModalModel) -> None:
    rpm = np.linspace(8000, 60000, 400)
    res = {}
    for milling in ("up", "down"):
        cond = CuttingConditions.from_immersion(0.3, milling)
        res[milling] = stability_lobes(
            iso_2dof, cutter=N_TEETH, material=MAT, conditions=cond, rpm=rpm
        )
    np.testing.assert_allclose(res["up"].a_lim, res["down"].a_lim, rtol=1e-9)


def test_up_down_differ_for_one_dof(one_dof_x: ModalModel) -> None:
    rpm = np.linspace(8000, 60000, 400)
    res = {}
    for milling in ("up", "down"):
        cond = CuttingConditions.from_immersion(0.3, milling)
        res[milling] = stability_lobes(
            one_dof_x, cutter=N_TEETH, material=MAT, conditions=cond, rpm=rpm
        )
    up, down = res["up"].a_lim, res["down"].a_lim
    both = np.isfinite(up) & np.isfinite(down)
    assert np.max(np.abs(up[both] / down[both] - 1)) > 0.2


def test_lobe_speed_formula_and_ordering() -> None:
    w = np.array([5000.0, 6000.0])
    eps = np.array([0.5, 5.0])
    k = np.arange(6)[:, None]
    n = lobe_speeds(w, eps, k, 3)
    # n = 60 / (N T), T = (eps + 2 k pi) / w
    t = 60.0 / (3 * n)
    np.testing.assert_allclose(t, (eps + 2 * math.pi * k) / w)
    # consecutive lobes are one chatter period apart and ordered by speed
    np.testing.assert_allclose(np.diff(t, axis=0), np.broadcast_to(2 * math.pi / w, (5, 2)))
    assert np.all(np.diff(n, axis=0) < 0)


def test_lobe_minima_speeds_ordered(iso_2dof: ModalModel) -> None:
    alpha = directional_factors(0.0, math.pi, KR)
    crit = critical_depth(iso_2dof, alpha, teeth=N_TEETH, kt=KT)
    n = crit.rpm(np.arange(5))
    assert np.all(np.diff(n) < 0)
    # chatter frequency of the bottom: just above the natural frequency
    assert 1.0 < float(crit.omega) / (2 * math.pi * 922) < 1.01


def test_envelope_minimum_matches_critical_depth(iso_2dof: ModalModel) -> None:
    alpha = directional_factors(0.0, math.pi, KR)
    crit = critical_depth(iso_2dof, alpha, teeth=N_TEETH, kt=KT)
    n_bottom = float(crit.rpm(1))
    lobes = stability_lobes(
        iso_2dof,
        cutter=N_TEETH,
        material=MAT,
        conditions=CuttingConditions.from_immersion(1.0, "down"),
        rpm=np.array([n_bottom]),
    )
    # the polyline chord lies just above the smooth lobe bottom (the converged lobes'
    # chord tolerance)
    assert float(lobes.a_lim[0]) == pytest.approx(float(crit.depth), rel=CHORD_TOL)
    assert float(lobes.a_lim[0]) >= float(crit.depth) * (1 - 1e-9)


def test_branch_tracking_is_continuous() -> None:
    # two modes of different frequency in x and y with cross coupling
    model = ModalModel.from_directional(
        [900.0, 1000.0, 950.0], [0.02, 0.02, 0.03], [2e6, 3e6, -8e6], ["xx", "yy", "xy"]
    )
    w = np.linspace(0.8, 1.2, 4001) * 2 * math.pi * 950
    alpha = directional_factors(*engagement_angles(0.5, "down"), 0.3)
    mu = zoa_eigenvalues(model.frf(w), alpha)
    raw = zoa_eigenvalues(model.frf(w), alpha, track=False)
    # same eigenvalue sets
    np.testing.assert_allclose(np.sort_complex(mu.T.copy()), np.sort_complex(raw.T.copy()))
    step = np.abs(np.diff(mu, axis=-1)).max()
    scale = np.abs(mu).max()
    assert step < 0.05 * scale


def test_batched_equals_loop(iso_2dof: ModalModel, one_dof_x: ModalModel) -> None:
    w = iso_2dof.frequency_grid()
    frfs = np.stack([iso_2dof.frf(w), one_dof_x.frf(w), 0.5 * iso_2dof.frf(w)])
    alpha = directional_factors(*engagement_angles(0.5, "down"), KR)
    rpm = np.linspace(5000, 50000, 300)
    batch = zoa_lobes(w, frfs, alpha=alpha, teeth=2, kt=KT, rpm=rpm)
    for i in range(3):
        one = zoa_lobes(w, frfs[i], alpha=alpha, teeth=2, kt=KT, rpm=rpm)
        np.testing.assert_array_equal(batch.a_lim[i], one.a_lim)
    # twice as stiff: exactly twice the depth
    np.testing.assert_allclose(batch.a_lim[2], 2 * batch.a_lim[0], rtol=1e-12)


def test_depth_scales_inversely_with_kt_and_teeth(iso_2dof: ModalModel) -> None:
    w = iso_2dof.frequency_grid()
    g = iso_2dof.frf(w)
    alpha = directional_factors(0.0, math.pi, KR)
    d1, e1 = zoa_depth(zoa_eigenvalues(g, alpha), teeth=2, kt=KT)
    d2, e2 = zoa_depth(zoa_eigenvalues(g, alpha), teeth=4, kt=2 * KT)
    ok = np.isfinite(d1)
    np.testing.assert_allclose(d2[ok], d1[ok] / 4)
    np.testing.assert_array_equal(e1[ok], e2[ok])


def test_low_immersion_flag(iso_2dof: ModalModel) -> None:
    rpm = np.linspace(10000, 20000, 50)
    low = stability_lobes(
        iso_2dof,
        cutter=2,
        material=MAT,
        conditions=CuttingConditions.from_immersion(0.1, "down"),
        rpm=rpm,
    )
    assert not low.valid
    assert "a/D = 0.1" in low.message
    assert "sdm" in low.message
    ok = stability_lobes(
        iso_2dof,
        cutter=2,
        material=MAT,
        conditions=CuttingConditions.from_immersion(0.25, "down"),
        rpm=rpm,
    )
    assert ok.valid
    assert ok.message == ""


def test_modal_and_frf_inputs_agree(iso_2dof: ModalModel) -> None:
    rpm = np.linspace(10000, 60000, 200)
    cond = CuttingConditions.from_immersion(0.5, "up")
    a = stability_lobes(iso_2dof, cutter=2, material=MAT, conditions=cond, rpm=rpm)
    w = a.omega  # the converged lobes' own samples, given as sampled FRFs
    b = stability_lobes((w, iso_2dof.frf(w)), cutter=2, material=MAT, conditions=cond, rpm=rpm)
    np.testing.assert_array_equal(a.a_lim, b.a_lim)


def test_bad_inputs_raise_input_error(iso_2dof: ModalModel) -> None:
    from robolobe.errors import InputError

    w = iso_2dof.frequency_grid()
    g = iso_2dof.frf(w)
    alpha = directional_factors(0.0, math.pi, KR)
    with pytest.raises(InputError, match="rpm"):
        zoa_lobes(w, g, alpha=alpha, teeth=2, kt=KT, rpm=[-1.0, 100.0])
    with pytest.raises(InputError, match="teeth"):
        zoa_lobes(w, g, alpha=alpha, teeth=0, kt=KT, rpm=[100.0])
    with pytest.raises(InputError, match="sorted"):
        zoa_lobes(w[::-1], g, alpha=alpha, teeth=2, kt=KT, rpm=[100.0])
    with pytest.raises(InputError, match="n_freq"):
        zoa_lobes(w[:-1], g, alpha=alpha, teeth=2, kt=KT, rpm=[100.0])
