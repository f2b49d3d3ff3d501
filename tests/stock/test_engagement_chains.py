"""Chains of tiny moves at changing heights against an exact reference written for the test.

A 2-D pocket's lead-out that ramps up out of the floor in ever shorter moves
(Fusion 360: ``safarazfadli-glitch_1001.nc`` tool 1, from ``../shared/realworld``,
skipped when absent) ends each pass beside the previous pass's lead-out. Where
such a move's edge meets the material, the Z-map's cells remember the deeper
or wider neighbours of the move that cleared the point (each cleared the cell
centres lower or wider), and the edge crosses that move's end disc at a graze
(centres a tenth of a millimetre apart: a micrometre of wall moves the angle by
about a degree). Before the exact test took the short neighbours of a
remembered move as candidates, N12370 (a 7 um move) erred by 2.9 deg.

The reference: a point of the cutting edge is in material when it lies inside
the box by more than the level tolerance and no earlier cutting move that has
cut (the production's lag: moves ending at least two cells of path before the
probe's end) cleared it to within the level tolerance of the tip (the move's
lowest tip height over its part within ``R + tol`` of the point). A move
shorter than the lag is one sample at its end; the edge is sampled every
0.1 deg and each change refined by bisection.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from robolobe.plan.paths import read_toolpath
from robolobe.stock import LEVEL_TOL_M, Stock, compute_engagement

from ._arc import engaged_arc

PROGRAM = (
    Path(__file__).resolve().parents[2].parent
    / "shared"
    / "realworld"
    / "cam"
    / "safarazfadli-glitch_1001.nc"
)
D = 6.35e-3  # tool 1 (header: T1 D=6.35 flat end mill)
R = 0.5 * D


def _tool1(tmp: Path) -> Path:
    """The program's preamble and tool 1's first section (to the next tool change)."""
    lines = PROGRAM.read_text(errors="replace").splitlines()
    changes = [k for k, ln in enumerate(lines) if " M6" in ln]
    t1 = next(k for k in changes if " T1 " in lines[k])
    end = next(k for k in changes if k > t1)
    q = tmp / "tool1.nc"
    q.write_text("\n".join(lines[: changes[0]] + lines[t1:end]) + "\nM30\n", encoding="utf-8")
    return q


def _angles(
    a: np.ndarray, b: np.ndarray, box: tuple[np.ndarray, np.ndarray], c: np.ndarray, z: float,
    f: np.ndarray,
) -> tuple[float, float]:  # fmt: skip
    """Exact (entry, exit) [rad] at centre ``c``, tip height ``z``, feed ``f`` against the
    moves ``a -> b`` (each (m, 3)); NaN where the edge meets no material."""
    tol = LEVEL_TOL_M
    rr = R + tol
    left = np.array([-f[1], f[0]])

    def material(ph: np.ndarray) -> np.ndarray:
        q = c + R * (np.sin(ph)[:, None] * f + np.cos(ph)[:, None] * left)
        d = b[:, :2] - a[:, :2]
        l2 = np.maximum((d * d).sum(1), 1e-30)
        rel = q[:, None, :] - a[None, :, :2]
        bb = (rel * d).sum(2)
        disc = bb * bb - l2 * ((rel * rel).sum(2) - rr * rr)
        sq = np.sqrt(np.maximum(disc, 0.0))
        t1 = (bb - sq) / l2
        t2 = (bb + sq) / l2
        za, dz = a[:, 2], b[:, 2] - a[:, 2]
        lev = np.minimum(za + np.clip(t1, 0, 1) * dz, za + np.clip(t2, 0, 1) * dz)
        cleared = ((disc >= 0) & (t2 >= 0) & (t1 <= 1) & (lev <= z + tol)).any(axis=1)
        inside = np.all((q > box[0][:2] + tol) & (q < box[1][:2] - tol), axis=1)
        return inside & (box[1][2] > z + tol) & ~cleared

    return engaged_arc(material, 24)


@pytest.mark.skipif(not PROGRAM.is_file(), reason="../shared/realworld/cam not present")
def test_tiny_ramp_moves_of_a_pocket_lead_out(tmp_path: Path) -> None:
    wp = read_toolpath(_tool1(tmp_path))
    xyz = wp[["x_m", "y_m", "z_m"]].to_numpy()
    cut = (wp["motion"] == "cut").to_numpy()
    lines = wp["line"].to_numpy()
    lo = xyz[cut].min(axis=0) - [R + 1e-3, R + 1e-3, 1e-3]
    hi = np.r_[xyz[cut, :2].max(axis=0) + R + 1e-3, xyz[cut, 2].max()]
    box = (lo, hi)
    e = compute_engagement(xyz, cut, D, Stock.box(tuple(lo), tuple(hi)))
    res = e.resolution_m
    cum = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(xyz, axis=0), axis=1))]
    lxy = np.r_[0.0, np.hypot(*np.diff(xyz[:, :2], axis=0).T)]
    dz = np.r_[0.0, np.diff(xyz[:, 2])]
    # the class: cutting moves shorter than a cell in x-y that climb (lead-out ramps)
    probes = np.flatnonzero(cut & (lxy > 1e-3 * res) & (lxy < res) & (dz > LEVEL_TOL_M))
    assert len(probes) >= 20, len(probes)
    errs = []
    for i in probes:
        done = np.flatnonzero(cut[:i] & (cum[:i] <= cum[i] - 2 * res))
        done = done[done > 0]
        a, d = xyz[done - 1, :2], xyz[done, :2] - xyz[done - 1, :2]
        t = np.clip(((xyz[i, :2] - a) * d).sum(1) / np.maximum((d * d).sum(1), 1e-30), 0, 1)
        k = done[np.linalg.norm(a + t[:, None] * d - xyz[i, :2], axis=1) < 2 * R + 1e-3]
        f = (xyz[i] - xyz[i - 1])[:2] / lxy[i]
        ref = _angles(xyz[k - 1], xyz[k], box, xyz[i, :2], float(xyz[i, 2]), f)
        ours = (float(e.phi_entry[i]), float(e.phi_exit[i]))
        assert math.isnan(ref[0]) == math.isnan(ours[0]), (int(lines[i]), ours, ref)
        if not math.isnan(ref[0]):
            errs.append((math.degrees(max(abs(ours[0] - ref[0]), abs(ours[1] - ref[1]))), lines[i]))
    worst = max(errs)
    assert len(errs) >= 20, len(errs)
    # the bisection's 1/8 deg, interpolated (before the chain neighbours: 2.9 deg)
    assert worst[0] < 0.25, f"line {worst[1]}: {worst[0]:.3f} deg"
