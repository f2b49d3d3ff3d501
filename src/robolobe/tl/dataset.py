"""Modal datasets: postures -> per direction ``n_modes`` x (frequency, damping, stiffness).

A :class:`ModalDataset` is the array form of ``modal.csv`` (docs/guide/modal.md) that
the learning side works on: postures ``q_rad (n, 6)`` and,
per driving-point direction (``xx``, ``yy``, optionally ``zz``) and mode
(1 = lowest frequency), the natural frequency, the damping ratio and the
modal stiffness. A mode that the file does not list is NaN.

Gaps are handled in one of two ways (:func:`interpolate_gaps`):

* ``"interpolate"``: the seed's ``process_data()`` (section 2.3): every value
  column is linearly interpolated along the posture order of the file
  (pandas ``interpolate``), ends filled with the nearest value;
* ``"mask"`` (used by the improved models): the missing values stay NaN and
  are left out of the training loss.

Postures, modes and angles that the model cannot be trusted for raise a
:class:`TrustWarning` (see :func:`check_dataset`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import DRIVING
from robolobe._modal_parameters import PARAMETERS, ModalParameters
from robolobe._text import count
from robolobe.errors import InputError

__all__ = [
    "DRIVING_DIRECTIONS",
    "PARAMETERS",
    "ModalDataset",
    "TrustWarning",
    "check_dataset",
    "check_meta_counts",
    "dataset_from_frame",
    "interpolate_gaps",
]

#: Driving-point directions the learning side models, in canonical order
#: (:data:`robolobe._directions.DRIVING`).
DRIVING_DIRECTIONS: tuple[str, ...] = DRIVING

FloatArray = NDArray[np.float64]


class TrustWarning(UserWarning):
    """The data or the query leaves the region where a model can be trusted."""


@dataclass(frozen=True, eq=False, init=False)
class ModalDataset:
    """Postures and their per-direction modal parameters.

    Built on one :class:`~robolobe._modal_parameters.ModalParameters`
    (:attr:`parameters`, posture ids and joint angles set); the attributes
    below are views of it.

    Parameters
    ----------
    posture_ids : sequence of str, length n
    q_rad : array_like, shape (n, 6)
        Controller joint angles [rad].
    directions : sequence of str
        Driving-point directions, e.g. ``("xx", "yy")``.
    y : array_like, shape (n, n_dir, n_modes, 3)
        ``[..., 0]`` natural frequency [Hz], ``[..., 1]`` damping ratio
        (fraction), ``[..., 2]`` modal stiffness [N/m]; NaN where missing.

    Raises
    ------
    InputError
        On a wrong shape, non-finite joint angles, a direction that is not a
        driving point, or values that break the rules of ``ModalParameters``
        (e.g. a damping ratio <= 0).
    """

    parameters: ModalParameters

    def __init__(
        self,
        posture_ids: Sequence[str],
        q_rad: ArrayLike,
        directions: Sequence[str],
        y: ArrayLike,
    ) -> None:
        q = np.asarray(q_rad, dtype=float)
        yy = np.asarray(y, dtype=float)
        n = len(posture_ids)
        dirs = tuple(directions)
        if q.shape != (n, 6):
            raise InputError(f"q_rad: expected shape ({n}, 6), found {q.shape}")
        if yy.ndim != 4 or yy.shape[:2] != (n, len(dirs)) or yy.shape[3] != 3:
            raise InputError(f"y: expected shape ({n}, {len(dirs)}, n_modes, 3), found {yy.shape}")
        if not np.all(np.isfinite(q)):
            raise InputError("q_rad: expected finite joint angles")
        bad = [d for d in dirs if d not in DRIVING_DIRECTIONS]
        if bad:
            raise InputError(f"directions: expected some of {DRIVING_DIRECTIONS}, found {bad}")
        params = ModalParameters.from_stacked(
            yy, dirs, posture_ids=tuple(str(p) for p in posture_ids), q_rad=q
        )
        object.__setattr__(self, "parameters", params)

    @property
    def posture_ids(self) -> tuple[str, ...]:
        """Posture names, length n."""
        assert self.parameters.posture_ids is not None
        return self.parameters.posture_ids

    @property
    def q_rad(self) -> FloatArray:
        """Controller joint angles [rad], shape (n, 6)."""
        assert self.parameters.q_rad is not None
        return self.parameters.q_rad

    @property
    def directions(self) -> tuple[str, ...]:
        """Driving-point directions."""
        return self.parameters.directions

    @property
    def y(self) -> FloatArray:
        """Frequency [Hz], damping ratio, stiffness [N/m] stacked, shape (n, n_dir, n_modes, 3)."""
        return self.parameters.stacked()

    @property
    def n_postures(self) -> int:
        """Number of postures."""
        return len(self.posture_ids)

    @property
    def n_modes(self) -> int:
        """Modes per direction."""
        return self.parameters.n_modes

    @property
    def q_deg(self) -> FloatArray:
        """Joint angles in degrees, shape (n, 6)."""
        return np.degrees(self.q_rad)

    def subset(self, index: ArrayLike) -> ModalDataset:
        """The postures selected by ``index`` (integer or boolean array)."""
        idx = np.arange(self.n_postures)[np.asarray(index)]
        return ModalDataset(
            posture_ids=tuple(self.posture_ids[i] for i in idx),
            q_rad=self.q_rad[idx],
            directions=self.directions,
            y=self.y[idx],
        )

    def select_ids(self, ids: Sequence[str]) -> ModalDataset:
        """The postures with the given ids, in that order.

        Raises
        ------
        InputError
            If an id is not in the dataset.
        """
        where = {p: i for i, p in enumerate(self.posture_ids)}
        missing = [p for p in ids if p not in where]
        if missing:
            raise InputError(f"posture ids not in the dataset: {missing[:5]}")
        return self.subset([where[p] for p in ids])

    def concat(self, other: ModalDataset) -> ModalDataset:
        """This dataset followed by ``other`` (same directions and modes)."""
        if other.directions != self.directions or other.n_modes != self.n_modes:
            raise InputError("concat: expected the same directions and number of modes")
        return ModalDataset(
            posture_ids=self.posture_ids + other.posture_ids,
            q_rad=np.vstack([self.q_rad, other.q_rad]),
            directions=self.directions,
            y=np.concatenate([self.y, other.y]),
        )

    @classmethod
    def from_parameters(cls, parameters: ModalParameters) -> ModalDataset:
        """The dataset of parameters that carry their posture ids and joint angles (spread dropped).

        Raises
        ------
        InputError
            Without posture ids or joint angles, or with a direction that is
            not a driving point.
        """
        if parameters.posture_ids is None or parameters.q_rad is None:
            raise InputError(
                "ModalDataset.from_parameters: expected parameters with posture_ids and q_rad"
            )
        return cls(
            posture_ids=parameters.posture_ids,
            q_rad=parameters.q_rad,
            directions=parameters.directions,
            y=parameters.stacked(),
        )

    def to_frame(self, extra: dict[str, FloatArray] | None = None) -> pd.DataFrame:
        """The ``modal.csv`` frame (docs/guide/modal.md); missing modes are left out.

        :meth:`ModalParameters.to_frame <robolobe._modal_parameters.ModalParameters.to_frame>`
        of :attr:`parameters`.

        Parameters
        ----------
        extra : dict of str to ndarray, shape (n, n_dir, n_modes), optional
            Extra per-value columns (e.g. spreads) to append.

        Returns
        -------
        pandas.DataFrame
            Columns ``posture_id, q1_deg..q6_deg, dir, mode, f_hz, zeta,
            k_N_per_m`` (+ extras), one row per posture, direction and mode.
        """
        return self.parameters.to_frame(extra)


def dataset_from_frame(
    df: pd.DataFrame,
    *,
    directions: Sequence[str] = ("xx", "yy"),
    n_modes: int = 5,
    source: str = "modal dataset",
) -> ModalDataset:
    """Build a :class:`ModalDataset` from a validated ``modal.csv`` frame.

    Parameters
    ----------
    df : pandas.DataFrame
        As returned by :func:`robolobe.modal.modal_csv.read_modal_csv`.
    directions : sequence of str
        Driving-point directions to keep (``"xx"``, ``"yy"``, ``"zz"``).
    n_modes : int
        Modes per direction (the seed: 5); higher modes are ignored, missing
        ones become NaN.
    source : str
        Name used in messages.

    Returns
    -------
    ModalDataset
        Postures in order of first appearance in the file.

    Raises
    ------
    InputError
        If a required column is missing or a direction has no rows at all.
    """
    return ModalDataset.from_parameters(
        ModalParameters.from_frame(df, directions=tuple(directions), n_modes=n_modes, source=source)
    )


def interpolate_gaps(ds: ModalDataset) -> ModalDataset:
    """Fill missing values as the seed's ``process_data()`` does.

    Each value column (direction x mode x parameter) is linearly interpolated
    along the posture order; leading and trailing gaps take the nearest
    value. A column with no value at all stays NaN.
    """
    n, nd, nm, _ = ds.y.shape
    flat = pd.DataFrame(ds.y.reshape(n, -1))
    filled = flat.interpolate(method="linear", axis=0, limit_direction="both")
    return ModalDataset(
        posture_ids=ds.posture_ids,
        q_rad=ds.q_rad,
        directions=ds.directions,
        y=filled.to_numpy().reshape(n, nd, nm, 3),
    )


def check_dataset(
    ds: ModalDataset,
    *,
    min_postures: int,
    q_min_rad: ArrayLike | None = None,
    q_max_rad: ArrayLike | None = None,
    source: str = "modal dataset",
    every_mode: bool = True,
) -> None:
    """Raise on data a model cannot be trained on; warn on what weakens it.

    Parameters
    ----------
    ds : ModalDataset
    min_postures : int
        Fewer postures than this is an error.
    q_min_rad, q_max_rad : array_like, shape (6,), optional
        Joint limits; postures outside them are an error.
    source : str
        Name used in messages.
    every_mode : bool
        True (a network's fixed outputs): each direction must have a value of
        each of its ``n_modes`` modes somewhere. False (the twin methods, which
        pair measured modes with the twin's by frequency): a direction may have
        fewer modes than the others; it needs one.

    Raises
    ------
    InputError
        Too few postures, postures outside the joint limits, duplicated
        postures, a direction x mode with no value at all (``every_mode``) or
        a direction without any.

    Warns
    -----
    TrustWarning
        Missing modes (which postures, directions, modes), and fewer than
        ``2 * min_postures`` postures.
    """
    n = ds.n_postures
    if n < min_postures:
        raise InputError(
            f"expected at least {min_postures} postures to train on, found {n}: the model "
            "would only repeat the few it saw",
            source=source,
        )
    if q_min_rad is not None and q_max_rad is not None:
        lo = np.asarray(q_min_rad, dtype=float)
        hi = np.asarray(q_max_rad, dtype=float)
        bad = np.any((ds.q_rad < lo - 1e-9) | (ds.q_rad > hi + 1e-9), axis=1)
        if np.any(bad):
            i = int(np.flatnonzero(bad)[0])
            j = int(np.flatnonzero((ds.q_rad[i] < lo - 1e-9) | (ds.q_rad[i] > hi + 1e-9))[0])
            raise InputError(
                f"posture {ds.posture_ids[i]!r}: q{j + 1} = {np.degrees(ds.q_rad[i, j]):.6g} deg "
                f"is outside the joint range [{np.degrees(lo[j]):.6g}, {np.degrees(hi[j]):.6g}] "
                f"deg ({count(int(bad.sum()), 'posture')} out of range)",
                source=source,
            )
    _, first = np.unique(np.round(ds.q_rad, 9), axis=0, return_index=True)
    if len(first) < n:
        dup = sorted(set(range(n)) - set(first.tolist()))
        raise InputError(
            f"postures {[ds.posture_ids[i] for i in dup[:5]]} repeat the joint angles of "
            "earlier postures",
            source=source,
        )
    known = np.all(np.isfinite(ds.y), axis=3)  # (n, n_dir, n_modes)
    for j, d in enumerate(ds.directions):
        empty = ~np.any(known[:, j], axis=0)  # (n_modes,): modes no posture has
        if every_mode and empty.any():
            raise InputError(
                f"direction {d!r}, mode {int(np.flatnonzero(empty)[0]) + 1}: no posture has a "
                f"value; expected {ds.n_modes} modes per direction",
                source=source,
            )
        if empty.all():
            raise InputError(
                f"direction {d!r}: no posture has a mode; expected at least one per direction "
                "(leave the direction out of the tests, or check its column 'dir')",
                source=source,
            )
    # a direction's modes beyond those any posture has are not missing values (twin
    # methods: that direction sees fewer modes)
    seen = np.any(known, axis=0, keepdims=True)  # (1, n_dir, n_modes)
    if not np.all(known | ~seen):
        miss = np.argwhere(~known & seen)
        where = ", ".join(
            f"{ds.posture_ids[p]}/{ds.directions[d]}/mode {m + 1}" for p, d, m in miss[:6]
        )
        more = f" and {len(miss) - 6} more" if len(miss) > 6 else ""
        warnings.warn(
            f"{source}: {count(len(miss), 'missing mode value')} ({where}{more}); those "
            "entries are filled or left out of training, and predictions for these modes near "
            "those postures are less reliable",
            TrustWarning,
            stacklevel=2,
        )
    if n < 2 * min_postures:
        warnings.warn(
            f"{source}: only {count(n, 'posture')}; predictions are trustworthy only near them "
            "(check the spread columns)",
            TrustWarning,
            stacklevel=2,
        )


def check_meta_counts(directions: Sequence[str], n_modes: int, where: str) -> None:
    """A model file's directions and mode count, as a fit writes them."""
    if (
        not directions
        or len(set(directions)) != len(directions)
        or set(directions) - set(DRIVING_DIRECTIONS)
    ):
        raise InputError(
            "inconsistent model file: directions: expected distinct ones of "
            f"{', '.join(DRIVING_DIRECTIONS)}, found {list(directions)}",
            source=where,
        )
    if not 1 <= n_modes <= 20:
        raise InputError(
            f"inconsistent model file: n_modes: expected 1 to 20, found {n_modes}", source=where
        )
