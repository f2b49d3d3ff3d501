"""The twin as the diagnosis sees it: receptance of records under candidate effects.

:class:`TwinModel` is the model function of the fits
(``model(effects, obs) -> H``). It differs from
:meth:`robolobe.twin.model.Twin.receptance` in two ways, both needed to
compare a model with recorded FRFs:

- **Exponential window.** Hammer-test FRFs are usually estimated with an
  exponential window ``w(t) = exp(-a t)`` on force and response (REFERENCES.md
  section 4). The windowed FRF of a linear structure is its transfer function
  evaluated at ``s = a + i w`` instead of ``i w`` (every pole moves left by
  ``a``): without this the window's damping would be mistaken for missing
  physics. With ``s = a + i w``::

      K + s^2 M + s C = (K + a^2 M + a C) - w^2 M + i w (C + 2 a M)

  so the twin's receptance solver is used unchanged with modified K and C.
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
from robolobe.twin.frf import receptance
from robolobe.twin.model import Twin

__all__ = ["TwinModel", "windowed_receptance"]

ComplexArray = NDArray[np.complex128]


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
        (0: no window, identical to ``twin.receptance``).

    Returns
    -------
    ndarray of complex, shape (..., n_freq, 3, 3)
        ``H(a + i w) (1 - i a / w)^2`` with the measurement effects applied
        (see the module notes).
    """
    if decay_per_s < 0 or not np.isfinite(decay_per_s):
        raise InputError(f"window decay: expected a rate >= 0 1/s, found {decay_per_s!r}")
    if decay_per_s == 0.0:
        return np.asarray(twin.receptance(q_rad, freq_hz))
    s = twin.system(q_rad)
    a = float(decay_per_s)
    M = s.M
    k = s.K + a * a * M + a * s.C
    c = s.C + 2.0 * a * M
    f = np.asarray(freq_hz, dtype=float)
    h = receptance(M, k, c, s.J, f)
    with np.errstate(divide="ignore", invalid="ignore"):
        acc = (1.0 - 1j * a / (2.0 * np.pi * f)) ** 2  # accelerance -> receptance by -w^2
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
