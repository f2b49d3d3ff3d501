"""Modes of the flexible-joint model: poles, damping, shapes, modal stiffness.

The linear model is ``M x'' + C x' + K x = J^T f``, response ``y = J x``
(docs/guide/robots.md: x the joint deflections, J the translational TCP
Jacobian in the TCP frame, y the TCP displacement). Two eigenproblems are
solved, both batched over postures:

* **Damped (state space).** The 2n eigenvalues of
  ``[[0, I], [-M^-1 K, -M^-1 C]]`` come in conjugate pairs
  ``lambda_r = -zeta_r w_r + i w_d,r``. They give the natural frequency
  ``w_r = |lambda_r|``, the damping ratio ``zeta_r = -Re(lambda_r)/|lambda_r|``
  and the damped frequency ``w_d,r = Im(lambda_r)``, exactly, also for
  non-proportional damping (viscous joint damping is not proportional). With
  the complex shapes ``psi_r`` normalised by ``a_r = psi_r^T (2 lambda_r M + C)
  psi_r`` the TCP residues are ``R_r = (J psi_r)(J psi_r)^T / a_r`` and the
  receptance is exactly ``H(w) = sum_r R_r/(i w - lambda_r) + conj(R_r)/(i w -
  conj(lambda_r))`` (:meth:`Modes.frf`). The poles come from the project's one
  state-space eigen-solve (:mod:`robolobe.twin._poles`), with its explicit
  policy for an overdamped mode (``overdamped="raise"`` refuses, ``"drop"``
  leaves ``nan`` in the mode's damped quantities, ``"keep"`` gives it the
  natural frequency ``sqrt(p1 p2)`` and damping ratio ``>= 1`` of its two real
  poles, for the real-mode (modal-stiffness) FRF a planner uses); the residues
  are computed on first use.

* **Undamped.** ``K phi = w0^2 M phi`` gives real, mass-normalised shapes
  (``phi^T M phi = I``) and the modal stiffness per TCP direction
  ``k_r,d = w0_r^2 / u_d,r^2`` with ``u = J phi`` (docs/guide/physics.md). This is the
  driving-point modal stiffness of the modal form
  ``H_dd ~ sum_r (w_r^2/k_r) / (w_r^2 - w^2 + 2 i zeta_r w_r w)``; it is exact
  for proportional damping and within O(zeta^2) otherwise.
  :meth:`Modes.k_from_residues` gives the alternative that an identification
  from measured FRFs would return (``k = w^2 / (2 i w_d R_dd)``, real part).

Mode r of both problems is the r-th by rising frequency: the damped modes
sorted by ``|lambda|``, the undamped ones by ``w0``. For the light damping of
robots (zeta of a few per cent) the two orders agree; only at exact
frequency crossings could the pairing swap two nearly equal modes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import DRIVING, dir_index
from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError
from robolobe.twin._poles import (
    OverdampedPolicy,
    modal_poles,
    overdamped_modes,
    pole_vectors,
    state_space_eig,
)

__all__ = [
    "SEEN_RATIO",
    "Modes",
    "OverdampedPolicy",
    "compute_modes",
    "damped_poles",
    "lowest_seen",
    "seen_mask",
    "state_space_eig",
    "undamped_modes",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TWO_PI = 2.0 * np.pi

SEEN_RATIO = 50.0
"""Default of :func:`seen_mask`: a mode is seen at the TCP if, in some direction,
its modal stiffness is at most this many times the smallest one there."""


def _system_arrays(
    M: ArrayLike, K: ArrayLike, C: ArrayLike, J: ArrayLike
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Validate shapes and broadcast (M, K, C, J) to one batch shape."""
    m = np.asarray(M, dtype=np.float64)
    k = np.asarray(K, dtype=np.float64)
    c = np.asarray(C, dtype=np.float64)
    j = np.asarray(J, dtype=np.float64)
    if m.ndim < 2 or m.shape[-1] != m.shape[-2]:
        raise InputError(f"M: expected shape (..., n, n), found {m.shape}")
    n = m.shape[-1]
    for name, arr in (("K", k), ("C", c)):
        if arr.ndim < 2 or arr.shape[-2:] != (n, n):
            raise InputError(f"{name}: expected shape (..., {n}, {n}), found {arr.shape}")
    if j.ndim < 2 or j.shape[-1] != n:
        raise InputError(f"J: expected shape (..., p, {n}), found {j.shape}")
    for name, arr in (("M", m), ("K", k), ("C", c), ("J", j)):
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name}: expected finite numbers, found inf or nan")
    try:
        batch = np.broadcast_shapes(m.shape[:-2], k.shape[:-2], c.shape[:-2], j.shape[:-2])
    except ValueError as exc:
        raise InputError(
            f"M, K, C, J: batch shapes {m.shape[:-2]}, {k.shape[:-2]}, {c.shape[:-2]}, "
            f"{j.shape[:-2]} do not broadcast"
        ) from exc
    return (
        np.broadcast_to(m, (*batch, n, n)),
        np.broadcast_to(k, (*batch, n, n)),
        np.broadcast_to(c, (*batch, n, n)),
        np.broadcast_to(j, (*batch, j.shape[-2], n)),
    )


def _symmetric(name: str, a: FloatArray) -> None:
    scale = np.max(np.abs(a), axis=(-2, -1), keepdims=True)
    asym = np.abs(a - np.swapaxes(a, -1, -2))
    if np.any(asym > 1e-9 * scale + 1e-300):
        raise InputError(f"{name}: expected a symmetric matrix, found an asymmetric one")


def _fix_sign(phi: FloatArray, u: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Make the largest TCP component of each mode shape positive."""
    idx = np.argmax(np.abs(u), axis=-2)  # (..., n_modes)
    lead = np.take_along_axis(u, idx[..., None, :], axis=-2)[..., 0, :]
    sign = np.where(lead < 0, -1.0, 1.0)
    return phi * sign[..., None, :], u * sign[..., None, :]


def undamped_modes(M: ArrayLike, K: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Undamped natural frequencies and mass-normalised shapes.

    Parameters
    ----------
    M, K : array_like, shape (..., n, n)
        Symmetric positive definite mass [kg m^2] and stiffness [N m/rad]
        matrices (any consistent units).

    Returns
    -------
    omega : ndarray, shape (..., n)
        Natural frequencies [rad/s], rising.
    phi : ndarray, shape (..., n, n)
        Column r is mode r, normalised so that ``phi^T M phi = I``.

    Raises
    ------
    InputError
        If M is not positive definite or K not positive definite.
    """
    m = np.asarray(M, dtype=np.float64)
    k = np.asarray(K, dtype=np.float64)
    _symmetric("M", m)
    _symmetric("K", k)
    try:
        low = np.linalg.cholesky(m)
    except np.linalg.LinAlgError as exc:
        raise InputError(
            "M: expected a positive definite mass matrix, found one that is not"
        ) from exc
    low_inv = np.linalg.inv(low)
    a = low_inv @ k @ np.swapaxes(low_inv, -1, -2)
    a = 0.5 * (a + np.swapaxes(a, -1, -2))
    w2, v = np.linalg.eigh(a)
    if np.any(w2 <= 0.0):
        raise InputError(
            "K: expected a positive definite stiffness matrix (no rigid-body modes), "
            f"found an eigenvalue {float(np.min(w2)):.3g}"
        )
    phi = np.swapaxes(low_inv, -1, -2) @ v
    return np.sqrt(w2), phi


def seen_mask(k_N_per_m: ArrayLike, max_ratio: float = SEEN_RATIO) -> NDArray[np.bool_]:
    """Which modes are seen at the TCP.

    A mode is seen if in at least one TCP direction d its modal stiffness
    ``k_r,d`` is at most ``max_ratio`` times the smallest ``k_s,d`` of all modes
    in that direction: for similar damping its resonance peak
    ``1 / (2 zeta k)`` then reaches ``1/max_ratio`` of the strongest one. A
    mode whose shape does not move the TCP (e.g. joint 6 spinning a tool on its
    axis, or joint 4 at a stretched wrist, q5 = 0) is not seen.

    Parameters
    ----------
    k_N_per_m : array_like, shape (..., p, n)
        Modal stiffness per direction and mode [N/m].
    max_ratio : float
        > 1.

    Returns
    -------
    ndarray of bool, shape (..., n)
    """
    k = np.asarray(k_N_per_m, dtype=np.float64)
    if not max_ratio > 1.0:
        raise InputError(f"max_ratio: expected a number > 1, found {max_ratio!r}")
    kmin = np.min(k, axis=-1, keepdims=True)
    return np.asarray(np.any(k <= max_ratio * kmin, axis=-2))


def lowest_seen(seen: ArrayLike, n: int) -> tuple[NDArray[np.intp], NDArray[np.bool_]]:
    """Indices of the ``n`` lowest seen modes (modes sorted by rising frequency).

    Parameters
    ----------
    seen : array_like of bool, shape (..., n_modes)
        From :func:`seen_mask`.
    n : int
        How many.

    Returns
    -------
    index : ndarray of int, shape (..., n)
        Mode indices (0-based), rising; padded with unseen indices where fewer
        than ``n`` modes are seen.
    valid : ndarray of bool, shape (..., n)
        False for the padding.
    """
    sm = np.asarray(seen, dtype=bool)
    if not 1 <= n <= sm.shape[-1]:
        raise InputError(f"n: expected 1..{sm.shape[-1]}, found {n}")
    idx = np.argsort(~sm, axis=-1, kind="stable")[..., :n]
    return idx, np.take_along_axis(sm, idx, axis=-1)


@dataclass(frozen=True, eq=False)
class Modes:
    """Modal parameters of the model at one or more postures.

    ``...`` is the batch (posture) shape, ``n`` the number of modes (= DOFs),
    ``p`` the number of TCP directions (3: x, y, z of the TCP frame).

    Attributes
    ----------
    f_hz : ndarray, shape (..., n)
        Natural frequencies ``|lambda_r| / 2 pi`` [Hz], rising.
    zeta : ndarray, shape (..., n)
        Damping ratios (fraction), ``-Re(lambda_r) / |lambda_r|``.
    omega_d : ndarray, shape (..., n)
        Damped natural frequencies ``Im(lambda_r)`` [rad/s].
    poles : ndarray, shape (..., n), complex
        ``lambda_r`` [rad/s], upper half plane.
    residues : ndarray, shape (..., n, p, p), complex
        TCP receptance residues [m/(N s)] of the poles (see :meth:`frf`);
        computed on first use (the eigenvectors are only paid for then).
    f_undamped_hz : ndarray, shape (..., n)
        Natural frequencies of the undamped problem [Hz].
    shapes : ndarray, shape (..., n_dof, n)
        Real, mass-normalised undamped shapes ``phi`` [1/sqrt(kg m^2) for
        joint DOFs].
    tcp_shapes : ndarray, shape (..., p, n)
        ``u = J phi`` [m/sqrt(kg)]; the sign makes the largest entry positive.
    k_N_per_m : ndarray, shape (..., p, n)
        Modal stiffness per TCP direction ``w0_r^2 / u_d,r^2`` [N/m]; ``inf``
        where the mode does not move the TCP in that direction.

    Notes
    -----
    With ``compute_modes(..., overdamped="drop")`` an overdamped mode keeps
    its slot with ``nan`` in the damped quantities (``f_hz``, ``zeta``,
    ``omega_d``, ``poles``, ``residues``); its undamped quantities are
    finite. With ``"keep"`` its ``f_hz`` and ``zeta`` (>= 1) are those of its
    two real poles (:func:`robolobe.twin._poles.overdamped_modes`),
    ``omega_d`` is 0 and ``poles`` and ``residues`` stay ``nan``. :meth:`frf`
    (the exact pole-residue sum) refuses both; the real-mode receptance of
    the shapes, frequencies and dampings (what :meth:`parameters` and a
    planner use) covers them.
    """

    f_hz: FloatArray
    zeta: FloatArray
    omega_d: FloatArray
    poles: ComplexArray
    f_undamped_hz: FloatArray
    shapes: FloatArray
    tcp_shapes: FloatArray
    k_N_per_m: FloatArray
    #: (M, K, C, J) the residues are computed from on first use
    _system: tuple[FloatArray, FloatArray, FloatArray, FloatArray] = field(repr=False)

    @cached_property
    def residues(self) -> ComplexArray:
        """TCP receptance residues [m/(N s)], shape (..., n, p, p), complex.

        ``R_r = (J psi_r)(J psi_r)^T / a_r`` with ``a_r = psi_r^T (2 lambda_r M
        + C) psi_r`` (plain transpose); ``nan`` for dropped overdamped modes.
        """
        m, k, c, j = self._system
        lam = self.poles
        psi = pole_vectors(m, k, c, lam)
        a = 2.0 * lam * np.einsum("...ir,...ij,...jr->...r", psi, m, psi) + np.einsum(
            "...ir,...ij,...jr->...r", psi, c, psi
        )
        uc = j @ psi  # (..., p, n)
        with np.errstate(invalid="ignore"):  # nan for dropped overdamped modes
            out: ComplexArray = np.einsum("...ir,...jr->...rij", uc, uc) / a[..., :, None, None]
        return out

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.f_hz.shape[-1])

    @property
    def omega(self) -> FloatArray:
        """Natural frequencies ``|lambda_r|`` [rad/s], shape (..., n)."""
        return _TWO_PI * self.f_hz

    def frf(self, freq_hz: ArrayLike) -> ComplexArray:
        """Receptance synthesised from the poles and residues (exact).

        Parameters
        ----------
        freq_hz : array_like, shape (n_freq,)
            Frequencies [Hz].

        Returns
        -------
        ndarray, shape (..., n_freq, p, p), complex
            ``sum_r R_r/(i w - lambda_r) + conj(R_r)/(i w - conj(lambda_r))`` [m/N].
        """
        if not np.all(np.isfinite(self.poles)):
            raise InputError(
                "modes: expected underdamped modes only to synthesise the FRF, found "
                "overdamped modes left out (overdamped='drop'); use the twin's "
                "receptance (method 'solve') instead"
            )
        iw = 1j * _TWO_PI * np.asarray(freq_hz, dtype=np.float64)
        lam = self.poles[..., None, :]  # (..., 1, n)
        g1 = 1.0 / (iw[:, None] - lam)  # (..., n_freq, n)
        g2 = 1.0 / (iw[:, None] - np.conj(lam))
        res = self.residues
        out: ComplexArray = np.einsum("...fr,...rij->...fij", g1, res) + np.einsum(
            "...fr,...rij->...fij", g2, np.conj(res)
        )
        return out

    def parameters(self, directions: Sequence[str] = DRIVING) -> ModalParameters:
        """The modes as :class:`~robolobe._modal_parameters.ModalParameters`.

        Each mode's frequency and damping repeat in every direction (one set
        of coupled modes); the stiffness is :attr:`k_N_per_m` of the TCP axis
        the driving point names (``"xx"``: x). The batch shape is flattened
        to the posture axis (a single posture: one).

        Parameters
        ----------
        directions : sequence of str, default ("xx", "yy", "zz")
            Driving points of :mod:`robolobe._directions`.

        Returns
        -------
        ModalParameters
            Shape (n_postures, n_directions, n_modes), no spread; a dropped
            overdamped mode (``overdamped="drop"``) is absent (NaN), a kept one
            (``"keep"``) has its damping ratio >= 1.

        Raises
        ------
        InputError
            A cross direction (``"xy"``: the modal stiffness is given per
            driving point only), or a TCP axis the modes were not computed
            for.
        """
        dirs = tuple(directions)
        axes = []
        for d in dirs:
            i, j = dir_index(d)
            if i != j:
                raise InputError(
                    f"directions: expected driving points such as 'xx' (the twin's modal "
                    f"stiffness is per TCP axis), found {d!r}"
                )
            if i >= self.k_N_per_m.shape[-2]:
                raise InputError(
                    f"directions: {d!r} needs TCP axis {i}, the modes have "
                    f"{self.k_N_per_m.shape[-2]} axes"
                )
            axes.append(i)
        n = self.n_modes
        f = np.reshape(self.f_hz, (-1, 1, n))
        z = np.reshape(self.zeta, (-1, 1, n))
        k = np.reshape(self.k_N_per_m, (-1, self.k_N_per_m.shape[-2], n))[:, axes]
        shape = (f.shape[0], len(dirs), n)
        return ModalParameters(np.broadcast_to(f, shape), np.broadcast_to(z, shape), k, dirs)

    def k_from_residues(self) -> FloatArray:
        """Driving-point modal stiffness from the complex residues [N/m].

        ``k_r,d = Re(w_r^2 / (2 i w_d,r R_r,dd))`` (docs/references.md: modal identification):
        what a pole-residue identification of the driving-point FRF returns.

        Returns
        -------
        ndarray, shape (..., p, n)
        """
        rdd = np.diagonal(self.residues, axis1=-2, axis2=-1)  # (..., n, p)
        w2 = (self.omega**2)[..., :, None]
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.real(w2 / (2j * self.omega_d[..., :, None] * rdd))
        k = np.where(np.abs(rdd) > 0, k, np.inf)
        return np.swapaxes(k, -1, -2)

    def dominant_direction(self) -> NDArray[np.intp]:
        """Index (0 = x, 1 = y, 2 = z) of the TCP direction each mode moves most.

        Returns
        -------
        ndarray of int, shape (..., n)
        """
        return np.argmax(np.abs(self.tcp_shapes), axis=-2)

    def seen(self, max_ratio: float = SEEN_RATIO) -> NDArray[np.bool_]:
        """Which modes are seen at the TCP (:func:`seen_mask`), shape (..., n)."""
        return seen_mask(self.k_N_per_m, max_ratio)

    def k_dominant_N_per_m(self) -> FloatArray:
        """Modal stiffness in each mode's dominant TCP direction [N/m], shape (..., n)."""
        return np.min(self.k_N_per_m, axis=-2)


def damped_poles(
    M: FloatArray,
    K: FloatArray,
    C: FloatArray,
    *,
    vectors: bool = False,
    overdamped: OverdampedPolicy = "raise",
) -> tuple[ComplexArray, ComplexArray | None]:
    """Upper-half-plane poles of ``(M, C, K)`` by rising ``|lambda|``.

    The state-space eigen-solve of :mod:`robolobe.twin._poles`
    (:func:`~robolobe.twin._poles.modal_poles`), batched over postures.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
    vectors : bool
        Also return the displacement eigenvectors (shape (..., n, n), column r
        for pole r, unit 2-norm, phase arbitrary); without them only the
        eigenvalues are computed (faster).
    overdamped : {"raise", "drop", "keep"}
        Policy for an overdamped mode (real poles): refuse, or leave ``nan``
        in its slot (and in its vector); "keep" is "drop" here (poles only).

    Returns
    -------
    lam : ndarray of complex, shape (..., n)
        Poles [rad/s].
    psi : ndarray of complex, shape (..., n, n) or None

    Raises
    ------
    InputError
        On an overdamped mode (real poles) under ``overdamped="raise"``.
    """
    lam = modal_poles(M, K, C, overdamped=overdamped)
    if not vectors:
        return lam, None
    return lam, pole_vectors(M, K, C, lam)


def compute_modes(
    M: ArrayLike,
    K: ArrayLike,
    C: ArrayLike,
    J: ArrayLike,
    *,
    overdamped: OverdampedPolicy = "raise",
) -> Modes:
    """Damped and undamped modes of ``(M, C, K)`` seen through ``J``.

    Parameters
    ----------
    M : array_like, shape (..., n, n)
        Mass matrix [kg m^2 for joint DOFs], symmetric positive definite.
    K : array_like, shape (..., n, n)
        Stiffness matrix [N m/rad], symmetric positive definite.
    C : array_like, shape (..., n, n)
        Viscous damping matrix [N m s/rad], symmetric.
    J : array_like, shape (..., p, n)
        Output (and input) Jacobian, typically the translational TCP
        Jacobian in the TCP frame [m/rad].
    overdamped : {"raise", "drop", "keep"}
        Policy for an overdamped mode (real poles, no resonance):
        ``"raise"`` (default) refuses; ``"drop"`` keeps the mode's slot
        with ``nan`` damped quantities; ``"keep"`` gives it the frequency and
        damping ratio (>= 1) of its real poles (see :class:`Modes`).

    Returns
    -------
    Modes
        Batch shape: the broadcast of the inputs' leading dimensions.

    Raises
    ------
    InputError
        On wrong shapes, non-finite entries, a mass or stiffness matrix that is
        not positive definite, or an overdamped mode (real poles) under
        ``overdamped="raise"``.
    """
    m, k, c, j = _system_arrays(M, K, C, J)
    _symmetric("C", c)

    # -- undamped problem: real mass-normalised shapes, modal stiffness
    w0, phi = undamped_modes(m, k)
    u = j @ phi  # (..., p, n)
    phi, u = _fix_sign(phi, u)
    with np.errstate(divide="ignore"):
        k_modal = (w0**2)[..., None, :] / u**2

    # -- damped problem: first-order (state-space) eigenvalues; the residues
    #    (eigenvectors) on first use
    if overdamped == "keep":
        lam, w, zeta = overdamped_modes(m, k, c)
        omega_d = np.where(np.isfinite(lam), lam.imag, 0.0)
    else:
        lam = modal_poles(m, k, c, overdamped=overdamped)
        w = np.abs(lam)
        zeta = -lam.real / w
        omega_d = lam.imag.copy()
    return Modes(
        f_hz=w / _TWO_PI,
        zeta=zeta,
        omega_d=omega_d,
        poles=lam,
        f_undamped_hz=w0 / _TWO_PI,
        shapes=phi,
        tcp_shapes=u,
        k_N_per_m=k_modal,
        _system=(m, k, c, j),
    )
