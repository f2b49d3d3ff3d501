""" "The robot file's values are off" as a candidate of its own.

A robot file is a prior (docs/guide/robots.md): joint stiffnesses and
dampings are rarely published and the masses are estimates. Before any
missing physics is named, the diagnosis asks whether correcting the file's
own values explains the recordings. The parameters are those of the twin
calibration (:mod:`robolobe.twin.params`, the parametrisation that
:class:`robolobe.tl.graybox.TwinCalibration` fits to identified modes):

========== ==== ===========================================
group      size fitted as
========== ==== ===========================================
stiffness  6    factor on each joint stiffness (k1..k6)
damping    6    factor on each joint damping (d1..d6)
ee_mass    1    factor on the end-effector mass and inertia
link_mass  6    factor on each link's mass and inertia
========== ==== ===========================================

The values are applied with :func:`robolobe.twin.params.apply_parameters`
(one place for what "the file's parameter theta" means), and the candidate
is fitted to the FRFs by the diagnosis's own fit
(:func:`robolobe.diagnose.fitting.fit_candidate`) like every other
candidate: the FRF residual sees levels and anti-resonances that identified
modes do not, and the held-out postures judge it on the same scale as the
physics candidates. The 18 centre-of-mass offsets of the twin calibration
are left out: with 19 factors the held-out test stays affordable (one
30-posture campaign in well under a minute), and a COM error shows as a
remaining misfit that the absolute noise test reports.

Layering (docs/guide/physics.md): ``diagnose`` is below ``tl`` in the package table, so
it may use ``tl``'s parametrisation.

Many of the 19 factors are not determined by one campaign (a link that
hardly moves the TCP); the candidate does not need them all to be: it is
judged by its held-out fit, and the report lists the factors that are
determined and moved.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from robolobe.diagnose.candidate import Candidate, ParamSpec
from robolobe.robots import Robot
from robolobe.twin.effects import Effect
from robolobe.twin.params import PARAMETER_GROUPS, apply_parameters, parameter_names

__all__ = ["CALIBRATION", "FileParameters", "calibration_candidate", "moved_parameters"]

#: Family name of the calibration candidate.
CALIBRATION = "file_parameters"
_GROUPS = ("stiffness", "damping", "ee_mass", "link_mass")
#: Bounds of every factor.
FACTOR_BOUNDS = (0.4, 2.5)


@dataclass(frozen=True)
class FileParameters(Effect):
    """The robot file's values corrected by the twin-calibration parameters.

    A stage-0 (robot-level) change, so the updated model bakes it into
    ``robot.toml``: the calibrated file.

    Parameters
    ----------
    groups : tuple of str
        Keys of :data:`robolobe.twin.params.PARAMETER_GROUPS`.
    theta : tuple of float
        Their parameters (log factors), 0 = the file.
    """

    name: ClassVar[str] = CALIBRATION
    stage: ClassVar[int] = 0
    groups: tuple[str, ...] = _GROUPS
    theta: tuple[float, ...] = ()

    def apply_robot(self, robot: Robot) -> Robot:
        """The robot with the corrected values."""
        return apply_parameters(robot, self.groups, np.asarray(self.theta, dtype=float))


def calibration_candidate(robot: Robot) -> Candidate:
    """The "file values off" candidate for ``robot`` (factors, log scale, null 1)."""
    groups = tuple(g for g in _GROUPS if g != "ee_mass" or robot.end_effector is not None)
    names = parameter_names(groups)
    lo, hi = FACTOR_BOUNDS
    specs = tuple(
        ParamSpec(n, lo, hi, (1.0,), "log", null=1.0, description=f"factor {n}") for n in names
    )
    assert len(specs) == sum(PARAMETER_GROUPS[g] for g in groups)

    def build(p: NDArray[np.float64]) -> tuple[Effect, ...]:
        return (FileParameters(groups=groups, theta=tuple(float(x) for x in np.log(p))),)

    return Candidate(
        CALIBRATION,
        specs,
        build,
        description="the robot file's joint stiffnesses, dampings and masses are off "
        "(twin-calibration parameters)",
        fixed={"groups": groups},
        require_identifiable=False,
    )


def moved_parameters(
    names: tuple[str, ...],
    values: NDArray[np.float64],
    std: NDArray[np.float64],
    *,
    min_change: float = 0.05,
) -> list[tuple[str, float, float]]:
    """The calibrated factors that moved and are determined.

    Parameters
    ----------
    names : tuple of str
    values, std : ndarray, shape (p,)
        Fitted factors and their standard deviations.
    min_change : float
        Least relative change reported.

    Returns
    -------
    list of (name, factor, std)
        Largest change first; a factor whose std exceeds its change is left out.
    """
    out = []
    for n, v, s in zip(names, values, std, strict=True):
        ch = abs(float(np.log(v)))
        if ch >= min_change and np.isfinite(s) and s < abs(v - 1.0):
            out.append((n, float(v), float(s)))
    return sorted(out, key=lambda t: -abs(np.log(t[1])))
