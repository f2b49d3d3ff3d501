"""The flexible-joint digital twin and simulated hammer tests.

:class:`~robolobe.twin.model.Twin` holds a robot and optional physics effects
(:mod:`~robolobe.twin.effects`) and gives joint-space matrices, damped modes
(:class:`~robolobe.twin.modes.Modes`) and the TCP receptance over any frequency
grid. :mod:`~robolobe.twin.hammer` simulates impact tests on it,
:mod:`~robolobe.twin.campaign` simulates whole campaigns (the data type and
its files are :mod:`robolobe.campaign`), :mod:`~robolobe.twin.designs` makes
seed-like posture designs.
"""

from robolobe.twin.effects import EFFECTS, Effect, effect_from_dict, effect_to_dict
from robolobe.twin.model import Twin
from robolobe.twin.modes import Modes, compute_modes

__all__ = [
    "EFFECTS",
    "Effect",
    "Modes",
    "Twin",
    "compute_modes",
    "effect_from_dict",
    "effect_to_dict",
]
