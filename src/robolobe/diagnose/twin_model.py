"""The twin as the diagnosis sees it: receptance of records under candidate effects.

:class:`TwinModel` is the model function of the fits
(``model(effects, obs) -> H``). It differs from
:meth:`robolobe.twin.model.Twin.receptance` in two ways, both needed to
compare a model with recorded FRFs:

- **Exponential window.** Hammer-test FRFs are usually estimated with an
  exponential window ``w(t) = exp(-a t)`` on force and response (docs/references.md
  section 4). The windowed FRF of a linear structure is its transfer function
  evaluated at ``s = a + i w`` instead of ``i w`` (every pole moves left by
  ``a``): without this the window's damping would be mistaken for missing
  physics. The transfer function is evaluated by modal superposition over
  the poles of the twin's assembled matrices
  (:func:`pole_residue_receptance`), which takes any complex ``s``.
  The recorded receptance is the windowed *accelerance* divided by
  ``-w^2`` (an accelerometer test), so it carries the factor
  ``((a + i w) / (i w))^2 = (1 - i a / w)^2`` as well: a phase lead of about
  ``2 a / w`` (0.24/f rad for a 4 s record windowed to 5 %), large at low
  frequency. Measurement effects (rotation, delay) are applied to the
  result as in the twin (a delay's extra gain ``exp(-a tau)`` differs from 1
  by less than 0.1 % for realistic ``a`` and ``tau`` and is left out).
- **Force levels.** :class:`~robolobe.twin.effects.FrictionDamping` depends
  on the hammer's force; records at different force levels are evaluated
  with their own level (``obs.force_N``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe.diagnose.observations import Observations
from robolobe.errors import InputError
from robolobe.robots import Robot
from robolobe.twin.effects import Effect, FrictionDamping
from robolobe.twin.model import Twin
from robolobe.twin.modes import damped_poles, state_space_eig

__all__ = [
    "TwinModel",
    "pole_residue_receptance",
    "state_space_poles",
    "twin_modes",
    "windowed_receptance",
]

ComplexArray = NDArray[np.complex128]


def state_space_poles(
    M: NDArray[np.float64],
    K: NDArray[np.float64],
    C: NDArray[np.float64],
    J: NDArray[np.float64],
) -> tuple[ComplexArray, ComplexArray, ComplexArray]:
    """All 2n poles of ``M x'' + C x' + K x = 0`` with their TCP shapes.

    The twin's one state-space eigen-solve (:mod:`robolobe.twin._poles`),
    every pole kept (complex pairs and real ones: the receptance is exact
    also for an overdamped mode).

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
    J : ndarray, shape (..., p, n)

    Returns
    -------
    lam : ndarray of complex, shape (..., 2n)
        Poles [rad/s] (complex pairs and, if any, overdamped real poles).
    u : ndarray of complex, shape (..., p, 2n)
        ``J phi_r``.
    a : ndarray of complex, shape (..., 2n)
        Modal normalisation ``2 lambda_r phi_r^T M phi_r + phi_r^T C phi_r``.
    """
    lam, phi = state_space_eig(M, K, C, vectors=True)
    assert phi is not None
    a = 2 * lam * np.sum(phi * (M @ phi), axis=-2) + np.sum(phi * (C @ phi), axis=-2)
    return lam, J @ phi, a


def pole_residue_receptance(
    M: NDArray[np.float64],
    K: NDArray[np.float64],
    C: NDArray[np.float64],
    J: NDArray[np.float64],
    s: NDArray[np.complex128],
) -> ComplexArray:
    """``J (K + s C + s^2 M)^-1 J^T`` by modal superposition over all 2n poles.

    State-space eigenproblem of ``M x'' + C x' + K x = 0`` (one small
    ``eig`` per posture, :func:`state_space_poles`), then

        H(s) = sum_r (J phi_r)(J phi_r)^T / (a_r (s - lambda_r)),
        a_r = 2 lambda_r phi_r^T M phi_r + phi_r^T C phi_r

    over all 2n eigenvalues (complex pairs and, if any, overdamped real
    poles): exact for symmetric M, C, K with distinct poles, and several times
    faster than a linear solve per frequency line.

    Parameters
    ----------
    M, K, C : ndarray, shape (..., n, n)
    J : ndarray, shape (..., p, n)
    s : ndarray of complex, shape (n_freq,)
        Laplace variable at each line [rad/s].

    Returns
    -------
    ndarray of complex, shape (..., n_freq, p, p)
    """
    lam, u, a = state_space_poles(M, K, C, J)
    g = 1.0 / (a[..., None, :] * (s[:, None] - lam[..., None, :]))  # (..., n_freq, 2n)
    out: ComplexArray = np.einsum("...fr,...ir,...jr->...fij", g, u, u, optimize=True)
    return out


def twin_modes(
    twin: Twin, q_rad: NDArray[np.float64]
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Underdamped modes of ``twin`` at postures ``q`` (overdamped modes left out).

    The twin's poles with the ``overdamped="drop"`` policy
    (:func:`robolobe.twin.modes.damped_poles`).

    Parameters
    ----------
    twin : Twin
    q_rad : ndarray, shape (n, 6)

    Returns
    -------
    f_hz : ndarray, shape (n, m)
        Natural frequencies ``|lambda| / 2 pi`` [Hz], rising; NaN-padded
        where a posture has fewer underdamped modes.
    zeta : ndarray, shape (n, m)
        Damping ratios ``-Re(lambda) / |lambda|``.
    shape : ndarray, shape (n, m, 3)
        Magnitude of the TCP shape ``|J phi|`` (scaled to unit norm).
    """
    sm = twin.system(q_rad)
    lam, psi = damped_poles(sm.M, sm.K, sm.C, vectors=True, overdamped="drop")
    assert psi is not None
    # dropped (nan) slots last, the rest rising
    order = np.argsort(np.where(np.isfinite(lam), np.abs(lam), np.inf), axis=-1, kind="stable")
    lam = np.take_along_axis(lam, order, axis=-1)
    u = np.take_along_axis(sm.J @ psi, order[:, None, :], axis=-1)
    m = int(np.isfinite(lam).sum(axis=-1).max(initial=0))
    w = np.abs(lam[:, :m])
    f = w / (2 * np.pi)
    z = -lam[:, :m].real / w
    v = np.abs(np.swapaxes(u[..., :m], -1, -2))  # (n, m, 3)
    sh = v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-300)
    return f, z, sh


def windowed_receptance(
    twin: Twin, q_rad: NDArray[np.float64], freq_hz: NDArray[np.float64], decay_per_s: float = 0.0
) -> ComplexArray:
    """Measured receptance of ``twin`` as an exponentially windowed test sees it.

    Parameters
    ----------
    twin : Twin
    q_rad : ndarray, shape (..., 6)
        Postures [rad].
    freq_hz : ndarray, shape (n_freq,)
        Frequencies [Hz].
    decay_per_s : float
        Decay rate of the exponential window ``a = -ln(window_end) / T`` [1/s]
        (0: no window; then equal to ``twin.receptance``).

    Returns
    -------
    ndarray of complex, shape (..., n_freq, 3, 3)
        ``H(a + i w) (1 - i a / w)^2`` with the measurement effects applied
        (see the module notes).
    """
    if decay_per_s < 0 or not np.isfinite(decay_per_s):
        raise InputError(f"window decay: expected a rate >= 0 1/s, found {decay_per_s!r}")
    sm = twin.system(q_rad)
    a = float(decay_per_s)
    f = np.asarray(freq_hz, dtype=float)
    w = 2.0 * np.pi * f
    h = pole_residue_receptance(sm.M, sm.K, sm.C, sm.J, np.asarray(a + 1j * w, dtype=complex))
    if a > 0:
        with np.errstate(divide="ignore", invalid="ignore"):
            acc = (1.0 - 1j * a / w) ** 2  # accelerance -> receptance by -w^2
        h = h * np.where(f > 0, acc, 1.0)[:, None, None]
    for e in sorted(twin.effects, key=lambda e: e.stage):
        h = e.modify_frf(h, f)
    return np.asarray(h)


class TwinModel:
    """Model function of the diagnosis: the nominal robot plus candidate effects.

    Parameters
    ----------
    robot : Robot
        The nominal robot.
    window_decay_per_s : float
        Exponential-window decay of the recordings [1/s] (0: none).

    Notes
    -----
    Calling the instance with ``(effects, obs)`` returns the receptance of
    ``obs``'s records, shape (obs.n, n_freq, 3, 3). The nominal prediction
    (no effects) is cached per :class:`Observations` object.
    """

    def __init__(self, robot: Robot, *, window_decay_per_s: float = 0.0) -> None:
        self.robot = robot
        self.window_decay_per_s = float(window_decay_per_s)
        self._nominal_cache: dict[int, tuple[Observations, ComplexArray]] = {}

    def __getstate__(self) -> dict[str, Any]:
        # a worker process gets the model without the cached nominal predictions (they
        # hold whole campaigns; the worker computes its own when it needs them)
        state = dict(self.__dict__)
        state["_nominal_cache"] = {}
        return state

    def twin(self, effects: tuple[Any, ...] = ()) -> Twin:
        """The twin with ``effects``."""
        return Twin(self.robot, tuple(effects))

    def __call__(self, effects: tuple[Any, ...], obs: Observations) -> ComplexArray:
        effects = tuple(effects)
        for e in effects:
            if not isinstance(e, Effect):
                raise InputError(f"effects: expected twin effects, found {e!r}")
        if not effects:
            hit = self._nominal_cache.get(id(obs))
            if hit is not None and hit[0] is obs:
                return hit[1]
        friction = [e for e in effects if isinstance(e, FrictionDamping)]
        if friction and obs.force_N is not None:
            out = np.empty(obs.H.shape, dtype=complex)
            for level in np.unique(obs.force_N):
                idx = np.flatnonzero(obs.force_N == level)
                eff = tuple(
                    dataclasses.replace(e, force_N=float(level))
                    if isinstance(e, FrictionDamping)
                    else e
                    for e in effects
                )
                out[idx] = windowed_receptance(
                    self.twin(eff), obs.q_rad[idx], obs.freq_hz, self.window_decay_per_s
                )
        else:
            out = windowed_receptance(
                self.twin(effects), obs.q_rad, obs.freq_hz, self.window_decay_per_s
            )
        if not effects:
            if len(self._nominal_cache) > 8:
                self._nominal_cache.clear()
            self._nominal_cache[id(obs)] = (obs, out)
        return out
