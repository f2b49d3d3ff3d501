"""The job's ``[stock]`` applied to a path: engagement per move, checked and summarised.

The planner still plans every cutting move at the job's ``cut.radial_width_mm``
(issue 26 wires the per-move engagement into the lobes). With a ``[stock]``
section, :func:`stock_engagement` computes every move's own engagement
(:mod:`robolobe.stock`), refuses a stock that does not fit the program, and
:func:`engagement_note` says in the plan's notes which moves engage wider
than planned and which feed moves cut air, with their ``file:line``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from robolobe.plan.job import Job
from robolobe.stock import (
    Engagement,
    check_stock_contains,
    compute_engagement,
    default_stock,
)

__all__ = ["engagement_note", "stock_engagement"]

#: Immersion a_e / D by which a move's own engagement may exceed the job's before the
#: note names it.
WIDER_BY = 0.05


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
    """One paragraph for the plan's notes: the stock, the moves engaged wider, air moves."""
    imm = eng.immersion
    # plunges are planned without a lateral limit already
    wider = eng.engaged & ~eng.plunge & (imm > job.radial_immersion + WIDER_BY)
    names = wp["source"].to_numpy()
    lines = wp["line"].to_numpy()
    mill = eng.milling()
    parts = [
        f"[stock]: engagement of every move computed on the {eng.stock.describe()} at a "
        f"{eng.resolution_m * 1e3:.3g} mm Z-map cell",
        *eng.notes,
    ]
    if wider.any():
        idx = np.flatnonzero(wider)
        worst = idx[np.argmax(imm[idx])]
        first = "; ".join(
            f"{Path(str(names[k])).name}:{int(lines[k])} a_e/D {imm[k]:.2f} ({mill[k]})"
            for k in idx[:3]
        )
        parts.append(
            f"this plan still plans every cutting move at cut.radial_width_mm (a_e/D "
            f"{job.radial_immersion:.2f}): {idx.size} moves engage wider, up to a_e/D "
            f"{imm[worst]:.2f} at {Path(str(names[worst])).name}:{int(lines[worst])} "
            f"(first: {first}); their stability limit is lower than the plan states"
        )
    return "; ".join(parts)
