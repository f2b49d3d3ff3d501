"""Input features, min-max scaling, target transforms and augmentation.

The seed (section 2.3, eq. 1-2): inputs are the six joint angles, targets the
15 modal values of a direction; both are min-max scaled to [0, 1] with the
minimum and maximum of the training data; the training set is augmented with
``X + U(-delta, delta)``, ``delta = 0.10``.

Decisions where the paper is silent (documented in the README):

* ``delta`` applies to the **min-max-scaled joint angles**: each augmented
  copy moves every joint by up to 10 % of that joint's training range; the
  targets of a copy are those of the original posture. Noise on raw degrees
  (0.1 deg) would do nothing, noise on raw targets would swamp damping.
* The augmented copies are drawn once (``copies`` of them, default 4 -> 5x
  the data), each ensemble member with its own draw.
* Scalers are refitted on each robot's own training data (the seed's
  ``process_data()`` runs per robot), also for a transferred model.

Improvements measured against the paper (tl_accuracy study):

* ``features="trig"``: ``sin q, cos q`` of every joint (12 inputs): the map is
  periodic in the wrist angles, which raw angles over +-300 deg hide.
* ``target_transform="log"``: log of frequency, damping and stiffness before
  min-max: these are positive and spread over decades (stiffness 3e4-3e6 N/m).
* ``target_transform="flex"``: log frequency, log damping and the
  sqrt-compliance ``c = sqrt(K_REF / k)`` (``K_REF`` = 1e6 N/m) of each mode
  at the driving point, which is ``|u_d| / w`` (u = J phi): a smooth function
  of the posture that goes to 0 where a mode stops moving the TCP along d,
  where ``k`` and ``log k`` blow up. A missing stiffness is read as "mode not
  seen at this driving point" (c = 0: no contribution to the FRF); missing
  frequencies and damping are left out of the loss.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = [
    "C_MIN",
    "FEATURES",
    "K_REF_N_PER_M",
    "TARGET_TRANSFORMS",
    "Features",
    "MinMax",
    "TargetTransform",
    "augment_angles",
    "features",
    "n_features",
]

FloatArray = NDArray[np.float64]
Features = Literal["angles", "trig", "trig5", "dh5"]
FEATURES: tuple[str, ...] = ("angles", "trig", "trig5", "dh5")
TARGET_TRANSFORMS: tuple[str, ...] = ("minmax", "log", "flex")
#: Reference stiffness of the ``"flex"`` transform [N/m].
K_REF_N_PER_M = 1.0e6
#: Smallest sqrt-compliance a ``"flex"`` model returns (k <= 1e12 N/m: no contribution).
C_MIN = 1.0e-3


@dataclass(frozen=True, eq=False)
class MinMax:
    """Min-max scaling ``(x - lo) / (hi - lo)`` per column.

    Attributes
    ----------
    lo, hi : ndarray, shape (...,)
        Column minimum and maximum of the data it was fitted on. A constant
        column (``hi == lo``) maps to 0.
    """

    lo: FloatArray
    hi: FloatArray

    @classmethod
    def fit(cls, x: ArrayLike, axis: int = 0) -> MinMax:
        """Fit on ``x`` along ``axis``, ignoring NaN."""
        a = np.asarray(x, dtype=float)
        with np.errstate(all="ignore"):
            lo = np.nanmin(a, axis=axis) if np.any(np.isfinite(a)) else np.zeros(1)
            hi = np.nanmax(a, axis=axis) if np.any(np.isfinite(a)) else np.ones(1)
        lo = np.where(np.isfinite(lo), lo, 0.0)
        hi = np.where(np.isfinite(hi), hi, lo + 1.0)
        return cls(lo=np.asarray(lo, dtype=float), hi=np.asarray(hi, dtype=float))

    @property
    def scale(self) -> FloatArray:
        """``hi - lo`` with constant columns mapped to 1."""
        s = self.hi - self.lo
        return np.where(s > 0, s, 1.0)

    def transform(self, x: ArrayLike) -> FloatArray:
        """Scale ``x`` (columns last)."""
        return (np.asarray(x, dtype=float) - self.lo) / self.scale

    def inverse(self, z: ArrayLike) -> FloatArray:
        """Undo :meth:`transform`."""
        return np.asarray(z, dtype=float) * self.scale + self.lo

    def to_dict(self) -> dict[str, list[float]]:
        """Plain JSON-able form."""
        return {
            "lo": self.lo.ravel().tolist(),
            "hi": self.hi.ravel().tolist(),
            "shape": list(self.lo.shape),
        }

    @classmethod
    def from_dict(cls, d: dict[str, list[float]]) -> MinMax:
        """Rebuild from :meth:`to_dict`."""
        shape = tuple(int(s) for s in d.get("shape", [len(d["lo"])]))
        lo = np.asarray(d["lo"], dtype=float).reshape(shape)
        hi = np.asarray(d["hi"], dtype=float).reshape(shape)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(hi >= lo)):
            raise ValueError("scaler: expected finite lo <= hi")  # a stored scaler that lies
        return cls(lo=lo, hi=hi)


def n_features(kind: str) -> int:
    """Number of network inputs for a feature kind."""
    if kind == "angles":
        return 6
    if kind == "trig":
        return 12
    if kind in ("trig5", "dh5"):
        return 10
    raise InputError(f"features: expected one of {FEATURES}, found {kind!r}")


def features(
    q_rad: ArrayLike,
    kind: str,
    scaler: MinMax,
    dh_map: tuple[ArrayLike, ArrayLike] | None = None,
) -> FloatArray:
    """Network inputs from joint angles.

    Parameters
    ----------
    q_rad : array_like, shape (..., 6)
        Joint angles [rad].
    kind : {"angles", "trig", "trig5", "dh5"}
        ``"angles"``: min-max-scaled angles (the seed); ``"trig"``: ``sin q``
        and ``cos q`` of the six joints; ``"trig5"``: the same for joints 2-6
        (joint 1 turns the whole arm about the vertical: without gravity
        effects it changes no mode); ``"dh5"``: sin and cos of the DH angles
        2-6, ``theta = coupling q + offset`` (relative link angles: the same
        meaning on a serial arm and on a parallelogram arm, whose axis 3 is
        absolute).
    scaler : MinMax
        The joint-angle scaler fitted on the training postures.
    dh_map : (coupling (6, 6), theta_offset_rad (6,)), optional
        Needed for ``"dh5"`` (from the robot file).

    Returns
    -------
    ndarray, shape (..., n_features(kind))
    """
    q = np.asarray(q_rad, dtype=float)
    if kind == "angles":
        return scaler.transform(q)
    if kind == "trig":
        return np.concatenate([np.sin(q), np.cos(q)], axis=-1)
    if kind == "trig5":
        return np.concatenate([np.sin(q[..., 1:]), np.cos(q[..., 1:])], axis=-1)
    if kind == "dh5":
        if dh_map is None:
            raise InputError("features 'dh5' need the robot's coupling and theta offsets")
        coupling = np.asarray(dh_map[0], dtype=float)
        offset = np.asarray(dh_map[1], dtype=float)
        th = q @ coupling.T + offset
        return np.concatenate([np.sin(th[..., 1:]), np.cos(th[..., 1:])], axis=-1)
    raise InputError(f"features: expected one of {FEATURES}, found {kind!r}")


def augment_angles(
    q_rad: ArrayLike,
    scaler: MinMax,
    *,
    delta: float,
    copies: int,
    rng: np.random.Generator,
) -> FloatArray:
    """The seed's augmentation ``X + U(-delta, delta)`` on min-max-scaled angles.

    Parameters
    ----------
    q_rad : array_like, shape (n, 6)
        Training postures [rad].
    scaler : MinMax
        Joint-angle scaler (its range sets the size of a unit of ``delta``).
    delta : float
        Half-width of the uniform perturbation, in scaled units (0.10 = 10 %
        of each joint's training range).
    copies : int
        Number of perturbed copies; the originals come first.

    Returns
    -------
    ndarray, shape ((1 + copies) * n, 6)
        Original postures followed by the copies [rad].
    """
    q = np.asarray(q_rad, dtype=float)
    if copies <= 0 or delta <= 0:
        return q.copy()
    noise = rng.uniform(-delta, delta, size=(copies, *q.shape)) * scaler.scale
    return np.concatenate([q[None], q[None] + noise]).reshape(-1, q.shape[-1])


@dataclass(frozen=True, eq=False)
class TargetTransform:
    """Targets -> network outputs: optional log, then min-max per output.

    Attributes
    ----------
    kind : {"minmax", "log"}
    scaler : MinMax
        Per (direction, mode, parameter) range of the (logged) training targets,
        arrays of shape (n_dir, n_modes, 3).
    """

    kind: str
    scaler: MinMax

    @staticmethod
    def _pre(y: ArrayLike, kind: str) -> FloatArray:
        a = np.asarray(y, dtype=float)
        if kind == "minmax":
            return a.copy()
        if kind not in TARGET_TRANSFORMS:
            raise InputError(
                f"target_transform: expected one of {TARGET_TRANSFORMS}, found {kind!r}"
            )
        with np.errstate(invalid="ignore", divide="ignore"):
            out = np.log(np.where(a > 0, a, np.nan))
            if kind == "flex":
                k = a[..., 2]
                c = np.sqrt(K_REF_N_PER_M / np.where(k > 0, k, np.nan))
                out[..., 2] = np.where(np.isnan(k), 0.0, c)
        return out

    @classmethod
    def fit(cls, y: ArrayLike, kind: str) -> TargetTransform:
        """Fit on targets of shape (n, n_dir, n_modes, 3) (NaN ignored)."""
        return cls(kind=kind, scaler=MinMax.fit(cls._pre(y, kind), axis=0))

    def pre(self, y: ArrayLike) -> FloatArray:
        """The targets in the space spreads live in (log / sqrt-compliance)."""
        return self._pre(y, self.kind)

    def post(self, z: ArrayLike) -> FloatArray:
        """Undo :meth:`pre` (``"flex"``: c below ``C_MIN`` -> ``K_REF / C_MIN**2``)."""
        a = np.asarray(z, dtype=float)
        if self.kind == "minmax":
            return a
        out = np.exp(a)
        if self.kind == "flex":
            out[..., 2] = K_REF_N_PER_M / np.maximum(a[..., 2], C_MIN) ** 2
        return out

    def transform(self, y: ArrayLike) -> FloatArray:
        """Targets (..., n_dir, n_modes, 3) -> scaled outputs."""
        return self.scaler.transform(self.pre(y))

    def inverse(self, z: ArrayLike) -> FloatArray:
        """Scaled outputs -> targets."""
        return self.post(self.scaler.inverse(z))

    def to_dict(self) -> dict[str, object]:
        """Plain JSON-able form."""
        return {"kind": self.kind, "scaler": self.scaler.to_dict()}

    @classmethod
    def from_dict(cls, d: dict[str, object]) -> TargetTransform:
        """Rebuild from :meth:`to_dict`."""
        sc = d["scaler"]
        if not isinstance(sc, dict):
            raise TypeError(f"target_transform.scaler: expected a table, found {type(sc).__name__}")
        return cls(kind=str(d["kind"]), scaler=MinMax.from_dict(sc))
