"""The updated model: the nominal robot plus what the diagnosis found.

Written as a folder::

    updated/
      robot.toml     # robolobe-robot/1: the nominal robot with the found changes
                     # that a robot file can hold (joint stiffness and damping
                     # factors, an added mass merged into the end effector)
      effects.toml   # format = "robolobe-effects/1"; [[effects]] tables for the
                     # rest (name = "tool_mode", f_hz = ..., ...), the
                     # robolobe.twin.effects.effect_to_dict form

``Twin(robot, effects)`` rebuilt from the folder (:func:`load_updated_model`)
gives the corrected receptance; ``effects.toml`` alone can be read with
:func:`read_effects` by any command that builds a twin.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from robolobe._atomic import atomic_dir, not_a_folder
from robolobe.errors import InputError
from robolobe.robots import Robot, load_robot, robot_to_toml
from robolobe.twin.effects import Effect
from robolobe.twin.effects_file import EFFECTS_FORMAT, effects_to_toml, read_effects
from robolobe.twin.model import Twin

__all__ = [
    "EFFECTS_FORMAT",
    "UPDATED_MODEL_FILES",
    "effects_to_toml",
    "load_updated_model",
    "read_effects",
    "write_updated_model",
]


#: The files :func:`write_updated_model` writes (checked before a run: :mod:`robolobe._atomic`).
UPDATED_MODEL_FILES: tuple[str, ...] = ("robot.toml", "effects.toml")


def write_updated_model(
    path: str | os.PathLike[str], robot: Robot, effects: Sequence[Effect], *, note: str = ""
) -> Path:
    """Write the updated model folder atomically.

    Robot-level effects (stage 0: joint stiffness/damping factors, added mass)
    are baked into ``robot.toml``; the others go to ``effects.toml``.

    Parameters
    ----------
    path : path-like
        Target folder.
    robot : Robot
        The nominal robot.
    effects : sequence of Effect
        The found effects.
    note : str
        What the diagnosis found (stored in ``effects.toml``).

    Returns
    -------
    Path
        The folder.
    """
    baked = [e for e in effects if e.stage == 0]
    rest = [e for e in effects if e.stage != 0]
    updated = Twin(robot, tuple(baked)).effective_robot
    if baked:
        names = ", ".join(e.name for e in baked)
        updated = updated.replace(name=f"{robot.name} (updated by diagnosis: {names})")
    target = Path(path)
    robot_name, effects_name = UPDATED_MODEL_FILES
    with atomic_dir(target, "updated-model", option="--updated-model") as tmp:
        (tmp / robot_name).write_text(robot_to_toml(updated), encoding="utf-8")
        (tmp / effects_name).write_text(effects_to_toml(rest, note=note), encoding="utf-8")
    return target


def load_updated_model(path: str | os.PathLike[str]) -> Twin:
    """The twin of an updated-model folder (:func:`write_updated_model`).

    Raises
    ------
    InputError
        Missing files or bad content.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise InputError(
            f"expected an updated-model folder, found {not_a_folder(folder)}", os.fspath(path)
        )
    robot = load_robot(folder / "robot.toml")
    return Twin(robot, read_effects(folder / "effects.toml"))
