"""Gray-box transfer: calibrate the digital twin of a robot to a few measured postures.

The black-box network of :mod:`robolobe.tl.estimator` has to learn how the
modes move with five joint angles from ~20 postures. The twin
(:class:`robolobe.twin.Twin`) already knows that dependence; what a robot
file gets wrong are a few dozen physical parameters. :class:`TwinCalibration`
fits them (:mod:`robolobe.twin.params`, 43 by default):

* the 6 joint stiffnesses and the 6 joint dampings (factors),
* the end-effector mass, its inertia scaled alike (a factor),
* each link's mass and inertia (6 factors) and centre of mass (18 offsets),
* each joint spring's load stiffening (6 values >= 0: ``k (1 + s |tau_g|)``,
  the gear stiffer under the gravity torque it holds; issue 27: on
  out-of-form robots B and C the calibrated spread of the modes' compliance
  halves, e.g. 0.23 -> 0.11 and 0.31 -> 0.10 per sigma)

by bounded nonlinear least squares (:func:`scipy.optimize.least_squares`,
factors log-parametrised) on the misfit between measured and twin modes plus
a Gaussian prior centred on the robot file (:data:`PRIOR_STD`), so that a
parameter the data cannot see stays at the file's value:

* per posture and driving-point direction the measured modes are matched to
  the twin's modes (the linear sum assignment of ``|log f_meas / f_twin|``
  plus a small driving-point-stiffness term; pairs farther apart than
  ``match_tol`` in log frequency are dropped);
* residuals ``log(f_meas / f_twin)`` (weight 1), ``log(zeta_meas / zeta_twin)``
  (weight ``weights[1]``) and ``log(k_meas / k_twin)`` at the measured
  direction (weight ``weights[2]``, only where the mode was seen there);
* prior residuals ``regularization * s * theta / prior_std`` per parameter,
  with ``s`` the scatter of the weighted data residuals: at least what
  identification leaves (:class:`robolobe.tl.twin_data.IdentificationNoise`
  through ``weights``), in the last stage the fit's own RMS if larger (a
  maximum a posteriori estimate with the residual variance estimated from
  the data).

The search is staged because mode matching makes the misfit multimodal:
stage 1 fits the factor groups from several starts with the matching redone
at every evaluation and a robust loss; stage 2 adds the centres of mass from
the stage-1 result (and random offsets, while the frequencies do not fit to
``accept_rms_f``); last, plain least squares with the matching fixed,
re-matched until it stops changing.

The calibrated robot (``robot_``) is an ordinary robot: :meth:`TwinCalibration.save`
writes it as a robot TOML that planning and simulation accept as is.
Predictions are the calibrated twin's modes with a spread: the parameter
covariance (Gauss-Newton, residual variance from the fit) propagated by
finite differences, plus the RMS log residual of each quantity at the
training postures (what the calibrated twin still misses there: model-form
error and measurement scatter).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from robolobe._matching import match_modes
from robolobe._threads import one_blas_thread, with_one_blas_thread
from robolobe.errors import ConvergenceError, InputError
from robolobe.robots.limits import as_postures
from robolobe.robots.model import Robot
from robolobe.tl.dataset import (
    DRIVING_DIRECTIONS,
    ModalDataset,
    check_meta_counts,
    dataset_from_frame,
)
from robolobe.tl.estimator import ModalPrediction
from robolobe.twin.params import (
    COM_UNIT_M,
    K_MAX,
    PARAMETER_GROUPS,
    ParametrizedTwin,
    apply_parameters,
    group_values,
    modal_values,
    parameter_names,
)

__all__ = [
    "DEFAULT_PARAMS",
    "PARAMETER_GROUPS",
    "PRIOR_STD",
    "TwinCalibration",
    "modal_frame_dataset",
    "parameter_covariance",
    "twin_values",
]

FloatArray = NDArray[np.float64]
#: Default calibrated groups: every group of :data:`PARAMETER_GROUPS`.
DEFAULT_PARAMS = ("stiffness", "damping", "ee_mass", "link_mass", "link_com", "load")
_FIRST_STAGE = ("stiffness", "damping", "ee_mass", "link_mass")
# held-out residuals: Gauss-Newton refit without a posture, from the fit (each step
# costs one eigen-solve and one Jacobian of the tested postures: milliseconds)
_HELD_OUT_STEPS = 6
_HELD_OUT_XTOL = 1e-4  # log-factor step at which the refit stops (0.01 %)
#: Relative cost difference within which two starts of a calibration stage end at the
#: same minimum: the stage stops there (out-of-form robot B draw 1: stage 2's six starts
#: ran 2 s each, the second ended at the first's cost and none of the others lower).
SAME_MINIMUM_RTOL = 1e-3


def _group_of(groups: Sequence[str]) -> list[str]:
    """The group of each parameter of ``groups``, in order."""
    return [g for g in groups for _ in range(PARAMETER_GROUPS[g])]


def _same_minimum(cost: float, best: float) -> bool:
    """Whether a start's final ``cost`` is the best so far found again (within
    :data:`SAME_MINIMUM_RTOL` of it, relative; a lower one is a new minimum)."""
    return bool(abs(cost - best) <= SAME_MINIMUM_RTOL * best)


#: Prior standard deviation of each group's parameters, in ``theta`` units
#: (log factor, or 0.1 m for centres of mass): joint stiffness x0.5-2 and
#: damping x0.4-2.5 at two sigma (rarely published, docs/guide/robots.md);
#: spindle and link masses +-10 %; centres of mass +-5 cm per axis.
PRIOR_STD: dict[str, float] = {
    "stiffness": math.log(2.0) / 2,
    "damping": math.log(2.5) / 2,
    "ee_mass": 0.1,
    "link_mass": 0.1,
    "link_com": 0.05 / COM_UNIT_M,
    "load": 1.0,
}
#: Largest load stiffening a calibration fits (``load``, per 1e4 N m of gravity torque):
#: a joint spring up to 11 x as stiff at 1e4 N m as at no load.
LOAD_MAX = 10.0


def parameter_covariance(jac: FloatArray, s2: float) -> FloatArray:
    """``s2 (J^T J)^+``: the fitted parameters' covariance, positive semi-definite.

    The pseudo-inverse through the eigenvalues of ``J^T J`` (those under
    numpy pinv's cutoff, ``max(shape) eps`` of the largest, dropped), symmetric
    and positive semi-definite by construction: pinv's SVD of an
    ill-conditioned ``J^T J`` gave an eigenvalue of -9e-10 times the largest on
    out-of-form robot C (draw 12), which the saved model's check refuses (a
    default transfer wrote a file it could not read, issue 27).

    Parameters
    ----------
    jac : ndarray, shape (n_res, p)
        Jacobian of the weighted residuals at the fit.
    s2 : float
        Residual variance per degree of freedom.

    Returns
    -------
    ndarray, shape (p, p)
    """
    j = np.asarray(jac, dtype=float)
    w, v = np.linalg.eigh(j.T @ j)
    keep = w > float(np.max(w, initial=0.0)) * max(j.shape) * np.finfo(float).eps
    cov = float(s2) * (v[:, keep] / w[keep]) @ v[:, keep].T
    return np.asarray(0.5 * (cov + cov.T))


def _check_covariance(theta: FloatArray, cov: FloatArray, where: str) -> None:
    """Refuse a stored parameter covariance no fit could give (the file lies)."""
    from robolobe._npz import check_range

    # log factors (stiffness x e^theta...) and centre-of-mass shifts in 0.1 m: beyond
    # +-10 (a factor of 22000, a 1 m shift) no calibration of a robot file lands
    check_range(theta, "theta", where, low=-10.0, high=10.0)
    check_range(cov, "covariance", where)
    scale = float(np.max(np.abs(cov), initial=0.0))
    if not np.allclose(cov, cov.T, rtol=1e-9, atol=1e-12 * scale):
        raise InputError("inconsistent model file: covariance: expected a symmetric matrix", where)
    low = float(np.min(np.linalg.eigvalsh(cov), initial=0.0)) if cov.size else 0.0
    if low < -1e-9 * max(scale, 1e-300):
        raise InputError(
            "inconsistent model file: covariance: expected a positive semi-definite matrix "
            f"(variances >= 0), found an eigenvalue {low:.3g}",
            where,
        )


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
    return modal_values(Twin(robot).modes(q, overdamped="keep"), directions, n_modes)


def _check_some_underdamped(
    robot: Robot, q_rad: FloatArray, posture_ids: Sequence[str], values: FloatArray
) -> None:
    """Refuse a robot file whose damping leaves no resonance at some tested posture.

    Overdamped modes (damping ratio >= 1, two real poles) are calibrated like
    the others (their natural frequency and damping ratio); a posture where
    *every* mode is overdamped has nothing a hammer test could show as a
    resonance, which is a damping value off by orders of magnitude (a unit).

    Parameters
    ----------
    robot : Robot
        The robot file's model.
    q_rad : ndarray, shape (n, 6)
        Tested postures [rad].
    posture_ids : sequence of str
    values : ndarray, shape (n, n_dir, n_modes, 3)
        The file's twin values (:meth:`ParametrizedTwin.values`).

    Raises
    ------
    InputError
        Naming the file, the first such posture and the joint of highest
        damping ratio ``c / (2 sqrt(k M_jj))`` there.
    """
    over = np.all(values[:, 0, :, 1] >= 1.0, axis=-1)  # (n,)
    if not np.any(over):
        return
    from robolobe.twin.system import nominal_system

    i = int(np.flatnonzero(over)[0])
    sys_ = nominal_system(robot, q_rad[i : i + 1])
    m_jj = np.diagonal(sys_.M.reshape(-1, sys_.n_dof, sys_.n_dof)[0])[:6]
    c = np.array([jt.damping_Nms_per_rad for jt in robot.joints])
    k = np.array([jt.stiffness_Nm_per_rad for jt in robot.joints])
    ratio = c / (2.0 * np.sqrt(k * m_jj))
    j = int(np.argmax(ratio))
    raise InputError(
        f"every mode of the robot file's twin is overdamped (no resonance to measure) at "
        f"posture {posture_ids[i]!r} ({int(over.sum())} of {len(over)} postures); joint "
        f"{j + 1}: damping {c[j]:.4g} N m s/rad is {ratio[j]:.3g} x critical: check the "
        "joints' damping_Nms_per_rad (unit N m s/rad; typical joints 0.5-5 % of critical)",
        source=robot.source,
    )


MISFIT_REFUSE_LOG_K = math.log(3.0)
"""RMS log modal-stiffness misfit of one direction (a factor of 3) beyond which the
calibrated twin is refused: model-form errors the twin lacks leave 7-19 % (studies/
tl_graybox.py), a heavily damped robot's complex close pairs ~30 %; a factor of 3 is a
wrong robot or mislabelled directions."""
MISFIT_REFUSE_LOG_F = math.log(1.1)
"""RMS log frequency misfit (10 %) beyond which the calibrated twin is refused."""


def _check_fits_the_robot(
    ds: ModalDataset, y: FloatArray, model: FloatArray, idx: tuple[NDArray[np.intp], ...]
) -> None:
    """Refuse tests that the calibrated twin cannot fit (wrong robot, mislabelled directions).

    Parameters
    ----------
    ds : ModalDataset
    y : ndarray, shape (n, n_dir, n_modes, 3)
        Measured values.
    model : ndarray, shape (n, n_dir, n_twin, 3)
        The calibrated twin's values.
    idx : tuple of 4 index arrays
        Matched pairs ``(posture, direction, measured mode, twin mode)``.

    Raises
    ------
    InputError
        Per direction, the RMS log misfit of modal stiffness beyond
        :data:`MISFIT_REFUSE_LOG_K` or of frequency beyond
        :data:`MISFIT_REFUSE_LOG_F`; names the direction, the worst posture and,
        when the stiffnesses fit another direction of the twin, that direction.
    """
    i, j, m, t = idx
    dirs = tuple(ds.directions)
    with np.errstate(invalid="ignore", divide="ignore"):
        lf = np.log(y[i, j, m, 0] / model[i, j, t, 0])
        lk_all = np.log(y[i, j, m, 2][:, None] / model[i, :, t, 2])  # (pairs, n_dir)
    for d, name in enumerate(dirs):
        sel = j == d
        if not sel.any():
            continue
        rms_f = float(np.sqrt(np.nanmean(lf[sel] ** 2)))
        fin = np.isfinite(lk_all[sel])
        rms_k = np.sqrt(np.nanmean(np.where(fin, lk_all[sel], np.nan) ** 2, axis=0))
        if rms_f <= MISFIT_REFUSE_LOG_F and not rms_k[d] > MISFIT_REFUSE_LOG_K:
            continue
        bad = np.abs(lk_all[sel, d]) if rms_k[d] > MISFIT_REFUSE_LOG_K else np.abs(lf[sel])
        worst = ds.posture_ids[int(i[sel][int(np.nanargmax(bad))])]
        what = (
            f"modal stiffness off by a factor of {math.exp(rms_k[d]):.3g} (RMS)"
            if rms_k[d] > MISFIT_REFUSE_LOG_K
            else f"frequencies off by {100 * (math.exp(rms_f) - 1):.3g} % (RMS)"
        )
        # the twin was calibrated to the labels given: a swapped direction fits its true
        # one only better, not well
        alt = sorted(
            (e for e in range(len(dirs)) if e != d and rms_k[e] < 0.7 * rms_k[d]),
            key=lambda e: float(rms_k[e]),
        )
        hint = (
            f"; they fit the twin's {dirs[alt[0]]!r} (factor {math.exp(rms_k[alt[0]]):.3g}): "
            "mislabelled directions? check the sensor and hammer axes against the TCP frame"
            if alt and rms_k[d] > MISFIT_REFUSE_LOG_K
            else "; the tests do not look like this robot file's (a wrong robot or a sensor "
            "frame other than the TCP frame?)"
        )
        raise InputError(
            f"direction {name!r}: the calibrated twin cannot fit the measured modes: {what}, "
            f"worst at posture {worst!r}{hint}"
        )


def _unmatched(
    ds: ModalDataset, idx: tuple[NDArray[np.intp], ...]
) -> tuple[tuple[str, str, float], ...]:
    """Measured modes without a twin partner: ``(posture id, direction, f [Hz])`` each."""
    y = np.asarray(ds.y)
    left = np.isfinite(y[..., 0])
    left[idx[0], idx[1], idx[2]] = False
    return tuple(
        (ds.posture_ids[i], ds.directions[j], float(y[i, j, m, 0])) for i, j, m in np.argwhere(left)
    )


def _warn_unmatched(
    unmatched: Sequence[tuple[str, str, float]], match_tol: float, match_k_gate: float
) -> None:
    """Say which measured modes the calibrated twin has no counterpart for."""
    import warnings

    from robolobe.tl.dataset import TrustWarning

    f = np.array([u[2] for u in unmatched])
    where = ", ".join(f"{p}/{d} {x:.4g} Hz" for p, d, x in unmatched[:6])
    more = f" and {len(unmatched) - 6} more" if len(unmatched) > 6 else ""
    warnings.warn(
        f"{len(unmatched)} measured mode(s) at {f.min():.4g}-{f.max():.4g} Hz have no twin mode "
        f"within {100 * (np.exp(match_tol) - 1):.0f} % in frequency and a factor of "
        f"{np.exp(match_k_gate):.3g} in stiffness ({where}{more}): physics the robot file "
        "lacks (a motor or servo mode, a spindle bracket) or spurious modes; they are left out "
        "of the calibration; a corrected twin (the default transfer) keeps those seen at enough "
        "postures as extra modes interpolated over posture (robolobe.tl.extra_modes), the "
        "calibrated robot file alone does not predict them",
        TrustWarning,
        stacklevel=3,
    )


def modal_frame_dataset(modal_df: pd.DataFrame) -> ModalDataset:
    """The driving-point rows (``xx``, ``yy``, ``zz``) of a ``modal.csv`` frame as a dataset.

    Parameters
    ----------
    modal_df : pandas.DataFrame
        Columns posture_id, q1_deg..q6_deg, dir, mode, f_hz, zeta, k_N_per_m
        (:func:`robolobe.modal.modal_csv.read_modal_csv`).

    Returns
    -------
    ModalDataset
        Every driving-point direction present, as many modes as numbered.
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
    return dataset_from_frame(modal_df, directions=dirs, n_modes=n_modes)


class TwinCalibration:
    """Fit the uncertain parameters of a robot file to measured modes.

    Parameters
    ----------
    robot : Robot or str
        The robot file's model (``"B"``, a ``.toml`` path or a Robot): the prior.
    params : sequence of str
        Groups to calibrate (:data:`robolobe.twin.params.PARAMETER_GROUPS`):
        ``"stiffness"``, ``"damping"``, ``"ee_mass"``, ``"link_mass"``,
        ``"link_com"``, ``"load"``; default all (43 parameters).
    bounds : (float, float)
        Bounds of every factor (stiffness, damping, masses).
    com_bound_m : float
        Largest centre-of-mass offset per axis [m].
    regularization : float
        Multiplier of the prior residuals pulling each parameter toward the
        robot file (1: the prior :data:`PRIOR_STD`; 0: none, parameters the
        data do not see wander).
    prior_std : dict of str to float, optional
        Prior standard deviation per group in ``theta`` units, overriding
        :data:`PRIOR_STD` for the groups given.
    weights : (float, float, float)
        Residual weights of log frequency, log damping and log stiffness.
    match_tol : float
        Largest ``|log f_meas / f_twin|`` of a matched pair (0.3: 35 %).
    match_k_weight : float
        Weight of ``|log k_meas / k_twin|`` (capped at 3) in the matching cost,
        which separates close modes seen in different directions.
    match_k_gate : float
        Largest ``|log k_meas / k_twin|`` of a pair in the final, gated
        matching (``log 10``): a measured mode the twin lacks (a motor or
        bracket mode) is left unmatched rather than paired with a twin mode
        that the direction does not see.
    n_rematch : int
        Most match-then-solve rounds.
    min_postures : int
        Fewest postures accepted by :meth:`fit`.
    robot_name : str or None
        Name of the calibrated robot (default ``<name>-calibrated``).
    n_starts : int
        Starts of the first stage (the factor groups; the robot file's values
        and ``n_starts - 1`` random factors in [0.75, 1.35]); the best is kept.
    n_starts_com : int
        Starts of the second stage (all groups, from the first stage's factors;
        centres of mass at the file's, then ``N(0, 5 cm)`` per axis).
    accept_rms_f : float
        A start whose RMS log-frequency residual is at most this (0.002: twice
        the identification scatter of frequencies) ends a stage's search; so
        does a start that ends at the best cost found so far (within
        :data:`SAME_MINIMUM_RTOL`): the minimum is found again, and out-of-form
        robots, whose frequencies never fit to the noise, do not run every start.
    random_state : int or None
        Seed of the random starts.

    Attributes
    ----------
    factors_ : dict of str to ndarray
        Fitted values per group (:func:`robolobe.twin.params.group_values`):
        factors (shape (6,) or (1,)); for ``link_com`` the offsets [m], shape
        (6, 3); for ``load`` the stiffening per 1e4 N m, shape (6,).
    robot_ : Robot
        The calibrated robot.
    param_names_ : tuple of str
        ``k1..k6``, ``d1..d6``, ``m_ee``, ``m1..m6``, ``c1x..c6z``, ``l1..l6``
        for the calibrated groups.
    theta_ : ndarray, shape (n_params,)
        Fitted parameters (log factors; COM offsets in units of 0.1 m).
    param_std_ : ndarray, shape (n_params,)
        Standard deviation of ``theta_`` (~ relative std of a factor).
    covariance_ : ndarray, shape (n_params, n_params)
        Covariance of ``theta_``.
    residual_rms_ : dict of str to float
        RMS of the unweighted log residuals ``f``, ``zeta``, ``k`` at the fit.
    n_matched_ : int
        Matched (posture, direction, mode) pairs; ``n_unmatched_`` measured
        modes left without a partner (``unmatched_``: their posture id,
        direction and frequency [Hz]; a TrustWarning names them). More
        measured modes per direction than the twin has are accepted.
    at_bounds_ : tuple of str
        Parameters that ended at a bound (the data want more than allowed).
    directions_ : tuple of str
    n_modes_ : int
        Modes per direction of the predictions: as many as the training data
        number, at most the twin's.
    """

    def __init__(
        self,
        *,
        robot: Robot | str | os.PathLike[str],
        params: Sequence[str] = DEFAULT_PARAMS,
        bounds: tuple[float, float] = (0.3, 3.0),
        com_bound_m: float = 0.15,
        regularization: float = 1.0,
        prior_std: dict[str, float] | None = None,
        weights: tuple[float, float, float] = (1.0, 0.2, 0.3),
        match_tol: float = 0.3,
        match_k_weight: float = 0.1,
        match_k_gate: float = math.log(10.0),
        n_rematch: int = 4,
        min_postures: int = 5,
        robot_name: str | None = None,
        n_starts: int = 4,
        n_starts_com: int = 6,
        accept_rms_f: float = 0.002,
        random_state: int | None = 0,
    ) -> None:
        self.robot = robot
        self.params = params
        self.bounds = bounds
        self.com_bound_m = com_bound_m
        self.regularization = regularization
        self.prior_std = prior_std
        self.weights = weights
        self.match_tol = match_tol
        self.match_k_weight = match_k_weight
        self.match_k_gate = match_k_gate
        self.n_rematch = n_rematch
        self.min_postures = min_postures
        self.robot_name = robot_name
        self.n_starts = n_starts
        self.n_starts_com = n_starts_com
        self.accept_rms_f = accept_rms_f
        self.random_state = random_state

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
        if not self.com_bound_m > 0:
            raise InputError(f"com_bound_m: expected > 0 m, found {self.com_bound_m}")
        if (
            self.regularization < 0
            or self.match_tol <= 0
            or self.n_rematch < 1
            or self.n_starts < 1
            or self.n_starts_com < 1
        ):
            raise InputError(
                "expected regularization >= 0, match_tol > 0, n_rematch >= 1 and n_starts >= 1, "
                f"found {self.regularization}, {self.match_tol}, {self.n_rematch}, {self.n_starts}"
            )
        if len(self.weights) != 3 or any(w < 0 for w in self.weights):
            raise InputError(f"weights: expected 3 non-negative numbers, found {self.weights}")
        prior = dict(self.prior_std or {})
        bad_prior = {
            g: v for g, v in prior.items() if g not in PARAMETER_GROUPS or not float(v) > 0
        }
        if bad_prior:
            raise InputError(
                f"prior_std: expected positive values for groups of {tuple(PARAMETER_GROUPS)}, "
                f"found {bad_prior}"
            )
        return robot, groups

    def _prior_vector(self, groups: tuple[str, ...]) -> FloatArray:
        """Prior standard deviation of every parameter [theta units], shape (n_params,)."""
        sd = {**PRIOR_STD, **(self.prior_std or {})}
        return np.concatenate([np.full(PARAMETER_GROUPS[g], float(sd[g])) for g in groups])

    def _noise_floor(self) -> float:
        """RMS of the weighted log residuals that identification scatter alone leaves."""
        from robolobe.tl.twin_data import IdentificationNoise

        noise = IdentificationNoise()
        w = np.asarray(self.weights, dtype=float)
        return float(np.sqrt(np.mean((w * [noise.f, noise.zeta, noise.k]) ** 2)))

    def _theta_bounds(self, groups: tuple[str, ...]) -> tuple[FloatArray, FloatArray]:
        lo, hi = (float(np.log(b)) for b in self.bounds)
        c = float(self.com_bound_m) / COM_UNIT_M
        los: list[float] = []
        his: list[float] = []
        for g in groups:
            n = PARAMETER_GROUPS[g]
            if g == "load":  # a stiffening: from none (the file's) up
                los += [0.0] * n
                his += [LOAD_MAX] * n
                continue
            los += [-c if g == "link_com" else lo] * n
            his += [c if g == "link_com" else hi] * n
        return np.asarray(los), np.asarray(his)

    def _match(
        self, ds: ModalDataset, model: FloatArray, tol: float | None = None
    ) -> tuple[tuple[NDArray[np.intp], ...], int]:
        """Assign measured modes to twin modes; returns index arrays and unmatched count.

        Per posture and direction the assignment of least total cost
        ``|log f_meas / f_twin| + match_k_weight * min(|log k_meas / k_twin|, 3)``
        (:func:`robolobe._matching.match_modes`; absent measured modes take no
        part). Returns ``(posture, direction, measured mode, twin mode)``
        index arrays of the pairs within ``tol`` in log frequency: the gate is
        applied after the assignment, on the frequency term alone, so that a
        mode whose best partner is too far is left out rather than pushing
        its neighbours onto other twin modes.
        """
        tol = self.match_tol if tol is None else tol
        y = np.asarray(ds.y)
        present = np.isfinite(y[..., 0])  # (n, nd, nm)
        with np.errstate(invalid="ignore", divide="ignore"):
            df = np.abs(np.log(y[..., :, None, 0] / model[..., None, :, 0]))  # (n, nd, nm, nt)
            dk_raw = np.abs(np.log(y[..., :, None, 2] / model[..., None, :, 2]))
        dk = np.where(np.isfinite(dk_raw), np.minimum(dk_raw, 3.0), 0.0)
        cost = np.where(present[..., None], df + self.match_k_weight * dk, np.nan)
        nt = model.shape[2]
        if y.shape[2] > nt:
            # more measured modes than the twin has: some are physics the file lacks (a
            # motor mode). A twin mode whose stiffness at the direction is off by more
            # than match_k_gate is no partner, so that such a mode does not take the
            # place of a twin mode that this direction does not see; and in the search
            # stages (ungated) a measured mode may pair with "none" at _none_cost (the
            # caller gives it a constant residual: the number of residuals stays fixed).
            # With at most the twin's modes the matching is as it always was.
            cost = np.where(np.isfinite(dk_raw) & (dk_raw > self.match_k_gate), np.inf, cost)
            if not np.isfinite(tol):
                none = np.where(present[..., None], self._none_cost(), np.nan)
                cost = np.concatenate(
                    [cost, np.broadcast_to(none, (*cost.shape[:-1], cost.shape[-2]))], axis=-1
                )
        ii, jj, mm, tt = match_modes(cost)
        ok = tt < nt
        ok[ok] = df[ii[ok], jj[ok], mm[ok], tt[ok]] <= tol
        idx = (ii[ok], jj[ok], mm[ok], tt[ok])
        return tuple(np.asarray(a, dtype=np.intp) for a in idx), int(present.sum() - ok.sum())

    def _none_cost(self) -> float:
        """Matching cost of leaving a measured mode unpaired in the search stages."""
        return float(self.match_tol + 3.0 * self.match_k_weight)

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
        return self.fit_dataset(modal_frame_dataset(modal_df))

    def fit_dataset(self, ds: ModalDataset) -> TwinCalibration:
        """Calibrate on a :class:`~robolobe.tl.dataset.ModalDataset` (NaN = not seen)."""
        with one_blas_thread():
            return self._fit_dataset(ds)

    def _fit_dataset(self, ds: ModalDataset) -> TwinCalibration:
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
        names = parameter_names(groups)
        p = len(names)
        lo, hi = self._theta_bounds(groups)
        q = ds.q_rad
        nm = ds.n_modes
        twin = ParametrizedTwin(base, q, groups, directions=ds.directions, n_modes=6)
        n_twin = twin.modes(np.zeros(p)).f_hz.shape[-1]
        twin.n_modes = n_twin
        _check_some_underdamped(base, q, ds.posture_ids, twin.values(np.zeros(p)))
        wf, wz, wk = (float(w) for w in self.weights)
        reg = float(self.regularization)
        prior_sd = self._prior_vector(groups)
        # weight of the prior rows: the scatter of the weighted data residuals
        # (updated from the fit in the last stage)
        prior_w = np.array([reg * self._noise_floor()])
        cache: dict[bytes, FloatArray] = {}

        def model(theta: FloatArray) -> FloatArray:
            key = np.asarray(theta, dtype=float).tobytes()
            if key not in cache:
                if len(cache) > 64:
                    cache.clear()
                cache[key] = twin.values(theta)
            return cache[key]

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
            return np.concatenate([data_res(theta, idx), prior_w[0] * theta / prior_sd])

        wvec = np.array([wf, wz, wk])
        jcache: dict[bytes, FloatArray] = {}

        def jacobian(theta: FloatArray, idx: tuple[NDArray[np.intp], ...]) -> FloatArray:
            key = np.asarray(theta, dtype=float).tobytes()
            if key not in jcache:
                jcache.clear()
                jcache[key] = twin.log_jacobian(theta)
            i, j, m, t = idx
            d = -jcache[key][i, j, t] * wvec[None, :, None]  # (n_pairs, 3, p)
            rows = d[np.isfinite(y[i, j, m])]
            return np.vstack([rows, np.diag(prior_w[0] / prior_sd)])

        fin_vals = np.isfinite(y)  # (n, nd, nm, 3)
        n_vals = int(fin_vals.sum())
        none_res = wf * self._none_cost()

        def n_fill(idx: tuple[NDArray[np.intp], ...]) -> int:
            """Finite values of the measured modes left unpaired (constant residuals)."""
            return n_vals - int(fin_vals[idx[0], idx[1], idx[2]].sum())

        mcache: dict[bytes, tuple[tuple[NDArray[np.intp], ...], int]] = {}

        def matched(theta: FloatArray) -> tuple[tuple[NDArray[np.intp], ...], int]:
            """Ungated matching at ``theta`` (the residuals' and the Jacobian's: once)."""
            key = np.asarray(theta, dtype=float).tobytes()
            if key not in mcache:
                if len(mcache) > 64:
                    mcache.clear()
                mcache[key] = self._match(ds, model(theta), tol=np.inf)
            return mcache[key]

        def dyn_jac(theta: FloatArray) -> FloatArray:
            idx, _ = matched(theta)
            jac_ = jacobian(theta, idx)
            nd_ = jac_.shape[0] - p
            return np.vstack([jac_[:nd_], np.zeros((n_fill(idx), p)), jac_[nd_:]])

        def dyn_res(theta: FloatArray) -> FloatArray:
            # every measured mode matched afresh (continuous where modes cross); one left
            # unpaired adds constant residuals, so that their number stays fixed
            idx, _ = matched(theta)
            r_ = residuals(theta, idx)
            nd_ = r_.size - p
            return np.concatenate([r_[:nd_], np.full(n_fill(idx), none_res), r_[nd_:]])

        def rms_f(theta: FloatArray) -> float:
            idx0, _ = matched(theta)
            mod0 = model(theta)
            f_res = np.log(y[idx0[0], idx0[1], idx0[2], 0] / mod0[idx0[0], idx0[1], idx0[3], 0])
            return float(np.sqrt(np.mean(f_res**2)))

        n_res0 = int(np.isfinite(y).sum())
        if n_res0 < p:
            raise InputError(
                f"expected at least {p} modal values to fit {p} factors, found {n_res0}"
            )
        # stage 1: the factor groups, robust loss, matching inside the residuals,
        # several starts (frequency matching has local minima where modes cross)
        first = np.concatenate(
            [np.full(PARAMETER_GROUPS[g], g in _FIRST_STAGE) for g in groups]
        ).astype(bool)
        if not first.any():
            first[:] = True
        theta = np.zeros(p)

        def sub_res(x: FloatArray) -> FloatArray:
            th = theta.copy()
            th[first] = x
            return dyn_res(th)

        def sub_jac(x: FloatArray) -> FloatArray:
            th = theta.copy()
            th[first] = x
            return dyn_jac(th)[:, first]

        rng = np.random.default_rng(self.random_state)
        n1 = int(first.sum())
        starts = [np.zeros(n1)] + [
            rng.uniform(np.log(0.75), np.log(1.35), n1) for _ in range(int(self.n_starts) - 1)
        ]
        sol: Any = None
        for x0 in starts:
            s0 = least_squares(
                sub_res,
                np.clip(x0, lo[first] + 1e-9, hi[first] - 1e-9),
                jac=sub_jac,
                bounds=(lo[first], hi[first]),
                loss="soft_l1",
                f_scale=0.02,
                max_nfev=8 * (n1 + 1),
            )
            again = sol is not None and _same_minimum(s0.cost, sol.cost)
            if sol is None or s0.cost < sol.cost:
                sol = s0
            th1 = theta.copy()
            th1[first] = sol.x
            if again or rms_f(th1) <= self.accept_rms_f:
                break  # the best found again, or frequencies fit to the noise level
        theta[first] = sol.x
        # stage 2: every group from there (centres of mass start at the file's,
        # then at random offsets while that does not reach the acceptance level)
        if not first.all():
            theta1 = theta.copy()
            best: Any = None
            for k_start in range(int(self.n_starts_com)):
                x0 = theta1.copy()
                if k_start:
                    x0[~first] = rng.normal(0.0, 0.5, int((~first).sum()))
                res2 = least_squares(
                    dyn_res,
                    np.clip(x0, lo + 1e-9, hi - 1e-9),
                    jac=dyn_jac,
                    bounds=(lo, hi),
                    loss="soft_l1",
                    f_scale=0.02,
                    max_nfev=8 * (p + 1),
                )
                again = best is not None and _same_minimum(res2.cost, best.cost)
                if best is None or res2.cost < best.cost:
                    best = res2
                if again or rms_f(np.asarray(best.x)) <= self.accept_rms_f:
                    break
            theta = np.asarray(best.x)
        # then: matching fixed (pairs within match_tol), plain least squares
        idx, unmatched = self._match(ds, model(theta))
        for _ in range(int(self.n_rematch)):
            n_res = int(np.isfinite(y[idx[0], idx[1], idx[2]]).sum())
            if n_res < p:
                raise InputError(
                    f"expected at least {p} matched modal values to fit {p} factors, found "
                    f"{n_res} ({unmatched} of {int(np.isfinite(y[..., 0]).sum())} measured modes "
                    f"had no twin mode within {100 * (np.exp(self.match_tol) - 1):.0f} %)"
                )
            r0 = data_res(theta, idx)
            prior_w[0] = reg * max(self._noise_floor(), float(np.sqrt(np.mean(r0**2))))
            sol = least_squares(
                residuals,
                theta,
                jac=jacobian,
                bounds=(lo, hi),
                args=(idx,),
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
        _check_fits_the_robot(ds, y, model(theta), idx)
        # covariance of theta: s^2 (J^T J)^-1 with the data residual variance
        jac = np.asarray(sol.jac)
        r_data = data_res(theta, idx)
        dof = max(r_data.size - p, 1)
        s2 = float(r_data @ r_data) / dof
        cov = parameter_covariance(jac, s2)
        i, j, m, t = idx
        raw = np.log(y[i, j, m] / model(theta)[i, j, t])
        rms = {
            name: float(np.sqrt(np.nanmean(raw[:, c] ** 2)))
            if np.isfinite(raw[:, c]).any()
            else float("nan")
            for c, name in enumerate(("f", "zeta", "k"))
        }
        rob = apply_parameters(base, groups, theta)
        self.theta_ = theta
        self.factors_ = group_values(groups, theta)
        self.robot_ = rob.replace(name=self.robot_name or f"{base.name}-calibrated")
        self.base_robot_ = base
        self.groups_ = groups
        self.param_names_ = names
        self.covariance_ = cov
        self.param_std_ = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        self.residual_rms_ = rms
        self.n_matched_ = len(i)
        self.n_unmatched_ = unmatched
        self.directions_ = tuple(ds.directions)
        # predictions are the twin's modes: as many as measured, at most the twin's
        self.n_modes_ = min(nm, n_twin)
        self.n_postures_ = ds.n_postures
        self.unmatched_ = _unmatched(ds, idx)
        if self.unmatched_ and nm > n_twin:
            # more measured modes than the twin: say which ones the model leaves out
            # (otherwise the count is reported as always, n_unmatched_)
            _warn_unmatched(self.unmatched_, self.match_tol, self.match_k_gate)
        # (no load stiffening, the lower bound of ``load``, is the file's value: not a bound
        # the data push against)
        self.at_bounds_ = tuple(
            n
            for n, th, a, b, g in zip(names, theta, lo, hi, _group_of(groups), strict=True)
            if (b - th < 1e-3) or (g != "load" and th - a < 1e-3)
        )
        self.train_q_rad_ = np.array(q)
        return self

    # ------------------------------------------------------------ predict
    def _check_fitted(self) -> None:
        if not hasattr(self, "robot_"):
            raise InputError("this TwinCalibration is not fitted yet: call fit()")

    @with_one_blas_thread
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
            Propagate the parameter covariance (first order, analytic
            eigen-sensitivities) and add the training residual scatter;
            False gives zero spread.

        Returns
        -------
        ModalPrediction
            ``kind="log"``: ``center`` is the log of the values and ``std`` the
            standard deviation of the log, shape (n, n_dir, n_modes, 3).
        """
        self._check_fitted()
        q = as_postures(q_rad)
        dirs = tuple(directions) if directions is not None else self.directions_
        nm = int(n_modes) if n_modes is not None else self.n_modes_
        twin = ParametrizedTwin(self.base_robot_, q, self.groups_, directions=dirs, n_modes=nm)
        center = np.log(twin.values(self.theta_))
        std = np.zeros_like(center)
        if spread:
            # first-order propagation with the analytic eigen-sensitivities, in
            # chunks of postures (the Jacobian holds n * n_params * 36 numbers)
            var = np.empty_like(center)
            for lo in range(0, len(q), 2000):
                part = ParametrizedTwin(
                    self.base_robot_, q[lo : lo + 2000], self.groups_, directions=dirs, n_modes=nm
                )
                jac = part.log_jacobian(self.theta_)  # (n, n_dir, nm, 3, n_params)
                var[lo : lo + 2000] = np.einsum("...a,ab,...b->...", jac, self.covariance_, jac)
            # plus what the calibrated twin still misses at the training postures
            # (model-form error and measurement scatter), per quantity
            rms = np.array([self.residual_rms_[c] for c in ("f", "zeta", "k")])
            std = np.sqrt(np.clip(var, 0.0, None) + np.nan_to_num(rms) ** 2)
        return ModalPrediction(directions=dirs, center=center, std=std, kind="log")

    @with_one_blas_thread
    def held_out_residuals(self, ds: ModalDataset, n_modes: int) -> FloatArray:
        """Log residuals at each tested posture of the calibration fitted without it.

        The fit's in-sample residuals understate its error at other postures
        (its parameters were fitted to them: on out-of-form robots the
        stiffness residual at new postures is 1.5-2.4 times the in-sample
        one). Posture ``i``'s rows are left out of the final least-squares
        stage (matching fixed, the same prior rows) and the parameters refitted
        from the fit by Gauss-Newton steps (at most ``_HELD_OUT_STEPS``, until
        no parameter moves by ``_HELD_OUT_XTOL``, within the fit's bounds); the
        residual at ``i`` is the refitted twin's. A first-order deletion (one
        step at the fit's Jacobian) was tried first: along the calibration's
        flat valleys it kept half the refit's move at some postures.

        Parameters
        ----------
        ds : ModalDataset
            The tests the calibration was fitted to.
        n_modes : int
            Twin modes of the output (extra measured modes are left out).

        Returns
        -------
        ndarray, shape (n, n_dir, n_modes, 3)
            ``log(measured / twin)`` of f, zeta, k at twin mode order, each
            posture's from the fit without it (NaN: no matched value).
        """
        self._check_fitted()
        q = np.asarray(ds.q_rad, dtype=float)
        y = np.asarray(ds.y)
        twin = ParametrizedTwin(
            self.base_robot_, q, self.groups_, directions=ds.directions, n_modes=6
        )
        theta = np.asarray(self.theta_, dtype=float)
        vals = twin.values(theta)
        (i, j, m, t), _ = self._match(ds, vals)
        with np.errstate(divide="ignore", invalid="ignore"):
            raw = np.log(y[i, j, m] / vals[i, j, t])  # (pairs, 3)
        w = np.asarray(self.weights, dtype=float)
        ok = np.isfinite(raw) & (vals[i, j, t] < K_MAX)
        jac = -twin.log_jacobian(theta)[i, j, t] * w[None, :, None]  # (pairs, 3, p)
        r_w = np.where(ok, raw * w, 0.0)
        jac = np.where(ok[..., None], jac, 0.0)
        prior_sd = self._prior_vector(self.groups_)
        used = r_w[ok]
        prior_w = float(self.regularization) * max(
            self._noise_floor(), float(np.sqrt(np.mean(used**2))) if used.size else 0.0
        )
        prior_a = (prior_w / prior_sd) ** 2
        lo, hi = self._theta_bounds(self.groups_)
        n_par = jac.shape[-1]
        held = np.full((len(q), len(ds.directions), n_modes, 3), np.nan)
        for k in np.unique(i):
            rest = i != k
            th = theta.copy()
            j_rest, r_rest = jac[rest].reshape(-1, n_par), r_w[rest].reshape(-1)
            for step in range(_HELD_OUT_STEPS):
                if step:
                    v = twin.values(th)[i, j, t]
                    with np.errstate(divide="ignore", invalid="ignore"):
                        r_new = np.log(y[i, j, m] / v) * w
                    j_new = -twin.log_jacobian(th)[i, j, t] * w[None, :, None]
                    r_rest = np.where(ok, r_new, 0.0)[rest].reshape(-1)
                    j_rest = np.where(ok[..., None], j_new, 0.0)[rest].reshape(-1, n_par)
                grad = j_rest.T @ r_rest + prior_a * th
                hess = j_rest.T @ j_rest + np.diag(prior_a)
                try:
                    d = -np.linalg.solve(hess, grad)
                except np.linalg.LinAlgError:
                    d = -np.linalg.lstsq(hess, grad, rcond=None)[0]
                th = np.clip(th + d, lo, hi)
                if np.max(np.abs(d)) < _HELD_OUT_XTOL:
                    break
            sel = i == k
            v_k = twin.values(th)[i[sel], j[sel], t[sel]]
            with np.errstate(divide="ignore", invalid="ignore"):
                ho = np.log(y[i[sel], j[sel], m[sel]] / v_k)
            keep = t[sel] < n_modes
            block = np.where(ok[sel] & np.isfinite(ho), ho, np.nan)[keep]
            held[k, j[sel][keep], t[sel][keep]] = block
        return held

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
        """Fitted parameters, one row each.

        Columns: ``param``, ``value`` (a factor on the robot file's value, a
        centre-of-mass offset [m], or a joint's load stiffening: its relative
        stiffening per 1e4 N m of gravity torque), ``unit`` (``"x"``, ``"m"`` or
        ``"per 1e4 N m"``) and ``std`` (1 sigma: relative for factors, [m] for
        offsets, in the value's units for the load stiffening).
        """
        self._check_fitted()
        group = np.array(_group_of(self.groups_))
        com, load = group == "link_com", group == "load"
        values = group_values(self.groups_, self.theta_)  # in the order of the groups
        return pd.DataFrame(
            {
                "param": self.param_names_,
                "value": np.concatenate([np.ravel(values[g]) for g in self.groups_]),
                "unit": np.where(com, "m", np.where(load, "per 1e4 N m", "x")),
                "std": np.where(com, COM_UNIT_M * self.param_std_, self.param_std_),
            }
        )

    # --------------------------------------------------------------- save
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the calibrated robot as a robot TOML (usable as ``robot.name`` in a job)."""
        from robolobe.robots.io import save_robot

        self._check_fitted()
        return save_robot(self.robot_, path)

    def state(self) -> tuple[dict[str, Any], dict[str, FloatArray]]:
        """What :meth:`predict` needs, as JSON-able metadata and float arrays.

        :meth:`from_state` rebuilds a fitted calibration from them (no pickling).
        """
        from robolobe.robots.io import robot_to_toml

        self._check_fitted()
        meta = {
            "base_robot_toml": robot_to_toml(self.base_robot_),
            "robot_name": self.robot_.name,
            "groups": list(self.groups_),
            "residual_rms": dict(self.residual_rms_),
            "directions": list(self.directions_),
            "n_modes": int(self.n_modes_),
            "n_postures": int(self.n_postures_),
            "n_matched": int(self.n_matched_),
            "n_unmatched": int(self.n_unmatched_),
            "at_bounds": list(self.at_bounds_),
        }
        arrays = {
            "theta": np.asarray(self.theta_, dtype=float),
            "covariance": np.asarray(self.covariance_, dtype=float),
            "train_q_rad": np.asarray(self.train_q_rad_, dtype=float),
        }
        return meta, arrays

    @classmethod
    def from_state(
        cls, meta: dict[str, Any], arrays: dict[str, Any], where: str
    ) -> TwinCalibration:
        """A fitted calibration from :meth:`state`'s output (``where`` names the file)."""
        from robolobe._documents import parse_toml
        from robolobe.robots.io import robot_from_dict

        try:
            base = robot_from_dict(parse_toml(str(meta["base_robot_toml"]), where), where)
            groups = tuple(str(g) for g in meta["groups"])
            theta = np.asarray(arrays["theta"], dtype=float)
            cov = np.asarray(arrays["covariance"], dtype=float)
            names = parameter_names(groups)
            if theta.shape != (len(names),) or cov.shape != (len(names), len(names)):
                raise InputError(f"theta/covariance do not fit {len(names)} parameters")
            _check_covariance(theta, cov, where)
            self = cls(robot=base, params=groups)
            self.theta_ = theta
            self.covariance_ = cov
            self.param_std_ = np.sqrt(np.clip(np.diag(cov), 0.0, None))
            self.base_robot_ = base
            self.groups_ = groups
            self.param_names_ = names
            self.robot_ = apply_parameters(base, groups, theta).replace(
                name=str(meta["robot_name"])
            )
            self.factors_ = group_values(groups, theta)
            self.residual_rms_ = {str(a): float(b) for a, b in meta["residual_rms"].items()}
            self.directions_ = tuple(str(d) for d in meta["directions"])
            self.n_modes_ = int(meta["n_modes"])
            check_meta_counts(self.directions_, self.n_modes_, where)
            self.n_postures_ = int(meta["n_postures"])
            self.n_matched_ = int(meta["n_matched"])
            self.n_unmatched_ = int(meta["n_unmatched"])
            self.unmatched_ = ()  # the fit's warning named them
            self.at_bounds_ = tuple(str(a) for a in meta["at_bounds"])
            self.train_q_rad_ = np.asarray(arrays["train_q_rad"], dtype=float)
        except InputError as exc:
            if exc.source is not None:
                raise
            raise InputError(f"inconsistent twin calibration ({exc})", source=where) from None
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"inconsistent twin calibration ({exc})", source=where) from None
        if not {"f", "zeta", "k"} <= set(self.residual_rms_):
            raise InputError(
                "inconsistent twin calibration: residual_rms: expected f, zeta and k, found "
                f"{sorted(self.residual_rms_)}",
                source=where,
            )
        return self

    def __repr__(self) -> str:
        state = "fitted" if hasattr(self, "robot_") else "unfitted"
        return f"TwinCalibration(params={tuple(self.params)}, {state})"
