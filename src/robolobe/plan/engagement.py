"""The job's ``[stock]`` applied to a path: engagement per move, checked and summarised.

:func:`plan_engagement` decides what the planner plans each move at: its own
engagement on the job's ``[stock]`` (:mod:`robolobe.stock`), else on the
stock the program implies (:func:`robolobe.stock.default_stock`), else --
where the program implies none (it cuts at one height at or above part
zero, or tilts the tool) -- the job's ``cut.radial_width_mm`` and the
planned depth, with a note saying which. :func:`stock_engagement` refuses a
stock that does not fit the program; :func:`engagement_note` names the air
moves and the moves engaged wider than ``cut.radial_width_mm``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.errors import InputError
from robolobe.plan.job import Job
from robolobe.stock import (
    Engagement,
    check_stock_contains,
    compute_engagement,
    default_stock,
)

__all__ = ["engagement_note", "plan_engagement", "stock_engagement"]


def stock_engagement(
    job: Job, wp: pd.DataFrame, path_name: str, *, default: bool = False
) -> Engagement | None:
    """Engagement of every move of ``wp`` on the job's stock (None without ``[stock]``).

    With ``default`` a job without ``[stock]`` gets the stock the program implies
    (:func:`robolobe.stock.default_stock`, its note in ``Engagement.notes``) at the
    default Z-map cell.

    Raises
    ------
    InputError
        A stock that does not contain the cutting region (naming the job
        file and ``stock``), a tilted tool on a cutting move (naming the
        path's line), a Z-map cell out of range.
    """
    if job.stock is None and not default:
        return None
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy(dtype=np.float64)
    cut = (wp["motion"] == "cut").to_numpy()
    lines = wp["line"].to_numpy()
    radius = 0.5 * job.tool.diameter_m
    stock = job.stock.shape if job.stock is not None else None
    if stock is None:
        stock = default_stock(xyz, cut, radius)
    else:
        check_stock_contains(stock, xyz, cut, radius, lines=lines, source=Path(job.source).name)
    return compute_engagement(
        xyz,
        cut,
        job.tool.diameter_m,
        stock,
        resolution_m=job.stock.resolution_m if job.stock is not None else None,
        axis=wp[["i", "j", "k"]].to_numpy(dtype=np.float64),
        lines=lines,
        source=Path(path_name).name,
    )


def engagement_note(job: Job, wp: pd.DataFrame, eng: Engagement) -> str:
    """One paragraph for the plan's notes: the stock and its Z-map, the air moves."""
    parts = [
        f"[stock]: engagement of every move computed on the {eng.stock.describe()} at a "
        f"{eng.resolution_m * 1e3:.3g} mm Z-map cell",
        *eng.notes,
    ]
    return "; ".join(parts)


def plan_engagement(job: Job, wp: pd.DataFrame, path_name: str) -> tuple[Engagement | None, str]:
    """The engagement the planner plans each move at, and the sentence that says so.

    Returns
    -------
    engagement : Engagement or None
        Every move's own engagement on the job's ``[stock]`` or the default
        stock; None where the plan falls back to ``cut.radial_width_mm`` (no
        ``[stock]`` and the program implies no stock with depth).
    note : str
        Which one the plan used, for its notes.

    Raises
    ------
    InputError
        From :func:`stock_engagement` when the job gives a ``[stock]``.
    """
    fallback = (
        f"engagement: every cutting move planned at cut.radial_width_mm (a_e/D "
        f"{job.radial_immersion:.2f}, {job.cut.milling} milling) and the planned depth"
    )
    if job.stock is not None:
        eng = stock_engagement(job, wp, path_name)
        assert eng is not None
        return eng, "engagement: each move's own, on the job's [stock]"
    try:
        eng = stock_engagement(job, wp, path_name, default=True)
    except InputError as exc:
        return None, f"{fallback}: the program implies no stock ({exc}); give [stock] to plan it"
    assert eng is not None
    cut = (wp["motion"] == "cut").to_numpy()
    if not np.any(cut & eng.engaged & ~eng.plunge):
        return None, (
            f"{fallback}: the program cuts at one height at or above part zero, so it "
            "implies no stock depth; give [stock] to plan each move's own engagement"
        )
    return eng, (
        "engagement: each move's own, on the default stock the program implies (no [stock] in "
        "the job)"
    )
