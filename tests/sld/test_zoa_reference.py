"""The test reference's closed-form 2x2 eigenvalues (``zoa_reference.eig2``) against LAPACK.

``reference_envelope`` solves the eigenvalues of ``alpha G(w)`` on some
50,000 frequencies per call; it does so in closed form (the stable quadratic
formula) instead of ``numpy.linalg.eigvals``' per-matrix LAPACK call. Both
eigenvalues must agree with LAPACK's to rounding on matrices like the
reference's (complex, of very different scales), on rank-1 matrices (one
eigenvalue zero: a rank-1 feed-frame receptance) and on repeated eigenvalues.
"""

from __future__ import annotations

import numpy as np

from .zoa_reference import eig2


def _matched(mu: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """|mu - ref| (n, 2) with ``ref``'s pair put in the order nearest ``mu``'s."""
    same = np.abs(mu - ref).max(axis=1)
    swapped = np.abs(mu - ref[:, ::-1]).max(axis=1)
    return np.minimum(same, swapped)


def test_eig2_equals_lapack_on_random_complex_matrices() -> None:
    rng = np.random.default_rng(7)
    n = 20_000
    g = (rng.normal(size=(n, 2, 2)) + 1j * rng.normal(size=(n, 2, 2))) * 10.0 ** rng.uniform(
        -9, -3, size=(n, 1, 1)
    )
    err = _matched(eig2(g), np.linalg.eigvals(g))
    scale = np.abs(g).max(axis=(1, 2))
    assert np.all(err <= 1e-12 * scale)


def test_eig2_on_rank_1_and_repeated_eigenvalues() -> None:
    rng = np.random.default_rng(8)
    u = rng.normal(size=(500, 2)) + 1j * rng.normal(size=(500, 2))
    v = rng.normal(size=(500, 2)) + 1j * rng.normal(size=(500, 2))
    rank1 = 1e-6 * u[:, :, None] * v[:, None, :]
    mu = eig2(rank1)
    big = np.einsum("ni,ni->n", v, u) * 1e-6  # the nonzero eigenvalue: v . u
    scale = np.abs(rank1).max(axis=(1, 2))
    assert np.all(np.abs(mu[:, 0] - big) <= 1e-12 * scale)
    assert np.all(np.abs(mu[:, 1]) <= 1e-12 * scale)
    # a multiple of the identity plus a nilpotent part: the eigenvalue twice
    lam = rng.normal(size=500) + 1j * rng.normal(size=500)
    g = np.zeros((500, 2, 2), complex)
    g[:, 0, 0] = g[:, 1, 1] = lam
    g[:, 0, 1] = rng.normal(size=500)
    assert np.allclose(eig2(g), lam[:, None], rtol=0.0, atol=1e-12)
    assert np.all(eig2(np.zeros((3, 2, 2), complex)) == 0.0)
