"""Physical plausibility of a robot description (unit mistakes, absurd values).

A robot file that is valid TOML with the right keys can still describe no
robot: link lengths in millimetres read as metres, a stiffness of 1e300,
joint limits in radians under a ``_deg`` key, an inertia in kg mm^2. Such a
file would give an absurd plan or a numerical failure deep in the twin, so
:func:`robot_findings` checks every value against the range of industrial
robots and returns what it finds: ``"error"`` findings for values no robot
has (the file loader refuses them), ``"warning"`` findings for values that are
merely unusual (logged when the file is read and repeated in a plan's
summary).

Ranges (SI, as in the file; angles in degrees):

- lengths (DH ``a_m``, ``d_m``, centres of mass, tool offset): at most
  :data:`LENGTH_MAX_M` (a larger one is millimetres); the arm's reach
  (:attr:`Robot.reach_m`) within :data:`REACH_ERROR_M`, usually
  :data:`REACH_USUAL_M`;
- joint stiffness within :data:`JOINT_K_ERROR`, usually :data:`JOINT_K_USUAL`
  (N m/rad); tilt and mount stiffness within :data:`TILT_K_ERROR`;
- damping: the time constant c/k at most :data:`DAMPING_TAU_ERROR_S`
  (a damping ratio of about 95 % at 10 Hz), usually below
  :data:`DAMPING_TAU_USUAL_S`;
- masses at most :data:`LINK_MASS_MAX_KG` (link) and :data:`EE_MASS_MAX_KG`
  (end effector); principal inertias at most :data:`INERTIA_MAX_KGM2` and a
  radius of gyration sqrt(I/m) at most :data:`GYRATION_MAX_M`;
- joint limits: not all within +-:data:`RADIAN_LIKE_DEG` (radians under a
  ``_deg`` key), nor all of one key (``q_min_deg`` or ``q_max_deg``), nor one
  equal to a multiple of pi/2 or to the other limit of its joint in radians;
  a joint whose range lies within +-:data:`RADIAN_LIKE_DEG` is warned; none beyond
  +-:data:`JOINT_LIMIT_MAX_DEG`; DH angles, base and tool ZYX angles and
  constraint bounds that equal +-pi/2 or +-pi are radians;
- moving masses: at least :data:`TOTAL_MASS_MIN_KG` in total;
- axis coupling: entries within +-:data:`COUPLING_MAX`, condition number at
  most :data:`COUPLING_COND_MAX`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from robolobe._toml_errors import number as _n
from robolobe.errors import InputError
from robolobe.robots.model import RigidBody, Robot
from robolobe.robots.transforms import xyz_zyx_from_pose

__all__ = [
    "COUPLING_COND_MAX",
    "COUPLING_MAX",
    "DAMPING_TAU_ERROR_S",
    "DAMPING_TAU_USUAL_S",
    "EE_MASS_MAX_KG",
    "GYRATION_MAX_M",
    "INERTIA_MAX_KGM2",
    "JOINT_K_ERROR",
    "JOINT_K_USUAL",
    "JOINT_LIMIT_MAX_DEG",
    "LENGTH_MAX_M",
    "LINK_MASS_MAX_KG",
    "Q_MAX_RAD",
    "RADIAN_LIKE_DEG",
    "REACH_ERROR_M",
    "REACH_USUAL_M",
    "TILT_K_ERROR",
    "TOTAL_MASS_MIN_KG",
    "Finding",
    "check_inertia_range",
    "robot_findings",
    "robot_warnings",
]

#: Longest single length [m] (DH a/d, a centre of mass, the tool offset).
LENGTH_MAX_M = 20.0
#: Reach [m] outside which a robot file is refused (lengths in mm, cm or km).
REACH_ERROR_M = (0.05, 20.0)
#: Reach [m] of industrial arms (table-top to the largest heavy-duty robots).
REACH_USUAL_M = (0.3, 6.0)
#: Joint stiffness [N m/rad] outside which a file is refused.
JOINT_K_ERROR = (1e2, 1e11)
#: Joint stiffness [N m/rad] of industrial robots (the seed's robots: 4.5e4-3.2e6).
JOINT_K_USUAL = (1e4, 1e9)
#: Tilt and mount stiffness [N m/rad] outside which a file is refused.
TILT_K_ERROR = (1e2, 1e12)
#: Tilt and mount stiffness [N m/rad] usually found (bearings, brackets).
TILT_K_USUAL = (1e4, 1e10)
#: Damping time constant c/k [s] above which a file is refused (zeta ~ pi f c/k:
#: about 95 % at 10 Hz, an overdamped robot; N mm s/rad read as N m s/rad gives
#: ~1 s). The seed's robots: 1e-4 to 1e-3 s.
DAMPING_TAU_ERROR_S = 0.03
#: Damping time constant c/k [s] above which a file is unusual (zeta ~ 16 % at 10 Hz).
DAMPING_TAU_USUAL_S = 0.005
#: Heaviest link [kg] (the largest robots' arms weigh a few tonnes).
LINK_MASS_MAX_KG = 1e5
#: Link mass [kg] above which a file is unusual.
LINK_MASS_USUAL_KG = 5e3
#: Heaviest end effector [kg] (the largest payloads are about 2.3 t).
EE_MASS_MAX_KG = 1e4
#: End-effector mass [kg] above which a file is unusual.
EE_MASS_USUAL_KG = 2.5e3
#: Largest principal inertia [kg m^2] of one body.
INERTIA_MAX_KGM2 = 1e5
#: Largest radius of gyration sqrt(I/m) [m] (kg mm^2 read as kg m^2 gives km).
GYRATION_MAX_M = 10.0
#: Radius of gyration [m] above which a body is unusual.
GYRATION_USUAL_M = 3.0
#: Joint limits all within this [deg] are radians under a ``_deg`` key (+-720 deg
#: is +-12.57 rad; no milling robot moves each joint by a few degrees only).
RADIAN_LIKE_DEG = 12.6
#: Largest joint limit [deg] (ten turns).
JOINT_LIMIT_MAX_DEG = 3600.0
#: The same in radians: the largest joint angle a posture (a model's training
#: postures, a campaign's) may hold; B's axis 4 turns +-400 deg.
Q_MAX_RAD = math.radians(JOINT_LIMIT_MAX_DEG)
#: Largest axis coupling ratio (DH angle per axis angle; 0, +-1 or a wrist's gear ratio).
COUPLING_MAX = 10.0
#: Axis coupling ratio above which a file is unusual.
COUPLING_USUAL = 2.0
#: Largest condition number of the coupling matrix (an axis that hardly moves its joint).
COUPLING_COND_MAX = 20.0
#: Coupling condition number above which a file is unusual.
COUPLING_COND_USUAL = 5.0
#: Moving mass [kg] below which a file is refused (the twin needs masses).
TOTAL_MASS_MIN_KG = 1.0
#: Moving mass [kg] below which the arm is unusual (a few kg: a toy).
TOTAL_MASS_USUAL_KG = 5.0


@dataclass(frozen=True)
class Finding:
    """One plausibility finding.

    Attributes
    ----------
    level : {"error", "warning"}
        ``"error"``: no robot has this value (a unit mistake or a typo);
        ``"warning"``: unusual but possible.
    key : str
        Key path in the robot file, e.g. ``[[joints]][2].a_m``.
    message : str
        ``expected ..., found ...`` with the unit.
    """

    level: Literal["error", "warning"]
    key: str
    message: str

    def __str__(self) -> str:
        return f"{self.key}: {self.message}"


def _range(lo: float, hi: float, unit: str) -> str:
    return f"{_n(lo)} to {_n(hi)} {unit}"


def check_inertia_range(mass_kg: float, components: Iterable[float], key: str, where: str) -> None:
    """Refuse an inertia or mass no body has, before any matrix is formed.

    Parameters
    ----------
    mass_kg : float
        Body mass [kg].
    components : iterable of 6 floats
        ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` [kg m^2].
    key : str
        Key path of the body (``[[joints]][3]``, ``end_effector``).
    where : str
        File name for the message.

    Raises
    ------
    InputError
        A mass above :data:`LINK_MASS_MAX_KG` (end effector:
        :data:`EE_MASS_MAX_KG`) or an inertia component above
        :data:`INERTIA_MAX_KGM2`.
    """
    m_max = EE_MASS_MAX_KG if key == "end_effector" else LINK_MASS_MAX_KG
    if mass_kg > m_max:
        raise InputError(
            f"{key}.mass_kg: expected at most {_n(m_max)} kg, found {_n(mass_kg)} kg", where
        )
    big = max(abs(float(c)) for c in components)
    if big > INERTIA_MAX_KGM2:
        raise InputError(
            f"{key}.inertia_kgm2: expected components of at most {_n(INERTIA_MAX_KGM2)} kg m^2 "
            f"(kg m^2, not kg mm^2), found {_n(big)} kg m^2",
            where,
        )


def _length(out: list[Finding], key: str, value_m: float, usual_m: float | None = None) -> None:
    v = abs(float(value_m))
    if v > LENGTH_MAX_M:
        out.append(
            Finding(
                "error",
                key,
                f"expected a length of at most {_n(LENGTH_MAX_M)} m (metres, not mm), "
                f"found {_n(value_m)} m",
            )
        )
    elif usual_m is not None and v > usual_m:
        out.append(
            Finding("warning", key, f"{_n(value_m)} m is unusually long (above {_n(usual_m)} m)")
        )


def _stiffness(
    out: list[Finding],
    key: str,
    k: float,
    err: tuple[float, float],
    usual: tuple[float, float],
    what: str,
) -> None:
    if not err[0] <= k <= err[1]:
        out.append(
            Finding(
                "error",
                key,
                f"expected a {what} stiffness of {_range(*err, 'N m/rad')}, found {_n(k)} N m/rad "
                "(check the unit: N m/rad)",
            )
        )
    elif not usual[0] <= k <= usual[1]:
        out.append(
            Finding(
                "warning",
                key,
                f"{_n(k)} N m/rad is outside the usual {what} stiffness of "
                f"{_range(*usual, 'N m/rad')}",
            )
        )


def _damping(out: list[Finding], key: str, c: float, k: float) -> None:
    tau = c / k
    if c == 0:
        out.append(Finding("warning", key, "0 N m s/rad: undamped (its modes get no damping)"))
    elif tau > DAMPING_TAU_ERROR_S:
        out.append(
            Finding(
                "error",
                key,
                f"expected a damping of at most {_n(DAMPING_TAU_ERROR_S * k)} N m s/rad "
                f"({_n(DAMPING_TAU_ERROR_S)} s times the stiffness, a damping ratio of about "
                f"{100 * math.pi * 10 * DAMPING_TAU_ERROR_S:.0f} % at 10 Hz), found {_n(c)} "
                "N m s/rad (check the unit: N m s/rad)",
            )
        )
    elif tau > DAMPING_TAU_USUAL_S:
        out.append(
            Finding(
                "warning",
                key,
                f"{_n(c)} N m s/rad is heavy damping (a damping ratio of about "
                f"{100 * math.pi * 10 * tau:.0f} % at 10 Hz)",
            )
        )


def _body(out: list[Finding], key: str, body: RigidBody) -> None:
    m = body.mass_kg
    usual = EE_MASS_USUAL_KG if key == "end_effector" else LINK_MASS_USUAL_KG
    if m > usual:
        out.append(
            Finding(
                "warning", f"{key}.mass_kg", f"{_n(m)} kg is unusually heavy (above {_n(usual)} kg)"
            )
        )
    _length(out, f"{key}.com_m", float(np.max(np.abs(body.com_m))), usual_m=3.0)
    i_max = float(np.max(np.linalg.eigvalsh(body.inertia_kgm2)))
    if m > 0 and i_max > 0:
        r = math.sqrt(i_max / m)
        if r > GYRATION_MAX_M:
            out.append(
                Finding(
                    "error",
                    f"{key}.inertia_kgm2",
                    f"expected a radius of gyration sqrt(I/m) of at most {_n(GYRATION_MAX_M)} m, "
                    f"found {_n(r)} m for I = {_n(i_max)} kg m^2 and m = {_n(m)} kg "
                    "(check the unit: kg m^2, not kg mm^2)",
                )
            )
        elif r > GYRATION_USUAL_M:
            out.append(
                Finding(
                    "warning",
                    f"{key}.inertia_kgm2",
                    f"radius of gyration sqrt(I/m) = {_n(r)} m is unusually large "
                    f"(above {_n(GYRATION_USUAL_M)} m)",
                )
            )


def _coupling(out: list[Finding], c: np.ndarray) -> None:
    """Axis coupling ratios: small numbers (0, +-1, gear ratios of a wrist), well conditioned."""
    big = float(np.max(np.abs(c)))
    cond = float(np.linalg.cond(c))
    if big > COUPLING_MAX or cond > COUPLING_COND_MAX:
        out.append(
            Finding(
                "error",
                "kinematics.coupling",
                f"expected axis coupling ratios within +-{_n(COUPLING_MAX)} and a condition "
                f"number of at most {_n(COUPLING_COND_MAX)}, found largest entry {_n(big)}, "
                f"condition number {_n(cond)}",
            )
        )
    elif big > COUPLING_USUAL or cond > COUPLING_COND_USUAL:
        out.append(
            Finding(
                "warning",
                "kinematics.coupling",
                f"unusual axis coupling (largest entry {_n(big)}, condition number {_n(cond)}; "
                "usually 0 and +-1)",
            )
        )


def _radian_like(values_deg: Iterable[float], turns: int = 2) -> float | None:
    """The first value that equals a nonzero multiple of pi/2 up to ``turns`` quarter
    turns (+-pi/2, +-pi; with ``turns=4`` also +-3 pi/2, +-2 pi) under a degree key:
    radians, or None."""
    for v in values_deg:
        k = round(v / (math.pi / 2))
        if k != 0 and abs(k) <= turns and abs(v - k * math.pi / 2) < 2e-3:
            return v
    return None


def _limits_in_radians(out: list[Finding], robot: Robot) -> None:
    """Joint limits written in radians under the ``_deg`` keys, all or in part.

    Every limit within +-:data:`RADIAN_LIKE_DEG`, or every value of one key
    (``q_min_deg`` or ``q_max_deg``: no arm has all six within a few degrees
    of zero), or one joint's limit equal to a multiple of pi/2 rad, or to the
    other limit of its joint in radians (a symmetric range half in radians):
    refused. One limit of an asymmetric range in radians is not decidable
    (robot A's joint 2 moves from -140 to -5 deg).
    One joint whose whole range lies within +-:data:`RADIAN_LIKE_DEG` (a
    near-locked axis, or radians): warned.
    """
    cols = {"q_min_deg": np.degrees(robot.q_min), "q_max_deg": np.degrees(robot.q_max)}
    big = {k: float(np.max(np.abs(v))) for k, v in cols.items()}
    if max(big.values()) <= RADIAN_LIKE_DEG:
        out.append(
            Finding(
                "error",
                "[[joints]].q_min_deg/q_max_deg",
                f"expected joint limits in degrees, found all within +-{_n(RADIAN_LIKE_DEG)} "
                f"(largest {_n(max(big.values()))}): radians? (1 rad = 57.3 deg)",
            )
        )
        return
    for name, other in (("q_min_deg", "q_max_deg"), ("q_max_deg", "q_min_deg")):
        if big[name] <= RADIAN_LIKE_DEG:
            out.append(
                Finding(
                    "error",
                    f"[[joints]].{name}",
                    f"expected joint limits in degrees, found every {name} within "
                    f"+-{_n(RADIAN_LIKE_DEG)} (largest {_n(big[name])}) while {other} reaches "
                    f"{_n(big[other])}: radians? (1 rad = 57.3 deg)",
                )
            )
            return
    for i in range(len(robot.joints)):
        lim = (float(cols["q_min_deg"][i]), float(cols["q_max_deg"][i]))
        key = f"[[joints]][{i + 1}]"
        for name, v in zip(cols, lim, strict=True):
            if _radian_like([v], turns=4) is not None:
                out.append(
                    Finding(
                        "error",
                        f"{key}.{name}",
                        f"expected a joint limit in degrees, found {_n(v)} (a multiple of pi/2 "
                        f"in radians: {_n(math.degrees(v))} deg?)",
                    )
                )
                return
        # a symmetric range with one side in radians: |small| rad == |big| deg (0.5 %)
        small, big_v = sorted(lim, key=abs)
        name = "q_min_deg" if small == lim[0] else "q_max_deg"
        if 0 < abs(small) <= RADIAN_LIKE_DEG and abs(
            abs(math.degrees(small)) - abs(big_v)
        ) <= 5e-3 * abs(big_v):
            other = "q_max_deg" if name == "q_min_deg" else "q_min_deg"
            out.append(
                Finding(
                    "error",
                    f"{key}.{name}",
                    f"expected a joint limit in degrees, found {_n(small)}: {other} = "
                    f"{_n(big_v)} in radians ({_n(math.degrees(small))} deg?)",
                )
            )
            return
        if max(abs(v) for v in lim) <= RADIAN_LIKE_DEG:
            out.append(
                Finding(
                    "warning",
                    key,
                    f"joint range {_n(lim[0])} to {_n(lim[1])} deg: the axis hardly moves; "
                    "if these are radians, write degrees (1 rad = 57.3 deg)",
                )
            )


def robot_findings(robot: Robot) -> list[Finding]:
    """Every plausibility finding of ``robot``, errors first.

    Parameters
    ----------
    robot : Robot

    Returns
    -------
    list of Finding
        Key paths are those of the robot file (docs/guide/robots.md), joints
        counted from 1.
    """
    out: list[Finding] = []
    for i, j in enumerate(robot.joints):
        key = f"[[joints]][{i + 1}]"
        _length(out, f"{key}.a_m", j.a_m)
        _length(out, f"{key}.d_m", j.d_m)
        _stiffness(out, f"{key}.stiffness_Nm_per_rad", j.stiffness_Nm_per_rad, JOINT_K_ERROR,
                   JOINT_K_USUAL, "joint")  # fmt: skip
        _damping(out, f"{key}.damping_Nms_per_rad", j.damping_Nms_per_rad, j.stiffness_Nm_per_rad)
        if j.tilt_stiffness_Nm_per_rad is not None and j.tilt_damping_Nms_per_rad is not None:
            for n, (k, c) in enumerate(
                zip(j.tilt_stiffness_Nm_per_rad, j.tilt_damping_Nms_per_rad, strict=True)
            ):
                _stiffness(out, f"{key}.tilt_stiffness_Nm_per_rad[{n + 1}]", k, TILT_K_ERROR,
                           TILT_K_USUAL, "tilt")  # fmt: skip
                _damping(out, f"{key}.tilt_damping_Nms_per_rad[{n + 1}]", c, k)
        _body(out, key, j.body)
        lim = (math.degrees(j.q_min_rad), math.degrees(j.q_max_rad))
        if max(abs(v) for v in lim) > JOINT_LIMIT_MAX_DEG:
            out.append(
                Finding(
                    "error",
                    key,
                    f"expected joint limits within +-{_n(JOINT_LIMIT_MAX_DEG)} deg (ten turns), "
                    f"found q_min_deg = {_n(lim[0])}, q_max_deg = {_n(lim[1])}",
                )
            )
    _limits_in_radians(out, robot)
    angles = [("[[joints]].alpha_deg", np.degrees(robot.alpha)),
              ("[[joints]].theta_offset_deg", np.degrees(robot.theta_offset)),
              ("kinematics.base.zyx_deg", np.degrees(xyz_zyx_from_pose(robot.base)[1])),
              ("tool.zyx_deg", np.degrees(xyz_zyx_from_pose(robot.tool)[1]))]  # fmt: skip
    angles += [
        (f"kinematics.constraints[{i + 1}].min_deg/max_deg", np.degrees([c.lo_rad, c.hi_rad]))
        for i, c in enumerate(robot.constraints)
    ]
    for key, vals in angles:
        v = _radian_like(vals)
        if v is not None:
            out.append(
                Finding(
                    "error",
                    key,
                    f"expected angles in degrees, found {_n(v)} (pi/2 or pi in radians: "
                    f"{_n(math.degrees(v))} deg?)",
                )
            )
    for name, vals in (("alpha_deg", robot.alpha), ("theta_offset_deg", robot.theta_offset)):
        big = float(np.max(np.abs(np.degrees(vals))))
        if big > JOINT_LIMIT_MAX_DEG:
            out.append(
                Finding(
                    "error",
                    f"[[joints]].{name}",
                    f"expected angles within +-{_n(JOINT_LIMIT_MAX_DEG)} deg, found {_n(big)} deg",
                )
            )
    _coupling(out, robot.coupling)
    _length(out, "tool.xyz_m", math.hypot(*(float(v) for v in robot.tool[:3, 3])), usual_m=2.0)
    base = float(np.max(np.abs(robot.base[:3, 3])))
    if base > 50.0:
        out.append(
            Finding(
                "error",
                "kinematics.base.xyz_m",
                f"expected a base position within +-50 m (metres, not mm), found {_n(base)} m",
            )
        )
    if robot.end_effector is not None:
        _body(out, "end_effector", robot.end_effector)
    if robot.mount_stiffness_Nm_per_rad is not None and robot.mount_damping_Nms_per_rad is not None:
        for n, (k, c) in enumerate(
            zip(robot.mount_stiffness_Nm_per_rad, robot.mount_damping_Nms_per_rad, strict=True)
        ):
            _stiffness(out, f"end_effector.mount_stiffness_Nm_per_rad[{n + 1}]", k, TILT_K_ERROR,
                       TILT_K_USUAL, "mount")  # fmt: skip
            _damping(out, f"end_effector.mount_damping_Nms_per_rad[{n + 1}]", c, k)
    if not out or all(f.level == "warning" for f in out):
        reach = robot.reach_m
        lo, hi = REACH_ERROR_M
        if not lo <= reach <= hi:
            out.append(
                Finding(
                    "error",
                    "[[joints]].a_m/d_m",
                    f"expected an arm reach (link lengths plus tool offset) of "
                    f"{_range(lo, hi, 'm')}, found {_n(reach)} m (lengths are metres)",
                )
            )
        elif not REACH_USUAL_M[0] <= reach <= REACH_USUAL_M[1]:
            out.append(
                Finding(
                    "warning",
                    "[[joints]].a_m/d_m",
                    f"arm reach {_n(reach)} m (link lengths plus tool offset) is outside the "
                    f"usual {_range(*REACH_USUAL_M, 'm')} of industrial robots",
                )
            )
    m = robot.total_mass_kg
    if m < TOTAL_MASS_USUAL_KG:
        level: Literal["error", "warning"] = "error" if m < TOTAL_MASS_MIN_KG else "warning"
        out.append(
            Finding(
                level,
                "[[joints]].mass_kg",
                f"expected moving masses (links and end effector) of at least "
                f"{_n(TOTAL_MASS_MIN_KG if level == 'error' else TOTAL_MASS_USUAL_KG)} kg in "
                f"total, found {_n(m)} kg",
            )
        )
    return sorted(out, key=lambda f: f.level != "error")


def robot_warnings(robot: Robot) -> list[str]:
    """Every finding of ``robot`` as a line for a summary (``key: message``)."""
    return [str(f) for f in robot_findings(robot)]
