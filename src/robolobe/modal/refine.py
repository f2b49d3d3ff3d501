"""Nonlinear refinement of poles: weighted least squares on the FRFs (variable projection).

The poles from the clustered stabilization diagram are good starting values;
the final estimate minimizes the weighted FRF misfit

    sum_k sum_f  W_k(f)^2 |H_k(f) - model_k(f; lambda, R_k, residuals_k)|^2

over the poles, the residues and residual terms being eliminated by the
linear LSFD solve for each trial set of poles (variable projection, Golub &
Pereyra). With noise-based weights this is close to the maximum-likelihood
estimate that PolyMAX-plus / MLMM refine to; it removes most of the bias of
the linearized pLSCF damping estimates, which matters for light damping
under an exponential window (REFERENCES.md section 4).

Each pole is parametrized by ``ln w_r`` and ``ln sigma_r`` and kept within
``f_bound`` (relative) of its start, with ``0 < zeta < zeta_max``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from robolobe.modal.lsfd import residue_basis

__all__ = ["RefineResult", "refine_poles"]


@dataclass(frozen=True)
class RefineResult:
    """Outcome of :func:`refine_poles`.

    Attributes
    ----------
    poles : ndarray of complex, shape (n_modes,)
        Refined poles (upper half plane), rad/s.
    cost_start, cost : float
        Weighted squared misfit before and after.
    at_bound : ndarray of bool, shape (n_modes,)
        Poles that ended on a bound (not trustworthy).
    success : bool
        Whether the optimizer reported convergence.
    """

    poles: NDArray[np.complex128]
    cost_start: float
    cost: float
    at_bound: NDArray[np.bool_]
    success: bool


def _projector(
    F: NDArray[np.float64],
    y: NDArray[np.float64],
    w2: NDArray[np.float64],
    lower: bool,
    upper: bool,
) -> Callable[[NDArray[np.complex128]], NDArray[np.float64]]:
    def resid(lam: NDArray[np.complex128]) -> NDArray[np.float64]:
        B = residue_basis(F, lam, lower=lower, upper=upper)
        br = np.concatenate([B.real, B.imag], axis=0)  # (2F, P)
        bw = w2.T[:, :, None] * br[None]  # (K, 2F, P)
        A = np.matmul(bw.transpose(0, 2, 1), br)  # (K, P, P)
        b = np.einsum("kfp,fk->kp", bw, y)
        scale = np.sqrt(np.einsum("kpp->kp", A))
        scale = np.where(scale > 0, scale, 1.0)
        A = A / (scale[:, :, None] * scale[:, None, :]) + 1e-12 * np.eye(br.shape[1])[None]
        x = np.linalg.solve(A, (b / scale)[..., None])[..., 0] / scale
        r = np.sqrt(w2) * (y - br @ x.T)
        return np.asarray(r.ravel(), dtype=float)

    return resid


def refine_poles(
    freq_hz: ArrayLike,
    H: ArrayLike,
    poles: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    lower: bool = True,
    upper: bool = True,
    f_bound: float = 0.05,
    zeta_max: float = 0.3,
    max_nfev: int = 60,
    free: ArrayLike | None = None,
) -> RefineResult:
    """Refine poles by weighted nonlinear least squares on the FRFs.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Fitting band, Hz (> 0 when ``lower``).
    H : array_like of complex, shape (n_freq, ...)
        FRFs; NaN entries get zero weight.
    poles : array_like of complex, shape (n_modes,)
        Starting poles, rad/s.
    weights : array_like, shape (n_freq, ...), optional
        Inverse noise standard deviation per line; default 1.
    lower, upper : bool
        Residual terms as in :func:`robolobe.modal.lsfd.lsfd`.
    f_bound : float
        Each natural frequency stays within this relative distance of its start.
    zeta_max : float
        Upper bound of the damping ratio.
    max_nfev : int
        Budget of function evaluations (per parameter, as scipy counts it).
    free : array_like of bool, shape (n_modes,), optional
        Poles to optimize; the others stay fixed (default: all).

    Returns
    -------
    RefineResult
    """
    F = np.asarray(freq_hz, dtype=float)
    h = np.asarray(H, dtype=complex).reshape(F.size, -1)
    lam0 = np.asarray(poles, dtype=complex).reshape(-1)
    w = (
        np.ones(h.shape)
        if weights is None
        else np.broadcast_to(np.asarray(weights, dtype=float), np.asarray(H).shape).reshape(
            F.size, -1
        )
    )
    good = np.isfinite(h) & np.isfinite(w)
    w = np.where(good, w, 0.0)
    h = np.where(good, h, 0.0)
    live = np.any(w > 0, axis=0)  # FRFs with data (absent directions have zero weight)
    h, w = h[:, live], w[:, live]
    y = np.concatenate([h.real, h.imag], axis=0)
    w2 = np.concatenate([w, w], axis=0) ** 2
    n = lam0.size
    if n == 0:
        return RefineResult(lam0.astype(np.complex128), 0.0, 0.0, np.zeros(0, bool), True)
    resid = _projector(F, y, w2, lower, upper)
    wr0 = np.abs(lam0)
    z0 = np.clip(-lam0.real / wr0, 1e-5, zeta_max * 0.999)
    fr = np.ones(n, bool) if free is None else np.asarray(free, dtype=bool).reshape(n)
    nf = int(np.count_nonzero(fr))
    if nf == 0:
        r = resid(lam0)
        c = 0.5 * float(r @ r)
        return RefineResult(lam0.astype(np.complex128), c, c, np.zeros(n, bool), True)

    def to_poles(p: NDArray[np.float64]) -> NDArray[np.complex128]:
        wr = wr0.copy()
        z = z0.copy()
        # LM steps are unbounded: clip before exp (the box is checked afterwards)
        wr[fr] = np.exp(np.clip(p[:nf], np.log(wr0[fr]) - 1.0, np.log(wr0[fr]) + 1.0))
        z[fr] = np.exp(np.clip(p[nf:], np.log(1e-6), np.log(0.999)))
        lam = -z * wr + 1j * wr * np.sqrt(1.0 - z**2)
        return np.asarray(np.where(fr, lam, lam0), dtype=np.complex128)

    p0 = np.concatenate([np.log(wr0[fr]), np.log(z0[fr])])
    r0 = resid(to_poles(p0))
    cost0 = 0.5 * float(r0 @ r0)
    try:
        # Levenberg-Marquardt (MINPACK): no LAPACK SVD per step, which is slow when
        # the BLAS runs many threads on a loaded machine; bounds are checked after.
        def fun(p: NDArray[np.float64]) -> NDArray[np.float64]:
            return resid(to_poles(p))

        sol = least_squares(
            fun,
            p0,
            method="lm",
            x_scale=np.concatenate([np.full(nf, 1e-3), np.full(nf, 0.1)]),
            max_nfev=max_nfev * (2 * nf + 1),
            diff_step=np.full(2 * nf, 1e-6),
        )
    except (ValueError, np.linalg.LinAlgError):
        return RefineResult(lam0.astype(np.complex128), cost0, cost0, fr.copy(), False)
    if not np.all(np.isfinite(sol.x)) or not np.isfinite(sol.cost) or sol.cost > cost0:
        return RefineResult(lam0.astype(np.complex128), cost0, cost0, np.zeros(n, bool), False)
    x = sol.x
    drift = np.abs(x[:nf] - p0[:nf]) > np.log1p(f_bound)
    zeta_out = x[nf:] > np.log(zeta_max)
    bad = drift | zeta_out
    # poles that left their box keep their start value
    x = np.where(np.concatenate([bad, bad]), p0, x)
    at_bound = np.zeros(n, bool)
    at_bound[fr] = bad
    return RefineResult(to_poles(x), cost0, float(sol.cost), at_bound, bool(sol.success))
