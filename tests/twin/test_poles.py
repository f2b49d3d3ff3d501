"""The one state-space pole routine: against SciPy's generalized eigensolver, batching, policy."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.linalg

from robolobe.diagnose.twin_model import pole_residue_receptance, state_space_poles, twin_modes
from robolobe.errors import InputError
from robolobe.robots import load_robot
from robolobe.twin import _poles
from robolobe.twin._poles import modal_poles, pole_vectors, state_space_eig
from robolobe.twin.frf import receptance
from robolobe.twin.model import Twin
from robolobe.twin.modes import compute_modes, damped_poles

EXAMPLE_ROBOT = Path(__file__).resolve().parents[2] / "examples" / "robots" / "my_robot.toml"


def _system(robot, n: int, seed: int, damping: float = 1.0):
    r = load_robot(robot)
    r = r.with_damping(r.damping * damping)
    q = np.random.default_rng(seed).uniform(r.q_min, r.q_max, (n, 6))
    return Twin(r).system(q)


def _reference(M, K, C, J):
    """Per posture, SciPy's ``eig`` of the state matrix built with ``scipy.linalg.solve``.

    One posture at a time, the selection and normalisation written out: the
    poles with Im > 0 rising by |lambda|, their residues
    ``(J psi)(J psi)^T / a`` from LAPACK's eigenvectors, and how many modes
    are overdamped.
    """
    n = M.shape[-1]
    lam_out, res_out, n_over = [], [], []
    eye, zero = np.eye(n), np.zeros((n, n))
    for m, k, c, j in zip(M, K, C, J, strict=True):
        a = np.block([[zero, eye], [-scipy.linalg.solve(m, k), -scipy.linalg.solve(m, c)]])
        lam, v = scipy.linalg.eig(a)
        up = lam.imag > 1e-9 * np.abs(lam)
        n_over.append(n - int(up.sum()))
        idx = np.flatnonzero(up)
        idx = idx[np.argsort(np.abs(lam[idx]))]
        psi = v[:n, idx]
        norm = 2 * lam[idx] * np.einsum("ir,ij,jr->r", psi, m, psi) + np.einsum(
            "ir,ij,jr->r", psi, c, psi
        )
        u = j @ psi
        lam_out.append(lam[idx])
        res_out.append(np.einsum("ir,jr->rij", u, u) / norm[:, None, None])
    return lam_out, res_out, np.asarray(n_over)


@pytest.mark.parametrize("robot", ["A", "B", "C"])
def test_poles_and_residues_equal_scipy_per_posture(robot: str) -> None:
    s = _system(robot, 12, seed=3)
    lam_ref, res_ref, n_over = _reference(s.M, s.K, s.C, s.J)
    assert not n_over.any()
    md = compute_modes(s.M, s.K, s.C, s.J)
    for p in range(12):
        np.testing.assert_allclose(md.poles[p], lam_ref[p], rtol=1e-10)
        scale = np.max(np.abs(res_ref[p]))
        np.testing.assert_allclose(md.residues[p], res_ref[p], rtol=0, atol=1e-9 * scale)


def test_residues_equal_a_40_digit_solution() -> None:
    """mpmath's eigenproblem of the state matrix at 40 digits (independent of LAPACK)."""
    mpmath = pytest.importorskip("mpmath", reason="mpmath (a sympy dependency) not installed")
    s = _system("B", 1, seed=3)
    md = compute_modes(s.M, s.K, s.C, s.J)
    with mpmath.workdps(40):
        m, k, c, j = (mpmath.matrix(x[0].tolist()) for x in (s.M, s.K, s.C, s.J))
        mi = mpmath.inverse(m)
        a = mpmath.zeros(12, 12)
        for i in range(6):
            a[i, 6 + i] = 1
            for jj in range(6):
                a[6 + i, jj] = (-mi * k)[i, jj]
                a[6 + i, 6 + jj] = (-mi * c)[i, jj]
        ev, vec = mpmath.eig(a)
        lam = np.array([complex(e) for e in ev])
        up = np.flatnonzero(lam.imag > 0)
        up = up[np.argsort(np.abs(lam[up]))]
        res = []
        for r in up:
            psi = vec[:6, r]
            norm = 2 * ev[r] * (psi.T * m * psi)[0] + (psi.T * c * psi)[0]
            u = j * psi
            res.append([[complex(u[i] * u[b] / norm) for b in range(3)] for i in range(3)])
    np.testing.assert_allclose(md.poles[0], lam[up], rtol=1e-13)
    ref = np.asarray(res)
    np.testing.assert_allclose(md.residues[0], ref, rtol=0, atol=1e-11 * np.abs(ref).max())


def test_batched_equals_one_posture_at_a_time() -> None:
    s = _system("B", 10, seed=5)
    md = compute_modes(s.M, s.K, s.C, s.J)
    for p in range(10):
        one = compute_modes(s.M[p], s.K[p], s.C[p], s.J[p])
        np.testing.assert_array_equal(one.poles, md.poles[p])
        np.testing.assert_allclose(one.residues, md.residues[p], rtol=1e-12, atol=0)


def test_pole_vectors_are_null_vectors_also_for_an_exact_pole(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # lambda = 2i exactly: Q(lambda) = 0 in floating point, so that the
    # unshifted solve is singular; the next shift must take over
    psi = pole_vectors(np.eye(1), 4.0 * np.eye(1), np.zeros((1, 1)), np.array([2j]))
    assert abs(psi[0, 0]) == pytest.approx(1.0, rel=1e-12)
    monkeypatch.setattr(_poles, "_SHIFT", 0.0)
    psi0 = pole_vectors(np.eye(1), 4.0 * np.eye(1), np.zeros((1, 1)), np.array([2j]))
    assert abs(psi0[0, 0]) == pytest.approx(1.0, rel=1e-12)
    monkeypatch.undo()
    s = _system("A", 20, seed=7)
    lam = modal_poles(s.M, s.K, s.C)
    psi = pole_vectors(s.M, s.K, s.C, lam)
    lam_all, v = state_space_eig(s.M, s.K, s.C, vectors=True)
    assert v is not None
    # each vector is parallel to LAPACK's eigenvector of the same pole
    for p in range(20):
        for r in range(6):
            i = int(np.argmin(np.abs(lam_all[p] - lam[p, r])))
            w = v[p, :, i] / np.linalg.norm(v[p, :, i])
            assert abs(abs(np.vdot(w, psi[p, :, r])) - 1.0) < 1e-10


def _one_overdamped() -> tuple[np.ndarray, ...]:
    """Two decoupled DOFs: w = 1 rad/s with zeta 1.5 (overdamped), w = 10 with zeta 0.05."""
    M = np.eye(2)
    K = np.diag([1.0, 100.0])
    C = np.diag([3.0, 1.0])
    J = np.array([[1.0, 0.0], [0.0, 2.0]])
    return M, K, C, J


def test_overdamped_policy_raise_and_drop() -> None:
    M, K, C, J = _one_overdamped()
    with pytest.raises(InputError, match="overdamped"):
        compute_modes(M, K, C, J)
    with pytest.raises(InputError, match="overdamped"):
        damped_poles(M, K, C)
    with pytest.raises(InputError, match="overdamped: expected one of"):
        compute_modes(M, K, C, J, overdamped="soften")  # type: ignore[arg-type]
    md = compute_modes(M, K, C, J, overdamped="drop")
    # slot 0 is the overdamped mode (sqrt(p1 p2) = 1 rad/s < 10): nan in the damped view,
    # finite and aligned in the undamped one
    assert np.isnan(md.f_hz[0])
    assert np.isnan(md.zeta[0])
    assert np.isnan(md.poles[0])
    assert np.all(np.isnan(md.residues[0]))
    np.testing.assert_allclose(md.f_undamped_hz, np.array([1.0, 10.0]) / (2 * np.pi))
    assert md.f_hz[1] == pytest.approx(10.0 / (2 * np.pi), rel=1e-12)
    assert md.zeta[1] == pytest.approx(0.05, rel=1e-12)
    assert md.residues[1, 1, 1] == pytest.approx(4.0 / (2j * 10.0 * np.sqrt(1 - 0.05**2)))
    np.testing.assert_allclose(md.k_N_per_m[:, 1], [np.inf, 25.0])
    with pytest.raises(InputError, match="overdamped"):
        md.frf([1.0, 2.0])
    # the diagnosis' list leaves it out; its receptance keeps all four poles (exact)
    f = np.linspace(0.0, 5.0, 11)
    h = pole_residue_receptance(M, K, C, J, np.asarray(2j * np.pi * f, dtype=np.complex128))
    np.testing.assert_allclose(h, receptance(M, K, C, J, f), rtol=1e-12, atol=1e-15)


def test_overdamped_policy_keep_gives_the_pair_its_frequency_and_damping() -> None:
    """'keep': the overdamped slot gets w0 = sqrt(p1 p2) and zeta = -(p1 + p2) / (2 w0)
    of its real poles; for this proportionally damped system the real-mode receptance
    of the modes is then the exact one (solved directly), the overdamped term included."""
    M, K, C, J = _one_overdamped()
    md = compute_modes(M, K, C, J, overdamped="keep")
    assert md.f_hz[0] == pytest.approx(1.0 / (2 * np.pi), rel=1e-12)
    assert md.zeta[0] == pytest.approx(1.5, rel=1e-12)
    assert md.omega_d[0] == 0.0
    assert np.isnan(md.poles[0])
    assert md.zeta[1] == pytest.approx(0.05, rel=1e-12)
    with pytest.raises(InputError, match="overdamped"):
        md.frf([1.0])
    f = np.linspace(0.0, 5.0, 41)
    w = 2 * np.pi * f
    wr, zr, u = 2 * np.pi * md.f_hz, md.zeta, md.tcp_shapes  # (2,), (2,), (2, 2)
    g = 1.0 / (wr**2 - w[:, None] ** 2 + 2j * zr * wr * w[:, None])  # (n_freq, 2)
    real_mode = np.einsum("fr,ir,jr->fij", g, u, u)
    np.testing.assert_allclose(real_mode, receptance(M, K, C, J, f), rtol=1e-12, atol=1e-15)
    # the same numbers as 'drop' everywhere else
    drop = compute_modes(M, K, C, J, overdamped="drop")
    np.testing.assert_array_equal(md.f_hz[1:], drop.f_hz[1:])
    np.testing.assert_array_equal(md.shapes, drop.shapes)


def test_example_robot_overdamped_postures_match_scipy() -> None:
    """The example robot's wrist mode is overdamped at some postures: 'raise' refuses
    them naming the file, 'drop' leaves exactly the modes SciPy finds overdamped out."""
    robot = load_robot(str(EXAMPLE_ROBOT))
    q = np.random.default_rng(0).uniform(robot.q_min, robot.q_max, (60, 6))
    twin = Twin(robot)
    s = twin.system(q)
    lam_ref, res_ref, n_over = _reference(s.M, s.K, s.C, s.J)
    assert 0 < np.count_nonzero(n_over) < 60  # the fixture shows both kinds
    with pytest.raises(InputError, match=r"my_robot.*overdamped|overdamped.*my_robot"):
        twin.modes(q)
    md = twin.modes(q, overdamped="drop")
    dropped = np.isnan(md.f_hz)
    np.testing.assert_array_equal(dropped.sum(axis=-1), n_over)
    f_diag, z_diag, _ = twin_modes(twin, q)
    for p in range(60):
        np.testing.assert_allclose(md.poles[p][~dropped[p]], lam_ref[p], rtol=1e-10)
        kept = np.isfinite(f_diag[p])
        np.testing.assert_allclose(f_diag[p][kept], np.abs(lam_ref[p]) / (2 * np.pi), rtol=1e-10)
        zeta_ref = -lam_ref[p].real / np.abs(lam_ref[p])
        np.testing.assert_allclose(z_diag[p][kept], zeta_ref, rtol=1e-8)
        scale = np.max(np.abs(res_ref[p]))
        np.testing.assert_allclose(md.residues[p][~dropped[p]], res_ref[p], atol=1e-9 * scale)
    # a dropped slot stays the slot of its undamped mode: the kept damped
    # frequencies stay within a few per cent of their undamped partners
    ratio = md.f_hz[dropped.any(-1)] / md.f_undamped_hz[dropped.any(-1)]
    assert np.nanmax(np.abs(ratio - 1.0)) < 0.1


def test_a_dropped_overdamped_mode_hardly_moves_the_stability_relevant_frf() -> None:
    """What 'drop' leaves out at the example robot's overdamped postures: the most
    negative real part of each driving-point FRF (what sets a chatter limit) of the
    kept poles is never more than 1 % less negative than the exact receptance's
    (leaving the mode out is conservative or nearly neutral; measured: <= 0.5 %)."""
    robot = load_robot(str(EXAMPLE_ROBOT))
    twin = Twin(robot)
    q = np.random.default_rng(0).uniform(robot.q_min, robot.q_max, (80, 6))
    dropped = np.isnan(twin.modes(q, overdamped="drop").f_hz).any(axis=-1)
    assert dropped.sum() >= 5
    s = twin.system(q[dropped])
    f = np.linspace(1.0, 1500.0, 1500)
    exact = receptance(s.M, s.K, s.C, s.J, f)
    lam, u, a = state_space_poles(s.M, s.K, s.C, s.J)
    real = np.abs(lam.imag) <= 1e-9 * np.abs(lam)
    g = np.where(
        real[:, None, :], 0.0, 1.0 / (a[:, None, :] * (2j * np.pi * f[:, None] - lam[:, None, :]))
    )
    kept = np.einsum("nfr,nir,njr->nfij", g, u, u)
    for d in range(3):
        ratio = exact[:, :, d, d].real.min(axis=1) / kept[:, :, d, d].real.min(axis=1)
        assert np.all(ratio < 1.01)
