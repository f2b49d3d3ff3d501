"""Measured modes a base model lacks, interpolated over posture with a spread.

A robot in a lab shows modes its twin does not have: a motor on a position
loop (a servo mode near the bottom of the band), a spindle on a bracket
(45-150 Hz), a tool holder. The twin calibration leaves such modes unpaired
(:meth:`robolobe.tl.graybox.TwinCalibration._match`), as does the network
transfer (its source network predicts a fixed number of modes). They are
data, not noise: a plan that does not see a bracket mode can put waypoints
beyond the true stability limit. :class:`ExtraModes` keeps them:

1. **modes**: at each posture, the unpaired rows of the driving-point
   directions with one frequency (identification writes a physical mode
   with the same ``f`` and ``zeta`` in every direction that sees it) are one
   physical mode, with a stiffness per direction that sees it;
2. **tracks**: across postures, the modes are grouped by frequency
   (single linkage in ``log f`` with gaps below :data:`TRACK_GAP`; one mode
   per posture, the one nearest the track's median); a track seen at fewer
   than :data:`MIN_SUPPORT` of the postures (and fewer than 3) is left out
   (a spurious or local mode), and a direction of a track seen at fewer than
   3 postures does not see it (infinite stiffness there); a value farther
   than 3.5 robust deviations (and a factor of 2) from its output's median
   is left out (a base-model mode left unpaired at that posture);
3. **interpolation**: each output (``log f`` and ``log zeta`` of a track,
   ``log k`` of a track at a direction) is its mean plus a Gaussian process
   on the joint angles (the kernel of :mod:`robolobe.tl.residual`, one
   length scale per joint and a signal fraction per output, by its marginal
   likelihood: a bracket's frequency follows one joint, a servo's stiffness
   others) fitted to the postures that saw it;
4. **spread**: the process's predictive standard deviation of a new test
   (scatter included), which grows from the leave-one-out error at the
   tests to the output's whole scatter over the postures far from them,
   times a scale per quantity so that :data:`~robolobe.tl.residual.SPREAD_CONFIDENCE`
   of the leave-one-out errors lie within
   :data:`~robolobe.tl.residual.SPREAD_SIGMA` spreads (never below 1).

At a posture where a track was not seen in a direction, the model predicts
the track's interpolated stiffness all the same (a mode seen at other
postures is assumed present: conservative for a plan). Predicted modes have
driving-point stiffness only (the diagonal of their residue matrix: a
modal dataset holds no cross terms), as a network's.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import minimize

from robolobe._directions import DRIVING
from robolobe.errors import InputError
from robolobe.robots.plausibility import Q_MAX_RAD

__all__ = [
    "MIN_SUPPORT",
    "TRACK_GAP",
    "ExtraModes",
    "split_extra_modes",
    "unpaired_of_calibration",
]

FloatArray = NDArray[np.float64]
#: Largest gap in ``log f`` between neighbouring modes of one track (8 %).
TRACK_GAP = float(np.log(1.08))
#: Least share of the postures a track must be seen at (and at least 3 postures).
MIN_SUPPORT = 0.25
_SAME_F = 1e-6  # rows of one physical mode carry the same frequency (identify writes one f)
_LOG_ELL_BOUNDS = (np.log(0.1), np.log(20.0))
_MIN_SCALE = (0.01, 0.05, 0.05)  # least scatter of log f, log zeta, log k of an output


class ExtraModes:
    """Modes measured beyond a base model's, over posture (module docstring).

    Attributes (fitted)
    -------------------
    directions_ : tuple of str
        Driving-point directions of the tests.
    n_tracks_ : int
        Extra modes the model predicts.
    train_q_rad_ : ndarray, shape (n, 6)
    values_ : ndarray, shape (n, n_tracks, 2 + n_dir)
        Training logs per posture: ``log f``, ``log zeta``, ``log k`` per
        direction (NaN: not seen).
    mean_, scale_ : ndarray, shape (n_tracks, 2 + n_dir)
        Mean and scatter of each output (NaN: an output without a model).
    length_scales_ : ndarray, shape (n_outputs, 6)
        Kernel length scales [rad] of each output (:meth:`_outputs` order).
    rho_ : ndarray, shape (n_outputs,)
        Signal fraction of each scaled output.
    spread_scale_ : ndarray, shape (3,)
        Calibration factor of the spread of log f, log zeta, log k.
    left_out_ : tuple of (float, int)
        Median frequency [Hz] and support of the groups left out.
    """

    def __init__(self) -> None:
        self.directions_: tuple[str, ...] = ()
        self.n_tracks_ = 0
        self.train_q_rad_ = np.zeros((0, 6))
        self.values_ = np.zeros((0, 0, 2))
        self.mean_ = np.zeros((0, 2))
        self.scale_ = np.zeros((0, 2))
        self.length_scales_ = np.ones((0, 6))
        self.rho_ = np.zeros(0)
        self.spread_scale_ = np.ones(3)
        self.left_out_: tuple[tuple[float, int], ...] = ()

    # ----------------------------------------------------------------- fit
    def fit(
        self,
        q_rad: ArrayLike,
        directions: Sequence[str],
        y: ArrayLike,
        paired: ArrayLike,
    ) -> ExtraModes:
        """Fit on the measured modes that the base model left unpaired.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Tested postures [rad].
        directions : sequence of str
            Driving points of ``y`` (``xx``, ``yy``, ``zz``).
        y : array_like, shape (n, n_dir, n_modes, 3)
            Measured f [Hz], zeta, k [N/m] (NaN: none).
        paired : array_like of bool, shape (n, n_dir, n_modes)
            True where the base model has the measured mode.

        Returns
        -------
        self
        """
        q = np.asarray(q_rad, dtype=float)
        yy = np.asarray(y, dtype=float)
        pr = np.asarray(paired, dtype=bool)
        dirs = tuple(directions)
        n = q.shape[0]
        if yy.ndim != 4 or yy.shape[:2] != (n, len(dirs)) or pr.shape != yy.shape[:3]:
            raise InputError(
                f"expected y (n, n_dir, n_modes, 3) and paired (n, n_dir, n_modes) for {n} "
                f"postures and {len(dirs)} directions, found {yy.shape} and {pr.shape}",
                source="ExtraModes.fit",
            )
        self.directions_ = dirs
        self.train_q_rad_ = q.copy()
        nd = len(dirs)
        # 1. physical modes per posture: {posture: [(log f, log zeta, {dir: log k})]}
        modes: list[tuple[int, float, float, dict[int, float]]] = []
        for i in range(n):
            here: list[tuple[float, float, dict[int, float]]] = []
            for j in range(nd):
                for m in np.flatnonzero(~pr[i, j] & np.all(np.isfinite(yy[i, j]), axis=-1)):
                    f, z, k = (float(v) for v in yy[i, j, m])
                    if not (f > 0 and z > 0 and k > 0):
                        continue
                    lf = float(np.log(f))
                    for lf0, _, ks in here:
                        if abs(lf0 - lf) < _SAME_F and j not in ks:
                            ks[j] = float(np.log(k))
                            break
                    else:
                        here.append((lf, float(np.log(z)), {j: float(np.log(k))}))
            modes += [(i, lf, lz, ks) for lf, lz, ks in here]
        # 2. tracks: single linkage in log f
        order = sorted(range(len(modes)), key=lambda a: modes[a][1])
        groups: list[list[int]] = []
        for a in order:
            if groups and modes[a][1] - modes[groups[-1][-1]][1] <= TRACK_GAP:
                groups[-1].append(a)
            else:
                groups.append([a])
        need = max(3, int(np.ceil(MIN_SUPPORT * n)))
        tracks: list[dict[int, int]] = []
        left: list[tuple[float, int]] = []
        for g in groups:
            med = float(np.median([modes[a][1] for a in g]))
            best: dict[int, int] = {}  # posture -> mode nearest the track's median
            for a in g:
                i = modes[a][0]
                if i not in best or abs(modes[a][1] - med) < abs(modes[best[i]][1] - med):
                    best[i] = a
            if len(best) >= need:
                tracks.append(best)
            else:
                left.append((float(np.exp(med)), len(best)))
        self.left_out_ = tuple(left)
        nt = len(tracks)
        vals = np.full((n, nt, 2 + nd), np.nan)
        for t, best in enumerate(tracks):
            for i, a in best.items():
                _, lf, lz, ks = modes[a]
                vals[i, t, 0], vals[i, t, 1] = lf, lz
                for j, lk in ks.items():
                    vals[i, t, 2 + j] = lk
        # a value far from its output's median (beyond 3.5 robust deviations and a factor
        # of 2) is a mode of the base model left unpaired at that posture, not this one's
        with warnings.catch_warnings(), np.errstate(invalid="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)  # an output without values
            center = np.nanmedian(vals, axis=0) if n else np.zeros(vals.shape[1:])
            dev = 1.4826 * np.nanmedian(np.abs(vals - center), axis=0) if n else center
            floor = np.array([_MIN_SCALE[min(c, 2)] for c in range(vals.shape[2])])
            gate = np.maximum(3.5 * np.fmax(dev, floor), np.log(2.0))
            vals = np.where(np.abs(vals - center) > gate, np.nan, vals)
        self.values_ = vals
        self.n_tracks_ = nt
        self._fit_process()
        return self

    def _outputs(self) -> list[tuple[int, int]]:
        """(track, column) of every output with at least 3 values."""
        ok = np.isfinite(self.values_).sum(axis=0)  # (nt, 2 + nd)
        return [(int(t), int(c)) for t, c in zip(*np.nonzero(ok >= 3), strict=True)]

    def _fit_process(self) -> None:
        from robolobe.tl.residual import SPREAD_CONFIDENCE, SPREAD_SIGMA, _pooled_nll

        nt, nc = self.values_.shape[1], self.values_.shape[2]
        self.mean_ = np.full((nt, nc), np.nan)
        self.scale_ = np.full((nt, nc), np.nan)
        outs = self._outputs()
        xs, ts = [], []
        for t, c in outs:
            v = self.values_[:, t, c]
            ok = np.isfinite(v)
            mu = float(np.mean(v[ok]))
            sd = max(float(np.std(v[ok])), _MIN_SCALE[min(c, 2)])
            self.mean_[t, c], self.scale_[t, c] = mu, sd
            xs.append(self.train_q_rad_[ok])
            ts.append((v[ok] - mu) / sd)
        n_ell = 6
        # hyperparameters per output (a bracket's frequency follows one joint, a servo's
        # stiffness others): length scales start long (a joint that does not matter
        # keeps a long one), bounded, by the marginal likelihood of the output alone
        hyp0 = np.r_[np.full(n_ell, np.log(3.0)), 0.0]
        bounds = [_LOG_ELL_BOUNDS] * n_ell + [(np.log(0.01 / 0.99), np.log(0.99 / 0.01))]
        self.length_scales_ = np.full((len(outs), n_ell), 3.0)
        self.rho_ = np.full(len(outs), 0.5)
        for o, (x, tt) in enumerate(zip(xs, ts, strict=True)):
            res = minimize(
                _pooled_nll, hyp0, args=([x], [tt], n_ell), method="L-BFGS-B", bounds=bounds
            )
            self.length_scales_[o] = np.exp(res.x[:n_ell])
            self.rho_[o] = float(1.0 / (1.0 + np.exp(-res.x[n_ell])))
        # leave-one-out errors in units of their own predictive spread, per quantity
        z: list[list[float]] = [[], [], []]
        for o, ((_, c), x, tt) in enumerate(zip(outs, xs, ts, strict=True)):
            a = np.linalg.inv(self._kmat(x, o))
            d = np.diag(a)
            e = (a @ tt) / d  # leave-one-out error (closed form)
            z[min(c, 2)] += list(np.abs(e) * np.sqrt(d))
        self.spread_scale_ = np.array(
            [
                float(np.clip(np.quantile(v, SPREAD_CONFIDENCE) / SPREAD_SIGMA, 1.0, 5.0))
                if len(v) >= 6
                else 1.5
                for v in z
            ]
        )

    def _kmat(self, x: FloatArray, o: int) -> FloatArray:
        """Covariance of output ``o``'s scaled values at postures ``x``."""
        from robolobe.tl.residual import _kernel

        rho = float(self.rho_[o])
        return rho * _kernel(x, x, self.length_scales_[o]) + (1.0 - rho) * np.eye(len(x))

    # ------------------------------------------------------------- predict
    def predict(
        self, q_rad: ArrayLike, directions: Sequence[str] = DRIVING
    ) -> tuple[FloatArray, FloatArray]:
        """The extra modes at postures: values and spread.

        Parameters
        ----------
        q_rad : array_like, shape (n, 6)
            Joint angles [rad].
        directions : sequence of str
            Driving points wanted; one the tests did not measure (or a track
            not seen there) gets infinite stiffness (the mode not seen).

        Returns
        -------
        values : ndarray, shape (n, n_dir, n_tracks, 3)
            f [Hz], zeta, k [N/m].
        log_std : ndarray, shape (n, n_dir, n_tracks, 3)
            Spread (std of log f, log zeta, log k); 0 where k is infinite.
        """
        from robolobe.tl.residual import _kernel

        q = np.asarray(q_rad, dtype=float).reshape(-1, 6)
        dirs = tuple(directions)
        n, nt = q.shape[0], self.n_tracks_
        nc = 2 + len(self.directions_)
        mean = np.full((n, nt, nc), np.nan)
        std = np.full((n, nt, nc), np.nan)
        for o, (t, c) in enumerate(self._outputs()):
            v = self.values_[:, t, c]
            ok = np.isfinite(v)
            x = self.train_q_rad_[ok]
            tt = (v[ok] - self.mean_[t, c]) / self.scale_[t, c]
            ks = float(self.rho_[o]) * _kernel(q, x, self.length_scales_[o])
            sol = np.linalg.solve(self._kmat(x, o), np.c_[tt, ks.T])
            mean[:, t, c] = self.mean_[t, c] + self.scale_[t, c] * (ks @ sol[:, 0])
            var = np.clip(1.0 - np.einsum("ij,ji->i", ks, sol[:, 1:]), 0.0, None)
            # a new test's spread, and the uncertainty of the output's mean
            std[:, t, c] = self.scale_[t, c] * np.sqrt(var + 1.0 / ok.sum())
        vals = np.full((n, len(dirs), nt, 3), np.nan)
        sd = np.zeros((n, len(dirs), nt, 3))
        for jj, d in enumerate(dirs):
            vals[:, jj, :, 0] = np.exp(mean[..., 0])
            vals[:, jj, :, 1] = np.exp(mean[..., 1])
            sd[:, jj, :, 0] = std[..., 0] * self.spread_scale_[0]
            sd[:, jj, :, 1] = std[..., 1] * self.spread_scale_[1]
            if d in self.directions_:
                c = 2 + self.directions_.index(d)
                seen = np.isfinite(mean[..., c])
                vals[:, jj, :, 2] = np.where(seen, np.exp(mean[..., c]), np.inf)
                sd[:, jj, :, 2] = np.where(seen, std[..., c] * self.spread_scale_[2], 0.0)
            else:
                vals[:, jj, :, 2] = np.inf
            sd[:, jj] = np.where(np.isfinite(vals[:, jj, :, 2])[..., None], sd[:, jj], 0.0)
        return vals, np.nan_to_num(sd, nan=0.0)

    def describe(self) -> list[str]:
        """One line per extra mode: frequency range, directions seen, support."""
        out = []
        for t in range(self.n_tracks_):
            f = np.exp(self.values_[:, t, 0])
            f = f[np.isfinite(f)]
            seen = [
                d
                for j, d in enumerate(self.directions_)
                if np.isfinite(self.values_[:, t, 2 + j]).sum() >= 3
            ]
            out.append(
                f"{f.min():.4g}-{f.max():.4g} Hz, seen in {', '.join(seen) or 'no direction'} "
                f"at {f.size} of {self.values_.shape[0]} postures"
            )
        return out

    def warn_left_out(self) -> None:
        """A TrustWarning naming the unpaired modes too rare to be a track."""
        from robolobe.tl.dataset import TrustWarning

        if self.left_out_:
            fs = ", ".join(f"{f:.4g} Hz ({c})" for f, c in self.left_out_[:6])
            warnings.warn(
                f"{len(self.left_out_)} measured mode group(s) without a model counterpart "
                f"seen at too few postures to interpolate (frequency, postures: {fs}): left "
                "out of the model (spurious or local modes)",
                TrustWarning,
                stacklevel=3,
            )

    # ---------------------------------------------------------------- save
    def arrays(self, prefix: str) -> dict[str, Any]:
        """Arrays to store in a model file (names start with ``prefix``)."""
        return {
            f"{prefix}dirs": np.array(",".join(self.directions_)),
            f"{prefix}q": self.train_q_rad_,
            f"{prefix}values": self.values_,
            f"{prefix}mean": self.mean_,
            f"{prefix}scale": self.scale_,
            f"{prefix}ell": self.length_scales_,
            f"{prefix}rho": self.rho_,
            f"{prefix}spread_scale": self.spread_scale_,
        }

    @classmethod
    def from_arrays(cls, arrays: Mapping[str, Any], prefix: str, where: str) -> ExtraModes:
        """Read :meth:`arrays` back (none stored: no extra modes), checking what breaks the math."""
        from robolobe._npz import check_range

        self = cls()
        if f"{prefix}values" not in arrays:
            return self
        try:
            dirs = str(arrays[f"{prefix}dirs"])
            self.directions_ = tuple(d for d in dirs.split(",") if d)
            self.train_q_rad_ = np.asarray(arrays[f"{prefix}q"], dtype=float)
            self.values_ = np.asarray(arrays[f"{prefix}values"], dtype=float)
            self.mean_ = np.asarray(arrays[f"{prefix}mean"], dtype=float)
            self.scale_ = np.asarray(arrays[f"{prefix}scale"], dtype=float)
            self.length_scales_ = np.asarray(arrays[f"{prefix}ell"], dtype=float)
            self.rho_ = np.asarray(arrays[f"{prefix}rho"], dtype=float).reshape(-1)
            self.spread_scale_ = np.asarray(arrays[f"{prefix}spread_scale"], dtype=float)
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(
                f"inconsistent model file: extra modes ({exc})", source=where
            ) from None
        n = self.train_q_rad_.shape[0]
        nd = len(self.directions_)
        if (
            any(d not in DRIVING for d in self.directions_)
            or self.train_q_rad_.shape != (n, 6)
            or self.values_.ndim != 3
            or self.values_.shape[0] != n
            or self.values_.shape[2] != 2 + nd
            or self.mean_.shape != self.values_.shape[1:]
            or self.scale_.shape != self.values_.shape[1:]
            or self.length_scales_.shape != (len(self.rho_), 6)
            or self.spread_scale_.shape != (3,)
        ):
            raise InputError(
                "inconsistent model file: extra modes: array shapes do not match", source=where
            )
        self.n_tracks_ = self.values_.shape[1]
        check_range(self.values_, "extra_values", where, low=-50.0, high=50.0, nan_ok=True)
        check_range(self.mean_, "extra_mean", where, low=-50.0, high=50.0, nan_ok=True)
        check_range(self.scale_, "extra_scale", where, low=0.0, open_low=True, nan_ok=True)
        check_range(self.length_scales_, "extra_ell", where, low=0.0, open_low=True)
        check_range(self.rho_, "extra_rho", where, low=0.0, high=1.0, open_high=True)
        if len(self.rho_) != len(self._outputs()):
            raise InputError(
                "inconsistent model file: extra modes: one kernel per output expected", where
            )
        check_range(self.spread_scale_, "extra_spread_scale", where, low=0.0, open_low=True)
        check_range(self.train_q_rad_, "extra_q", where, low=-Q_MAX_RAD, high=Q_MAX_RAD)
        return self


def unpaired_of_calibration(cal: Any, ds: Any) -> ExtraModes:
    """:class:`ExtraModes` of the tests' modes a fitted twin calibration has no partner for.

    Parameters
    ----------
    cal : TwinCalibration
        Fitted on ``ds``.
    ds : ModalDataset
        The hammer tests.

    Returns
    -------
    ExtraModes
        Fitted (no tracks when every measured mode has a twin partner).
    """
    twin = cal.predict(ds.q_rad, directions=ds.directions, n_modes=6, spread=False).values
    (i, j, m, _), _ = cal._match(ds, twin)
    y = np.asarray(ds.y)
    paired = np.zeros(y.shape[:3], bool)
    paired[i, j, m] = True
    return ExtraModes().fit(ds.q_rad, ds.directions, y, paired)


def split_extra_modes(df: Any, robot: Any, directions: Sequence[str]) -> tuple[Any, ExtraModes]:
    """A modal table without the modes a robot file's twin lacks, and those modes' model.

    For a model that predicts a fixed number of modes per direction by rank
    (the seed's network): a servo or bracket mode among the measured ones
    would shift the rank of every mode above it. Per posture and direction
    the measured modes are matched to the robot file's twin modes as the
    twin calibration matches them (:meth:`robolobe.tl.graybox.TwinCalibration._match`,
    frequency within 35 % and, with more measured modes than the twin has,
    stiffness within a factor of 10); the unpaired ones that form tracks
    over the postures (:class:`ExtraModes`) are taken out and the rest
    numbered again by rising frequency at each posture (as ``identify``
    numbers them).

    Parameters
    ----------
    df : pandas.DataFrame
        A ``modal.csv`` frame.
    robot : Robot
        The robot file (its nominal twin).
    directions : sequence of str
        Driving points kept.

    Returns
    -------
    (pandas.DataFrame, ExtraModes)
        The rows of the modes the twin has, renumbered, and the extra modes' model.
    """
    import pandas as pd

    from robolobe.tl.dataset import dataset_from_frame
    from robolobe.tl.graybox import TwinCalibration, twin_values

    dirs = tuple(d for d in directions if d in set(df["dir"].astype(str).str.lower()))
    mode_no = pd.to_numeric(df["mode"], errors="coerce")
    ds = dataset_from_frame(df, directions=dirs, n_modes=int(mode_no.max()))
    twin = twin_values(robot, ds.q_rad, directions=dirs, n_modes=6)
    (i, j, m, _), _ = TwinCalibration(robot=robot)._match(ds, twin)
    y = np.asarray(ds.y)
    paired = np.zeros(y.shape[:3], bool)
    paired[i, j, m] = True
    extra = ExtraModes().fit(ds.q_rad, dirs, y, paired)
    if not extra.n_tracks_:
        return df, extra
    # the (posture, frequency) of every mode of a track
    pp, tt = np.nonzero(np.isfinite(extra.values_[..., 0]))
    taken = {
        (ds.posture_ids[p], float(np.exp(extra.values_[p, t, 0])))
        for p, t in zip(pp, tt, strict=True)
    }
    pid = df["posture_id"].astype(str)
    f = df["f_hz"].astype(float)
    drop = np.array(
        [
            any(p == tp and abs(x / tf - 1) < 1e-6 for tp, tf in taken)
            for p, x in zip(pid, f, strict=True)
        ]
    )
    out = df.loc[~drop].copy()
    # numbered again: rank of the frequency among the posture's remaining modes
    ranks = out.groupby("posture_id")["f_hz"].rank(method="dense").astype(int)
    out["mode"] = ranks
    return out.reset_index(drop=True), extra
