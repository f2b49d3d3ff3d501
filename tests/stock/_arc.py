"""The engaged arc of a material test: the tests' own references share this search."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from robolobe.stock import MIN_ARC_DEG


def engaged_arc(
    material: Callable[[np.ndarray], np.ndarray],
    steps: int,
    samples: int = 1801,
    min_arc_deg: float = MIN_ARC_DEG,
) -> tuple[float, float]:
    """(entry, exit) [rad] of the material over the cutting half [0, pi].

    Parameters
    ----------
    material : callable
        Angles [rad], shape (k,), to True where the cutter's edge meets material.
    steps : int
        Bisection steps refining each edge between its two samples.
    samples : int
        Equally spaced angles scanned first (each run of engaged ones is an arc).
    min_arc_deg : float
        Arcs narrower than this [deg] (both ends refined) are none, as in
        :mod:`robolobe.stock.engagement` (0: every arc counts).

    Returns
    -------
    (float, float)
        The first kept arc's entry and the last one's exit; NaN, NaN where no
        arc is kept; 0 or pi where the arc reaches the end of the half.
    """
    ph = np.linspace(0.0, math.pi, samples)
    m = material(ph)
    if not m.any():
        return math.nan, math.nan

    def refine(lo: float, hi: float, lo_mat: bool) -> float:
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            if bool(material(np.array([mid]))[0]) == lo_mat:
                lo = mid
            else:
                hi = mid
        return 0.5 * (lo + hi)

    edges = np.flatnonzero(np.diff(np.r_[0, m.astype(np.int8), 0]))
    kept = []
    for k0, k1 in zip(edges[::2], edges[1::2] - 1, strict=True):
        lo = 0.0 if k0 == 0 else refine(ph[k0 - 1], ph[k0], False)
        hi = math.pi if k1 == len(m) - 1 else refine(ph[k1], ph[k1 + 1], True)
        if hi - lo >= math.radians(min_arc_deg):
            kept.append((lo, hi))
    if not kept:
        return math.nan, math.nan
    return kept[0][0], kept[-1][1]
