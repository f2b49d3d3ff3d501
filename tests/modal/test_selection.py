"""Stabilization diagram and clustering selection: close modes, light damping, noise."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.modal.plscf import plscf
from robolobe.modal.selection import SelectionSettings, select_poles
from robolobe.modal.stabilization import StabilizationCriteria, stabilization_diagram

from ._systems import add_noise, make_system


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_clustering_finds_every_mode_once(seed: int) -> None:
    sysm = make_system(seed)
    f = np.arange(4, 185) * 0.25  # 1..46 Hz
    H = add_noise(sysm.H(f), 0.01, np.random.default_rng(seed), proportional=True)
    dg = stabilization_diagram(plscf(f, H, range(1, 17)), band_hz=(4.0, 40.0))
    sel = select_poles(dg)
    inband = sysm.f_hz[sysm.f_hz < 40]
    # exactly one selected pole per true mode, incl. the close pair 7.0 / 7.35 Hz (5 %)
    assert sel.n_modes == inband.size
    # linearized pLSCF (before refinement): f within 1 %, damping within 30 %
    np.testing.assert_allclose(sel.f_hz, inband, rtol=1e-2)
    np.testing.assert_allclose(sel.zeta, sysm.zeta[: inband.size], rtol=0.3)
    assert np.all(sel.n_members >= 5)
    assert sum(len(m) for m in sel.members) <= dg.poles.size


def test_diagram_flags_noise_free() -> None:
    sysm = make_system(3)
    f = np.arange(4, 185) * 0.25
    dg = stabilization_diagram(plscf(f, sysm.H(f), range(1, 13)), band_hz=(4.0, 40.0))
    assert dg.orders.tolist() == list(range(1, 13))
    # from order 8 on (24 poles for 8 modes), every true mode is stable in f, zeta and shape
    for fr in sysm.f_hz[sysm.f_hz < 40]:
        for n in range(8, 13):
            near = (dg.order == n) & (np.abs(dg.f_hz - fr) < 0.01 * fr)
            assert np.any(near & dg.stable), (fr, n)
    assert np.all(dg.stable <= dg.physical)
    assert np.all((dg.zeta[dg.physical] > 0) & (dg.zeta[dg.physical] < 0.2))


def test_nearest_pole_picking_would_fail_but_clustering_does_not() -> None:
    """Two modes 1.5 % apart with different shapes: clusters stay separate."""
    from ._systems import ModalSystem

    sysm = ModalSystem(
        np.array([10.0, 10.15, 20.0]),
        np.array([0.01, 0.012, 0.02]),
        np.array([[1.0, 0.1, 0.0], [0.0, 1.0, 0.3], [0.5, 0.5, 0.5]]) / 30.0,
    )
    f = np.arange(8, 161) * 0.25
    H = add_noise(sysm.H(f), 0.001, np.random.default_rng(5))
    sel = select_poles(stabilization_diagram(plscf(f, H, range(1, 15)), band_hz=(4, 40)))
    np.testing.assert_allclose(sel.f_hz, sysm.f_hz, rtol=1e-3)


def test_settings_validation() -> None:
    with pytest.raises(InputError, match="d_max"):
        SelectionSettings(d_max=3.0)
    with pytest.raises(InputError, match="require"):
        SelectionSettings(require="nope")
    with pytest.raises(InputError, match="mac_min"):
        StabilizationCriteria(mac_min=1.5)
    with pytest.raises(InputError, match="model order"):
        stabilization_diagram([], band_hz=(1, 2))
