"""Concealed "real" robots drawn from a robot file, for transfer studies and tests.

Study code, not the library: the studies and tests put ``studies/`` on
``sys.path`` and import it as ``concealed_robots``.

A robot file is an estimate of the robot that cuts. :func:`concealed_robot`
draws a physically valid robot that differs from the file the way real
robots do, in parameters a twin calibration fits and in some it cannot:

* joint stiffnesses x U(0.75, 1.3), joint dampings x U(0.6, 1.6), spindle
  mass and inertia x U(0.85, 1.15) (``file_error="joints"`` stops here);
* ``"full"`` also: every link's mass and inertia x U(0.9, 1.1), its centre
  of mass moved by N(0, 5 cm) per axis, and its inertia *shape* changed
  (:func:`perturb_inertia_shape`: principal second moments of the mass
  distribution x U(0.8, 1.2), principal axes turned by N(0, 10 deg));
* optionally a tool offset (the hammer-test point and TCP not where the file
  says; ``tool_offset_m`` standard deviation per axis).

Inertia-shape errors and tool offsets are model-form errors of a calibration
that fits masses, centres of mass and joint parameters only. The result goes
through the robot loader (written as TOML and read back), so it is a robot
file a user could have.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial.transform import Rotation

from robolobe.errors import InputError
from robolobe.robots.model import RigidBody, Robot

__all__ = ["concealed_robot", "perturb_inertia_shape", "through_loader"]

FloatArray = NDArray[np.float64]


def perturb_inertia_shape(
    inertia_kgm2: ArrayLike,
    rng: np.random.Generator,
    *,
    spread: float = 0.2,
    turn_deg: float = 10.0,
) -> FloatArray:
    """A physically valid inertia tensor of another shape, same body mass.

    The inertia about the centre of mass is ``I = tr(S) 1 - S`` with ``S``
    the (positive semidefinite) second moment of the mass distribution.
    Scaling the principal second moments ``s_i = tr(I) / 2 - I_i`` by
    positive factors keeps ``S`` semidefinite, so every principal moment stays
    at most the sum of the other two (the triangle inequality the loader
    checks); the principal axes are then turned about a random axis.

    Parameters
    ----------
    inertia_kgm2 : array_like, shape (3, 3)
        A valid inertia tensor [kg m^2].
    rng : numpy.random.Generator
    spread : float
        Second moments x U(1 - spread, 1 + spread), 0 <= spread < 1.
    turn_deg : float
        Standard deviation of the turn of the principal axes [deg].

    Returns
    -------
    ndarray, shape (3, 3)
    """
    if not 0 <= spread < 1:
        raise InputError(f"spread: expected 0 <= spread < 1, found {spread}")
    ev, vec = np.linalg.eigh(np.asarray(inertia_kgm2, dtype=float))
    s = np.clip(0.5 * ev.sum() - ev, 0.0, None)  # principal second moments [kg m^2]
    s = s * rng.uniform(1 - spread, 1 + spread, 3)
    moments = s.sum() - s
    axis = rng.normal(size=3)
    turn = Rotation.from_rotvec(axis / np.linalg.norm(axis) * np.radians(rng.normal(0, turn_deg)))
    axes = turn.as_matrix() @ vec
    out = axes @ np.diag(moments) @ axes.T
    return np.asarray(0.5 * (out + out.T))


def through_loader(robot: Robot) -> Robot:
    """``robot`` written as a robot TOML and loaded again (the loader's checks apply)."""
    from robolobe.robots import load_robot
    from robolobe.robots.io import save_robot

    with tempfile.TemporaryDirectory() as tmp:
        path = save_robot(robot, Path(tmp) / "robot.toml")
        return load_robot(path)


def concealed_robot(
    base: Robot,
    rng: np.random.Generator,
    *,
    file_error: str = "full",
    tool_offset_m: float = 0.0,
    name: str | None = None,
) -> Robot:
    """A "real" robot drawn from the robot file ``base`` (module docstring).

    Parameters
    ----------
    base : Robot
        The robot file.
    rng : numpy.random.Generator
    file_error : {"full", "joints"}
        What differs from the file.
    tool_offset_m : float
        Standard deviation per axis of the tool (TCP) offset in the tool
        frame [m]; 0: none.
    name : str, optional
        Default ``<base name>-truth``.

    Returns
    -------
    Robot
        Loaded from its own TOML file.
    """
    from robolobe.twin.params import COM_UNIT_M, apply_parameters

    if file_error not in ("full", "joints"):
        raise InputError(f"file_error: expected 'full' or 'joints', found {file_error!r}")
    theta = [
        np.log(rng.uniform(0.75, 1.3, 6)),
        np.log(rng.uniform(0.6, 1.6, 6)),
        np.log(rng.uniform(0.85, 1.15, 1)),
    ]
    groups: tuple[str, ...] = ("stiffness", "damping", "ee_mass")
    if file_error == "full":
        theta += [np.log(rng.uniform(0.9, 1.1, 6)), rng.normal(0.0, 0.05, 18) / COM_UNIT_M]
        groups = ("stiffness", "damping", "ee_mass", "link_mass", "link_com")
    truth = apply_parameters(base, groups, np.concatenate(theta))
    if file_error == "full":
        joints = tuple(
            dataclasses.replace(
                j,
                body=RigidBody(
                    j.body.mass_kg, j.body.com_m, perturb_inertia_shape(j.body.inertia_kgm2, rng)
                ),
            )
            for j in truth.joints
        )
        truth = truth.replace(joints=joints)
    if tool_offset_m > 0:
        shift = np.eye(4)
        shift[:3, 3] = rng.normal(0.0, tool_offset_m, 3)
        truth = truth.replace(tool=truth.tool @ shift)
    return through_loader(truth.replace(name=name or f"{base.name}-truth"))
