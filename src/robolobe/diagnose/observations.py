"""Recorded FRFs on one frequency grid, ready for comparison with a model.

A campaign (docs/guide/campaign.md) may hold per-posture grids and any subset of
the nine directions. :class:`Observations` puts all records on one grid
inside the analysis band, keeps a mask of what was measured and carries the
noise scale of every point (:mod:`robolobe.diagnose.noise`).

A *record* is one set of FRFs: a posture, or a posture at one hammer force
level (campaigns for friction tests repeat postures at several force
levels). ``group`` ties records of one posture together: cross-validation
holds out whole groups.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import ALL_DIRS, dir_index
from robolobe.diagnose.noise import variance_inflation
from robolobe.errors import InputError

__all__ = [
    "Observations",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
BoolArray = NDArray[np.bool_]


def _frozen(a: NDArray[np.generic]) -> NDArray[np.generic]:
    a = np.array(a)
    a.setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class Observations:
    """Measured receptances of several records on one frequency grid.

    Parameters
    ----------
    record_ids : tuple of str, length n
        One id per record (the posture id, with ``@<force>N`` for force levels).
    group : tuple of str, length n
        Posture id of each record (cross-validation holds out whole groups).
    q_rad : ndarray, shape (n, 6)
        Joint angles of each record [rad].
    freq_hz : ndarray, shape (n_freq,)
        Common frequency grid [Hz], increasing.
    H : ndarray of complex, shape (n, n_freq, 3, 3)
        Receptance [m/N], TCP axes, (response, excitation); NaN where absent.
    sigma : ndarray, shape (n, n_freq, 3, 3)
        Noise scale of each point: standard deviation of the real and of the
        imaginary part of ``log H`` (relative noise, dimensionless); NaN
        where absent.
    force_N : ndarray, shape (n,), optional
        Hammer force level of each record [N] (peak force), if known.
    source : str
        Where the data came from (for messages).
    window_decay_per_s : float
        Exponential-window decay of the recordings [1/s]; sets the
        correlation of neighbouring lines (:attr:`inflation`).
    """

    record_ids: tuple[str, ...]
    group: tuple[str, ...]
    q_rad: FloatArray
    freq_hz: FloatArray
    H: ComplexArray
    sigma: FloatArray
    force_N: FloatArray | None = None
    source: str = "<observations>"
    window_decay_per_s: float = 0.0
    _mask: BoolArray = field(init=False, repr=False)
    _H_measured: ComplexArray = field(init=False, repr=False)
    _inv_sigma_measured: FloatArray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = len(self.record_ids)
        q = np.asarray(self.q_rad, dtype=float)
        f = np.asarray(self.freq_hz, dtype=float)
        H = np.asarray(self.H, dtype=complex)
        s = np.asarray(self.sigma, dtype=float)
        if len(self.group) != n:
            raise InputError(f"group: expected {n} entries, found {len(self.group)}", self.source)
        if q.shape != (n, 6):
            raise InputError(f"q_rad: expected shape ({n}, 6), found {q.shape}", self.source)
        if f.ndim != 1 or f.size < 8 or np.any(np.diff(f) <= 0):
            raise InputError(
                "freq_hz: expected at least 8 increasing frequencies, "
                f"found {f.size} (increasing: {bool(np.all(np.diff(f) > 0))})",
                self.source,
            )
        if H.shape != (n, f.size, 3, 3) or s.shape != H.shape:
            raise InputError(
                f"H and sigma: expected shape {(n, f.size, 3, 3)}, found {H.shape} and {s.shape}",
                self.source,
            )
        mask = np.isfinite(H) & np.isfinite(s) & (s > 0) & (np.abs(H) > 0)
        force = None
        if self.force_N is not None:
            force = np.asarray(self.force_N, dtype=float)
            if force.shape != (n,):
                raise InputError(f"force_N: expected shape ({n},), found {force.shape}")
        object.__setattr__(self, "record_ids", tuple(str(r) for r in self.record_ids))
        object.__setattr__(self, "group", tuple(str(g) for g in self.group))
        object.__setattr__(self, "q_rad", _frozen(q))
        object.__setattr__(self, "freq_hz", _frozen(f))
        object.__setattr__(self, "H", _frozen(np.where(mask, H, np.nan + 0j)))
        object.__setattr__(self, "sigma", _frozen(np.where(mask, s, np.nan)))
        object.__setattr__(self, "force_N", None if force is None else _frozen(force))
        object.__setattr__(self, "_mask", _frozen(mask))
        object.__setattr__(self, "_H_measured", _frozen(H[mask]))
        object.__setattr__(self, "_inv_sigma_measured", _frozen(1.0 / s[mask]))

    # ---------------------------------------------------------------- views
    @property
    def n(self) -> int:
        """Number of records."""
        return len(self.record_ids)

    @property
    def mask(self) -> BoolArray:
        """Measured points, shape (n, n_freq, 3, 3)."""
        return self._mask

    @property
    def H_measured(self) -> ComplexArray:
        """``H[mask]``: the measured points in a fixed order, shape (m,)."""
        return self._H_measured

    @property
    def inv_sigma_measured(self) -> FloatArray:
        """``1 / sigma[mask]``, shape (m,)."""
        return self._inv_sigma_measured

    @property
    def dir_mask(self) -> BoolArray:
        """Directions measured in each record (any frequency), shape (n, 3, 3)."""
        return np.asarray(self._mask.any(axis=1))

    @property
    def directions(self) -> tuple[str, ...]:
        """Directions measured in at least one record, in array order (response, excitation)."""
        m = np.asarray(self.dir_mask.any(axis=0))
        return tuple(d for d in ALL_DIRS if bool(m[dir_index(d)]))

    @property
    def inflation(self) -> float:
        """Variance inflation from line correlation (see ``noise.variance_inflation``)."""
        df = float(np.median(np.diff(self.freq_hz)))
        return variance_inflation(df, self.window_decay_per_s)

    @property
    def groups(self) -> tuple[str, ...]:
        """Distinct posture groups in order of first appearance."""
        return tuple(dict.fromkeys(self.group))

    @property
    def force_levels_N(self) -> FloatArray:
        """Distinct force levels [N] (empty if unknown)."""
        if self.force_N is None:
            return np.zeros(0)
        return np.unique(np.round(self.force_N, 6))

    def subset(self, idx: ArrayLike) -> Observations:
        """The records ``idx`` (integer indices or a boolean mask)."""
        i = np.arange(self.n)[np.asarray(idx)]
        return Observations(
            record_ids=tuple(self.record_ids[k] for k in i),
            group=tuple(self.group[k] for k in i),
            q_rad=self.q_rad[i],
            freq_hz=self.freq_hz,
            H=self.H[i],
            sigma=self.sigma[i],
            force_N=None if self.force_N is None else self.force_N[i],
            source=self.source,
            window_decay_per_s=self.window_decay_per_s,
        )

    def decimated(self, max_lines: int) -> Observations:
        """At most ``max_lines`` frequency lines, spaced evenly in log frequency.

        Log spacing keeps the relative resolution (lines per half-power
        bandwidth ``2 zeta f``) the same at every frequency, so that a wide
        band (the whole recorded band, e.g. 1-512 Hz) still resolves the low
        robot modes; at low frequency, where log spacing would be finer than
        the recorded line spacing, every line is kept.

        Parameters
        ----------
        max_lines : int
            Upper bound on the number of frequency lines (>= 8).
        """
        if max_lines < 8:
            raise InputError(f"max_lines: expected >= 8, found {max_lines}")
        n = self.freq_hz.size
        if n <= max_lines:
            return self
        f = self.freq_hz
        f0 = max(float(f[0]), 1e-3)
        lo, hi = 8, 64 * max_lines
        sl = np.unique(np.linspace(0, n - 1, max_lines).round().astype(int))
        # the most log-spaced targets whose distinct nearest lines fit in max_lines
        while lo < hi:
            m = (lo + hi + 1) // 2
            idx = np.unique(np.searchsorted(f, np.geomspace(f0, float(f[-1]), m)).clip(0, n - 1))
            if idx.size <= max_lines:
                lo, sl = m, idx
            else:
                hi = m - 1
        return Observations(
            record_ids=self.record_ids,
            group=self.group,
            q_rad=self.q_rad,
            freq_hz=self.freq_hz[sl],
            H=self.H[:, sl],
            sigma=self.sigma[:, sl],
            force_N=self.force_N,
            source=self.source,
            window_decay_per_s=self.window_decay_per_s,
        )
