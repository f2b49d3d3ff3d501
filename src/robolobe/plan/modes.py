"""Where the robot's posture-dependent modes come from: a tl model or the twin.

A *mode source* turns postures ``q`` (n, 6) [rad] into :class:`RobotModes`:
modal parameters per TCP direction (x, y, z of the TCP frame) with their
spread, and a 3-D :class:`~robolobe.sld.frf.ModalModel` of the TCP
receptance for the tool-point FRF.

- :class:`PredictorSource`: a :class:`robolobe.tl.estimator.ModalPredictor`
  (the shipped model of A, B or C, or a model file). Driving-point modes per
  direction, no cross terms (that is what a triaxial hammer campaign
  identifies); spread from the ensemble.
- :class:`TwinSource`: the exact nominal modes of the robot file
  (:meth:`robolobe.twin.model.Twin.modes`), coupled 3x3 residues from the
  mode shapes, no spread.

:func:`mode_source` picks one from a job's ``robot.model``.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.robots.model import Robot
from robolobe.sld.frf import ModalModel
from robolobe.twin.effects import Effect

__all__ = [
    "ModeSource",
    "PredictorSource",
    "RobotModes",
    "TwinSource",
    "mode_source",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
_DIRS = ("xx", "yy", "zz")


@dataclass(frozen=True, eq=False)
class RobotModes:
    """Robot modes at a batch of postures, per TCP direction.

    Attributes
    ----------
    f_hz, zeta, k_N_per_m : ndarray, shape (n, 3, n_modes)
        Natural frequency [Hz], damping ratio, modal stiffness [N/m] per TCP
        direction x, y, z (``inf`` stiffness: the mode does not move the TCP
        that way; NaN: no such mode).
    log_std : ndarray, shape (n, 3, n_modes, 3) or None
        Standard deviation of (log f, log zeta, log k); None without spread.
    model : ModalModel
        TCP-frame receptance model, dim 3, batch (n,).
    extrapolation : ndarray, shape (n,) or None
        How far each posture lies outside the model's training range (0 inside;
        0.1 = 10 % of a joint's range beyond).
    source : str
        Description (``"tl model A (shipped)"``, ``"twin"``, a file name).
    """

    f_hz: FloatArray
    zeta: FloatArray
    k_N_per_m: FloatArray
    log_std: FloatArray | None
    model: ModalModel
    extrapolation: FloatArray | None
    source: str

    def scenarios(self, k_sigma: float) -> list[ModalModel]:
        """Robust scenario models: lower k and zeta by ``k_sigma``, f shifted -, 0, +.

        Empty without spread (or ``k_sigma == 0``).
        """
        if self.log_std is None or k_sigma <= 0 or not np.any(self.log_std > 0):
            return []
        s = k_sigma * np.nan_to_num(self.log_std)
        z_lo = self.zeta * np.exp(-s[..., 1])
        k_lo = self.k_N_per_m * np.exp(-s[..., 2])
        return [
            _directional(self.f_hz * np.exp(sign * s[..., 0]), z_lo, k_lo)
            for sign in (-1.0, 0.0, 1.0)
        ]


def _directional(f: FloatArray, z: FloatArray, k: FloatArray) -> ModalModel:
    """3-D model from per-direction modes (n, 3, m); NaN/inf entries are absent."""
    n, nd, m = f.shape
    ok = np.isfinite(f) & np.isfinite(z) & np.isfinite(k) & (k > 0)
    ff = np.where(ok, f, np.nan).reshape(n, nd * m)
    zz = np.where(ok, z, np.nan).reshape(n, nd * m)
    kk = np.where(ok, k, np.nan).reshape(n, nd * m)
    dirs = [d for d in _DIRS[:nd] for _ in range(m)]
    return ModalModel.from_directional(ff, zz, kk, dirs, dim=3)


class ModeSource(Protocol):
    """Anything that predicts robot modes at postures."""

    name: str

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        """Modes at postures ``q_rad`` (n, 6)."""
        ...


class PredictorSource:
    """Modes from a fitted :class:`robolobe.tl.estimator.ModalPredictor`.

    Parameters
    ----------
    predictor : ModalPredictor
    name : str
        Description for reports.
    """

    def __init__(self, predictor: object, name: str) -> None:
        self.predictor = predictor
        self.name = name

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        pred = self.predictor.predict(q, warn=False)  # type: ignore[attr-defined]
        dirs = tuple(pred.directions)
        vals = np.asarray(pred.values)  # (n, n_dir, m, 3)
        # relative spread (std of log value) whatever the model's output kind
        std = np.nan_to_num(np.asarray(pred.log_std), nan=0.0, posinf=0.0)
        n, _, m, _ = vals.shape
        full = np.full((n, 3, m, 3), np.nan)
        full_std = np.zeros((n, 3, m, 3))
        for d, name in enumerate(dirs):
            if name not in _DIRS:
                raise InputError(f"model direction {name!r}: expected driving points xx, yy, zz")
            full[:, _DIRS.index(name)] = vals[:, d]
            full_std[:, _DIRS.index(name)] = std[:, d]
        f, z, k = full[..., 0], full[..., 1], full[..., 2]
        extr = np.asarray(self.predictor.extrapolation(q))  # type: ignore[attr-defined]
        return RobotModes(
            f_hz=f,
            zeta=z,
            k_N_per_m=k,
            log_std=full_std,
            model=_directional(f, z, k),
            extrapolation=extr,
            source=self.name,
        )


class TwinSource:
    """Exact nominal modes of the robot file (no spread).

    Parameters
    ----------
    robot : Robot
    """

    def __init__(self, robot: Robot, effects: Sequence[Effect] = ()) -> None:
        from robolobe.twin.model import Twin

        self.twin = Twin(robot, tuple(effects))
        names = ", ".join(e.name for e in effects)
        self.name = f"twin of {robot.name}" + (f" + {names}" if names else "")

    def predict(self, q_rad: ArrayLike) -> RobotModes:
        q = np.asarray(q_rad, dtype=np.float64).reshape(-1, 6)
        md = self.twin.modes(q)
        f = np.asarray(md.f_hz)  # (n, m)
        z = np.asarray(md.zeta)
        u = np.asarray(md.tcp_shapes)  # (n, 3, m)
        k = np.asarray(md.k_N_per_m)  # (n, 3, m)
        n, m = f.shape
        keep = np.isfinite(f) & (f > 0) & (z > 0) & (z < 1)
        model = ModalModel.from_shapes(
            2 * np.pi * np.where(keep, f, 1.0),
            np.where(keep, z, 0.05),
            np.swapaxes(np.where(keep[:, None, :], u, 0.0), -1, -2),
        )
        return RobotModes(
            f_hz=np.broadcast_to(f[:, None, :], (n, 3, m)).copy(),
            zeta=np.broadcast_to(z[:, None, :], (n, 3, m)).copy(),
            k_N_per_m=k,
            log_std=None,
            model=model,
            extrapolation=None,
            source=self.name,
        )


def mode_source(
    model: str, robot: Robot, robot_key: str, effects: Sequence[Effect] = ()
) -> tuple[ModeSource, str]:
    """The mode source a job asks for.

    Parameters
    ----------
    model : str
        ``"builtin"`` (the shipped tl model of A, B or C), ``"twin"`` or the
        path of a tl model file.
    robot : Robot
    robot_key : str
        ``"A"``, ``"B"``, ``"C"`` or the robot file.
    effects : sequence of Effect
        Physics effects added to the twin (``model = "twin"`` only).

    Returns
    -------
    (ModeSource, str)
        The source and a note (non-empty when a fallback was used).

    Raises
    ------
    InputError
        A model file that cannot be read, or ``builtin`` for a robot file.
    """
    if model == "twin":
        return TwinSource(robot, effects), ""
    if effects:
        raise InputError(
            f"robot.effects: physics effects act on the twin; expected robot.model = 'twin', "
            f"found {model!r}"
        )
    from robolobe.tl.models import load_model

    if model == "builtin":
        if robot_key not in ("A", "B", "C"):
            raise InputError(
                "robot.model: 'builtin' models exist for robots A, B and C only; for a robot "
                "file give model = 'twin' or the path of a tl model",
            )
        try:
            pred = load_model(robot_key)
        except InputError as exc:
            note = f"shipped tl model of {robot_key} unavailable ({exc}); using the twin"
            logger.info(note)
            return TwinSource(robot), note
        return PredictorSource(pred, f"tl model {robot_key} (shipped)"), ""
    pred = load_model(Path(model))
    return PredictorSource(pred, f"tl model {Path(model).name}"), ""
