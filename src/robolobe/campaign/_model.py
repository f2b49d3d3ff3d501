"""Measured data: the hammer-test campaign and its test header (docs/guide/campaign.md).

The data model only; reading and writing live in :mod:`robolobe.campaign._io`,
UFF 58 in :mod:`robolobe.campaign.uff`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import ALL_DIRS, dir_index
from robolobe.errors import InputError

__all__ = [
    "ALL_DIRS",
    "FRF_COLUMNS",
    "POSTURE_COLUMNS",
    "TEST_KEYS",
    "Campaign",
    "PostureFRF",
    "TestHeader",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

POSTURE_COLUMNS: tuple[str, ...] = ("posture_id", *(f"q{i}_deg" for i in range(1, 7)))
FRF_COLUMNS: tuple[str, ...] = ("posture_id", "dir", "freq_hz", "re", "im")
TEST_KEYS: tuple[str, ...] = (
    "sample_rate_hz",
    "duration_s",
    "impacts",
    "coherence_min",
    "window_end",
    "window_decay_per_s",
)
"""Keys of the ``[test]`` table (:class:`TestHeader`)."""


# ------------------------------------------------------------------ test header
#: Smallest exponential-window value at the record end. The window adds the decay
#: ln(1 / w_end) / T to every mode (corrected afterwards); at 1e-3 that is 6.9 / T
#: 1/s (a 4 s record: 5.5 % damping added at 5 Hz), as much as a robot mode's own
#: damping (1-10 %). Lower, the window, not the structure, sets the records'
#: decay (1e-300 leaves a few milliseconds of signal) and the damping correction
#: subtracts two large numbers. Hammer-test practice ends the window at 1-10 %.
WINDOW_END_MIN = 1e-3
WINDOW_END_WHAT = f"an exponential-window value in [{WINDOW_END_MIN:g}, 1]"

_TEST_RANGES: dict[str, tuple[str, float, float, bool]] = {
    # key: (what, low, high, low inclusive)
    "sample_rate_hz": ("a sampling rate in Hz", 0.0, 1e7, False),
    "duration_s": ("a record length in s", 0.0, 1e5, False),
    "impacts": ("a number of impacts", 1.0, 1e6, True),
    "coherence_min": ("a coherence in [0, 1]", 0.0, 1.0, True),
    "window_end": (WINDOW_END_WHAT, WINDOW_END_MIN, 1.0, True),
    "window_decay_per_s": ("a window decay rate >= 0 1/s", 0.0, 1e6, True),
}


@dataclass(frozen=True, eq=False)
class TestHeader(Mapping[str, Any]):
    """The ``[test]`` table of a campaign: how the FRFs were measured.

    Every key is optional. It behaves as a read-only mapping of the keys
    given (so it writes back to ``campaign.toml`` unchanged); the typed
    attributes are None where a key is absent.

    Parameters
    ----------
    sample_rate_hz : float, optional
        Sampling rate of the records [Hz].
    duration_s : float, optional
        Record length ``T`` [s].
    impacts : int, optional
        Impacts averaged per FRF.
    coherence_min : float, optional
        Lowest coherence accepted, in [0, 1].
    window_end : float, optional
        Value of the exponential force/response window at the end of the
        record, in (0, 1]; needs ``duration_s``.
    window_decay_per_s : float, optional
        The window's decay rate [1/s] given directly (instead of
        ``window_end``).
    extra : mapping, optional
        Other keys, kept as given (informative).

    Raises
    ------
    InputError
        A value of the wrong type or out of range, ``window_end`` without
        ``duration_s``, or both ``window_end`` and ``window_decay_per_s``.
    """

    __test__ = False  # not a pytest class

    sample_rate_hz: float | None = None
    duration_s: float | None = None
    impacts: int | None = None
    coherence_min: float | None = None
    window_end: float | None = None
    window_decay_per_s: float | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)
    source: str = field(default="campaign.toml", repr=False)

    def __post_init__(self) -> None:
        for key, (what, lo, hi, lo_in) in _TEST_RANGES.items():
            v = getattr(self, key)
            if v is None:
                continue
            where = f"{self.source}[test.{key}]"
            if isinstance(v, bool) or not isinstance(v, int | float | np.integer | np.floating):
                raise InputError(f"expected {what}, found {v!r}", source=where)
            x = float(v)
            ok = math.isfinite(x) and (x >= lo if lo_in else x > lo) and x <= hi
            if key == "impacts" and x != int(x):
                ok = False
            if not ok:
                raise InputError(f"expected {what}, found {v!r}", source=where)
            object.__setattr__(self, key, int(x) if key == "impacts" else x)
        if self.window_end is not None and self.duration_s is None:
            raise InputError(
                "window_end needs duration_s (the record length) to correct the damping; "
                "add duration_s or give window_decay_per_s",
                source=f"{self.source}[test]",
            )
        if self.window_end is not None and self.window_decay_per_s is not None:
            raise InputError(
                "expected window_end (with duration_s) or window_decay_per_s, found both",
                source=f"{self.source}[test]",
            )
        object.__setattr__(self, "extra", dict(self.extra))

    @classmethod
    def from_mapping(
        cls, table: Mapping[str, Any] | None, *, source: str = "campaign.toml"
    ) -> TestHeader:
        """The header of a ``[test]`` table (unknown keys go to ``extra``)."""
        if isinstance(table, TestHeader):
            return table
        data = dict(table or {})
        known = {k: data.pop(k) for k in TEST_KEYS if k in data}
        return cls(**known, extra=data, source=source)

    @property
    def has_window(self) -> bool:
        """Whether the header says how the records were windowed."""
        return self.window_end is not None or self.window_decay_per_s is not None

    @property
    def decay_per_s(self) -> float:
        """Decay rate the exponential window added to every pole [1/s].

        ``window_decay_per_s`` if given, else ``-ln(window_end) / duration_s``,
        else 0 (no window). Identified damping is corrected by it
        (docs/references.md, exponential window).
        """
        if self.window_decay_per_s is not None:
            return float(self.window_decay_per_s)
        if self.window_end is not None and self.duration_s is not None:
            return -math.log(self.window_end) / self.duration_s
        return 0.0

    @functools.cached_property
    def _items(self) -> dict[str, Any]:
        # built once: the header is frozen (cached_property writes __dict__ directly)
        out = {k: getattr(self, k) for k in TEST_KEYS if getattr(self, k) is not None}
        out.update(self.extra)
        return out

    def __getitem__(self, key: str) -> Any:
        return self._items[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Mapping):
            return self._items == dict(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]


# ------------------------------------------------------------------ data model
@dataclass(frozen=True, eq=False)
class PostureFRF:
    """The FRFs of one posture on its frequency grid.

    Parameters
    ----------
    freq_hz : array_like, shape (n_freq,)
        Frequencies [Hz], strictly increasing, >= 0.
    H : array_like, shape (n_freq, 3, 3), complex
        Receptance [m/N], rows response and columns excitation (TCP axes);
        NaN for directions not measured (a whole column entry).
    """

    freq_hz: FloatArray
    H: ComplexArray

    def __post_init__(self) -> None:
        f = np.array(self.freq_hz, dtype=float)
        h = np.array(self.H, dtype=complex)
        if f.ndim != 1 or f.size < 1 or h.shape != (f.size, 3, 3):
            raise InputError(
                f"expected freq_hz (n,) and H (n, 3, 3), found {f.shape} and {h.shape}",
                source="PostureFRF",
            )
        if not np.all(np.isfinite(f)) or f[0] < 0 or np.any(np.diff(f) <= 0):
            raise InputError("expected increasing finite frequencies >= 0", source="PostureFRF")
        nan = np.isnan(h)
        partial = nan.any(axis=0) & ~nan.all(axis=0)
        if partial.any() or np.isinf(h).any():
            raise InputError(
                "expected each direction either fully finite or fully NaN (absent)",
                source="PostureFRF",
            )
        f.setflags(write=False)
        h.setflags(write=False)
        object.__setattr__(self, "freq_hz", f)
        object.__setattr__(self, "H", h)

    @property
    def has_dir(self) -> NDArray[np.bool_]:
        """Directions present, shape (3, 3) bool (response, excitation)."""
        return np.asarray(~np.isnan(self.H[0].real))

    @property
    def dirs(self) -> frozenset[str]:
        """Two-letter directions present."""
        m = self.has_dir
        return frozenset(d for d in ALL_DIRS if m[dir_index(d)])


@dataclass(frozen=True, eq=False)
class Campaign:
    """A hammer-test campaign.

    Parameters
    ----------
    robot : str
        ``"A"``, ``"B"``, ``"C"`` or the path of a robot file (as read:
        resolved against the campaign folder).
    posture_ids : sequence of str, length n
        Unique posture ids.
    q_rad : array_like, shape (n, 6)
        Joint angles [rad].
    frfs : sequence of PostureFRF, length n
        FRFs per posture (same order as ``posture_ids``).
    notes : str
        Free text.
    test : TestHeader or mapping
        How the FRFs were measured (the ``[test]`` table); a mapping is
        validated into a :class:`TestHeader`.
    force_N : array_like, shape (n,), optional
        The hammer's peak force per posture [N] (``postures.csv`` column
        ``force_N``), for tests repeated at several force levels.
    """

    robot: str
    posture_ids: tuple[str, ...]
    q_rad: FloatArray
    frfs: tuple[PostureFRF, ...]
    notes: str = ""
    test: TestHeader = field(default_factory=TestHeader)
    force_N: FloatArray | None = None

    def __post_init__(self) -> None:
        ids = tuple(str(p) for p in self.posture_ids)
        q = np.array(self.q_rad, dtype=float)
        frfs = tuple(self.frfs)
        if q.shape != (len(ids), 6) or len(frfs) != len(ids):
            raise InputError(
                f"expected {len(ids)} posture ids, q_rad ({len(ids)}, 6) and {len(ids)} FRFs, "
                f"found q_rad {q.shape} and {len(frfs)} FRFs",
                source="Campaign",
            )
        if len(set(ids)) != len(ids):
            dup = next(p for p in ids if ids.count(p) > 1)
            raise InputError(f"duplicate posture id {dup!r}", source="Campaign")
        if not np.all(np.isfinite(q)):
            raise InputError("expected finite joint angles", source="Campaign")
        if not all(isinstance(f, PostureFRF) for f in frfs):
            raise InputError("expected PostureFRF items in frfs", source="Campaign")
        if self.force_N is not None:
            force = np.array(self.force_N, dtype=float)
            if force.shape != (len(ids),):
                raise InputError(
                    f"expected force_N of {len(ids)} values, found shape {force.shape}",
                    source="Campaign",
                )
            bad = ~(np.isfinite(force) & (force > 0))
            if bad.any():
                i = int(np.argmax(bad))
                raise InputError(
                    f"expected peak forces > 0 N in force_N, found {force[i]:g} for posture "
                    f"{ids[i]!r}",
                    source="Campaign",
                )
            force.setflags(write=False)
            object.__setattr__(self, "force_N", force)
        q.setflags(write=False)
        object.__setattr__(self, "posture_ids", ids)
        object.__setattr__(self, "q_rad", q)
        object.__setattr__(self, "frfs", frfs)
        object.__setattr__(self, "robot", str(self.robot))
        object.__setattr__(self, "test", TestHeader.from_mapping(self.test))

    # ---------------------------------------------------------------- views
    @property
    def n_postures(self) -> int:
        """Number of postures."""
        return len(self.posture_ids)

    @property
    def q_deg(self) -> FloatArray:
        """Joint angles [deg], shape (n, 6)."""
        return np.degrees(self.q_rad)

    @property
    def dirs(self) -> frozenset[str]:
        """Directions present in at least one posture."""
        out: set[str] = set()
        for f in self.frfs:
            out |= f.dirs
        return frozenset(out)

    def index(self, posture_id: str) -> int:
        """Position of ``posture_id`` (InputError if unknown)."""
        try:
            return self.posture_ids.index(str(posture_id))
        except ValueError:
            raise InputError(f"unknown posture id {posture_id!r}", source="Campaign") from None

    def frf(self, posture_id: str, dir: str) -> tuple[FloatArray, ComplexArray]:
        """One FRF.

        Parameters
        ----------
        posture_id : str
        dir : str
            Two letters from x, y, z (response, excitation).

        Returns
        -------
        freq_hz : ndarray, shape (n_freq,)
        H : ndarray, shape (n_freq,), complex
            Receptance [m/N].
        """
        d = str(dir).lower()
        if d not in ALL_DIRS:
            raise InputError(f"expected a direction like 'xx', found {dir!r}", source="Campaign")
        rec = self.frfs[self.index(posture_id)]
        if d not in rec.dirs:
            raise InputError(
                f"posture {posture_id!r} has no direction {d!r} (has {sorted(rec.dirs)})",
                source="Campaign",
            )
        r, e = dir_index(d)
        return rec.freq_hz, rec.H[:, r, e]

    def has_common_grid(self) -> bool:
        """Whether all postures share one frequency grid."""
        if not self.frfs:
            return True
        g0 = self.frfs[0].freq_hz
        return all(f.freq_hz.shape == g0.shape and np.array_equal(f.freq_hz, g0) for f in self.frfs)

    def common_grid(self) -> tuple[FloatArray, ComplexArray, NDArray[np.bool_]]:
        """Stacked arrays on the common frequency grid.

        Returns
        -------
        freq_hz : ndarray, shape (n_freq,)
        H : ndarray, shape (n, n_freq, 3, 3), complex
            Receptance [m/N], NaN where a direction is absent.
        has_dir : ndarray, shape (n, 3, 3), bool

        Raises
        ------
        InputError
            If postures have different grids (naming the first that differs).
        """
        if not self.frfs:
            return np.zeros(0), np.zeros((0, 0, 3, 3), complex), np.zeros((0, 3, 3), bool)
        g0 = self.frfs[0].freq_hz
        for pid, f in zip(self.posture_ids, self.frfs, strict=True):
            if f.freq_hz.shape != g0.shape or not np.array_equal(f.freq_hz, g0):
                raise InputError(
                    f"postures have different frequency grids: {self.posture_ids[0]!r} has "
                    f"{g0.size} points {g0[0]:g}..{g0[-1]:g} Hz, {pid!r} has "
                    f"{f.freq_hz.size} points {f.freq_hz[0]:g}..{f.freq_hz[-1]:g} Hz",
                    source="Campaign",
                )
        H = np.stack([f.H for f in self.frfs])
        has = np.stack([f.has_dir for f in self.frfs])
        return g0.copy(), H, has

    @classmethod
    def from_arrays(
        cls,
        robot: str,
        posture_ids: Sequence[str],
        q_rad: ArrayLike,
        freq_hz: ArrayLike,
        H: ArrayLike,
        *,
        dirs: Iterable[str] | None = None,
        notes: str = "",
        test: Mapping[str, Any] | None = None,
        force_N: ArrayLike | None = None,
    ) -> Campaign:
        """Build a campaign whose postures share one grid.

        Parameters
        ----------
        robot : str
        posture_ids : sequence of str, length n
        q_rad : array_like, shape (n, 6)
        freq_hz : array_like, shape (n_freq,)
        H : array_like, shape (n, n_freq, 3, 3), complex
            Receptance [m/N]; NaN columns are absent directions.
        dirs : iterable of str, optional
            Keep only these directions (others set to NaN).
        notes, test, force_N
            As in :class:`Campaign`.
        """
        h = np.array(H, dtype=complex)
        f = np.asarray(freq_hz, dtype=float)
        if h.ndim != 4 or h.shape[1:] != (f.size, 3, 3):
            raise InputError(
                f"expected H (n, {f.size}, 3, 3), found {h.shape}", source="Campaign.from_arrays"
            )
        if dirs is not None:
            keep = np.zeros((3, 3), bool)
            for d in dirs:
                dd = str(d).lower()
                if dd not in ALL_DIRS:
                    raise InputError(
                        f"expected directions like 'xx', found {d!r}", source="Campaign.from_arrays"
                    )
                keep[dir_index(dd)] = True
            h[:, :, ~keep] = np.nan
        return cls(
            robot=robot,
            posture_ids=tuple(posture_ids),
            q_rad=np.asarray(q_rad, dtype=float),
            frfs=tuple(PostureFRF(f, hp) for hp in h),
            notes=notes,
            test=TestHeader.from_mapping(test),
            force_N=None if force_N is None else np.asarray(force_N, dtype=float),
        )
