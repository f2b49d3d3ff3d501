"""Nonlinear refinement of poles: weighted least squares on the FRFs (variable projection).

The poles from the clustered stabilization diagram are good starting values;
the final estimate minimizes the weighted FRF misfit

    sum_k sum_f  W_k(f)^2 |H_k(f) - model_k(f; lambda, R_k, residuals_k)|^2

over the poles, the residues and residual terms being eliminated by the
linear LSFD solve for each trial set of poles (variable projection, Golub &
Pereyra). With noise-based weights this is close to the maximum-likelihood
estimate that PolyMAX-plus / MLMM refine to; it removes most of the bias of
the linearized pLSCF damping estimates, which matters for light damping
under an exponential window (docs/references.md: modal identification).

Each pole is parametrized by ``ln w_r`` and ``ln sigma_r`` and kept within
``f_bound`` (relative) of its start, with ``0 < zeta < zeta_max``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, leastsq

from robolobe.errors import InputError
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


class _Projection:
    """Variable-projection residual and its Jacobian for one set of FRFs.

    ``resid(lam)``: weighted misfit after the linear LSFD solve, shape
    (2 n_freq * n_frf,). ``jac(lam, dlam)``: its derivative with respect to
    parameters that move pole ``r`` by ``dlam[j]`` (one pole per parameter,
    ``owner[j]``), in Kaufman's form ``J_k = -P_k W_k (dB/dp) x_k`` (the
    projector onto the orthogonal complement of the weighted basis, the
    changed basis columns times the current linear solution): exact at the
    solution's first order, one projection per FRF instead of a residual
    evaluation per parameter (finite differences).
    """

    def __init__(
        self,
        F: NDArray[np.float64],
        y: NDArray[np.float64],
        w2: NDArray[np.float64],
        lower: bool,
        upper: bool,
    ) -> None:
        self.F, self.y, self.w2, self.lower, self.upper = F, y, w2, lower, upper
        self.sw = np.sqrt(w2)
        self._key: bytes | None = None
        # Weights proportional across the FRFs (no coherence weighting: w_k = c_k w_0, as
        # in a campaign read from frf.csv) give every FRF the same least-squares
        # solution operator and projector: one normal matrix serves them all, and the
        # Jacobian projects the 2J changed columns once instead of K J products.
        self.sw0: NDArray[np.float64] | None = None
        i0 = int(np.argmax(self.sw.sum(axis=0)))
        ref = self.sw[:, i0]
        c = self.sw.sum(axis=0) / ref.sum()
        if np.max(np.abs(self.sw - ref[:, None] * c[None, :])) <= 1e-12 * np.max(ref):
            self.sw0, self.c = ref, c

    def _solve(self, lam: NDArray[np.complex128]) -> None:
        key = lam.tobytes()
        if key == self._key:
            return
        B = residue_basis(self.F, lam, lower=self.lower, upper=self.upper)
        br = np.concatenate([B.real, B.imag], axis=0)  # (2F, P)
        eye = 1e-12 * np.eye(br.shape[1])
        if self.sw0 is not None:
            aw = self.sw0[:, None] * br  # (2F, P), the same for every FRF
            A = aw.T @ aw
            scale = np.sqrt(np.diagonal(A))
            scale = np.where(scale > 0, scale, 1.0)
            An = A / np.outer(scale, scale) + eye
            b = aw.T @ (self.sw0[:, None] * self.y)  # (P, K)
            x = (np.linalg.solve(An, b / scale[:, None]) / scale[:, None]).T  # (K, P)
        else:
            aw = self.sw.T[:, :, None] * br[None]  # (K, 2F, P)
            awt = aw.transpose(0, 2, 1)
            A = np.matmul(awt, aw)  # (K, P, P)
            b = np.matmul(awt, (self.sw * self.y).T[:, :, None])[..., 0]
            scale = np.sqrt(np.diagonal(A, axis1=1, axis2=2))
            scale = np.where(scale > 0, scale, 1.0)
            An = A / (scale[:, :, None] * scale[:, None, :]) + eye[None]
            x = np.linalg.solve(An, (b / scale)[..., None])[..., 0] / scale
        self._key, self.aw, self.An, self.scale, self.x = key, aw, An, scale, x
        self.r = self.sw * (self.y - br @ x.T)  # (2F, K)

    def resid(self, lam: NDArray[np.complex128]) -> NDArray[np.float64]:
        self._solve(lam)
        return np.asarray(self.r.ravel(), dtype=float)

    def jac(
        self, lam: NDArray[np.complex128], owner: NDArray[np.intp], dlam: NDArray[np.complex128]
    ) -> NDArray[np.float64]:
        self._solve(lam)
        s = 2j * np.pi * self.F
        g = 1.0 / (s[:, None] - lam[owner][None, :])  # (F, J)
        gc = 1.0 / (s[:, None] - np.conj(lam[owner])[None, :])
        d1 = g**2 * dlam[None, :]  # d g / dp
        d1c = gc**2 * np.conj(dlam)[None, :]  # d g* / dp
        c1 = d1 + d1c  # derivative of column 2r (g + g*)
        c2 = 1j * (d1 - d1c)  # derivative of column 2r + 1 (i (g - g*))
        c1r = np.concatenate([c1.real, c1.imag], axis=0)  # (2F, J)
        c2r = np.concatenate([c2.real, c2.imag], axis=0)
        xa = self.x[:, 2 * owner]  # (K, J)
        xb = self.x[:, 2 * owner + 1]
        J = owner.size
        if self.sw0 is not None:
            # P (sw_k dB x_k) = c_k (xa_k P(sw0 c1) + xb_k P(sw0 c2)), P shared by the FRFs
            v = self.sw0[:, None] * np.concatenate([c1r, c2r], axis=1)  # (2F, 2J)
            coef = np.linalg.solve(self.An, (self.aw.T @ v) / self.scale[:, None])
            pv = v - self.aw @ (coef / self.scale[:, None])  # (2F, 2J)
            ca, cb = self.c[:, None] * xa, self.c[:, None] * xb  # (K, J)
            out = pv[:, None, :J] * ca[None] + pv[:, None, J:] * cb[None]  # (2F, K, J)
            return np.asarray(-out.reshape(-1, J), dtype=float)
        # weighted changed-basis times solution, per FRF: (K, 2F, J)
        v = self.sw.T[:, :, None] * (c1r[None] * xa[:, None, :] + c2r[None] * xb[:, None, :])
        aw = self.aw
        rhs = np.matmul(aw.transpose(0, 2, 1), v) / self.scale[:, :, None]  # (K, P, J)
        coef = np.linalg.solve(self.An, rhs) / self.scale[:, :, None]
        pv = v - np.matmul(aw, coef)  # (K, 2F, J)
        return np.asarray(-pv.transpose(1, 0, 2).reshape(-1, J), dtype=float)


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
    jacobian: str = "analytic",
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
    jacobian : {"analytic", "fd"}
        Variable-projection Jacobian (Kaufman) or finite differences (the
        reference it was checked against: same poles to ~1e-7 relative,
        several times slower).

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
    proj = _Projection(F, y, w2, lower, upper)
    resid = proj.resid
    wr0 = np.abs(lam0)
    z0 = np.clip(-lam0.real / wr0, 1e-5, zeta_max * 0.999)
    fr = np.ones(n, bool) if free is None else np.asarray(free, dtype=bool).reshape(n)
    nf = int(np.count_nonzero(fr))
    if nf == 0:
        r = resid(lam0)
        c = 0.5 * float(r @ r)
        return RefineResult(lam0.astype(np.complex128), c, c, np.zeros(n, bool), True)

    lo_w, hi_w = np.log(wr0[fr]) - 1.0, np.log(wr0[fr]) + 1.0
    lo_z, hi_z = np.log(1e-6), np.log(0.999)

    def to_poles(p: NDArray[np.float64]) -> NDArray[np.complex128]:
        wr = wr0.copy()
        z = z0.copy()
        # LM steps are unbounded: clip before exp (the box is checked afterwards)
        wr[fr] = np.exp(np.clip(p[:nf], lo_w, hi_w))
        z[fr] = np.exp(np.clip(p[nf:], lo_z, hi_z))
        lam = -z * wr + 1j * wr * np.sqrt(1.0 - z**2)
        return np.asarray(np.where(fr, lam, lam0), dtype=np.complex128)

    idx_free = np.flatnonzero(fr)
    owner = np.concatenate([idx_free, idx_free])

    def jac(p: NDArray[np.float64]) -> NDArray[np.float64]:
        lam = to_poles(p)
        wr, lf = np.abs(lam[idx_free]), lam[idx_free]
        z = -lf.real / wr
        # d lam / d ln(wr) = lam; d lam / d ln(zeta) = -zeta wr (1 + i zeta / sqrt(1 - zeta^2))
        dw = lf * ((p[:nf] > lo_w) & (p[:nf] < hi_w))
        dz = -z * wr * (1 + 1j * z / np.sqrt(1 - z**2)) * ((p[nf:] > lo_z) & (p[nf:] < hi_z))
        return proj.jac(lam, owner, np.concatenate([dw, dz]))

    p0 = np.concatenate([np.log(wr0[fr]), np.log(z0[fr])])
    r0 = resid(to_poles(p0))
    cost0 = 0.5 * float(r0 @ r0)
    try:
        # Levenberg-Marquardt (MINPACK): no LAPACK SVD per step, which is slow when
        # the BLAS runs many threads on a loaded machine; bounds are checked after.
        def fun(p: NDArray[np.float64]) -> NDArray[np.float64]:
            return resid(to_poles(p))

        if jacobian not in ("analytic", "fd"):
            raise InputError(f"jacobian: expected 'analytic' or 'fd', found {jacobian!r}")
        x_scale = np.concatenate([np.full(nf, 1e-3), np.full(nf, 0.1)])
        if jacobian == "fd":
            sol = least_squares(
                fun,
                p0,
                jac="2-point",
                method="lm",
                x_scale=x_scale,
                max_nfev=max_nfev * (2 * nf + 1),
                diff_step=np.full(2 * nf, 1e-6),
            )
            x_opt, cost_opt, ok = sol.x, float(sol.cost), bool(sol.success)
        else:
            # MINPACK's lmder with least_squares(method="lm")'s settings (same iterates)
            # without its per-call wrapping, which cost more than the residuals here
            x_opt, _, info, _, ier = leastsq(
                fun,
                p0,
                Dfun=jac,
                full_output=True,
                ftol=1e-8,
                xtol=1e-8,
                gtol=1e-8,
                maxfev=max_nfev * 4,
                factor=100.0,
                diag=1.0 / x_scale,
            )
            r_opt = info["fvec"]
            cost_opt, ok = 0.5 * float(r_opt @ r_opt), ier in (1, 2, 3, 4)
    # TypeError: leastsq's 'improper input' (fewer residuals than parameters), which
    # least_squares raises as a ValueError
    except (ValueError, TypeError, np.linalg.LinAlgError):
        return RefineResult(lam0.astype(np.complex128), cost0, cost0, fr.copy(), False)
    if not np.all(np.isfinite(x_opt)) or not np.isfinite(cost_opt) or cost_opt > cost0:
        return RefineResult(lam0.astype(np.complex128), cost0, cost0, np.zeros(n, bool), False)
    x = x_opt
    drift = np.abs(x[:nf] - p0[:nf]) > np.log1p(f_bound)
    zeta_out = x[nf:] > np.log(zeta_max)
    bad = drift | zeta_out
    # poles that left their box keep their start value
    x = np.where(np.concatenate([bad, bad]), p0, x)
    at_bound = np.zeros(n, bool)
    at_bound[fr] = bad
    return RefineResult(to_poles(x), cost0, cost_opt, at_bound, ok)
