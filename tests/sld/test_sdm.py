"""Semi-discretization: internal checks and the ZOA validation of REFERENCES.md section 3."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from robolobe.errors import InputError
from robolobe.sld import (
    CuttingConditions,
    ModalModel,
    critical_depth,
    directional_factors,
    sdm_lobes,
    sdm_spectral_radius,
    sdm_system,
)
from robolobe.sld.sdm import expm_batched

from .sld_reference import F_N, KR, KT, N_TEETH, ZETA

SLOT = CuttingConditions.from_immersion(1.0, "down")


def test_expm_batched_matches_scipy() -> None:
    rng = np.random.default_rng(7)
    a = rng.normal(size=(20, 6, 6)) * rng.uniform(1e-3, 40.0, (20, 1, 1))
    want = np.stack([scipy.linalg.expm(x) for x in a])
    got = expm_batched(a)
    scale = np.abs(want).max(axis=(1, 2), keepdims=True)
    assert np.max(np.abs(got - want) / scale) < 1e-11


def test_realization_reproduces_the_frf() -> None:
    model = ModalModel.from_directional(
        [700.0, 700.0, 1500.0, 900.0],
        [0.03, 0.03, 0.02, 0.02],
        [3e7, 5e7, 6e7, -4e7],
        ["xx", "yy", "yy", "xy"],
    )
    sys = sdm_system(model, teeth=2, kt=KT, kr=KR, conditions=SLOT, intervals=4)
    # modes with the same pole are merged: 700 Hz (rank 2), 1500 Hz, 900 Hz (rank 2, indefinite)
    assert sys.omega.size == 5
    w = np.linspace(500, 2000, 50) * 2 * math.pi
    den = sys.omega**2 - w[:, None] ** 2 + 2j * sys.zeta * sys.omega * w[:, None]
    h = np.einsum("is,fs,sj->fij", sys.c, 1 / den, sys.b)
    np.testing.assert_allclose(h, model.frf(w), rtol=1e-10, atol=1e-20)


def test_zero_depth_radius_is_free_decay(iso_2dof: ModalModel) -> None:
    # without cutting the monodromy is the free motion over one tooth period
    sys = sdm_system(iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, intervals=20)
    rpm = np.array([5000.0, 20000.0, 60000.0])
    period = 60.0 / (N_TEETH * rpm)
    want = np.exp(-ZETA * 2 * math.pi * F_N * period)
    np.testing.assert_allclose(sdm_spectral_radius(sys, 0.0, rpm), want, rtol=1e-9)


def test_radius_grows_with_depth(iso_2dof: ModalModel) -> None:
    sys = sdm_system(iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, intervals=20)
    rho = sdm_spectral_radius(sys, np.array([1e-6, 4.0e-5, 6.0e-5, 2e-4]), 17800.0)
    assert rho[0] < 1.0
    assert rho[1] < 1.0
    assert rho[2] > 1.0
    assert rho[3] > rho[2]


def test_limit_brackets_the_boundary(iso_2dof: ModalModel) -> None:
    rpm = np.array([14000.0, 30000.0])
    lobes = sdm_lobes(
        iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, rpm=rpm, intervals=20, rtol=1e-5
    )
    sys = sdm_system(iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, intervals=20)
    assert np.all(sdm_spectral_radius(sys, lobes.a_lim * (1 - 1e-4), rpm) < 1.0)
    assert np.all(sdm_spectral_radius(sys, lobes.a_lim * (1 + 1e-4), rpm) > 1.0)
    assert lobes.method == "sdm"
    assert lobes.valid


def _sdm_lobe_minimum(model: ModalModel, cond: CuttingConditions, rpm: np.ndarray, m: int) -> float:
    lobes = sdm_lobes(
        model, teeth=N_TEETH, kt=KT, kr=KR, conditions=cond, rpm=rpm, intervals=m, rtol=2e-5
    )
    return float(lobes.a_lim.min())


@pytest.mark.slow
@pytest.mark.parametrize("lobe", [0, 1])
def test_sdm_matches_zoa_for_slotting(iso_2dof: ModalModel, lobe: int) -> None:
    # REFERENCES.md section 3: 2-DOF isotropic slot, ZOA 0.047925 mm, converged
    # SDM within 0.5 %. "Converged": the m = 30 / m = 40 Richardson limit
    # (first-order SD errors go as 1/m^2), and m = 40 itself.
    alpha = directional_factors(0.0, math.pi, KR)
    crit = critical_depth(iso_2dof, alpha, teeth=N_TEETH, kt=KT)
    assert float(crit.depth) * 1e3 == pytest.approx(0.047925, rel=1e-4)
    rpm = float(crit.rpm(lobe)) * np.linspace(0.985, 1.015, 11)
    a = {
        m: sdm_lobes(
            iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, rpm=rpm, intervals=m, rtol=2e-5
        ).a_lim
        for m in (30, 40)
    }
    converged = float(((40**2 * a[40] - 30**2 * a[30]) / (40**2 - 30**2)).min())
    assert converged == pytest.approx(float(crit.depth), rel=5e-3)
    assert float(a[40].min()) == pytest.approx(float(crit.depth), rel=5e-3)


@pytest.mark.slow
def test_sdm_converged_in_intervals(iso_2dof: ModalModel) -> None:
    # first-order SD converges as 1/m^2 (Insperger, Stepan & Turi 2008): the
    # error ratio between m = 20 and m = 40 is ~4, and m = 40 is within 0.3 %
    # of the Richardson limit from m = 30 and 40.
    rpm = np.array([17800.0, 50100.0])
    a = {
        m: sdm_lobes(
            iso_2dof, teeth=N_TEETH, kt=KT, kr=KR, conditions=SLOT, rpm=rpm, intervals=m, rtol=1e-7
        ).a_lim
        for m in (20, 30, 40)
    }
    limit = (40**2 * a[40] - 30**2 * a[30]) / (40**2 - 30**2)
    np.testing.assert_allclose(a[40], limit, rtol=3e-3)
    ratio = (a[20] - limit) / (a[40] - limit)
    np.testing.assert_allclose(ratio, 4.0, rtol=0.15)


@pytest.mark.parametrize("immersion", [0.1, 0.05])
def test_zoa_misses_the_flip_lobe_at_low_immersion(iso_2dof: ModalModel, immersion: float) -> None:
    # REFERENCES.md section 3: ZOA is non-conservative at a/D <= 0.1 (it misses
    # the period-doubling lobe); here ZOA's lowest depth over all speeds is at
    # least 1.3 times the SDM depth at the flip lobe near 2 x 60 f_n / N rpm.
    cond = CuttingConditions.from_immersion(immersion, "down")
    alpha = directional_factors(cond.phi_entry, cond.phi_exit, KR)
    zoa_min = float(critical_depth(iso_2dof, alpha, teeth=N_TEETH, kt=KT).depth)
    rpm = np.linspace(55000.0, 58000.0, 13)
    sdm_min = _sdm_lobe_minimum(iso_2dof, cond, rpm, 30)
    assert zoa_min / sdm_min >= 1.3


def test_one_dof_up_down_differ_in_sdm_too(one_dof_x: ModalModel) -> None:
    rpm = np.array([15000.0, 25000.0])
    got = {
        m: sdm_lobes(
            one_dof_x,
            teeth=N_TEETH,
            kt=KT,
            kr=KR,
            conditions=CuttingConditions.from_immersion(0.5, m),
            rpm=rpm,
            intervals=20,
        ).a_lim
        for m in ("up", "down")
    }
    assert np.max(np.abs(got["up"] / got["down"] - 1)) > 0.2


def test_sdm_input_errors(iso_2dof: ModalModel) -> None:
    with pytest.raises(InputError, match="intervals"):
        sdm_system(iso_2dof, teeth=2, kt=KT, kr=KR, conditions=SLOT, intervals=1)
    batched = ModalModel.isotropic([[900.0], [950.0]], [[0.02], [0.02]], [[1e6], [1e6]])
    with pytest.raises(InputError, match="unbatched"):
        sdm_system(batched, teeth=2, kt=KT, kr=KR, conditions=SLOT)
    with pytest.raises(InputError, match="rpm"):
        sdm_lobes(iso_2dof, teeth=2, kt=KT, kr=KR, conditions=SLOT, rpm=[0.0])


def test_batched_sdm_through_stability_lobes() -> None:
    from robolobe.sld import Material, stability_lobes

    batch = ModalModel.isotropic([[922.0], [922.0]], [[ZETA], [ZETA]], [[2e6], [4e6]])
    rpm = np.array([17000.0, 30000.0])
    got = stability_lobes(
        batch,
        cutter=N_TEETH,
        material=Material("m", KT, KR),
        conditions=SLOT,
        rpm=rpm,
        method="sdm",
        intervals=12,
    )
    assert got.a_lim.shape == (2, 2)
    # twice as stiff, same frequency: twice the depth (the SDM is linear in 1/k)
    np.testing.assert_allclose(got.a_lim[1], 2 * got.a_lim[0], rtol=1e-3)
