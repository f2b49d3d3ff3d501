"""A helical entry's floor against a reference written for the test (sampled tool positions).

A CAM program enters a pocket by a helix of small pitch (Fusion 360's
``Dryless_TopFridge.nc``: a 1.587 mm cutter on a 0.755 mm helix radius, 0.165 mm
a turn, read as chords that each drop 8.3 um, less than the level tolerance),
then cleans the bore's floor at the final depth. The Z-map skipped the start
disc of a move that continued the previous one at its height "within the level
tolerance", so a chain of chords each dropping a few micrometres left the floor
of their start discs as high as the drops added up to: 27 um where the
program's level moves then cut, entry angles up to 84 deg off (N2296).

The reference has no Z-map and no analytic sweep: the tool positions along
every earlier cutting move are sampled every micrometre, and a point of the
cutting edge is in material when it lies inside the box by more than the level
tolerance and no sampled position within ``R + tol`` of it has its tip within
``tol`` of the probe's tip height (the definition of
:mod:`robolobe.stock.engagement`: material thinner than the level tolerance is
none). The edge is sampled every 0.1 deg and each change refined by bisection.
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


def _program(drop_um: float) -> tuple[np.ndarray, np.ndarray, int]:
    """A helix (radius 0.75 mm, 20 chords a turn, each dropping ``drop_um``) from the stock
    top to 0.5 mm deep, then level moves of 0.15 mm across the bore's floor at that depth.

    Returns the waypoints (n, 3) [m], the cutting flags and the first level move's index.
    """
    rh = 0.75e-3
    depth = 0.5e-3
    n_ch = math.ceil(depth / (drop_um * 1e-6))
    k = np.arange(n_ch + 1)
    ang = 2 * math.pi * k / 20
    helix = np.c_[rh * np.cos(ang), rh * np.sin(ang), -np.minimum(k * drop_um * 1e-6, depth)]
    end = helix[-1]
    # across the bore through its centre and out to the other side, in 0.15 mm moves
    direction = -end[:2] / np.linalg.norm(end[:2])
    steps = np.arange(1, 12)[:, None] * 0.15e-3
    level = np.c_[end[:2] + steps * direction, np.full(len(steps), end[2])]
    xyz = np.vstack([[[rh, 0.0, 0.5e-3]], helix, level])
    cut = np.ones(len(xyz), dtype=bool)
    cut[0] = False
    return xyz, cut, len(helix) + 1


@pytest.mark.parametrize("drop_um", [8.25, 4.0])
def test_level_moves_over_a_helix_floor(drop_um: float) -> None:
    xyz, cut, first_level = _program(drop_um)
    box = (np.array([-3e-3, -3e-3, -2e-3]), np.array([3e-3, 3e-3, 0.0]))
    e = compute_engagement(xyz, cut, D, Stock.box(tuple(box[0]), tuple(box[1])))
    res = e.resolution_m
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    errs = []
    n_cut = 0
    # the level moves after the first (no turn: one sample, at the move's end)
    for i in range(first_level + 1, len(xyz)):
        upto = int(np.searchsorted(cum, cum[i] - 2 * res, side="right"))  # the lag
        pos = swept_positions(xyz, cut, min(upto, i))
        f = (xyz[i, :2] - xyz[i - 1, :2]) / np.linalg.norm(xyz[i, :2] - xyz[i - 1, :2])
        ref = swept_reference(pos, box, xyz[i, :2], float(xyz[i, 2]), f, R, TOL)
        ours = (float(e.phi_entry[i]), float(e.phi_exit[i]))
        assert math.isnan(ref[0]) == math.isnan(ours[0]), (i, ours, ref)
        if not math.isnan(ref[0]):
            n_cut += 1
            errs.append(math.degrees(max(abs(ours[0] - ref[0]), abs(ours[1] - ref[1]))))
    assert n_cut >= 5, n_cut  # the floor's remnant is cut (the test can fail)
    # the bisection's 1/8 deg interpolated, and the distance field's res^2 / 8 R
    assert max(errs) < 0.5, [round(x, 3) for x in errs]
