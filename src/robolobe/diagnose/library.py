"""The library of named candidate additions to the nominal robot model.

Each candidate wraps one effect of :mod:`robolobe.twin.effects`, so the same
physics that the twin simulates is what the diagnosis fits. A family with a
discrete choice (which joint, which link and bending axis, which tool
direction) becomes one candidate per choice (a *variant*); the selection
sees every variant and the report names the family and the variant.

=========================  =========================================  ==========================
family                     fitted parameters (bounds)                 variants
=========================  =========================================  ==========================
``none``                   -                                          -
``added_mass``             mass_kg (0.05..500, log)                   -
``joint_stiffness``        factor (0.2..5, log)                       joints 1..6
``joint_damping``          factor (0.05..20, log)                     joints 1..6
``gravity_stiffening``     beta (0..20), tau_ref = 1e4 N m fixed      -
``coupled_joint_stiffness``  k_coupling_Nm_per_rad (+-0.9 sqrt(k2 k3))  joints 2-3
``base_compliance``        stiffness_Nm_per_rad (1e6..1e11, log)      -
``tool_mode``              f_hz (to 1.5 f_max), zeta, mass_kg         direction x, y, z, xyz
``sensor_misalignment``    rx_rad, ry_rad, rz_rad (+-0.35)            -
``sensor_delay``           delay_s (+-0.02)                           -
``hammer_direction``       rx_rad, ry_rad, rz_rad (+-0.35); one hit:  all hits, hit x, y, z
                           the two angles that tilt it
``link_flexibility``       stiffness_Nm_per_rad (1e5..1e10, log)      link 1..5, axis x, y
``friction_damping``       torque_Nm (0.1..1e4, log)                  -
=========================  =========================================  ==========================

Start grids are physical: factors around 1, masses from sensors to spindles,
tool-mode frequencies spread log-evenly over the analysis band.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe._directions import ALL_DIRS, AXES
from robolobe.diagnose.calibration import CALIBRATION, calibration_candidate
from robolobe.diagnose.candidate import NONE, Candidate, ParamSpec, Requirement
from robolobe.errors import InputError
from robolobe.robots import Robot
from robolobe.twin.effects import (
    AddedMass,
    BaseCompliance,
    CoupledJointStiffness,
    Effect,
    FrictionDamping,
    GravityStiffening,
    HammerDirection,
    JointDamping,
    JointStiffness,
    LinkFlexibility,
    SensorDelay,
    SensorGain,
    SensorMisalignment,
    ServoMode,
    TcpOffset,
    ToolMode,
    link_bending_axes,
)

__all__ = ["FAMILIES", "Untestable", "build_library"]

#: Names of the candidate families, ``none`` first.
FAMILIES: tuple[str, ...] = (
    NONE,
    CALIBRATION,
    "added_mass",
    "joint_stiffness",
    "joint_damping",
    "gravity_stiffening",
    "coupled_joint_stiffness",
    "base_compliance",
    "tool_mode",
    "sensor_misalignment",
    "sensor_delay",
    "link_flexibility",
    "friction_damping",
    "servo_mode",
    "tcp_offset",
    "sensor_gain",
    "hammer_direction",
)


@dataclass(frozen=True)
class Untestable:
    """A candidate the data cannot test.

    Parameters
    ----------
    name : str
        Family name.
    variant : str
        Variant (empty for the whole family).
    reason : str
    """

    name: str
    variant: str
    reason: str

    @property
    def label(self) -> str:
        """``name`` or ``name[variant]``."""
        return f"{self.name}[{self.variant}]" if self.variant else self.name


Builder = Callable[[NDArray[np.float64]], tuple[Effect, ...]]


def _rotation_params() -> tuple[ParamSpec, ...]:
    """Search ranges of the three angles of a rotated sensor or hammer [rad]."""
    g = (-0.1, 0.0, 0.1)
    return tuple(
        ParamSpec(n, -0.35, 0.35, g, "linear", null=0.0) for n in ("rx_rad", "ry_rad", "rz_rad")
    )


def _builder(cls: type[Effect], names: Sequence[str], **fixed: Any) -> Builder:
    """``p -> (cls(**fixed, names[0]=p[0], ...),)``."""

    def build(p: NDArray[np.float64]) -> tuple[Effect, ...]:
        kw = {n: float(v) for n, v in zip(names, p, strict=True)}
        return (cls(**fixed, **kw),)

    return build


def _no_effects(p: NDArray[np.float64]) -> tuple[Effect, ...]:
    return ()


def _axis_name(axis: tuple[float, ...]) -> str:
    """``x``, ``-z``, or the vector, for an axis in a DH frame."""
    a = np.asarray(axis)
    i = int(np.argmax(np.abs(a)))
    if abs(a[i]) > 0.999:
        return ("-" if a[i] < 0 else "") + AXES[i]
    return "(" + ", ".join(f"{x:.2f}" for x in a) + ")"


def _family(
    robot: Robot, name: str, band_hz: tuple[float, float], directions: Sequence[str] = ALL_DIRS
) -> list[Candidate]:
    """All variants of one family."""
    lo_hz, hi_hz = band_hz
    if name == NONE:
        return [Candidate(NONE, (), _no_effects, description="the nominal model as it is")]
    if name == CALIBRATION:
        return [calibration_candidate(robot)]
    if name == "added_mass":
        return [
            Candidate(
                name,
                (ParamSpec("mass_kg", 0.05, 500.0, (0.5, 2.0, 8.0, 30.0, 100.0), "log"),),
                _builder(AddedMass, ["mass_kg"]),
                description="an unmodelled point mass at the TCP (sensor, adapter, clamp)",
            )
        ]
    if name in ("joint_stiffness", "joint_damping"):
        cls, spec, what = (
            (
                JointStiffness,
                ParamSpec("factor", 0.2, 5.0, (0.6, 0.85, 1.2, 1.7), "log", null=1.0),
                "stiffness",
            )
            if name == "joint_stiffness"
            else (
                JointDamping,
                ParamSpec("factor", 0.05, 20.0, (0.3, 0.7, 1.5, 4.0), "log", null=1.0),
                "damping",
            )
        )
        return [
            Candidate(
                name,
                (spec,),
                _builder(cls, ["factor"], joint=j),
                variant=f"joint {j}",
                description=f"joint {j}'s {what} off by a factor",
                fixed={"joint": j},
            )
            for j in range(1, 7)
        ]
    if name == "gravity_stiffening":
        return [
            Candidate(
                name,
                (ParamSpec("beta", 0.0, 20.0, (0.05, 0.3, 1.0, 3.0), "linear", null=0.0),),
                _builder(GravityStiffening, ["beta"]),
                description="joint stiffness rising with each joint's gravity torque "
                "(k = k0 (1 + beta |tau_g| / 1e4 N m))",
                fixed={"tau_ref_Nm": 1.0e4},
            )
        ]
    if name == "coupled_joint_stiffness":
        kmax = 0.9 * float(np.sqrt(robot.stiffness[1] * robot.stiffness[2]))
        grid = tuple(kmax * g for g in (-0.6, -0.3, -0.1, 0.1, 0.3, 0.6))
        return [
            Candidate(
                name,
                (ParamSpec("k_coupling_Nm_per_rad", -kmax, kmax, grid, "linear", null=0.0),),
                _builder(CoupledJointStiffness, ["k_coupling_Nm_per_rad"], joints=(2, 3)),
                variant="joints 2-3",
                description="a stiffness coupling joints 2 and 3 (parallelogram, balancer)",
                fixed={"joints": (2, 3)},
            )
        ]
    if name == "base_compliance":
        return [
            Candidate(
                name,
                (ParamSpec("stiffness_Nm_per_rad", 1e6, 1e11, (3e6, 1e7, 3e7, 1e8, 1e9), "log"),),
                _builder(BaseCompliance, ["stiffness_Nm_per_rad"]),
                description="an elastic base or floor (the robot rocks on a rotational spring)",
                fixed={"mass_kg": BaseCompliance().mass_kg},
            )
        ]
    if name == "tool_mode":
        f_lo = max(1.0, 0.75 * lo_hz)
        f_hi = min(5000.0, 1.5 * hi_hz)
        f_grid = tuple(float(x) for x in np.geomspace(max(f_lo, 0.9 * lo_hz + 0.5), hi_hz, 24))
        out = []
        ee = robot.end_effector
        for d in ("x", "y", "z", "xyz"):
            req = Requirement(
                any_of_directions=tuple(r + e for r in AXES for e in AXES if d in (r, e))
                if d != "xyz"
                else (),
                why=f"a tool mode along {d} shows only in FRFs involving {d}",
            )
            out.append(
                Candidate(
                    name,
                    (
                        ParamSpec("f_hz", f_lo, f_hi, f_grid, "log"),
                        ParamSpec("zeta", 0.003, 0.2, (0.03,), "log"),
                        ParamSpec("mass_kg", 0.1, 200.0, (0.3, 3.0, 15.0), "log"),
                    ),
                    _builder(ToolMode, ["f_hz", "zeta", "mass_kg"], direction=d),
                    variant=f"direction {d}",
                    description=f"a local spindle/bracket/tool mode along {d}",
                    requirement=req,
                    fixed={"direction": d},
                )
            )
            if ee is not None and ee.mass_kg > 0.5 and d != "xyz":
                m_hi = 0.9 * ee.mass_kg
                out.append(
                    Candidate(
                        name,
                        (
                            ParamSpec("f_hz", f_lo, f_hi, f_grid, "log"),
                            ParamSpec("zeta", 0.003, 0.2, (0.03,), "log"),
                            ParamSpec(
                                "mass_kg",
                                0.1,
                                m_hi,
                                tuple(x for x in (0.3, 3.0, 15.0) if x < m_hi) or (0.2,),
                                "log",
                            ),
                        ),
                        _builder(
                            ToolMode,
                            ["f_hz", "zeta", "mass_kg"],
                            direction=d,
                            mass_in_file=True,
                        ),
                        variant=f"local, direction {d}",
                        description=f"a local tool/bracket mode along {d} whose mass the "
                        "file already holds in its end effector",
                        requirement=req,
                        fixed={"direction": d, "mass_in_file": True},
                    )
                )
        return out
    if name == "sensor_misalignment":
        return [
            Candidate(
                name,
                _rotation_params(),
                _builder(SensorMisalignment, ["rx_rad", "ry_rad", "rz_rad"]),
                description="accelerometer axes rotated against the TCP frame",
                requirement=Requirement(
                    min_directions=2,
                    why="a rotated sensor mixes response directions; one direction alone "
                    "cannot tell a rotation from a level change",
                ),
            )
        ]
    if name == "sensor_delay":
        return [
            Candidate(
                name,
                (
                    ParamSpec(
                        "delay_s", -0.02, 0.02, (-0.004, -0.001, 0.001, 0.004), "linear", null=0.0
                    ),
                ),
                _builder(SensorDelay, ["delay_s"]),
                description="a delay of the response channel (phase error linear in frequency)",
            )
        ]
    if name == "link_flexibility":
        out = []
        for link in range(1, 6):
            for axis in link_bending_axes(robot, link):
                ax = _axis_name(axis)
                out.append(
                    Candidate(
                        name,
                        (
                            ParamSpec(
                                "stiffness_Nm_per_rad", 1e5, 1e10, (3e5, 3e6, 3e7, 3e8), "log"
                            ),
                        ),
                        _builder(LinkFlexibility, ["stiffness_Nm_per_rad"], link=link, axis=axis),
                        variant=f"link {link} about {ax}",
                        description=f"bending of link {link} about its DH-frame {ax} axis "
                        f"(across joint {link + 1}'s axis)",
                        fixed={"link": link, "axis": axis},
                    )
                )
        return out
    if name == "servo_mode":
        return [
            Candidate(
                name,
                (
                    ParamSpec("stiffness_Nm_per_rad", 1e3, 1e10, (1e4, 1e5, 1e6, 1e7, 1e8), "log"),
                    ParamSpec("zeta", 0.005, 0.8, (0.05, 0.2), "log"),
                    ParamSpec("rotor_inertia_kgm2", 0.1, 3000.0, (5.0, 50.0, 300.0), "log"),
                ),
                _builder(
                    ServoMode, ["stiffness_Nm_per_rad", "zeta", "rotor_inertia_kgm2"], joint=j
                ),
                variant=f"joint {j}",
                description=f"joint {j}'s servo holds it with a finite stiffness "
                "(a holding mode of the arm)",
                fixed={"joint": j},
            )
            for j in range(1, 7)
        ]
    if name == "tcp_offset":
        g = (-0.06, 0.0, 0.06)
        return [
            Candidate(
                name,
                tuple(ParamSpec(f"d{a}_m", -0.3, 0.3, g, "linear", null=0.0) for a in AXES),
                lambda p: (TcpOffset(offset_m=(float(p[0]), float(p[1]), float(p[2]))),),
                description="the tested point is offset from the file's TCP (tool length)",
            )
        ]
    if name == "sensor_gain":
        chans = sorted({d[0] for d in directions})
        idx = ["xyz".index(c) for c in chans]

        def build_gain(p: NDArray[np.float64]) -> tuple[Effect, ...]:
            g = [1.0, 1.0, 1.0]
            for i, v in zip(idx, p, strict=True):
                g[i] = float(v)
            return (SensorGain(gain=(g[0], g[1], g[2])),)

        return [
            Candidate(
                name,
                tuple(
                    ParamSpec(f"g{c}", 0.5, 2.0, (0.9, 1.0, 1.1), "log", null=1.0) for c in chans
                ),
                build_gain,
                description="a response channel's sensitivity is off (level error)",
                fixed={"channels": tuple(chans)},
            )
        ]
    if name == "hammer_direction":
        out = [
            Candidate(
                name,
                _rotation_params(),
                _builder(HammerDirection, ["rx_rad", "ry_rad", "rz_rad"]),
                description="the hammer hits off the nominal axes (input side)",
                requirement=Requirement(
                    min_directions=2,
                    why="an off-axis hit mixes excitation directions; one direction alone "
                    "cannot tell it from a level change",
                ),
            )
        ]
        # one hit direction off on its own (each is hit by hand): the two angles that
        # tilt e_hit (the rotation about the hit's own axis does not move it)
        for hit, free in (
            ("x", ("ry_rad", "rz_rad")),
            ("y", ("rx_rad", "rz_rad")),
            ("z", ("rx_rad", "ry_rad")),
        ):
            out.append(
                Candidate(
                    name,
                    tuple(p for p in _rotation_params() if p.name in free),
                    _builder(HammerDirection, list(free), hit=hit),
                    variant=f"hit {hit}",
                    description=f"the hammer hits along {hit} off the axis (input side)",
                    requirement=Requirement(
                        min_directions=2,
                        any_of_directions=tuple(r + hit for r in AXES),
                        why=f"an off-axis {hit} hit shows only in the FRFs of {hit} hits, "
                        "and in more than one response direction",
                    ),
                    fixed={"hit": hit},
                )
            )
        return out
    if name == "friction_damping":
        return [
            Candidate(
                name,
                (ParamSpec("torque_Nm", 0.1, 1e4, (3.0, 30.0, 300.0), "log"),),
                _builder(FrictionDamping, ["torque_Nm"]),
                description="Coulomb joint friction: damping that falls as the hammer force rises",
                requirement=Requirement(
                    min_force_levels=2,
                    why="friction shows as damping that changes with the force level; at one "
                    "level it cannot be told from viscous joint damping",
                ),
            )
        ]
    raise InputError(f"candidate: expected one of {', '.join(FAMILIES)}, found {name!r}")


def build_library(
    robot: Robot,
    *,
    directions: Sequence[str],
    n_force_levels: int,
    band_hz: tuple[float, float],
    families: Sequence[str] | None = None,
) -> tuple[list[Candidate], list[Untestable]]:
    """The candidates the data can test, and those they cannot.

    Parameters
    ----------
    robot : Robot
        The nominal robot (sets the coupling bounds).
    directions : sequence of str
        Directions measured in the campaign.
    n_force_levels : int
        Distinct hammer force levels in the campaign (0 if unknown).
    band_hz : (float, float)
        Analysis band [Hz] (sets the tool-mode search range).
    families : sequence of str, optional
        Families to include (default all); ``none`` is always included.

    Returns
    -------
    candidates : list of Candidate
        ``none`` first.
    untestable : list of Untestable
    """
    names = list(FAMILIES if families is None else dict.fromkeys([NONE, *families]))
    for n in names:
        if n not in FAMILIES:
            raise InputError(f"candidate: expected one of {', '.join(FAMILIES)}, found {n!r}")
    cands: list[Candidate] = []
    skipped: list[Untestable] = []
    for n in names:
        for c in _family(robot, n, band_hz, directions):
            why = c.requirement.unmet(directions, n_force_levels)
            if why is None:
                cands.append(c)
            else:
                skipped.append(Untestable(c.name, c.variant, why))
    # report a family once if none of its variants can be tested
    fams_ok = {c.name for c in cands}
    merged: list[Untestable] = []
    for u in skipped:
        if u.name in fams_ok:
            merged.append(u)
        elif not any(m.name == u.name and not m.variant for m in merged):
            merged.append(Untestable(u.name, "", u.reason))
    return cands, merged
