"""Where the nominal model and the recordings disagree.

Everything here works on generic arrays: the recordings
(:class:`~robolobe.diagnose.observations.Observations`) and the nominal
model's receptance of the same records. The mismatch score of a point is
the squared log-ratio residual per real part::

    s = (Re(r)^2 + Im(r)^2) / 2,   r = log(H_nom / H_meas) / sigma

so ``s`` is about 1 where the model fits within the noise. The map is ``s``
averaged over the measured directions, per record and frequency line.

Signatures (docs/references.md: missing physics) summarised per direction:

- level offset: the median log-magnitude ratio (a uniform offset points to a
  sensitivity or mass/stiffness scale error);
- phase trend: the slope of the phase difference against angular frequency,
  a pure delay ``tau`` gives ``Im log(H_nom/H_meas) = +w tau``;
- cross-direction content: the energy of the off-diagonal FRFs relative to
  the driving points, measured against nominal (a rotated sensor or
  coupling adds it);
- per-band scores: the mean score per direction in bands of a few hertz.

Per-mode tables pair the nominal modes of each posture with the modes seen
in the recordings (:func:`pair_modes`).
"""

from __future__ import annotations

import itertools
import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robolobe._directions import ALL_DIRS, dir_index
from robolobe._matching import match_modes
from robolobe.diagnose.observations import Observations
from robolobe.diagnose.residuals import log_ratio

__all__ = [
    "BandScore",
    "DirectionSignature",
    "MismatchMap",
    "ModePair",
    "mismatch_map",
    "pair_modes",
]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class DirectionSignature:
    """Summary signature of one measured direction.

    Parameters
    ----------
    direction : str
    score : float
        Mean mismatch score over records and lines (1: at the noise).
    level_offset : float
        Median ``log|H_nom/H_meas|`` (0.1: model 10 % too high).
    delay_s : float
        Phase trend as a delay [s] (positive: recording lags the model).
    delay_std_s : float
        Standard error of ``delay_s`` [s].
    """

    direction: str
    score: float
    level_offset: float
    delay_s: float
    delay_std_s: float


@dataclass(frozen=True)
class BandScore:
    """Mean mismatch score of one direction in one frequency band.

    Parameters
    ----------
    direction : str
    f_lo_hz, f_hi_hz : float
        Band edges [Hz].
    score : float
        Mean over records and lines.
    worst_record : str
        Record with the largest band score.
    worst_score : float
    """

    direction: str
    f_lo_hz: float
    f_hi_hz: float
    score: float
    worst_record: str
    worst_score: float


@dataclass(frozen=True, eq=False)
class MismatchMap:
    """Mismatch between the nominal model and the recordings.

    Parameters
    ----------
    record_ids : tuple of str
    freq_hz : ndarray, shape (n_freq,)
    score : ndarray, shape (n, n_freq)
        Mean mismatch score over measured directions (1: at the noise).
    record_score : ndarray, shape (n,)
        Mean over lines of ``score``.
    directions : tuple of DirectionSignature
    bands : tuple of BandScore
    cross_ratio : ndarray, shape (n,)
        Off-diagonal-to-driving-point energy of the recordings divided by the
        same ratio of the model (NaN without cross directions).
    """

    record_ids: tuple[str, ...]
    freq_hz: FloatArray
    score: FloatArray
    record_score: FloatArray
    directions: tuple[DirectionSignature, ...]
    bands: tuple[BandScore, ...]
    cross_ratio: FloatArray

    @property
    def overall(self) -> float:
        """Mean score over everything measured."""
        return float(np.nanmean(self.score))


def _delay(w: FloatArray, ph: FloatArray, wt: FloatArray) -> tuple[float, float]:
    """Weighted slope of phase ``ph`` (records x lines) against ``w``, with per-record offsets."""
    ok = np.isfinite(ph) & (wt > 0)
    if ok.sum() < 4:
        return float("nan"), float("nan")
    W = np.where(ok, wt, 0.0)
    P = np.where(ok, ph, 0.0)
    ww = np.broadcast_to(w, P.shape)
    sw = W.sum(axis=1, keepdims=True)
    sw = np.where(sw > 0, sw, 1.0)
    wc = ww - (W * ww).sum(axis=1, keepdims=True) / sw  # remove per-record mean
    pc = P - (W * P).sum(axis=1, keepdims=True) / sw
    sxx = float(np.sum(W * wc**2))
    if sxx <= 0:
        return float("nan"), float("nan")
    slope = float(np.sum(W * wc * pc) / sxx)
    res = pc - slope * wc
    dof = max(int(ok.sum()) - ph.shape[0] - 1, 1)
    s2 = float(np.sum(W * res**2)) / dof
    return slope, float(np.sqrt(s2 / sxx))


def mismatch_map(
    H_nom: NDArray[np.complexfloating], obs: Observations, *, band_hz: float = 5.0
) -> MismatchMap:
    """Compare the nominal model with the recordings.

    Parameters
    ----------
    H_nom : ndarray of complex, shape (n, n_freq, 3, 3)
        Nominal receptance of ``obs``'s records on its grid.
    obs : Observations
    band_hz : float
        Width of the bands of the band table [Hz].

    Returns
    -------
    MismatchMap
    """
    lr = log_ratio(H_nom, obs)
    with np.errstate(invalid="ignore"):  # NaN where not measured
        z = lr / obs.sigma
    s = (z.real**2 + z.imag**2) / 2.0  # NaN where not measured
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # absent directions
        smap = np.nanmean(s.reshape(obs.n, obs.freq_hz.size, 9), axis=-1)
        rec = np.nanmean(smap, axis=1)
    w = 2 * np.pi * obs.freq_hz
    sig: list[DirectionSignature] = []
    bands: list[BandScore] = []
    f = obs.freq_hz
    edges = np.arange(np.floor(f[0] / band_hz) * band_hz, f[-1] + band_hz, band_hz)
    for d in ALL_DIRS:
        i, j = dir_index(d)
        m = obs.mask[:, :, i, j]
        if not m.any():
            continue
        sd = np.where(m, s[:, :, i, j], np.nan)
        lrd = lr[:, :, i, j]
        wt = np.where(m, 1.0 / obs.sigma[:, :, i, j] ** 2, 0.0)
        slope, err = _delay(w, np.where(m, lrd.imag, np.nan), wt)
        sig.append(
            DirectionSignature(
                direction=d,
                score=float(np.nanmean(sd)),
                level_offset=float(np.nanmedian(lrd.real[m])),
                delay_s=slope,
                delay_std_s=err,
            )
        )
        for lo, hi in itertools.pairwise(edges):
            sel = (f >= lo) & (f < hi)
            if not (m[:, sel]).any():
                continue
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)
                per_rec = np.nanmean(sd[:, sel], axis=1)
            k = int(np.nanargmax(per_rec))
            bands.append(
                BandScore(
                    direction=d,
                    f_lo_hz=float(lo),
                    f_hi_hz=float(hi),
                    score=float(np.nanmean(sd[:, sel])),
                    worst_record=obs.record_ids[k],
                    worst_score=float(per_rec[k]),
                )
            )
    # cross-direction content, measured vs nominal
    Hm = np.where(obs.mask, obs.H, 0.0)
    Hn = np.where(obs.mask, np.nan_to_num(np.asarray(H_nom)), 0.0)
    diag = np.eye(3, dtype=bool)
    em_d = np.sum(np.abs(Hm[..., diag]) ** 2, axis=(1, 2))
    em_o = np.sum(np.abs(Hm[..., ~diag]) ** 2, axis=(1, 2))
    en_d = np.sum(np.abs(Hn[..., diag]) ** 2, axis=(1, 2))
    en_o = np.sum(np.abs(Hn[..., ~diag]) ** 2, axis=(1, 2))
    with np.errstate(divide="ignore", invalid="ignore"):
        cross = (em_o / em_d) / (en_o / en_d)
    has_cross = obs.mask[..., ~diag].any(axis=(1, 2))
    cross = np.where(has_cross & np.isfinite(cross), cross, np.nan)
    return MismatchMap(
        record_ids=obs.record_ids,
        freq_hz=obs.freq_hz,
        score=smap,
        record_score=rec,
        directions=tuple(sig),
        bands=tuple(bands),
        cross_ratio=cross,
    )


@dataclass(frozen=True)
class ModePair:
    """One row of a per-mode table.

    Parameters
    ----------
    record : str
    status : {"paired", "nominal only", "recorded only"}
    f_nom_hz, zeta_nom, f_meas_hz, zeta_meas : float
        NaN where the side is missing.
    mac : float
        Shape agreement (NaN if unpaired or no shapes).
    """

    record: str
    status: str
    f_nom_hz: float
    zeta_nom: float
    f_meas_hz: float
    zeta_meas: float
    mac: float

    @property
    def df_pct(self) -> float:
        """Frequency shift of the recording against the model [%]."""
        return 100.0 * (self.f_meas_hz - self.f_nom_hz) / self.f_nom_hz

    @property
    def dzeta_pct(self) -> float:
        """Damping change of the recording against the model [%]."""
        return 100.0 * (self.zeta_meas - self.zeta_nom) / self.zeta_nom


def pair_modes(
    record: str,
    f_nom: FloatArray,
    zeta_nom: FloatArray,
    shape_nom: NDArray[np.complexfloating] | None,
    f_meas: FloatArray,
    zeta_meas: FloatArray,
    shape_meas: NDArray[np.complexfloating] | None,
    *,
    max_rel_df: float = 0.25,
) -> list[ModePair]:
    """Pair nominal and recorded modes of one record.

    Assignment (Hungarian) on ``|ln(f_meas/f_nom)| / max_rel_df + (1 - MAC)``;
    pairs farther apart than ``max_rel_df`` in frequency or with MAC < 0.3
    stay unpaired (docs/references.md: modal identification: MAC alone is ambiguous with
    three-component shapes, so frequency leads).

    Parameters
    ----------
    record : str
    f_nom, zeta_nom : ndarray, shape (m1,)
    shape_nom : ndarray, shape (m1, 3), optional
        TCP shapes of the nominal modes.
    f_meas, zeta_meas : ndarray, shape (m2,)
    shape_meas : ndarray, shape (m2, 3), optional
    max_rel_df : float
        Largest relative frequency difference of a pair.

    Returns
    -------
    list of ModePair
        Sorted by frequency.
    """
    fn = np.asarray(f_nom, dtype=float)
    fm = np.asarray(f_meas, dtype=float)
    zn = np.asarray(zeta_nom, dtype=float)
    zm = np.asarray(zeta_meas, dtype=float)
    n1, n2 = fn.size, fm.size
    if shape_nom is not None and shape_meas is not None and n1 and n2:
        a = np.asarray(shape_nom, dtype=complex)
        b = np.asarray(shape_meas, dtype=complex)
        num = np.abs(a.conj() @ b.T) ** 2
        den = np.outer(np.sum(np.abs(a) ** 2, 1), np.sum(np.abs(b) ** 2, 1))
        with np.errstate(divide="ignore", invalid="ignore"):
            macm = np.where(den > 0, num / den, np.nan)
    else:
        macm = np.full((n1, n2), np.nan)
    rows: list[ModePair] = []
    used_n: set[int] = set()
    used_m: set[int] = set()
    if n1 and n2:
        dist = np.abs(np.log(fm[None, :] / fn[:, None])) / max_rel_df
        cost = dist + np.nan_to_num(1.0 - macm, nan=0.0)
        # every pair admissible here; the distance and MAC gates follow
        ri, ci = match_modes(cost)
        for i, j in zip(ri, ci, strict=True):
            if dist[i, j] > 1.0 or (np.isfinite(macm[i, j]) and macm[i, j] < 0.3):
                continue
            used_n.add(int(i))
            used_m.add(int(j))
            rows.append(ModePair(record, "paired", fn[i], zn[i], fm[j], zm[j], float(macm[i, j])))
    nan = float("nan")
    for ia in range(n1):
        if ia not in used_n:
            rows.append(ModePair(record, "nominal only", fn[ia], zn[ia], nan, nan, nan))
    for jb in range(n2):
        if jb not in used_m:
            rows.append(ModePair(record, "recorded only", nan, nan, fm[jb], zm[jb], nan))
    rows.sort(key=lambda r: r.f_nom_hz if np.isfinite(r.f_nom_hz) else r.f_meas_hz)
    return rows


def recorded_peaks(
    obs: Observations, *, window_decay_per_s: float = 0.0, prominence: float = 0.05
) -> list[tuple[FloatArray, FloatArray, FloatArray]]:
    """Modes seen in the recordings, by peak picking (a quick estimate for pairing).

    The driving-point magnitudes, each scaled to its maximum, are summed per
    record; peaks of that sum give the frequency, the half-power width of the
    direction that dominates the peak gives the damping (minus the window's
    ``a / w``), and ``sqrt|Im H_dd|`` at the peak the shape magnitude per
    direction (driving-point residues go as the shape squared).

    Parameters
    ----------
    obs : Observations
    window_decay_per_s : float
        Exponential-window decay of the recordings [1/s].
    prominence : float
        Least peak prominence relative to the record's largest value.

    Returns
    -------
    list of (f_hz, zeta, shape)
        Per record: ndarray (m,), ndarray (m,), ndarray (m, 3) (NaN for
        directions not measured).
    """
    from scipy.signal import find_peaks, peak_widths

    f = obs.freq_hz
    out = []
    for k in range(obs.n):
        mags = []
        dirs = []
        for i in range(3):
            if obs.mask[k, :, i, i].all():
                a = np.abs(obs.H[k, :, i, i])
                mags.append(a / a.max())
                dirs.append(i)
        if not mags:
            out.append((np.zeros(0), np.zeros(0), np.zeros((0, 3))))
            continue
        s = np.sum(mags, axis=0)
        pk, _ = find_peaks(s, prominence=prominence * s.max())
        if pk.size == 0:
            out.append((np.zeros(0), np.zeros(0), np.zeros((0, 3))))
            continue
        # half-power width on the direction that dominates each peak
        mg = np.array(mags)
        best = np.argmax(mg[:, pk], axis=0)
        width = np.empty(pk.size)
        for i, (d, p) in enumerate(zip(best, pk, strict=True)):
            lo_i = max(p - 2, 0)
            p_d = lo_i + int(np.argmax(mg[d, lo_i : p + 3]))  # the direction's own maximum
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a peak on the band edge has no width
                width[i] = peak_widths(mg[d], [p_d], rel_height=1 - 1 / np.sqrt(2))[0][0]
        df = float(np.median(np.diff(f)))
        fp = np.interp(pk.astype(float), np.arange(f.size), f)
        # parabolic refinement of the peak line
        inner = (pk > 0) & (pk < f.size - 1)
        y0, y1, y2 = (s[np.clip(pk + d, 0, f.size - 1)] for d in (-1, 0, 1))
        den = y0 - 2 * y1 + y2
        shift = np.where(inner & (den < 0), 0.5 * (y0 - y2) / np.where(den < 0, den, -1.0), 0.0)
        fp = fp + shift * df
        zeta = width * df / (2 * fp) - window_decay_per_s / (2 * np.pi * fp)
        zeta = np.clip(zeta, 1e-4, None)
        shape = np.full((pk.size, 3), np.nan)
        for i in dirs:
            shape[:, i] = np.sqrt(np.abs(obs.H[k, pk, i, i].imag))
        out.append((fp, zeta, shape))
    return out
