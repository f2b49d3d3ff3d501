"""From a campaign (docs/guide/campaign.md) to :class:`Observations`.

What the diagnosis takes from a campaign beyond the FRFs:

- the test header's window decay (:attr:`robolobe.campaign.TestHeader.decay_per_s`).
  Without a window in the header the FRFs are taken as unwindowed (a quality
  note says so: a window would otherwise look like extra damping).
- ``Campaign.force_N`` (the optional ``postures.csv`` column), the hammer's
  peak force of the posture's records. Friction tests repeat a posture at several force
  levels under different posture ids; records with the same joint angles
  form one posture group for cross-validation.

Postures with different frequency grids are interpolated (complex, linear)
onto the grid of the first posture inside the band, with a quality warning.
"""

from __future__ import annotations

import logging
import warnings

import numpy as np
from numpy.typing import NDArray

from robolobe.campaign import Campaign
from robolobe.diagnose.noise import roughness_sigma
from robolobe.diagnose.observations import Observations
from robolobe.errors import InputError
from robolobe.modal.quality import QualityIssue, check_campaign_grids, check_posture_frfs

__all__ = [
    "LOWEST_HZ",
    "USABLE_SHARE",
    "campaign_observations",
    "noisy_postures",
]

log = logging.getLogger(__name__)

#: Share of the highest recorded line in the default band: above ~80 % of the Nyquist
#: frequency the acquisition's anti-aliasing filter shapes the spectra (analysers show
#: 400 of 512 lines for this reason), which no structural model explains.
USABLE_SHARE = 0.8
#: Lower edge of the default band [Hz]: below it a hammer test carries almost
#: no response (the receptance estimate divides the accelerance by w^2).
LOWEST_HZ = 1.0


def noisy_postures(
    ids: tuple[str, ...],
    sigma: NDArray[np.float64],
    *,
    factor: float = 3.0,
    min_share: float = 0.5,
) -> list[QualityIssue]:
    """Postures whose FRF noise stands out from the campaign's (double hits and the like).

    A double hit kept in the averages puts notches into the force spectrum
    (every ``1 / delay`` Hz); the FRF estimate is noisy at and around them. So
    are overloads and loose sensors. The check compares each posture's
    driving-point noise scale (:func:`robolobe.diagnose.noise.roughness_sigma`)
    with the campaign's median at the same line and direction.

    Parameters
    ----------
    ids : tuple of str
        Posture ids, length n.
    sigma : ndarray, shape (n, n_freq, 3, 3)
        Noise scale (NaN where not measured).
    factor : float
        A line counts as noisy above ``factor`` times the campaign's median.
    min_share : float
        Share of noisy lines from which a posture is flagged.

    Returns
    -------
    list of QualityIssue
        One ``warning`` per flagged posture (``check = "double_hit"``).
    """
    if len(ids) < 3:
        return []
    d = np.stack([sigma[:, :, i, i] for i in range(3)], axis=-1)  # (n, n_freq, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(d, axis=0)  # (n_freq, 3)
        noisy = np.where(np.isfinite(d), d > factor * med, np.nan)
        share = np.nanmean(noisy, axis=(1, 2))
        ratio = np.nanmedian(d / med, axis=(1, 2))
    out = []
    for pid, sh, r in zip(ids, share, ratio, strict=True):
        if np.isfinite(sh) and sh >= min_share:
            out.append(
                QualityIssue(
                    pid,
                    "*",
                    "double_hit",
                    "warning",
                    f"the FRF noise is over {factor:g} x the campaign's at {sh:.0%} of the lines "
                    f"(median {r:.1f} x): a double hit, an overload or a loose sensor? "
                    "Check the force signals; the posture is kept, with its noise",
                    value=float(sh),
                )
            )
    return out


def _groups(q_rad: NDArray[np.float64], ids: tuple[str, ...]) -> tuple[str, ...]:
    """Posture id of the first record with the same joint angles (1e-6 rad)."""
    key = np.round(q_rad / 1e-6).astype(np.int64)
    first: dict[bytes, str] = {}
    out = []
    for i, pid in enumerate(ids):
        k = key[i].tobytes()
        out.append(first.setdefault(k, pid))
    return tuple(out)


def campaign_observations(
    campaign: Campaign,
    *,
    band_hz: tuple[float, float] | None = None,
    window_decay_per_s: float | None = None,
    force_N: NDArray[np.float64] | None = None,
    noise_floor: float = 0.01,
) -> tuple[Observations, float, list[QualityIssue]]:
    """Observations of a campaign on one grid in the band, with quality findings.

    Parameters
    ----------
    campaign : Campaign
    band_hz : (float, float) or None
        Analysis band [Hz]; None: the whole recorded band from
        :data:`LOWEST_HZ` up to :data:`USABLE_SHARE` of its highest line (the
        first posture's grid). A band wider than
        the recordings is cut to them, with a quality note saying so.
    window_decay_per_s : float, optional
        Exponential-window decay [1/s]; default from ``campaign.test``, else 0.
    force_N : ndarray, shape (n,), optional
        Hammer force level per posture [N].
    noise_floor : float
        Lower bound of the noise scale (:mod:`robolobe.diagnose.noise`).

    Returns
    -------
    obs : Observations
    window_decay_per_s : float
        The decay used.
    issues : list of QualityIssue
        Data-quality findings (``error`` ones are left out of the data).
    """
    ids = campaign.posture_ids
    issues: list[QualityIssue] = list(check_campaign_grids(ids, [r.freq_hz for r in campaign.frfs]))
    ref = campaign.frfs[0].freq_hz
    rec_lo, rec_hi = float(ref[ref > 0][0]) if np.any(ref > 0) else 0.0, float(ref[-1])
    if band_hz is None:
        band_hz = (max(LOWEST_HZ, rec_lo), USABLE_SHARE * rec_hi)
    lo, hi = band_hz
    if not (0 <= lo < hi):
        raise InputError(f"band_hz: expected 0 <= low < high, found {band_hz}")
    if lo < rec_lo or hi > rec_hi:
        issues.append(
            QualityIssue(
                "*",
                "*",
                "band",
                "warning",
                f"the requested band {lo:g}-{hi:g} Hz is wider than the recordings "
                f"({rec_lo:g}-{rec_hi:g} Hz): analysed {max(lo, rec_lo):g}-{min(hi, rec_hi):g} Hz",
            )
        )
        lo, hi = max(lo, rec_lo), min(hi, rec_hi)
        band_hz = (lo, hi)
    sel = (ref >= lo) & (ref <= hi)
    f = ref[sel]
    if f.size < 8:
        raise InputError(
            f"expected at least 8 frequency lines in {lo:g}..{hi:g} Hz, found {f.size} "
            f"(posture {ids[0]!r}: {ref.size} lines {ref[0]:g}..{ref[-1]:g} Hz)",
            source="frf",
        )
    H = np.full((len(ids), f.size, 3, 3), np.nan + 0j)
    for k, (pid, rec) in enumerate(zip(ids, campaign.frfs, strict=True)):
        found = check_posture_frfs(pid, rec.freq_hz, rec.H, band_hz=band_hz)
        issues.extend(found)
        h = np.array(rec.H)
        for iss in found:
            if iss.severity == "error":
                if iss.dir == "*":
                    h[:] = np.nan
                else:
                    h[:, "xyz".index(iss.dir[0]), "xyz".index(iss.dir[1])] = np.nan
        if rec.freq_hz.shape == ref.shape and np.array_equal(rec.freq_hz, ref):
            H[k] = h[sel]
            continue
        g = rec.freq_hz
        inside = (f >= g[0]) & (f <= g[-1])
        for i in range(3):
            for j in range(3):
                if np.all(np.isnan(h[:, i, j])):
                    continue
                re = np.interp(f, g, h[:, i, j].real)
                im = np.interp(f, g, h[:, i, j].imag)
                H[k, :, i, j] = np.where(inside, re + 1j * im, np.nan)
    decay = window_decay_per_s
    if decay is None:
        decay = campaign.test.decay_per_s
        if not campaign.test.has_window:
            issues.append(
                QualityIssue(
                    "*",
                    "*",
                    "window",
                    "info",
                    "campaign.toml [test] gives no window_end (or window_decay_per_s): the FRFs "
                    "are taken as unwindowed; an exponential window would look like extra damping",
                )
            )
    sigma = roughness_sigma(f, H, window_decay_per_s=decay, floor=noise_floor)
    # without the model-form floor, so that noise under 1 % still tells postures apart
    issues.extend(noisy_postures(ids, roughness_sigma(f, H, window_decay_per_s=decay, floor=1e-6)))
    if force_N is not None and np.asarray(force_N).shape != (len(ids),):
        raise InputError(f"force_N: expected {len(ids)} values, found {np.asarray(force_N).shape}")
    obs = Observations(
        record_ids=ids,
        group=_groups(campaign.q_rad, ids),
        q_rad=campaign.q_rad,
        freq_hz=f,
        H=H,
        sigma=sigma,
        force_N=force_N,
        source="campaign",
        window_decay_per_s=float(decay),
    )
    if not obs.mask.any():
        raise InputError("no usable FRF in the campaign after the quality checks", source="frf")
    return obs, float(decay), issues
