"""The calibrated twin plus a learned correction of what it still misses.

A twin calibration (:class:`robolobe.tl.graybox.TwinCalibration`) fits the
physical parameters a robot file gets wrong, but not what its *form* lacks:
link inertias of another shape, gear stiffness that grows with the gravity
load, a tool (hammer-test point) not where the file says. Those leave a
smooth, posture-dependent residual. :class:`CorrectedTwin` learns it:

1. calibrate the twin on the hammer tests;
2. residuals ``r = log(measured / twin)`` of f, zeta and k per direction and
   twin mode (the calibration's own mode matching, so a mode not seen in a
   direction is not mistaken for the next one);
3. per quantity, a Gaussian process on the joint angles shared by all
   (direction, mode) outputs: each output scaled to unit RMS, an RBF kernel
   with one length scale per joint and a signal fraction ``rho`` (the rest is
   scatter), hyperparameters by the pooled marginal likelihood; or taken,
   frozen, from a source model fitted on another robot (``kernel_source``:
   the length scales of model-form residuals learned on robot A's campaign,
   only ``rho`` refitted);
4. per output, the leave-one-out predictions ``g`` of the process
   (closed form) decide how much of it to use: ``alpha = <r, g> / <g, g>``
   clipped to [0, 1], and ``alpha = 0`` (the calibrated twin unchanged)
   unless the leave-one-out squared error falls by more than a fraction
   ``max(2 / n, min_gain)`` of its sum (``2 / n``: twice what fitting one
   factor to noise gains); and a quantity is corrected at all only if its
   leave-one-out squared error pooled over the outputs falls by more than
   ``pooled_gain`` (a decision on all its data, less noisy than each
   output's: where the twin's form is right for a quantity, it stays as is);
5. spread: the twin's parameter spread plus, per output, the leave-one-out
   RMS error of the corrected residual, scaled up where the process is less
   certain than at the training postures (away from the tests); the spread
   robust plans use (:meth:`CorrectedTwin.planning_spread`) takes a
   model-form term from held-out tests (each posture's residual of the twin
   calibrated without it, :meth:`~robolobe.tl.graybox.TwinCalibration.held_out_residuals`,
   less the process' leave-one-out correction: the in-sample residuals
   understate the error at other postures 1.5-2.4 times in stiffness on
   out-of-form robots), combined with the in-sample residual into the
   standardized residual (:func:`standardized_residuals`: the held-out one
   alone would count the parameters' variance twice), for f, zeta and k alike,
   sized by the mode's share of
   the direction's compliance (:func:`share_factor`), times a scale per quantity
   calibrated on held-out tests (:func:`calibrate_spread`: the share of
   held-out tests within two spreads is :data:`SPREAD_CONFIDENCE`) and a
   factor per compliance-share class that covers each class alike
   (:func:`class_cover_factor`), and the cross-validated coverage is kept
   (``spread_cover_``).

The correction tends to zero away from the tested postures (the process has
zero mean), so the predictor falls back on the calibrated twin where the
tests say nothing. Saved as one ``.npz`` without pickles (the robot file as
TOML text, arrays, JSON metadata); :func:`robolobe.tl.models.load_model`
reads it, so a job's ``robot.model`` can name it.
"""

from __future__ import annotations

import json
import math
import os
import warnings
import zipfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize

from robolobe._atomic import atomic_path
from robolobe._npz import check_range, read_npz
from robolobe._threads import one_blas_thread, with_one_blas_thread
from robolobe.errors import InputError
from robolobe.robots.limits import as_postures, within_joint_limits
from robolobe.robots.model import Robot
from robolobe.robots.plausibility import Q_MAX_RAD
from robolobe.tl.dataset import ModalDataset, check_meta_counts
from robolobe.tl.estimator import ModalPrediction
from robolobe.tl.graybox import TwinCalibration, modal_frame_dataset
from robolobe.twin.params import K_MAX

__all__ = [
    "CORRECTED_TWIN_FORMAT",
    "SPREAD_CONFIDENCE",
    "SPREAD_SIGMA",
    "CorrectedTwin",
    "calibrate_spread",
    "class_cover_factor",
    "compliance_share",
    "is_corrected_twin_file",
    "needed_scales",
    "share_factor",
    "standardized_residuals",
]

FloatArray = NDArray[np.float64]
#: ``format`` of a saved :class:`CorrectedTwin`.
CORRECTED_TWIN_FORMAT = "robolobe-corrected-twin/1"
_QUANTITIES = ("f", "zeta", "k")
_LOG_ELL_BOUNDS = (np.log(0.05), np.log(20.0))  # length scales [rad]
_RHO_BOUNDS = (0.01, 0.99)


#: Width [std] at which the planning spread is calibrated, and the share of held-out
#: tests it must cover there (two-sided normal: 95.45 %; a robust plan's default
#: ``k_sigma = 2`` joint (frequency, compliance) region states the same 95.45 % for
#: a limit linear in the errors: ``plan.modes.region_confidence``).
SPREAD_SIGMA = 2.0
SPREAD_CONFIDENCE = math.erf(SPREAD_SIGMA / math.sqrt(2.0))
_SCALE_BOUNDS = (0.25, 10.0)  # least and largest calibration scale of a quantity's spread


def standardized_residuals(inner: ArrayLike, held: ArrayLike) -> FloatArray:
    """Model-form error per test: in-sample and held-out residuals combined.

    ``sign(held) sqrt(|inner * held|)``. For a fit linear in its parameters
    the in-sample residual is ``inner = (1 - h_ii) held`` (``h_ii`` the test's
    leverage), so this is the standardized residual ``inner / sqrt(1 - h_ii)``,
    whose variance is the model-form (noise) variance alone; the held-out
    residual's, ``sigma^2 / (1 - h_ii)``, adds the variance of the parameters
    fitted without the test at its posture (large at a design's postures,
    each of which carries information no other test has), and
    :meth:`CorrectedTwin.planning_spread` adds the parameters' variance at each
    posture again: a spread from held-out residuals counts it twice. On
    out-of-form robots B and C the held-out log k residuals of modes with over
    half a direction's compliance were 2-3x the true error of the prediction
    at new postures (issue 27).

    Parameters
    ----------
    inner, held : array_like, same shape
        In-sample and held-out log residuals (NaN: no test).

    Returns
    -------
    ndarray
        NaN where either is NaN.
    """
    a = np.asarray(inner, dtype=float)
    b = np.asarray(held, dtype=float)
    return np.asarray(np.sign(b) * np.sqrt(np.abs(a * b)))


def calibrate_spread(
    held: FloatArray, var_p: FloatArray, h: FloatArray | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Scale per quantity of the model-form spread, from held-out tests, and its coverage.

    Each output's (direction, mode, quantity) model-form spread is the RMS of
    its held-out residuals; here that spread is taken at each test ``i``
    without the test itself, ``s_-i = sqrt((sum e^2 - e_i^2) / (n - 1))``,
    and the test is covered at the scale ``lam`` when
    ``|e_i| <= SPREAD_SIGMA * sqrt(var_p_i + lam^2 s_-i^2)``. Per quantity
    the scale is the :data:`SPREAD_CONFIDENCE` quantile of the scale each
    test needs (pooled over the outputs), clipped to [0.25, 10]. The coverage
    reported is cross-validated over postures: each posture's tests are
    checked at the scale found without that posture.

    Parameters
    ----------
    held : ndarray, shape (n, n_dir, n_modes, 3)
        Held-out log residuals of f, zeta, k (NaN: no test).
    var_p : ndarray, shape (n, n_dir, n_modes, 3)
        Variance of the logs from the calibrated parameters at the tests.
    h : ndarray, shape (n, n_dir, n_modes, 3), optional
        Relative size of the model-form error at each test (default 1): the
        output's spread is the RMS of ``e / h`` times ``h`` at the test
        (:func:`share_factor`).

    Returns
    -------
    scale : ndarray, shape (3,)
        Factor on the model-form spread per quantity (1 where there are no data).
    cover : ndarray, shape (3,)
        Cross-validated share of held-out tests within ``SPREAD_SIGMA`` spreads
        at the calibrated scale (NaN: no data).
    cover_raw : ndarray, shape (3,)
        The same at scale 1 (the spread before calibration).
    """
    need = needed_scales(held, var_p, h)
    scale, _, cover, cover_raw = class_cover_factor(need, np.zeros(need.shape[:3]))
    return scale, cover, cover_raw


def needed_scales(held: FloatArray, var_p: FloatArray, h: FloatArray | None = None) -> FloatArray:
    """The scale of the model-form spread each held-out test needs to be covered.

    ``|e_i| <= SPREAD_SIGMA * sqrt(var_p_i + lam^2 s_-i^2)`` at ``lam`` and
    above (:func:`calibrate_spread`: ``s_-i`` the output's spread without the
    test, times ``h``).

    Parameters
    ----------
    held, var_p : ndarray, shape (n, n_dir, n_modes, 3)
    h : ndarray, same shape, optional

    Returns
    -------
    ndarray, shape (n, n_dir, n_modes, 3)
        NaN where there is no test or its output has fewer than 3.
    """
    e = np.asarray(held, dtype=float)
    hh = np.ones_like(e) if h is None else np.asarray(h, dtype=float)
    ok = np.isfinite(e)
    n_out = ok.sum(axis=0)  # (nd, nm, 3)
    ss = np.where(ok, e / hh, 0.0) ** 2
    tot = ss.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s_i = hh * np.sqrt(np.clip(tot - ss, 0.0, None) / (n_out - 1))
        need = np.sqrt(np.clip(e**2 / SPREAD_SIGMA**2 - var_p, 0.0, None)) / s_i
    use = ok & (n_out >= 3) & np.isfinite(need)
    return np.asarray(np.where(use, need, np.nan))


def _class_scales(v: FloatArray, cls: NDArray[np.intp], n_cls: int, min_count: int) -> FloatArray:
    """Pooled scale and each class's factor on it for one quantity's needed scales ``v``.

    Returns shape (1 + n_cls,): the pooled :data:`SPREAD_CONFIDENCE` quantile,
    then per class its own quantile over the pooled one (1 with fewer than
    ``min_count`` tests).
    """
    out = np.ones(1 + n_cls)
    out[0] = float(np.clip(np.quantile(v, SPREAD_CONFIDENCE), *_SCALE_BOUNDS))
    for b in range(n_cls):
        sel = cls == b
        if sel.sum() >= min_count:
            q = float(np.clip(np.quantile(v[sel], SPREAD_CONFIDENCE), *_SCALE_BOUNDS))
            out[1 + b] = q / out[0]
    return out


def class_cover_factor(
    need: FloatArray, share: FloatArray, min_count: int = 20
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Scale per quantity, and a factor per share class that covers each class alike.

    The scale is :func:`calibrate_spread`'s: the :data:`SPREAD_CONFIDENCE`
    quantile of the scale each held-out test needs, pooled over the outputs
    and the compliance-share classes (:func:`share_classes`). Pooled, the
    classes are not covered alike (the relative sizes of :func:`share_factor`
    are RMS values, which a few large residuals of weak modes set: on
    out-of-form robot C the true frequencies of the modes with over half a
    direction's compliance were within two spreads at 93.6 %, those of the
    others at 97.3 %, issue 27). Per class, the factor is the ratio of the
    class's own quantile of the needed scale to the pooled scale (1 for a
    class with fewer than ``min_count`` tests), so that each class is covered
    at the confidence. With one class (every share alike) the factors are 1
    and this is :func:`calibrate_spread`.

    Parameters
    ----------
    need : ndarray, shape (n, n_dir, n_modes, 3)
        :func:`needed_scales` (NaN: no test).
    share : ndarray, shape (n, n_dir, n_modes)
        Compliance share at each test (:func:`compliance_share`).
    min_count : int
        Least number of tests of a class for a factor of its own.

    Returns
    -------
    scale : ndarray, shape (3,)
        Pooled scale per quantity, clipped to [0.25, 10] (1 with fewer than 10
        tests).
    factor : ndarray, shape (3, len(SHARE_EDGES) + 1)
        Factor on the pooled scale per quantity and class.
    cover : ndarray, shape (3,)
        Cross-validated share of the tests within ``SPREAD_SIGMA`` spreads at
        the pooled scale times the class factor, each posture's tests checked
        at those found without the posture (NaN: fewer than 10 tests).
    cover_raw : ndarray, shape (3,)
        The share within ``SPREAD_SIGMA`` spreads at scale 1 (NaN alike).
    """
    cls = np.broadcast_to(share_classes(share), need.shape[:3])
    post = np.broadcast_to(np.arange(need.shape[0])[:, None, None], need.shape[:3])
    n_cls = len(SHARE_EDGES) + 1
    scale = np.ones(3)
    factor = np.ones((3, n_cls))
    cover = np.full(3, np.nan)
    cover_raw = np.full(3, np.nan)
    for c in range(3):
        ok = np.isfinite(need[..., c])
        if ok.sum() < 10:
            continue
        v, k, p = need[..., c][ok], cls[ok], post[ok]
        sc = _class_scales(v, k, n_cls, min_count)
        scale[c], factor[c] = sc[0], sc[1:]
        hit = np.empty(v.size, bool)
        for i in np.unique(p):
            here = p == i
            sc = _class_scales(v[~here], k[~here], n_cls, min_count)
            hit[here] = v[here] <= sc[0] * sc[1 + k[here]]
        cover[c] = float(hit.mean())
        cover_raw[c] = float(np.mean(v <= 1.0))
    return scale, factor, cover, cover_raw


#: Edges of the compliance-share classes of :func:`share_factor`.
SHARE_EDGES = (0.05, 0.2, 0.5)


def compliance_share(values: FloatArray) -> FloatArray:
    """Each mode's share of its direction's summed peak compliance ``1 / (k zeta)``.

    Parameters
    ----------
    values : ndarray, shape (n, n_dir, n_modes, 3)
        f [Hz], zeta, k [N/m] (NaN: none; k >= K_MAX: not seen).

    Returns
    -------
    ndarray, shape (n, n_dir, n_modes)
        In [0, 1]; 0 where a mode is not seen.
    """
    v = np.asarray(values, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        c = 1.0 / (v[..., 2] * v[..., 1])
    c = np.where(np.isfinite(c) & (v[..., 2] < K_MAX) & (c > 0), c, 0.0)
    tot = c.sum(axis=-1, keepdims=True)
    return np.asarray(np.where(tot > 0, c / np.where(tot > 0, tot, 1.0), 0.0))


def share_classes(share: FloatArray) -> NDArray[np.intp]:
    """Class of each compliance share (:data:`SHARE_EDGES`), 0 (smallest) to 3."""
    return np.asarray(np.searchsorted(np.asarray(SHARE_EDGES), share, side="right"))


def share_factor(held: FloatArray, share: FloatArray, min_count: int = 10) -> FloatArray:
    """Relative size of the model-form error per quantity and compliance-share class.

    A mode that dominates a direction's compliance is known better than one
    that barely moves the tool point that way (its modal stiffness is the
    inverse square of a small shape component): on out-of-form robots the
    held-out log k error of modes with over half a direction's compliance is
    a third of that of modes under a fifth. Per quantity, the RMS of the
    held-out residuals of each class over the RMS of all (1 for a class with
    fewer than ``min_count`` tests).

    Parameters
    ----------
    held : ndarray, shape (n, n_dir, n_modes, 3)
    share : ndarray, shape (n, n_dir, n_modes)

    Returns
    -------
    ndarray, shape (3, len(SHARE_EDGES) + 1)
    """
    cls = share_classes(share)
    out = np.ones((3, len(SHARE_EDGES) + 1))
    for c in range(3):
        e = held[..., c]
        ok = np.isfinite(e)
        if ok.sum() < min_count:
            continue
        rms = float(np.sqrt(np.mean(e[ok] ** 2)))
        for b in range(out.shape[1]):
            sel = ok & (cls == b)
            if sel.sum() >= min_count and rms > 0:
                out[c, b] = max(float(np.sqrt(np.mean(e[sel] ** 2))) / rms, 1e-3)
    return out


def _kernel(xa: FloatArray, xb: FloatArray, ell: FloatArray) -> FloatArray:
    """Unit-variance RBF kernel, shape (len(xa), len(xb))."""
    d = (xa[:, None, :] - xb[None, :, :]) / ell
    return np.asarray(np.exp(-0.5 * np.sum(d * d, axis=-1)))


#: Outputs of :func:`_grouped_nll` that share their postures: (postures (n, d), the
#: outputs' values (k, n), their places in the list of outputs).
_OutputGroup = tuple[FloatArray, FloatArray, list[int]]


def _share_postures(xs: list[FloatArray], ts: list[FloatArray]) -> list[_OutputGroup]:
    """The outputs grouped by their postures (one kernel matrix per group)."""
    groups: list[_OutputGroup] = []
    members: list[list[int]] = []
    for o, x in enumerate(xs):
        for g, (xg, _, _) in enumerate(groups):
            if xg.shape == x.shape and np.array_equal(xg, x):
                members[g].append(o)
                break
        else:
            groups.append((x, np.empty(0), []))
            members.append([o])
    return [
        (x, np.array([ts[o] for o in idx], dtype=float), idx)
        for (x, _, _), idx in zip(groups, members, strict=True)
    ]


def _grouped_nll(hyp: FloatArray, groups: list[_OutputGroup], n_ell: int) -> float:
    """:func:`_pooled_nll` of outputs grouped by :func:`_share_postures`.

    One kernel matrix and Cholesky factor per group of outputs at the same
    postures; every output's term as :func:`_pooled_nll` computes it, summed in
    the outputs' order (the same number).
    """
    ell = np.exp(hyp[:n_ell])
    rho = 1.0 / (1.0 + np.exp(-hyp[n_ell]))
    terms = np.zeros(sum(len(idx) for _, _, idx in groups))
    for x, t, idx in groups:
        k = rho * _kernel(x, x, ell) + (1.0 - rho) * np.eye(len(x))
        try:
            c = np.linalg.cholesky(k)
        except np.linalg.LinAlgError:
            return 1e12
        log_det = float(np.log(np.diag(c)).sum())
        for o, t_o in zip(idx, t, strict=True):
            a = np.linalg.solve(c, t_o)
            terms[o] = 0.5 * float(a @ a) + log_det
    total = 0.0
    for v in terms:
        total += float(v)
    return total


def _pooled_nll(hyp: FloatArray, xs: list[FloatArray], ts: list[FloatArray], n_ell: int) -> float:
    """Negative log marginal likelihood of unit-RMS outputs sharing one kernel.

    Parameters
    ----------
    hyp : ndarray, shape (n_ell + 1,)
        Log length scales, then the logit of the signal fraction ``rho``.
    xs, ts : list of ndarray
        Each output's postures (n_o, n_ell) and values (n_o,).
    n_ell : int
        Number of length scales.
    """
    return _grouped_nll(hyp, _share_postures(xs, ts), n_ell)


def _frozen_nll(logit_rho: FloatArray, log_ell: FloatArray, groups: list[_OutputGroup]) -> float:
    """:func:`_grouped_nll` with the length scales held fixed."""
    return _grouped_nll(np.r_[log_ell, logit_rho], groups, len(log_ell))


def is_corrected_twin_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is a saved :class:`CorrectedTwin` (reads only its metadata)."""
    try:
        if not zipfile.is_zipfile(path):
            return False
        with zipfile.ZipFile(path) as zf, zf.open("meta.npy") as fh:
            meta = json.loads(str(np.lib.format.read_array(fh, allow_pickle=False)))
    except (OSError, ValueError, EOFError, KeyError, RecursionError, zipfile.BadZipFile):
        return False  # not readable as a corrected twin: the readers give the reason
    return isinstance(meta, dict) and meta.get("format") == CORRECTED_TWIN_FORMAT


class CorrectedTwin:
    """Calibrated twin plus a cross-validated Gaussian-process correction (module docstring).

    Parameters
    ----------
    robot : Robot or str
        The robot file (``"B"``, a ``.toml`` path or a Robot).
    calibration : dict, optional
        Keyword arguments of :class:`~robolobe.tl.graybox.TwinCalibration`
        (``params``, ``bounds``...; ``robot`` is the one above).
    prefit : TwinCalibration, optional
        A calibration already fitted to the same hammer tests (its robot
        file is used; ``calibration`` is then ignored): only the correction
        is learned.
    kernel_source : CorrectedTwin, optional
        A fitted model (e.g. on robot A) whose kernel length scales are
        taken frozen; only the signal fraction is refitted.
    min_postures : int
        Fewest postures accepted by :meth:`fit`.
    min_points : int
        Fewest training values of an output for it to get a correction.
    min_gain : float
        Least relative fall of the leave-one-out squared error for an output
        to be corrected (module docstring, step 4).
    pooled_gain : float
        Least relative fall of a quantity's pooled leave-one-out squared
        error for any of its outputs to be corrected.
    random_state : int or None
        Seed of the calibration's random starts.

    Attributes
    ----------
    calibration_ : TwinCalibration
    robot_ : Robot
        The calibrated robot.
    length_scales_ : ndarray, shape (3, 6)
        Kernel length scales per quantity (f, zeta, k) and joint [rad].
    rho_ : ndarray, shape (3,)
        Signal fraction of the scaled residuals per quantity.
    alpha_ : ndarray, shape (n_dir, n_modes, 3)
        Share of the process used per output (0: the calibrated twin as is).
    scale_ : ndarray, shape (n_dir, n_modes, 3)
        RMS of the training residuals per output (NaN: no data).
    loo_rmse_ : ndarray, shape (n_dir, n_modes, 3)
        Leave-one-out RMS log error of the corrected residual per output.
    loo_rmse_twin_ : ndarray, shape (n_dir, n_modes, 3)
        The same for the calibrated twin alone (in-sample residual RMS).
    spread_scale_ : ndarray, shape (3,)
        Calibration scale of the model-form spread per quantity (f, zeta, k)
        (:func:`calibrate_spread`).
    share_h_ : ndarray, shape (3, 4)
        Relative model-form error per quantity and compliance-share class
        (:func:`share_factor`) times the class's coverage factor
        (:func:`class_cover_factor`).
    form_std_ : ndarray, shape (n_dir, n_modes, 3)
        Model-form spread per output at share factor 1.
    spread_cover_, spread_cover_raw_ : ndarray, shape (3,)
        Cross-validated share of the tests' standardized residuals
        (:func:`standardized_residuals`) within ``SPREAD_SIGMA`` model-form
        spreads, calibrated and at scale 1 (NaN: too few tests).
    directions_ : tuple of str
    n_modes_ : int
    train_q_rad_ : ndarray, shape (n, 6)
    extra_ : ExtraModes
        Measured modes the twin lacks (:mod:`robolobe.tl.extra_modes`), which
        :class:`robolobe.plan.modes.CorrectedTwinSource` adds to the twin's.
    """

    length_scales_: FloatArray
    rho_: FloatArray

    def __init__(
        self,
        *,
        robot: Robot | str | os.PathLike[str],
        calibration: dict[str, Any] | None = None,
        prefit: TwinCalibration | None = None,
        kernel_source: CorrectedTwin | None = None,
        min_postures: int = 8,
        min_points: int = 6,
        min_gain: float = 0.0,
        pooled_gain: float = 0.2,
        random_state: int | None = 0,
    ) -> None:
        self.robot = robot
        self.calibration = calibration
        self.prefit = prefit
        self.kernel_source = kernel_source
        self.min_postures = min_postures
        self.min_points = min_points
        self.min_gain = min_gain
        self.pooled_gain = pooled_gain
        self.random_state = random_state

    # ----------------------------------------------------------------- fit
    def fit(self, modal_df: pd.DataFrame) -> CorrectedTwin:
        """Fit on a ``modal.csv`` frame (driving-point rows ``xx``, ``yy``, ``zz``)."""
        return self.fit_dataset(modal_frame_dataset(modal_df))

    def _residuals(self, cal: TwinCalibration, ds: ModalDataset) -> FloatArray:
        """``log(measured / twin)`` per posture, direction, twin mode, quantity (NaN: none)."""
        q = ds.q_rad
        twin = cal.predict(q, directions=ds.directions, n_modes=6, spread=False).values
        nm = min(ds.n_modes, cal.n_modes_)  # outputs: twin modes (extra measured ones left out)
        (i, j, m, t), _ = cal._match(ds, twin)
        y = np.asarray(ds.y)
        r = np.full((len(q), len(ds.directions), nm, 3), np.nan)
        keep = t < nm
        i, j, m, t = i[keep], j[keep], m[keep], t[keep]
        with np.errstate(divide="ignore", invalid="ignore"):
            val = np.log(y[i, j, m] / twin[i, j, t])
        val[:, 2] = np.where(twin[i, j, t, 2] >= K_MAX, np.nan, val[:, 2])
        r[i, j, t] = val
        return r

    def fit_dataset(self, ds: ModalDataset) -> CorrectedTwin:
        """Fit on a :class:`~robolobe.tl.dataset.ModalDataset` (NaN = not seen)."""
        with one_blas_thread():
            return self._fit_dataset(ds)

    def _fit_dataset(self, ds: ModalDataset) -> CorrectedTwin:
        if ds.n_postures < self.min_postures:
            raise InputError(
                f"expected at least {self.min_postures} postures for a corrected twin, found "
                f"{ds.n_postures}"
            )
        if self.min_points < 3:
            raise InputError(f"min_points: expected >= 3, found {self.min_points}")
        src = self.kernel_source
        if src is not None and not hasattr(src, "length_scales_"):
            raise InputError("kernel_source: expected a fitted CorrectedTwin")
        if self.prefit is not None:
            cal = self.prefit
            if not hasattr(cal, "robot_"):
                raise InputError("prefit: expected a fitted TwinCalibration")
        else:
            kw = dict(self.calibration or {})
            kw.setdefault("random_state", self.random_state)
            cal = TwinCalibration(robot=self.robot, **kw).fit_dataset(ds)
        r = self._residuals(cal, ds)
        from robolobe.tl.extra_modes import unpaired_of_calibration

        self.extra_ = unpaired_of_calibration(cal, ds)  # measured modes the twin lacks
        x = np.asarray(ds.q_rad, dtype=float)
        nd, nm = r.shape[1], r.shape[2]
        n_ell = x.shape[1]
        ok = np.isfinite(r)
        count = ok.sum(axis=0)  # (nd, nm, 3)
        # RMS over the postures that see each mode (a mode no posture sees: NaN)
        mean_sq = np.where(ok, r, 0.0) ** 2
        scale = np.sqrt(mean_sq.sum(axis=0) / np.maximum(count, 1))  # (nd, nm, 3)
        scale = np.where(count > 0, np.maximum(scale, 1e-6), np.nan)
        ells = np.zeros((3, n_ell))
        rhos = np.zeros(3)
        alpha = np.zeros((nd, nm, 3))
        loo = np.where(count > 0, scale, np.nan)
        inv_var_mean = np.ones((nd, nm, 3))
        # held-out residuals: each posture's from the calibration fitted without it
        # (the in-sample ones understate the error at other postures), less the
        # process' leave-one-out correction where used (filled per quantity below)
        r_ho = cal.held_out_residuals(ds, nm)
        held = np.where(np.isfinite(r_ho), r_ho, r)
        inner = r.copy()  # the in-sample residuals, less the same correction
        for c in range(3):
            outs = [
                (j, m) for j in range(nd) for m in range(nm) if count[j, m, c] >= self.min_points
            ]
            xs = [x[ok[:, j, m, c]] for j, m in outs]
            ts = [r[ok[:, j, m, c], j, m, c] / scale[j, m, c] for j, m in outs]
            if src is not None:
                ell0 = np.log(src.length_scales_[c])
                rho0 = float(src.rho_[c])
            else:
                ell0 = np.full(n_ell, np.log(0.5))
                rho0 = 0.5
            hyp0 = np.r_[ell0, np.log(rho0 / (1 - rho0))]
            if outs:
                lo_r, hi_r = (np.log(b / (1 - b)) for b in _RHO_BOUNDS)
                shared = _share_postures(xs, ts)
                if src is None:
                    bounds = [_LOG_ELL_BOUNDS] * n_ell + [(lo_r, hi_r)]
                    res = minimize(
                        _grouped_nll,
                        hyp0,
                        args=(shared, n_ell),
                        method="L-BFGS-B",
                        bounds=bounds,
                    )
                    hyp = np.asarray(res.x)
                else:  # length scales frozen: refit the signal fraction only
                    res = minimize(
                        _frozen_nll,
                        hyp0[n_ell:],
                        args=(ell0, shared),
                        method="L-BFGS-B",
                        bounds=[(lo_r, hi_r)],
                    )
                    hyp = np.r_[ell0, res.x]
            else:
                hyp = hyp0
            ell = np.exp(hyp[:n_ell])
            rho = float(1.0 / (1.0 + np.exp(-hyp[n_ell])))
            ells[c], rhos[c] = ell, rho
            pooled = [0.0, 0.0]  # squared error of the twin, of the corrected twin (scaled)
            loo_g: dict[tuple[int, int], FloatArray] = {}
            for (j, m), xo, to in zip(outs, xs, ts, strict=True):
                kmat = rho * _kernel(xo, xo, ell) + (1.0 - rho) * np.eye(len(xo))
                a = np.linalg.inv(kmat)
                d = np.diag(a)
                g = to - (a @ to) / d  # leave-one-out means (closed form)
                loo_g[j, m] = g
                gg = float(g @ g)
                al = float(np.clip((to @ g) / gg, 0.0, 1.0)) if gg > 0 else 0.0
                sse0 = float(to @ to)
                sse = float(np.sum((to - al * g) ** 2))
                if sse0 - sse <= max(2.0 / len(to), self.min_gain) * sse0:
                    al, sse = 0.0, sse0
                alpha[j, m, c] = al
                pooled[0] += sse0  # unit-RMS outputs: each counts alike
                pooled[1] += sse
                loo[j, m, c] = scale[j, m, c] * np.sqrt(sse / len(to))
                # mean predictive variance at the training postures, left out in turn
                inv_var_mean[j, m, c] = float(np.mean(1.0 / d))
            if outs and pooled[0] - pooled[1] <= self.pooled_gain * pooled[0]:
                alpha[..., c] = 0.0  # not worth it for this quantity: the twin as is
                loo[..., c] = np.where(count[..., c] > 0, scale[..., c], np.nan)
            # held-out residual per test: the twin's residual without the posture, less
            # the process' leave-one-out mean where the correction is used
            for (j, m), g in loo_g.items():
                if alpha[j, m, c] > 0:
                    sel = ok[:, j, m, c]
                    held[sel, j, m, c] -= alpha[j, m, c] * scale[j, m, c] * g
                    inner[sel, j, m, c] -= alpha[j, m, c] * scale[j, m, c] * g
        self.calibration_ = cal
        self.robot_ = cal.robot_
        self.length_scales_ = ells
        self.rho_ = rhos
        self.alpha_ = alpha
        self.scale_ = scale
        self.loo_rmse_ = loo
        self.loo_rmse_twin_ = np.where(count > 0, scale, np.nan)
        self.loo_var_mean_ = inv_var_mean
        self.train_r_ = r
        self.directions_ = tuple(ds.directions)
        self.n_modes_ = nm
        self.train_q_rad_ = x
        center, _ = self._parameter_variance(x, ds.directions, nm)
        share = compliance_share(np.exp(center))
        form_r = standardized_residuals(inner, held)
        self.share_h_ = share_factor(form_r, share)
        h = np.moveaxis(self.share_h_[:, share_classes(share)], 0, -1)  # (n, nd, nm, 3)
        # the model-form term alone (the parameters' variance is added at each posture),
        # each compliance-share class covered at the confidence, not only all pooled
        self.spread_scale_, kappa, self.spread_cover_, self.spread_cover_raw_ = class_cover_factor(
            needed_scales(form_r, np.zeros_like(form_r), h), share
        )
        with np.errstate(invalid="ignore", divide="ignore"):
            u = form_r / h
            n_u = np.isfinite(u).sum(axis=0)
            form = np.sqrt(np.nansum(u**2, axis=0) / n_u)
        # the output's model-form spread at a share of factor 1 (its RMS where no tests)
        self.form_std_ = np.where(n_u > 0, form, loo)
        # the class factors act where the spread is predicted (form_std_ is per output
        # at the share factor without them: with them an output always in one class
        # would divide its factor out again)
        self.share_h_ = self.share_h_ * kappa
        return self

    def _parameter_variance(
        self, q: FloatArray, directions: Sequence[str], n_modes: int
    ) -> tuple[FloatArray, FloatArray]:
        """The calibrated twin's logs and their variance from its parameters alone.

        Both of shape (n, n_dir, nm, 3).
        """
        cal = self.calibration_
        base = cal.predict(q, directions=directions, n_modes=n_modes, spread=True)
        rms = np.nan_to_num([cal.residual_rms_[c] for c in _QUANTITIES])
        var = np.clip(np.asarray(base.std) ** 2 - rms**2, 0.0, None)
        return np.asarray(base.center), np.asarray(var)

    # ------------------------------------------------------------- predict
    def _check_fitted(self) -> None:
        if not hasattr(self, "calibration_"):
            raise InputError("this CorrectedTwin is not fitted yet: call fit()")

    @property
    def directions(self) -> tuple[str, ...]:
        """Driving-point directions of the predictions."""
        self._check_fitted()
        return self.directions_

    @property
    def robot_name(self) -> str:
        """Name of the calibrated robot."""
        self._check_fitted()
        return str(self.robot_.name)

    def correction(self, q_rad: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """Learned log correction and its spread at postures.

        Returns
        -------
        mean, std : ndarray, shape (n, n_dir, n_modes, 3)
            Added to the calibrated twin's log f, log zeta, log k; ``std`` is
            the leave-one-out error scaled by the process' uncertainty there
            (NaN where the output has no training data).
        """
        self._check_fitted()
        q = np.asarray(q_rad, dtype=float)
        x = self.train_q_rad_
        r = self.train_r_
        nd, nm = r.shape[1], r.shape[2]
        mean = np.zeros((len(q), nd, nm, 3))
        std = np.tile(self.loo_rmse_, (len(q), 1, 1, 1))
        for c in range(3):
            ell, rho = self.length_scales_[c], float(self.rho_[c])
            for j in range(nd):
                for m in range(nm):
                    okm = np.isfinite(r[:, j, m, c])
                    if okm.sum() < self.min_points or not np.isfinite(self.scale_[j, m, c]):
                        continue
                    xo = x[okm]
                    to = r[okm, j, m, c] / self.scale_[j, m, c]
                    kmat = rho * _kernel(xo, xo, ell) + (1.0 - rho) * np.eye(len(xo))
                    ks = rho * _kernel(q, xo, ell)
                    sol = np.linalg.solve(kmat, np.c_[to, ks.T])
                    mean[:, j, m, c] = (
                        self.alpha_[j, m, c] * self.scale_[j, m, c] * (ks @ sol[:, 0])
                    )
                    var = 1.0 - np.einsum("ij,ji->i", ks, sol[:, 1:])  # predictive, with scatter
                    ratio = np.clip(var / self.loo_var_mean_[j, m, c], 1.0, None)
                    std[:, j, m, c] = self.loo_rmse_[j, m, c] * np.sqrt(ratio)
        return mean, std

    @with_one_blas_thread
    def predict(
        self,
        q_rad: ArrayLike,
        *,
        directions: Sequence[str] | None = None,
        n_modes: int | None = None,
        spread: bool = True,
        warn: bool = True,
    ) -> ModalPrediction:
        """Modes of the calibrated twin with the learned correction and its spread.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        directions : sequence of str, optional
            Must be the training directions (the default); other directions
            get the calibrated twin without correction.
        n_modes : int, optional
            Modes per direction (default: as trained); modes beyond those
            trained get no correction.
        spread : bool
            False: zero spread (faster).
        warn : bool
            Warn about postures outside the robot's joint limits.

        Returns
        -------
        ModalPrediction
            ``kind="log"``, shape (n, n_dir, n_modes, 3).
        """
        self._check_fitted()
        q = as_postures(q_rad)
        if warn:
            rob = self.robot_
            out = ~within_joint_limits(rob, q)
            if out.any():
                warnings.warn(
                    f"{int(out.sum())} postures outside the joint limits of {rob.name}",
                    stacklevel=2,
                )
        dirs = tuple(directions) if directions is not None else self.directions_
        nm = int(n_modes) if n_modes is not None else self.n_modes_
        base = self.calibration_.predict(q, directions=dirs, n_modes=nm, spread=spread)
        center = np.array(base.center)
        std = np.array(base.std)
        rms = np.nan_to_num([self.calibration_.residual_rms_[c] for c in _QUANTITIES])
        if spread:  # the calibration's in-sample residual term is replaced by the LOO error
            std = np.sqrt(np.clip(std**2 - rms**2, 0.0, None))
        mean_c, std_c = self.correction(q)
        k_on = center[..., 2] < np.log(K_MAX) - 1e-9
        for jj, d in enumerate(dirs):
            if d not in self.directions_:
                if spread:
                    std[:, jj] = np.sqrt(std[:, jj] ** 2 + rms**2)
                continue
            j = self.directions_.index(d)
            mm = min(nm, self.n_modes_)
            add = mean_c[:, j, :mm].copy()
            add[..., 2] = np.where(k_on[:, jj, :mm], add[..., 2], 0.0)
            center[:, jj, :mm] += add
            if spread:
                sc = np.where(np.isfinite(std_c[:, j, :mm]), std_c[:, j, :mm], rms)
                std[:, jj, :mm] = np.sqrt(std[:, jj, :mm] ** 2 + sc**2)
                std[:, jj, mm:] = np.sqrt(std[:, jj, mm:] ** 2 + rms**2)
        if not spread:
            std = np.zeros_like(center)
        return ModalPrediction(directions=dirs, center=center, std=std, kind="log")

    @with_one_blas_thread
    def planning_spread(
        self,
        q_rad: ArrayLike,
        *,
        directions: Sequence[str] | None = None,
        n_modes: int | None = None,
    ) -> FloatArray:
        """Spread of the prediction's *error* at postures: what a robust plan lowers by.

        Per direction, mode and posture, the variance of

        * the calibration's parameter covariance propagated to the posture, plus
        * a model-form term calibrated on held-out tests: the output's
          RMS standardized residual of log f, log zeta and log k
          (:func:`standardized_residuals` of the in-sample residual and the
          residual of the twin calibrated without the test's posture, each
          less the process' leave-one-out correction where used: what the
          twin's form misses, which on a robot outside that form is mostly
          real error, not identification scatter; the held-out residual
          alone also holds the variance of the parameters fitted without the
          test, which the first term gives),
          sized by the mode's share of the direction's compliance at the
          posture (:func:`share_factor`: a dominant mode is known better),
          widened away from the tests as the process is less certain there
          (:meth:`correction`), times the quantity's calibration scale
          :attr:`spread_scale_` (:func:`calibrate_spread`: standardized
          residuals within ``SPREAD_SIGMA`` model-form spreads at
          :data:`SPREAD_CONFIDENCE`).
          Without tests of an output (a direction not tested) the
          calibration's in-sample residual RMS of the quantity, scaled alike.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        directions : sequence of str, optional
            Default: the training directions.
        n_modes : int, optional
            Modes per direction (twin mode order); default as trained.

        Returns
        -------
        ndarray, shape (n, n_dir, n_modes, 3)
            Standard deviation of log f, log zeta, log k.
        """
        self._check_fitted()
        q = np.asarray(q_rad, dtype=float)
        dirs = tuple(directions) if directions is not None else self.directions_
        nm = int(n_modes) if n_modes is not None else self.n_modes_
        center, var_p = self._parameter_variance(q, dirs, nm)
        rms = np.nan_to_num([self.calibration_.residual_rms_[c] for c in _QUANTITIES])
        form = np.broadcast_to(rms, var_p.shape).copy()
        _, std_c = self.correction(q)
        share = compliance_share(np.exp(center))
        h = np.moveaxis(self.share_h_[:, share_classes(share)], 0, -1)  # (n, n_dir, nm, 3)
        for jj, d in enumerate(dirs):
            if d not in self.directions_:
                continue
            j = self.directions_.index(d)
            mm = min(nm, self.n_modes_)
            # the output's spread at this mode's compliance share, widened away from the
            # tests as the correction's
            with np.errstate(invalid="ignore", divide="ignore"):
                widen = std_c[:, j, :mm] / self.loo_rmse_[j, :mm]
            sc = self.form_std_[j, :mm] * h[:, jj, :mm] * np.where(np.isfinite(widen), widen, 1.0)
            form[:, jj, :mm] = np.where(np.isfinite(sc), sc, rms)
        return np.asarray(np.sqrt(var_p + (form * self.spread_scale_) ** 2))

    def extrapolation(self, q_rad: ArrayLike) -> FloatArray:
        """Zero per posture: the twin is physics over the whole workspace.

        Away from the tested postures the correction fades to zero and its
        spread grows (:meth:`correction`); nothing extrapolates blindly.

        Returns
        -------
        ndarray, shape (n,)
        """
        self._check_fitted()
        return np.zeros(len(np.asarray(q_rad, dtype=float).reshape(-1, 6)))

    def summary(self) -> pd.DataFrame:
        """Per direction, mode and quantity: training values, alpha, RMS errors (twin, LOO)."""
        self._check_fitted()
        rows = []
        for j, d in enumerate(self.directions_):
            for m in range(self.n_modes_):
                for c, name in enumerate(_QUANTITIES):
                    rows.append(
                        {
                            "dir": d,
                            "mode": m + 1,
                            "quantity": name,
                            "n": int(np.isfinite(self.train_r_[:, j, m, c]).sum()),
                            "alpha": float(self.alpha_[j, m, c]),
                            "rms_twin": float(self.loo_rmse_twin_[j, m, c]),
                            "rms_loo": float(self.loo_rmse_[j, m, c]),
                        }
                    )
        return pd.DataFrame(rows)

    # ---------------------------------------------------------------- save
    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write one ``.npz`` (JSON metadata and float arrays; nothing pickled), atomically."""
        self._check_fitted()
        cal_meta, cal_arrays = self.calibration_.state()
        meta = {
            "format": CORRECTED_TWIN_FORMAT,
            "calibration": cal_meta,
            "directions": list(self.directions_),
            "n_modes": int(self.n_modes_),
            "min_points": int(self.min_points),
        }
        arrays: dict[str, Any] = {f"cal_{k}": v for k, v in cal_arrays.items()}
        arrays.update(
            meta=np.array(json.dumps(meta)),
            length_scales=self.length_scales_,
            rho=self.rho_,
            alpha=self.alpha_,
            scale=self.scale_,
            loo_rmse=self.loo_rmse_,
            loo_rmse_twin=self.loo_rmse_twin_,
            loo_var_mean=self.loo_var_mean_,
            train_r=self.train_r_,
            train_q_rad=self.train_q_rad_,
            spread_scale=self.spread_scale_,
            spread_cover=self.spread_cover_,
            spread_cover_raw=self.spread_cover_raw_,
            share_h=self.share_h_,
            form_std=self.form_std_,
            **self.extra_.arrays("extra_"),
        )
        path = Path(path)
        with atomic_path(path) as tmp, tmp.open("wb") as fh:
            np.savez_compressed(fh, **arrays)
        return path

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> CorrectedTwin:
        """Read a model written by :meth:`save` (``allow_pickle=False``).

        Raises
        ------
        InputError
            Missing or unreadable file, another format, inconsistent content.
        """
        from robolobe._documents import parse_json

        where = str(path)
        arrays = read_npz(path)
        if "meta" not in arrays:
            raise InputError("not a robolobe model: no 'meta' entry", source=where)
        meta = parse_json(str(arrays["meta"]), f"{where}[meta]")
        if meta.get("format") != CORRECTED_TWIN_FORMAT:
            raise InputError(
                f"format: expected {CORRECTED_TWIN_FORMAT!r}, found {meta.get('format')!r}",
                source=where,
            )
        if not isinstance(meta.get("calibration"), dict):
            raise InputError(
                f"inconsistent model file: meta.calibration: expected a table, found "
                f"{type(meta.get('calibration')).__name__}",
                source=where,
            )
        cal = TwinCalibration.from_state(
            meta["calibration"],
            {k[4:]: v for k, v in arrays.items() if k.startswith("cal_")},
            where,
        )
        try:
            self = cls(robot=cal.base_robot_, min_points=int(meta["min_points"]))
            self.calibration_ = cal
            self.robot_ = cal.robot_
            self.directions_ = tuple(str(d) for d in meta["directions"])
            self.n_modes_ = int(meta["n_modes"])
            for name in (
                "length_scales",
                "rho",
                "alpha",
                "scale",
                "loo_rmse",
                "loo_rmse_twin",
                "loo_var_mean",
                "train_r",
                "train_q_rad",
            ):
                setattr(self, f"{name}_", np.asarray(arrays[name], dtype=float))
            # files written before the spread was calibrated: scale 1, coverage unknown
            self.spread_scale_ = np.asarray(arrays.get("spread_scale", np.ones(3)), dtype=float)
            self.spread_cover_ = np.asarray(
                arrays.get("spread_cover", np.full(3, np.nan)), dtype=float
            )
            self.spread_cover_raw_ = np.asarray(
                arrays.get("spread_cover_raw", np.full(3, np.nan)), dtype=float
            )
            self.share_h_ = np.asarray(
                arrays.get("share_h", np.ones((3, len(SHARE_EDGES) + 1))), dtype=float
            )
            self.form_std_ = np.asarray(arrays.get("form_std", self.loo_rmse_), dtype=float)
            from robolobe.tl.extra_modes import ExtraModes

            self.extra_ = ExtraModes.from_arrays(arrays, "extra_", where)
        except (KeyError, TypeError, ValueError, AttributeError) as exc:
            raise InputError(f"inconsistent model file ({exc})", source=where) from None
        check_meta_counts(self.directions_, self.n_modes_, where)
        if self.min_points < 1:
            raise InputError(
                f"inconsistent model file: min_points: expected >= 1, found {self.min_points}",
                source=where,
            )
        nd, nm = len(self.directions_), self.n_modes_
        n = len(self.train_q_rad_)
        if (
            self.alpha_.shape != (nd, nm, 3)
            or self.train_r_.shape != (n, nd, nm, 3)
            or self.length_scales_.shape != (3, 6)
            or self.rho_.shape != (3,)
        ):
            raise InputError(
                "inconsistent model file: array shapes do not match the directions and modes",
                source=where,
            )
        # values that break the math (a singular kernel, a negative spread) are lies
        check_range(self.length_scales_, "length_scales", where, low=0.0, open_low=True)
        check_range(self.rho_, "rho", where, low=0.0, high=1.0, open_high=True)
        check_range(self.alpha_, "alpha", where, low=0.0, high=1.0)
        check_range(self.scale_, "scale", where, low=0.0, open_low=True, nan_ok=True)
        check_range(self.loo_rmse_, "loo_rmse", where, low=0.0, nan_ok=True)
        check_range(self.loo_rmse_twin_, "loo_rmse_twin", where, low=0.0, nan_ok=True)
        check_range(self.loo_var_mean_, "loo_var_mean", where, low=0.0, open_low=True, nan_ok=True)
        check_range(self.train_r_, "train_r", where, nan_ok=True)
        check_range(self.train_q_rad_, "train_q_rad", where, low=-Q_MAX_RAD, high=Q_MAX_RAD)
        if self.spread_scale_.shape != (3,) or self.spread_cover_.shape != (3,):
            raise InputError(
                "inconsistent model file: spread_scale and spread_cover: expected 3 values each",
                source=where,
            )
        check_range(self.spread_scale_, "spread_scale", where, low=0.0, open_low=True)
        if self.share_h_.shape != (3, len(SHARE_EDGES) + 1) or self.form_std_.shape != (nd, nm, 3):
            raise InputError(
                "inconsistent model file: share_h and form_std: expected shapes "
                f"(3, {len(SHARE_EDGES) + 1}) and ({nd}, {nm}, 3)",
                source=where,
            )
        check_range(self.share_h_, "share_h", where, low=0.0, open_low=True)
        check_range(self.form_std_, "form_std", where, low=0.0, nan_ok=True)
        check_range(self.spread_cover_, "spread_cover", where, low=0.0, high=1.0, nan_ok=True)
        return self

    def __repr__(self) -> str:
        state = "fitted" if hasattr(self, "calibration_") else "unfitted"
        return f"CorrectedTwin(robot={getattr(self.robot, 'name', self.robot)!r}, {state})"
