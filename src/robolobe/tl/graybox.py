"""Gray-box transfer: calibrate the digital twin of a robot to a few measured postures.

The black-box network of :mod:`robolobe.tl.estimator` has to learn how the
modes move with five joint angles from ~20 postures. The twin
(:class:`robolobe.twin.Twin`) already knows that dependence; what a robot
file gets wrong are mostly a few scalar parameters. :class:`TwinCalibration`
fits multiplicative factors on

* the 6 joint stiffnesses (``"stiffness"``),
* the 6 joint dampings (``"damping"``),
* the end-effector mass, its inertia scaled alike (``"ee_mass"``)

by nonlinear least squares (:func:`scipy.optimize.least_squares`, factors
log-parametrised, bounded, regularised toward 1) on the misfit between
measured and twin modes:

* per posture and driving-point direction the measured modes are matched to
  the twin's modes (:func:`scipy.optimize.linear_sum_assignment` on
  ``|log f_meas / f_twin|`` plus a small driving-point-stiffness term, pairs
  farther apart than ``match_tol`` in log frequency are dropped), re-matched
  after each solve until the assignment stops changing;
* residuals ``log(f_meas / f_twin)`` (weight 1), ``log(zeta_meas / zeta_twin)``
  (weight ``weights[1]``) and ``log(k_meas / k_twin)`` at the measured
  direction (weight ``weights[2]``, only where the measured stiffness is
  known, i.e. the mode was seen there);
* ``regularization * log(factor)`` per factor.

The calibrated robot (``robot_``) is an ordinary robot: :meth:`TwinCalibration.save`
writes it as a robot TOML that planning and simulation accept as is.
Predictions are the calibrated twin's modes with a spread propagated from the
parameter covariance (Gauss-Newton, residual variance from the fit) by
finite differences: they state the uncertainty of the *parameters*, not the
error of the twin's structure (a model-form error is not in the spread).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares, linear_sum_assignment

from robolobe.errors import ConvergenceError, InputError
from robolobe.robots.model import RigidBody, Robot
from robolobe.tl.dataset import DRIVING_DIRECTIONS, ModalDataset, dataset_from_frame
from robolobe.tl.estimator import ModalPrediction

__all__ = ["PARAMETER_GROUPS", "TwinCalibration", "twin_values"]

FloatArray = NDArray[np.float64]
_AXIS = {"xx": 0, "yy": 1, "zz": 2}
#: Parameter groups that can be calibrated and their number of factors.
PARAMETER_GROUPS: dict[str, int] = {"stiffness": 6, "damping": 6, "ee_mass": 1}
_K_MAX = 1e15  # N/m: modal stiffness of a mode that does not move the TCP at d


def _as_robot(robot: Robot | str | os.PathLike[str]) -> Robot:
    if isinstance(robot, Robot):
        return robot
    from robolobe.robots import load_robot

    return load_robot(robot)


def twin_values(
    robot: Robot, q_rad: ArrayLike, *, directions: Sequence[str] = ("xx", "yy"), n_modes: int = 5
) -> FloatArray:
    """The twin's lowest modes per driving-point direction, all of them (seen or not).

    Parameters
    ----------
    robot : Robot
    q_rad : array_like, shape (n, 6)
        Joint angles [rad].
    directions : sequence of str
        Driving points (``xx``, ``yy``, ``zz``).
    n_modes : int
        Lowest modes kept.

    Returns
    -------
    ndarray, shape (n, n_dir, n_modes, 3)
        Frequency [Hz], damping ratio, modal stiffness at the direction [N/m]
        (capped at 1e15 for modes that do not move the TCP along it).
    """
    from robolobe.twin import Twin

    q = np.asarray(q_rad, dtype=float)
    m = Twin(robot).modes(q)
    if m.f_hz.shape[-1] < n_modes:
        raise InputError(f"n_modes: the twin has {m.f_hz.shape[-1]} modes, asked {n_modes}")
    out = np.empty((len(q), len(directions), n_modes, 3))
    for j, d in enumerate(directions):
        out[:, j, :, 0] = m.f_hz[:, :n_modes]
        out[:, j, :, 1] = m.zeta[:, :n_modes]
        k = np.abs(m.k_N_per_m[:, _AXIS[d], :n_modes])
        out[:, j, :, 2] = np.where(np.isfinite(k), np.minimum(k, _K_MAX), _K_MAX)
    return out


class TwinCalibration:
    """Fit stiffness, damping and end-effector-mass factors of a robot file to measured modes.

    Parameters
    ----------
    robot : Robot or str
        The robot file's model (``"B"``, a ``.toml`` path or a Robot): the prior.
    params : sequence of str
        Groups to calibrate, some of ``"stiffness"``, ``"damping"``, ``"ee_mass"``.
    bounds : (float, float)
        Bounds of every factor.
    regularization : float
        Weight of ``log(factor)`` residuals pulling each factor toward 1
        (a parameter the data do not see stays at 1).
    weights : (float, float, float)
        Residual weights of log frequency, log damping and log stiffness.
    match_tol : float
        Largest ``|log f_meas / f_twin|`` of a matched pair (0.3: 35 %).
    match_k_weight : float
        Weight of ``|log k_meas / k_twin|`` (capped at 3) in the matching cost,
        which separates close modes seen in different directions.
    n_rematch : int
        Most match-then-solve rounds.
    min_postures : int
        Fewest postures accepted by :meth:`fit`.
    robot_name : str or None
        Name of the calibrated robot (default ``<name>-calibrated``).
    n_starts : int
        Starts of the robust first round (the robot file's values and
        ``n_starts - 1`` random factors in [0.75, 1.35]); the best is kept.
    accept_rms_f : float
        A start whose RMS log-frequency residual is at most this (0.002: twice
        the identification scatter of frequencies) ends the search.
    random_state : int or None
        Seed of the random starts.

    Attributes
    ----------
    factors_ : dict of str to ndarray
        Fitted factors per group (shape (6,) or (1,)).
    robot_ : Robot
        The calibrated robot.
    param_names_ : tuple of str
        ``k1..k6``, ``c1..c6``, ``m_ee`` for the calibrated groups.
    param_std_ : ndarray, shape (n_params,)
        Standard deviation of ``log(factor)`` (~ relative std of the factor).
    covariance_ : ndarray, shape (n_params, n_params)
        Covariance of the log factors.
    residual_rms_ : dict of str to float
        RMS of the unweighted log residuals ``f``, ``zeta``, ``k`` at the fit.
    n_matched_ : int
        Matched (posture, direction, mode) pairs; ``n_unmatched_`` measured
        modes left without a partner.
    directions_ : tuple of str
    n_modes_ : int
        Modes per direction in the training data (predictions use the same).
    """

    def __init__(
        self,
        *,
        robot: Robot | str | os.PathLike[str],
        params: Sequence[str] = ("stiffness", "damping", "ee_mass"),
        bounds: tuple[float, float] = (0.3, 3.0),
        regularization: float = 1e-3,
        weights: tuple[float, float, float] = (1.0, 0.2, 0.3),
        match_tol: float = 0.3,
        match_k_weight: float = 0.1,
        n_rematch: int = 4,
        min_postures: int = 5,
        robot_name: str | None = None,
        n_starts: int = 8,
        accept_rms_f: float = 0.002,
        random_state: int | None = 0,
    ) -> None:
        self.accept_rms_f = accept_rms_f
        self.n_starts = n_starts
        self.random_state = random_state
        self.robot = robot
        self.params = params
        self.bounds = bounds
        self.regularization = regularization
        self.weights = weights
        self.match_tol = match_tol
        self.match_k_weight = match_k_weight
        self.n_rematch = n_rematch
        self.min_postures = min_postures
        self.robot_name = robot_name

    # ------------------------------------------------------------ helpers
    def _validate(self) -> tuple[Robot, tuple[str, ...]]:
        robot = _as_robot(self.robot)
        groups = tuple(self.params)
        bad = [g for g in groups if g not in PARAMETER_GROUPS]
        if not groups or bad or len(set(groups)) != len(groups):
            raise InputError(
                f"params: expected distinct groups from {tuple(PARAMETER_GROUPS)}, found {groups}"
            )
        if "ee_mass" in groups and (robot.end_effector is None or robot.end_effector.mass_kg <= 0):
            raise InputError(
                "params: 'ee_mass' needs a robot with an end effector of positive mass",
                source=robot.source,
            )
        lo, hi = (float(b) for b in self.bounds)
        if not 0 < lo < 1 < hi:
            raise InputError(f"bounds: expected 0 < lo < 1 < hi, found {self.bounds}")
        if (
            self.regularization < 0
            or self.match_tol <= 0
            or self.n_rematch < 1
            or self.n_starts < 1
        ):
            raise InputError(
                "expected regularization >= 0, match_tol > 0 and n_rematch >= 1, found "
                f"{self.regularization}, {self.match_tol}, {self.n_rematch}"
            )
        if len(self.weights) != 3 or any(w < 0 for w in self.weights):
            raise InputError(f"weights: expected 3 non-negative numbers, found {self.weights}")
        return robot, groups

    @staticmethod
    def _names(groups: tuple[str, ...]) -> tuple[str, ...]:
        names: list[str] = []
        for g in groups:
            if g == "stiffness":
                names += [f"k{i}" for i in range(1, 7)]
            elif g == "damping":
                names += [f"c{i}" for i in range(1, 7)]
            else:
                names.append("m_ee")
        return tuple(names)

    @staticmethod
    def _apply(base: Robot, groups: tuple[str, ...], factors: FloatArray) -> Robot:
        robot, i = base, 0
        for g in groups:
            n = PARAMETER_GROUPS[g]
            f = factors[i : i + n]
            i += n
            if g == "stiffness":
                robot = robot.with_stiffness(base.stiffness * f)
            elif g == "damping":
                robot = robot.with_damping(base.damping * f)
            else:
                ee = base.end_effector
                assert ee is not None  # checked in _validate
                robot = robot.replace(
                    end_effector=RigidBody(ee.mass_kg * f[0], ee.com_m, ee.inertia_kgm2 * f[0])
                )
        return robot

    def _match(
        self, ds: ModalDataset, model: FloatArray, tol: float | None = None
    ) -> tuple[tuple[NDArray[np.intp], ...], int]:
        """Assign measured modes to twin modes; returns index arrays and unmatched count."""
        tol = self.match_tol if tol is None else tol
        ii: list[int] = []
        jj: list[int] = []
        mm: list[int] = []
        tt: list[int] = []
        unmatched = 0
        for i in range(ds.n_postures):
            for j in range(len(ds.directions)):
                y = ds.y[i, j]
                meas = np.flatnonzero(np.isfinite(y[:, 0]))
                if meas.size == 0:
                    continue
                df = np.abs(np.log(y[meas, 0][:, None] / model[i, j, :, 0][None, :]))
                with np.errstate(invalid="ignore", divide="ignore"):
                    dk = np.abs(np.log(y[meas, 2][:, None] / model[i, j, :, 2][None, :]))
                dk = np.where(np.isfinite(dk), np.minimum(dk, 3.0), 0.0)
                cost = df + self.match_k_weight * dk
                r, c = linear_sum_assignment(cost)
                ok = df[r, c] <= tol
                unmatched += int(meas.size - ok.sum())
                ii += [i] * int(ok.sum())
                jj += [j] * int(ok.sum())
                mm += meas[r[ok]].tolist()
                tt += c[ok].tolist()
        idx = tuple(np.asarray(a, dtype=np.intp) for a in (ii, jj, mm, tt))
        return idx, unmatched

    # --------------------------------------------------------------- fit
    def fit(self, modal_df: pd.DataFrame) -> TwinCalibration:
        """Calibrate on a ``modal.csv`` frame (:func:`robolobe.modal.modal_csv.read_modal_csv`).

        Parameters
        ----------
        modal_df : pandas.DataFrame
            Columns posture_id, q1_deg..q6_deg, dir, mode, f_hz, zeta,
            k_N_per_m; driving-point rows (``xx``, ``yy``, ``zz``) are used.

        Returns
        -------
        self
        """
        if not isinstance(modal_df, pd.DataFrame):
            raise InputError(f"modal_df: expected a pandas DataFrame, found {type(modal_df)}")
        if "dir" not in modal_df.columns or "mode" not in modal_df.columns:
            missing = [c for c in ("dir", "mode") if c not in modal_df.columns]
            raise InputError(f"modal_df: missing columns {missing}", source="modal dataset")
        dirs_in = set(modal_df["dir"].astype(str).str.lower())
        dirs = tuple(d for d in DRIVING_DIRECTIONS if d in dirs_in)
        if not dirs:
            raise InputError(
                f"modal_df: expected driving-point rows (dir xx, yy or zz), found {sorted(dirs_in)}"
            )
        n_modes = int(pd.to_numeric(modal_df["mode"], errors="coerce").max())
        if not n_modes >= 1:
            raise InputError("modal_df: expected mode numbers >= 1", source="modal dataset")
        ds = dataset_from_frame(modal_df, directions=dirs, n_modes=n_modes)
        return self.fit_dataset(ds)

    def fit_dataset(self, ds: ModalDataset) -> TwinCalibration:
        """Calibrate on a :class:`~robolobe.tl.dataset.ModalDataset` (NaN = not seen)."""
        from robolobe.twin import Twin

        base, groups = self._validate()
        if ds.n_postures < self.min_postures:
            raise InputError(
                f"expected at least {self.min_postures} postures to calibrate, found "
                f"{ds.n_postures}"
            )
        y = np.asarray(ds.y)
        fin = np.isfinite(y)
        if np.any(fin & (y <= 0)):
            raise InputError("expected positive frequencies, damping ratios and stiffnesses")
        names = self._names(groups)
        p = len(names)
        lo, hi = np.log(float(self.bounds[0])), np.log(float(self.bounds[1]))
        q = ds.q_rad
        nd, nm = len(ds.directions), ds.n_modes
        n_twin = Twin(base).modes(q[:1]).f_hz.shape[-1]
        wf, wz, wk = (float(w) for w in self.weights)
        reg = float(self.regularization)

        def model(theta: FloatArray) -> FloatArray:
            rob = self._apply(base, groups, np.exp(theta))
            return twin_values(rob, q, directions=ds.directions, n_modes=n_twin)

        def data_res(theta: FloatArray, idx: tuple[NDArray[np.intp], ...]) -> FloatArray:
            i, j, m, t = idx
            mod = model(theta)[i, j, t]  # (n_pairs, 3)
            meas = y[i, j, m]
            r = np.log(meas / mod)
            r[:, 0] *= wf
            r[:, 1] *= wz
            r[:, 2] *= wk
            return np.asarray(r[np.isfinite(meas)])

        def residuals(theta: FloatArray, idx: tuple[NDArray[np.intp], ...]) -> FloatArray:
            return np.concatenate([data_res(theta, idx), reg * theta])

        meas_idx = np.argwhere(np.isfinite(y[..., 0]))  # (n_meas, 3): posture, dir, mode

        def dyn_res(theta: FloatArray) -> FloatArray:
            # every measured mode matched afresh (continuous where modes cross)
            idx, _ = self._match(ds, model(theta), tol=np.inf)
            return residuals(theta, idx)

        # round 1: robust loss, matching inside the residuals, several starts
        # (frequency matching has local minima where modes cross) -> best one
        n_res0 = int(np.isfinite(y).sum())
        if n_res0 < p:
            raise InputError(
                f"expected at least {p} modal values to fit {p} factors, found {n_res0}"
            )
        rng = np.random.default_rng(self.random_state)
        starts = [np.zeros(p)] + [
            rng.uniform(np.log(0.75), np.log(1.35), p) for _ in range(int(self.n_starts) - 1)
        ]
        sol: Any = None
        for x0 in starts:
            s0 = least_squares(
                dyn_res,
                np.clip(x0, lo + 1e-9, hi - 1e-9),
                bounds=(np.full(p, lo), np.full(p, hi)),
                loss="soft_l1",
                f_scale=0.02,
                diff_step=np.full(p, 1e-6),
                max_nfev=6 * (p + 1),
            )
            if sol is None or s0.cost < sol.cost:
                sol = s0
            idx0, _ = self._match(ds, model(np.asarray(sol.x)), tol=np.inf)
            mod0 = model(np.asarray(sol.x))
            f_res = np.log(y[idx0[0], idx0[1], idx0[2], 0] / mod0[idx0[0], idx0[1], idx0[3], 0])
            if np.sqrt(np.mean(f_res**2)) <= self.accept_rms_f:
                break  # frequencies fit to the noise level: no other start needed
        theta = np.asarray(sol.x)
        # rounds 2+: matching fixed (pairs within match_tol), plain least squares
        idx, unmatched = self._match(ds, model(theta))
        for _ in range(int(self.n_rematch)):
            n_res = int(np.isfinite(y[idx[0], idx[1], idx[2]]).sum())
            if n_res < p:
                raise InputError(
                    f"expected at least {p} matched modal values to fit {p} factors, found "
                    f"{n_res} ({unmatched} of {len(meas_idx)} measured modes had no twin mode "
                    f"within {100 * (np.exp(self.match_tol) - 1):.0f} %)"
                )
            sol = least_squares(
                residuals,
                theta,
                bounds=(np.full(p, lo), np.full(p, hi)),
                args=(idx,),
                diff_step=np.full(p, 1e-6),
                max_nfev=10 * (p + 1),
            )
            if not np.all(np.isfinite(sol.x)):
                raise ConvergenceError(f"twin calibration failed: {sol.message}")
            theta = np.asarray(sol.x)
            new_idx, unmatched = self._match(ds, model(theta))
            same = len(new_idx[0]) == len(idx[0]) and all(
                np.array_equal(a, b) for a, b in zip(new_idx, idx, strict=True)
            )
            idx = new_idx
            if same:
                break
        assert sol is not None
        # covariance of the log factors: s^2 (J^T J)^-1 with the data residual variance
        jac = np.asarray(sol.jac)
        r_data = data_res(theta, idx)
        dof = max(r_data.size - p, 1)
        s2 = float(r_data @ r_data) / dof
        jtj = jac.T @ jac
        cov = s2 * np.linalg.pinv(jtj)
        i, j, m, t = idx
        mod = model(theta)[i, j, t]
        raw = np.log(y[i, j, m] / mod)
        rms = {
            name: float(np.sqrt(np.nanmean(raw[:, c] ** 2)))
            if np.isfinite(raw[:, c]).any()
            else float("nan")
            for c, name in enumerate(("f", "zeta", "k"))
        }
        factors = np.exp(theta)
        out: dict[str, FloatArray] = {}
        k = 0
        for g in groups:
            out[g] = factors[k : k + PARAMETER_GROUPS[g]]
            k += PARAMETER_GROUPS[g]
        rob = self._apply(base, groups, factors)
        name = self.robot_name or f"{base.name}-calibrated"
        self.theta_ = theta
        self.factors_ = out
        self.robot_ = rob.replace(name=name)
        self.base_robot_ = base
        self.groups_ = groups
        self.param_names_ = names
        self.covariance_ = cov
        self.param_std_ = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        self.residual_rms_ = rms
        self.n_matched_ = len(i)
        self.n_unmatched_ = unmatched
        self.directions_ = tuple(ds.directions)
        self.n_modes_ = nm
        self.n_postures_ = ds.n_postures
        self.at_bounds_ = tuple(
            n for n, th in zip(names, theta, strict=True) if min(th - lo, hi - th) < 1e-3
        )
        self.train_q_rad_ = np.array(q)
        self.nd_ = nd
        return self

    # ------------------------------------------------------------ predict
    def _check_fitted(self) -> None:
        if not hasattr(self, "robot_"):
            raise InputError("this TwinCalibration is not fitted yet: call fit()")

    def predict(
        self,
        q_rad: ArrayLike,
        *,
        directions: Sequence[str] | None = None,
        n_modes: int | None = None,
        spread: bool = True,
    ) -> ModalPrediction:
        """Modes of the calibrated twin with their parameter spread.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        directions : sequence of str, optional
            Default: the training directions.
        n_modes : int, optional
            Lowest modes per direction; default: as in the training data.
        spread : bool
            Propagate the parameter covariance (one twin evaluation per
            factor); False gives zero spread.

        Returns
        -------
        ModalPrediction
            ``kind="log"``: ``center`` is the log of the values and ``std`` the
            standard deviation of the log, shape (n, n_dir, n_modes, 3).
        """
        self._check_fitted()
        q = np.asarray(q_rad, dtype=float)
        if q.ndim != 2 or q.shape[1] != 6 or not np.all(np.isfinite(q)):
            raise InputError(f"q_rad: expected finite angles of shape (n, 6), found {q.shape}")
        dirs = tuple(directions) if directions is not None else self.directions_
        bad = [d for d in dirs if d not in _AXIS]
        if bad:
            raise InputError(f"directions: expected xx, yy or zz, found {bad}")
        nm = int(n_modes) if n_modes is not None else self.n_modes_
        center = np.log(twin_values(self.robot_, q, directions=dirs, n_modes=nm))
        std = np.zeros_like(center)
        if spread:
            h = 1e-4
            jac = np.empty((len(self.theta_), *center.shape))
            for a in range(len(self.theta_)):
                th = self.theta_.copy()
                th[a] += h
                rob = self._apply(self.base_robot_, self.groups_, np.exp(th))
                jac[a] = (np.log(twin_values(rob, q, directions=dirs, n_modes=nm)) - center) / h
            jf = jac.reshape(len(self.theta_), -1)
            var = np.einsum("ak,ab,bk->k", jf, self.covariance_, jf)
            std = np.sqrt(np.clip(var, 0.0, None)).reshape(center.shape)
        return ModalPrediction(directions=dirs, center=center, std=std, kind="log")

    def predict_dataset(
        self, q_rad: ArrayLike, posture_ids: Sequence[str] | None = None
    ) -> ModalDataset:
        """Point predictions as a :class:`ModalDataset` (``.to_frame()`` gives modal.csv rows)."""
        q = np.asarray(q_rad, dtype=float)
        ids = (
            tuple(posture_ids)
            if posture_ids is not None
            else tuple(f"p{i + 1}" for i in range(len(q)))
        )
        pred = self.predict(q, spread=False)
        return ModalDataset(ids, q, pred.directions, pred.values)

    def summary(self) -> pd.DataFrame:
        """Fitted factors with their 1-sigma relative spread, one row per parameter."""
        self._check_fitted()
        return pd.DataFrame(
            {
                "param": self.param_names_,
                "factor": np.exp(self.theta_),
                "log_std": self.param_std_,
            }
        )

    # --------------------------------------------------------------- save
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibrated robot as a robot TOML (usable as ``robot.name`` in a job)."""
        from robolobe.robots.io import save_robot

        self._check_fitted()
        return save_robot(self.robot_, path)

    def __repr__(self) -> str:
        state = "fitted" if hasattr(self, "robot_") else "unfitted"
        return f"TwinCalibration(params={tuple(self.params)}, {state})"
