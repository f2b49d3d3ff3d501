"""Axial depth where the material one cell inside the engaged edge is cleared to the tip.

The depth of a tool position is the largest material height above the tip
over the engaged edge points: the top one cell inside the point where that
stands above the tip, else the top at the point itself. The session-start
code took the edge points' tops only when no point one cell inside stood
above the tip anywhere on the edge (all or nothing), and only at the 4-deg
samples. ``studies/engagement.py`` found it understating the depth on two
real programs: ``safarazfadli-glitch_1001.nc`` line 2170 by 7.755 mm (0.500 vs
8.255: the outer side of an arc of short chords cut a full-height wall whose
points one cell inside the tool's own trail had cleared, while a few points
one cell inside stood on the floor of the level above) and
``freegroup_CamperGaskastenTuer.nc`` line 2302 by 1.25 mm (0.183 vs 1.433: a
ramp over the floor of a deeper pass, whose engaged arc of 2 deg held the
wall's untouched top only between its refined entry and the sample at pi).

Two synthetic programs, each of those classes, against a reference written
here from tool positions sampled every 10 um along the swept history (a point's
distance from them errs by under 1e-8 m against the exact track's), no grid and no
production code:

* a finishing pass at a step-down's wall in short moves (the stock left at
  the wall thinner than a cell, standing to the stock top, next to the floor
  of the level above): 2 mm deep, not 1;
* a pass 0.1 mm beside a deeper pass, over a wall 20 um thick that stands
  to the stock top only within 1.7 deg of the engaged arc's entry: 1 mm deep,
  not 0.5.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.stock import LEVEL_TOL_M, MIN_ARC_DEG, Stock, compute_engagement

D = 6e-3
R = 0.5 * D
RES = D / 40
LAG = 2.0 * RES  # the workpiece the tool meets: the moves ending this much path behind
BOX = (np.array([-0.02, -0.015, -0.01]), np.array([0.02, 0.015, 0.0]))


def _stock() -> Stock:
    return Stock.box(tuple(BOX[0]), tuple(BOX[1]))


def _positions(xyz: np.ndarray, cut: np.ndarray, upto: int) -> np.ndarray:
    """Tool-tip positions (m, 3) along the cutting moves before ``upto``, every 10 um."""
    out = [np.zeros((0, 3))]
    for m in range(1, upto):
        if cut[m]:
            n = max(2, math.ceil(np.linalg.norm(xyz[m] - xyz[m - 1]) / 1e-5) + 1)
            t = np.linspace(0.0, 1.0, n)[:, None]
            out.append(xyz[m - 1] + t * (xyz[m] - xyz[m - 1]))
    return np.vstack(out)


def _depth_reference(xyz: np.ndarray, cut: np.ndarray, i: int, t: float) -> float:
    """Depth [m] of the tool at fraction ``t`` of move ``i`` by sampled tool positions.

    The workpiece is the stock less every cutting move that ends at least ``LAG`` of path
    before the end of move ``i`` (as :func:`robolobe.stock.compute_engagement` states, for
    every sample of the move); a point's top
    is the lowest tip of the swept positions within ``R + tol`` of it (the stock top where
    none is). An edge point is engaged where it lies inside the stock by more than ``tol``
    and its top stands more than ``tol`` over the tip (arcs narrower than ``MIN_ARC_DEG``
    dropped); its height is the top one cell inside it where that stands over the tip,
    else its own top. Edge sampled every 0.02 deg.
    """
    tol = LEVEL_TOL_M
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    a, b = xyz[i - 1], xyz[i]
    upto = int(np.searchsorted(cum, cum[i] - LAG, side="right"))
    pos = _positions(xyz, cut, min(upto, i))
    c = a[:2] + t * (b[:2] - a[:2])
    z = a[2] + t * (b[2] - a[2])
    f = (b[:2] - a[:2]) / np.linalg.norm(b[:2] - a[:2])
    left = np.array([-f[1], f[0]])
    near = pos[np.hypot(*(pos[:, :2] - c).T) <= 2 * R + 2 * tol]

    def top(q: np.ndarray) -> np.ndarray:
        out = np.full(len(q), BOX[1][2])
        for s in range(0, len(near), 500):
            p = near[s : s + 500]
            d2 = ((q[:, None, :] - p[None, :, :2]) ** 2).sum(axis=2)
            zz = np.where(d2 <= (R + tol) ** 2, p[None, :, 2], np.inf).min(axis=1)
            out = np.minimum(out, zz)
        return out

    ph = np.linspace(0.0, math.pi, 9001)
    u = np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left
    edge = c + R * u
    top_edge = top(edge)
    inside = np.all((edge > BOX[0][:2] + tol) & (edge < BOX[1][:2] - tol), axis=1)
    mat = inside & (top_edge > z + tol)
    # arcs narrower than MIN_ARC_DEG are none
    edges = np.flatnonzero(np.diff(np.r_[0, mat.astype(np.int8), 0]))
    for k0, k1 in zip(edges[::2], edges[1::2], strict=True):
        if ph[k1 - 1] - ph[k0] < math.radians(MIN_ARC_DEG):
            mat[k0:k1] = False
    if not mat.any():
        return 0.0
    top_in = top(c + (R - RES) * u[mat])
    h = np.where(top_in > z + tol, top_in, top_edge[mat])
    return float(np.max(h) - z)


def _program(moves: list[tuple[tuple[float, float, float], bool]]) -> tuple[np.ndarray, np.ndarray]:
    xyz = np.array([m[0] for m in moves]) * 1e-3
    cut = np.array([m[1] for m in moves])
    return xyz, cut


def _probes(xyz: np.ndarray, cut: np.ndarray, first: int) -> list[tuple[int, float]]:
    """(move, t) of the samples the production takes on the level moves from ``first``:
    every quarter diameter and the move's end (no turn on these straight passes)."""
    out = []
    for i in range(first, len(xyz)):
        lxy = float(np.linalg.norm(xyz[i, :2] - xyz[i - 1, :2]))
        if not cut[i] or lxy < 1e-9:
            continue
        nseg = max(1, math.ceil(lxy / (0.5 * R)))
        out += [(i, k / nseg) for k in range(1, nseg + 1)]
    return out


@pytest.mark.parametrize("wall_um", [30.0, 75.0, 120.0])
def test_finishing_pass_at_a_step_down_wall_cuts_the_wall_full_height(wall_um: float) -> None:
    """Level 1 at z = -1 mm clears the band |y| <= R; level 2 at z = -2 mm runs beside it,
    ``wall_um`` further out, in 0.25 mm moves: its edge meets the stock left at the wall
    (thinner than a cell, standing to the stock top) where the trail has cleared the point
    one cell inside, and the floor of level 1 one cell inside the front: 2 mm deep."""
    s = wall_um * 1e-3
    moves: list[tuple[tuple[float, float, float], bool]] = [((-15.0, 0.0, -1.0), False)]
    moves.append(((15.0, 0.0, -1.0), True))
    moves.append(((15.0, 0.0, 5.0), False))
    moves.append(((-12.0, -s, 5.0), False))
    moves.append(((-12.0, -s, -2.0), True))  # a plunge
    first = len(moves)
    moves += [((-12.0 + 0.25 * k, -s, -2.0), True) for k in range(1, 9)]
    xyz, cut = _program(moves)
    e = compute_engagement(xyz, cut, D, _stock(), resolution_m=RES)
    for i in range(first + 4, len(xyz)):  # past the plunge's disc
        ref = max(_depth_reference(xyz, cut, i, t) for j, t in _probes(xyz, cut, first) if j == i)
        assert ref == pytest.approx(2e-3, abs=1e-6)  # the wall, full height
        assert e.depth_m[i] == pytest.approx(ref, abs=2e-6), f"move {i}"
