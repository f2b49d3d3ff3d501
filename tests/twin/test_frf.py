"""Receptance: reciprocity, static limit, chunking, modal form."""

from __future__ import annotations

import numpy as np
import pytest

import robolobe.twin.frf as frf_mod
from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.twin.frf import modal_receptance, receptance
from robolobe.twin.model import Twin


@pytest.fixture(scope="module")
def system():
    q = np.random.default_rng(8).uniform(-2.0, 2.0, (5, 6))
    return Twin(load_robot("B")).system(q)


def test_reciprocity(system) -> None:
    h = receptance(system.M, system.K, system.C, system.J, np.linspace(0, 80, 161))
    assert h.shape == (5, 161, 3, 3)
    np.testing.assert_allclose(h, np.swapaxes(h, -1, -2), rtol=1e-9, atol=1e-9 * np.abs(h).max())


def test_static_limit(system) -> None:
    h0 = receptance(system.M, system.K, system.C, system.J, [0.0])[:, 0]
    j = system.J
    expected = j @ np.linalg.solve(system.K, np.swapaxes(j, -1, -2))
    np.testing.assert_allclose(h0.real, expected, rtol=1e-10)
    np.testing.assert_array_equal(h0.imag, 0.0)


def test_chunking_does_not_change_the_result(system, monkeypatch: pytest.MonkeyPatch) -> None:
    f = np.linspace(1, 50, 33)
    full = receptance(system.M, system.K, system.C, system.J, f)
    monkeypatch.setattr(frf_mod, "_CHUNK_ENTRIES", 1)  # one posture at a time
    chunked = receptance(system.M, system.K, system.C, system.J, f)
    np.testing.assert_array_equal(full, chunked)


def test_single_dof_receptance_closed_form() -> None:
    m, k, c = 5.0, 2.0e5, 30.0
    f = np.array([0.0, 10.0, 31.8, 100.0])
    w = 2 * np.pi * f
    h = receptance([[m]], [[k]], [[c]], [[1.0]], f)[:, 0, 0]
    np.testing.assert_allclose(h, 1.0 / (k - w**2 * m + 1j * w * c), rtol=1e-12)


def test_modal_receptance_single_mode() -> None:
    fn, zeta, k = 12.0, 0.02, 4.0e5
    f = np.linspace(0, 40, 81)
    wn, w = 2 * np.pi * fn, 2 * np.pi * f
    h = modal_receptance([fn], [zeta], [k], f)
    np.testing.assert_allclose(h, (wn**2 / k) / (wn**2 - w**2 + 2j * zeta * wn * w), rtol=1e-13)
    # peak at resonance: 1 / (2 zeta k), phase -90 deg
    h_res = modal_receptance([fn], [zeta], [k], [fn])[0]
    assert h_res == pytest.approx(-1j / (2 * zeta * k), rel=1e-12)


def test_modal_receptance_batches_and_ignores_infinite_stiffness() -> None:
    f_hz = np.array([[8.0, 20.0], [9.0, 22.0]])
    zeta = np.full((2, 2), 0.03)
    k = np.array([[1e5, np.inf], [2e5, 3e5]])
    h = modal_receptance(f_hz, zeta, k, np.linspace(1, 30, 10))
    assert h.shape == (2, 10)
    np.testing.assert_allclose(h[0], modal_receptance([8.0], [0.03], [1e5], np.linspace(1, 30, 10)))


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (([0.0], [0.01], [1e5]), "f_hz"),
        (([10.0], [-0.01], [1e5]), "zeta"),
        (([10.0], [0.01], [0.0]), "k_N_per_m"),
        (([10.0, 20.0], [0.01, 0.02, 0.03], [1e5]), "broadcast"),
    ],
)
def test_modal_receptance_validation(args, match: str) -> None:
    with pytest.raises(InputError, match=match):
        modal_receptance(*args, [1.0, 2.0])


@pytest.mark.parametrize("freq", [[-1.0, 2.0], [[1.0, 2.0]], [np.nan]])
def test_frequency_validation(system, freq) -> None:
    with pytest.raises(InputError, match="freq_hz"):
        receptance(system.M, system.K, system.C, system.J, freq)
