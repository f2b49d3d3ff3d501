"""Milling cutter geometry."""

from __future__ import annotations

import math
from dataclasses import dataclass

from robolobe.errors import InputError

__all__ = ["Cutter"]


@dataclass(frozen=True)
class Cutter:
    """An end mill.

    Parameters
    ----------
    diameter : float
        Cutter diameter D [m].
    teeth : int
        Number of flutes N (>= 1).
    helix : float, default 30 deg
        Helix angle [rad], ``0 <= helix < pi/2``. The zero-order solution
        does not depend on it (the directional factors are averages); it is
        kept for the record and for callers that model force signals.
    flute_length : float or None
        Flute length [m]: the largest axial depth the cutter can take, or
        None when unknown.

    Raises
    ------
    InputError
        On a non-positive diameter, a tooth count below one, a helix angle
        outside ``[0, pi/2)`` or a non-positive flute length.
    """

    diameter: float
    teeth: int
    helix: float = math.radians(30.0)
    flute_length: float | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.diameter) and self.diameter > 0.0):
            raise InputError(f"diameter: expected a positive length in m, found {self.diameter!r}")
        if isinstance(self.teeth, bool) or int(self.teeth) != self.teeth or self.teeth < 1:
            raise InputError(f"teeth: expected an integer >= 1, found {self.teeth!r}")
        object.__setattr__(self, "teeth", int(self.teeth))
        if not (math.isfinite(self.helix) and 0.0 <= self.helix < math.pi / 2):
            raise InputError(f"helix: expected an angle in [0, pi/2) rad, found {self.helix!r}")
        if self.flute_length is not None and not (
            math.isfinite(self.flute_length) and self.flute_length > 0.0
        ):
            raise InputError(
                "flute_length: expected a positive length in m or None, "
                f"found {self.flute_length!r}"
            )

    @property
    def radius(self) -> float:
        """Cutter radius [m]."""
        return 0.5 * self.diameter

    @property
    def max_depth(self) -> float:
        """Largest usable axial depth [m] (``inf`` without a flute length)."""
        return math.inf if self.flute_length is None else self.flute_length
