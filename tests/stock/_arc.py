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


def swept_positions(xyz: np.ndarray, cut: np.ndarray, upto: int, step: float = 1e-6) -> np.ndarray:
    """Tool-tip positions (m, 3) along the cutting moves before ``upto``, every ``step``.

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip points of the path [m].
    cut : ndarray of bool, shape (n,)
        Feed moves (move ``m`` runs from point ``m - 1`` to point ``m``).
    upto : int
        The first move not swept.
    step : float
        Spacing of the positions along a move [m] (default a micrometre).
    """
    out = [np.zeros((0, 3))]
    for m in range(1, upto):
        if cut[m]:
            n = max(2, math.ceil(np.linalg.norm(xyz[m] - xyz[m - 1]) / step) + 1)
            t = np.linspace(0.0, 1.0, n)[:, None]
            out.append(xyz[m - 1] + t * (xyz[m] - xyz[m - 1]))
    return np.vstack(out)


def swept_reference(
    pos: np.ndarray,
    box: tuple[np.ndarray, np.ndarray],
    c: np.ndarray,
    z: float,
    f: np.ndarray,
    radius: float,
    tol: float,
    steps: int = 20,
) -> tuple[float, float]:
    """(entry, exit) [rad] of a flat end mill in a box stock swept at ``pos``; NaN: no material.

    The edge point meets material where it lies inside the box by more than
    ``tol``, the box top is over the tip by more than ``tol``, and no swept
    position whose tip reaches ``z + tol`` has the point within ``radius + tol``.

    Parameters
    ----------
    pos : ndarray, shape (m, 3)
        Swept tool-tip positions [m] (:func:`swept_positions`).
    box : (ndarray, ndarray)
        Stock corners, shape (3,) each [m].
    c : ndarray, shape (2,)
        Tool centre [m].
    z : float
        Tip height [m].
    f : ndarray, shape (2,)
        Unit feed direction.
    radius, tol : float
        Tool radius and level tolerance [m].
    steps : int
        Bisection steps of :func:`engaged_arc`.
    """
    left = np.array([-f[1], f[0]])
    # positions whose tip reaches the probe's level, near enough to reach its edge
    reach = np.hypot(*(pos[:, :2] - c).T) <= 2 * radius + 2 * tol
    low = pos[(pos[:, 2] <= z + tol) & reach, :2]

    def material(ph: np.ndarray) -> np.ndarray:
        q = c + radius * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left)
        cleared = np.zeros(len(q), dtype=bool)
        for s in range(0, len(low), 5000):
            d2 = ((q[:, None, :] - low[None, s : s + 5000]) ** 2).sum(axis=2)
            cleared |= (d2 <= (radius + tol) ** 2).any(axis=1)
        inside = np.all((q > box[0][:2] + tol) & (q < box[1][:2] - tol), axis=1)
        return inside & (box[1][2] > z + tol) & ~cleared

    return engaged_arc(material, steps)
