"""The one modal-parameter type: frequency, damping and stiffness per posture, direction, mode.

:class:`ModalParameters` is what every producer of modes returns (the twin's
:meth:`robolobe.twin.modes.Modes.parameters`, an identification's
:meth:`robolobe.modal.posture.PostureModal.parameters`, a ``modal.csv`` table
through :meth:`ModalParameters.from_frame`, a predictor's
:meth:`robolobe.tl.estimator.ModalPrediction.parameters`) and what planning
and the lobes consume (:class:`robolobe.plan.modes.RobotModes`,
:meth:`robolobe.sld.frf.ModalModel.from_parameters`). The modal form
(docs/guide/modal.md) of the driving-point receptance in direction ``d`` is::

    H_dd(w) ~ sum_r (w_r^2 / k_r,d) / (w_r^2 - w^2 + 2 i zeta_r w_r w)

Axis order, everywhere: ``(n_postures, n_directions, n_modes)``; directions
are names of the project's one direction vocabulary
(:mod:`robolobe._directions`: ``"xx"``, ``"yy"``, ``"zz"`` for driving points).
This module imports no robolobe package, so every layer may use it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import ALL_DIRS, DRIVING, dir_index
from robolobe.errors import InputError

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["PARAMETERS", "Q_COLUMNS", "ModalParameters"]

FloatArray = NDArray[np.float64]

#: The three modal parameters per mode, in the order of stacked arrays ``(..., 3)``
#: (and of the spread :attr:`ModalParameters.log_std`).
PARAMETERS: tuple[str, ...] = ("f_hz", "zeta", "k_N_per_m")
#: Joint-angle columns of the modal.csv long table (docs/guide/modal.md), degrees.
Q_COLUMNS: tuple[str, ...] = tuple(f"q{i}_deg" for i in range(1, 7))


def _frozen_copy(x: object) -> FloatArray:
    """``x`` as a read-only float64 array: copied, unless it already is one that owns its data."""
    if (
        isinstance(x, np.ndarray)
        and x.dtype == np.float64
        and not x.flags.writeable
        and x.flags.owndata
    ):
        return x
    a = np.array(x, dtype=np.float64)
    a.setflags(write=False)
    return a


def _first_bad(mask: NDArray[np.bool_], directions: Sequence[str]) -> str:
    p, d, m = (int(i) for i in np.argwhere(mask)[0][:3])
    return f"posture {p}, direction {directions[d]!r}, mode {m + 1}"


@dataclass(frozen=True, eq=False)
class ModalParameters:
    """Modal parameters at a batch of postures, per direction and mode.

    Parameters
    ----------
    f_hz : array_like, shape (n_postures, n_directions, n_modes)
        Natural frequencies [Hz]: > 0, or NaN where the mode is absent.
    zeta : array_like, shape (n_postures, n_directions, n_modes)
        Damping ratios (fraction): > 0, or NaN where absent.
    k_N_per_m : array_like, shape (n_postures, n_directions, n_modes)
        Modal stiffness [N/m] of the mode in that direction: non-zero, signed
        like the residue (an identification's reversed polarity, a cross
        direction), ``inf`` where the mode does not move that way, NaN where
        absent.
    directions : sequence of str, length n_directions
        Distinct direction names (``"xx"``, ``"yy"``, ``"zz"``; a cross
        direction such as ``"xy"`` is allowed), from :mod:`robolobe._directions`.
    log_std : array_like, shape (n_postures, n_directions, n_modes, 3), optional
        Spread: standard deviation of (log f, log zeta, log k), >= 0; NaN or
        ``inf`` where unknown. None: no spread.
    posture_ids : sequence of str, length n_postures, optional
        Names of the postures.
    q_rad : array_like, shape (n_postures, 6), optional
        Controller joint angles of the postures [rad] (needed by
        :meth:`to_frame`).

    Raises
    ------
    InputError
        On a shape, direction or value that breaks the rules above (the
        message says what was expected and what was found).

    Notes
    -----
    The arrays are read-only copies (a read-only float64 array that owns its
    data is taken as it is: nothing can change it). A mode is the same physical mode in
    every direction only if the producer says so (the twin's coupled modes
    repeat their frequency and damping in each direction); a predictor's or a
    ``modal.csv``'s mode ``r`` of one direction is independent of mode ``r``
    of another.

    Examples
    --------
    >>> p = ModalParameters([[[10.0]]], [[[0.05]]], [[[2e6]]], ("xx",))
    >>> p.shape, p.stacked()[0, 0, 0].tolist()
    ((1, 1, 1), [10.0, 0.05, 2000000.0])
    """

    f_hz: FloatArray
    zeta: FloatArray
    k_N_per_m: FloatArray
    directions: tuple[str, ...]
    log_std: FloatArray | None = None
    posture_ids: tuple[str, ...] | None = None
    q_rad: FloatArray | None = None

    def __post_init__(self) -> None:
        arrs = {}
        for name in PARAMETERS:
            try:
                a = _frozen_copy(getattr(self, name))
            except (TypeError, ValueError) as exc:
                raise InputError(f"ModalParameters.{name}: expected numbers ({exc})") from None
            if a.ndim != 3:
                raise InputError(
                    f"ModalParameters.{name}: expected shape (n_postures, n_directions, "
                    f"n_modes), found {a.shape}"
                )
            arrs[name] = a
        shape = arrs["f_hz"].shape
        for name in PARAMETERS[1:]:
            if arrs[name].shape != shape:
                raise InputError(
                    f"ModalParameters.{name}: expected the shape of f_hz {shape}, "
                    f"found {arrs[name].shape}"
                )
        if isinstance(self.directions, str):
            raise InputError(
                f"ModalParameters.directions: expected a sequence of names such as "
                f"('xx', 'yy'), found the string {self.directions!r}"
            )
        dirs = tuple(str(d) for d in self.directions)
        for d in dirs:
            if d not in ALL_DIRS:
                dir_index(d)  # raises with the vocabulary's message
        if len(dirs) != shape[1] or len(set(dirs)) != len(dirs):
            raise InputError(
                f"ModalParameters.directions: expected {shape[1]} distinct directions "
                f"(axis 1 of f_hz), found {dirs}"
            )
        f, z, k = arrs["f_hz"], arrs["zeta"], arrs["k_N_per_m"]
        for name, bad, rule in (
            ("f_hz", ~np.isnan(f) & ~(np.isfinite(f) & (f > 0)), "a frequency > 0 Hz or NaN"),
            ("zeta", ~np.isnan(z) & ~(np.isfinite(z) & (z > 0)), "a damping ratio > 0 or NaN"),
            ("k_N_per_m", k == 0, "a non-zero stiffness [N/m], inf or NaN"),
        ):
            if np.any(bad):
                first = _first_bad(bad, dirs)
                raise InputError(
                    f"ModalParameters.{name}: expected {rule}, found "
                    f"{float(arrs[name][bad][0])!r} at {first} ({int(bad.sum())} value(s))"
                )
        for name, a in arrs.items():
            object.__setattr__(self, name, a)
        object.__setattr__(self, "directions", dirs)
        if self.log_std is not None:
            s = _frozen_copy(self.log_std)
            if s.shape != (*shape, 3):
                raise InputError(
                    f"ModalParameters.log_std: expected shape {(*shape, 3)} (std of log f, "
                    f"log zeta, log k), found {s.shape}"
                )
            if np.any(s < 0):
                raise InputError(
                    "ModalParameters.log_std: expected standard deviations >= 0 (NaN or inf: "
                    f"unknown), found {float(s[s < 0][0])!r}"
                )
            object.__setattr__(self, "log_std", s)
        if self.posture_ids is not None:
            if isinstance(self.posture_ids, str):
                raise InputError(
                    "ModalParameters.posture_ids: expected a sequence of ids, found the string "
                    f"{self.posture_ids!r}"
                )
            ids = tuple(str(p) for p in self.posture_ids)
            if len(ids) != shape[0]:
                raise InputError(
                    f"ModalParameters.posture_ids: expected {shape[0]} ids (axis 0 of f_hz), "
                    f"found {len(ids)}"
                )
            object.__setattr__(self, "posture_ids", ids)
        if self.q_rad is not None:
            q = np.array(self.q_rad, dtype=np.float64)
            if q.shape != (shape[0], 6):
                raise InputError(
                    f"ModalParameters.q_rad: expected shape ({shape[0]}, 6), found {q.shape}"
                )
            if not np.all(np.isfinite(q)):
                raise InputError("ModalParameters.q_rad: expected finite joint angles [rad]")
            q.setflags(write=False)
            object.__setattr__(self, "q_rad", q)

    # ------------------------------------------------------------ shape
    @property
    def shape(self) -> tuple[int, int, int]:
        """``(n_postures, n_directions, n_modes)``."""
        n, d, m = self.f_hz.shape
        return int(n), int(d), int(m)

    @property
    def n_postures(self) -> int:
        """Number of postures."""
        return self.shape[0]

    @property
    def n_modes(self) -> int:
        """Modes per direction."""
        return self.shape[2]

    def stacked(self) -> FloatArray:
        """``(f_hz, zeta, k_N_per_m)`` on a last axis, shape (n_postures, n_dir, n_modes, 3)."""
        return np.stack([self.f_hz, self.zeta, self.k_N_per_m], axis=-1)

    @classmethod
    def from_stacked(
        cls,
        values: ArrayLike,
        directions: Sequence[str],
        *,
        log_std: ArrayLike | None = None,
        posture_ids: Sequence[str] | None = None,
        q_rad: ArrayLike | None = None,
    ) -> ModalParameters:
        """From values stacked as :meth:`stacked` returns them, shape (n, n_dir, n_modes, 3)."""
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 4 or v.shape[-1] != 3:
            raise InputError(
                f"values: expected shape (n_postures, n_directions, n_modes, 3), found {v.shape}"
            )
        return cls(
            v[..., 0],
            v[..., 1],
            v[..., 2],
            tuple(directions),
            log_std=None if log_std is None else np.asarray(log_std, dtype=np.float64),
            posture_ids=None if posture_ids is None else tuple(posture_ids),
            q_rad=None if q_rad is None else np.asarray(q_rad, dtype=np.float64),
        )

    def select(self, directions: Sequence[str]) -> ModalParameters:
        """The parameters on ``directions``, in that order.

        A direction these parameters do not hold has every mode absent
        (NaN parameters and spread): e.g. a predictor of x and y put on the
        planner's ``("xx", "yy", "zz")``.

        Parameters
        ----------
        directions : sequence of str
            Distinct names of :mod:`robolobe._directions`.

        Returns
        -------
        ModalParameters
        """
        dirs = tuple(directions)
        n, _, m = self.shape
        out = np.full((n, len(dirs), m, 3), np.nan)
        std = None if self.log_std is None else np.full((n, len(dirs), m, 3), np.nan)
        vals = self.stacked()
        for j, d in enumerate(dirs):
            if d in self.directions:
                i = self.directions.index(d)
                out[:, j] = vals[:, i]
                if std is not None and self.log_std is not None:
                    std[:, j] = self.log_std[:, i]
        return ModalParameters.from_stacked(
            out, dirs, log_std=std, posture_ids=self.posture_ids, q_rad=self.q_rad
        )

    # ------------------------------------------------------------ modal.csv
    def to_frame(self, extra: Mapping[str, ArrayLike] | None = None) -> pd.DataFrame:
        """The ``modal.csv`` long table (docs/guide/modal.md); absent modes are left out.

        Parameters
        ----------
        extra : mapping of str to array_like, shape (n_postures, n_directions, n_modes), optional
            Extra per-value columns (e.g. spreads) appended after the modal.csv ones.

        Returns
        -------
        pandas.DataFrame
            Columns ``posture_id, q1_deg..q6_deg, dir, mode, f_hz, zeta,
            k_N_per_m`` (+ extras), one row per posture, direction and mode
            (in that order) whose three parameters are finite; ``mode``
            counts from 1. Write it with
            :func:`robolobe.modal.modal_csv.write_modal_csv` (which validates
            the file's rules).

        Raises
        ------
        InputError
            Without :attr:`posture_ids` and :attr:`q_rad` (the table names
            each posture and its joint angles).
        """
        if self.posture_ids is None or self.q_rad is None:
            raise InputError(
                "ModalParameters.to_frame: expected posture_ids and q_rad (modal.csv names each "
                "posture and its joint angles), found "
                f"posture_ids={'set' if self.posture_ids is not None else None}, "
                f"q_rad={'set' if self.q_rad is not None else None}"
            )
        n, nd, nm = self.shape
        grids = np.meshgrid(np.arange(n), np.arange(nd), np.arange(nm), indexing="ij")
        p_idx, d_idx, m_idx = (g.ravel() for g in grids)
        vals = self.stacked().reshape(-1, 3)
        keep = np.all(np.isfinite(vals), axis=1)
        qd = np.degrees(self.q_rad)
        data: dict[str, Any] = {"posture_id": np.asarray(self.posture_ids, dtype=object)[p_idx]}
        for j, c in enumerate(Q_COLUMNS):
            data[c] = qd[p_idx, j]
        data["dir"] = np.asarray(self.directions, dtype=object)[d_idx]
        data["mode"] = m_idx + 1
        for i, name in enumerate(PARAMETERS):
            data[name] = vals[:, i]
        for name, arr in (extra or {}).items():
            data[name] = np.asarray(arr, dtype=float).reshape(-1)
        import pandas as pd  # only for the table: sld and the twin need no pandas

        df = pd.DataFrame(data)
        return df.loc[keep].reset_index(drop=True)

    @classmethod
    def from_frame(
        cls,
        df: pd.DataFrame,
        *,
        directions: Sequence[str] | None = None,
        n_modes: int | None = None,
        source: str = "modal dataset",
    ) -> ModalParameters:
        """The parameters of a ``modal.csv`` long table.

        Parameters
        ----------
        df : pandas.DataFrame
            As :func:`robolobe.modal.modal_csv.read_modal_csv` returns it
            (validated): ``posture_id, q1_deg..q6_deg, dir, mode, f_hz,
            zeta, k_N_per_m``.
        directions : sequence of str, optional
            Driving-point directions to keep, in that order; default every
            driving point with rows, in the order ``xx, yy, zz``.
        n_modes : int, optional
            Modes per direction; higher modes are ignored, missing ones are
            absent (NaN). Default: the highest mode number in the table.
        source : str
            Name used in messages.

        Returns
        -------
        ModalParameters
            Postures in order of first appearance, with their ids and joint
            angles (those of each posture's first row); no spread.

        Raises
        ------
        InputError
            A missing column, a direction that is not a driving point or has
            no rows, ``n_modes < 1``, or values that break the type's rules.
        """
        need = ["posture_id", *Q_COLUMNS, "dir", "mode", *PARAMETERS]
        missing = [c for c in need if c not in df.columns]
        if missing:
            raise InputError(f"expected columns {need}; missing {missing}", source=source)
        dirs = df["dir"].astype(str).str.lower().to_numpy()
        if directions is None:
            directions = tuple(d for d in DRIVING if d in set(dirs.tolist()))
        directions = tuple(directions)
        if not directions:
            raise InputError(
                f"expected driving-point rows (dir {', '.join(DRIVING)}), found dirs "
                f"{sorted(set(dirs.tolist()))}",
                source=source,
            )
        modes = df["mode"].to_numpy(dtype=int)
        if n_modes is None:
            n_modes = int(modes.max()) if modes.size else 0
        if n_modes < 1:
            raise InputError(f"n_modes: expected >= 1, found {n_modes}", source=source)
        ids = list(dict.fromkeys(df["posture_id"].astype(str)))
        if not ids:
            raise InputError("expected at least one posture, found none", source=source)
        pos = {p: i for i, p in enumerate(ids)}
        first = df.drop_duplicates("posture_id")
        q_deg = (
            first.set_index(first["posture_id"].astype(str))
            .loc[ids, list(Q_COLUMNS)]
            .to_numpy(dtype=float)
        )
        y = np.full((len(ids), len(directions), n_modes, 3), np.nan)
        pidx = df["posture_id"].astype(str).map(pos).to_numpy()
        vals = df[list(PARAMETERS)].to_numpy(dtype=float)
        for j, d in enumerate(directions):
            if d not in DRIVING:
                raise InputError(
                    f"directions: expected driving points {DRIVING}, found {d!r}", source=source
                )
            sel = (dirs == d) & (modes <= n_modes)
            if not np.any(dirs == d):
                raise InputError(
                    f"direction {d!r}: expected rows for it, found none (directions in the "
                    f"file: {sorted(set(dirs.tolist()))})",
                    source=source,
                )
            y[pidx[sel], j, modes[sel] - 1, :] = vals[sel]
        return cls.from_stacked(y, directions, posture_ids=ids, q_rad=np.radians(q_deg))
