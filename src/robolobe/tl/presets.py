"""Named parameter sets of :class:`robolobe.tl.estimator.ModalPredictor`.

* ``"paper"``: the seed's method as published (section 2.3): raw joint
  angles min-max-scaled, targets min-max-scaled, gaps interpolated along the
  posture order, 5 x 32 ReLU, Adam, MSE, batch 8, 500 epochs, augmentation
  delta 0.10; transfer with 3 frozen layers.
* ``"improved"``: the same network and schedule with sin/cos features of
  joints 2-6 (joint 1 turns the whole arm: no effect on the modes without
  gravity), log frequency / log damping / sqrt-compliance targets, masked
  gaps and no augmentation (measured: no gain, 5x the training time;
  :mod:`robolobe.tl.preprocess`). The default of the shipped models, chosen
  by the accuracy study (studies/tl_accuracy.py).

Both use a 5-member deep ensemble per direction for the spread.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Any

__all__ = ["DEFAULT_PRESET", "PRESETS"]

_COMMON: dict[str, Any] = {
    "directions": ("xx", "yy"),
    "n_modes": 5,
    "hidden": (32, 32, 32, 32, 32),
    "epochs": 500,
    "batch_size": 8,
    "learning_rate": 1e-3,
    "augment_delta": 0.10,
    "augment_copies": 4,
    "n_members": 5,
    "n_frozen": 3,
}

PRESETS: MappingProxyType[str, MappingProxyType[str, Any]] = MappingProxyType(
    {
        "paper": MappingProxyType(
            {
                **_COMMON,
                "features": "angles",
                "target_transform": "minmax",
                "missing": "interpolate",
            }
        ),
        "improved": MappingProxyType(
            {
                **_COMMON,
                "features": "trig5",
                "target_transform": "flex",
                "missing": "mask",
                "augment_delta": 0.0,
                "augment_copies": 0,
            }
        ),
    }
)
DEFAULT_PRESET = "improved"
