"""The shipped models: robot A pretrained, B and C transferred from it.

They live in ``robolobe/data/models/{A,B,C}.npz`` (format of
:meth:`robolobe.tl.estimator.ModalPredictor.save`) with their provenance in
``models.json``, and are made again, bit for bit from the same seed, by
``python studies/make_models.py`` (twin campaigns of the seed's designs,
identified-like data, the ``"improved"`` preset).
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

from robolobe.errors import InputError
from robolobe.tl.estimator import ModalPredictor

if TYPE_CHECKING:
    from robolobe.tl.residual import CorrectedTwin

__all__ = ["SHIPPED", "load_model", "shipped_info"]

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
    path = Path(key)
    if not path.is_file():
        raise InputError(
            f"expected a model file or one of the shipped models {', '.join(SHIPPED)}, "
            f"found {key!r}",
            source="MODEL",
        )
    from robolobe.tl.residual import CorrectedTwin, is_corrected_twin_file

    if is_corrected_twin_file(path):
        return CorrectedTwin.load(path)
    return ModalPredictor.load(path)
