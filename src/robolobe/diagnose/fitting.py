"""Fit one candidate to all records at once; parameter uncertainty and identifiability.

The fit minimises the soft-L1 deviance of the log-ratio residual
(:mod:`robolobe.diagnose.residuals`) over the candidate's internal
coordinates with :func:`scipy.optimize.least_squares` (trust-region
reflective, bounded). Starts: the candidate's parameter grid is scanned
first (one model evaluation per grid point) and the best few grid points
are refined.

Uncertainty: with ``J`` the Jacobian of the residual in internal
coordinates at the optimum, ``s^2 = D / (N - p)`` (1 when the fit reaches
the noise, larger when misfit remains) and ``c`` the variance inflation of
correlated frequency lines (:func:`robolobe.diagnose.noise.variance_inflation`)::

    Cov_z = c s^2 (J^T J)^-1,  Cov_p = G Cov_z G,  G = diag(dp/dz)

Identifiability: the singular values of ``J`` with unit-norm columns give
the condition number (1: independent parameters; 1e3 and more: a direction
in parameter space the data cannot see) and the correlations; a parameter
whose relative standard deviation exceeds 50 % of its value (log scale) or
of its bound range (linear scale) is reported as poorly determined.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import least_squares

from robolobe.diagnose.candidate import Candidate
from robolobe.diagnose.observations import Observations
from robolobe.diagnose.residuals import F_SCALE, deviance, residual_vector
from robolobe.errors import RobolobeError

__all__ = ["CandidateFit", "ModelFn", "fit_candidate", "predict"]

log = logging.getLogger(__name__)

#: ``model(effects, obs) -> H`` with H of shape (obs.n, n_freq, 3, 3), complex, m/N.
ModelFn = Callable[[tuple[Any, ...], Observations], NDArray[np.complex128]]

COND_MAX = 1e3
REL_STD_MAX = 0.5


@dataclass(frozen=True, eq=False)
class CandidateFit:
    """Result of fitting one candidate.

    Parameters
    ----------
    candidate : Candidate
    params : ndarray, shape (p,)
        Fitted physical parameters.
    std : ndarray, shape (p,)
        Standard deviations (physical units); inf where not determined.
    corr : ndarray, shape (p, p)
        Correlation matrix of the parameters.
    deviance : float
        Soft-L1 deviance at the optimum (``chi^2`` for small residuals).
    n_resid : int
        Number of real residuals N.
    cond : float
        Condition number of the column-normalised Jacobian (1 for p <= 1).
    identifiable : bool
        Whether every parameter is determined (see module docstring).
    notes : tuple of str
        Identifiability and convergence remarks.
    at_bound : tuple of bool
        Whether each parameter ended on a bound.
    nfev : int
        Model evaluations spent.
    inflation : float
        Variance inflation of the residuals from line correlation: the
        information criteria count ``N / inflation`` independent residuals
        and ``D / inflation`` as deviance.
    """

    candidate: Candidate
    params: NDArray[np.float64]
    std: NDArray[np.float64]
    corr: NDArray[np.float64]
    deviance: float
    n_resid: int
    cond: float
    identifiable: bool
    notes: tuple[str, ...]
    at_bound: tuple[bool, ...]
    nfev: int
    inflation: float = 1.0

    @property
    def k(self) -> int:
        """Number of fitted parameters."""
        return self.candidate.n_params

    @property
    def aic(self) -> float:
        """Akaike information criterion ``D/c + 2 p`` (c: :attr:`inflation`)."""
        return self.deviance / self.inflation + 2.0 * self.k

    @property
    def bic(self) -> float:
        """Bayesian information criterion ``D/c + p ln(N/c)`` (c: :attr:`inflation`)."""
        n_eff = max(self.n_resid / self.inflation, 1.0)
        return self.deviance / self.inflation + self.k * float(np.log(n_eff))

    @property
    def z(self) -> NDArray[np.float64]:
        """Fitted internal coordinates."""
        return self.candidate.to_internal(self.params) if self.k else np.zeros(0)


def predict(
    model: ModelFn, candidate: Candidate, params: NDArray[np.float64], obs: Observations
) -> NDArray[np.complex128]:
    """Model receptance of ``obs``'s records with ``candidate`` at ``params``."""
    return np.asarray(model(candidate.effects(params) if candidate.n_params else (), obs))


class _Objective:
    """Residual function in internal coordinates, counting evaluations."""

    def __init__(self, model: ModelFn, candidate: Candidate, obs: Observations) -> None:
        self.model = model
        self.candidate = candidate
        self.obs = obs
        self.nfev = 0
        self.n_resid = 2 * int(obs.mask.sum())
        self._last: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None

    def __call__(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        self.nfev += 1
        try:
            H = predict(self.model, self.candidate, self.candidate.to_physical(z), self.obs)
        except (RobolobeError, ValueError, np.linalg.LinAlgError) as exc:
            log.debug("%s at z=%s: %s", self.candidate.label, z, exc)
            r = np.full(self.n_resid, 1e3)
        else:
            r = residual_vector(H, self.obs)
        self._last = (np.array(z, dtype=float), r)
        return r

    def at(self, z: NDArray[np.float64]) -> NDArray[np.float64]:
        """The residual at ``z``, reusing the last evaluation when it was at ``z``."""
        if self._last is not None and np.array_equal(self._last[0], z):
            return self._last[1]
        return self(z)


def _span(lo: NDArray[np.float64], hi: NDArray[np.float64]) -> NDArray[np.float64]:
    """Width of each internal coordinate's bounds (1 where unbounded)."""
    return np.where(np.isfinite(hi - lo), hi - lo, 1.0)


def _jacobian(
    obj: _Objective,
    z: NDArray[np.float64],
    r0: NDArray[np.float64],
    hi: NDArray[np.float64],
    h: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Forward-difference Jacobian of the raw residual with steps ``h`` (> 0), shape (m, p).

    A step that would cross the upper bound is taken downwards instead.
    """
    J = np.empty((r0.size, z.size))
    for i in range(z.size):
        zz = z.copy()
        zz[i] = z[i] + h[i] if z[i] + h[i] <= hi[i] else z[i] - h[i]
        J[:, i] = (obj(zz) - r0) / (zz[i] - z[i])
    return J


def _fit_steps(z: NDArray[np.float64], span: NDArray[np.float64]) -> NDArray[np.float64]:
    """Finite-difference steps of the local fit: ``1e-4 |z|``, at least ``1e-6`` of the span.

    A step relative to ``|z|`` alone (scipy's ``diff_step``) vanishes at
    ``z = 0``, which is a candidate's null value in internal coordinates (a
    delay of 0, a log factor of 1) and where the trust region's first step
    from a one-parameter grid start lands, to rounding: a step of 1e-22 gives
    a Jacobian of rounding noise, and the fit "converges" on the null
    (``gtol``) with a better optimum next to it.
    """
    return np.maximum(1e-4 * np.abs(z), 1e-6 * span)


def _uncertainty(
    cand: Candidate,
    z: NDArray[np.float64],
    J: NDArray[np.float64],
    dev: float,
    n: int,
    inflation: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], float, list[str], bool]:
    p = cand.n_params
    norms = np.linalg.norm(J, axis=0)
    notes: list[str] = []
    dead = norms <= 1e-12 * max(1.0, float(norms.max(initial=0.0)))
    if np.any(dead):
        for i in np.flatnonzero(dead):
            notes.append(f"{cand.params[i].name}: the data do not depend on it")
        std = np.full(p, np.inf)
        corr = np.eye(p)
        return std, corr, np.inf, notes, False
    Jn = J / norms
    sv = np.linalg.svd(Jn, compute_uv=False)
    cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else np.inf
    s2 = dev / max(n - p, 1)
    try:
        cov_n = np.linalg.inv(Jn.T @ Jn)
    except np.linalg.LinAlgError:
        cov_n = np.linalg.pinv(Jn.T @ Jn)
    cov_z = s2 * inflation * cov_n / np.outer(norms, norms)
    sd_z = np.sqrt(np.clip(np.diag(cov_z), 0.0, None))
    corr = cov_z / np.outer(sd_z, sd_z) if np.all(sd_z > 0) else np.eye(p)
    G = np.array([ps.dphys_dz(zi) for ps, zi in zip(cand.params, z, strict=True)])
    std = sd_z * np.abs(G)
    ok = cond < COND_MAX
    if not ok:
        notes.append(f"parameters not separable (condition number {cond:.3g})")
    for k, ps in enumerate(cand.params):
        rel = sd_z[k] if ps.scale == "log" else sd_z[k] / (ps.upper - ps.lower)
        if rel > REL_STD_MAX:
            ok = False
            notes.append(f"{ps.name}: poorly determined (relative std {rel:.2g})")
    for a in range(p):
        for b in range(a + 1, p):
            if abs(corr[a, b]) > 0.95:
                notes.append(
                    f"{cand.params[a].name} and {cand.params[b].name} "
                    f"correlated ({corr[a, b]:+.3f})"
                )
    return std, corr, cond, notes, ok


def fit_candidate(
    candidate: Candidate,
    model: ModelFn,
    obs: Observations,
    *,
    z0: NDArray[np.float64] | None = None,
    n_starts: int = 2,
    max_nfev: int = 40,
    scan_points: int = 48,
) -> CandidateFit:
    """Fit ``candidate`` to every record of ``obs`` at once.

    Parameters
    ----------
    candidate : Candidate
    model : ModelFn
        ``model(effects, obs) -> H`` (n, n_freq, 3, 3).
    obs : Observations
    z0 : ndarray, shape (p,), optional
        Warm start in internal coordinates (skips the grid scan).
    n_starts : int
        Grid points refined by the local fit.
    max_nfev : int
        Residual evaluations per local fit (scipy's count; the finite-
        difference Jacobian columns come on top).
    scan_points : int
        Most grid points scanned.

    Returns
    -------
    CandidateFit
    """
    obj = _Objective(model, candidate, obs)
    n = obj.n_resid
    p = candidate.n_params
    if p == 0:
        r = obj(np.zeros(0))
        return CandidateFit(
            candidate=candidate,
            params=np.zeros(0),
            std=np.zeros(0),
            corr=np.zeros((0, 0)),
            deviance=deviance(r),
            n_resid=n,
            cond=1.0,
            identifiable=True,
            notes=(),
            at_bound=(),
            nfev=obj.nfev,
            inflation=obs.inflation,
        )
    lo, hi = candidate.bounds_internal
    if z0 is not None:
        starts = [np.clip(np.asarray(z0, dtype=float), lo, hi)]
    else:
        grid = candidate.start_grid(scan_points)
        zs = np.array([candidate.to_internal(g) for g in grid])
        devs = np.array([deviance(obj(z)) for z in zs])
        order = np.argsort(devs)
        starts = []
        span = _span(lo, hi)
        for i in order:
            # keep starts that are apart by more than 5 % of the range in some coordinate
            if all(np.max(np.abs(zs[i] - s) / span) > 0.05 for s in starts):
                starts.append(zs[i])
            if len(starts) >= n_starts:
                break
    span = _span(lo, hi)

    def jac(z: NDArray[np.float64]) -> NDArray[np.float64]:
        # scipy evaluates the residual at z just before asking for the Jacobian there
        return _jacobian(obj, z, obj.at(z), hi, _fit_steps(z, span))

    best = None
    for s in starts:
        # keep starts strictly inside the bounds
        eps = 1e-9 * np.maximum(1.0, np.abs(hi - lo))
        x0 = np.clip(s, lo + eps, hi - eps)
        res = least_squares(
            obj,
            x0,
            bounds=(lo, hi),
            loss="soft_l1",
            f_scale=F_SCALE,
            x_scale="jac",
            jac=jac,
            max_nfev=max_nfev,
        )
        if best is None or res.cost < best.cost:
            best = res
    assert best is not None
    z = np.asarray(best.x, dtype=float)
    r0 = np.asarray(best.fun, dtype=float)
    J = _jacobian(obj, z, r0, hi, 1e-3 * np.minimum(1.0, span))
    dev = deviance(r0)
    std, corr, cond, notes, ok = _uncertainty(candidate, z, J, dev, n, obs.inflation)
    span = hi - lo
    at_bound = tuple(bool(min(z[i] - lo[i], hi[i] - z[i]) < 1e-3 * span[i]) for i in range(p))
    for i, b in enumerate(at_bound):
        if b:
            notes.append(f"{candidate.params[i].name}: on its bound")
    if best.status == 0:
        notes.append("local fit stopped at its evaluation limit")
    return CandidateFit(
        candidate=candidate,
        params=candidate.to_physical(z),
        std=std,
        corr=corr,
        deviance=dev,
        n_resid=n,
        cond=cond,
        identifiable=ok,
        notes=tuple(notes),
        at_bound=at_bound,
        nfev=obj.nfev,
        inflation=obs.inflation,
    )
