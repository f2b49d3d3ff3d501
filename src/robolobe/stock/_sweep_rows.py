"""The Z-map sweep of :func:`robolobe.stock._kernels._sweep` in numpy, for the Python path.

Where numba does not run (a path below the compile size, :data:`robolobe.stock.
_kernels.JIT_MIN_WORK`, or numba missing), the scalar sweep costs about 2 us
per swept cell in Python: 60 % of the bundled pocket's engagement. This is the
same sweep with the cells of a move as arrays: every cell is visited once per
sweep and reads and writes only its own entries, so the order does not matter,
and every value is computed with the same IEEE operations in the same order as
the scalar code (no fused or reordered arithmetic), which makes the result
equal bit for bit (tested against the scalar function and against the compiled
kernels). The scalar function stays the definition: it is what numba compiles.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = ["sweep"]

#: Below this many candidate cells (rows x the band's width) the scalar sweep is faster
#: than the array set-up (~40 numpy calls).
_MIN_CELLS = 48


def _max(a: Any, b: Any) -> Any:
    """Python's ``max(a, b)`` elementwise: ``a`` unless ``b > a`` (so ``max(0.0, -0.0)`` is
    ``0.0``, and a NaN ``a`` stays, as in the scalar code; ``np.maximum`` differs in both)."""
    return np.where(b > a, b, a)


def _min(a: Any, b: Any) -> Any:
    """Python's ``min(a, b)`` elementwise: ``a`` unless ``b < a``."""
    return np.where(b < a, b, a)


def sweep(
    w: Any,
    ids: Any,
    m: int,
    x0: float,
    y0: float,
    res: float,
    radius: float,
    band: float,
    p0: Any,
    p1: Any,
    skip_start: bool,
    tol: float,
    scalar: Any,
) -> None:
    """:func:`robolobe.stock._kernels._sweep` (same arguments, same result), per move.

    ``scalar`` is that function: it runs small moves and any move whose bounds
    are not finite (so every edge case keeps its one definition).
    """
    ny = w.shape[0]
    nx = w.shape[1]
    ax, ay, az = float(p0[0]), float(p0[1]), float(p0[2])
    dx, dy, dz = float(p1[0]) - ax, float(p1[1]) - ay, float(p1[2]) - az
    l2 = dx * dx + dy * dy
    ll = math.sqrt(l2)
    r = radius + band
    ymin = min(ay, ay + dy) - r
    ymax = max(ay, ay + dy) + r
    j0 = max(0, math.ceil((ymin - y0) / res - 0.5))
    j1 = min(ny - 1, math.floor((ymax - y0) / res - 0.5))
    if j1 < j0:
        return
    if (j1 - j0 + 1) * (2.0 * r / res + 1.0) < _MIN_CELLS:
        scalar(w, ids, m, x0, y0, res, radius, band, p0, p1, skip_start, tol)
        return
    j = np.arange(j0, j1 + 1)
    yc = y0 + (j + 0.5) * res
    lo = np.full(j.size, math.inf)
    hi = np.full(j.size, -math.inf)
    for cx, cy in ((ax, ay), (ax + dx, ay + dy)):
        e = yc - cy
        near = np.abs(e) <= r
        hw = np.sqrt(np.where(near, r * r - e * e, 0.0))
        lo = np.where(near, _min(lo, cx - hw), lo)
        hi = np.where(near, _max(hi, cx + hw), hi)
    if ll > 0.0:
        xa = np.full(j.size, -math.inf)
        xb = np.full(j.size, math.inf)
        ct = (yc - ay) * dy / l2
        if abs(dx) > 1e-300:
            q1 = ax + (0.0 - ct) * l2 / dx
            q2 = ax + (1.0 - ct) * l2 / dx
            xa = _max(xa, _min(q1, q2))
            xb = _min(xb, _max(q1, q2))
        else:
            out = ~((ct >= 0.0) & (ct <= 1.0))
            xa = np.where(out, math.inf, xa)
            xb = np.where(out, -math.inf, xb)
        cu = (yc - ay) * dx / ll
        if abs(dy) > 1e-300:
            q1 = ax + (cu - r) * ll / dy
            q2 = ax + (cu + r) * ll / dy
            xa = _max(xa, _min(q1, q2))
            xb = _min(xb, _max(q1, q2))
        else:
            out = np.abs(cu) > r
            xa = np.where(out, math.inf, xa)
            xb = np.where(out, -math.inf, xb)
        both = xa <= xb
        lo = np.where(both, _min(lo, xa), lo)
        hi = np.where(both, _max(hi, xb), hi)
    rows = lo <= hi
    if skip_start and ll > 0.0:
        if abs(dx) > 1e-300:
            xh = ax - (yc - ay) * dy / dx
            if dx > 0.0:
                lo = _max(lo, xh)
            else:
                hi = _min(hi, xh)
        else:
            rows &= ~((yc - ay) * dy <= 0.0)
        rows &= lo <= hi
    if not rows.any():
        return
    j, yc, lo, hi = j[rows], yc[rows], lo[rows], hi[rows]
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        scalar(w, ids, m, x0, y0, res, radius, band, p0, p1, skip_start, tol)
        return
    i0 = np.clip(np.ceil((lo - x0) / res - 0.5), 0.0, float(nx)).astype(np.int64)
    i1 = np.clip(np.floor((hi - x0) / res - 0.5), -1.0, float(nx - 1)).astype(np.int64)
    # the cells behind the start, deep inside the previous move's end disc: skipped
    k0 = np.ones(j.size)
    k1 = np.zeros(j.size)
    rin = radius - band
    if skip_start and rin > 0.0:
        e = yc - ay
        inner = np.abs(e) < rin
        hw = np.sqrt(np.where(inner, rin * rin - e * e, 0.0))
        k0 = np.where(inner, np.ceil((ax - hw - x0) / res - 0.5), k0)
        k1 = np.where(inner, np.floor((ax + hw - x0) / res - 0.5), k1)
    count = _max(i1 - i0 + 1, 0)
    total = int(count.sum())
    if total == 0:
        return
    starts = np.cumsum(count) - count
    jj = np.repeat(j, count)
    ii = np.arange(total) - np.repeat(starts - i0, count)
    keep = ~((np.repeat(k0, count) <= ii) & (ii <= np.repeat(k1, count)))
    xc = x0 + (ii + 0.5) * res
    qx = xc - ax
    qy = np.repeat(yc, count) - ay
    if skip_start:
        keep &= ~(qx * dx + qy * dy <= 0.0)
    t = _min(1.0, _max(0.0, (qx * dx + qy * dy) / l2)) if l2 > 0.0 else np.zeros(total)
    ex = qx - t * dx
    ey = qy - t * dy
    sv = radius - np.sqrt(ex * ex + ey * ey)
    keep &= sv >= -band
    if not keep.any():
        return
    jj, ii, qx, qy, t, sv = jj[keep], ii[keep], qx[keep], qy[keep], t[keep], sv[keep]
    inside = sv >= 0.0
    # the tip height of the sweep at the cell: the lowest over the part of the move that
    # covers the centre (inside), else the nearest point's (a plunge: every height is as close)
    zc = np.full(sv.size, min(az, az + dz)) if l2 == 0.0 else az + t * dz
    if inside.any():
        if dz == 0.0:
            z_in = np.full(int(inside.sum()), az)
        elif l2 == 0.0:
            z_in = np.full(int(inside.sum()), min(az, az + dz))
        else:
            qi, qj = qx[inside], qy[inside]
            b = qi * dx + qj * dy
            disc = b * b - l2 * (qi * qi + qj * qj - radius * radius)
            sq = np.sqrt(_max(disc, 0.0))
            t1 = _min(1.0, _max(0.0, (b - sq) / l2))
            t2 = _min(1.0, _max(0.0, (b + sq) / l2))
            z_in = _min(az + t1 * dz, az + t2 * dz)
        zc[inside] = z_in
        ji, ij = jj[inside], ii[inside]
        lower = z_in < w[ji, ij, 0]
        w[ji[lower], ij[lower], 0] = z_in[lower]
        ids[ji[lower], ij[lower], 1] = m
    z_old = w[jj, ii, 2]
    deeper = zc < z_old - tol
    wider = ~deeper & (zc <= z_old + tol) & (sv > w[jj, ii, 1])
    w[jj[deeper], ii[deeper], 1] = sv[deeper]
    w[jj[deeper], ii[deeper], 2] = zc[deeper]
    ids[jj[deeper], ii[deeper], 0] = m
    w[jj[wider], ii[wider], 1] = sv[wider]
    ids[jj[wider], ii[wider], 0] = m
