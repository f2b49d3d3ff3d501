"""State-space poles of ``M x'' + C x' + K x = 0``: the project's one eigen-solve of them.

Every pole, mode and pole-residue receptance of the twin comes from here
(:func:`robolobe.twin.modes.compute_modes`, :func:`robolobe.twin.modes.damped_poles`,
the diagnosis' windowed receptance and mode list), so the poles and the
treatment of overdamped modes are the same everywhere.

The eigenvalues of the first-order (state-space) matrix
``A = [[0, I], [-M^-1 K, -M^-1 C]]`` (shape (2n, 2n)) are solved for a whole
stack of postures by one batched LAPACK call (:func:`state_space_eig`). An
underdamped mode is a conjugate pair ``lambda, conj(lambda)``; an
*overdamped* mode is two real poles ``p1, p2 < 0`` (no resonance). The
modal view (:func:`modal_poles`) keeps the n upper-half-plane poles, one per
mode, and treats overdamped modes by an explicit policy (``overdamped``):

``"raise"``
    refuse with :class:`~robolobe.errors.InputError` (the twin's modes: a
    robot whose modes are overdamped is usually a file with wrong damping
    units, and the caller names the file).
``"drop"``
    leave the mode out: its slot holds ``nan`` (the diagnosis' mode list,
    and any caller that can do without an overdamped mode, e.g. a planner,
    which only needs the resonant ones). The slot keeps the mode's place in
    the rising-frequency order so that slot r stays mode r of the undamped
    problem: an overdamped pair sorts at ``sqrt(p1 p2)`` (its undamped
    frequency for a single degree of freedom). With several overdamped modes
    at one posture the real poles are paired nested (smallest with largest
    magnitude), which only orders the ``nan`` slots among themselves.

A pole counts as real when ``|Im lambda| <= 1e-9 |lambda|`` (LAPACK returns
real eigenvalues of a real matrix with an imaginary part of exactly 0).

Eigenvectors are computed only when asked: :func:`pole_vectors` finds the
null vector of ``Q(lambda) = lambda^2 M + lambda C + K`` for known poles by
two steps of inverse iteration (a batched ``n x n`` solve per pole), about
as cheap as LAPACK's eigenvectors of the ``2n x 2n`` matrix and only paid by
callers that need residues.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError

__all__ = [
    "OVERDAMPED_POLICIES",
    "REAL_POLE_TOL",
    "OverdampedPolicy",
    "modal_poles",
    "pole_vectors",
    "state_matrix",
    "state_space_eig",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

OverdampedPolicy = Literal["raise", "drop"]
OVERDAMPED_POLICIES: tuple[str, ...] = ("raise", "drop")

REAL_POLE_TOL = 1e-9
"""A pole is real (part of an overdamped mode) when ``|Im| <= REAL_POLE_TOL |lambda|``."""

_SHIFT = 1e-14
"""Relative shift of inverse iteration off the pole (:func:`pole_vectors`)."""

OVERDAMPED_MESSAGE = (
    "damping: expected an underdamped system (complex pole pairs), found an "
    "overdamped mode (real poles); reduce the damping"
)


def state_matrix(M: FloatArray, K: FloatArray, C: FloatArray) -> FloatArray:
    """First-order system matrix ``[[0, I], [-M^-1 K, -M^-1 C]]``.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
        Mass [kg m^2], stiffness [N m/rad] and damping [N m s/rad] matrices
        (any consistent units), one batch shape.

    Returns
    -------
    ndarray, shape (..., 2n, 2n)
    """
    n = M.shape[-1]
    m_inv = np.linalg.inv(M)
    a = np.zeros((*M.shape[:-2], 2 * n, 2 * n))
    a[..., :n, n:] = np.eye(n)
    a[..., n:, :n] = -m_inv @ K
    a[..., n:, n:] = -m_inv @ C
    return a


def state_space_eig(
    M: FloatArray, K: FloatArray, C: FloatArray, *, vectors: bool = False
) -> tuple[ComplexArray, ComplexArray | None]:
    """All 2n poles of ``M x'' + C x' + K x = 0`` (complex pairs and real ones).

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
        One batch shape (postures).
    vectors : bool
        Also return the displacement part of the eigenvectors.

    Returns
    -------
    lam : ndarray of complex, shape (..., 2n)
        Poles [rad/s] in LAPACK's order (unsorted).
    psi : ndarray of complex, shape (..., n, 2n) or None
        Column r: displacement part of the eigenvector of ``lam[..., r]``
        (scale arbitrary); None unless ``vectors``.
    """
    n = M.shape[-1]
    a = state_matrix(M, K, C)
    if vectors:
        lam, v = np.linalg.eig(a)
        return np.asarray(lam, dtype=np.complex128), np.asarray(v[..., :n, :], np.complex128)
    return np.asarray(np.linalg.eigvals(a), dtype=np.complex128), None


def _nested_pair_keys(real_poles: FloatArray) -> FloatArray:
    """Sort keys ``sqrt(p_i p_j)`` of overdamped pairs (real poles paired nested)."""
    mag = np.sort(np.abs(real_poles))
    half = mag.size // 2
    out: FloatArray = np.sqrt(mag[:half] * mag[::-1][:half])
    return out


def modal_poles(
    M: FloatArray, K: FloatArray, C: FloatArray, *, overdamped: OverdampedPolicy = "raise"
) -> ComplexArray:
    """One pole per mode: the upper-half-plane poles by rising ``|lambda|``.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
        One batch shape (postures).
    overdamped : {"raise", "drop"}
        What to do with an overdamped mode (two real poles), see the module
        notes: ``"raise"`` refuses, ``"drop"`` leaves a ``nan`` in its slot.

    Returns
    -------
    ndarray of complex, shape (..., n)
        ``lambda_r`` [rad/s] with ``Im > 0``; ``nan`` for dropped modes.

    Raises
    ------
    InputError
        On an overdamped mode under ``"raise"``, or an unknown policy.
    """
    if overdamped not in OVERDAMPED_POLICIES:
        raise InputError(f"overdamped: expected one of {OVERDAMPED_POLICIES}, found {overdamped!r}")
    n = M.shape[-1]
    lam_all, _ = state_space_eig(M, K, C)
    size = np.abs(lam_all)
    upper = lam_all.imag > REAL_POLE_TOL * size
    n_under = upper.sum(axis=-1)
    short = n_under < n
    if np.any(short) and overdamped == "raise":
        raise InputError(OVERDAMPED_MESSAGE)
    key = np.where(upper, size, np.inf)
    if np.any(short):
        real = np.abs(lam_all.imag) <= REAL_POLE_TOL * size
        flat_key = key.reshape(-1, 2 * n)
        flat_lam = lam_all.reshape(-1, 2 * n)
        flat_real = real.reshape(-1, 2 * n)
        for p in np.flatnonzero(short.reshape(-1)):
            idx = np.flatnonzero(flat_real[p])
            keys = _nested_pair_keys(flat_lam[p, idx].real)
            flat_key[p, idx[: keys.size]] = keys
        key = flat_key.reshape(key.shape)
    order = np.argsort(key, axis=-1, kind="stable")[..., :n]
    lam = np.take_along_axis(np.where(upper, lam_all, np.nan + 0j), order, axis=-1)
    return np.asarray(lam, dtype=np.complex128)


def pole_vectors(M: FloatArray, K: FloatArray, C: FloatArray, lam: ComplexArray) -> ComplexArray:
    """Displacement eigenvectors of known poles: null vectors of ``lambda^2 M + lambda C + K``.

    Two steps of inverse iteration from a fixed start vector, shifted
    ``1e-14 |lambda|`` off the pole (so that ``Q`` stays invertible; should it
    still be singular to rounding, the shift grows to 1e-12, then 1e-10).
    The vectors agree with LAPACK's (``numpy.linalg.eig`` of the state
    matrix) to ~1e-12 of their scale; the residues to ~1e-10 relative.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
    lam : ndarray of complex, shape (..., m)
        Poles [rad/s] of the system (``nan`` allowed: its vector is ``nan``).

    Returns
    -------
    ndarray of complex, shape (..., n, m)
        Column r: eigenvector of pole r, unit 2-norm (phase arbitrary).
    """
    bad = ~np.isfinite(lam)
    lam0 = np.where(bad, 0.0, lam)[..., :, None, None]  # (..., m, 1, 1)
    shifts = (_SHIFT, 1e-12, 1e-10)
    for i, shift in enumerate(shifts):
        # shifted off the pole: a pole exact to rounding can make LU's last pivot
        # exactly 0 (a few per thousand); the vector moves by ~100 x the shift
        s = lam0 * (1.0 + shift)
        q = (s * s) * M[..., None, :, :] + s * C[..., None, :, :] + K[..., None, :, :]
        x = np.ones((*q.shape[:-1], 1), dtype=np.complex128)
        try:
            for _ in range(2):
                x = np.linalg.solve(q, x)
                x = x / np.linalg.norm(x, axis=-2, keepdims=True)
            break
        except np.linalg.LinAlgError:
            if i == len(shifts) - 1:
                raise
    psi = np.swapaxes(x[..., 0], -1, -2)  # (..., n, m)
    return np.asarray(np.where(bad[..., None, :], np.nan + 0j, psi), dtype=np.complex128)
