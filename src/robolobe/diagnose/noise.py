"""Noise scale of measured FRFs, in the units of the diagnosis residual.

The diagnosis compares model and data through ``log(H_model / H_meas)``
(:mod:`robolobe.diagnose.residuals`). Its noise is the noise of ``log H_meas``:
for an FRF estimate with relative random error ``e`` the real part
(log-magnitude) and the imaginary part (phase, rad) each have a standard
deviation of about ``e``. Two estimates are offered:

- from the ordinary coherence ``g2`` of ``n_avg`` averaged impacts (Bendat &
  Piersol, normalized random error of an FRF magnitude estimate)::

      e = sqrt((1 - g2) / (2 n_avg g2))

- from the roughness of the FRF along frequency, when no coherence is
  recorded: the second difference ``d2_i = log(H_{i-1}/H_i) + log(H_{i+1}/H_i)``
  of white log-noise with per-part deviation ``s`` is complex normal with
  per-part variance ``6 s^2``, so ``median |d2| = sqrt(6) sqrt(2 ln 2) s``.
  A running median over a few hertz follows the noise as it changes with
  frequency (low coherence at anti-resonances and at low frequency) and
  ignores the few lines of curvature at sharp peaks. An exponential window
  ``exp(-a t)`` correlates neighbouring lines (spacing ``df``): white noise
  gets the line correlation ``rho_m = 2a / (2a + 2 pi i m df)`` (0.48 + 0.50i
  at lag 1 for a 4 s record windowed to 5 %), which shrinks the second
  difference to ``(6 - 8 Re rho_1 + 2 Re rho_2) s^2``; the estimate is
  corrected for it.

The FRF's own curvature at sharp, closely spaced resonances also makes
second differences: on robot D of the independent study
(``studies/diagnose_independent.py``; 4.3-28 Hz modes at 0.25 Hz lines) the
second-difference estimate at 10-30 Hz was 12x the true noise of the
driving points (0.0235 against 0.0020), and a model error 2-3x the true noise
passed as "within the noise". A fourth difference (weights 1 -4 6 -4 1,
``V = 70`` for white lines, :func:`difference_variance` with the window's
correlation) sees far less curvature (0.0038 there) but misses smooth,
line-correlated measurement error (at 1-10 Hz it gave 0.42x the true noise
where the second difference gave 1.0x). The estimate is the second
difference's, bounded by ``curvature_guard`` (3) times the fourth's: the
bound acts only where the two disagree by more than correlated noise makes
them (2.3-2.6x at 1-10 Hz), i.e. where the curvature dominates.

Both are bounded below by ``floor``, a model-form tolerance: differences
under about 1 % in magnitude (0.6 deg in phase) are treated as noise whatever
the test's signal-to-noise ratio; and above by ``cap`` (a point whose noise
exceeds 100 % carries almost no information).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = [
    "coherence_sigma",
    "difference_variance",
    "line_correlation_factor",
    "roughness_sigma",
    "variance_inflation",
]


def coherence_sigma(
    coherence: ArrayLike, n_avg: int, *, floor: float = 0.01, cap: float = 1.0
) -> NDArray[np.float64]:
    """Log-noise scale from the ordinary coherence.

    Parameters
    ----------
    coherence : array_like, any shape
        Ordinary coherence ``g2`` in (0, 1]; NaN where absent.
    n_avg : int
        Number of averaged impacts (>= 1).
    floor, cap : float
        Bounds of the result (dimensionless).

    Returns
    -------
    ndarray, same shape
        Standard deviation of the real and of the imaginary part of ``log H``.
    """
    if n_avg < 1:
        raise InputError(f"n_avg: expected >= 1, found {n_avg}")
    g2 = np.clip(np.asarray(coherence, dtype=float), 1e-6, 1.0)
    e = np.sqrt((1.0 - g2) / (2.0 * n_avg * g2))
    return np.asarray(np.clip(e, floor, cap))


def line_correlation_factor(df_hz: float, window_decay_per_s: float) -> float:
    """Ratio of the true noise deviation to the one second differences see.

    Parameters
    ----------
    df_hz : float
        Line spacing [Hz].
    window_decay_per_s : float
        Exponential-window decay rate [1/s] (0: uncorrelated lines, factor 1).

    Returns
    -------
    float
        ``sqrt(6 / (6 - 8 Re rho_1 + 2 Re rho_2))``.
    """
    a = float(window_decay_per_s)
    if a <= 0:
        return 1.0
    rho = [2 * a / (2 * a + 2j * np.pi * m * df_hz) for m in (1, 2)]
    return float(np.sqrt(6.0 / (6.0 - 8.0 * rho[0].real + 2.0 * rho[1].real)))


def variance_inflation(df_hz: float, window_decay_per_s: float) -> float:
    """How much line correlation inflates the variance of a fitted parameter.

    With ``Re rho_m = b^2 / (b^2 + m^2)``, ``b = a / (pi df)``::

        1 + 2 sum_{m>=1} Re rho_m = pi b coth(pi b)

    (3.0 for a 4 s record windowed to 5 % at 0.25 Hz lines; 1 without a
    window). Parameter standard deviations are multiplied by its square root
    and information criteria count ``N / inflation`` independent residuals.

    Parameters
    ----------
    df_hz : float
        Line spacing [Hz].
    window_decay_per_s : float
        Exponential-window decay rate [1/s].
    """
    b = float(window_decay_per_s) / (np.pi * df_hz)
    if b <= 1e-9:
        return 1.0
    x = np.pi * b
    return float(x / np.tanh(x))


def difference_variance(order: int, df_hz: float, window_decay_per_s: float) -> float:
    """Variance of an ``order``-th difference of log-noise, per unit per-part variance / 2.

    ``E|d|^2 = 2 s^2 V`` with ``V = sum_mn c_m c_n Re rho_|m-n|`` (``c`` the
    binomial difference weights, ``rho`` the exponential window's line
    correlation, ``rho_0 = 1``): 6 for a white second difference, 70 for a
    white fourth.

    Parameters
    ----------
    order : int
        Difference order (>= 1).
    df_hz : float
        Line spacing [Hz].
    window_decay_per_s : float
        Exponential-window decay rate [1/s] (0: uncorrelated lines).
    """
    c = np.array([(-1) ** k * math.comb(order, k) for k in range(order + 1)], dtype=float)
    a = float(window_decay_per_s)
    lag = np.abs(np.subtract.outer(np.arange(order + 1), np.arange(order + 1)))
    rho = (2 * a / (2 * a + 2j * np.pi * lag * df_hz)).real if a > 0 else (lag == 0).astype(float)
    return float(c @ rho @ c)


def _difference_scale(
    f: NDArray[np.float64], Hm: NDArray[np.complex128], order: int, half: int, decay: float
) -> NDArray[np.float64]:
    """Running median of ``|order-th difference of log H|`` as a per-part noise deviation."""
    ax = Hm.ndim - 3
    n = f.size
    mid = order // 2
    c = [(-1) ** k * math.comb(order, k) for k in range(order + 1)]
    with np.errstate(divide="ignore", invalid="ignore"):
        ref = np.take(Hm, np.arange(mid, n - order + mid), axis=ax)
        d = sum(
            ck * np.log(np.take(Hm, np.arange(k, n - order + k), axis=ax) / ref)
            for k, ck in enumerate(c)
            if k != mid
        )
        d = np.abs(d)
    d = np.where(np.isfinite(d), d, np.nan)
    # edge lines take their neighbour's value
    first = np.repeat(np.take(d, [0], axis=ax), mid, axis=ax)
    last = np.repeat(np.take(d, [-1], axis=ax), order - mid, axis=ax)
    d = np.concatenate([first, d, last], axis=ax)
    pad = [(0, 0)] * d.ndim
    pad[ax] = (half, half)
    # NaN padding: windows at the band's ends take the median of the lines they hold
    # (edge padding let one line's value stand for half a window there)
    padded = np.pad(d, pad, mode="constant", constant_values=np.nan)
    win = np.lib.stride_tricks.sliding_window_view(padded, 2 * half + 1, axis=ax)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows (absent dirs)
        med = np.nanmedian(win, axis=-1)
    df = float(np.median(np.diff(f)))
    v = difference_variance(order, df, decay)
    return np.asarray(med / (np.sqrt(v) * np.sqrt(2.0 * np.log(2.0))))


def roughness_sigma(
    freq_hz: ArrayLike,
    H: ArrayLike,
    *,
    window_hz: float = 3.0,
    window_decay_per_s: float = 0.0,
    floor: float = 0.01,
    cap: float = 1.0,
    curvature_guard: float = 3.0,
) -> NDArray[np.float64]:
    """Log-noise scale from the roughness of measured FRFs along frequency.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequency grid [Hz], uniform or nearly so.
    H : array_like of complex, shape (..., n_freq, 3, 3)
        Measured receptance; NaN where absent.
    window_hz : float
        Width of the running median [Hz].
    window_decay_per_s : float
        Decay rate ``a`` of the exponential window of the test [1/s] (0: none).
    floor, cap : float
        Bounds of the result (dimensionless).
    curvature_guard : float
        The second-difference estimate is bounded by this multiple of the
        fourth-difference one (module notes; 0: no bound).

    Returns
    -------
    ndarray, shape of ``H``
        Standard deviation of the real and of the imaginary part of
        ``log H``; NaN where ``H`` is absent.
    """
    f = np.asarray(freq_hz, dtype=float)
    Hm = np.asarray(H, dtype=complex)
    if Hm.ndim < 3 or Hm.shape[-3] != f.size:
        raise InputError(f"H: expected shape (..., {f.size}, 3, 3), found {Hm.shape}")
    if f.size < 5:
        raise InputError(f"freq_hz: expected at least 5 lines, found {f.size}")
    df = float(np.median(np.diff(f)))
    half = max(2, round(0.5 * window_hz / df))
    s = _difference_scale(f, Hm, 2, half, window_decay_per_s)
    if curvature_guard > 0 and f.size >= 7:
        s4 = _difference_scale(f, Hm, 4, half, window_decay_per_s)
        s = np.where(np.isfinite(s4), np.minimum(s, curvature_guard * s4), s)
    s = np.clip(s, floor, cap)
    return np.asarray(np.where(np.isfinite(Hm), s, np.nan))
