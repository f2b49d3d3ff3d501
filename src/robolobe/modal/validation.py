"""Check an identified modal dataset against known (true) modes.

Used by the accuracy study (``studies/modal_accuracy.py``) on simulated
campaigns of the twin, whose true modes are known exactly.

*Visible* (the definition the accuracy targets refer to): true mode ``r`` is
visible at driving point ``d`` of a posture when its natural frequency lies
in the analysis band and the peak of its term in the measured (windowed)
FRF, ``|R_r,dd| / (sigma_r + window decay)``, is at least ``visible_min``
(default 5 %) of the largest ``|H_dd|`` of the windowed true receptance in
the band.

Matching, per posture and direction: identified rows and true modes are
paired by the gated assignment :func:`robolobe._matching.match_modes` on the relative
frequency difference, pairs above ``f_tol`` (5 %) forbidden. A visible true
mode left unpaired is *missed*; an identified row that pairs with no true
mode at all (visible or not) is *spurious*.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES
from robolobe._matching import match_modes

__all__ = [
    "AccuracyReport",
    "compare_with_truth",
    "true_visibility",
]


def true_visibility(
    poles: ArrayLike,
    residues: ArrayLike,
    freq_hz: ArrayLike,
    *,
    band_hz: tuple[float, float],
    window_decay_per_s: float = 0.0,
) -> NDArray[np.float64]:
    """Visibility of true modes at the driving points, shape (n, 3, n_modes).

    Parameters
    ----------
    poles : array_like of complex, shape (n, n_modes)
        True poles, rad/s.
    residues : array_like of complex, shape (n, n_modes, 3, 3)
        True receptance residues.
    freq_hz : array_like, shape (n_freq,)
        Lines on which the windowed receptance peak is taken.
    band_hz : (float, float)
    window_decay_per_s : float
        Decay rate added by the exponential window.

    Returns
    -------
    ndarray
        Peak of each mode's term over the band's largest ``|H_dd|``; 0 for
        modes outside the band.
    """
    lam = np.asarray(poles, dtype=complex)
    R = np.asarray(residues, dtype=complex)
    f = np.asarray(freq_hz, dtype=float)
    band = (f >= band_hz[0]) & (f <= band_hz[1])
    lam_w = lam - window_decay_per_s
    s = 2j * np.pi * f[band]
    g = 1.0 / (s[None, :, None] - lam_w[:, None, :])
    gc = 1.0 / (s[None, :, None] - np.conj(lam_w)[:, None, :])
    Rdd = np.diagonal(R, axis1=-2, axis2=-1)  # (n, m, 3)
    H = np.einsum("nfm,nmd->nfd", g, Rdd) + np.einsum("nfm,nmd->nfd", gc, np.conj(Rdd))
    hmax = np.max(np.abs(H), axis=1)  # (n, 3)
    peak = np.abs(Rdd) / np.abs(lam_w.real)[..., None]  # (n, m, 3)
    vis = np.swapaxes(peak, 1, 2) / hmax[:, :, None]
    fn = np.abs(lam) / (2 * np.pi)
    inb = (fn >= band_hz[0]) & (fn <= band_hz[1])
    return np.asarray(np.where(inb[:, None, :], vis, 0.0), dtype=float)


@dataclass(frozen=True)
class AccuracyReport:
    """Identified vs true modes.

    Attributes
    ----------
    matched : pandas.DataFrame
        One row per identified row paired with a visible true mode:
        ``posture_id, dir, mode, true_mode, f_true, f_est, zeta_true,
        zeta_est, k_true, k_est, err_f, err_zeta, err_k`` (relative errors,
        absolute values).
    missed : pandas.DataFrame
        Visible true modes not identified: ``posture_id, dir, true_mode, f_true, visibility``.
    spurious : pandas.DataFrame
        Identified rows matching no true mode: ``posture_id, dir, mode, f_est``.
    extra : int
        Identified rows that match a true mode that is not visible (not errors).
    n_visible : int
        Visible true (posture, direction, mode) triples.
    """

    matched: pd.DataFrame
    missed: pd.DataFrame
    spurious: pd.DataFrame
    extra: int
    n_visible: int

    def percentile(self, q: float = 90.0) -> dict[str, float]:
        """``q``-th percentile of the relative errors of f, zeta, k."""
        m = self.matched
        if m.empty:
            return {"f": float("nan"), "zeta": float("nan"), "k": float("nan")}
        return {
            "f": float(np.percentile(m["err_f"], q)),
            "zeta": float(np.percentile(m["err_zeta"], q)),
            "k": float(np.percentile(m["err_k"], q)),
        }


def compare_with_truth(
    table: pd.DataFrame,
    posture_ids: Sequence[str],
    f_hz: ArrayLike,
    zeta: ArrayLike,
    k_N_per_m: ArrayLike,
    visibility: ArrayLike,
    *,
    visible_min: float = 0.05,
    f_tol: float = 0.05,
    dirs: Sequence[str] = ("xx", "yy", "zz"),
) -> AccuracyReport:
    """Pair identified rows with true modes and measure the errors.

    Parameters
    ----------
    table : pandas.DataFrame
        Identified modal dataset (``posture_id, dir, mode, f_hz, zeta, k_N_per_m``).
    posture_ids : sequence of str, length n
    f_hz, zeta : array_like, shape (n, n_modes)
        True natural frequencies (Hz) and damping ratios.
    k_N_per_m : array_like, shape (n, 3, n_modes)
        True driving-point modal stiffness.
    visibility : array_like, shape (n, 3, n_modes)
        From :func:`true_visibility`.
    visible_min : float
        Visibility threshold of the accuracy targets.
    f_tol : float
        Largest relative frequency difference of a pair.
    dirs : sequence of str
        Driving points to check.

    Returns
    -------
    AccuracyReport
    """
    F = np.asarray(f_hz, dtype=float)
    Z = np.asarray(zeta, dtype=float)
    K = np.asarray(k_N_per_m, dtype=float)
    V = np.asarray(visibility, dtype=float)
    groups = {key: g for key, g in table.groupby(["posture_id", "dir"], sort=False)}
    matched, missed, spurious = [], [], []
    extra = 0
    n_visible = 0
    for p, pid in enumerate(posture_ids):
        for dname in dirs:
            d = AXES.index(dname[0])
            vis = V[p, d]
            visible = np.flatnonzero(vis >= visible_min)
            n_visible += visible.size
            g = groups.get((str(pid), dname))
            if g is None or g.empty:
                for rv in visible.tolist():
                    missed.append((str(pid), dname, int(rv), float(F[p, rv]), float(vis[rv])))
                continue
            fe = g["f_hz"].to_numpy(float)
            c = np.abs(fe[:, None] - F[p][None, :]) / F[p][None, :]
            # visible true modes are preferred partners
            cost = np.where(c <= f_tol, c + np.where(vis >= visible_min, 0.0, 0.5)[None, :], np.inf)
            rows, cols = match_modes(cost)
            pair = {int(i): int(j) for i, j in zip(rows, cols, strict=True)}
            got = set(pair.values())
            for i, (_, row) in enumerate(g.iterrows()):
                if i not in pair:
                    spurious.append((str(pid), dname, int(row["mode"]), float(row["f_hz"])))
                    continue
                r = pair[i]
                if vis[r] < visible_min:
                    extra += 1
                    continue
                kt = K[p, d, r]
                matched.append(
                    (
                        str(pid),
                        dname,
                        int(row["mode"]),
                        r,
                        F[p, r],
                        float(row["f_hz"]),
                        Z[p, r],
                        float(row["zeta"]),
                        kt,
                        float(row["k_N_per_m"]),
                        abs(float(row["f_hz"]) - F[p, r]) / F[p, r],
                        abs(float(row["zeta"]) - Z[p, r]) / Z[p, r],
                        abs(float(row["k_N_per_m"]) - kt) / kt,
                    )
                )
            for rv in visible.tolist():
                if rv not in got:
                    missed.append((str(pid), dname, int(rv), float(F[p, rv]), float(vis[rv])))
    cols_m = [
        "posture_id",
        "dir",
        "mode",
        "true_mode",
        "f_true",
        "f_est",
        "zeta_true",
        "zeta_est",
        "k_true",
        "k_est",
        "err_f",
        "err_zeta",
        "err_k",
    ]
    return AccuracyReport(
        matched=pd.DataFrame(matched, columns=cols_m),
        missed=pd.DataFrame(
            missed, columns=["posture_id", "dir", "true_mode", "f_true", "visibility"]
        ),
        spurious=pd.DataFrame(spurious, columns=["posture_id", "dir", "mode", "f_est"]),
        extra=extra,
        n_visible=n_visible,
    )
