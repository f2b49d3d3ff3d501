"""The engaged arc of a material test: the tests' own references share this search."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np


def engaged_arc(
    material: Callable[[np.ndarray], np.ndarray], steps: int, samples: int = 1801
) -> tuple[float, float]:
    """(entry, exit) [rad] of the material over the cutting half [0, pi].

    Parameters
    ----------
    material : callable
        Angles [rad], shape (k,), to True where the cutter's edge meets material.
    steps : int
        Bisection steps refining each edge between its two samples.
    samples : int
        Equally spaced angles scanned first (the first and the last engaged one
        bound the arc).

    Returns
    -------
    (float, float)
        NaN, NaN where no sample meets material; 0 or pi where the arc
        reaches the end of the half.
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

    k0 = int(np.argmax(m))
    k1 = len(m) - 1 - int(np.argmax(m[::-1]))
    entry = 0.0 if k0 == 0 else refine(ph[k0 - 1], ph[k0], False)
    exit_ = math.pi if k1 == len(m) - 1 else refine(ph[k1], ph[k1 + 1], True)
    return entry, exit_
