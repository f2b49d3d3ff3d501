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
    which works with the exact poles). The slot keeps the mode's place in
    the rising-frequency order so that slot r stays mode r of the undamped
    problem: an overdamped pair sorts at ``sqrt(p1 p2)`` (its undamped
    frequency for a single degree of freedom). With several overdamped modes
    at one posture the real poles are paired nested (smallest with largest
    magnitude).
``"keep"``
    as ``"drop"`` for the poles, and :func:`overdamped_modes` gives each
    overdamped slot the natural frequency and damping ratio of its pair,
    ``w0 = sqrt(p1 p2)`` and ``zeta = -(p1 + p2) / (2 w0) >= 1``: the pair
    is the single-degree-of-freedom term ``1 / (w0^2 - w^2 + 2 i zeta w0 w)``
    (exact for one overdamped mode of a proportionally damped system, as the
    planner's real-mode model is for the underdamped ones). A complex pair
    gives the same two numbers (``|lambda|^2 = p1 p2``, ``-2 Re lambda =
    -(p1 + p2)``), so one formula covers both kinds of mode. With several
    overdamped modes at one posture the nested pairing is a choice, not a
    property of the system.

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
    "overdamped_modes",
    "pole_vectors",
    "state_matrix",
    "state_space_eig",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

OverdampedPolicy = Literal["raise", "drop", "keep"]
OVERDAMPED_POLICIES: tuple[str, ...] = ("raise", "drop", "keep")

REAL_POLE_TOL = 1e-9
"""A pole is real (part of an overdamped mode) when ``|Im| <= REAL_POLE_TOL |lambda|``."""

_SHIFT = 1e-14
"""Relative shift of inverse iteration off the pole (:func:`pole_vectors`)."""

OVERDAMPED_MESSAGE = (
    "damping: expected an underdamped system (complex pole pairs), found an "
    "overdamped mode (two real poles, no resonance) at posture index {where} "
    "({count} of {total} postures); a heavily damped joint can have one: use "
    "overdamped='keep' (as planning and calibration do), or check the joint "
    "damping values and their unit (N m s/rad)"
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


def _slots(
    M: FloatArray, K: FloatArray, C: FloatArray, overdamped: OverdampedPolicy
) -> tuple[ComplexArray, FloatArray]:
    """Upper-half-plane poles per slot (``nan`` where overdamped) and, per slot, the
    product and sum ``(p1 p2, p1 + p2)`` of the overdamped pair there (``nan`` elsewhere),
    shape (..., n) and (..., n, 2)."""
    if overdamped not in OVERDAMPED_POLICIES:
        raise InputError(f"overdamped: expected one of {OVERDAMPED_POLICIES}, found {overdamped!r}")
    n = M.shape[-1]
    lam_all, _ = state_space_eig(M, K, C)
    size = np.abs(lam_all)
    upper = lam_all.imag > REAL_POLE_TOL * size
    n_under = upper.sum(axis=-1)
    short = n_under < n
    if np.any(short) and overdamped == "raise":
        flat = short.reshape(-1)
        raise InputError(
            OVERDAMPED_MESSAGE.format(
                where=int(np.flatnonzero(flat)[0]), count=int(flat.sum()), total=flat.size
            )
        )
    key = np.where(upper, size, np.inf)
    pair = np.full((*lam_all.shape, 2), np.nan)
    if np.any(short):
        real = np.abs(lam_all.imag) <= REAL_POLE_TOL * size
        flat_key = key.reshape(-1, 2 * n)
        flat_lam = lam_all.reshape(-1, 2 * n)
        flat_real = real.reshape(-1, 2 * n)
        flat_pair = pair.reshape(-1, 2 * n, 2)
        for p in np.flatnonzero(short.reshape(-1)):
            idx = np.flatnonzero(flat_real[p])
            re = flat_lam[p, idx].real
            order = np.argsort(np.abs(re))
            half = idx.size // 2
            lo, hi = re[order[:half]], re[order[::-1][:half]]  # nested: smallest with largest
            slot = idx[order[:half]]
            flat_key[p, slot] = np.sqrt(lo * hi)
            flat_pair[p, slot, 0] = lo * hi
            flat_pair[p, slot, 1] = lo + hi
        key = flat_key.reshape(key.shape)
        pair = flat_pair.reshape(pair.shape)
    order = np.argsort(key, axis=-1, kind="stable")[..., :n]
    lam = np.take_along_axis(np.where(upper, lam_all, np.nan + 0j), order, axis=-1)
    pairs = np.take_along_axis(pair, order[..., None], axis=-2)
    return np.asarray(lam, dtype=np.complex128), pairs


def modal_poles(
    M: FloatArray, K: FloatArray, C: FloatArray, *, overdamped: OverdampedPolicy = "raise"
) -> ComplexArray:
    """One pole per mode: the upper-half-plane poles by rising ``|lambda|``.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
        One batch shape (postures).
    overdamped : {"raise", "drop", "keep"}
        What to do with an overdamped mode (two real poles), see the module
        notes: ``"raise"`` refuses, ``"drop"`` and ``"keep"`` leave a ``nan``
        in its slot (:func:`overdamped_modes` describes it under ``"keep"``).

    Returns
    -------
    ndarray of complex, shape (..., n)
        ``lambda_r`` [rad/s] with ``Im > 0``; ``nan`` for overdamped modes.

    Raises
    ------
    InputError
        On an overdamped mode under ``"raise"``, or an unknown policy.
    """
    return _slots(M, K, C, overdamped)[0]


def overdamped_modes(
    M: FloatArray, K: FloatArray, C: FloatArray
) -> tuple[ComplexArray, FloatArray, FloatArray]:
    """The poles of :func:`modal_poles` and every mode's natural frequency and damping.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
        One batch shape (postures).

    Returns
    -------
    lam : ndarray of complex, shape (..., n)
        As :func:`modal_poles` with ``overdamped="keep"`` (``nan`` where overdamped).
    w0 : ndarray, shape (..., n)
        Natural frequency [rad/s]: ``|lambda|`` of an underdamped mode,
        ``sqrt(p1 p2)`` of an overdamped pair.
    zeta : ndarray, shape (..., n)
        Damping ratio: ``-Re(lambda) / |lambda|`` (< 1), or
        ``-(p1 + p2) / (2 w0)`` (>= 1) of an overdamped pair.
    """
    lam, pair = _slots(M, K, C, "keep")
    od = ~np.isfinite(lam)
    w_pair = np.sqrt(pair[..., 0])
    w0 = np.where(od, w_pair, np.abs(lam))
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(od, -pair[..., 1] / (2.0 * w_pair), -lam.real / np.abs(lam))
    return lam, np.asarray(w0, np.float64), np.asarray(zeta, np.float64)


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
