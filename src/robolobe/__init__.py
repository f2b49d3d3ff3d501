"""robolobe: chatter-free milling plans for industrial robots.

The public Python API, imported lazily (``import robolobe as rl`` costs
nothing until a name is used)::

    import robolobe as rl

    campaign = rl.read_campaign("camp")                  # hammer tests (CSV or UFF 58)
    modal = rl.identify(campaign)                        # modal parameters per posture
    model = rl.transfer(modal.table, robot="B")          # calibrated twin + correction
    job = rl.load_job("job_B_contour.toml")
    plan = rl.plan_path("contour.apt", job, modes=model)
    rl.write_plan(plan, "out")                           # waypoints, summary, plots, report

Subpackages (each owns one concept, docs/guide/physics.md): :mod:`robolobe.robots`,
:mod:`robolobe.campaign` (measured data), :mod:`robolobe.twin`,
:mod:`robolobe.modal`, :mod:`robolobe.tl`, :mod:`robolobe.sld`, :mod:`robolobe.stock`,
:mod:`robolobe.plan`, :mod:`robolobe.diagnose`, :mod:`robolobe.cli`.
"""

from __future__ import annotations

import importlib
from typing import Any

from robolobe.errors import (
    ConvergenceError,
    InfeasibleError,
    InputError,
    InputTypeError,
    ReachabilityError,
    RobolobeError,
    SingularityError,
)

__version__ = "0.1.0"

#: Public name -> (module, attribute).
_API: dict[str, tuple[str, str]] = {
    # robots and their twins
    "load_robot": ("robolobe.robots", "load_robot"),
    "Twin": ("robolobe.twin.model", "Twin"),
    # measured data and modal identification
    "read_campaign": ("robolobe.campaign", "read_campaign"),
    "write_campaign": ("robolobe.campaign", "write_campaign"),
    "identify": ("robolobe.modal.identify", "identify_campaign"),
    "read_modal_csv": ("robolobe.modal.modal_csv", "read_modal_csv"),
    "read_modal_parameters": ("robolobe.modal.modal_csv", "read_modal_parameters"),
    # the one modal-parameter type (twin, identification, predictors -> planning, lobes)
    "ModalParameters": ("robolobe._modal_parameters", "ModalParameters"),
    # mode predictors (estimators: fit / predict / save)
    "CorrectedTwin": ("robolobe.tl.residual", "CorrectedTwin"),
    "TwinCalibration": ("robolobe.tl.graybox", "TwinCalibration"),
    "ModalPredictor": ("robolobe.tl.estimator", "ModalPredictor"),
    "load_model": ("robolobe.tl.models", "load_model"),
    "transfer": ("robolobe.tl.transfer", "transfer"),
    # stability lobes
    "stability_lobes": ("robolobe.sld", "stability_lobes"),
    # stock and engagement per move
    "Stock": ("robolobe.stock.shapes", "Stock"),
    "compute_engagement": ("robolobe.stock.engagement", "compute_engagement"),
    # planning
    "load_job": ("robolobe.plan.job", "load_job"),
    "read_toolpath": ("robolobe.plan.paths", "read_toolpath"),
    "plan_path": ("robolobe.plan.pipeline", "plan_path"),
    "PlanSummary": ("robolobe.plan._summary", "PlanSummary"),
    "write_plan": ("robolobe.plan.report", "write_outputs"),
    "write_program": ("robolobe.plan.program", "write_program"),
    "verify": ("robolobe.plan.verify", "verify_plan"),
    "check_program": ("robolobe.plan.check", "check_program"),
    "compare_robots": ("robolobe.plan.compare", "compare_robots"),
    # diagnosis (not "diagnose": importing robolobe.diagnose would replace it
    # by the subpackage of that name)
    "diagnose_campaign": ("robolobe.diagnose.pipeline", "diagnose"),
}

__all__ = [
    "ConvergenceError",
    "InfeasibleError",
    "InputError",
    "InputTypeError",
    "ReachabilityError",
    "RobolobeError",
    "SingularityError",
    "__version__",
    *sorted(_API),
]


def __getattr__(name: str) -> Any:
    try:
        module, attr = _API[name]
    except KeyError:
        raise AttributeError(f"module 'robolobe' has no attribute {name!r}") from None
    value = getattr(importlib.import_module(module), attr)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
