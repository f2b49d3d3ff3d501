"""A candidate addition to the nominal model: named physics with 1-3 parameters.

A :class:`Candidate` maps a parameter vector (physical units) to the model
effects it adds (``build``), and carries bounds, a start grid and what data
it needs. The fit works in internal coordinates ``z`` (the logarithm of
parameters declared ``scale="log"``, the parameter itself otherwise), so
that factors and masses spanning decades are searched evenly.

The library of robot physics built on the twin's effects is in
:mod:`robolobe.diagnose.library`; this module knows nothing of robots.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["NONE", "Candidate", "ParamSpec", "Requirement"]

NONE = "none"


@dataclass(frozen=True)
class ParamSpec:
    """One fitted parameter of a candidate.

    Parameters
    ----------
    name : str
        Parameter name with its unit, e.g. ``"mass_kg"``, ``"factor"``.
    lower, upper : float
        Bounds in physical units (``lower < upper``; both > 0 for log scale).
    grid : tuple of float
        Start values scanned before the local fit (physical units, within bounds).
    scale : {"log", "linear"}
        Internal coordinate of the fit.
    null : float or None
        Value at which the effect vanishes (e.g. factor 1, mass 0), if any.
    description : str
        One line for reports.
    """

    name: str
    lower: float
    upper: float
    grid: tuple[float, ...]
    scale: Literal["log", "linear"] = "linear"
    null: float | None = None
    description: str = ""

    def __post_init__(self) -> None:
        if not self.lower < self.upper:
            raise InputError(
                f"{self.name}: expected lower < upper, found {self.lower}, {self.upper}"
            )
        if self.scale == "log" and self.lower <= 0:
            raise InputError(f"{self.name}: log scale needs lower > 0, found {self.lower}")
        if not self.grid:
            raise InputError(f"{self.name}: expected at least one grid value")
        for g in self.grid:
            if not self.lower <= g <= self.upper:
                raise InputError(
                    f"{self.name}: grid value {g} outside [{self.lower}, {self.upper}]"
                )

    def to_internal(self, p: float) -> float:
        """Physical value -> internal coordinate."""
        return float(np.log(p)) if self.scale == "log" else float(p)

    def to_physical(self, z: float) -> float:
        """Internal coordinate -> physical value."""
        return float(np.exp(z)) if self.scale == "log" else float(z)

    def dphys_dz(self, z: float) -> float:
        """Derivative of the physical value with respect to the internal coordinate."""
        return float(np.exp(z)) if self.scale == "log" else 1.0


@dataclass(frozen=True)
class Requirement:
    """What a candidate needs from the data to be tested.

    Parameters
    ----------
    min_directions : int
        Least number of distinct measured directions.
    any_of_directions : tuple of str
        At least one of these directions must be measured (empty: any).
    min_force_levels : int
        Least number of distinct hammer force levels.
    why : str
        Physical reason, for the message when the data fall short.
    """

    min_directions: int = 1
    any_of_directions: tuple[str, ...] = ()
    min_force_levels: int = 0
    why: str = ""

    def unmet(self, directions: Sequence[str], n_force_levels: int) -> str | None:
        """Why the data cannot test the candidate, or None if they can."""
        dirs = set(directions)
        if len(dirs) < self.min_directions:
            return (
                f"needs at least {self.min_directions} measured directions, "
                f"found {len(dirs)} ({', '.join(sorted(dirs)) or 'none'})"
                + (f": {self.why}" if self.why else "")
            )
        if self.any_of_directions and not dirs.intersection(self.any_of_directions):
            return (
                f"needs one of the directions {', '.join(self.any_of_directions)}, "
                f"found {', '.join(sorted(dirs)) or 'none'}" + (f": {self.why}" if self.why else "")
            )
        if n_force_levels < self.min_force_levels:
            return (
                f"needs records at {self.min_force_levels} or more hammer force levels, "
                f"found {n_force_levels}" + (f": {self.why}" if self.why else "")
            )
        return None


@dataclass(frozen=True, eq=False)
class Candidate:
    """A named addition to the nominal model.

    Parameters
    ----------
    name : str
        Library name (``"added_mass"``, ``"joint_stiffness"``, ... or ``"none"``).
    params : tuple of ParamSpec
        Fitted parameters (empty for ``none``).
    build : callable
        ``build(p) -> tuple of effects`` for physical parameters ``p``, shape
        (n_params,). The effects are whatever the model function understands
        (twin effects for robots).
    variant : str
        Discrete choice inside the family, e.g. ``"joint 3"`` (empty if none).
    description : str
        One line of physics for reports.
    requirement : Requirement
        What the data must hold to test it.
    fixed : dict
        Fixed settings of the variant, for reports and the updated model.
    require_identifiable : bool
        Whether every parameter must be determined for the candidate to be
        named (False for the file calibration: judged by its held-out fit).
    """

    name: str
    params: tuple[ParamSpec, ...]
    build: Callable[[NDArray[np.float64]], tuple[Any, ...]]
    variant: str = ""
    description: str = ""
    requirement: Requirement = field(default_factory=Requirement)
    fixed: dict[str, Any] = field(default_factory=dict)
    require_identifiable: bool = True

    @property
    def label(self) -> str:
        """``name`` or ``name[variant]``."""
        return f"{self.name}[{self.variant}]" if self.variant else self.name

    @property
    def n_params(self) -> int:
        """Number of fitted parameters."""
        return len(self.params)

    @property
    def bounds_internal(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Lower and upper bounds in internal coordinates, shape (n_params,) each."""
        lo = np.array([p.to_internal(p.lower) for p in self.params])
        hi = np.array([p.to_internal(p.upper) for p in self.params])
        return lo, hi

    def to_physical(self, z: ArrayLike) -> NDArray[np.float64]:
        """Internal coordinates -> physical parameters."""
        zz = np.atleast_1d(np.asarray(z, dtype=float))
        return np.array([p.to_physical(v) for p, v in zip(self.params, zz, strict=True)])

    def to_internal(self, p: ArrayLike) -> NDArray[np.float64]:
        """Physical parameters -> internal coordinates."""
        pp = np.atleast_1d(np.asarray(p, dtype=float))
        return np.array([s.to_internal(v) for s, v in zip(self.params, pp, strict=True)])

    def effects(self, p: ArrayLike) -> tuple[Any, ...]:
        """Effects for physical parameters ``p``."""
        return tuple(self.build(np.atleast_1d(np.asarray(p, dtype=float))))

    def start_grid(self, max_points: int = 64) -> NDArray[np.float64]:
        """Start points in physical units, shape (m, n_params).

        The Cartesian product of the parameter grids, thinned evenly to
        ``max_points`` if larger.
        """
        if not self.params:
            return np.zeros((1, 0))
        pts = np.array(list(itertools.product(*[p.grid for p in self.params])), dtype=float)
        if len(pts) > max_points:
            keep = np.unique(np.linspace(0, len(pts) - 1, max_points).round().astype(int))
            pts = pts[keep]
        return pts

    def null_params(self) -> NDArray[np.float64] | None:
        """Parameters at which the effect vanishes, if every parameter has a null value."""
        if not self.params or any(p.null is None for p in self.params):
            return None
        return np.array([float(p.null) for p in self.params if p.null is not None])
