"""Modes: closed forms, orthogonality, pole-residue synthesis, modal stiffness."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.twin.frf import modal_receptance, receptance
from robolobe.twin.model import Twin
from robolobe.twin.modes import SEEN_RATIO, compute_modes, undamped_modes


def _nominal(name: str, n: int = 8, seed: int = 0):
    r = load_robot(name)
    q = np.random.default_rng(seed).uniform(-2.0, 2.0, (n, 6))
    s = Twin(r).system(q)
    return s.M, s.K, s.C, s.J


def test_single_dof_closed_form() -> None:
    m, k, c, j = 12.0, 3.0e5, 40.0, 0.7
    md = compute_modes([[m]], [[k]], [[c]], [[j]])
    wn = np.sqrt(k / m)
    zeta = c / (2 * np.sqrt(k * m))
    assert md.f_hz[0] == pytest.approx(wn / (2 * np.pi), rel=1e-12)
    assert md.f_undamped_hz[0] == pytest.approx(wn / (2 * np.pi), rel=1e-12)
    assert md.zeta[0] == pytest.approx(zeta, rel=1e-10)
    assert md.omega_d[0] == pytest.approx(wn * np.sqrt(1 - zeta**2), rel=1e-10)
    # k at the output: u = j / sqrt(m), k = wn^2 m / j^2 = k / j^2
    assert md.k_N_per_m[0, 0] == pytest.approx(k / j**2, rel=1e-10)
    # residue of a 1-DOF receptance j^2 / (m (s^2 + 2 zeta wn s + wn^2)): j^2 / (2 i m wd)
    assert md.residues[0, 0, 0] == pytest.approx(j**2 / (2j * m * md.omega_d[0]), rel=1e-9)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_shapes_are_mass_and_stiffness_orthogonal(name: str) -> None:
    m, k, c, j = _nominal(name)
    md = compute_modes(m, k, c, j)
    phi = md.shapes
    eye = np.broadcast_to(np.eye(6), m.shape)
    np.testing.assert_allclose(np.swapaxes(phi, -1, -2) @ m @ phi, eye, atol=1e-10)
    w0 = 2 * np.pi * md.f_undamped_hz
    kk = np.swapaxes(phi, -1, -2) @ k @ phi
    np.testing.assert_allclose(kk / w0[..., :, None] ** 2, eye, atol=1e-8)
    np.testing.assert_allclose(md.tcp_shapes, j @ phi, atol=1e-14)
    assert np.all(np.diff(md.f_hz, axis=-1) >= 0)
    assert np.all(np.diff(md.f_undamped_hz, axis=-1) >= 0)


@pytest.mark.parametrize("name", ["A", "B", "C"])
def test_frf_equals_pole_residue_superposition(name: str) -> None:
    m, k, c, j = _nominal(name)
    md = compute_modes(m, k, c, j)
    f = np.linspace(0.0, 120.0, 241)
    h = receptance(m, k, c, j, f)
    hs = md.frf(f)
    err = np.max(np.abs(hs - h)) / np.max(np.abs(h))
    assert err < 1e-8


def test_proportional_damping_closed_forms() -> None:
    m, k, _, j = _nominal("B", n=4)
    alpha, beta = 0.8, 2.0e-4
    c = alpha * m + beta * k
    md = compute_modes(m, k, c, j)
    w = 2 * np.pi * md.f_undamped_hz
    # classical damping: same frequencies, zeta = alpha/(2w) + beta w/2
    np.testing.assert_allclose(md.f_hz, md.f_undamped_hz, rtol=1e-9)
    np.testing.assert_allclose(md.zeta, alpha / (2 * w) + beta * w / 2, rtol=1e-8)
    # and k from the residues equals w^2/u^2 exactly, so the modal form is exact
    np.testing.assert_allclose(md.k_from_residues(), md.k_N_per_m, rtol=1e-7)
    f = np.linspace(0.5, 60, 120)
    h = receptance(m, k, c, j, f)
    for d in range(3):
        hm = modal_receptance(md.f_hz, md.zeta, md.k_N_per_m[..., d, :], f)
        np.testing.assert_allclose(hm, h[..., d, d], rtol=1e-7, atol=1e-9 * np.abs(h).max())


def test_modal_stiffness_matches_driving_point_residue_for_light_damping() -> None:
    m, k, c, j = _nominal("A", n=6, seed=3)
    md = compute_modes(m, k, 0.05 * c, j)  # light, non-proportional damping
    kd = md.k_N_per_m
    kr = md.k_from_residues()
    # compare where the mode is seen at the TCP (the twin's visibility rule, SEEN_RATIO);
    # a barely visible mode's residue is dominated by damping coupling to its neighbours
    show = kd < SEEN_RATIO * kd.min(axis=-1, keepdims=True)
    np.testing.assert_allclose(kr[show], kd[show], rtol=2e-3)


def test_undamped_modes_raise_on_indefinite_matrices() -> None:
    with pytest.raises(InputError, match="M"):
        undamped_modes([[1.0, 2.0], [2.0, 1.0]], np.eye(2))
    with pytest.raises(InputError, match="K"):
        undamped_modes(np.eye(2), [[1.0, 0.0], [0.0, -1.0]])
    with pytest.raises(InputError, match="symmetric"):
        undamped_modes(np.eye(2), [[1.0, 0.5], [0.0, 1.0]])


def test_overdamped_raises() -> None:
    with pytest.raises(InputError, match="overdamped"):
        compute_modes([[1.0]], [[1.0]], [[3.0]], [[1.0]])


def test_shape_errors() -> None:
    with pytest.raises(InputError, match="J"):
        compute_modes(np.eye(2), np.eye(2), np.zeros((2, 2)), np.ones((3, 3)))
    with pytest.raises(InputError, match="broadcast"):
        compute_modes(
            np.broadcast_to(np.eye(2), (3, 2, 2)), np.eye(2), np.zeros((4, 2, 2)), np.ones((3, 2))
        )


def test_dominant_direction_and_stiffness() -> None:
    m, k, c, j = _nominal("C", n=3)
    md = compute_modes(m, k, c, j)
    d = md.dominant_direction()
    kd = np.take_along_axis(md.k_N_per_m, d[..., None, :], axis=-2)[..., 0, :]
    np.testing.assert_allclose(md.k_dominant_N_per_m(), kd)


def test_overdamped_robot_is_refused_naming_its_file() -> None:
    from robolobe.errors import InputError
    from robolobe.robots import load_robot
    from robolobe.twin import Twin

    robot = load_robot("B")
    heavy = robot.with_damping(robot.damping * 300)
    match = r"built-in.*overdamped.*posture index 0 \(1 of 1.*check the joint damping"
    with pytest.raises(InputError, match=match):
        Twin(heavy).modes(np.zeros((1, 6)) + 0.3)
