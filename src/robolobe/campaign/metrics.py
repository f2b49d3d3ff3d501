"""FRF and shape similarity metrics: FRAC, NRMSE (as in the seed paper) and MAC.

- FRAC (seed eq. 5, docs/references.md: modal identification)::

      FRAC = |sum_w Hp Hm*|^2 / (sum_w |Hp|^2  sum_w |Hm|^2)

- NRMSE (seed eq. 6)::

      NRMSE = || |Hp| - |Hm| ||_2 / || |Hm| ||_2

  with ``Hp`` the predicted (synthesized) and ``Hm`` the measured FRF.
- MAC::

      MAC = |phi1^H phi2|^2 / ((phi1^H phi1) (phi2^H phi2))
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["frac", "mac", "mac_matrix", "nrmse"]


def frac(Hp: ArrayLike, Hm: ArrayLike, axis: int = -1) -> NDArray[np.float64]:
    """Frequency response assurance criterion between predicted and measured FRFs.

    Parameters
    ----------
    Hp, Hm : array_like of complex, broadcastable, frequencies along ``axis``
        Predicted and measured FRFs over the same frequency lines.
    axis : int
        Frequency axis.

    Returns
    -------
    numpy.ndarray of float
        FRAC in [0, 1], the broadcast shape without ``axis`` (0-d for 1-D
        input). NaN if either FRF is all zero or holds NaN.
    """
    p = np.asarray(Hp, dtype=complex)
    m = np.asarray(Hm, dtype=complex)
    num = np.abs(np.sum(p * np.conj(m), axis=axis)) ** 2
    den = np.sum(np.abs(p) ** 2, axis=axis) * np.sum(np.abs(m) ** 2, axis=axis)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    out = np.where(np.isnan(den), np.nan, out)
    return np.asarray(out, dtype=float)


def nrmse(Hp: ArrayLike, Hm: ArrayLike, axis: int = -1) -> NDArray[np.float64]:
    """Normalized root-mean-square error of FRF magnitudes (seed eq. 6).

    Parameters
    ----------
    Hp, Hm : array_like of complex, broadcastable, frequencies along ``axis``
        Predicted and measured FRFs.
    axis : int
        Frequency axis.

    Returns
    -------
    numpy.ndarray of float
        ``|| |Hp| - |Hm| || / || |Hm| ||`` (0 is a perfect match); NaN if
        ``Hm`` is all zero or either holds NaN.
    """
    ap = np.abs(np.asarray(Hp, dtype=complex))
    am = np.abs(np.asarray(Hm, dtype=complex))
    num = np.sqrt(np.sum((ap - am) ** 2, axis=axis))
    den = np.sqrt(np.sum(am**2, axis=axis))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    out = np.where(np.isnan(den) | np.isnan(num), np.nan, out)
    return np.asarray(out, dtype=float)


def mac(phi1: ArrayLike, phi2: ArrayLike) -> NDArray[np.float64]:
    """Modal assurance criterion of shape vectors along the last axis.

    Parameters
    ----------
    phi1, phi2 : array_like (real or complex), shape (..., n_dof), broadcastable

    Returns
    -------
    numpy.ndarray of float, shape (...)
        MAC in [0, 1]; NaN for a zero vector.
    """
    a = np.asarray(phi1, dtype=complex)
    b = np.asarray(phi2, dtype=complex)
    num = np.abs(np.sum(np.conj(a) * b, axis=-1)) ** 2
    den = np.sum(np.abs(a) ** 2, axis=-1) * np.sum(np.abs(b) ** 2, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    return np.asarray(out, dtype=float)


def mac_matrix(phi1: ArrayLike, phi2: ArrayLike) -> NDArray[np.float64]:
    """MAC between every pair of shapes.

    Parameters
    ----------
    phi1 : array_like, shape (m1, n_dof)
    phi2 : array_like, shape (m2, n_dof)

    Returns
    -------
    numpy.ndarray of float, shape (m1, m2)
    """
    a = np.atleast_2d(np.asarray(phi1, dtype=complex))
    b = np.atleast_2d(np.asarray(phi2, dtype=complex))
    num = np.abs(a.conj() @ b.T) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=1), np.sum(np.abs(b) ** 2, axis=1))
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)
    return np.asarray(out, dtype=float)
