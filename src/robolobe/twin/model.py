"""The digital twin: a robot plus optional physics effects.

``Twin(robot)`` is the nominal model of docs/guide/robots.md;
``Twin(robot, effects)`` adds effects from :mod:`robolobe.twin.effects`,
applied by stage: robot-level changes, joint stiffness/damping terms, extra
structural DOFs, a tool attachment at the TCP, then measurement effects on
the output FRF.

Usage::

    from robolobe.robots import load_robot
    from robolobe.twin.model import Twin
    from robolobe.twin.effects import AddedMass

    twin = Twin(load_robot("B")).with_effects(AddedMass(mass_kg=2.0))
    modes = twin.modes(q)                    # q (..., 6) rad
    H = twin.receptance(q, freq_hz)          # (..., n_freq, 3, 3) m/N
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.robots import Robot
from robolobe.twin._poles import OverdampedPolicy
from robolobe.twin.effects import Effect
from robolobe.twin.frf import _freq, receptance
from robolobe.twin.modes import Modes, compute_modes
from robolobe.twin.system import SystemMatrices, nominal_system

__all__ = ["Twin"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]


@dataclass(frozen=True, eq=False)
class Twin:
    """Flexible-joint model of a robot with optional effects.

    Parameters
    ----------
    robot : Robot
        The nominal robot.
    effects : tuple of Effect
        Effects to add (order only matters for the order of extra DOFs).
    """

    robot: Robot
    effects: tuple[Effect, ...] = field(default=())

    def __post_init__(self) -> None:
        if not isinstance(self.robot, Robot):
            raise InputError(f"robot: expected a robolobe.robots.Robot, found {type(self.robot)}")
        effects = tuple(self.effects)
        for e in effects:
            if not isinstance(e, Effect):
                raise InputError(f"effects: expected robolobe.twin.effects effects, found {e!r}")
        object.__setattr__(self, "effects", effects)

    # ------------------------------------------------------------ building
    @cached_property
    def _ordered(self) -> tuple[Effect, ...]:
        return tuple(sorted(self.effects, key=lambda e: e.stage))

    @cached_property
    def effective_robot(self) -> Robot:
        """The robot after robot-level effects (added mass, joint factors)."""
        robot = self.robot
        for e in self._ordered:
            robot = e.apply_robot(robot)
        return robot

    def with_effects(self, *effects: Effect) -> Twin:
        """A copy with ``effects`` appended."""
        return Twin(self.robot, (*self.effects, *effects))

    def system(self, q: ArrayLike) -> SystemMatrices:
        """Assembled matrices at postures ``q``.

        Parameters
        ----------
        q : array_like, shape (..., 6)
            Controller axis angles [rad].

        Returns
        -------
        SystemMatrices
            ``M``, ``K``, ``C`` of shape (..., n, n) and ``J`` (..., 3, n),
            n = 6 plus the DOFs the effects add.
        """
        mats = nominal_system(self.effective_robot, q)
        for e in self._ordered:
            mats = e.modify(mats)
        return mats

    # ------------------------------------------------------------- results
    def mass_matrix(self, q: ArrayLike) -> FloatArray:
        """Mass matrix, shape (..., n, n) (joint DOFs first) [kg m^2 for joints]."""
        return self.system(q).M

    def modes(self, q: ArrayLike, *, overdamped: OverdampedPolicy = "raise") -> Modes:
        """Modes at postures ``q`` (:func:`robolobe.twin.modes.compute_modes`).

        Measurement effects do not act on modes (they change the FRF only).

        Parameters
        ----------
        q : array_like, shape (..., 6)
            Controller axis angles [rad].
        overdamped : {"raise", "drop", "keep"}
            Policy for an overdamped mode (real poles): ``"raise"`` (default)
            refuses naming the robot file; ``"drop"`` leaves ``nan`` in its
            damped quantities (frequency, damping, poles), for callers that
            need the resonant modes only; ``"keep"`` gives it the frequency
            and damping ratio (>= 1) of its real poles, for the real-mode
            receptance a planner builds (:class:`~robolobe.twin.modes.Modes`).
        """
        s = self.system(q)
        try:
            return compute_modes(s.M, s.K, s.C, s.J, overdamped=overdamped)
        except InputError as exc:
            if exc.source:
                raise
            # name the robot file: an overdamped joint mode is a property of its values
            raise InputError(
                f"{exc.detail} (robot {self.robot.name!r})",
                source=self.robot.source,
            ) from None

    def receptance(
        self, q: ArrayLike, freq_hz: ArrayLike, *, method: Literal["solve", "modal"] = "solve"
    ) -> ComplexArray:
        """Measured TCP receptance at postures ``q``.

        Parameters
        ----------
        q : array_like, shape (..., 6)
            Controller axis angles [rad].
        freq_hz : array_like, shape (n_freq,)
            Frequencies [Hz].
        method : {"solve", "modal"}
            ``"solve"``: the definition, one linear solve per posture and
            frequency (:func:`robolobe.twin.frf.receptance`). ``"modal"``: the
            exact pole-residue sum of the damped modes (:meth:`Modes.frf`),
            about three times faster on long frequency grids; needs an
            underdamped system. Both agree to ~1e-12 relative.

        Returns
        -------
        ndarray, shape (..., n_freq, 3, 3), complex
            ``H[..., f, a, b]``: TCP displacement along a (TCP frame) per unit
            force along b [m/N], measurement effects applied.
        """
        f = _freq(freq_hz)
        s = self.system(q)
        if method == "solve":
            h = receptance(s.M, s.K, s.C, s.J, f)
        elif method == "modal":
            h = compute_modes(s.M, s.K, s.C, s.J).frf(f)
        else:
            raise InputError(f"method: expected 'solve' or 'modal', found {method!r}")
        for e in self._ordered:
            h = e.modify_frf(h, f)
        return h
