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
import re
from pathlib import Path

import numpy as np
import pytest

from robolobe.plan.paths import read_toolpath
from robolobe.stock import LEVEL_TOL_M, MIN_ARC_DEG, Stock, compute_engagement, default_stock

from ._arc import swept_positions

D = 6e-3
R = 0.5 * D
RES = D / 40
BOX = (np.array([-0.02, -0.015, -0.01]), np.array([0.02, 0.015, 0.0]))


def _stock() -> Stock:
    return Stock.box(tuple(BOX[0]), tuple(BOX[1]))


def _depth_reference(
    xyz: np.ndarray,
    cut: np.ndarray,
    i: int,
    t: float,
    radius: float = R,
    res: float = RES,
    box: tuple[np.ndarray, np.ndarray] = BOX,
) -> float:
    """Depth [m] of the tool at fraction ``t`` of move ``i`` by sampled tool positions.

    The workpiece is the stock less every cutting move that ends at least two cells of path
    before the end of move ``i`` (as :func:`robolobe.stock.compute_engagement` states, for
    every sample of the move); a point's top
    is the lowest tip of the swept positions within ``R + tol`` of it (the stock top where
    none is). An edge point is engaged where it lies inside the stock by more than ``tol``
    and its top stands more than ``tol`` over the tip (arcs narrower than ``MIN_ARC_DEG``
    dropped); its height is the top one cell inside it where that stands over the tip,
    else its own top. Edge sampled every 0.02 deg. Only the moves whose track passes
    within ``2 radius`` of the tool are sampled (the others reach no point of its edge).
    """
    tol = LEVEL_TOL_M
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    a, b = xyz[i - 1], xyz[i]
    upto = min(i, int(np.searchsorted(cum, cum[i] - 2.0 * res, side="right")))
    c = a[:2] + t * (b[:2] - a[:2])
    p0, d = xyz[: upto - 1, :2], np.diff(xyz[:upto, :2], axis=0)
    w = np.clip(((c - p0) * d).sum(1) / np.maximum((d * d).sum(1), 1e-30), 0.0, 1.0)
    reach = np.r_[False, np.hypot(*(p0 + w[:, None] * d - c).T) <= 2 * radius + 2 * tol]
    pos = swept_positions(xyz, cut[:upto] & reach, upto, step=1e-5)
    z = a[2] + t * (b[2] - a[2])
    f = (b[:2] - a[:2]) / np.linalg.norm(b[:2] - a[:2])
    left = np.array([-f[1], f[0]])
    near = pos[np.hypot(*(pos[:, :2] - c).T) <= 2 * radius + 2 * tol]

    def top(q: np.ndarray) -> np.ndarray:
        out = np.full(len(q), box[1][2])
        for s in range(0, len(near), 500):
            p = near[s : s + 500]
            d2 = ((q[:, None, :] - p[None, :, :2]) ** 2).sum(axis=2)
            zz = np.where(d2 <= (radius + tol) ** 2, p[None, :, 2], np.inf).min(axis=1)
            out = np.minimum(out, zz)
        return out

    ph = np.linspace(0.0, math.pi, 9001)
    u = np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left
    edge = c + radius * u
    top_edge = top(edge)
    inside = np.all((edge > box[0][:2] + tol) & (edge < box[1][:2] - tol), axis=1)
    mat = inside & (top_edge > z + tol)
    # arcs narrower than MIN_ARC_DEG are none
    edges = np.flatnonzero(np.diff(np.r_[0, mat.astype(np.int8), 0]))
    for k0, k1 in zip(edges[::2], edges[1::2], strict=True):
        if ph[k1 - 1] - ph[k0] < math.radians(MIN_ARC_DEG):
            mat[k0:k1] = False
    if not mat.any():
        return 0.0
    top_in = top(c + (radius - res) * u[mat])
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


@pytest.mark.parametrize(
    "wall_um",
    [pytest.param(30.0, marks=pytest.mark.slow), 75.0, pytest.param(120.0, marks=pytest.mark.slow)],
)
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


CAM = Path(__file__).resolve().parents[2].parent / "shared" / "realworld" / "cam"


def _original_lines(text: str, tool: int) -> tuple[str, np.ndarray]:
    """The preamble and every section of ``tool`` of a program, and each line's number in
    the original file (as ``studies/engagement.py`` takes a tool's sections)."""
    lines = text.splitlines()
    changes = [k for k, ln in enumerate(lines) if re.search(r"\bT\d+\s*M0?6\b", ln)]
    keep = list(range(changes[0]))
    for k, nxt in zip(changes, [*changes[1:], len(lines)], strict=True):
        if re.search(rf"\bT{tool}\s*M0?6\b", lines[k]):
            keep += range(k, nxt)
    return "\n".join(lines[k] for k in keep) + "\n", np.array(keep) + 1


@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "tool", "diameter", "line", "expected_mm"),
    [
        # the outer side of an arc of short chords cuts a full-height wall (was 0.500)
        ("safarazfadli-glitch_1001.nc", 1, 6.35e-3, 2170, 8.255),
        # a ramp over a deeper pass: the wall's top only near the arc's entry (was 0.183)
        ("freegroup_CamperGaskastenTuer.nc", None, 5e-3, 2302, 1.433),
    ],
)
def test_worst_depth_moves_of_the_real_programs(
    tmp_path: Path, name: str, tool: int | None, diameter: float, line: int, expected_mm: float
) -> None:
    """The study's two worst depth moves against the sampled-positions reference: every
    chord of the line, at every sample the production takes (its default stock)."""
    path = CAM / name
    if not path.is_file():
        pytest.skip("../shared/realworld/cam not present")
    origin = None
    if tool is not None:
        text, origin = _original_lines(path.read_text(errors="replace"), tool)
        path = tmp_path / name
        path.write_text(text, encoding="utf-8")
    wp = read_toolpath(path)
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy()
    cut = (wp["motion"] == "cut").to_numpy()
    lines = wp["line"].to_numpy()
    if origin is not None:
        lines = origin[lines - 1]
    stock = default_stock(xyz, cut, 0.5 * diameter)
    e = compute_engagement(xyz, cut, diameter, stock)
    x0, y0, x1, y1 = stock.bounds()
    box = (np.array([x0, y0, stock.z_bottom]), np.array([x1, y1, stock.z_top]))
    moves = np.flatnonzero((lines == line) & cut)
    assert moves.size
    worst = 0.0
    for i in moves:
        lxy = float(np.linalg.norm(xyz[i, :2] - xyz[i - 1, :2]))
        nseg = max(1, math.ceil(lxy / (0.25 * diameter)))
        ts = [k / nseg for k in range(1, nseg + 1)]
        prev = xyz[i - 1, :2] - xyz[i - 2, :2]
        lp = float(np.linalg.norm(prev))
        straight = cut[i - 1] and lp > 1e-3 * e.resolution_m
        turn = (prev / lp if straight else np.zeros(2)) @ (xyz[i, :2] - xyz[i - 1, :2]) / lxy
        if turn < math.cos(math.radians(5.0)) and lxy > 4 * e.resolution_m:
            ts.insert(0, 2 * e.resolution_m / lxy)  # the sample just after a turn
        ref = max(_depth_reference(xyz, cut, i, t, 0.5 * diameter, e.resolution_m, box) for t in ts)
        assert e.depth_m[i] == pytest.approx(ref, abs=2e-6), f"{name}:{line} move {i}"
        worst = max(worst, ref)
    assert worst * 1e3 == pytest.approx(expected_mm, abs=1e-6)
