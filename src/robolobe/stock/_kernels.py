"""Z-map kernels: material removal by a flat end mill and engagement along the path.

The in-process workpiece is a Z-map on a square grid (cell centres
``x0 + (i + 1/2) res``, ``y0 + (j + 1/2) res``; arrays ``(ny, nx)``):

``h``
    top of the material at the cell centre [m] (the stock top until a sweep
    lowers it; inside and outside the outline alike);
``s``, ``zs``
    clearance ``R - d`` [m] of the cell centre from the tool axis of the
    sweeps at the lowest level ``zs`` [m] that reached the cell (positive
    inside the swept region; negative in a band of ``w`` outside it);
``sd``
    signed distance to the stock outline [m] (negative inside, clipped).

``ids``
    per cell, the sweeps (move indices, 0: none) that set ``zs`` and ``s``, and
    ``h``.

Engagement tests points on the cutting edge with the bilinear interpolation
of a value that is negative where material is: the clearance is a distance
field, so the edge of the material is found to a small fraction of a cell
(error ~ res^2 / 8 R) instead of half a cell as with a height alone. That
holds where the four cells around the point have their clearance from one
sweep at the tip's level. Where they disagree in sign and do not (two
sweeps' edges meeting; a wall at the tip's level over cells cut deeper
before; a floor whose height crosses the level tolerance between cell
centres, as a helix's or a ramp's bottom does), the point is decided exactly
instead: cleared when one of the sweeps those cells remember, or one of the
tool's last four, or a short move next to a remembered one along the path
(:func:`chain_neighbours`: in a ramp's, a helix's or a lead-out's chain of tiny moves the
move that clears a point is often shadowed at every cell centre by a deeper
neighbour), passes within ``R + tol`` of it with its lowest tip height
there within ``tol`` of the tip (the definition of
:mod:`robolobe.stock.engagement`, no grid in it). A cell keeps the records of
its deepest sweeps only: where none of those clears the point and one of the
four cells was reached deeper than the tip (the tip runs again at a level a
deeper pass has since cut below: a second pass over a holding tab, a ramp over
the floor of a deeper pocket), the sweep that cleared it may be forgotten, and
the point is decided by every earlier sweep whose track passes near it (the
sweep index, :func:`sweep_index`, buckets of the tool diameter; built only for
a path where a cutting move rises above an earlier one). The angle is then
exact to the bisection (1/8 deg, interpolated) unless the sweep that clears
the point is shadowed at the cells by a wider sweep at the same level (it
reaches past it by less than a cell). The material top for the axial depth is
decided the same way.

The functions are plain Python compiled with numba where available
(:func:`robolobe._jit.available`); without it they run as Python (slow:
for tests of the reference path only).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from robolobe import _jit

_INF = math.inf
#: Bisection steps refining a sign change between two angle samples (4 deg / 2^5).
_BISECT = 5
#: The tool's own trail: the last cutting moves that removed their material, always
#: candidates of the exact test (:func:`_candidates`).
_RECENT = 4
#: Bound on the material value's change per radian of edge angle, in tool radii (a
#: distance field is 1; the bilinear interpolation of one, up to sqrt 2).
_LIPSCHITZ = 1.5
#: Sub-samples of a sample step searched for a narrow arc (4 deg / 4 = 1 deg: every arc
#: of :data:`MIN_ARC_DEG` holds one).
_SUB = 4
#: An arc of material on the cutting edge narrower than this [deg] is none: a graze (a
#: sliver a micrometre over the level tolerance, as where the edge runs tangent to the
#: stock's outline) whose outermost angle would set the move's entry or exit by up to
#: tens of degrees though it carries under 1/180 of a slot's edge; the arc is dropped
#: with its angles and its depth. The references of ``studies/engagement.py`` and
#: ``tests/stock`` apply the same rule.
MIN_ARC_DEG = 1.0
_MIN_ARC = math.radians(MIN_ARC_DEG)
#: Four cells whose tops differ by at most this [m] are level (their top is exact enough).
_LEVEL_CELLS = 1e-6
#: Material thinner than this many cells at the edge is none (float rounding on a wall).
_EDGE_EPS = 0.01
#: Chain neighbours of a move (:func:`chain_neighbours`): the short ramp moves (x-y length
#: at most this many cells) whose ends lie within this many cells of path from the move's.
CHAIN_CELLS = 2.0
#: At most this many chain neighbours on each side of a move.
CHAIN_MAX = 8
#: The work area of :func:`_candidates` at the head of ``cand`` (the tool's trail, the
#: candidates); the sweep index (:func:`sweep_index`) follows it.
_CAND = 1 + _RECENT + 8 * (1 + 2 * CHAIN_MAX)


def _sweep(w, ids, m, x0, y0, res, radius, band, p0, p1, skip_start, tol):
    """Remove the material a flat end mill sweeps from ``p0`` to ``p1`` (x, y, z [m]).

    Every cell centre within ``radius + band`` of the tool axis's x-y track
    gets the clearance of this sweep (level rule: a lower sweep replaces, one
    at the same level keeps the larger clearance, a higher one is ignored);
    those within ``radius`` get their top lowered to the lowest tip height
    over the part of the move that covers them. ``skip_start``: the move
    continues the previous cutting move from ``p0`` and does not descend (it
    rises by at most the level tolerance), so that move's end disc already set
    the cells behind ``p0`` and those deep inside it as low as this one would.
    """
    ny = w.shape[0]
    nx = w.shape[1]
    ax, ay, az = p0[0], p0[1], p0[2]
    dx, dy, dz = p1[0] - ax, p1[1] - ay, p1[2] - az
    l2 = dx * dx + dy * dy
    ll = math.sqrt(l2)
    r = radius + band
    ymin = min(ay, ay + dy) - r
    ymax = max(ay, ay + dy) + r
    j0 = max(0, math.ceil((ymin - y0) / res - 0.5))
    j1 = min(ny - 1, math.floor((ymax - y0) / res - 0.5))
    rin = radius - band
    for j in range(j0, j1 + 1):
        yc = y0 + (j + 0.5) * res
        lo = _INF
        hi = -_INF
        for cx, cy in ((ax, ay), (ax + dx, ay + dy)):
            e = yc - cy
            if abs(e) <= r:
                hw = math.sqrt(r * r - e * e)
                lo = min(lo, cx - hw)
                hi = max(hi, cx + hw)
        if ll > 0.0:
            # the rectangle part: 0 <= t <= 1 and |u| <= r, both linear in x
            xa = -_INF
            xb = _INF
            # t(x) = (x - ax) dx / l2 + (yc - ay) dy / l2
            ct = (yc - ay) * dy / l2
            if abs(dx) > 1e-300:
                q1 = ax + (0.0 - ct) * l2 / dx
                q2 = ax + (1.0 - ct) * l2 / dx
                xa = max(xa, min(q1, q2))
                xb = min(xb, max(q1, q2))
            elif not (0.0 <= ct <= 1.0):
                xa, xb = _INF, -_INF
            # u(x) = (-(x - ax) dy + (yc - ay) dx) / ll
            cu = (yc - ay) * dx / ll
            if abs(dy) > 1e-300:
                q1 = ax + (cu - r) * ll / dy
                q2 = ax + (cu + r) * ll / dy
                xa = max(xa, min(q1, q2))
                xb = min(xb, max(q1, q2))
            elif abs(cu) > r:
                xa, xb = _INF, -_INF
            if xa <= xb:
                lo = min(lo, xa)
                hi = max(hi, xb)
        if lo > hi:
            continue
        if skip_start and ll > 0.0:
            # only cells ahead of the start: (x - ax) dx + (yc - ay) dy > 0
            if abs(dx) > 1e-300:
                xh = ax - (yc - ay) * dy / dx
                if dx > 0.0:
                    lo = max(lo, xh)
                else:
                    hi = min(hi, xh)
            elif (yc - ay) * dy <= 0.0:
                continue
            if lo > hi:
                continue
        i0 = max(0, math.ceil((lo - x0) / res - 0.5))
        i1 = min(nx - 1, math.floor((hi - x0) / res - 0.5))
        k0 = 1
        k1 = 0
        if skip_start and rin > 0.0:
            e = yc - ay
            if abs(e) < rin:
                hw = math.sqrt(rin * rin - e * e)
                k0 = math.ceil((ax - hw - x0) / res - 0.5)
                k1 = math.floor((ax + hw - x0) / res - 0.5)
        i = i0
        while i <= i1:
            if k0 <= i <= k1:
                i = k1 + 1
                continue
            xc = x0 + (i + 0.5) * res
            qx = xc - ax
            qy = yc - ay
            if skip_start and qx * dx + qy * dy <= 0.0:
                # behind the start: nearest point p0, as for the move that ended there
                i += 1
                continue
            t = 0.0
            if l2 > 0.0:
                t = min(1.0, max(0.0, (qx * dx + qy * dy) / l2))
            ex = qx - t * dx
            ey = qy - t * dy
            sv = radius - math.sqrt(ex * ex + ey * ey)
            if sv >= -band:
                if sv >= 0.0:
                    # lowest tip height over the part of the move that covers the centre
                    if dz == 0.0:
                        zc = az
                    elif l2 == 0.0:
                        zc = min(az, az + dz)
                    else:
                        b = qx * dx + qy * dy
                        disc = b * b - l2 * (qx * qx + qy * qy - radius * radius)
                        sq = math.sqrt(max(disc, 0.0))
                        t1 = min(1.0, max(0.0, (b - sq) / l2))
                        t2 = min(1.0, max(0.0, (b + sq) / l2))
                        zc = min(az + t1 * dz, az + t2 * dz)
                    if zc < w[j, i, 0]:
                        w[j, i, 0] = zc
                        ids[j, i, 1] = m
                elif l2 == 0.0:
                    zc = min(az, az + dz)  # a plunge: every height is as close
                else:
                    zc = az + t * dz
                z_old = w[j, i, 2]
                if zc < z_old - tol:
                    w[j, i, 1] = sv
                    w[j, i, 2] = zc
                    ids[j, i, 0] = m
                elif zc <= z_old + tol and sv > w[j, i, 1]:
                    w[j, i, 1] = sv
                    ids[j, i, 0] = m
            i += 1


def _sweep_value(w, i, j, z, res, tol):
    """Clearance of one cell at tip height ``z`` from the sweeps: negative where not cleared.

    Returns ``(value, clean)``: ``clean`` when the value is the clearance of the
    sweeps at the tip's own level (within ``tol``), the distance field that locates
    a single-level wall to a small fraction of a cell; not clean where the cell
    was cleared deeper than the tip (the wall at the tip's level may belong to
    other sweeps) or the value is only a sign (``0.5 res`` cleared, ``-res``
    material: a floor whose height crosses the tolerance between cell centres).
    """
    ny = w.shape[0]
    nx = w.shape[1]
    if i < 0 or j < 0 or i >= nx or j >= ny:
        return res, True
    zs = w[j, i, 2]
    valid = zs <= z + tol
    level = zs >= z - tol
    sv = w[j, i, 1]
    if w[j, i, 0] <= z + tol:  # cleared down to the tip (or above the stock top)
        if valid and sv > 0.0:
            return sv, level
        return 0.5 * res, False
    if valid and sv < 0.0:
        return sv, level
    return -res, False


def _move_dist(xyz, k, px, py):
    """Distance [m] of the point ``(px, py)`` from the x-y track of move ``k``."""
    ax = xyz[k - 1, 0]
    ay = xyz[k - 1, 1]
    dx = xyz[k, 0] - ax
    dy = xyz[k, 1] - ay
    qx = px - ax
    qy = py - ay
    l2 = dx * dx + dy * dy
    t = 0.0
    if l2 > 0.0:
        t = min(1.0, max(0.0, (qx * dx + qy * dy) / l2))
    ex = qx - t * dx
    ey = qy - t * dy
    return math.sqrt(ex * ex + ey * ey)


def _move_clear(xyz, k, px, py, z, rr, tol):
    """Exact clearance of the point ``(px, py)`` at tip height ``z`` by the sweep of move ``k``.

    ``min(rr - d, z + tol - level)``: ``d`` the distance from the move's x-y track
    (:func:`_move_dist`), ``level`` its lowest tip height over the part within
    ``rr`` of the point (:func:`_move_level`). Non-negative exactly where the move
    cleared the point to within ``tol`` of the tip.
    """
    return min(rr - _move_dist(xyz, k, px, py), z + tol - _move_level(xyz, k, px, py, rr))


def _candidates(ids, i, j, cand, chain):
    """The distinct sweeps (move indices) that may decide a point in the cell square
    ``(i..i+1, j..j+1)``: the last :data:`_RECENT` cutting moves that removed their
    material (``cand[1 : cand[0] + 1]``, set by :func:`_run`: the tool's own trail),
    each of the four cells' lowest-level and lowest-top sweeps, and their chain
    neighbours (``chain[k]``: the short moves before and after move ``k`` within
    :data:`CHAIN_CELLS` cells of path, :func:`chain_neighbours`) that have removed their
    material: in a chain of tiny moves at changing heights (a ramp, a helix) the
    sweep that clears a point is often one the cells do not remember, shadowed at
    every cell centre by a deeper or wider neighbour.
    Written to ``cand[1 : n + 1]``; returns ``n``."""
    nc = cand[0]
    newest = cand[1] if nc > 0 else 0
    for dj in range(2):
        for di in range(2):
            ii = i + di
            jj = j + dj
            if ii < 0 or jj < 0 or ii >= ids.shape[1] or jj >= ids.shape[0]:
                continue
            for q in range(2):
                k0 = ids[jj, ii, q]
                if k0 <= 0:
                    continue
                for k in range(k0 - chain[k0, 0], max(k0, min(k0 + chain[k0, 1], newest)) + 1):
                    new = True
                    for c in range(1, nc + 1):
                        if cand[c] == k:
                            new = False
                            break
                    if new and nc + 1 < _CAND:  # the sweep index follows
                        nc += 1
                        cand[nc] = k
    return nc


def _exact_clear(ids, xyz, i, j, px, py, z, rr, tol, cand, chain):
    """Exact clearance (:func:`_move_clear`) of a point by the sweeps its cells remember:
    the largest; ``-inf`` when none was stored there."""
    nc = _candidates(ids, i, j, cand, chain)
    best = -_INF
    for c in range(1, nc + 1):
        best = max(best, _move_clear(xyz, cand[c], px, py, z, rr, tol))
    return best


def _top_bounds(w, x0, y0, res, px, py):
    """Lowest and highest top [m] of the four cells around the point ``(px, py)``."""
    i = math.floor((px - x0) / res - 0.5)
    j = math.floor((py - y0) / res - 0.5)
    lo = _INF
    hi = -_INF
    for dj in range(2):
        for di in range(2):
            h = _top(w, i + di, j + dj)
            lo = min(lo, h)
            hi = max(hi, h)
    return lo, hi


def _cleared_deeper(w, i, j, z, tol):
    """Whether one of the four cells ``(i..i+1, j..j+1)`` was reached by a sweep deeper than
    the tip ``z`` [m] (its level or its top more than ``tol`` below): its records then
    name that sweep, not necessarily the one that cleared the material at the tip's level."""
    for dj in range(2):
        for di in range(2):
            ii = i + di
            jj = j + dj
            if ii < 0 or jj < 0 or ii >= w.shape[1] or jj >= w.shape[0]:
                continue
            if w[jj, ii, 2] < z - tol or w[jj, ii, 0] < z - tol:
                return True
    return False


def _bucket(index, x0, y0, res, px, py):
    """Entries ``(lo, hi)`` of the sweep index (:func:`sweep_index`, ``cand[_CAND:]`` in the
    kernels) of the bucket holding the point ``(px, py)``: its moves are ``index[lo:hi]``
    (none off the index or where it is empty)."""
    nbx = index[0]
    if nbx == 0:
        return 0, 0
    side = index[2] * res
    bi = math.floor((px - x0) / side)
    bj = math.floor((py - y0) / side)
    if bi < 0 or bj < 0 or bi >= nbx or bj >= index[1]:
        return 0, 0
    b = 3 + bj * nbx + bi
    return index[b], index[b + 1]


def _index_clear(index, xyz, x0, y0, res, px, py, z, rr, tol, newest):
    """Exact clearance (:func:`_move_clear`) of the point ``(px, py)`` at tip height ``z`` by
    every cutting move up to ``newest`` whose sweep may reach it: the moves of the
    point's bucket of the sweep index (:func:`sweep_index`); the largest, ``-inf`` where
    there is none (or no index). Stops at the first that clears the point."""
    lo, hi = _bucket(index, x0, y0, res, px, py)
    best = -_INF
    for e in range(lo, hi):
        k = index[e]
        if k > newest:
            break  # in order of the path: the rest have not removed their material yet
        best = max(best, _move_clear(xyz, k, px, py, z, rr, tol))
        if best >= 0.0:
            break
    return best


def _exact_top(w, ids, xyz, x0, y0, res, rr, ztop, px, py, cand, chain):
    """Material top [m] at the point ``(px, py)``, within the four cells' tops.

    Where the four cells around the point are level (within a micrometre), their
    lowest top; otherwise the lowest tip height of the remembered sweeps
    (:func:`_candidates`) that cover the point (the exact floor of a ramp, the
    step of a wall), or the highest of the four cells where none does. Where that
    leaves the point above the lowest of the four cells, the sweep that lowered it
    may be one no cell remembers (a deeper sweep replaced its records: the floor of
    a holding tab's first traverse next to the deeper passes): then every earlier
    sweep of the point's bucket of the sweep index (``cand[_CAND:]``) decides
    (:func:`_index_top`).
    """
    lo, hi = _top_bounds(w, x0, y0, res, px, py)
    if hi - lo <= _LEVEL_CELLS:
        return lo
    nc = _candidates(ids, math.floor((px - x0) / res - 0.5), math.floor((py - y0) / res - 0.5),
                     cand, chain)  # fmt: skip
    top = min(hi, ztop)
    for c in range(1, nc + 1):
        if _move_dist(xyz, cand[c], px, py) <= rr:
            top = min(top, _move_level(xyz, cand[c], px, py, rr))
    if top > lo + _LEVEL_CELLS:
        newest = cand[1] if cand[0] > 0 else 0
        top = _index_top(cand[_CAND:], xyz, x0, y0, res, px, py, rr, newest, top)
    return max(top, lo)


def _index_top(index, xyz, x0, y0, res, px, py, rr, newest, top):
    """``top`` [m] lowered to the lowest tip height (:func:`_move_level`) of the cutting
    moves up to ``newest`` that pass within ``rr`` of the point ``(px, py)``, from the
    point's bucket of the sweep index (:func:`sweep_index`; none where it is empty)."""
    lo, hi = _bucket(index, x0, y0, res, px, py)
    for e in range(lo, hi):
        k = index[e]
        if k > newest:
            break
        if _move_dist(xyz, k, px, py) <= rr:
            top = min(top, _move_level(xyz, k, px, py, rr))
    return top


def _move_level(xyz, k, px, py, rr):
    """Lowest tip height [m] of move ``k`` over its part within ``rr`` of ``(px, py)``
    (at the nearest point of the track where no part is)."""
    ax = xyz[k - 1, 0]
    ay = xyz[k - 1, 1]
    az = xyz[k - 1, 2]
    dx = xyz[k, 0] - ax
    dy = xyz[k, 1] - ay
    dz = xyz[k, 2] - az
    qx = px - ax
    qy = py - ay
    l2 = dx * dx + dy * dy
    if l2 == 0.0:
        return min(az, az + dz)
    b = qx * dx + qy * dy
    disc = b * b - l2 * (qx * qx + qy * qy - rr * rr)
    if disc < 0.0:
        t = min(1.0, max(0.0, b / l2))
        return az + t * dz
    sq = math.sqrt(disc)
    t1 = min(1.0, max(0.0, (b - sq) / l2))
    t2 = min(1.0, max(0.0, (b + sq) / l2))
    return min(az + t1 * dz, az + t2 * dz)


def _top(w, i, j):
    """Material top of one cell [m] (-inf off the grid)."""
    if i < 0 or j < 0 or i >= w.shape[1] or j >= w.shape[0]:
        return -_INF
    return w[j, i, 0]


def _stock_value(w, i, j, res):
    """Signed distance of one cell to the stock outline (negative inside)."""
    if i < 0 or j < 0 or i >= w.shape[1] or j >= w.shape[0]:
        return res
    return w[j, i, 3]


def _edge_value(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, ph, cand, chain):
    """Material value at edge angle ``ph`` [rad] (negative: material).

    The larger of the sweep clearance and the interpolated distance to the stock
    outline (each a smooth field; their maximum is taken after the
    interpolation, so an edge near the stock's outline is not blurred). The
    sweep clearance is the bilinear interpolation of the four cells' clearances
    (:func:`_sweep_value`) where they are all clean or all of one sign; where the
    cells disagree and one is not clean (a floor crossing the tolerance between
    cell centres: a helix's or a ramp's bottom; a wall at the tip's level over
    cells cut deeper before) it is the exact clearance by the sweeps the four
    cells remember (:func:`_exact_clear`), so the answer does not hang on where
    the cell centres fall. Shifted by the level tolerance ``tol`` (at least
    ``_EDGE_EPS * res``): material thinner than it in x-y is none, as it is in z.
    An edge point on the boundary of an earlier cut (a pass retracing a wall, the
    flanks of a slot's own track, an arc retraced with other chords: up to the
    readers' chord tolerance proud of the wall) is not in material; the angle of
    such a graze would hang on a micrometre (1 um of clearance moves a tangent
    graze's end by about 2 deg), the cut is none.
    """
    sp = math.sin(ph)
    cp = math.cos(ph)
    px = cx + radius * (sp * fx - cp * fy)
    py = cy + radius * (sp * fy + cp * fx)
    gx = (px - x0) / res - 0.5
    gy = (py - y0) / res - 0.5
    i = math.floor(gx)
    j = math.floor(gy)
    ux = gx - i
    uy = gy - j
    v00, c00 = _sweep_value(w, i, j, z, res, tol)
    v10, c10 = _sweep_value(w, i + 1, j, z, res, tol)
    v01, c01 = _sweep_value(w, i, j + 1, z, res, tol)
    v11, c11 = _sweep_value(w, i + 1, j + 1, z, res, tol)
    w00 = (1.0 - ux) * (1.0 - uy)
    w10 = ux * (1.0 - uy)
    w01 = (1.0 - ux) * uy
    w11 = ux * uy
    stock = (
        w00 * _stock_value(w, i, j, res)
        + w10 * _stock_value(w, i + 1, j, res)
        + w01 * _stock_value(w, i, j + 1, res)
        + w11 * _stock_value(w, i + 1, j + 1, res)
    )
    shift = max(_EDGE_EPS * res, tol)
    lo = min(min(v00, v10), min(v01, v11))
    hi = max(max(v00, v10), max(v01, v11))
    if lo < 0.0 <= hi:
        exact = -_INF
        if c00 and c10 and c01 and c11:
            if i >= 0 and j >= 0 and i + 1 < ids.shape[1] and j + 1 < ids.shape[0]:
                # one level: the clearance is one sweep's distance field where the four
                # cells have it from one sweep; from several, the exact largest of theirs
                # (the interpolation would cut the corner where two sweeps' edges meet)
                k00 = ids[j, i, 0]
                k10 = ids[j, i + 1, 0]
                k01 = ids[j + 1, i, 0]
                k11 = ids[j + 1, i + 1, 0]
                if not (k00 == k10 and k00 == k01 and k00 == k11):
                    rr = radius + shift
                    for k in (k00, k10, k01, k11):
                        if k > 0:
                            exact = max(exact, _move_clear(xyz, k, px, py, z, rr, tol))
        else:
            exact = _exact_clear(ids, xyz, i, j, px, py, z, radius + shift, tol, cand, chain)
            if exact < 0.0 and _cleared_deeper(w, i, j, z, tol):
                # a deeper sweep has replaced the cells' records since: the sweep at the
                # tip's level that cleared the point (a pass over a holding tab, over the
                # floor of a deeper pass) may be remembered by none of them
                exact = max(exact, _index_clear(cand[_CAND:], xyz, x0, y0, res, px, py, z,
                                                radius + shift, tol,
                                                cand[1] if cand[0] > 0 else 0))  # fmt: skip
        if exact > -_INF:
            return max(exact, stock + shift)
    sweep = w00 * v00 + w10 * v10 + w01 * v01 + w11 * v11
    return max(sweep, stock) + shift


def _crossing(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, a, va, b, vb, cand, chain):
    """Angle [rad] between ``a`` and ``b`` where the value changes sign (bisection, then linear)."""
    for _ in range(_BISECT):
        m = 0.5 * (a + b)
        vm = _edge_value(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, m, cand, chain)
        if (vm < 0.0) == (va < 0.0):
            a = m
            va = vm
        else:
            b = m
            vb = vm
    return a + (b - a) * va / (va - vb)


def _sample_crossing(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, dphi, vals, k,
                     cand, chain):  # fmt: skip
    """:func:`_crossing` between the edge samples ``k - 1`` and ``k`` (values ``vals``)."""
    return _crossing(
        w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, (k - 1) * dphi, vals[k - 1],
        k * dphi, vals[k], cand, chain,
    )  # fmt: skip


def _point_depth(w, ids, xyz, x0, y0, res, radius, rr, ztop, cx, cy, fx, fy, ph, z, tol, base,
                 depth, cand, chain):  # fmt: skip
    """``depth`` [m] raised to the material height above ``base`` at the engaged edge point at
    angle ``ph`` [rad] (tool centre ``(cx, cy)``, feed ``(fx, fy)``).

    The height is the material top one cell inside the edge point where that stands above
    the tip ``z`` (at the edge itself the top jumps where the edge runs along the wall of an
    earlier, deeper cut); where the point one cell inside is cleared down to the tip (a
    crescent or a wall thinner than a cell: the outer side of a turn, a finishing pass at
    a step-down's wall, a sliver), the top at the edge point itself. The four cells'
    highest top bounds both: where it leaves nothing above ``depth`` the exact tops
    (:func:`_exact_top`) are not computed.
    """
    ux = math.sin(ph) * fx - math.cos(ph) * fy
    uy = math.sin(ph) * fy + math.cos(ph) * fx
    rin = radius - res
    qx = cx + rin * ux
    qy = cy + rin * uy
    ex = cx + radius * ux
    ey = cy + radius * uy
    lo, hi = _top_bounds(w, x0, y0, res, qx, qy)
    level = hi - lo <= _LEVEL_CELLS
    if level and lo > z + tol:
        return max(depth, lo - base)
    elo, ehi = _top_bounds(w, x0, y0, res, ex, ey)
    if max(hi, ehi) - base <= depth:
        return depth
    if not level:
        top = _exact_top(w, ids, xyz, x0, y0, res, rr, ztop, qx, qy, cand, chain)
        if top > z + tol:
            return max(depth, top - base)
    if ehi - base <= depth:
        return depth
    top = elo
    if ehi - elo > _LEVEL_CELLS:
        top = _exact_top(w, ids, xyz, x0, y0, res, rr, ztop, ex, ey, cand, chain)
    if top > z + tol:
        return max(depth, top - base)
    return depth


def _engage(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, bottom, ztop, tol, nphi, vals,
            pend, out, cand, chain, arcs, subs):  # fmt: skip
    """Engagement of the cutting edge at one tool position.

    The front half of the edge is sampled at ``nphi`` angles; each change
    of sign is refined by bisection. Writes ``out = (phi_entry, phi_exit,
    n_arcs, depth)``: entry and exit angles [rad] in the feed frame (x along
    ``(fx, fy)``, y to its left, angle clockwise from +y seen from +z), the
    number of separate engaged arcs, and the axial depth [m] of the material
    under the engaged edge above the tip or the stock bottom: the largest, over
    the engaged edge points (the samples, the sub-samples and each arc's two
    refined ends), of the top one cell inside the point where that stands above
    the tip, else the top at the point itself (:func:`_point_depth`). An arc of
    material narrower than :data:`MIN_ARC_DEG` is none (a graze: its angles would hang on a
    micrometre of material): it adds no arc, angle or depth. No engagement:
    ``n_arcs = 0`` and NaN angles. ``pend``, ``arcs`` (rows ``lo, hi, k0, k1``:
    an arc's angles and, from the samples, its first and last sample; ``-1``
    for one found between samples) and ``subs`` (rows ``angle, arc``) are scratch.
    """
    dphi = math.pi / (nphi - 1)
    rr = radius + max(_EDGE_EPS * res, tol)
    rin = radius - res
    base = max(z, bottom)
    depth = 0.0
    full = ztop - base  # the deepest there is: no need to look further
    for k in range(nphi):
        ph = k * dphi
        v = _edge_value(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, ph, cand, chain)
        vals[k] = v
        pend[k] = False
        if v < 0.0 and depth < full:
            # the material top one cell inside the engaged edge point (at the edge itself
            # the top jumps where the edge runs along the wall of an earlier, deeper cut):
            # level cells now, the others (exact, slower) after, where they may be deeper
            ux = math.sin(ph) * fx - math.cos(ph) * fy
            uy = math.sin(ph) * fy + math.cos(ph) * fx
            lo, hi = _top_bounds(w, x0, y0, res, cx + rin * ux, cy + rin * uy)
            if hi - lo <= _LEVEL_CELLS and lo > z + tol:
                depth = max(depth, lo - base)
            else:  # not level, or cleared there: decided after (:func:`_point_depth`)
                pend[k] = True
    # the arcs of the samples, each end refined
    na = 0
    k = 0
    while k < nphi:
        if vals[k] < 0.0:
            k0 = k
            while k + 1 < nphi and vals[k + 1] < 0.0:
                k += 1
            lo = 0.0
            if k0 > 0:
                lo = _sample_crossing(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol,
                                      dphi, vals, k0, cand, chain)  # fmt: skip
            hi = math.pi
            if k < nphi - 1:
                hi = _sample_crossing(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol,
                                      dphi, vals, k + 1, cand, chain)  # fmt: skip
            arcs[na, 0] = lo
            arcs[na, 1] = hi
            arcs[na, 2] = k0
            arcs[na, 3] = k
            na += 1
        k += 1
    # arcs narrower than a sample step, between two samples in air: the value is about
    # Lipschitz in the edge angle (at most R per rad: a distance field along an edge
    # point moving at R), so two samples whose values sum to more than the step's travel
    # have none between them; the others are sampled every quarter step (1 deg, so that
    # no arc of MIN_ARC_DEG is missed), and an arc found there is refined as the others are
    lim = _LIPSCHITZ * radius * dphi
    ns = 0
    for k in range(1, nphi):
        va = vals[k - 1]
        vb = vals[k]
        if va < 0.0 or vb < 0.0 or va + vb >= lim:
            continue
        pa = (k - 1) * dphi
        pv = va
        for q in range(1, _SUB + 1):
            ph = (k - 1 + q / _SUB) * dphi
            v = vb
            if q < _SUB:
                v = _edge_value(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, ph,
                                cand, chain)  # fmt: skip
            if (v < 0.0) != (pv < 0.0):
                cr = _crossing(w, ids, xyz, x0, y0, res, radius, cx, cy, z, fx, fy, tol, pa, pv,
                               ph, v, cand, chain)  # fmt: skip
                if v < 0.0:
                    arcs[na, 0] = cr
                    arcs[na, 2] = -1.0
                    arcs[na, 3] = -1.0
                else:  # the interval ends in air: every arc opened in it closes
                    arcs[na, 1] = cr
                    na += 1
            if v < 0.0:
                subs[ns, 0] = ph
                subs[ns, 1] = na
                ns += 1
            pa = ph
            pv = v
    # the arcs that count, and the depth under their edge points
    narcs = 0
    entry = math.inf
    exit_ = -math.inf
    for a in range(na):
        if arcs[a, 1] - arcs[a, 0] >= _MIN_ARC:
            narcs += 1
            entry = min(entry, arcs[a, 0])
            exit_ = max(exit_, arcs[a, 1])
    redo = False  # a dropped arc holds samples: their depth is none
    for a in range(na):
        if arcs[a, 2] >= 0.0 and arcs[a, 1] - arcs[a, 0] < _MIN_ARC:
            redo = True
    if narcs == 0:
        depth = 0.0
    else:
        if redo:
            depth = 0.0
            for k in range(nphi):
                pend[k] = False
            for a in range(na):
                if arcs[a, 2] < 0.0 or arcs[a, 1] - arcs[a, 0] < _MIN_ARC:
                    continue
                for k in range(int(arcs[a, 2]), int(arcs[a, 3]) + 1):
                    if depth >= full:
                        break
                    ph = k * dphi
                    ux = math.sin(ph) * fx - math.cos(ph) * fy
                    uy = math.sin(ph) * fy + math.cos(ph) * fx
                    lo, hi = _top_bounds(w, x0, y0, res, cx + rin * ux, cy + rin * uy)
                    if hi - lo <= _LEVEL_CELLS and lo > z + tol:
                        depth = max(depth, lo - base)
                    else:
                        pend[k] = True
        for k in range(nphi):
            if pend[k] and depth < full:
                depth = _point_depth(w, ids, xyz, x0, y0, res, radius, rr, ztop, cx, cy, fx, fy,
                                     k * dphi, z, tol, base, depth, cand, chain)  # fmt: skip
        for q in range(ns):
            a = int(subs[q, 1])
            if depth < full and arcs[a, 1] - arcs[a, 0] >= _MIN_ARC:
                depth = _point_depth(w, ids, xyz, x0, y0, res, radius, rr, ztop, cx, cy, fx, fy,
                                     subs[q, 0], z, tol, base, depth, cand, chain)  # fmt: skip
        # each kept arc's refined ends, just inside (up to a sample step from the nearest
        # sample: the material there may stand higher than anywhere the samples fall, as
        # where a ramp's edge meets a wall's untouched top beside an earlier deeper pass)
        inset = dphi / (1 << _BISECT)
        for a in range(na):
            width = arcs[a, 1] - arcs[a, 0]
            if width < _MIN_ARC or depth >= full:
                continue
            d_in = min(inset, 0.5 * width)
            lo = arcs[a, 0] + d_in
            hi = arcs[a, 1] - d_in
            if arcs[a, 0] > 0.0:
                depth = _point_depth(w, ids, xyz, x0, y0, res, radius, rr, ztop, cx, cy, fx, fy,
                                     lo, z, tol, base, depth, cand, chain)  # fmt: skip
            if arcs[a, 1] < math.pi:
                depth = _point_depth(w, ids, xyz, x0, y0, res, radius, rr, ztop, cx, cy, fx, fy,
                                     hi, z, tol, base, depth, cand, chain)  # fmt: skip
    out[0] = entry if narcs > 0 else math.nan
    out[1] = exit_ if narcs > 0 else math.nan
    out[2] = narcs
    out[3] = depth


def _remove(w, ids, x0, y0, res, radius, band, xyz, cutting, tol, m, prev_cut_end, p0, p1):
    """Move ``m``'s material removal (a cutting move: its sweep); returns the last
    cutting move that has removed its material (``p0``, ``p1``: scratch (3,))."""
    if m == 0 or not cutting[m]:
        return prev_cut_end
    for c in range(3):
        p0[c] = xyz[m - 1, c]
        p1[c] = xyz[m, c]
    # the previous move's end disc has set the cells around p0 to p0's height or lower: a
    # move that does not descend adds nothing there. One that descends, even by less than
    # the level tolerance, must lower them: a helix's chords each drop a few micrometres,
    # and skipped, the floor of its start disc would stay as high as the drops add up to
    rise = p1[2] - p0[2]
    flat = 0.0 <= rise <= tol
    _sweep(w, ids, m, x0, y0, res, radius, band, p0, p1, flat and prev_cut_end == m - 1, tol)
    return m


def _run(
    w,
    ids,
    x0,
    y0,
    res,
    radius,
    band,
    xyz,
    cutting,
    cum,
    lag,
    step,
    turn_cos,
    bottom,
    ztop,
    tol,
    nphi,
    phi_entry,
    phi_exit,
    n_arcs,
    depth,
    plunge,
    chain,
    index,
):
    """Walk the path: engagement of every cutting move, then its material removal.

    Before move ``i`` is queried, every earlier cutting move that ends at
    least ``lag`` [m] of path before move ``i``'s end has removed its
    material (so a chain of tiny moves sees the workpiece as it was ``lag``
    behind the tool, not the boundary of its own last step). Move ``i`` is
    sampled at ``lag`` into the move after a turn (when longer than
    ``2 lag``) and every ``step`` [m] up to its end; the move keeps the
    smallest entry, the largest exit, the most arcs and the largest depth
    of its samples. ``index``: the sweep index (:func:`sweep_index`), kept after the
    candidates' work area in ``cand`` (``cand[_CAND:]``: the edge test reaches it there
    without one more array passed down every call).
    """
    n = xyz.shape[0]
    vals = np.empty(nphi)
    pend = np.zeros(nphi, dtype=np.bool_)
    arc_rows = np.empty((nphi * _SUB, 4))  # _engage's scratch
    sub_rows = np.empty((nphi * _SUB, 2))
    out = np.empty(4)
    cand = np.zeros(_CAND + index.shape[0], dtype=np.int64)
    cand[_CAND:] = index
    p0 = np.empty(3)
    p1 = np.empty(3)
    applied = 0  # moves [0, applied) have removed their material
    last_dir_x = 0.0
    last_dir_y = 0.0
    prev_cut_end = -1
    for i in range(1, n):
        if not cutting[i]:
            last_dir_x = 0.0
            last_dir_y = 0.0
            continue
        # bring the workpiece up to date (lagged for tiny moves)
        while applied < i and cum[applied] <= cum[i] - lag:
            prev_cut_end = _remove(w, ids, x0, y0, res, radius, band, xyz, cutting, tol, applied,
                                   prev_cut_end, p0, p1)  # fmt: skip
            if applied > 0 and cutting[applied]:
                # the tool's trail (cand[1 : cand[0] + 1], newest first)
                for c in range(min(cand[0], _RECENT - 1), 0, -1):
                    cand[c + 1] = cand[c]
                cand[1] = applied
                cand[0] = min(cand[0] + 1, _RECENT)
            applied += 1
        ax, ay, az = xyz[i - 1, 0], xyz[i - 1, 1], xyz[i - 1, 2]
        dx, dy, dz = xyz[i, 0] - ax, xyz[i, 1] - ay, xyz[i, 2] - az
        lxy = math.sqrt(dx * dx + dy * dy)
        if lxy <= 1e-3 * res:
            # plunge (or a pure z move): the end face cuts what lies under the tool
            plunge[i] = True
            last_dir_x = 0.0
            last_dir_y = 0.0
            gi = math.floor((ax - x0) / res)
            gj = math.floor((ay - y0) / res)
            top = -_INF
            if 0 <= gi < w.shape[1] and 0 <= gj < w.shape[0] and w[gj, gi, 3] < 0.0:
                top = w[gj, gi, 0]
            d = min(top, max(az, az + dz)) - max(min(az, az + dz), bottom)
            if dz < 0.0 and d > tol:
                phi_entry[i] = 0.0
                phi_exit[i] = math.pi
                n_arcs[i] = 1
                depth[i] = d
            continue
        fx = dx / lxy
        fy = dy / lxy
        nseg = max(1, math.ceil(lxy / step))
        turned = last_dir_x * fx + last_dir_y * fy < turn_cos
        last_dir_x = fx
        last_dir_y = fy
        first = 1 if (turned and lxy > 2.0 * lag) else 0
        ent = _INF
        ext = -_INF
        arcs = 0
        dep = 0.0
        for k in range(1 - first, nseg + 1):
            t = lag / lxy if k == 0 else k / nseg
            _engage(
                w,
                ids,
                xyz,
                x0,
                y0,
                res,
                radius,
                ax + t * dx,
                ay + t * dy,
                az + t * dz,
                fx,
                fy,
                bottom,
                ztop,
                tol,
                nphi,
                vals,
                pend,
                out,
                cand,
                chain,
                arc_rows,
                sub_rows,
            )
            if out[2] > 0:
                ent = min(ent, out[0])
                ext = max(ext, out[1])
                arcs = max(arcs, int(out[2]))
                dep = max(dep, out[3])
        if arcs > 0:
            phi_entry[i] = ent
            phi_exit[i] = ext
            n_arcs[i] = arcs
            depth[i] = dep
    # the remaining moves remove their material too (the final workpiece)
    while applied < n:
        prev_cut_end = _remove(w, ids, x0, y0, res, radius, band, xyz, cutting, tol, applied,
                               prev_cut_end, p0, p1)  # fmt: skip
        applied += 1


def _register(xyz, cutting, reach, bx0, by0, bs, nbx, nby, start, moves, fill):
    """Bucket the cutting moves of a path: count (``fill`` False: ``start[b + 1]`` += 1 per
    move that may reach bucket ``b``) or write (``fill`` True: the moves at ``start[b]``
    on, in path order; ``start`` is advanced). A move may reach a bucket when its x-y
    track passes within ``reach`` [m] of the bucket square (tested on the bucket's
    circumscribed circle)."""
    half = 0.5 * bs * math.sqrt(2.0)
    for k in range(1, xyz.shape[0]):
        if not cutting[k]:
            continue
        ax = xyz[k - 1, 0]
        ay = xyz[k - 1, 1]
        bx = xyz[k, 0]
        by = xyz[k, 1]
        i0 = max(0, math.floor((min(ax, bx) - reach - bx0) / bs))
        i1 = min(nbx - 1, math.floor((max(ax, bx) + reach - bx0) / bs))
        j0 = max(0, math.floor((min(ay, by) - reach - by0) / bs))
        j1 = min(nby - 1, math.floor((max(ay, by) + reach - by0) / bs))
        for bj in range(j0, j1 + 1):
            for bi in range(i0, i1 + 1):
                if _move_dist(xyz, k, bx0 + (bi + 0.5) * bs, by0 + (bj + 0.5) * bs) > reach + half:
                    continue
                b = bj * nbx + bi
                if fill:
                    moves[start[b]] = k
                    start[b] += 1
                else:
                    start[b + 1] += 1


def _rises(xyz, cutting, tol):
    """Whether a cutting move of the path rises more than ``tol`` [m] above the lowest tip
    of the cutting moves before it (a loop: no temporaries the size of the path)."""
    floor = _INF
    for k in range(1, xyz.shape[0]):
        if not cutting[k]:
            continue
        za = xyz[k - 1, 2]
        zb = xyz[k, 2]
        if max(za, zb) > floor + tol:
            return True
        floor = min(floor, min(za, zb))
    return False


def chain_neighbours(xyz: Any, cutting: Any, res: float) -> Any:
    """Per move, how many moves before and after it are its chain neighbours.

    A neighbour of move ``k`` is a cutting move ``m`` (at most :data:`CHAIN_MAX`
    away, the moves between them neighbours too) that changes height (a ramp's,
    a helix's, a lead-out's step), whose x-y length is at most
    :data:`CHAIN_CELLS` cells and which is separated from move ``k`` by at most
    :data:`CHAIN_CELLS` cells of x-y path. The exact test takes them as
    candidates with the sweeps a cell remembers (:func:`_candidates`). At one
    height the cells keep the sweep of the largest clearance, which decides the
    point; so level moves and long moves have none, and a path of them costs
    nothing more (the 1e6-move zig-zag of ``benchmarks/bench_engagement.py``,
    every move 12 um, is level). A step under the level tolerance counts too:
    a helix's chords that each drop less than it are more than it apart two
    chords on, so a later chord's band (:func:`_sweep`'s level rule: a lower
    sweep replaces) takes the cells along the edge of the one that cleared them
    (a random case's probe at D/13.4 to D/22 erred by 1.25 deg).

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip positions [m].
    cutting : ndarray of bool, shape (n,)
        Feed moves.
    res : float
        Z-map cell [m].

    Returns
    -------
    ndarray of int8, shape (n, 2)
        Neighbours before (column 0) and after (column 1) each move.
    """
    n = len(xyz)
    out = np.zeros((n, 2), dtype=np.int8)
    if n < 3:
        return out
    lxy = np.r_[0.0, np.hypot(*np.diff(xyz[:, :2], axis=0).T)]
    cumxy = np.cumsum(lxy)  # x-y path to the end of each move
    seg = np.cumsum(~np.asarray(cutting, dtype=bool))  # one value along a run of cutting moves
    lim = CHAIN_CELLS * res
    short = (lxy <= lim) & (np.r_[0.0, np.diff(xyz[:, 2])] != 0.0)
    k = np.arange(n)
    cut = np.asarray(cutting, dtype=bool)
    back = np.ones(n, dtype=bool)
    fwd = np.ones(n, dtype=bool)
    for d in range(1, CHAIN_MAX + 1):
        m = k - d
        ok = m >= 1
        mc = np.maximum(m, 0)
        back &= ok & cut[mc] & (seg[mc] == seg) & short[mc] & (cumxy[k - 1] - cumxy[mc] <= lim)
        out[back, 0] = d
        m = k + d
        mc = np.minimum(m, n - 1)
        fwd &= (m < n) & (seg[mc] == seg) & short[mc] & (cumxy[mc - 1] - cumxy[k] <= lim)
        out[fwd, 1] = d
    out[~cut] = 0
    return out


def sweep_index(
    xyz: Any,
    cutting: Any,
    radius: float,
    res: float,
    x0: float,
    y0: float,
    nx: int,
    ny: int,
    tol: float,
) -> Any:
    """The sweep index of a path: for each bucket of a square grid over the Z-map, the
    cutting moves whose sweep may reach it, in path order.

    The exact test of :func:`_edge_value` decides a point from the sweeps its four cells
    remember; a cell remembers its lowest-level and lowest-top sweeps, so once a deeper
    sweep reaches it the one that cleared it at a higher level is forgotten. A tip that
    runs at such a level again (over a holding tab left by the pass before, over the
    shoulder of a deeper pocket) is then decided from every earlier sweep near the
    point, through this index (:func:`_index_clear`, :func:`_index_top`): exact, as the
    definition. Only a path where a cutting move rises more than ``tol`` above an
    earlier one needs it; for the others (one level, or only descending) it is empty.

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip positions [m].
    cutting : ndarray of bool, shape (n,)
        Feed moves.
    radius, res : float
        Tool radius and Z-map cell [m].
    x0, y0 : float
        Corner of the Z-map [m] (the buckets' too); ``nx``, ``ny`` its cells.
    tol : float
        Level tolerance [m].

    Returns
    -------
    ndarray of int64
        One array (the kernels pass it down to every edge test): ``nbx, nby, side``
        (buckets along x and y; bucket side in cells, at least the tool diameter),
        then ``nbx * nby + 1`` offsets into this array, bucket ``b`` holding the moves
        ``index[index[3 + b] : index[4 + b]]``. ``[0, 0, 0]`` when empty.
    """
    p = np.asarray(xyz, dtype=np.float64)
    cut = np.asarray(cutting, dtype=np.bool_)
    if not globals()["_rises"](p, cut, tol):
        return np.zeros(3, dtype=np.int64)
    side = math.ceil(2.0 * radius / res)
    bs = side * res
    nbx = max(1, math.ceil(nx / side))
    nby = max(1, math.ceil(ny / side))
    nb = nbx * nby
    reach = radius + res + tol  # beyond the exact test's radius + max(0.01 res, tol)
    register = globals()["_register"]
    start = np.zeros(nb + 1, dtype=np.int64)
    register(p, cut, reach, x0, y0, bs, nbx, nby, start, start, False)
    np.cumsum(start, out=start)
    index = np.zeros(4 + nb + int(start[-1]), dtype=np.int64)
    index[:3] = (nbx, nby, side)
    index[3 : 4 + nb] = start + 4 + nb
    register(p, cut, reach, x0, y0, bs, nbx, nby, index[3 : 3 + nb].copy(), index, True)
    return index


_COMPILED: dict[str, Any] = {}
#: The scalar :func:`_sweep` (what numba compiles) once the Python path has replaced it.
_SCALAR: dict[str, Any] = {}


def _python_kernels() -> Any:
    """``run`` and ``sweep`` in Python: the sweep's cells as numpy arrays
    (:func:`robolobe.stock._sweep_rows.sweep`, equal bit for bit to :func:`_sweep`)."""
    if "sweep" not in _SCALAR:
        from robolobe.stock._sweep_rows import sweep as rows

        scalar = _SCALAR["sweep"] = _sweep

        def sweep(w, ids, m, x0, y0, res, radius, band, p0, p1, skip_start, tol):
            rows(w, ids, m, x0, y0, res, radius, band, p0, p1, skip_start, tol, scalar)

        globals()["_sweep"] = sweep  # what _remove calls
    return _run, globals()["_sweep"]


def kernels(work: float = math.inf) -> Any:
    """``run`` and ``sweep``: compiled where numba is available and ``work`` (:func:`work`)
    pays for its start-up (:data:`JIT_MIN_WORK`), else the Python functions (numba not
    imported); compiled whatever the size once compiled in this process."""
    if "run" not in _COMPILED and not _jit.use_compiled(
        work, cold=JIT_MIN_WORK, warm=JIT_MIN_WORK_STARTED
    ):
        return _python_kernels()
    if "run" not in _COMPILED:
        if _jit.available():
            deco = _jit.njit()
            g = globals()
            g["_sweep"] = deco(_SCALAR.get("sweep", _sweep))
            g["_sweep_value"] = deco(_sweep_value)
            g["_move_dist"] = deco(_move_dist)
            g["_move_level"] = deco(_move_level)
            g["_move_clear"] = deco(_move_clear)
            g["_candidates"] = deco(_candidates)
            g["_exact_clear"] = deco(_exact_clear)
            g["_exact_top"] = deco(_exact_top)
            g["_cleared_deeper"] = deco(_cleared_deeper)
            g["_bucket"] = deco(_bucket)
            g["_index_clear"] = deco(_index_clear)
            g["_index_top"] = deco(_index_top)
            g["_register"] = deco(_register)
            g["_rises"] = deco(_rises)
            g["_top_bounds"] = deco(_top_bounds)
            g["_stock_value"] = deco(_stock_value)
            g["_top"] = deco(_top)
            g["_edge_value"] = deco(_edge_value)
            g["_point_depth"] = deco(_point_depth)
            g["_crossing"] = deco(_crossing)
            g["_sample_crossing"] = deco(_sample_crossing)
            g["_remove"] = deco(_remove)
            g["_engage"] = deco(_engage)
            g["_run"] = deco(_run)
        _COMPILED["run"] = globals()["_run"]
        _COMPILED["sweep"] = globals()["_sweep"]
    return _COMPILED["run"], _COMPILED["sweep"]


#: :func:`work` from which :func:`kernels` compiles in a fresh process. Measured
#: (benchmarks/bench_jit.py --kernel stock, CPU, 2-core machine at load 5): the Python
#: kernel costs 1.9 us per swept cell and 0.53 ms per engagement sample (fit over 11
#: zig-zags and the bundled pocket, residuals < 0.07 s), numba's start-up and the
#: cached kernels' first call 0.55-0.6 s; equal at ~290,000 units. The numpy sweep
#: (:func:`_python_kernels`) has since taken the cells' part of the Python cost down by
#: about 3.5x; measured again with it (``--kernel stock --reps 3 --sizes
#: 100,300,400,550,700,850,1000,3000``, load 1-4): Python 0.54 s at 379,000 units against
#: 0.72 s compiled cold, 0.65 s at 461,000 against 0.56 s; equal at ~420,000 units on
#: the zig-zags (the cell and sample weights of :func:`work` were not fitted again). The
#: bundled pocket is 190,000 (Python), the 10k zig-zag 2.9 million (compiled).
JIT_MIN_WORK = 420_000.0
#: The same where numba has started (:func:`robolobe._jit.started`): the kernels'
#: cache load (~30 ms) against the same Python cost.
JIT_MIN_WORK_STARTED = 20_000.0
#: Cost of one engagement sample (``nphi`` edge points, the crossings) in swept cells.
_SAMPLE_CELLS = 280.0


def work(xyz: Any, cutting: Any, radius: float, res: float) -> float:
    """The Python kernels' cost of a path, in swept cells (the unit of :data:`JIT_MIN_WORK`).

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip positions [m].
    cutting : ndarray of bool, shape (n,)
        Feed moves.
    radius, res : float
        Tool radius and Z-map cell [m].

    Returns
    -------
    float
        Cells the cutting moves sweep (band ``2 (radius + 1.5 res)`` along
        their x-y length) plus :data:`_SAMPLE_CELLS` per engagement sample
        (one per ``radius / 2`` of a move, and one more).
    """
    if len(xyz) < 2:
        return 0.0
    d = np.diff(xyz[:, :2], axis=0)
    lxy = np.hypot(d[:, 0], d[:, 1])[cutting[1:]]
    band = 2.0 * (radius + 1.5 * res)
    samples = np.ceil(lxy / (0.5 * radius)).sum() + lxy.size
    return float(lxy.sum() * band / (res * res) + _SAMPLE_CELLS * samples)
