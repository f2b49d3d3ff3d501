"""Modal FRFs and frequency grids."""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.sld import ModalModel, frequency_grid


def _sdof(w: np.ndarray, f: float, z: float, k: float) -> np.ndarray:
    wr = 2 * math.pi * f
    return (wr**2 / k) / (wr**2 - w**2 + 2j * z * wr * w)


def test_frf_matches_modal_formula() -> None:
    # FORMATS.md section 3: H_dd = sum_r (w_r^2 / k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)
    model = ModalModel.from_directional(
        [10.0, 25.0, 800.0, 30.0],
        [0.02, 0.03, 0.01, 0.05],
        [2e5, 9e5, 3e7, -4e6],
        ["xx", "xx", "yy", "xy"],
    )
    w = np.linspace(1, 6000, 777)
    h = model.frf(w)
    np.testing.assert_allclose(h[:, 0, 0], _sdof(w, 10, 0.02, 2e5) + _sdof(w, 25, 0.03, 9e5))
    np.testing.assert_allclose(h[:, 1, 1], _sdof(w, 800, 0.01, 3e7))
    np.testing.assert_allclose(h[:, 0, 1], _sdof(w, 30, 0.05, -4e6))
    np.testing.assert_array_equal(h[:, 0, 1], h[:, 1, 0])
    # static compliance: sum of 1/k
    h0 = model.frf(np.array([1e-3]))[0, 0, 0]
    assert h0.real == pytest.approx(1 / 2e5 + 1 / 9e5, rel=1e-9)


def test_shapes_and_isotropic() -> None:
    iso = ModalModel.isotropic([100.0, 300.0], [0.02, 0.02], [1e6, 2e6])
    w = np.array([500.0, 1000.0])
    h = iso.frf(w)
    np.testing.assert_allclose(h[:, 0, 0], h[:, 1, 1])
    np.testing.assert_array_equal(h[:, 0, 1], 0)
    # a mass-normalised shape u gives residue u u^T, so k_d = w^2 / u_d^2
    wr = 2 * math.pi * 50.0
    u = np.array([[0.01, -0.02, 0.005]])
    m = ModalModel.from_shapes([wr], [0.03], u)
    h3 = m.frf(np.array([wr]))
    np.testing.assert_allclose(h3[0, 1, 1], _sdof(np.array([wr]), 50.0, 0.03, wr**2 / 0.02**2)[0])
    assert h3[0, 0, 1].real == pytest.approx(h3[0, 1, 0].real)


def test_batched_frf_and_rotation() -> None:
    rng = np.random.default_rng(2)
    w_modes = rng.uniform(30, 250, (4, 3))
    u = rng.normal(size=(4, 3, 3)) * 0.01
    m = ModalModel.from_shapes(w_modes, np.full((4, 3), 0.02), u)
    assert m.batch_shape == (4,)
    assert m.n_modes == 3
    assert m.dim == 3
    w = np.linspace(10, 400, 50)
    h = m.frf(w)
    assert h.shape == (4, 50, 3, 3)
    # rotating the model equals rotating its FRF
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    hr = m.rotated(q).frf(w)
    np.testing.assert_allclose(hr, np.einsum("ia,bfij,jc->bfac", q, h, q), atol=1e-15)
    # the trace is invariant
    np.testing.assert_allclose(np.trace(hr, axis1=-2, axis2=-1), np.trace(h, axis1=-2, axis2=-1))
    # per-entry grids broadcast
    grid = m.frequency_grid(shared=False)
    assert grid.shape[0] == 4
    assert m.frf(grid).shape == (4, grid.shape[1], 3, 3)


def test_absent_modes_contribute_nothing() -> None:
    with_nan = ModalModel.from_directional(
        [100.0, np.nan], [0.02, np.nan], [1e6, np.nan], ["xx", "yy"]
    )
    without = ModalModel.from_directional([100.0], [0.02], [1e6], ["xx"])
    w = np.linspace(100, 1000, 20)
    np.testing.assert_allclose(with_nan.frf(w), without.frf(w))


def test_grid_resolves_each_mode() -> None:
    f = np.array([6.0, 33.0, 1200.0])
    z = np.array([0.01, 0.02, 0.015])
    w_modes = 2 * math.pi * f
    grid = frequency_grid(w_modes, z)
    assert np.all(np.diff(grid) > 0)
    assert grid[0] == pytest.approx(0.5 * w_modes.min())
    assert grid[-1] == pytest.approx(2 * w_modes.max())
    # at least ~8 points per half-power bandwidth (2 zeta w_r) at every peak
    for wr, zr in zip(w_modes, z, strict=True):
        inside = np.sum(np.abs(grid - wr) <= zr * wr)
        assert inside >= 8
    # far fewer points than a uniform grid of that resolution
    uniform = (grid[-1] - grid[0]) / (0.01 * 2 * math.pi * 6.0 / 8)
    assert grid.size < uniform / 100


def test_grid_per_entry_has_equal_lengths() -> None:
    w_modes = np.array([[100.0, 2000.0], [150.0, 2500.0], [90.0, 1800.0]])
    z = np.full_like(w_modes, 0.02)
    g = frequency_grid(w_modes, z, shared=False)
    assert g.shape[0] == 3
    assert np.all(np.diff(g, axis=-1) >= 0)
    for i in range(3):
        for wr in w_modes[i]:
            assert np.min(np.abs(g[i] - wr)) < 0.005 * wr


def test_modal_model_validation() -> None:
    with pytest.raises(InputError, match="zeta"):
        ModalModel([100.0], [0.0], [[[1.0, 0], [0, 1.0]]])
    with pytest.raises(InputError, match="omega"):
        ModalModel([-1.0], [0.1], [[[1.0, 0], [0, 1.0]]])
    with pytest.raises(InputError, match="direction"):
        ModalModel.from_directional([100.0], [0.02], [1e6], ["xz"])
    with pytest.raises(InputError, match="one per mode"):
        ModalModel.from_directional([100.0, 200.0], [0.02, 0.02], [1e6, 1e6], ["xx"])
    with pytest.raises(InputError, match="k_N_per_m"):
        ModalModel.from_directional([100.0], [0.02], [0.0], ["xx"])


@pytest.mark.parametrize(
    ("batch_r", "batch_a", "d", "d_out"),
    [
        ((40,), (40,), 3, 2),
        ((40,), (), 3, 2),
        ((), (7,), 3, 3),
        ((5, 4), (5, 4), 2, 2),
        ((9,), (9,), 3, 1),
    ],
)
def test_rotated_equals_the_einsum_bit_for_bit(batch_r, batch_a, d, d_out):
    """The term-by-term rotation gives np.einsum's values exactly (same products and order)."""
    rng = np.random.default_rng(sum(batch_r) + 10 * d + d_out)
    full = rng.normal(size=(*batch_r, d, d))
    r = full[..., :, :d_out]  # a view with the strides of feed_frame(...)[..., :, :2]
    u = rng.normal(size=(*batch_a, 6, d))
    m = ModalModel(
        np.broadcast_to(rng.uniform(50, 500, 6), (*batch_a, 6)).copy(),
        np.full((*batch_a, 6), 0.03),
        u[..., :, None] * u[..., None, :] * 1e-7 + rng.normal(size=(*batch_a, 6, d, d)) * 1e-9,
    )
    ref = np.einsum("...ia,...mij,...jb->...mab", r, m.residues, r)
    got = m.rotated(r).residues
    assert got.shape == ref.shape
    np.testing.assert_array_equal(got, ref)
