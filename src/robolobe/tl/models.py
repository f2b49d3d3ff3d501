"""The shipped models: robot A pretrained, B and C transferred from it.

They live in ``robolobe/data/models/{A,B,C}.npz`` (format of
:meth:`robolobe.tl.estimator.ModalPredictor.save`) with their provenance in
``models.json``, and are made again, bit for bit from the same seed, by
``python studies/make_models.py`` (twin campaigns of the seed's designs,
identified-like data, the ``"improved"`` preset).
"""

from __future__ import annotations

import contextlib
import json
import os
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robolobe._atomic import check_input_file
from robolobe.errors import InputError
from robolobe.tl.estimator import ModalPredictor

if TYPE_CHECKING:
    from robolobe.tl.residual import CorrectedTwin

__all__ = ["SHIPPED", "check_model_robot", "load_model", "model_robot_names", "shipped_info"]

#: Keys of the shipped models.
SHIPPED: tuple[str, ...] = ("A", "B", "C")


def _ref(name: str) -> Any:
    return resources.files("robolobe.data").joinpath("models", name)


def shipped_info() -> dict[str, Any]:
    """Provenance of the shipped models (``models.json``), {} if absent."""
    ref = _ref("models.json")
    if not ref.is_file():
        return {}
    data: dict[str, Any] = json.loads(ref.read_text(encoding="utf-8"))
    return data


def load_model(spec: str | Path) -> ModalPredictor | CorrectedTwin:
    """A shipped model by key (``"A"``, ``"B"``, ``"C"``) or a model file.

    A model file is a network (:class:`ModalPredictor`) or a calibrated twin
    with its learned correction (:class:`robolobe.tl.residual.CorrectedTwin`,
    from ``robolobe transfer --robot R``); both predict modes with spread.

    Raises
    ------
    InputError
        Unknown key, missing or unreadable file.
    """
    key = str(spec)
    if key.upper() in SHIPPED and not Path(key).exists():
        ref = _ref(f"{key.upper()}.npz")
        with resources.as_file(ref) as path:
            if not path.is_file():
                raise InputError(
                    "shipped model missing; run python studies/make_models.py",
                    source=f"robolobe/data/models/{key.upper()}.npz",
                )
            return ModalPredictor.load(path)
    path = check_input_file(
        key, f"a model file or one of the shipped models {', '.join(SHIPPED)}", key
    )
    from robolobe.tl.residual import CorrectedTwin, is_corrected_twin_file

    if is_corrected_twin_file(path):
        return CorrectedTwin.load(path)
    return ModalPredictor.load(path)


def model_robot_names(model: object) -> set[str]:
    """Names of the robot a model was made for (empty: the model does not say).

    A corrected twin holds its robot file (its name and the calibrated
    name); a network holds a label: a built-in key (``"B"``) or the robot
    file it was transferred to (read for its name when it still exists).
    """
    from robolobe.robots import load_robot
    from robolobe.robots.model import Robot

    names: set[str] = set()
    for attr in ("robot", "robot_"):
        label = getattr(model, attr, None)
        if isinstance(label, Robot):
            names.add(label.name)
    cal = getattr(model, "calibration_", None)
    base = getattr(cal, "base_robot_", None)
    if isinstance(base, Robot):
        names.add(base.name)
    label = getattr(model, "robot", None)
    if isinstance(label, str | os.PathLike) and str(label):
        spec = os.fspath(label)
        if spec.upper() in SHIPPED or Path(spec).is_file():
            # a robot file that moved or changed: the model cannot say
            with contextlib.suppress(InputError):
                names.add(load_robot(spec).name)
    return names


def check_model_robot(model: object, robot: Any, what: str) -> None:
    """Refuse a model made for another robot than ``robot``.

    Parameters
    ----------
    model : ModalPredictor or CorrectedTwin
    robot : Robot
        The robot the model is about to be used with.
    what : str
        The option or key that named the model, for the message.

    Raises
    ------
    InputError
        When the model names its robot and it is not ``robot``.
    """
    made = model_robot_names(model)
    if made and robot.name not in made:
        raise InputError(
            f"expected a model of robot {robot.name!r}, found one made for "
            f"{' / '.join(sorted(made))!r} (its modes belong to that robot)",
            source=what,
        )
