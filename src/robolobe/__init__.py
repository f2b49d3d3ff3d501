"""robolobe: chatter-free milling plans for industrial robots.

Subpackages (each owns one concept, DESIGN.md): :mod:`robolobe.robots`,
:mod:`robolobe.twin`, :mod:`robolobe.modal`, :mod:`robolobe.tl`,
:mod:`robolobe.sld`, :mod:`robolobe.plan`, :mod:`robolobe.diagnose`,
:mod:`robolobe.cli`.
"""

from robolobe.errors import (
    ConvergenceError,
    InfeasibleError,
    InputError,
    ReachabilityError,
    RobolobeError,
    SingularityError,
)

__version__ = "0.1.0"

__all__ = [
    "ConvergenceError",
    "InfeasibleError",
    "InputError",
    "ReachabilityError",
    "RobolobeError",
    "SingularityError",
    "__version__",
]
