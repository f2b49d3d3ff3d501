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

:func:`mode_source` picks one from a job's ``robot.model``; the default is the
twin: the shipped networks miss their own robot's twin by 3-15 % in
frequency and 20-300 % in stiffness over the workspace (README, planning).
"""

from __future__ import annotations

import logging
import math
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
    "RobustBound",
    "TwinSource",
    "as_mode_source",
    "mode_source",
]

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
_DIRS = ("xx", "yy", "zz")
#: Largest log spread (per sigma) a robust plan takes from a source: a larger one says
#: the source does not know (e.g. a network's stiffness of a mode it calls not visible),
#: and lowering a stiffness by exp(-k_sigma * 3) would plan on a robot that does not exist.
MAX_LOG_STD = 0.35
#: Largest relative speed window (frequency uncertainty) of a robust plan.
MAX_WINDOW = 0.25
#: Modal stiffness [N/m] from which a mode counts as not visible in a direction.
INVISIBLE_K = 1e11


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
    shapes_coupled : bool
        True when ``model`` holds one set of coupled modes (the twin's, the
        same in every direction); False for per-direction modes (a predictor).
    """

    f_hz: FloatArray
    zeta: FloatArray
    k_N_per_m: FloatArray
    log_std: FloatArray | None
    model: ModalModel
    extrapolation: FloatArray | None
    source: str
    shapes_coupled: bool = False

    def robust(self, k_sigma: float, assumed: Sequence[float] = ()) -> RobustBound | None:
        """The robust bound of these modes: stiffness and damping lowered, a speed window.

        Each visible mode's stiffness and damping are lowered by ``k_sigma``
        standard deviations of their log spread (capped at
        :data:`MAX_LOG_STD` per sigma); frequencies keep their nominal values
        and their uncertainty becomes a relative speed window
        ``+-k_sigma * std(log f)`` (the lobes of modes all shifted by a factor
        ``r`` are the lobes at speed ``Omega / r``): the planner takes the
        smallest limit inside that window, which keeps speeds away from steep
        lobe walls. Modes that are not visible in a direction (stiffness at
        least :data:`INVISIBLE_K`, or none) keep it: a spread of a mode that a
        test cannot see is not a spread of its stiffness.

        Parameters
        ----------
        k_sigma : float
            Width of the bound in standard deviations (0: no bound).
        assumed : (float, float, float)
            Spread (std of log f, log zeta, log k) used where the source has
            none (the twin); empty: no bound without a source spread.

        Returns
        -------
        RobustBound or None
            None when ``k_sigma`` is 0 or there is no spread.
        """
        if k_sigma <= 0:
            return None
        n, nd, m = self.f_hz.shape
        if self.log_std is not None and np.any(self.log_std > 0):
            std = np.clip(np.nan_to_num(self.log_std, nan=0.0, posinf=0.0), 0.0, MAX_LOG_STD)
            how = f"{self.source}'s prediction spread"
        elif len(assumed) == 3 and any(a > 0 for a in assumed):
            std = np.broadcast_to(
                np.clip(np.asarray(assumed, dtype=np.float64), 0.0, MAX_LOG_STD), (n, nd, m, 3)
            ).copy()
            how = "the job's assumed spread (the mode source has none)"
        else:
            return None
        s = k_sigma * std
        visible = np.isfinite(self.k_N_per_m) & (np.abs(self.k_N_per_m) < INVISIBLE_K)
        s = np.where(visible[..., None], s, 0.0)
        model = self.model
        if self.shapes_coupled:
            # one set of modes seen in all directions: a mode's spread is its largest
            sm = s.max(axis=1)  # (n, m, 3)
            f_scale = np.ones((n, m))
            z_scale = np.exp(-sm[..., 1])
            r_scale = np.exp(sm[..., 2])
        else:
            sm = s.reshape(n, nd * m, 3)
            f_scale = np.ones((n, nd * m))
            z_scale = np.exp(-sm[..., 1])
            r_scale = np.exp(sm[..., 2])
        lowered = ModalModel(
            model.omega * f_scale,
            model.zeta * z_scale,
            model.residues * r_scale[..., None, None],
        )
        # the speed window: the largest frequency spread of the modes that matter at
        # each posture (peak compliance at least 5 % of the largest)
        peak = np.abs(np.trace(model.residues, axis1=-2, axis2=-1)) / (
            2.0 * model.zeta * model.omega**2
        )
        matter = peak >= 0.05 * peak.max(axis=1, keepdims=True)
        window = np.minimum(np.max(np.where(matter, sm[..., 0], 0.0), axis=1), MAX_WINDOW)
        return RobustBound(
            model=lowered,
            window=np.asarray(window, dtype=np.float64),
            k_sigma=float(k_sigma),
            std_max=np.asarray(std.reshape(-1, 3).max(axis=0), dtype=np.float64),
            how=how,
        )


@dataclass(frozen=True, eq=False)
class RobustBound:
    """What robust planning plans on (see :meth:`RobotModes.robust`).

    Attributes
    ----------
    model : ModalModel
        TCP-frame model with stiffness and damping lowered, batch (n,).
    window : ndarray, shape (n,)
        Relative half-width of the speed window (frequency uncertainty).
    k_sigma : float
    std_max : ndarray, shape (3,)
        Largest spread used (std of log f, log zeta, log k).
    how : str
        Where the spread came from.
    """

    model: ModalModel
    window: FloatArray
    k_sigma: float
    std_max: FloatArray
    how: str

    @property
    def confidence(self) -> float:
        """One-sided normal probability that a quantity lies inside its bound."""
        return 0.5 * (1.0 + math.erf(self.k_sigma / math.sqrt(2.0)))

    def describe(self) -> dict[str, object]:
        """JSON-ready statement of the bound."""
        sf, sz, sk = (float(v) for v in self.std_max)
        ks = self.k_sigma
        return {
            "k_sigma": ks,
            "confidence_pct": round(100.0 * self.confidence, 2),
            "spread_from": self.how,
            "frequency_window_pct_max": round(100.0 * float(np.max(self.window, initial=0.0)), 3),
            "frequency_window_pct_median": round(
                100.0 * float(np.median(self.window)) if self.window.size else 0.0, 3
            ),
            "stiffness_lowered_to_pct": round(100.0 * math.exp(-ks * sk), 2),
            "damping_lowered_to_pct": round(100.0 * math.exp(-ks * sz), 2),
            "statement": (
                f"each mode's frequency within "
                f"+-{100 * min(math.exp(ks * sf) - 1, MAX_WINDOW):.2g} %, "
                f"stiffness above {100 * math.exp(-ks * sk):.3g} % and damping above "
                f"{100 * math.exp(-ks * sz):.3g} % of the prediction (k_sigma = {ks:g}: "
                f"{100 * self.confidence:.1f} % one-sided per quantity if the spread is "
                "normal in log)"
            ),
        }


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
    """Exact nominal modes of the robot file (no spread unless given).

    Parameters
    ----------
    robot : Robot
    effects : sequence of Effect
        Physics effects added to the twin.
    spread : (float, float, float), optional
        Spread of its modes (std of log f, log zeta, log k), e.g. a calibrated
        twin's residual scatter (:attr:`robolobe.tl.graybox.TwinCalibration.residual_rms_`);
        default none (robust plans then take the job's assumed spread).
    """

    def __init__(
        self,
        robot: Robot,
        effects: Sequence[Effect] = (),
        spread: Sequence[float] | None = None,
    ) -> None:
        from robolobe.twin.model import Twin

        self.twin = Twin(robot, tuple(effects))
        names = ", ".join(e.name for e in effects)
        self.name = f"twin of {robot.name}" + (f" + {names}" if names else "")
        if spread is not None:
            sp = np.asarray(spread, dtype=np.float64)
            if sp.shape != (3,) or not np.all(np.isfinite(sp)) or np.any(sp < 0):
                raise InputError(f"spread: expected 3 non-negative log spreads, found {spread!r}")
            self.spread: FloatArray | None = sp
        else:
            self.spread = None

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
            log_std=None
            if self.spread is None
            else np.broadcast_to(self.spread, (n, 3, m, 3)).copy(),
            model=model,
            extrapolation=None,
            source=self.name,
            shapes_coupled=True,
        )


def as_mode_source(modes: object) -> ModeSource:
    """Any mode predictor as the planner's mode source.

    Parameters
    ----------
    modes : object
        A mode source (``PredictorSource``, ``TwinSource`` or anything with
        ``name`` and ``predict(q) -> RobotModes``); a :class:`Robot` (its
        twin); a fitted ``TwinCalibration`` (the calibrated twin with its
        residual spread); or a fitted ``ModalPredictor`` / ``CorrectedTwin``
        (anything whose ``predict(q)`` returns a ``ModalPrediction`` and that
        has ``extrapolation(q)``).

    Returns
    -------
    ModeSource

    Raises
    ------
    InputError
        For anything else, or an estimator that is not fitted.
    """
    if isinstance(modes, PredictorSource | TwinSource):
        return modes
    if isinstance(modes, Robot):
        return TwinSource(modes)
    robot = getattr(modes, "robot_", None)
    rms = getattr(modes, "residual_rms_", None)
    if isinstance(robot, Robot) and isinstance(rms, dict) and not hasattr(modes, "extrapolation"):
        spread = [float(rms[c]) for c in ("f", "zeta", "k")]
        return TwinSource(robot, spread=spread)
    if hasattr(modes, "predict") and hasattr(modes, "extrapolation"):
        name = type(modes).__name__
        label = getattr(modes, "robot_name", None) or getattr(modes, "robot", None)
        return PredictorSource(modes, f"{name} ({label})" if isinstance(label, str) else name)
    if hasattr(modes, "predict") and isinstance(getattr(modes, "name", None), str):
        return modes  # type: ignore[return-value]
    raise InputError(
        "modes: expected a mode predictor (CorrectedTwin, TwinCalibration, ModalPredictor, "
        f"a Robot or a mode source), found {type(modes).__name__}"
    )


def mode_source(
    model: str, robot: Robot, robot_key: str, effects: Sequence[Effect] = ()
) -> tuple[ModeSource, str]:
    """The mode source a job asks for.

    Parameters
    ----------
    model : str
        ``"twin"`` (the robot file's own modes: the default), ``"builtin"``
        (the shipped tl model of A, B or C) or the path of a tl model file.
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
