"""Holding tabs cut in two levels against a reference written for the test (sampled tool positions).

A CAM contour with holding tabs (Fusion 360's ``Dryless_TopFridge.nc``: a
1.587 mm cutter, passes at Z-6 and Z-6.35, each rising to Z-5.953 over every
tab) retraces the tab at the same height in its second pass: that traverse
cuts nothing, the first pass's took the material down to the tab's top. The
Z-map kept per cell only its deepest sweep: the deeper passes on either side
of the tab replaced the records of the cells near the tab's ends, the exact
test then no longer knew the first tab traverse, and the second one was
planned as cutting (88 moves, arcs up to 171 deg, "depth" 5.953 mm: the stock
top) where the study's reference, and a brute-force check, found air.

The program here is the same pattern on a straight groove: a pass at the
first level, then two passes deeper, each rising over one tab (pure z moves up
and down at its ends). The second tab traverse is at the first's height (air)
or lower by ``tab_drop`` (a strip that thick: cutting, a full slot, so the test
also fails where the fix would call material air).

The reference has no Z-map and no analytic sweep: the tool positions along
every earlier cutting move are sampled every micrometre, and a point of the
cutting edge is in material when it lies inside the box by more than the level
tolerance and no sampled position within ``R + tol`` of it has its tip within
``tol`` of the probe's tip height (the definition of
:mod:`robolobe.stock.engagement`: material thinner than the level tolerance is
none). Each move is probed where the production samples it (two cells into a
move after a turn, then every quarter diameter to its end, the workpiece as the
moves up to two cells of path behind left it) and keeps the widest entry and
exit; the edge is sampled every 0.1 deg and each change refined by bisection.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.stock import LEVEL_TOL_M, Stock, compute_engagement

from ._arc import swept_positions, swept_reference

D = 1.6e-3
R = 0.5 * D
TOL = LEVEL_TOL_M
#: The tab spans x = 4..7 mm of a groove along y = 0 from x = -2 to 12 mm (stock x 0..10).
TAB = (4e-3, 7e-3)
Z_TOP_PASS, Z_PASS1, Z_PASS2, Z_TAB = -0.3e-3, -0.6e-3, -0.8e-3, -0.5e-3


def _program(tab_drop: float) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """The groove's three passes (the last two over the tab); waypoints (n, 3) [m], cutting
    flags, and the indices of the two tab traverses."""
    pts: list[tuple[float, float, float]] = []
    cut: list[bool] = []
    tabs = []

    def go(x: float, z: float, feed: bool = True) -> None:
        pts.append((x, 0.0, z))
        cut.append(feed)

    go(-2e-3, 1e-3, False)
    go(-2e-3, Z_TOP_PASS)
    go(12e-3, Z_TOP_PASS)
    for z_pass, z_tab in ((Z_PASS1, Z_TAB), (Z_PASS2, Z_TAB - tab_drop)):
        go(12e-3, 1e-3, False)
        go(-2e-3, 1e-3, False)
        go(-2e-3, z_pass)
        go(TAB[0], z_pass)
        go(TAB[0], z_tab)  # up onto the tab
        go(TAB[1], z_tab)
        tabs.append(len(pts) - 1)
        go(TAB[1], z_pass)  # down behind it
        go(12e-3, z_pass)
    return np.array(pts), np.array(cut), tabs


def _reference_move(
    xyz: np.ndarray, cut: np.ndarray, i: int, box: tuple[np.ndarray, np.ndarray], res: float
) -> tuple[float, float]:
    """The move's widest (entry, exit) [rad] over the production's sample positions."""
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    lag = 2.0 * res
    upto = int(np.searchsorted(cum, cum[i] - lag, side="right"))  # moves [0, upto) applied
    pos = swept_positions(xyz, cut, min(upto, i))
    a, b = xyz[i - 1], xyz[i]
    lxy = float(np.linalg.norm(b[:2] - a[:2]))
    f = (b[:2] - a[:2]) / lxy
    nseg = max(1, math.ceil(lxy / (0.5 * R)))
    ts = [k / nseg for k in range(1, nseg + 1)]
    if lxy > 2 * lag:  # every move here follows a z move or a rapid: a turn
        ts.insert(0, lag / lxy)
    entry, exit_ = math.inf, -math.inf
    for t in ts:
        p = a + t * (b - a)
        e, x = swept_reference(pos, box, p[:2], float(p[2]), f, R, TOL)
        if not math.isnan(e):
            entry, exit_ = min(entry, e), max(exit_, x)
    return (entry, exit_) if math.isfinite(entry) else (math.nan, math.nan)


@pytest.mark.parametrize(
    ("tab_drop", "cells"),
    [(0.0, 40), (0.0, 12), (0.05e-3, 12)],
    ids=["same-height-D/40", "same-height-D/12", "second-tab-50um-lower-D/12"],
)
def test_second_pass_over_a_holding_tab(tab_drop: float, cells: int) -> None:
    xyz, cut, tabs = _program(tab_drop)
    box = (np.array([0.0, -3e-3, -2e-3]), np.array([10e-3, 3e-3, 0.0]))
    e = compute_engagement(
        xyz, cut, D, Stock.box(tuple(box[0]), tuple(box[1])), resolution_m=D / cells
    )
    moving = np.r_[False, np.linalg.norm(np.diff(xyz[:, :2], axis=0), axis=1) > 0]
    errs = {}
    for i in np.flatnonzero(cut & moving):
        ref = _reference_move(xyz, cut, int(i), box, e.resolution_m)
        ours = (float(e.phi_entry[i]), float(e.phi_exit[i]))
        assert math.isnan(ref[0]) == math.isnan(ours[0]), (int(i), ours, ref)
        if not math.isnan(ref[0]):
            errs[int(i)] = math.degrees(max(abs(ours[0] - ref[0]), abs(ours[1] - ref[1])))
    # the first tab traverse cuts the tab's top (a slot); the second retraces it: air at
    # the same height, a slot through the strip left when it runs lower
    assert e.n_arcs[tabs[0]] > 0
    assert e.depth_m[tabs[0]] == pytest.approx(Z_TOP_PASS - Z_TAB, abs=1e-6)
    if tab_drop:
        assert e.n_arcs[tabs[1]] > 0
        assert e.depth_m[tabs[1]] == pytest.approx(tab_drop, abs=1e-6)
    else:
        assert e.n_arcs[tabs[1]] == 0
    assert len(errs) >= 6, errs  # the cutting moves were compared (the test can fail)
    assert max(errs.values()) < 0.5, {k: round(v, 3) for k, v in errs.items()}
