"""Baselines for the transfer, run on the same splits as the transferred model.

* ``source-only``: robot A's model unchanged (A's scalers too);
* ``target-only``: the same network trained from scratch on the target data;
* ``affine``: A's prediction corrected per output, ``t = a t_A(q) + b``
  (least squares in the model's target space: log / sqrt-compliance);
* ``gp-residual``: A's prediction plus a Gaussian process on the residuals
  (ARD squared-exponential kernel on sin/cos joint features, hyperparameters
  shared by all outputs, by maximum marginal likelihood); its posterior
  standard deviation is the spread;
* ``fine-tune-all``: the transfer with no frozen layer.

All have ``fit(q_rad, y)``, ``fit_dataset(ds)`` and ``predict(q_rad)`` ->
:class:`~robolobe.tl.estimator.ModalPrediction`.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import cho_factor, cho_solve
from scipy.optimize import minimize

from robolobe.errors import InputError
from robolobe.tl.dataset import ModalDataset, TrustWarning
from robolobe.tl.estimator import ModalPrediction, ModalPredictor
from robolobe.tl.preprocess import TargetTransform

__all__ = ["AffineCorrection", "GPResidual", "SourceOnly", "make_baselines"]

FloatArray = NDArray[np.float64]


def _src_center(source: ModalPredictor, q: FloatArray) -> FloatArray:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TrustWarning)
        return source.predict(q).center


class _Base:
    def __init__(self, source: ModalPredictor) -> None:
        self.source = source
        self.directions = tuple(source.directions)
        self.kind = source.target_transform_.kind

    def _pre(self, y: ArrayLike) -> FloatArray:
        return TargetTransform(self.kind, self.source.target_transform_.scaler).pre(y)

    def fit_dataset(self, ds: ModalDataset) -> Any:
        """:meth:`fit` on a dataset with the source's directions."""
        idx = [ds.directions.index(d) for d in self.directions]
        return self.fit(ds.q_rad, ds.y[:, idx, : int(self.source.n_modes)])

    def fit(self, q_rad: ArrayLike, y: ArrayLike) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError


class SourceOnly(_Base):
    """The source model applied to the target as it is."""

    def fit(self, q_rad: ArrayLike, y: ArrayLike) -> SourceOnly:
        """Nothing to learn; returns self."""
        return self

    def predict(self, q_rad: ArrayLike) -> ModalPrediction:
        """The source's prediction."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TrustWarning)
            return self.source.predict(q_rad)


class AffineCorrection(_Base):
    """Source prediction with a per-output affine correction in the target space."""

    def fit(self, q_rad: ArrayLike, y: ArrayLike) -> AffineCorrection:
        """Least-squares ``a, b`` per output; offset only where the source is flat."""
        q = np.asarray(q_rad, dtype=float)
        t = self._pre(y).reshape(len(q), -1)
        s = _src_center(self.source, q).reshape(len(q), -1)
        a = np.ones(t.shape[1])
        b = np.zeros(t.shape[1])
        res_sd = np.zeros(t.shape[1])
        for j in range(t.shape[1]):
            ok = np.isfinite(t[:, j])
            if ok.sum() == 0:
                continue
            x, z = s[ok, j], t[ok, j]
            if ok.sum() >= 3 and np.var(x) > 1e-12:
                a[j], b[j] = np.polyfit(x, z, 1)
            else:
                b[j] = float(np.mean(z - x))
            r = z - (a[j] * x + b[j])
            res_sd[j] = float(np.sqrt(np.mean(r**2))) if len(r) > 2 else 0.0
        self.a_, self.b_, self.res_sd_ = a, b, res_sd
        return self

    def predict(self, q_rad: ArrayLike) -> ModalPrediction:
        """Corrected prediction; spread = residual RMS of the fit."""
        q = np.asarray(q_rad, dtype=float)
        s = _src_center(self.source, q)
        shape = s.shape
        c = (s.reshape(len(q), -1) * self.a_ + self.b_).reshape(shape)
        sd = np.broadcast_to(self.res_sd_, (len(q), self.a_.size)).reshape(shape).copy()
        return ModalPrediction(self.directions, c, sd, self.kind)


class GPResidual(_Base):
    """Source prediction plus a Gaussian process on its residuals."""

    @staticmethod
    def _x(q: FloatArray) -> FloatArray:
        return np.concatenate([np.sin(q), np.cos(q)], axis=1)

    def fit(self, q_rad: ArrayLike, y: ArrayLike) -> GPResidual:
        """Maximum marginal likelihood of shared ARD hyperparameters, per-output means."""
        q = np.asarray(q_rad, dtype=float)
        t = self._pre(y).reshape(len(q), -1)
        s = _src_center(self.source, q).reshape(len(q), -1)
        r = t - s
        self.mu_ = np.nan_to_num(np.nanmean(r, axis=0))
        self.sd_ = np.nan_to_num(np.nanstd(r, axis=0), nan=1.0)
        self.sd_ = np.where(self.sd_ > 1e-9, self.sd_, 1.0)
        z = (r - self.mu_) / self.sd_
        x = self._x(q)
        masks = np.isfinite(z)
        groups: dict[bytes, list[int]] = {}
        for j in range(z.shape[1]):
            groups.setdefault(masks[:, j].tobytes(), []).append(j)
        d2 = (x[:, None, :] - x[None, :, :]) ** 2  # (n, n, p)

        def nll(theta: FloatArray) -> float:
            ell = np.exp(theta[:-2])
            sf2, sn2 = np.exp(2 * theta[-2]), np.exp(2 * theta[-1]) + 1e-8
            k = sf2 * np.exp(-0.5 * (d2 / ell**2).sum(-1))
            total = 0.0
            for key, cols in groups.items():
                m = np.frombuffer(key, dtype=bool)
                if m.sum() == 0:
                    continue
                km = k[np.ix_(m, m)] + sn2 * np.eye(int(m.sum()))
                try:
                    cf = cho_factor(km)
                except np.linalg.LinAlgError:
                    return 1e10
                zz = z[m][:, cols]
                alpha = cho_solve(cf, zz)
                total += 0.5 * float((zz * alpha).sum())
                total += len(cols) * float(np.log(np.diag(cf[0])).sum())
            return total

        p = x.shape[1]
        theta0 = np.concatenate([np.full(p, np.log(1.0)), [0.0, np.log(0.3)]])
        bounds = [(np.log(0.05), np.log(20.0))] * p + [(-3.0, 2.0), (-5.0, 0.5)]
        res = minimize(nll, theta0, method="L-BFGS-B", bounds=bounds, options={"maxiter": 200})
        self.theta_ = res.x
        self.x_, self.z_, self.masks_ = x, z, masks
        return self

    def predict(self, q_rad: ArrayLike) -> ModalPrediction:
        """Posterior mean and standard deviation (incl. noise) in the target space."""
        q = np.asarray(q_rad, dtype=float)
        s = _src_center(self.source, q)
        shape = s.shape
        xs = self._x(q)
        ell = np.exp(self.theta_[:-2])
        sf2, sn2 = np.exp(2 * self.theta_[-2]), np.exp(2 * self.theta_[-1]) + 1e-8
        k = sf2 * np.exp(-0.5 * (((self.x_[:, None] - self.x_[None]) / ell) ** 2).sum(-1))
        ks = sf2 * np.exp(-0.5 * (((xs[:, None] - self.x_[None]) / ell) ** 2).sum(-1))
        n_out = self.z_.shape[1]
        mean = np.zeros((len(q), n_out))
        var = np.full((len(q), n_out), sf2 + sn2)
        for j in range(n_out):
            m = self.masks_[:, j]
            if not m.any():
                continue
            cf = cho_factor(k[np.ix_(m, m)] + sn2 * np.eye(int(m.sum())))
            mean[:, j] = ks[:, m] @ cho_solve(cf, self.z_[m, j])
            v = cho_solve(cf, ks[:, m].T)
            var[:, j] = sf2 + sn2 - np.einsum("ij,ji->i", ks[:, m], v)
        c = s.reshape(len(q), -1) + self.mu_ + mean * self.sd_
        sd = np.sqrt(np.maximum(var, 0.0)) * self.sd_
        return ModalPrediction(self.directions, c.reshape(shape), sd.reshape(shape), self.kind)


def make_baselines(source: ModalPredictor, params: dict[str, Any], seed: int) -> dict[str, Any]:
    """Unfitted baselines for a transfer from ``source`` (see module docstring).

    Parameters
    ----------
    source : ModalPredictor
        Fitted source model.
    params : dict
        Parameters of the transferred model (a preset).
    seed : int
        ``random_state`` of the networks.
    """
    if not hasattr(source, "net_"):
        raise InputError("source: expected a fitted ModalPredictor")
    p = {k: v for k, v in params.items() if k not in ("source", "n_frozen", "calibration")}
    return {
        "source-only": SourceOnly(source),
        "target-only": ModalPredictor(**p, calibration="cv", random_state=seed),
        "affine": AffineCorrection(source),
        "gp-residual": GPResidual(source),
        "fine-tune-all": ModalPredictor(
            **p, source=source, n_frozen=0, calibration="cv", random_state=seed
        ),
    }
