"""The robolobe error hierarchy.

Every error that reaches a user derives from :class:`RobolobeError`. Messages
name the file, line or key, what was expected and what was found; the CLI
prints them as one line and exits with code 2 (:data:`EXIT_INPUT`), or 3 for
an infeasible plan (:data:`EXIT_INFEASIBLE`).
"""

from __future__ import annotations

__all__ = [
    "EXIT_INFEASIBLE",
    "EXIT_INPUT",
    "ConvergenceError",
    "InfeasibleError",
    "InputError",
    "InputTypeError",
    "ReachabilityError",
    "RobolobeError",
    "SingularityError",
]

EXIT_INPUT = 2
EXIT_INFEASIBLE = 3


class RobolobeError(Exception):
    """Base class of all errors robolobe raises on purpose."""

    exit_code: int = EXIT_INPUT


class InputError(RobolobeError, ValueError):
    """Bad user input: a file, a key, a column, a value out of range.

    Parameters
    ----------
    message : str
        What was expected and what was found.
    source : str, optional
        File name (and ``:line`` or ``[key]``) the problem was found in;
        prefixed to the message.
    """

    def __init__(self, message: str, source: str | None = None) -> None:
        self.source = source
        self.detail = message
        super().__init__(f"{source}: {message}" if source else message)


class InputTypeError(InputError, TypeError):
    """An argument of the Python API of the wrong type (also a :class:`TypeError`).

    Parameters
    ----------
    argument : str
        The parameter's name.
    expected : str
        The types it takes, in words (``"a path or a Job"``).
    value : object
        What was given; the message names its type.
    """

    def __init__(self, argument: str, expected: str, value: object) -> None:
        super().__init__(f"expected {expected}, found {_type_name(value)}", source=argument)


def _type_name(value: object) -> str:
    if value is None:
        return "None"
    if isinstance(value, str):
        return f"the string {value!r}"
    module = type(value).__module__.split(".")[0]
    name = type(value).__qualname__
    if module != "builtins":
        name = f"{module}.{name}"
    return f"{'an' if name[0] in 'aeiou' else 'a'} {name}"


class ReachabilityError(RobolobeError):
    """A pose the robot cannot reach (outside the workspace or the limits)."""


class SingularityError(ReachabilityError):
    """A pose at (or too close to) a kinematic singularity."""


class ConvergenceError(RobolobeError):
    """An iterative method did not converge to an acceptable answer."""


class InfeasibleError(RobolobeError):
    """No plan satisfies the constraints (the reason says where and why)."""

    exit_code = EXIT_INFEASIBLE
