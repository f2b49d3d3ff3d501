"""The posture -> modal-parameter predictor (scikit-learn style).

:class:`ModalPredictor` is the seed paper's model (section 2.3) with a deep
ensemble around it: ``n_members`` networks per TCP direction, each
``n_in -> hidden -> 3 * n_modes``, trained together (vectorized, see
:mod:`robolobe.tl.network`). With ``source=`` a fitted predictor it is the
paper's transfer: every member starts from the source's weights and its first
``n_frozen`` layers stay fixed.

Uncertainty: the spread of the members in the (log-)target space, scaled by a
calibration factor per direction and parameter so that the stated intervals
hold on postures the model did not see. The factor comes from K-fold cross-
validation of the whole ensemble (``calibration="cv"``, all folds trained in
the same vectorized pass) or from a held-out fraction
(``calibration="holdout"``, the seed's 80:20 split of robot A).
"""

from __future__ import annotations

import json
import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ndtri

from robolobe._atomic import atomic_path
from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError
from robolobe.robots.limits import as_postures
from robolobe.robots.plausibility import Q_MAX_RAD
from robolobe.tl.dataset import (
    DRIVING_DIRECTIONS,
    ModalDataset,
    TrustWarning,
    interpolate_gaps,
)
from robolobe.tl.forward import ArrayMLP
from robolobe.tl.preprocess import (
    FEATURES,
    TARGET_TRANSFORMS,
    MinMax,
    TargetTransform,
    augment_angles,
    features,
    n_features,
)
from robolobe.tl.training import TrainHistory, train_ensemble

__all__ = ["MODEL_FORMAT", "ModalPrediction", "ModalPredictor", "transfer_network"]

MODEL_FORMAT = "robolobe-tl/1"
FloatArray = NDArray[np.float64]
_Z90 = float(ndtri(0.95))  # 1.6449: half-width of a central 90 % normal interval


@dataclass(frozen=True, eq=False)
class ModalPrediction:
    """Predicted modal parameters with their spread.

    Attributes
    ----------
    directions : tuple of str
        Driving-point directions (``"xx"``, ``"yy"``, ...).
    center : ndarray, shape (n, n_dir, n_modes, 3)
        Ensemble mean in the target space of the model (log of the values
        when ``kind == "log"``, the values themselves otherwise).
    std : ndarray, shape (n, n_dir, n_modes, 3)
        Calibrated standard deviation in the same space (0 for one member).
    kind : str
        The model's target transform (``"log"`` or ``"minmax"``).
    members : ndarray, shape (n_members, n, n_dir, n_modes, 3) or None
        Each member's prediction in physical units, if requested.
    """

    directions: tuple[str, ...]
    center: FloatArray
    std: FloatArray
    kind: str
    members: FloatArray | None = field(default=None)

    def _post(self, t: FloatArray) -> FloatArray:
        return TargetTransform(self.kind, MinMax(np.zeros(1), np.ones(1))).post(t)

    @property
    def values(self) -> FloatArray:
        """Point prediction in physical units, shape (n, n_dir, n_modes, 3)."""
        return self._post(self.center)

    @property
    def f_hz(self) -> FloatArray:
        """Natural frequencies [Hz], shape (n, n_dir, n_modes)."""
        return self.values[..., 0]

    @property
    def zeta(self) -> FloatArray:
        """Damping ratios (fraction), shape (n, n_dir, n_modes)."""
        return self.values[..., 1]

    @property
    def k_N_per_m(self) -> FloatArray:
        """Modal stiffnesses [N/m], shape (n, n_dir, n_modes)."""
        return self.values[..., 2]

    @property
    def std_physical(self) -> FloatArray:
        """Standard deviation in physical units (first order in the spread)."""
        if self.kind == "minmax":
            return self.std.copy()
        out = self.values * self.std  # d exp(t) = exp(t) dt
        if self.kind == "flex":  # k = K / c^2: dk = 2 k dc / c
            c = np.maximum(self.center[..., 2], 1e-3)
            out[..., 2] = 2.0 * self.values[..., 2] * self.std[..., 2] / c
        return out

    @property
    def log_std(self) -> FloatArray:
        """Relative spread: standard deviation of ``log(value)`` (first order), any kind.

        ``"log"``: the spread itself; ``"flex"``: f and zeta as is, stiffness
        ``2 std_c / c`` (``k = K / c^2``); ``"minmax"``: ``std / value``.
        """
        if self.kind == "log":
            return self.std.copy()
        if self.kind == "flex":
            out = self.std.copy()
            c = np.maximum(self.center[..., 2], 1e-3)
            out[..., 2] = 2.0 * self.std[..., 2] / c
            return out
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.values > 0, self.std / self.values, np.inf)

    def parameters(self) -> ModalParameters:
        """The point prediction with its relative spread as one modal-parameter set.

        Returns
        -------
        ModalParameters
            :attr:`values` (physical units: Hz, fraction, N/m) on
            :attr:`directions`, shape (n, n_dir, n_modes), with
            :attr:`log_std` as the spread.

        Raises
        ------
        InputError
            If the prediction breaks the type's rules (a frequency or damping
            ratio <= 0, a stiffness of 0: a min-max model predicting outside
            its training range).
        """
        return ModalParameters.from_stacked(self.values, self.directions, log_std=self.log_std)

    def interval(self, level: float = 0.9) -> tuple[FloatArray, FloatArray]:
        """Central ``level`` interval per value, physical units.

        Returns
        -------
        lo, hi : ndarray, shape (n, n_dir, n_modes, 3)
        """
        if not 0.0 < level < 1.0:
            raise InputError(f"level: expected 0 < level < 1, found {level}")
        z = float(ndtri(0.5 + level / 2.0))
        lo = self._post(self.center - z * self.std)
        hi = self._post(self.center + z * self.std)
        if self.kind == "flex":  # stiffness falls as c rises
            lo[..., 2], hi[..., 2] = hi[..., 2].copy(), lo[..., 2].copy()
        return lo, hi

    def z_scores(self, y_true: ArrayLike) -> FloatArray:
        """``(y - center) / std`` in the target space, shape (n, n_dir, n_modes, 3)."""
        t = TargetTransform(self.kind, MinMax(np.zeros(1), np.ones(1))).pre(y_true)
        with np.errstate(invalid="ignore", divide="ignore"):
            return (t - self.center) / self.std


class ModalPredictor:
    """Posture -> per-direction modal parameters, a deep ensemble of the seed's network.

    Parameters
    ----------
    directions : sequence of str, default ("xx", "yy")
        Driving-point directions to model (the seed: x and y; z optional).
    n_modes : int, default 5
        Modes per direction (the seed: 5).
    hidden : sequence of int, default (32, 32, 32, 32, 32)
        Hidden layer widths (the seed: 5 x 32 ReLU).
    features : {"angles", "trig", "trig5", "dh5"}, default "trig5"
        Network inputs: min-max-scaled angles (the seed), sin/cos of each
        joint, of joints 2-6, or of the DH angles 2-6 (see
        :func:`robolobe.tl.preprocess.features`).
    target_transform : {"minmax", "log", "flex"}, default "flex"
        Targets min-max-scaled (the seed), logged first, or log frequency /
        log damping / sqrt-compliance.
    epochs, batch_size, learning_rate : int, int, float
        Adam on the MSE (seed: 500, 8, 1e-3).
    augment_delta : float, default 0.0
        Seed eq. 1 on the min-max-scaled angles (the seed: 0.10); 0 disables
        augmentation.
    augment_copies : int, default 0
        Augmented copies per posture (drawn once per member; the seed: 4).
    missing : {"interpolate", "mask"}, default "mask"
        Missing values: the seed's linear interpolation along the posture
        order, or left out of the loss.
    n_members : int, default 5
        Ensemble members per direction (1 = no spread).
    source : ModalPredictor, optional
        A fitted predictor to transfer from (seed section 2.3).
    n_frozen : int, default 3
        Leading layers kept fixed when transferring (seed: 3); ignored
        without ``source``.
    calibration : {"cv", "holdout", "none"}, default "cv"
        How the spread is calibrated (see module docstring).
    calibration_folds : int, default 5
        Folds for ``"cv"``.
    validation_fraction : float, default 0.2
        Postures held out for ``"holdout"`` (the seed's 80:20 split); they
        are not trained on.
    robot : str, optional
        Label of the robot (stored with the model).
    coupling : array_like, shape (6, 6), optional
        The robot's joint coupling (DH angle = coupling q + offset); needed
        for ``features="dh5"``, stored with the model.
    theta_offset_rad : array_like, shape (6,), optional
        The robot's DH angle offsets [rad]; with ``coupling``.
    random_state : int, default 0
        Seed of every random draw (initial weights, augmentation, shuffles,
        folds).

    Notes
    -----
    The defaults are the ``"improved"`` preset of
    :mod:`robolobe.tl.presets`, the shipped models' settings (chosen by
    studies/tl_accuracy.py); ``ModalPredictor(**PRESETS["paper"])`` is the
    seed's method as published.

    Attributes
    ----------
    net_ : ArrayMLP
        ``n_dir * n_members`` networks; model ``d * n_members + e``.
    angle_scaler_ : MinMax
        Joint-angle range of the training postures [rad].
    target_transform_ : TargetTransform
    calibration_ : ndarray, shape (n_dir, 3)
        Spread factor per direction and parameter (1 if not calibrated).
    calibration_coverage_ : ndarray, shape (n_dir, 3) or None
        Fraction of held-out values inside the calibrated 90 % interval.
    train_q_rad_ : ndarray, shape (n_train, 6)
        Postures trained on.
    validation_ : dict or None
        Posture ids held out (``"holdout"``).
    history_ : TrainHistory
    lineage_ : list of str
        Robots this model was trained on, source first.
    """

    net_: ArrayMLP
    angle_scaler_: MinMax
    target_transform_: TargetTransform
    calibration_: FloatArray
    calibration_coverage_: FloatArray | None
    train_q_rad_: FloatArray
    validation_: dict[str, Any] | None
    history_: TrainHistory
    lineage_: list[str]
    n_frozen_used_: int

    def __init__(
        self,
        *,
        directions: tuple[str, ...] | list[str] = ("xx", "yy"),
        n_modes: int = 5,
        hidden: tuple[int, ...] | list[int] = (32, 32, 32, 32, 32),
        features: str = "trig5",
        target_transform: str = "flex",
        epochs: int = 500,
        batch_size: int = 8,
        learning_rate: float = 1e-3,
        augment_delta: float = 0.0,
        augment_copies: int = 0,
        missing: str = "mask",
        n_members: int = 5,
        source: ModalPredictor | None = None,
        n_frozen: int = 3,
        calibration: str = "cv",
        calibration_folds: int = 5,
        validation_fraction: float = 0.2,
        robot: str | None = None,
        coupling: Any = None,
        theta_offset_rad: Any = None,
        random_state: int = 0,
    ) -> None:
        self.directions = directions
        self.n_modes = n_modes
        self.hidden = hidden
        self.features = features
        self.target_transform = target_transform
        self.epochs = epochs
        self.batch_size = batch_size
        self.learning_rate = learning_rate
        self.augment_delta = augment_delta
        self.augment_copies = augment_copies
        self.missing = missing
        self.n_members = n_members
        self.source = source
        self.n_frozen = n_frozen
        self.calibration = calibration
        self.calibration_folds = calibration_folds
        self.validation_fraction = validation_fraction
        self.robot = robot
        self.coupling = coupling
        self.theta_offset_rad = theta_offset_rad
        self.random_state = random_state

    # ------------------------------------------------------------ parameters
    #: Measured modes beyond the network's (:class:`robolobe.tl.extra_modes.ExtraModes`),
    #: set by :func:`robolobe.tl.transfer.transfer` and kept by :meth:`save`; None: none.
    extra_: Any = None

    _PARAM_NAMES = (
        "directions", "n_modes", "hidden", "features", "target_transform", "epochs",
        "batch_size", "learning_rate", "augment_delta", "augment_copies", "missing",
        "n_members", "n_frozen", "calibration", "calibration_folds",
        "validation_fraction", "robot", "coupling", "theta_offset_rad", "random_state",
    )  # fmt: skip

    def get_params(self) -> dict[str, Any]:
        """Constructor parameters (``source`` included)."""
        out = {k: getattr(self, k) for k in self._PARAM_NAMES}
        out["source"] = self.source
        return out

    def set_params(self, **params: Any) -> ModalPredictor:
        """Set constructor parameters; returns self."""
        for k, v in params.items():
            if k not in self._PARAM_NAMES and k != "source":
                raise InputError(f"unknown parameter {k!r}; expected one of {self._PARAM_NAMES}")
            setattr(self, k, v)
        return self

    def _validate_params(self) -> None:
        dirs = tuple(self.directions)
        if (
            not dirs
            or any(d not in DRIVING_DIRECTIONS for d in dirs)
            or len(set(dirs)) != len(dirs)
        ):
            raise InputError(
                f"directions: expected distinct values of {DRIVING_DIRECTIONS}, found {dirs}"
            )
        checks = [
            (int(self.n_modes) >= 1, "n_modes: expected >= 1"),
            (len(self.hidden) >= 1 and min(self.hidden) >= 1, "hidden: expected widths >= 1"),
            (self.features in FEATURES, f"features: expected one of {FEATURES}"),
            (
                self.target_transform in TARGET_TRANSFORMS,
                f"target_transform: expected one of {TARGET_TRANSFORMS}",
            ),
            (int(self.epochs) >= 1, "epochs: expected >= 1"),
            (int(self.batch_size) >= 1, "batch_size: expected >= 1"),
            (float(self.learning_rate) > 0, "learning_rate: expected > 0"),
            (0 <= float(self.augment_delta) < 1, "augment_delta: expected 0 <= delta < 1"),
            (int(self.augment_copies) >= 0, "augment_copies: expected >= 0"),
            (self.missing in ("interpolate", "mask"), "missing: expected interpolate or mask"),
            (int(self.n_members) >= 1, "n_members: expected >= 1"),
            (
                self.calibration in ("cv", "holdout", "none"),
                "calibration: expected cv, holdout or none",
            ),
            (int(self.calibration_folds) >= 2, "calibration_folds: expected >= 2"),
            (
                0 < float(self.validation_fraction) < 1,
                "validation_fraction: expected 0 < fraction < 1",
            ),
        ]
        for ok, msg in checks:
            if not ok:
                raise InputError(msg)
        if self.features == "dh5":
            if self.coupling is None or self.theta_offset_rad is None:
                raise InputError(
                    "features 'dh5': expected the robot's coupling and theta_offset_rad "
                    "(give the robot, e.g. --robot B)"
                )
            if np.shape(self.coupling) != (6, 6) or np.shape(self.theta_offset_rad) != (6,):
                raise InputError("coupling: expected (6, 6) and theta_offset_rad (6,)")
        if self.source is not None:
            src = self.source
            if not hasattr(src, "net_"):
                raise InputError("source: expected a fitted ModalPredictor")
            if src.features != self.features or tuple(src.hidden) != tuple(self.hidden):
                raise InputError(
                    f"source: features/hidden {src.features}/{tuple(src.hidden)} differ from "
                    f"{self.features}/{tuple(self.hidden)}"
                )
            if int(src.n_modes) != int(self.n_modes):
                raise InputError(f"source: n_modes {src.n_modes} differs from {self.n_modes}")
            miss = [d for d in dirs if d not in tuple(src.directions)]
            if miss:
                raise InputError(f"source: has no network for direction(s) {miss}")
            if not 0 <= int(self.n_frozen) <= len(self.hidden):
                raise InputError(f"n_frozen: expected 0..{len(self.hidden)}, found {self.n_frozen}")

    def _dh(self) -> tuple[Any, Any] | None:
        if self.coupling is None or self.theta_offset_rad is None:
            return None
        return (np.asarray(self.coupling, float), np.asarray(self.theta_offset_rad, float))

    # ------------------------------------------------------------------- fit
    def fit(self, q_rad: ArrayLike, y: ArrayLike) -> ModalPredictor:
        """Train (or transfer) on postures and their modal parameters.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        y : array_like, shape (n, n_dir, n_modes, 3)
            Frequency [Hz], damping ratio, modal stiffness [N/m] per direction
            (in the order of ``directions``) and mode; NaN where missing.

        Returns
        -------
        self
        """
        self._validate_params()
        q = as_postures(q_rad)
        dirs = tuple(self.directions)
        nd, nm = len(dirs), int(self.n_modes)
        yy = np.asarray(y, dtype=float)
        if yy.shape != (q.shape[0], nd, nm, 3):
            raise InputError(
                f"y: expected shape ({q.shape[0]}, {nd}, {nm}, 3) for directions {dirs}, "
                f"found {yy.shape}"
            )
        n = q.shape[0]
        min_n = 5 if self.calibration != "cv" else max(5, int(self.calibration_folds))
        if n < min_n:
            raise InputError(f"expected at least {min_n} postures to fit, found {n}")
        finite = np.isfinite(yy)
        if np.any(finite & (yy <= 0)):
            raise InputError("y: expected positive frequencies, damping ratios and stiffnesses")
        if self.missing == "interpolate" and not np.all(finite):
            ds = interpolate_gaps(ModalDataset(tuple(str(i) for i in range(n)), q, dirs, yy))
            yy = np.array(ds.y)
        if not np.all(np.any(np.isfinite(yy), axis=0)):
            raise InputError("y: a direction x mode x parameter has no value at all")

        import torch  # training only: loading and predicting never import torch

        from robolobe.tl.network import EnsembleMLP

        rng = np.random.default_rng(self.random_state)
        gen = torch.Generator().manual_seed(int(self.random_state))

        # ---- which postures each fold trains on
        holdout = np.zeros(n, dtype=bool)
        if self.calibration == "holdout":
            n_val = max(1, round(float(self.validation_fraction) * n))
            holdout[rng.permutation(n)[:n_val]] = True
        n_folds = int(self.calibration_folds) if self.calibration == "cv" else 0
        fold_of = rng.permutation(n) % n_folds if n_folds else np.zeros(n, dtype=int)
        train = ~holdout

        self.angle_scaler_ = MinMax.fit(q[train])
        self.target_transform_ = TargetTransform.fit(yy[train], self.target_transform)
        e = int(self.n_members)
        n_groups = 1 + n_folds
        n_models = n_groups * nd * e
        copies = int(self.augment_copies) if self.augment_delta > 0 else 0
        n_aug = n * (1 + copies)
        post_idx = np.tile(np.arange(n), 1 + copies)  # posture of each augmented row

        x_all = np.empty((n_models, n_aug, n_features(self.features)), dtype=np.float32)
        for m in range(n_models):
            qa = augment_angles(
                q, self.angle_scaler_, delta=float(self.augment_delta), copies=copies, rng=rng
            )
            x_all[m] = features(qa, self.features, self.angle_scaler_, self._dh())
        ys = self.target_transform_.transform(yy)  # (n, nd, nm, 3)
        ys = ys.reshape(n, nd, nm * 3)
        model_dir = (np.arange(n_models) // e) % nd
        model_group = np.arange(n_models) // (nd * e)
        y_all = ys[post_idx][:, model_dir, :].transpose(1, 0, 2)  # (M, n_aug, n_out)
        mask = np.isfinite(y_all)
        y_all = np.where(mask, y_all, 0.0)
        rows = np.broadcast_to(train[post_idx], (n_models, n_aug)).copy()
        for g in range(1, n_groups):
            rows[model_group == g] &= (fold_of[post_idx] != g - 1)[None, :]

        sizes = (n_features(self.features), *map(int, self.hidden), nm * 3)
        net = EnsembleMLP(n_models, sizes, gen)
        n_frozen = 0
        lineage: list[str] = []
        if self.source is not None:
            src: ModalPredictor = self.source
            src_dirs = tuple(src.directions)
            e_src = int(src.n_members)
            pick = [
                src_dirs.index(dirs[int(model_dir[m])]) * e_src + (m % e) % e_src
                for m in range(n_models)
            ]
            net = EnsembleMLP.from_arrays(src.net_.select(pick).to_arrays())
            n_frozen = int(self.n_frozen)
            lineage = list(src.lineage_)
        self.history_ = train_ensemble(
            net,
            torch.from_numpy(x_all),
            torch.from_numpy(y_all.astype(np.float32)),
            torch.from_numpy(mask.astype(np.float32)),
            rows=torch.from_numpy(rows),
            n_frozen=n_frozen,
            epochs=int(self.epochs),
            batch_size=int(self.batch_size),
            learning_rate=float(self.learning_rate),
            generator=gen,
        )
        self.n_frozen_used_ = n_frozen
        self.net_ = ArrayMLP.from_arrays(net.select(np.flatnonzero(model_group == 0)).to_arrays())
        self.train_q_rad_ = q[train].copy()
        self.lineage_ = [*lineage, self.robot or "unnamed"]
        self.calibration_ = np.ones((nd, 3))
        self.calibration_coverage_ = None
        self.validation_ = None

        # ---- calibration of the spread
        if e > 1 and self.calibration != "none":
            t_true = self.target_transform_.pre(yy)  # (n, nd, nm, 3)
            x_plain = features(q, self.features, self.angle_scaler_, self._dh())
            out = net.predict_numpy(x_plain)  # (M, n, nm*3)
            out = out.reshape(n_groups, nd, e, n, nm, 3).transpose(0, 2, 3, 1, 4, 5)
            scale = self.target_transform_.scaler
            t_pred = out * scale.scale + scale.lo  # broadcasting over (nd, nm, 3)
            if self.calibration == "cv":
                held = np.stack([fold_of == g for g in range(n_folds)])  # (K, n)
                sd_all = t_pred[1:].std(axis=1, ddof=1)  # (K, n, nd, nm, 3)
                mu = t_pred[1:].mean(axis=1)
                mu = np.einsum("kn,knjmp->njmp", held.astype(float), mu)
                sd = np.einsum("kn,knjmp->njmp", held.astype(float), sd_all)
                use = np.ones(n, dtype=bool)
            else:
                mu = t_pred[0].mean(axis=0)
                sd = t_pred[0].std(axis=0, ddof=1)
                use = holdout
            z = np.abs(t_true - mu) / np.maximum(sd, 1e-12)
            z = np.where(np.isfinite(t_true), z, np.nan)[use]  # (n_use, nd, nm, 3)
            zf = z.transpose(1, 3, 0, 2).reshape(nd, 3, -1)
            q90 = np.nanquantile(zf, 0.9, axis=-1)
            self.calibration_ = np.where(np.isfinite(q90) & (q90 > 0), q90 / _Z90, 1.0)
            inside = zf <= (self.calibration_[..., None] * _Z90)
            self.calibration_coverage_ = np.nanmean(np.where(np.isfinite(zf), inside, np.nan), -1)
            if self.calibration == "holdout":
                vid = np.flatnonzero(holdout)
                self.validation_ = {"index": vid.tolist()}
        return self

    def fit_dataset(self, ds: ModalDataset) -> ModalPredictor:
        """:meth:`fit` on a :class:`ModalDataset` (its directions must match)."""
        if tuple(ds.directions) != tuple(self.directions) or ds.n_modes != int(self.n_modes):
            idx = [ds.directions.index(d) for d in self.directions if d in ds.directions]
            if len(idx) != len(tuple(self.directions)) or ds.n_modes < int(self.n_modes):
                raise InputError(
                    f"dataset has directions {ds.directions} and {ds.n_modes} modes; the model "
                    f"needs {tuple(self.directions)} and {self.n_modes}"
                )
            return self.fit(ds.q_rad, ds.y[:, idx, : int(self.n_modes)])
        return self.fit(ds.q_rad, ds.y)

    # --------------------------------------------------------------- predict
    def _check_fitted(self) -> None:
        if not hasattr(self, "net_"):
            raise InputError("this ModalPredictor is not fitted yet: call fit() or load()")

    def extrapolation(self, q_rad: ArrayLike) -> FloatArray:
        """How far postures lie outside the training range, per posture.

        Returns
        -------
        ndarray, shape (n,)
            Largest excess over all joints, in units of that joint's
            training range (0 inside the range, 0.1 = 10 % of a range beyond).
        """
        self._check_fitted()
        q = as_postures(q_rad)
        sc = self.angle_scaler_
        lo = (sc.lo - q) / sc.scale
        hi = (q - sc.hi) / sc.scale
        return np.asarray(np.maximum(np.maximum(lo, hi), 0.0).max(axis=1))

    def predict(
        self, q_rad: ArrayLike, *, return_members: bool = False, warn: bool = True
    ) -> ModalPrediction:
        """Predict modal parameters with their calibrated spread.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        return_members : bool
            Also return each member's prediction.
        warn : bool
            Emit a :class:`TrustWarning` for postures beyond the training
            range by more than 10 % of a joint's range.

        Returns
        -------
        ModalPrediction
        """
        self._check_fitted()
        q = as_postures(q_rad)
        if warn:
            ex = self.extrapolation(q)
            far = ex > 0.10
            if np.any(far):
                warnings.warn(
                    f"{int(far.sum())} of {len(q)} postures lie outside the training range "
                    f"(up to {100 * ex.max():.0f} % of a joint range beyond); predictions "
                    "there are extrapolations: trust them only as far as their spread says",
                    TrustWarning,
                    stacklevel=2,
                )
        dirs = tuple(self.directions)
        nd, nm, e = len(dirs), int(self.n_modes), int(self.n_members)
        x = features(q, self.features, self.angle_scaler_, self._dh())
        out = self.net_.predict_numpy(x)  # (nd*e, n, nm*3)
        out = out.reshape(nd, e, len(q), nm, 3).transpose(1, 2, 0, 3, 4)  # (e, n, nd, nm, 3)
        sc = self.target_transform_.scaler
        t = out * sc.scale + sc.lo
        center = t.mean(axis=0)
        if e > 1:
            std = t.std(axis=0, ddof=1) * self.calibration_[None, :, None, :]
        else:
            std = np.zeros_like(center)
        members = self.target_transform_.post(t) if return_members else None
        return ModalPrediction(
            directions=dirs,
            center=center,
            std=std,
            kind=self.target_transform_.kind,
            members=members,
        )

    def predict_dataset(
        self, q_rad: ArrayLike, posture_ids: list[str] | None = None
    ) -> ModalDataset:
        """Predictions as a :class:`ModalDataset` (point values)."""
        q = as_postures(q_rad)
        ids = posture_ids or [f"p{i + 1}" for i in range(len(q))]
        pred = self.predict(q)
        return ModalDataset(tuple(ids), q, tuple(self.directions), pred.values)

    # ------------------------------------------------------------- save/load
    def _meta(self) -> dict[str, Any]:
        params = {k: getattr(self, k) for k in self._PARAM_NAMES}
        params["directions"] = list(params["directions"])
        params["hidden"] = [int(h) for h in params["hidden"]]
        if params["coupling"] is not None:
            params["coupling"] = np.asarray(params["coupling"], float).tolist()
            params["theta_offset_rad"] = np.asarray(params["theta_offset_rad"], float).tolist()
        return {
            "format": MODEL_FORMAT,
            "params": params,
            "angle_scaler": self.angle_scaler_.to_dict(),
            "target_transform": self.target_transform_.to_dict(),
            "calibration": self.calibration_.tolist(),
            "calibration_coverage": None
            if self.calibration_coverage_ is None
            else self.calibration_coverage_.tolist(),
            "n_frozen_used": int(self.n_frozen_used_),
            "lineage": list(self.lineage_),
            "validation": self.validation_,
            "final_train_loss": [float(v) for v in self.history_.train_loss[-1]],
        }

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model to one ``.npz`` file: weights, scalers, metadata (JSON).

        No Python objects are pickled: weights and training postures are plain
        float arrays, everything else is a JSON string. Written atomically.
        """
        self._check_fitted()
        path = Path(path)
        arrays: dict[str, Any] = dict(self.net_.to_arrays())
        arrays["train_q_rad"] = self.train_q_rad_.astype(np.float64)
        arrays["meta"] = np.array(json.dumps(self._meta()))
        extra = getattr(self, "extra_", None)
        if extra is not None:  # measured modes beyond the network's (robolobe.tl.extra_modes)
            arrays.update(extra.arrays("extra_"))
        with atomic_path(path) as tmp, tmp.open("wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> ModalPredictor:
        """Read a model written by :meth:`save` (``allow_pickle=False``).

        Raises
        ------
        InputError
            If the file is missing, not a robolobe model, or inconsistent.
        """
        from robolobe._npz import read_npz

        return cls._from_arrays(read_npz(path), str(path))

    @classmethod
    def _from_arrays(cls, arrays: dict[str, Any], where: str) -> ModalPredictor:
        from robolobe._documents import parse_json
        from robolobe._npz import check_range
        from robolobe.tl.dataset import check_meta_counts

        if "meta" not in arrays:
            raise InputError("not a robolobe model: no 'meta' entry", source=where)
        meta = parse_json(str(arrays["meta"]), f"{where}[meta]")
        if meta.get("format") != MODEL_FORMAT:
            raise InputError(
                f"format: expected {MODEL_FORMAT!r}, found {meta.get('format')!r}", source=where
            )
        try:
            params = dict(meta["params"])
            params["directions"] = tuple(params["directions"])
            params["hidden"] = tuple(params["hidden"])
            model = cls(**params)
            model.net_ = ArrayMLP.from_arrays({k: v for k, v in arrays.items() if k[0] in "Wb"})
            model.angle_scaler_ = MinMax.from_dict(meta["angle_scaler"])
            model.target_transform_ = TargetTransform.from_dict(meta["target_transform"])
            model.calibration_ = np.asarray(meta["calibration"], dtype=float)
            cov = meta.get("calibration_coverage")
            model.calibration_coverage_ = None if cov is None else np.asarray(cov, dtype=float)
            model.n_frozen_used_ = int(meta.get("n_frozen_used", 0))
            model.lineage_ = list(meta.get("lineage", []))
            model.validation_ = meta.get("validation")
            model.train_q_rad_ = np.asarray(arrays["train_q_rad"], dtype=float)
            loss = np.asarray([meta.get("final_train_loss", [np.nan])], dtype=float)
            model.history_ = TrainHistory(train_loss=loss, val_loss=None)
        except InputError as exc:
            if exc.source is not None:
                raise
            raise InputError(f"inconsistent model file ({exc})", source=where) from None
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"inconsistent model file ({exc})", source=where) from None
        for k, v in arrays.items():
            if k[0] in "Wb":
                check_range(v, k, where)
        check_range(model.calibration_, "calibration", where, low=0.0, open_low=True)
        check_range(model.train_q_rad_, "train_q_rad", where, low=-Q_MAX_RAD, high=Q_MAX_RAD)
        try:
            check_meta_counts(tuple(model.directions), int(model.n_modes), where)
            nd, e = len(model.directions), int(model.n_members)
            want = (
                n_features(model.features),
                *(int(h) for h in model.hidden),
                3 * int(model.n_modes),
            )
        except InputError:
            raise
        except (TypeError, ValueError, KeyError) as exc:
            raise InputError(f"inconsistent model file (params: {exc})", source=where) from None
        if model.net_.n_models != nd * e or model.net_.sizes != want:
            raise InputError(
                f"weights: expected {nd * e} networks of sizes {want}, found "
                f"{model.net_.n_models} of {model.net_.sizes}",
                source=where,
            )
        if model.calibration_.shape != (nd, 3):
            raise InputError(
                "calibration: expected one factor per direction and parameter", source=where
            )
        if "extra_values" in arrays:  # measured modes beyond the network's
            from robolobe.tl.extra_modes import ExtraModes

            model.extra_ = ExtraModes.from_arrays(arrays, "extra_", where)
        return model

    def __repr__(self) -> str:
        fitted = "fitted" if hasattr(self, "net_") else "not fitted"
        return (
            f"ModalPredictor(robot={self.robot!r}, directions={tuple(self.directions)}, "
            f"features={self.features!r}, target_transform={self.target_transform!r}, "
            f"n_members={self.n_members}, {fitted})"
        )


def transfer_network(
    source: ModalPredictor, q_rad: ArrayLike, y: ArrayLike, **params: Any
) -> ModalPredictor:
    """The seed's transfer: a copy of ``source``'s settings, refitted on a new robot.

    Parameters
    ----------
    source : ModalPredictor
        Fitted source model (robot A).
    q_rad, y : array_like
        Target postures and modal parameters (see :meth:`ModalPredictor.fit`).
    **params
        Overrides of the source's parameters (e.g. ``n_frozen``, ``robot``).
        Defaults: ``calibration="cv"`` and ``n_frozen=3``.

    Returns
    -------
    ModalPredictor
        Fitted on the target, first ``n_frozen`` layers equal to the source's.
    """
    base = {k: v for k, v in source.get_params().items() if k != "source"}
    base.update(calibration="cv", n_frozen=3, robot=None, coupling=None, theta_offset_rad=None)
    base.update(params)
    base["source"] = source
    return ModalPredictor(**base).fit(q_rad, y)
