"""A graze of the stock's outline: an arc of material narrower than 1 deg is none.

Fusion 360's ``Dryless_TopFridge.nc`` (1.587 mm cutter, no ``[stock]``: the
default stock, the box of the cutting moves grown by the tool radius) ends each
level of its outside contour with a lead-out ramp whose last move ends at the
program's largest x: there the cutting edge runs tangent to the default box's
side, and between the disc the level's plunge cleared and the band of the
level tolerance along the side the edge meets a sliver of material 0.6 deg
wide and at most 1.4 um thicker than the tolerance. The reference reported
its entry (80.3 deg), the Z-map's 1-deg search missed it and reported the next
arc's (99.1 deg): 18.8 deg apart on 6 moves (lines 2384, 2419, ...). Such an
arc is a graze, not a cut (under 1/180 of a slot's edge); the engagement's
definition drops arcs narrower than :data:`robolobe.stock.MIN_ARC_DEG`.

Here the same geometry with a 10 mm cutter: a plunge beside the box's side
clears a disc, then a short move ends tangent to the side, the disc's edge
placed so that the sliver is 0.3 to 2.5 deg wide. The reference has no Z-map
and no analytic sweep: the tool positions along every earlier cutting move
are sampled every micrometre, and a point of the cutting edge is in material
when it lies inside the box by more than the level tolerance and no sampled
position within ``R + tol`` of it has its tip within ``tol`` of the probe's
tip; the edge is sampled every 0.1 deg and each change refined by bisection.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from robolobe.stock import LEVEL_TOL_M, MIN_ARC_DEG, compute_engagement, default_stock

from ._arc import engaged_arc

R = 0.005
D = 2 * R
TOL = LEVEL_TOL_M
X = 0.02  # the program's largest x plus the radius: the default box's side [m]
Z = -0.002
#: The angle [deg] below which the edge's points lie within the tolerance of the side.
BAND_DEG = 90.0 - math.degrees(math.acos(1.0 - TOL / R))


def _program(width_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """A plunge at (X - R, e) that leaves a sliver ``width_deg`` wide on the probe's edge,
    then the probe: a move along +x, 1.5 lags long, ending at (X - R, 0) tangent to the side."""
    # the plunge's disc (cleared to R + tol) reaches the edge's point at phi_c
    cos_c = math.cos(math.radians(BAND_DEG - width_deg))
    e = R * cos_c + math.sqrt((R * cos_c) ** 2 + 2 * R * TOL + TOL * TOL)
    lag = 2 * D / 40
    c = np.array([X - R, 0.0])
    xyz = np.array(
        [
            [c[0], e, 0.02],
            [c[0], e, Z],  # plunge: a disc
            [c[0], e, 0.02],
            [c[0] - 1.5 * lag, 0.0, 0.02],
            [c[0] - 1.5 * lag, 0.0, Z],
            [c[0], 0.0, Z],  # the probe
        ]
    )
    cut = np.array([False, True, False, False, True, True])
    return xyz, cut


def _reference(xyz: np.ndarray, box: np.ndarray, min_arc_deg: float) -> tuple[float, float]:
    """(entry, exit) [rad] of the probe (the last move) against the moves before it."""
    pos = [xyz[m - 1] + t * (xyz[m] - xyz[m - 1]) for m in (1, 4) for t in np.linspace(0, 1, 22001)]
    low = np.array([p[:2] for p in pos if p[2] <= Z + TOL])
    c = xyz[-1, :2]
    f = np.array([1.0, 0.0])
    left = np.array([0.0, 1.0])

    def material(ph: np.ndarray) -> np.ndarray:
        q = c + R * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left)
        d2 = ((q[:, None, :] - low[None, :, :]) ** 2).sum(axis=2)
        cleared = (d2 <= (R + TOL) ** 2).any(axis=1)
        inside = np.all((q > box[0] + TOL) & (q < box[1] - TOL), axis=1)
        return inside & ~cleared

    return engaged_arc(material, 24, min_arc_deg=min_arc_deg)


@pytest.mark.parametrize("width_deg", [0.3, 0.6, 0.85, 1.3, 2.5])
def test_a_graze_of_the_default_stock_narrower_than_one_degree_is_none(width_deg: float) -> None:
    xyz, cut = _program(width_deg)
    stock = default_stock(xyz, cut, R)
    box = np.array([stock.outline.min(axis=0), stock.outline.max(axis=0)])
    assert box[1, 0] == pytest.approx(X)  # the probe's edge is tangent to the side
    every = _reference(xyz, box, 0.0)
    ref = _reference(xyz, box, MIN_ARC_DEG)
    # the case is what it says: a first arc of that width, then the band along the side
    assert math.degrees(every[0]) == pytest.approx(BAND_DEG - width_deg, abs=0.05)
    narrow = width_deg < MIN_ARC_DEG
    # a narrow arc is none: the entry is the next arc's, past the band (tens of degrees on)
    past = 180.0 - BAND_DEG if narrow else BAND_DEG - width_deg
    assert math.degrees(ref[0]) == pytest.approx(past, abs=0.05)
    e = compute_engagement(xyz, cut, D, stock)
    ours = (float(e.phi_entry[-1]), float(e.phi_exit[-1]))
    err = math.degrees(max(abs(ours[0] - ref[0]), abs(ours[1] - ref[1])))
    assert err < 0.5, (np.degrees(ours), np.degrees(ref), np.degrees(every))
    assert e.n_arcs[-1] == (1 if narrow else 2)
