"""pLSCF poles and participation vectors on analytic FRFs (exact truth)."""

from __future__ import annotations

import numpy as np
import pytest

from robolobe.campaign.metrics import mac
from robolobe.errors import InputError
from robolobe.modal.plscf import plscf

from ._systems import make_system


def _match(poles: np.ndarray, true: np.ndarray) -> np.ndarray:
    return np.array([poles[np.argmin(np.abs(poles - t))] for t in true])


@pytest.mark.parametrize("poly_reference", [True, False])
def test_noise_free_poles_exact(poly_reference: bool) -> None:
    sysm = make_system(1)
    f = np.arange(1, 181) * 0.25  # 0.25..45 Hz
    H = sysm.H(f)
    if poly_reference:
        data, order = H, 10  # 3 references: 30 poles
    else:
        data, order = np.stack([H[:, 0, 0], H[:, 1, 1], H[:, 2, 2]], 1)[:, :, None], 30
    (ps,) = plscf(f, data, [order])
    inband = sysm.poles[sysm.f_hz < 40]
    got = _match(ps.poles, inband)
    # modes above the band (60, 95 Hz) bias the in-band poles only slightly
    np.testing.assert_allclose(np.abs(got), np.abs(inband), rtol=2e-4)
    np.testing.assert_allclose(-got.real / np.abs(got), sysm.zeta[sysm.f_hz < 40], rtol=0.05)
    if poly_reference:
        idx = [int(np.argmin(np.abs(ps.poles - t))) for t in inband]
        m = mac(ps.vectors[idx], sysm.u[sysm.f_hz < 40])
        assert np.all(m > 0.999)  # participation vector = TCP shape (reciprocity)


def test_orders_and_validation() -> None:
    sysm = make_system(2)
    f = np.linspace(2, 40, 100)
    sets = plscf(f, sysm.H(f), [2, 5, 9])
    assert [p.order for p in sets] == [2, 5, 9]
    assert all(np.all(p.poles.imag > 0) for p in sets)
    assert all(np.all(np.diff(p.poles.imag) >= 0) for p in sets)
    assert sets[-1].vectors.shape[1] == 3
    bad = sysm.H(f)
    bad[3, 0, 0] = np.nan
    bad = sysm.H(f)
    bad[3, 0, 0] = np.nan
    with pytest.raises(InputError, match="finite"):
        plscf(f, bad, [4])
    with pytest.raises(InputError, match="shape"):
        plscf(f, sysm.H(f)[:, 0], [4])
    with pytest.raises(InputError, match="increasing"):
        plscf(f[::-1], sysm.H(f), [4])
    with pytest.raises(InputError, match="orders"):
        plscf(f, sysm.H(f), [0])


@pytest.mark.parametrize("m", [2, 3, 4])
def test_participation_vectors_are_the_companion_eigenvectors(m: int) -> None:
    """Null vectors of the matrix polynomial = first block of the companion's eigenvectors."""
    from robolobe.modal.plscf import _null_vectors

    rng = np.random.default_rng(m)
    n = 6
    alpha_t = rng.normal(size=(n, m, m))  # alpha_0^T .. alpha_{n-1}^T, alpha_n = I
    k = n * m
    comp = np.zeros((k, k))
    comp[: k - m, m:] = np.eye(k - m)
    comp[k - m :, :] = -alpha_t.transpose(1, 0, 2).reshape(m, k)
    z, vecs = np.linalg.eig(comp)  # an independent eigen-solver's vectors
    P = np.einsum("pr,rij->pij", z[:, None] ** np.arange(n), alpha_t) + (z**n)[
        :, None, None
    ] * np.eye(m)
    L = _null_vectors(P)
    np.testing.assert_allclose(np.linalg.norm(L, axis=1), 1.0, rtol=1e-12)
    np.testing.assert_allclose(mac(L, vecs[:m].T), 1.0, atol=1e-9)


def test_participation_vector_of_a_double_pole() -> None:
    """A 2-D null space (every 2x2 minor zero): a unit vector of it, not a zero vector."""
    from robolobe.modal.plscf import _null_vectors

    u = np.array([1.0, 2.0, -1.0]) / np.sqrt(6)
    P = np.stack([np.outer(u, [1.0, 0.5, 2.0]), np.zeros((3, 3))]).astype(complex)
    L = _null_vectors(P)
    np.testing.assert_allclose(np.linalg.norm(L, axis=1), 1.0)
    np.testing.assert_allclose(np.abs(np.einsum("pij,pj->pi", P, L)), 0.0, atol=1e-12)
    assert _null_vectors(np.zeros((0, 3, 3), complex)).shape == (0, 3)
