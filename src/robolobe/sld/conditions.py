"""Cutting conditions: engagement (entry/exit angles), up/down milling, feed."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from robolobe.errors import InputError

__all__ = ["CuttingConditions", "engagement_angles", "radial_immersion"]

Milling = Literal["up", "down"]


def engagement_angles(immersion: float, milling: str) -> tuple[float, float]:
    """Entry and exit angles for a radial immersion ``a_e / D``.

    Up milling starts at ``phi_st = 0`` and leaves at
    ``phi_ex = acos(1 - 2 a_e/D)``; down milling starts at
    ``phi_st = acos(2 a_e/D - 1)`` and leaves at ``phi_ex = pi``
    (docs/references.md: stability lobes). Slotting (``a_e/D = 1``) is ``(0, pi)`` for both.

    Parameters
    ----------
    immersion : float
        Radial immersion ``a_e / D`` in ``(0, 1]``.
    milling : {"up", "down"}
        Milling mode.

    Returns
    -------
    (float, float)
        ``(phi_st, phi_ex)`` [rad].

    Raises
    ------
    InputError
        On an immersion outside ``(0, 1]`` or an unknown milling mode.
    """
    if not (math.isfinite(immersion) and 0.0 < immersion <= 1.0):
        raise InputError(f"immersion: expected a_e/D in (0, 1], found {immersion!r}")
    if milling == "up":
        return 0.0, math.acos(1.0 - 2.0 * immersion)
    if milling == "down":
        return math.acos(2.0 * immersion - 1.0), math.pi
    raise InputError(f"milling: expected 'up' or 'down', found {milling!r}")


def radial_immersion(phi_entry: float, phi_exit: float) -> float:
    """Radial immersion ``a_e / D = (cos phi_st - cos phi_ex) / 2`` [-]."""
    return 0.5 * (math.cos(phi_entry) - math.cos(phi_exit))


@dataclass(frozen=True)
class CuttingConditions:
    """Where the teeth cut and how much.

    Build with :meth:`from_immersion` or :meth:`from_radial_width`, or give
    the angles directly.

    Parameters
    ----------
    phi_entry, phi_exit : float
        Entry and exit angles [rad], ``0 <= phi_entry < phi_exit <= pi``,
        measured clockwise from the normal (y) axis (see
        :mod:`robolobe.sld.directional` for the frame).
    feed_per_tooth : float or None
        Feed per tooth f_z [m] (informative for the stability limit, which
        does not depend on it; used for the feed rate and forces).
    milling : {"up", "down"} or None
        Recorded milling mode; None for angles given directly.

    Raises
    ------
    InputError
        On angles outside ``[0, pi]`` or not increasing, or a non-positive feed.
    """

    phi_entry: float
    phi_exit: float
    feed_per_tooth: float | None = None
    milling: Milling | None = None

    def __post_init__(self) -> None:
        st, ex = self.phi_entry, self.phi_exit
        if not (math.isfinite(st) and math.isfinite(ex) and 0.0 <= st < ex <= math.pi + 1e-12):
            raise InputError(
                "phi_entry/phi_exit: expected 0 <= phi_entry < phi_exit <= pi rad, "
                f"found {st!r}, {ex!r}"
            )
        if self.feed_per_tooth is not None and not (
            math.isfinite(self.feed_per_tooth) and self.feed_per_tooth > 0.0
        ):
            raise InputError(
                f"feed_per_tooth: expected a positive length in m, found {self.feed_per_tooth!r}"
            )
        if self.milling not in (None, "up", "down"):
            raise InputError(f"milling: expected 'up', 'down' or None, found {self.milling!r}")

    @classmethod
    def from_immersion(
        cls, immersion: float, milling: str, *, feed_per_tooth: float | None = None
    ) -> CuttingConditions:
        """Conditions from the radial immersion ``a_e / D`` and the milling mode."""
        st, ex = engagement_angles(immersion, milling)
        return cls(st, ex, feed_per_tooth=feed_per_tooth, milling=milling)  # type: ignore[arg-type]

    @classmethod
    def from_radial_width(
        cls,
        width: float,
        diameter: float,
        milling: str,
        *,
        feed_per_tooth: float | None = None,
    ) -> CuttingConditions:
        """Conditions from the radial width of cut ``a_e`` [m] and the diameter [m]."""
        if not (math.isfinite(diameter) and diameter > 0.0):
            raise InputError(f"diameter: expected a positive length in m, found {diameter!r}")
        if not (math.isfinite(width) and 0.0 < width <= diameter * (1.0 + 1e-12)):
            raise InputError(
                f"radial width: expected 0 < a_e <= D = {diameter!r} m, found {width!r}"
            )
        return cls.from_immersion(
            min(width / diameter, 1.0), milling, feed_per_tooth=feed_per_tooth
        )

    @property
    def immersion(self) -> float:
        """Radial immersion ``a_e / D`` [-]."""
        return radial_immersion(self.phi_entry, min(self.phi_exit, math.pi))
