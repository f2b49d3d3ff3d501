"""robolobe.plan: chatter-free spindle speed and depth along a toolpath.

Job files (:mod:`~robolobe.plan.job`), toolpath readers
(:mod:`~robolobe.plan.paths`), the per-waypoint pipeline
(:mod:`~robolobe.plan.pipeline`: IK, modes, tool-point FRFs, lobes), the
optimizer (:mod:`~robolobe.plan.optimize`: global search, casadi refinement,
exact verification), outputs (:mod:`~robolobe.plan.report`), robot comparison
(:mod:`~robolobe.plan.compare`) and batch planning (:mod:`~robolobe.plan.batch`).

Typical use::

    from robolobe.plan import load_job, plan_path, write_outputs

    res = plan_path("pocket.nc", load_job("job.toml"))
    write_outputs(res, "out")
    print(res.summary.mrr_cm3_per_min, res.summary.min_margin)

The names below are imported lazily (the optimizer and the plots pull in
scipy, casadi and matplotlib only when used).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = [
    "Job",
    "PlanResult",
    "PlanSummary",
    "ProcessLimits",
    "batch_plan",
    "compare_robots",
    "load_job",
    "plan_path",
    "process_limits",
    "read_toolpath",
    "write_outputs",
]

_WHERE = {
    "Job": "robolobe.plan.job",
    "load_job": "robolobe.plan.job",
    "PlanResult": "robolobe.plan.pipeline",
    "PlanSummary": "robolobe.plan._summary",
    "plan_path": "robolobe.plan.pipeline",
    "read_toolpath": "robolobe.plan.paths",
    "write_outputs": "robolobe.plan.report",
    "compare_robots": "robolobe.plan.compare",
    "batch_plan": "robolobe.plan.batch",
    "ProcessLimits": "robolobe.plan.limits",
    "process_limits": "robolobe.plan.limits",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'robolobe.plan' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*globals(), *__all__])
