"""Poly-reference least-squares complex frequency-domain pole estimation (pLSCF, PolyMAX).

Right matrix-fraction model in the z-domain (Peeters, Van der Auweraer,
Guillaume, Leuridan 2004, "The PolyMAX frequency-domain method: a new
standard for modal parameter estimation", Shock and Vibration 11):

    H_o(w) (1 x m) = N_o(w) D(w)^-1,
    N_o(w) = sum_{r=0}^n z^r beta_{o,r}   (beta 1 x m, real)
    D(w)   = sum_{r=0}^n z^r alpha_r      (alpha m x m, real),   z = exp(i w dt)

for every output ``o`` and ``m`` references. The equation error
``W_o(w) [N_o(w) - H_o(w) D(w)]`` is linear in the real coefficients; the
numerator coefficients are eliminated (reduced normal equations), the
denominator is found with the constraint ``alpha_n = I``, and the poles are
the eigenvalues ``z`` of the block companion matrix, ``lambda = ln(z) / dt``
(``dt = 1 / (2 f_max)``). The first ``m`` rows of an eigenvector are the
modal participation vector ``L`` (the "shape" at the references).

With a single reference (``m = 1``) this is the common-denominator LSCF; it
is what driving-point-only campaigns use (the FRFs ``H_xx, H_yy, H_zz`` as
three outputs). There the pole's vector is the numerator values
``N_o(z_lambda)`` across outputs, proportional to the residues.

The normal matrices are built once at the highest order: those of every
lower order are their leading blocks, so a stabilization diagram over many
orders costs one pass over the data plus a small eigenproblem per order.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["PoleSet", "plscf"]


@dataclass(frozen=True)
class PoleSet:
    """Poles of one model order.

    Attributes
    ----------
    order : int
        Polynomial order ``n`` (``n * m`` poles in total, conjugates included).
    poles : numpy.ndarray of complex, shape (n_p,)
        Poles in the upper half plane (``Im > 0``), rad/s, sorted by
        frequency. Unstable poles (``Re >= 0``) are kept; the caller filters.
    vectors : numpy.ndarray of complex, shape (n_p, n_v)
        Participation vectors (``m > 1``, ``n_v = m``) or numerator values
        across outputs (``m = 1``, ``n_v`` = number of outputs), unit norm.
    """

    order: int
    poles: NDArray[np.complex128]
    vectors: NDArray[np.complex128]

    @property
    def f_hz(self) -> NDArray[np.float64]:
        """Undamped natural frequencies |lambda| / 2 pi, Hz, shape (n_p,)."""
        return np.abs(self.poles) / (2.0 * np.pi)

    @property
    def zeta(self) -> NDArray[np.float64]:
        """Damping ratios -Re(lambda) / |lambda|, shape (n_p,)."""
        return np.asarray(-self.poles.real / np.abs(self.poles))


def plscf(
    freq_hz: ArrayLike,
    H: ArrayLike,
    orders: Sequence[int],
    *,
    weights: ArrayLike | None = None,
) -> list[PoleSet]:
    """Estimate poles for several model orders with pLSCF.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency lines of the fitting band, strictly increasing, Hz. The
        z-domain sampling time is ``dt = 1 / (2 freq_hz[-1])``.
    H : array_like of complex, shape (n_freq, n_out, n_ref)
        FRFs (any consistent unit); finite values only.
    orders : sequence of int
        Model orders ``n >= 1`` to estimate.
    weights : array_like, shape (n_freq, n_out), optional
        Weighting function per frequency and output (e.g. inverse noise
        standard deviation). Default: each output scaled by the inverse of
        its RMS magnitude so that all outputs count alike.

    Returns
    -------
    list of PoleSet
        One per order, in the order given.
    """
    f = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex)
    if h.ndim != 3 or h.shape[0] != f.size:
        raise InputError(
            f"H: expected shape (n_freq={f.size}, n_out, n_ref), found {h.shape}", source="plscf"
        )
    if f.ndim != 1 or f.size < 4 or np.any(np.diff(f) <= 0):
        raise InputError("freq_hz: expected >= 4 strictly increasing values", source="plscf")
    if not np.all(np.isfinite(h)):
        raise InputError("H: expected finite values, found NaN or inf", source="plscf")
    orders = [int(n) for n in orders]
    if not orders or min(orders) < 1:
        raise InputError(f"orders: expected integers >= 1, found {orders}", source="plscf")
    n_freq, n_out, m = h.shape
    n_max = max(orders)
    if (n_max + 1) * m > 2 * n_freq * n_out:
        raise InputError(
            f"orders: the highest order {n_max} needs more data than {n_freq} lines "
            f"x {n_out} outputs",
            source="plscf",
        )

    if weights is None:
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=(0, 2)))
        rms = np.where(rms > 0, rms, 1.0)
        w = np.broadcast_to(1.0 / rms, (n_freq, n_out))
    else:
        w = np.broadcast_to(np.asarray(weights, dtype=float), (n_freq, n_out))

    dt = 1.0 / (2.0 * f[-1])
    omega = 2.0 * np.pi * f
    gamma = np.exp(1j * np.outer(omega * dt, np.arange(n_max + 1)))  # (F, n+1)

    # X_o = W_o Gamma, Y_o = -W_o (Gamma kron H_o); normal matrices at n_max.
    X = w.T[:, :, None] * gamma[None]  # (O, F, n+1)
    # Y[o, f, r*m + j] = -X[o, f, r] H[f, o, j]
    Y = -(X[:, :, :, None] * np.transpose(h, (1, 0, 2))[:, :, None, :]).reshape(
        n_out, n_freq, (n_max + 1) * m
    )
    Xh = X.conj().transpose(0, 2, 1)
    R = np.matmul(Xh, X).real  # (O, n+1, n+1)
    S = np.matmul(Xh, Y).real  # (O, n+1, (n+1)m)
    Y2 = Y.reshape(n_out * n_freq, -1)
    T = (Y2.conj().T @ Y2).real  # ((n+1)m, (n+1)m), summed over outputs

    lams: list[NDArray[np.complex128]] = []
    vecs: list[NDArray[np.complex128] | None] = []
    polys: list[NDArray[np.complex128]] = []  # m > 1: P(z) = sum z^r alpha_r^T at each pole
    # Reduced normal matrices of every order from one Cholesky factor R_o = C_o C_o^T:
    # C_o's leading blocks factor R_o's, so S_n^T R_n^-1 S_n = Z_n^T Z_n with Z = C^-1 S
    # cut to the order, i.e. a running sum of the outer products of Z's rows.
    Z = np.linalg.solve(np.linalg.cholesky(R), S)  # (O, n+1, (n+1)m)
    ZtZ = np.cumsum(np.einsum("oia,oib->iab", Z, Z), axis=0)  # (n+1, (n+1)m, (n+1)m)
    for n in orders:
        na, nb = n + 1, (n + 1) * m
        M = T[:nb, :nb] - ZtZ[n, :nb, :nb]
        M = 0.5 * (M + M.T)
        k = n * m
        try:
            alpha_low = -np.linalg.solve(M[:k, :k], M[:k, k:])  # (n m, m)
        except np.linalg.LinAlgError:
            alpha_low = -np.linalg.lstsq(M[:k, :k], M[:k, k:], rcond=None)[0]
        # Block companion of sum z^r alpha_r^T: its eigenvectors are [L; z L; ...] with
        # L^T D(z) = 0, the participation vector (H ~ psi L^T / (s - lambda) near a pole).
        comp = np.zeros((k, k))
        if n > 1:
            comp[: k - m, m:] = np.eye(k - m)
        alpha_t = alpha_low.reshape(n, m, m).transpose(0, 2, 1)
        comp[k - m :, :] = -alpha_t.transpose(1, 0, 2).reshape(m, k)
        # eigenvalues only (the eigenvectors cost ~1.6x more): L is the null vector of
        # the m x m matrix polynomial at the pole, found for all orders at once below
        zs = np.linalg.eigvals(comp)
        with np.errstate(divide="ignore", invalid="ignore"):
            lam = np.log(zs.astype(complex)) / dt
        keep = np.isfinite(lam) & (lam.imag > 0)
        order_idx = np.argsort(lam[keep].imag)
        zk = zs[keep][order_idx]
        lams.append(lam[keep][order_idx])
        if m > 1:
            powers = zk[:, None] ** np.arange(n + 1)[None, :]  # (n_p, n + 1)
            coef = np.concatenate([alpha_t.reshape(n, m * m), np.eye(m).reshape(1, m * m)])
            polys.append((powers @ coef).reshape(-1, m, m))
            vecs.append(None)
        else:
            # numerator values per output: beta_o = -R_o^-1 S_o A, A = [alpha_low; 1]
            A = np.concatenate([alpha_low[:, 0], [1.0]])
            beta = -np.linalg.solve(R[:, :na, :na], (S[:, :na, :nb] @ A)[..., None])[..., 0]
            powers = zk[:, None] ** np.arange(na)[None, :]  # (n_p, na)
            vec = (powers @ beta.T) / w.mean(axis=0)[None, :]  # undo output weights
            norms = np.linalg.norm(vec, axis=1, keepdims=True)
            vecs.append(vec / np.where(norms > 0, norms, 1.0))
    n_v = m if m > 1 else n_out
    if m > 1:
        # participation vectors of every order in one batch
        allv = _null_vectors(np.concatenate(polys)) if polys else np.zeros((0, m), complex)
        cuts = np.cumsum([lam.size for lam in lams])[:-1]
        vecs = list(np.split(allv, cuts))
    return [
        PoleSet(
            order=n,
            poles=lam.astype(np.complex128),
            vectors=np.asarray(v, dtype=np.complex128).reshape(lam.size, n_v),
        )
        for n, lam, v in zip(orders, lams, vecs, strict=True)
    ]


def _null_vectors(P: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """Unit right null vectors ``L`` (``P L ~ 0``) of nearly singular m x m matrices.

    Parameters
    ----------
    P : ndarray of complex, shape (n_p, m, m)
        The matrix polynomial ``sum_r z^r alpha_r^T`` (``alpha_n = I``) at the
        eigenvalues ``z`` of the block companion matrix.

    Returns
    -------
    ndarray of complex, shape (n_p, m)
        The first block of the companion's eigenvector, normalized (for m = 2, 3
        orthogonal, bilinearly, to the rows; else the right singular vector of the
        smallest singular value).
    """
    n_p, m, _ = P.shape
    if n_p == 0:
        return np.zeros((0, m), dtype=np.complex128)
    if m == 3:
        # orthogonal to two rows: their cross product; of the three pairs the longest
        # product is the best conditioned (much cheaper than batched 3x3 SVDs)
        c = np.stack(
            [np.cross(P[:, 0], P[:, 1]), np.cross(P[:, 0], P[:, 2]), np.cross(P[:, 1], P[:, 2])],
            axis=1,
        )  # (n_p, 3 pairs, 3)
        best = np.argmax(np.sum(np.abs(c) ** 2, axis=2), axis=1)
        L = c[np.arange(n_p), best]
    elif m == 2:
        best = np.argmax(np.sum(np.abs(P) ** 2, axis=2), axis=1)  # the longer row
        r = P[np.arange(n_p), best]
        L = np.stack([-r[:, 1], r[:, 0]], axis=1)
    else:
        L = np.linalg.svd(P)[2][:, -1, :].conj()
    nrm = np.linalg.norm(L, axis=1)
    # rank <= m - 2 (a null space of dimension >= 2: all products ~0): any vector of it,
    # from the SVD
    scale = np.linalg.norm(P.reshape(n_p, -1), axis=1) ** (m - 1)
    weak = ~(nrm > 1e-9 * scale)
    if m in (2, 3) and weak.any():
        L[weak] = np.linalg.svd(P[weak])[2][:, -1, :].conj()
        nrm[weak] = np.linalg.norm(L[weak], axis=1)
    return np.asarray(L / np.where(nrm > 0, nrm, 1.0)[:, None], dtype=np.complex128)
