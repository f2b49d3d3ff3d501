"""The residual the diagnosis minimises, and the fit metrics it reports.

Residual (decided here, used by every fit and score)::

    r = log(H_model / H_meas) / sigma          (complex, per measured point)

split into its real part (log-magnitude ratio: absolute level included) and
imaginary part (phase difference, wrapped to (-pi, pi]), each scaled by the
noise of ``log H_meas`` (:mod:`robolobe.diagnose.noise`). Why this form:

- the robot's FRFs span decades between peaks, anti-resonances and cross
  directions; a log ratio weighs every line by its relative error, and the
  noise scale then says how much each line can be trusted;
- the absolute level is kept (added mass and stiffness change it, a delay
  or a rotated sensor does not), so the nominal model's level error counts;
  a uniform level offset in one direction (sensor sensitivity) is reported
  by the mismatch map and is not a candidate;
- a frequency shift of a peak gives a bounded residual (a complex
  difference grows with the peak height and makes fits start-dependent).

Where the recording is dominated by its noise (relative noise ``sigma``
above :data:`NOISY_SIGMA`: cross FRFs far above the modes, deep
anti-resonances, the anti-aliasing roll-off) the log is the wrong scale: the
measured value is the noise itself, and a model whose true value lies 100x
below it would miss by ``log(100) / sigma`` ~ 5-9 noise deviations however
right it is. There the residual is the linear relative difference
``(H_model / H_meas - 1) / sigma`` (equal to the log form to first order
where both are small, so the switch is continuous in the region that
matters): a model below the noise misses by ~``1 / sigma`` (about one noise
deviation), a model *above* the recorded level still misses by its full
excess. Which points are noisy is decided by the data alone.

Fits use a soft-L1 loss with scale ``F_SCALE`` (quadratic for residuals of a
few noise deviations, linear beyond), so a model zero that sits a line
away from the measured anti-resonance does not dominate a fit. The
*deviance* ``D = sum f^2 rho((r/f)^2)`` equals ``chi^2`` for small residuals;
information criteria use ``D`` as ``-2 log L``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robolobe._directions import DRIVING, dir_index
from robolobe.campaign.metrics import frac, nrmse
from robolobe.diagnose.observations import Observations
from robolobe.errors import InputError

__all__ = [
    "F_SCALE",
    "FitMetrics",
    "deviance",
    "deviance_per_record",
    "fit_metrics",
    "log_ratio",
    "noise_nrmse",
    "residual_vector",
]

#: Scale of the soft-L1 loss, in noise deviations.
F_SCALE = 3.0
#: Bound on |log ratio| (a model FRF of zero or inf would give inf).
_LOG_CAP = 20.0
#: Relative noise above which a point counts as noise-dominated (linear residual).
NOISY_SIGMA = 0.25


def _capped(x: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x`` clipped to +-cap, NaN to +cap (``fmin`` takes the number where one is NaN)."""
    return np.fmax(np.fmin(x, _LOG_CAP), -_LOG_CAP)


def _ratio_residual(
    ratio: NDArray[np.complex128], noisy: NDArray[np.bool_]
) -> NDArray[np.complex128]:
    """``log(ratio)`` (real part capped), or ``ratio - 1`` where ``noisy`` (module notes).

    NaN gives the cap (and a phase of pi), +-inf the +-cap. The log is taken
    as ``log|z| + i atan2(Im z, Re z)``: numpy's complex log to rounding, at a
    fraction of its cost (it was most of a fit's cost); both forms are cheap
    enough to compute everywhere and pick from.
    """
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        log_mag = _capped(np.log(np.abs(ratio)))
        # the phase of a log lies in [-pi, pi]; only NaN is replaced (by pi)
        phase = np.fmin(np.arctan2(ratio.imag, ratio.real), np.pi)
        lin = ratio - 1.0
    re = np.where(noisy, _capped(lin.real), log_mag)
    im = np.where(noisy, _capped(lin.imag), phase)
    out = np.empty(ratio.shape, dtype=complex)
    out.real = re
    out.imag = im
    return out


def log_ratio(H_model: NDArray[np.complexfloating], obs: Observations) -> NDArray[np.complex128]:
    """``log(H_model / H_meas)`` on measured points, NaN elsewhere.

    On noise-dominated points (``sigma > NOISY_SIGMA``) the linear relative
    difference ``H_model / H_meas - 1`` instead (module notes).

    Parameters
    ----------
    H_model : ndarray of complex, shape (n, n_freq, 3, 3)
        Model receptance of the records of ``obs``.
    obs : Observations

    Returns
    -------
    ndarray of complex, shape (n, n_freq, 3, 3)
        Real part clipped to +-20; non-finite model values give the cap.
    """
    Hp = np.asarray(H_model, dtype=complex)
    if Hp.shape != obs.H.shape:
        raise InputError(f"H_model: expected shape {obs.H.shape}, found {Hp.shape}")
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        out = _ratio_residual(Hp / obs.H, np.nan_to_num(obs.sigma) > NOISY_SIGMA)
    return np.where(obs.mask, out, np.nan + 0j)


def residual_vector(H_model: NDArray[np.complexfloating], obs: Observations) -> NDArray[np.float64]:
    """Normalised residuals of all measured points, flattened.

    Parameters
    ----------
    H_model : ndarray of complex, shape (n, n_freq, 3, 3)
    obs : Observations

    Returns
    -------
    ndarray, shape (2 m,)
        Real parts then imaginary parts of ``log(H_model/H_meas)/sigma`` (the
        linear form on noise-dominated points, :func:`log_ratio`) over
        the ``m`` measured points (order of ``obs.H_measured``).
    """
    Hp = np.asarray(H_model)
    if Hp.shape != obs.H.shape:
        raise InputError(f"H_model: expected shape {obs.H.shape}, found {Hp.shape}")
    w = obs.inv_sigma_measured
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        lr = _ratio_residual(Hp[obs.mask] / obs.H_measured, w < 1.0 / NOISY_SIGMA)
    return np.concatenate([lr.real * w, lr.imag * w])


def _rho(r: NDArray[np.float64]) -> NDArray[np.float64]:
    """Soft-L1 deviance contribution of normalised residuals ``r``."""
    z = (r / F_SCALE) ** 2
    return np.asarray(F_SCALE**2 * 2.0 * (np.sqrt(1.0 + z) - 1.0))


def deviance(r: NDArray[np.float64]) -> float:
    """Deviance ``sum f^2 rho((r/f)^2)`` of a residual vector (``chi^2`` for small r)."""
    return float(np.sum(_rho(np.asarray(r, dtype=float))))


def deviance_per_record(
    H_model: NDArray[np.complexfloating], obs: Observations
) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Deviance and number of real residuals of each record.

    Returns
    -------
    dev : ndarray, shape (n,)
    count : ndarray of int, shape (n,)
    """
    with np.errstate(invalid="ignore"):
        z = log_ratio(H_model, obs) / obs.sigma
    contrib = np.where(obs.mask, _rho(np.nan_to_num(z.real)) + _rho(np.nan_to_num(z.imag)), 0.0)
    dev = contrib.sum(axis=(1, 2, 3))
    count = 2 * obs.mask.sum(axis=(1, 2, 3))
    return np.asarray(dev), np.asarray(count, dtype=np.int64)


@dataclass(frozen=True)
class FitMetrics:
    """FRAC and NRMSE of model against measurement, per record.

    Computed over the analysis band on the driving-point directions that were
    measured (cross directions are too noisy for FRAC to reach its ceiling),
    then averaged over directions.

    Parameters
    ----------
    frac : ndarray, shape (n,)
        Mean FRAC of each record.
    nrmse : ndarray, shape (n,)
        Mean NRMSE of each record.
    """

    frac: NDArray[np.float64]
    nrmse: NDArray[np.float64]

    @property
    def frac_mean(self) -> float:
        """Mean FRAC over records."""
        return float(np.nanmean(self.frac))

    @property
    def frac_min(self) -> float:
        """Smallest FRAC over records."""
        return float(np.nanmin(self.frac))

    @property
    def nrmse_mean(self) -> float:
        """Mean NRMSE over records."""
        return float(np.nanmean(self.nrmse))


def fit_metrics(H_model: NDArray[np.complexfloating], obs: Observations) -> FitMetrics:
    """FRAC and NRMSE (seed eqs. 5, 6) per record on the driving points.

    Parameters
    ----------
    H_model : ndarray of complex, shape (n, n_freq, 3, 3)
    obs : Observations

    Returns
    -------
    FitMetrics
    """
    Hp = np.asarray(H_model, dtype=complex)
    fr = np.full((obs.n, 3), np.nan)
    nr = np.full((obs.n, 3), np.nan)
    for k, d in enumerate(DRIVING):
        i, j = dir_index(d)
        m = obs.mask[:, :, i, j]
        ok = m.any(axis=1)
        if not ok.any():
            continue
        hm = np.where(m, obs.H[:, :, i, j], 0.0)
        hp = np.where(m, Hp[:, :, i, j], 0.0)
        hp = np.nan_to_num(hp)
        fr[ok, k] = frac(hp[ok], hm[ok], axis=1)
        nr[ok, k] = nrmse(hp[ok], hm[ok], axis=1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # records without driving points
        return FitMetrics(frac=np.nanmean(fr, axis=1), nrmse=np.nanmean(nr, axis=1))


def noise_nrmse(obs: Observations) -> NDArray[np.float64]:
    """NRMSE that the noise alone gives, per record (the scale of :func:`fit_metrics`).

    A model equal to the true FRF misses each measured line by its noise,
    ``|H| sigma`` in magnitude, so its expected NRMSE on a driving point is
    ``sqrt(sum sigma^2 |H|^2 / sum |H|^2)``; averaged over the measured
    driving points like :func:`fit_metrics`.

    Returns
    -------
    ndarray, shape (n,)
    """
    out = np.full((obs.n, 3), np.nan)
    for k, d in enumerate(DRIVING):
        i, j = dir_index(d)
        m = obs.mask[:, :, i, j]
        ok = m.any(axis=1)
        if not ok.any():
            continue
        a2 = np.where(m, np.abs(np.nan_to_num(obs.H[:, :, i, j])) ** 2, 0.0)
        s2 = np.where(m, np.nan_to_num(obs.sigma[:, :, i, j]) ** 2, 0.0)
        den = a2.sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[ok, k] = np.sqrt((s2 * a2).sum(axis=1)[ok] / den[ok])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.asarray(np.nanmean(out, axis=1))
