"""Simulated impact-hammer tests at the TCP, as run in the seed paper.

A modal hammer hits the tool in +x, +y and +z (TCP axes); a triaxial
accelerometer at the TCP records the response; each excitation direction is
hit ``impacts`` times and the spectra are averaged into H1, H2 and the
coherence (docs/references.md: seed paper in numbers, modal identification).
Defaults mirror the seed: 1024 Hz
sampling, 4 s records (0.25 Hz resolution), 5 impacts.

How the signals are made (no loop over frequencies)
----------------------------------------------------
The structure is given by its receptance ``H(f)`` (m/N, 3x3, TCP axes). The
hammer force of one impact is a half-sine pulse of width ``tau`` and peak
``A`` at time ``t0`` (plus an optional second hit), whose continuous Fourier
transform is known in closed form,

    P(w) = (pi/tau) (1 + exp(-i w tau)) / ((pi/tau)^2 - w^2) * exp(-i w t0).

Force and acceleration ``-w^2 H(w) F(w)`` are formed on a fine frequency grid
``k / (settle_factor * duration_s)`` (0 .. fs/2), multiplied by the
acquisition chain's anti-alias response and transformed to time with one
inverse real FFT: this is the sampled signal of a record ``settle_factor``
times longer than the measured one, in which the response has time to decay
(the periodic wrap-around of the long record is the response to an identical
impact ``settle_factor * duration_s`` earlier: ~exp(-sigma T_long), e.g.
3e-4 for a 0.2 % mode at 10 Hz with the defaults). The measured record is the
first ``duration_s`` of it, so a lightly damped response is truncated exactly
as in a real test (leakage), and sub-sample trigger jitter is exact.

Sampling a 1-3 ms pulse at 1024 Hz (2-3 samples) needs care: the pulse has
energy above fs/2. The acquisition chain is modelled as a zero-phase Gaussian
low-pass (no ringing) with gain ``antialias_nyquist_gain`` at fs/2, and all
content above fs/2 is removed (an ideal decimation stage: no aliasing). The
filter acts on both channels and cancels in H1 and H2.

Then white Gaussian noise is added to both channels, the force channel gets a
rectangular force window (zero after ``pretrigger_s + force_window_s``), both
channels get the same exponential window ``w(t) = window_end ** (t / T)``
(``T = duration_s``) and the spectra are averaged over the impacts that pass
the double-hit check. Because the exponential window satisfies
``w(t) = w(t - s) w(s)``, the windowed FRF is exactly the FRF of the structure
with every pole moved left by ``window_decay_per_s = -ln(window_end) / T``:
a pole ``lambda = sigma + i w_d`` (sigma < 0) identified from windowed data is
corrected by ``sigma_true = sigma_est - ln(window_end) / T`` (see
:func:`correct_window_damping`).

Accelerance is converted to receptance by dividing by ``-w^2``. At 0 Hz the
accelerance carries no information; the receptance there is extrapolated
from the next two bins (real part, even quadratic ``(4 H_1 - H_2) / 3``;
imaginary part 0) and the coherence is left as computed.
"""

from __future__ import annotations

import dataclasses
import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.campaign._model import WINDOW_END_MIN
from robolobe.errors import InputError

__all__ = [
    "DIRECTIONS",
    "HammerTestResult",
    "HammerTestSettings",
    "ReceptanceLike",
    "correct_window_damping",
    "detect_double_hits",
    "half_sine_spectrum",
    "simulate_hammer_test",
]

logger = logging.getLogger(__name__)

DIRECTIONS = ("x", "y", "z")
"""TCP axes in the order used by the 3x3 FRF arrays (rows: response, columns: excitation)."""

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
ReceptanceLike = Callable[[FloatArray], ArrayLike] | ArrayLike
"""A callable ``receptance(freq_hz (n,)) -> (..., n, 3, 3)`` [m/N] or such an array."""

# Postures simulated together (memory of the intermediate spectra: about
# 45 x n_fine x 16 bytes per posture, ~24 MB with the defaults).
_CHUNK = 4


@dataclass(frozen=True, kw_only=True)
class HammerTestSettings:
    """Parameters of a simulated impact-hammer test.

    Parameters
    ----------
    sample_rate_hz : float
        Sampling rate [Hz] (seed: 1024).
    duration_s : float
        Record length per impact [s] (seed: 4, i.e. 0.25 Hz resolution).
    impacts : int
        Impacts averaged per excitation direction (seed: 5).
    pulse_width_s : float
        Width of the half-sine force pulse [s] (hammer tip: ~1-3 ms).
    force_peak_n : float
        Mean peak force of an impact [N].
    force_peak_spread : float
        Relative standard deviation of the peak force between impacts.
    force_noise_n : float
        Standard deviation of the white noise on the force channel [N]
        (default 0.05 N, est.: hammer and acquisition noise).
    accel_noise_m_per_s2 : float
        Standard deviation of the white noise on each accelerometer channel
        [m/s^2] (broadband, 0..fs/2). Default 5e-4 m/s^2 (est.: a 10 mV/g
        triaxial sensor with ~0.0002 g rms resolution over 1 Hz-10 kHz,
        scaled to the 512 Hz band, plus acquisition noise).
    snr_db : float or None
        If given, replaces both absolute noise levels: each channel's noise
        standard deviation is the RMS of its clean signal over the record
        divided by ``10 ** (snr_db / 20)``.
    double_hit_probability : float
        Probability that an impact is followed by a second hit (0..1).
    double_hit_delay_s : (float, float)
        Range of the delay of the second hit [s] (uniform).
    double_hit_ratio : (float, float)
        Range of the second hit's peak relative to the first (uniform).
    double_hit_limit : float
        An impact whose second-to-first force peak ratio exceeds this is a
        double hit (docs/references.md: modal identification: ~0.002 clean, 0.01-0.03 works).
    reject_double_hits : bool
        Leave double hits out of the averages (if every impact of a direction
        is a double hit, all are kept and a warning is logged).
    pretrigger_s : float
        Time from the start of the record to the impact [s].
    force_window_s : float or None
        The force channel is set to zero from ``pretrigger_s +
        force_window_s`` on (rectangular force window); ``None``: no force
        window.
    window_end : float
        Value of the exponential window at the end of the record, in (0, 1];
        1 means no window. Applied to force and response.
    settle_factor : int
        The simulated record is this many times longer than the measured one
        (>= 1; see the module notes on wrap-around).
    antialias_nyquist_gain : float
        Gain of the Gaussian anti-alias low-pass at fs/2, in (0, 1].
    """

    sample_rate_hz: float = 1024.0
    duration_s: float = 4.0
    impacts: int = 5
    pulse_width_s: float = 0.002
    force_peak_n: float = 300.0
    force_peak_spread: float = 0.1
    force_noise_n: float = 0.05
    accel_noise_m_per_s2: float = 5e-4
    snr_db: float | None = None
    double_hit_probability: float = 0.0
    double_hit_delay_s: tuple[float, float] = (0.008, 0.04)
    double_hit_ratio: tuple[float, float] = (0.05, 0.5)
    double_hit_limit: float = 0.02
    reject_double_hits: bool = True
    pretrigger_s: float = 0.02
    force_window_s: float | None = 0.1
    window_end: float = 0.05
    settle_factor: int = 16
    antialias_nyquist_gain: float = 0.01

    def __post_init__(self) -> None:
        def bad(name: str, expected: str) -> InputError:
            return InputError(
                f"expected {expected}, found {getattr(self, name)!r}",
                source=f"HammerTestSettings.{name}",
            )

        for name in ("sample_rate_hz", "duration_s", "pulse_width_s", "force_peak_n"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
                raise bad(name, "a positive number")
        for name in ("force_peak_spread", "force_noise_n", "accel_noise_m_per_s2", "pretrigger_s"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and math.isfinite(v) and v >= 0):
                raise bad(name, "a number >= 0")
        if not (isinstance(self.impacts, int) and self.impacts >= 1):
            raise bad("impacts", "an integer >= 1")
        if not (isinstance(self.settle_factor, int) and self.settle_factor >= 1):
            raise bad("settle_factor", "an integer >= 1")
        n = self.sample_rate_hz * self.duration_s
        if abs(n - round(n)) > 1e-9 * n or round(n) < 8 or round(n) % 2:
            raise bad("duration_s", "sample_rate_hz * duration_s an even whole number >= 8")
        if not 0.0 <= self.double_hit_probability <= 1.0:
            raise bad("double_hit_probability", "a probability in [0, 1]")
        for name in ("double_hit_delay_s", "double_hit_ratio"):
            lo, hi = getattr(self, name)
            if not (0 <= lo <= hi and math.isfinite(hi)):
                raise bad(name, "a range (low, high) with 0 <= low <= high")
        if not self.double_hit_limit > 0:
            raise bad("double_hit_limit", "a positive number")
        if not WINDOW_END_MIN <= self.window_end <= 1.0:
            raise bad("window_end", f"a number in [{WINDOW_END_MIN:g}, 1]")
        if not 0.0 < self.antialias_nyquist_gain <= 1.0:
            raise bad("antialias_nyquist_gain", "a number in (0, 1]")
        if self.force_window_s is not None and not self.force_window_s > 0:
            raise bad("force_window_s", "a positive number or None")
        if self.snr_db is not None and not math.isfinite(self.snr_db):
            raise bad("snr_db", "a finite number or None")
        if self.pretrigger_s + 2 * self.pulse_width_s >= self.duration_s:
            raise bad("pretrigger_s", "pretrigger_s + 2 pulse_width_s < duration_s")

    # ------------------------------------------------------------ derived
    @property
    def n_samples(self) -> int:
        """Samples per measured record."""
        return round(self.sample_rate_hz * self.duration_s)

    @property
    def freq_hz(self) -> FloatArray:
        """Frequency grid of the results [Hz], shape (n_samples // 2 + 1,): 0..fs/2."""
        return np.fft.rfftfreq(self.n_samples, 1.0 / self.sample_rate_hz).astype(np.float64)

    @property
    def fine_freq_hz(self) -> FloatArray:
        """Grid on which the receptance is needed [Hz], step 1 / (settle_factor duration_s)."""
        n = self.n_samples * self.settle_factor
        return np.fft.rfftfreq(n, 1.0 / self.sample_rate_hz).astype(np.float64)

    @property
    def window_decay_per_s(self) -> float:
        """Decay rate the exponential window adds to every pole [1/s]: -ln(window_end) / T."""
        return -math.log(self.window_end) / self.duration_s

    def replace(self, **changes: object) -> HammerTestSettings:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class HammerTestResult:
    """FRF estimates of a simulated hammer test.

    Leading dimensions ``...`` are those of the receptance given to
    :func:`simulate_hammer_test` (e.g. postures). Rows of the 3x3 blocks are
    the response direction, columns the excitation (hit) direction, both in
    TCP axes (x, y, z); columns not excited are NaN.

    Attributes
    ----------
    freq_hz : ndarray, shape (n_freq,)
        Frequencies [Hz], 0..fs/2 in steps of 1 / duration_s.
    H1, H2 : ndarray, shape (..., n_freq, 3, 3), complex
        Receptance [m/N] from the H1 = G_FX / G_FF and H2 = G_XX / G_XF
        estimators (accelerance divided by -w^2; 0 Hz extrapolated).
    coherence : ndarray, shape (..., n_freq, 3, 3)
        Ordinary coherence H1 / H2 = |G_FX|^2 / (G_FF G_XX), in [0, 1]
        (0 where a channel carries no signal at all).
    double_hit_ratio : ndarray, shape (..., 3, impacts)
        Second-to-first force peak ratio of each impact per excitation
        direction (NaN for directions not excited).
    used : ndarray, shape (..., 3, impacts), bool
        Impacts that entered the averages.
    excited : tuple of str
        Excitation directions simulated ("x", "y", "z").
    window_end : float
        Exponential window value at the end of the record (1: no window).
    window_decay_per_s : float
        Decay rate the window added to every pole [1/s]; correct identified
        poles with :func:`correct_window_damping`.
    settings : HammerTestSettings
        The settings used.
    """

    freq_hz: FloatArray
    H1: ComplexArray
    H2: ComplexArray
    coherence: FloatArray
    double_hit_ratio: FloatArray
    used: NDArray[np.bool_]
    excited: tuple[str, ...]
    window_end: float
    window_decay_per_s: float
    settings: HammerTestSettings = field(repr=False)

    def __post_init__(self) -> None:
        for name in ("freq_hz", "H1", "H2", "coherence", "double_hit_ratio", "used"):
            getattr(self, name).setflags(write=False)

    @property
    def double_hits(self) -> NDArray[np.bool_]:
        """Impacts flagged as double hits, shape (..., 3, impacts)."""
        return np.asarray(self.double_hit_ratio > self.settings.double_hit_limit)

    @property
    def dirs(self) -> frozenset[str]:
        """Two-letter directions (response then excitation) the result holds."""
        return frozenset(r + e for r in DIRECTIONS for e in self.excited)

    def accelerance(self, estimator: Literal["H1", "H2"] = "H1") -> ComplexArray:
        """Accelerance [(m/s^2)/N] = -w^2 times the receptance, shape (..., n_freq, 3, 3)."""
        h = self.H1 if estimator == "H1" else self.H2
        w2 = (2 * np.pi * self.freq_hz) ** 2
        return np.asarray(-w2[:, None, None] * h)


def half_sine_spectrum(freq_hz: ArrayLike, width_s: float) -> ComplexArray:
    """Fourier transform of a unit half-sine pulse ``sin(pi t / width)`` on [0, width].

    Parameters
    ----------
    freq_hz : array_like
        Frequencies [Hz], any shape.
    width_s : float
        Pulse width [s].

    Returns
    -------
    ndarray, complex, same shape as ``freq_hz``
        ``P(w) = a (1 + exp(-i w width)) / (a^2 - w^2)``, ``a = pi / width``
        [N s per N of peak]; ``P(0) = 2 width / pi``, ``P(a) = -i width / 2``.
    """
    w = 2 * np.pi * np.asarray(freq_hz, dtype=float)
    a = np.pi / width_s
    den = a * a - w * w
    near = np.abs(den) < 1e-9 * a * a
    safe = np.where(near, 1.0, den)
    p = a * (1 + np.exp(-1j * w * width_s)) / safe
    return np.asarray(np.where(near, -0.5j * width_s, p), dtype=complex)


def correct_window_damping(
    f_hz: ArrayLike, zeta: ArrayLike, decay_per_s: float
) -> tuple[FloatArray, FloatArray]:
    """Remove the exponential window's damping from identified modes.

    A pole ``lambda = -zeta w + i w sqrt(1 - zeta^2)`` identified from
    windowed data has its real part shifted by ``-decay_per_s``; the true
    pole keeps the damped frequency and has ``sigma_true = sigma_est +
    decay_per_s`` (``= sigma_est - ln(window_end) / T``, docs/references.md
    section 4; ``sigma`` the negative real part).

    Parameters
    ----------
    f_hz : array_like
        Identified undamped natural frequencies [Hz].
    zeta : array_like
        Identified damping ratios (fractions), same shape.
    decay_per_s : float
        ``HammerTestResult.window_decay_per_s`` [1/s].

    Returns
    -------
    f_hz, zeta : ndarray
        Corrected natural frequencies [Hz] and damping ratios. A damping that
        would become negative is returned as is at 0 (the window dominated).
    """
    f = np.asarray(f_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    wn = 2 * np.pi * f
    decay_est = z * wn
    wd = wn * np.sqrt(np.clip(1 - z * z, 0.0, None))
    decay = np.clip(decay_est - decay_per_s, 0.0, None)
    wn_true = np.sqrt(wd * wd + decay * decay)
    with np.errstate(invalid="ignore", divide="ignore"):
        z_true = np.where(wn_true > 0, decay / wn_true, 0.0)
    return wn_true / (2 * np.pi), z_true


def detect_double_hits(
    force: ArrayLike, *, sample_rate_hz: float, pulse_width_s: float, search_s: float | None = None
) -> FloatArray:
    """Second-to-first force peak ratio of impact records.

    The main peak is the largest force sample; the second is the largest
    sample outside ``ceil(pulse_width * fs) + 2`` samples either side of it
    (the pulse itself and the anti-alias spread), before the main peak or up
    to ``search_s`` after it.

    Parameters
    ----------
    force : array_like, shape (..., n_samples)
        Force records [N] (unwindowed).
    sample_rate_hz : float
        Sampling rate [Hz].
    pulse_width_s : float
        Nominal pulse width [s].
    search_s : float, optional
        How far after the main peak to look [s] (default: whole record).

    Returns
    -------
    ndarray, shape (...)
        Ratio (0 for an isolated pulse without noise).
    """
    f = np.asarray(force, dtype=float)
    n = f.shape[-1]
    idx = np.arange(n)
    n0 = np.argmax(f, axis=-1)[..., None]
    first = np.take_along_axis(f, n0, axis=-1)[..., 0]
    guard = math.ceil(pulse_width_s * sample_rate_hz) + 2
    far = np.abs(idx - n0) > guard
    if search_s is not None:
        far &= idx - n0 <= search_s * sample_rate_hz
    second = np.max(np.where(far, f, -np.inf), axis=-1)
    second = np.where(np.isfinite(second), np.clip(second, 0.0, None), 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(np.where(first > 0, second / first, np.inf))


def _receptance_on_grid(receptance: ReceptanceLike, fine: FloatArray) -> ComplexArray:
    h = receptance(fine) if callable(receptance) else receptance
    arr = np.asarray(h)
    if arr.ndim < 3 or arr.shape[-3:] != (fine.size, 3, 3):
        raise InputError(
            f"expected a receptance of shape (..., {fine.size}, 3, 3) on the fine grid "
            f"(HammerTestSettings.fine_freq_hz), found shape {arr.shape}",
            source="simulate_hammer_test(receptance)",
        )
    if not np.all(np.isfinite(arr)):
        raise InputError(
            "expected finite receptance values, found NaN or inf",
            source="simulate_hammer_test(receptance)",
        )
    return np.asarray(arr, dtype=complex)


def _parse_excite(excite: str | Sequence[str]) -> tuple[int, ...]:
    letters = tuple(excite)
    if (
        not letters
        or any(c not in DIRECTIONS for c in letters)
        or len(set(letters)) != len(letters)
    ):
        raise InputError(
            f"expected distinct excitation directions from x, y, z, found {excite!r}",
            source="simulate_hammer_test(excite)",
        )
    return tuple(sorted(DIRECTIONS.index(c) for c in letters))


def simulate_hammer_test(
    receptance: ReceptanceLike,
    *,
    rng: np.random.Generator,
    settings: HammerTestSettings | None = None,
    excite: str | Sequence[str] = "xyz",
) -> HammerTestResult:
    """Simulate an impact-hammer test on a structure with a known receptance.

    Parameters
    ----------
    receptance : callable or array_like
        ``receptance(freq_hz) -> (..., n_fine, 3, 3)`` complex receptance
        [m/N] in TCP axes (rows response, columns excitation), called once
        with ``settings.fine_freq_hz`` (shape (n_fine,)); or that array
        itself. Leading dimensions (e.g. postures) are simulated together
        (memory ~ 144 bytes x n_fine per posture for the input).
    rng : numpy.random.Generator
        Source of all randomness (force levels, jitter, double hits, noise).
        One child generator is spawned per leading index, so a posture's
        result does not depend on which others are simulated with it.
    settings : HammerTestSettings, optional
        Test parameters (default: the seed's test).
    excite : str or sequence of str
        Directions hit, subset of "xyz" (each gives a column of the FRF).

    Returns
    -------
    HammerTestResult
        H1, H2 and coherence on ``settings.freq_hz``.
    """
    s = settings if settings is not None else HammerTestSettings()
    if not isinstance(rng, np.random.Generator):
        raise InputError(
            f"expected a numpy.random.Generator, found {type(rng).__name__}",
            source="simulate_hammer_test(rng)",
        )
    cols = _parse_excite(excite)
    fine = s.fine_freq_hz
    h = _receptance_on_grid(receptance, fine)
    batch_shape = h.shape[:-3]
    h = h.reshape((-1, fine.size, 3, 3))
    n_post = h.shape[0]
    children = rng.spawn(n_post)

    n_freq = s.n_samples // 2 + 1
    h1 = np.full((n_post, n_freq, 3, 3), np.nan + 0j)
    h2 = np.full((n_post, n_freq, 3, 3), np.nan + 0j)
    coh = np.full((n_post, n_freq, 3, 3), np.nan)
    ratio = np.full((n_post, 3, s.impacts), np.nan)
    used = np.zeros((n_post, 3, s.impacts), dtype=bool)
    for start in range(0, n_post, _CHUNK):
        stop = min(start + _CHUNK, n_post)
        out = _simulate_chunk(h[start:stop][..., list(cols)], children[start:stop], s)
        c = list(cols)
        h1[start:stop, :, :, c] = out[0]
        h2[start:stop, :, :, c] = out[1]
        coh[start:stop, :, :, c] = out[2]
        ratio[start:stop, c] = out[3]
        used[start:stop, c] = out[4]

    shape = (*batch_shape, n_freq, 3, 3)
    return HammerTestResult(
        freq_hz=s.freq_hz,
        H1=h1.reshape(shape),
        H2=h2.reshape(shape),
        coherence=coh.reshape(shape),
        double_hit_ratio=ratio.reshape((*batch_shape, 3, s.impacts)),
        used=used.reshape((*batch_shape, 3, s.impacts)),
        excited=tuple(DIRECTIONS[c] for c in cols),
        window_end=float(s.window_end),
        window_decay_per_s=s.window_decay_per_s,
        settings=s,
    )


def _simulate_chunk(
    h: ComplexArray, rngs: Sequence[np.random.Generator], s: HammerTestSettings
) -> tuple[ComplexArray, ComplexArray, FloatArray, FloatArray, NDArray[np.bool_]]:
    """Simulate postures ``h`` (P, n_fine, 3, E) -> H1, H2, coh (P, n_freq, 3, E), ratio, used."""
    n_p, _, _, n_e = h.shape
    n_i = s.impacts
    fs = s.sample_rate_hz
    n = s.n_samples
    n_long = n * s.settle_factor
    fine = s.fine_freq_hz
    w = 2 * np.pi * fine

    # Random draws, per posture from its own generator (order fixed).
    amp = np.empty((n_p, n_e, n_i))
    t0 = np.empty((n_p, n_e, n_i))
    second = np.zeros((n_p, n_e, n_i))
    delay = np.zeros((n_p, n_e, n_i))
    for p, g in enumerate(rngs):
        amp[p] = s.force_peak_n * np.clip(
            1 + s.force_peak_spread * g.standard_normal((n_e, n_i)), 0.2, None
        )
        t0[p] = s.pretrigger_s + g.uniform(0.0, 1.0 / fs, (n_e, n_i))
        hit2 = g.random((n_e, n_i)) < s.double_hit_probability
        second[p] = np.where(hit2, g.uniform(*s.double_hit_ratio, (n_e, n_i)), 0.0)
        delay[p] = g.uniform(*s.double_hit_delay_s, (n_e, n_i))

    # Force spectra on the fine grid, (P, E, I, n_fine), filtered.
    sigma_aa = (fs / 2) / math.sqrt(-2 * math.log(s.antialias_nyquist_gain))
    gain = np.exp(-0.5 * (fine / sigma_aa) ** 2)
    pulse = half_sine_spectrum(fine, s.pulse_width_s) * gain
    shift = np.exp(-1j * w * t0[..., None]) * (
        1 + second[..., None] * np.exp(-1j * w * delay[..., None])
    )
    force_spec = amp[..., None] * pulse * shift
    # Acceleration spectra (P, E, I, 3, n_fine): -w^2 H[:, :, r, e] F_e.
    acc_gain = -(w * w) * np.moveaxis(h, 1, -1)  # (P, 3, E, n_fine)
    acc_spec = np.moveaxis(acc_gain, 1, 2)[:, :, None] * force_spec[:, :, :, None, :]

    force = np.fft.irfft(force_spec, n=n_long, axis=-1)[..., :n] * fs
    acc = np.fft.irfft(acc_spec, n=n_long, axis=-1)[..., :n] * fs
    del acc_spec, force_spec

    # Noise.
    if s.snr_db is not None:
        scale = 10 ** (s.snr_db / 20)
        f_std = np.sqrt(np.mean(force**2, axis=-1)) / scale
        a_std = np.sqrt(np.mean(acc**2, axis=-1)) / scale
    else:
        f_std = np.full(force.shape[:-1], s.force_noise_n)
        a_std = np.full(acc.shape[:-1], s.accel_noise_m_per_s2)
    for p, g in enumerate(rngs):
        force[p] += f_std[p][..., None] * g.standard_normal(force.shape[1:])
        acc[p] += a_std[p][..., None] * g.standard_normal(acc.shape[1:])

    # Double hits on the raw force.
    ratio = detect_double_hits(
        force, sample_rate_hz=fs, pulse_width_s=s.pulse_width_s, search_s=s.force_window_s
    )
    flagged = np.asarray(ratio > s.double_hit_limit)
    used = ~flagged if s.reject_double_hits else np.ones_like(flagged)
    none_left = np.asarray(~used.any(axis=-1))
    if none_left.any():
        logger.warning(
            "every impact of %d excitation(s) is a double hit; averaging them anyway",
            int(none_left.sum()),
        )
        used = np.asarray(used | none_left[..., None])

    # Windows.
    t = np.arange(n) / fs
    expw = s.window_end ** (t / s.duration_s)
    fwin = expw.copy()
    if s.force_window_s is not None:
        fwin[t > s.pretrigger_s + s.force_window_s] = 0.0
    fspec = np.fft.rfft(force * fwin, axis=-1)  # (P, E, I, n_freq)
    xspec = np.fft.rfft(acc * expw, axis=-1)  # (P, E, I, 3, n_freq)

    u = used[..., None].astype(float)
    g_ff = np.sum(u * np.abs(fspec) ** 2, axis=2)  # (P, E, F)
    g_fx = np.sum(u[..., None, :] * np.conj(fspec)[:, :, :, None, :] * xspec, axis=2)  # (P,E,3,F)
    g_xx = np.sum(u[..., None, :] * np.abs(xspec) ** 2, axis=2)
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = np.where(g_ff[:, :, None] > 0, g_fx / g_ff[:, :, None], 0.0)
        a2 = np.where(np.abs(g_fx) > 0, g_xx / np.conj(g_fx), a1)
        den = g_ff[:, :, None] * g_xx
        coh = np.where(den > 0, np.abs(g_fx) ** 2 / den, 0.0)
    # (P, E, 3, F) -> (P, F, 3, E)
    a1 = np.moveaxis(a1, (1, 2, 3), (3, 2, 1))
    a2 = np.moveaxis(a2, (1, 2, 3), (3, 2, 1))
    coh = np.clip(np.moveaxis(coh, (1, 2, 3), (3, 2, 1)), 0.0, 1.0)
    return _to_receptance(a1, s), _to_receptance(a2, s), coh, ratio, used


def _to_receptance(acc: ComplexArray, s: HammerTestSettings) -> ComplexArray:
    """Accelerance (P, F, 3, E) -> receptance; 0 Hz extrapolated from bins 1 and 2."""
    w = 2 * np.pi * s.freq_hz
    out = np.empty_like(acc)
    out[:, 1:] = acc[:, 1:] / -(w[1:, None, None] ** 2)
    out[:, 0] = ((4 * out[:, 1] - out[:, 2]) / 3).real
    return out
