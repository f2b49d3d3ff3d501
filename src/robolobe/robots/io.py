"""Robot description files (``format = "robolobe-robot/1"``, docs/guide/robots.md).

:func:`load_robot` reads a built-in robot ("A", "B", "C") or a TOML file,
validates it (pydantic at the file edge) and returns a :class:`Robot`.
Every problem raises :class:`~robolobe.errors.InputError` naming the file and
the key path, e.g. ``B.toml: [[joints]][3].stiffness_Nm_per_rad: expected a
positive number, found -5``. Indices in key paths count from 1 (joint 3 is
``[[joints]][3]``). Unknown keys are allowed; those that look like a typo of
a known key are logged as warnings.

Inertias in files are ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]``: the entries of the
inertia tensor about the COM (products as tensor entries, i.e.
``Ixy = -integral(x y dm)``, the URDF convention).
"""

from __future__ import annotations

import logging
import math
import os
from importlib import resources
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
import tomli_w
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from robolobe._atomic import not_a_file
from robolobe._documents import parse_toml
from robolobe._toml_errors import (
    PrintableText,
    check_key_typos,
    describe_error,
    found,
    key_path,
)
from robolobe.errors import InputError, InputTypeError
from robolobe.robots.model import Joint, LinearConstraint, RigidBody, Robot
from robolobe.robots.plausibility import check_inertia_range, robot_findings
from robolobe.robots.transforms import pose_from_xyz_zyx, xyz_zyx_from_pose

__all__ = [
    "BUILTIN_ROBOTS",
    "FORMAT",
    "builtin_path",
    "inertia_from_components",
    "inertia_to_components",
    "load_robot",
    "robot_from_dict",
    "robot_to_dict",
    "robot_to_toml",
    "save_robot",
]

logger = logging.getLogger(__name__)

FORMAT = "robolobe-robot/1"
BUILTIN_ROBOTS = ("A", "B", "C")

# ------------------------------------------------------------------ schema
Num = Annotated[float, Field(allow_inf_nan=False, strict=True)]
PosNum = Annotated[float, Field(gt=0, allow_inf_nan=False, strict=True)]
NonNegNum = Annotated[float, Field(ge=0, allow_inf_nan=False, strict=True)]
Vec3 = Annotated[list[Num], Field(min_length=3, max_length=3)]
Vec6 = Annotated[list[Num], Field(min_length=6, max_length=6)]
# optional compliances (README "Robot description"): stiffness in (0, 1e12] N m/rad,
# damping in [0, 1e9] N m s/rad, one value per tilt axis
_TiltK = Annotated[float, Field(gt=0, le=1e12, allow_inf_nan=False, strict=True)]
_TiltC = Annotated[float, Field(ge=0, le=1e9, allow_inf_nan=False, strict=True)]
PairK = Annotated[list[_TiltK], Field(min_length=2, max_length=2)]
PairC = Annotated[list[_TiltC], Field(min_length=2, max_length=2)]
# load-dependent joint stiffness: relative stiffening per kN m of gravity torque, [0, 100]
_LoadS = Annotated[float, Field(ge=0, le=100, allow_inf_nan=False, strict=True)]


class _Spec(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True)


class _PoseSpec(_Spec):
    xyz_m: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])
    zyx_deg: Vec3 = Field(default_factory=lambda: [0.0, 0.0, 0.0])


class _ConstraintSpec(_Spec):
    coeffs: Vec6
    min_deg: Num
    max_deg: Num


class _KinematicsSpec(_Spec):
    convention: Literal["standard-dh", "modified-dh"]
    base: _PoseSpec | None = None
    coupling: Annotated[list[Vec6], Field(min_length=6, max_length=6)] | None = None
    constraints: list[_ConstraintSpec] = Field(default_factory=list)


class _BodySpec(_Spec):
    mass_kg: NonNegNum
    com_m: Vec3
    inertia_kgm2: Vec6


class _EndEffectorSpec(_BodySpec):
    mount_stiffness_Nm_per_rad: PairK | None = None
    mount_damping_Nms_per_rad: PairC | None = None


class _JointSpec(_Spec):
    a_m: Num
    alpha_deg: Num
    d_m: Num
    theta_offset_deg: Num = 0.0
    q_min_deg: Num
    q_max_deg: Num
    mass_kg: NonNegNum
    com_m: Vec3
    inertia_kgm2: Vec6
    stiffness_Nm_per_rad: PosNum
    damping_Nms_per_rad: NonNegNum
    tilt_stiffness_Nm_per_rad: PairK | None = None
    tilt_damping_Nms_per_rad: PairC | None = None
    load_stiffening_per_kNm: _LoadS = 0.0


class _RobotSpec(_Spec):
    name: Annotated[PrintableText, Field(min_length=1)]
    format: Literal["robolobe-robot/1"]
    kinematics: _KinematicsSpec
    tool: _PoseSpec = Field(default_factory=_PoseSpec)
    end_effector: _EndEffectorSpec | None = None
    joints: Annotated[list[_JointSpec], Field(min_length=6, max_length=6)]
    # TCP path speed while milling [mm/s]; 1e5 mm/s (100 m/s) is far above any arm: a unit slip
    max_path_speed_mm_per_s: (
        Annotated[float, Field(gt=0, le=1e5, allow_inf_nan=False, strict=True)] | None
    ) = None


_KNOWN_KEYS: dict[str, set[str]] = {
    "": set(_RobotSpec.model_fields),
    "kinematics": set(_KinematicsSpec.model_fields),
    "kinematics.base": set(_PoseSpec.model_fields),
    "kinematics.constraints": set(_ConstraintSpec.model_fields),
    "tool": set(_PoseSpec.model_fields),
    "end_effector": set(_EndEffectorSpec.model_fields),
    "joints": set(_JointSpec.model_fields),
}


# ------------------------------------------------------------ key paths
def _check_typos(raw: dict[str, Any], where: str) -> None:
    kin = raw.get("kinematics")
    tables: list[tuple[Any, set[str], str]] = [
        (raw, _KNOWN_KEYS[""], ""),
        (kin, _KNOWN_KEYS["kinematics"], "kinematics."),
        (raw.get("tool"), _KNOWN_KEYS["tool"], "tool."),
        (raw.get("end_effector"), _KNOWN_KEYS["end_effector"], "end_effector."),
    ]
    if isinstance(kin, dict):
        tables.append((kin.get("base"), _KNOWN_KEYS["kinematics.base"], "kinematics.base."))
        cons = kin.get("constraints")
        if isinstance(cons, list):
            tables += [
                (c, _KNOWN_KEYS["kinematics.constraints"], f"kinematics.constraints[{i + 1}].")
                for i, c in enumerate(cons)
            ]
    joints = raw.get("joints")
    if isinstance(joints, list):
        tables += [
            (j, _KNOWN_KEYS["joints"], f"[[joints]][{i + 1}].") for i, j in enumerate(joints)
        ]
    check_key_typos(tables, where)


# -------------------------------------------------------------- inertia
def inertia_from_components(c: Any) -> np.ndarray:
    """3x3 tensor from ``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` [kg m^2]."""
    ixx, iyy, izz, ixy, ixz, iyz = (float(x) for x in c)
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])


def inertia_to_components(inertia: np.ndarray) -> list[float]:
    """``[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` of a 3x3 tensor [kg m^2]."""
    i = np.asarray(inertia, dtype=np.float64)
    return [float(i[0, 0]), float(i[1, 1]), float(i[2, 2]),
            float(i[0, 1]), float(i[0, 2]), float(i[1, 2])]  # fmt: skip


def _body(spec: _BodySpec | _JointSpec, key: str, where: str) -> RigidBody:
    check_inertia_range(spec.mass_kg, spec.inertia_kgm2, key, where)
    inertia = inertia_from_components(spec.inertia_kgm2)
    eig = np.linalg.eigvalsh(inertia)
    scale = max(float(np.max(np.abs(eig))), 1e-300)
    tol = 1e-9 * scale
    ok = bool(np.all(eig > tol)) if spec.mass_kg > 0 else bool(np.all(eig >= -tol))
    # physical consistency: each principal moment <= sum of the other two
    ok = ok and bool(eig[2] <= eig[0] + eig[1] + tol)
    if not ok:
        what = "positive-definite" if spec.mass_kg > 0 else "positive-semidefinite"
        raise InputError(
            f"{key}.inertia_kgm2: expected a {what} inertia tensor satisfying the triangle "
            f"inequality, found principal moments {', '.join(f'{v:.4g}' for v in eig)} kg m^2",
            source=where,
        )
    return RigidBody(mass_kg=spec.mass_kg, com_m=np.array(spec.com_m), inertia_kgm2=inertia)


def _pose(spec: _PoseSpec | None) -> np.ndarray:
    if spec is None:
        return np.eye(4)
    return pose_from_xyz_zyx(spec.xyz_m, np.radians(spec.zyx_deg))


# --------------------------------------------------------------- loading
def _opt_pair(v: list[float] | None) -> tuple[float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]))


def _both(k: list[float] | None, c: list[float] | None, key: str, what: str, where: str) -> None:
    """The stiffness and damping of an optional compliance come together."""
    if (k is None) != (c is None):
        have, miss = (
            (f"{what}_stiffness_Nm_per_rad", f"{what}_damping_Nms_per_rad")
            if c is None
            else (f"{what}_damping_Nms_per_rad", f"{what}_stiffness_Nm_per_rad")
        )
        raise InputError(
            f"{key}.{miss}: expected two numbers beside {have}, found it missing", where
        )


def _build(d: dict[str, Any], source: str, where: str) -> Robot:
    if not isinstance(d, dict):
        raise InputError(f"expected a table at the top level, found {found(d)}", source=where)
    _check_typos(d, where)
    try:
        spec = _RobotSpec.model_validate(d)
    except ValidationError as exc:
        errs = exc.errors(include_url=False)
        first = errs[0]
        loc = tuple(first["loc"])
        if loc == ("joints",) and first["type"] in ("too_short", "too_long"):
            n = len(first["input"]) if isinstance(first["input"], list) else "?"
            msg = f"[[joints]]: expected exactly 6 joints, found {n}"
        else:
            msg = f"{key_path(loc, table_arrays=('joints',))}: {describe_error(first)}"
        if len(errs) > 1:
            msg += f" (and {len(errs) - 1} more problem{'s' if len(errs) > 2 else ''})"
        raise InputError(msg, source=where) from None

    kin = spec.kinematics
    coupling = np.eye(6) if kin.coupling is None else np.array(kin.coupling, dtype=np.float64)
    if abs(np.linalg.det(coupling)) < 1e-9:
        raise InputError(
            "kinematics.coupling: expected an invertible 6x6 matrix, found a singular one",
            source=where,
        )
    constraints = []
    for i, c in enumerate(kin.constraints):
        key = f"kinematics.constraints[{i + 1}]"
        if not any(abs(x) > 0 for x in c.coeffs):
            raise InputError(f"{key}.coeffs: expected a nonzero row, found all zeros", where)
        if not c.min_deg < c.max_deg:
            raise InputError(
                f"{key}: expected min_deg < max_deg, found {c.min_deg} >= {c.max_deg}", where
            )
        constraints.append(
            LinearConstraint(
                coeffs=np.array(c.coeffs),
                lo_rad=math.radians(c.min_deg),
                hi_rad=math.radians(c.max_deg),
            )
        )
    joints = []
    for i, j in enumerate(spec.joints):
        key = f"[[joints]][{i + 1}]"
        if not j.q_min_deg < j.q_max_deg:
            raise InputError(
                f"{key}: expected q_min_deg < q_max_deg, found {j.q_min_deg} >= {j.q_max_deg}",
                where,
            )
        _both(j.tilt_stiffness_Nm_per_rad, j.tilt_damping_Nms_per_rad, key, "tilt", where)
        joints.append(
            Joint(
                a_m=j.a_m,
                alpha_rad=math.radians(j.alpha_deg),
                d_m=j.d_m,
                theta_offset_rad=math.radians(j.theta_offset_deg),
                q_min_rad=math.radians(j.q_min_deg),
                q_max_rad=math.radians(j.q_max_deg),
                body=_body(j, key, where),
                stiffness_Nm_per_rad=j.stiffness_Nm_per_rad,
                damping_Nms_per_rad=j.damping_Nms_per_rad,
                tilt_stiffness_Nm_per_rad=_opt_pair(j.tilt_stiffness_Nm_per_rad),
                tilt_damping_Nms_per_rad=_opt_pair(j.tilt_damping_Nms_per_rad),
                load_stiffening_per_Nm=j.load_stiffening_per_kNm / 1e3,
            )
        )
    ee = None if spec.end_effector is None else _body(spec.end_effector, "end_effector", where)
    mount_k = mount_c = None
    if spec.end_effector is not None:
        e = spec.end_effector
        _both(e.mount_stiffness_Nm_per_rad, e.mount_damping_Nms_per_rad, "end_effector", "mount",
              where)  # fmt: skip
        mount_k, mount_c = (
            _opt_pair(e.mount_stiffness_Nm_per_rad),
            _opt_pair(e.mount_damping_Nms_per_rad),
        )
        if mount_k is not None and e.mass_kg <= 0:
            raise InputError(
                "end_effector.mount_stiffness_Nm_per_rad: expected an end effector with mass "
                "(a compliant mount carries it), found mass_kg = 0",
                where,
            )
    robot = Robot(
        name=spec.name,
        convention=kin.convention,
        joints=tuple(joints),
        base=_pose(kin.base),
        coupling=coupling,
        tool=_pose(spec.tool),
        end_effector=ee,
        constraints=tuple(constraints),
        source=source,
        mount_stiffness_Nm_per_rad=mount_k,
        mount_damping_Nms_per_rad=mount_c,
        max_path_speed_m_per_s=(
            None if spec.max_path_speed_mm_per_s is None else spec.max_path_speed_mm_per_s * 1e-3
        ),
    )
    findings = robot_findings(robot)
    for f in findings:
        if f.level == "error":
            raise InputError(str(f), where)
        logger.warning("%s: %s", where, f)
    return robot


def robot_from_dict(d: dict[str, Any], source: str) -> Robot:
    """Validate a parsed robot description and build a :class:`Robot`.

    Parameters
    ----------
    d : dict
        The parsed TOML document (docs/guide/robots.md).
    source : str
        Where it came from (file name); prefixes error messages and is stored
        in :attr:`Robot.source`.

    Raises
    ------
    InputError
        Naming ``source`` and the key path of the first problem.
    """
    return _build(d, source, source)


def builtin_path(name: str) -> Path:
    """Path of the built-in robot file ``name`` ("A", "B" or "C")."""
    key = name.upper()
    if key not in BUILTIN_ROBOTS:
        raise InputError(f"expected a built-in robot {BUILTIN_ROBOTS} or a file, found {name!r}")
    return Path(str(resources.files("robolobe.data").joinpath("robots", f"{key}.toml")))


def load_robot(spec: str | os.PathLike[str] | Robot) -> Robot:
    """Load a built-in robot or a robot file.

    Parameters
    ----------
    spec : str or path-like or Robot
        ``"A"``, ``"B"``, ``"C"`` (built-in, case-insensitive) or the path of
        a ``robolobe-robot/1`` TOML file (a :class:`Robot` is returned as it is).

    Returns
    -------
    Robot

    Raises
    ------
    InputError
        Unreadable file, TOML syntax error (with its line) or invalid content
        (naming the key).
    """
    if isinstance(spec, Robot):
        return spec
    if not isinstance(spec, str | os.PathLike):
        raise InputTypeError("robot", "'A', 'B', 'C', a robot file's path or a Robot", spec)
    text_spec = os.fspath(spec)
    if isinstance(spec, str) and spec.upper() in BUILTIN_ROBOTS and not Path(spec).is_file():
        key = spec.upper()
        path = builtin_path(key)
        where, source = f"{key}.toml", f"built-in {key}"
    else:
        path = Path(text_spec)
        where = source = text_spec
        if not path.is_file():
            raise InputError(
                f"expected a built-in robot {', '.join(BUILTIN_ROBOTS)} or a robot file, "
                f"found {not_a_file(path)}",
                source=where,
            )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"cannot read the file: {exc}", source=where) from None
    return _build(parse_toml(text, where), source, where)


# --------------------------------------------------------------- writing
def _clean(x: float) -> float | int:
    v = float(x)
    r = round(v, 12)
    if abs(v - r) <= 1e-15 * max(1.0, abs(v)):
        v = r
    return v + 0.0  # no -0.0


def _pose_dict(pose: np.ndarray) -> dict[str, list[float | int]]:
    xyz, zyx = xyz_zyx_from_pose(pose)
    return {"xyz_m": [_clean(v) for v in xyz], "zyx_deg": [_clean(v) for v in np.degrees(zyx)]}


def _body_dict(body: RigidBody) -> dict[str, Any]:
    return {
        "mass_kg": _clean(body.mass_kg),
        "com_m": [_clean(v) for v in body.com_m],
        "inertia_kgm2": [_clean(v) for v in inertia_to_components(body.inertia_kgm2)],
    }


def robot_to_dict(robot: Robot) -> dict[str, Any]:
    """The file content (docs/guide/robots.md) of ``robot`` as a dict."""
    kin: dict[str, Any] = {"convention": robot.convention}
    if not np.allclose(robot.base, np.eye(4), rtol=0, atol=0):
        kin["base"] = _pose_dict(robot.base)
    if not np.array_equal(robot.coupling, np.eye(6)):
        kin["coupling"] = [[_clean(v) for v in row] for row in robot.coupling]
    if robot.constraints:
        kin["constraints"] = [
            {
                "coeffs": [_clean(v) for v in c.coeffs],
                "min_deg": _clean(math.degrees(c.lo_rad)),
                "max_deg": _clean(math.degrees(c.hi_rad)),
            }
            for c in robot.constraints
        ]
    out: dict[str, Any] = {
        "name": robot.name,
        "format": FORMAT,
        "kinematics": kin,
        "tool": _pose_dict(robot.tool),
    }
    if robot.max_path_speed_m_per_s is not None:
        out["max_path_speed_mm_per_s"] = _clean(robot.max_path_speed_m_per_s * 1e3)
    if robot.end_effector is not None:
        out["end_effector"] = _body_dict(robot.end_effector)
        if robot.mount_stiffness_Nm_per_rad is not None:
            out["end_effector"]["mount_stiffness_Nm_per_rad"] = _pair_out(
                robot.mount_stiffness_Nm_per_rad
            )
            out["end_effector"]["mount_damping_Nms_per_rad"] = _pair_out(
                robot.mount_damping_Nms_per_rad
            )
    out["joints"] = [
        {
            "a_m": _clean(j.a_m),
            "alpha_deg": _clean(math.degrees(j.alpha_rad)),
            "d_m": _clean(j.d_m),
            "theta_offset_deg": _clean(math.degrees(j.theta_offset_rad)),
            "q_min_deg": _clean(math.degrees(j.q_min_rad)),
            "q_max_deg": _clean(math.degrees(j.q_max_rad)),
            **_body_dict(j.body),
            "stiffness_Nm_per_rad": _clean(j.stiffness_Nm_per_rad),
            "damping_Nms_per_rad": _clean(j.damping_Nms_per_rad),
            **(
                {
                    "tilt_stiffness_Nm_per_rad": _pair_out(j.tilt_stiffness_Nm_per_rad),
                    "tilt_damping_Nms_per_rad": _pair_out(j.tilt_damping_Nms_per_rad),
                }
                if j.has_tilt
                else {}
            ),
            **(
                {"load_stiffening_per_kNm": _clean(j.load_stiffening_per_Nm * 1e3)}
                if j.load_stiffening_per_Nm > 0
                else {}
            ),
        }
        for j in robot.joints
    ]
    return out


def _pair_out(v: tuple[float, float] | None) -> list[float | int]:
    assert v is not None
    return [_clean(x) for x in v]


def robot_to_toml(robot: Robot) -> str:
    """Serialize ``robot`` as a ``robolobe-robot/1`` TOML document.

    ``load_robot`` of the result equals ``robot`` numerically (see
    :func:`~robolobe.robots.model.robots_allclose`); comments are not kept.
    """
    return tomli_w.dumps(robot_to_dict(robot))


def save_robot(robot: Robot, path: str | os.PathLike[str]) -> Path:
    """Write ``robot`` to ``path`` atomically; returns the path."""
    from robolobe._atomic import atomic_write_text

    target = Path(path)
    atomic_write_text(target, robot_to_toml(robot))
    return target
