"""Stock definitions: the raw workpiece before the program cuts it.

A stock is a prism in the workpiece (path) frame: a closed outline in the
x-y plane extruded from ``z_bottom`` to ``z_top`` (a box is the outline of
four corners). Meshes (STL) are not read: no mesh library is a dependency,
and a 2.5-D Z-map needs only the outline and the top.

When a job gives no stock, :func:`default_stock` derives one from the program
and says so in its :attr:`Stock.note`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError, InputTypeError

__all__ = ["Stock", "check_stock_contains", "default_stock", "signed_distance"]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True, eq=False)
class Stock:
    """A prismatic stock: an x-y outline extruded between two heights.

    Parameters
    ----------
    outline : ndarray, shape (n, 2)
        Closed polygon [m] in the workpiece frame (first point not repeated),
        either orientation, not self-intersecting.
    z_bottom, z_top : float
        Bottom and top of the stock [m], ``z_bottom < z_top``.
    kind : {"box", "outline", "default"}
        How it was given.
    note : str
        A sentence for the plan summary (how the stock was chosen).
    """

    outline: FloatArray
    z_bottom: float
    z_top: float
    kind: Literal["box", "outline", "default"] = "outline"
    note: str = ""
    _area: float = field(default=0.0, repr=False)

    def __post_init__(self) -> None:
        try:
            o = np.array(self.outline, dtype=np.float64)
        except (TypeError, ValueError):
            raise InputTypeError("outline", "an (n, 2) array of x, y [m]", self.outline) from None
        for key in ("z_bottom", "z_top"):
            v = getattr(self, key)
            if isinstance(v, bool) or not isinstance(v, numbers.Real):
                raise InputTypeError(key, "a height in m (a number)", v)
        if o.ndim != 2 or o.shape[1] != 2 or len(o) < 3 or not np.all(np.isfinite(o)):
            raise InputError(f"outline: expected at least 3 finite (x, y) points, found {o.shape}")
        if len(o) > 3 and np.allclose(o[0], o[-1]):
            o = o[:-1]
        area = 0.5 * float(np.sum(o[:, 0] * np.roll(o[:, 1], -1) - np.roll(o[:, 0], -1) * o[:, 1]))
        if abs(area) <= 0.0:
            raise InputError("outline: expected a polygon with an area, found a degenerate one")
        if not (math.isfinite(self.z_bottom) and math.isfinite(self.z_top)):
            raise InputError("z_bottom/z_top: expected finite heights")
        if self.z_top <= self.z_bottom:
            raise InputError(
                f"z range: expected bottom < top, found {self.z_bottom * 1e3:g} >= "
                f"{self.z_top * 1e3:g} mm"
            )
        o.setflags(write=False)
        object.__setattr__(self, "outline", o)
        object.__setattr__(self, "_area", abs(area))

    @classmethod
    def box(cls, lo: tuple[float, float, float], hi: tuple[float, float, float]) -> Stock:
        """A box from its min and max corners [m] (each coordinate ``lo < hi``)."""
        (x0, y0, z0), (x1, y1, z1) = lo, hi
        if not (x0 < x1 and y0 < y1 and z0 < z1):
            raise ValueError(
                f"box: expected min < max in x, y and z, found min "
                f"{[round(v * 1e3, 6) for v in lo]}, max {[round(v * 1e3, 6) for v in hi]} mm"
            )
        pts = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
        return cls(pts, z0, z1, kind="box")

    @property
    def area_m2(self) -> float:
        """Area of the outline [m^2]."""
        return self._area

    def bounds(self) -> tuple[float, float, float, float]:
        """``(x_min, y_min, x_max, y_max)`` of the outline [m]."""
        o = self.outline
        return (
            float(o[:, 0].min()),
            float(o[:, 1].min()),
            float(o[:, 0].max()),
            float(o[:, 1].max()),
        )

    def describe(self) -> str:
        """One line: the kind, the x-y extent and the heights, in mm."""
        x0, y0, x1, y1 = self.bounds()
        shape = "box" if self.kind == "box" else f"{len(self.outline)}-point outline"
        return (
            f"{shape} x {x0 * 1e3:g}..{x1 * 1e3:g}, y {y0 * 1e3:g}..{y1 * 1e3:g}, "
            f"z {self.z_bottom * 1e3:g}..{self.z_top * 1e3:g} mm"
        )


def signed_distance(outline: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
    """Signed distance [m] of points to a closed polygon: negative inside.

    Parameters
    ----------
    outline : ndarray, shape (n, 2)
        Polygon vertices [m].
    x, y : ndarray
        Point coordinates [m] (same shape).

    Returns
    -------
    ndarray
        Distance to the nearest edge, negative for points inside (even-odd rule).
    """
    px = np.asarray(x, dtype=np.float64)
    py = np.asarray(y, dtype=np.float64)
    d2 = np.full(px.shape, np.inf)
    inside = np.zeros(px.shape, dtype=bool)
    a = outline
    b = np.roll(outline, -1, axis=0)
    for (ax, ay), (bx, by) in zip(a, b, strict=True):
        ex, ey = bx - ax, by - ay
        ll = ex * ex + ey * ey
        t = np.clip(((px - ax) * ex + (py - ay) * ey) / ll, 0.0, 1.0)
        dx, dy = px - ax - t * ex, py - ay - t * ey
        np.minimum(d2, dx * dx + dy * dy, out=d2)
        crosses = (ay > py) != (by > py)
        with np.errstate(divide="ignore", invalid="ignore"):
            xint = ax + (py - ay) * ex / (by - ay)
        inside ^= crosses & (px < xint)
    d = np.sqrt(d2)
    return np.where(inside, -d, d)


def _horizontal(xyz: FloatArray) -> BoolArray:
    """Moves (ending at each waypoint) that travel in x-y (more than 1 um)."""
    step = np.diff(xyz[:, :2], axis=0, prepend=xyz[:1, :2])
    return np.hypot(step[:, 0], step[:, 1]) > 1e-6


def default_stock(xyz: FloatArray, cutting: BoolArray, tool_radius: float) -> Stock:
    """The stock a program implies when the job gives none.

    The x-y box of the cutting moves grown by the tool radius (the region the
    tool can reach), from the lowest cutting Z up to Z = 0 of the workpiece
    frame (part zero on the stock top, the CAM convention) when the program
    cuts below zero, else up to the highest Z at which a cutting move travels
    in x-y.

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip positions [m] (the end of each move).
    cutting : ndarray of bool, shape (n,)
        Whether the move ending at each waypoint is a feed (cutting) move.
    tool_radius : float
        Cutter radius [m].

    Raises
    ------
    InputError
        When the program has no cutting move that travels in x-y.
    """
    cut = cutting & _horizontal(xyz)
    # the start of a cutting move is where the cut begins: include it
    start = np.zeros_like(cut)
    start[:-1] = cut[1:]
    pts = xyz[cut | start]
    if not cut.any():
        raise InputError("stock: cannot derive a default stock: the path has no cutting move")
    zmin = float(pts[:, 2].min())
    ztop = 0.0 if zmin < -1e-6 else float(xyz[cut, 2].max())
    if ztop - zmin < 1e-6:
        ztop = zmin + 1e-6
    lo = pts[:, :2].min(axis=0) - tool_radius
    hi = pts[:, :2].max(axis=0) + tool_radius
    s = Stock.box((lo[0], lo[1], zmin), (hi[0], hi[1], ztop))
    rule = (
        "Z = 0 (part zero on the stock top)"
        if zmin < -1e-6
        else "the highest Z of an x-y cutting move"
    )
    note = (
        f"no [stock] in the job: assumed the box the cutting moves reach "
        f"({s.describe()}), top at {rule}; give [stock] for the real part"
    )
    return Stock(s.outline, s.z_bottom, s.z_top, kind="default", note=note)


def check_stock_contains(
    stock: Stock,
    xyz: FloatArray,
    cutting: BoolArray,
    tool_radius: float,
    *,
    lines: NDArray[np.int64] | None = None,
    source: str = "stock",
) -> None:
    """Refuse a stock that does not contain the program's cutting region.

    A cutting move below the stock top whose tool is more than one tool
    diameter (at least 5 mm) outside the stock outline cuts air where the
    program expects material: the stock is in another place, size or unit
    than the program. So is a stock that no cutting move reaches.

    Raises
    ------
    InputError
        Naming ``source`` (the job key), the first such line and the stock.
    """
    below = cutting & (xyz[:, 2] < stock.z_top - 1e-6)
    if not below.any():
        raise InputError(
            f"stock: expected the stock to contain the path's cutting region, found every "
            f"cutting move at or above its top ({stock.describe()}; lowest cutting Z "
            f"{xyz[cutting, 2].min() * 1e3:g} mm)",
            source=source,
        )
    idx = np.flatnonzero(below)
    d = signed_distance(stock.outline, xyz[idx, 0], xyz[idx, 1])
    margin = max(2.0 * tool_radius, 5e-3)
    far = d - tool_radius > margin
    if far.all() or far.any():
        k = int(idx[np.argmax(far)]) if far.any() else int(idx[0])
        where = f" (line {int(lines[k])})" if lines is not None else ""
        if far.all():
            what = "no cutting move reaches the stock"
        else:
            what = (
                f"a cutting move{where} at x {xyz[k, 0] * 1e3:g}, y {xyz[k, 1] * 1e3:g} mm "
                f"with its tool {(float(d[np.argmax(far)]) - tool_radius) * 1e3:.1f} mm "
                f"outside the stock"
            )
        raise InputError(
            f"stock: expected the stock to contain the path's cutting region, found {what} "
            f"({stock.describe()})",
            source=source,
        )
