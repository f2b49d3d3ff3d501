"""Engagement of a flat end mill along a program: entry/exit angles, axial depth, air.

:func:`compute_engagement` walks the path once over a Z-map of the stock
(:mod:`robolobe.stock._kernels`): each cutting move is first tested against
the workpiece as the earlier moves left it, then removes its own material.

Angles follow :mod:`robolobe.sld.directional`: in the feed frame (x along
the move's x-y direction, z the tool axis, y = z x x, i.e. to the left of
the feed) the immersion angle is measured clockwise from +y seen from +z
(right-hand cutter, M03). Up milling enters at 0, down milling exits at pi,
a slot spans 0..pi. A move's engagement is the envelope of its samples
(the smallest entry, the largest exit): a move into a corner or across an
earlier cut keeps its worst position. When the edge meets material in more
than one arc (crossing a rib, a slot's two walls), the outermost entry and
exit are reported and ``n_arcs`` says how many arcs there were. An arc
narrower than :data:`MIN_ARC_DEG` (1 deg of edge angle) is none: a graze whose
outermost angle would swing the entry or exit by tens of degrees (the edge
tangent to the default stock's outline, which lies one tool radius outside the
path's extreme points, meets it in a sliver a micrometre over the level
tolerance).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from robolobe.errors import InputError, InputTypeError
from robolobe.stock._kernels import MIN_ARC_DEG, chain_neighbours, kernels, sweep_index, work
from robolobe.stock.shapes import Stock, signed_distance

__all__ = [
    "DEFAULT_CELLS_PER_DIAMETER",
    "LEVEL_TOL_M",
    "MAX_CELLS",
    "MIN_ARC_DEG",
    "MIN_CELLS_PER_DIAMETER",
    "Engagement",
    "compute_engagement",
    "zmap_resolution",
]

FloatArray = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

#: Default Z-map cell: the tool diameter over this.
DEFAULT_CELLS_PER_DIAMETER = 40
#: Coarsest Z-map cell accepted: the tool diameter over this.
MIN_CELLS_PER_DIAMETER = 10
#: Largest Z-map (cells); 24 bytes a cell (four float32, two int32 sweep indices).
MAX_CELLS = 16_000_000
#: Heights closer than this [m] are one level: the Z-map's sweeps at one height, the
#: plan's sections at one tip height (:mod:`robolobe.plan.passes`), and material
#: shallower than it is air. 10 um: a program's own rounding of one height (4
#: decimals in inch: 2.5 um) is one level.
LEVEL_TOL_M = 1e-5
#: Largest tilt of the tool axis from +z [deg] the Z-map accepts on a cutting move.
MAX_TILT_DEG = 0.5
#: Angular samples of the front half of the cutting edge (4 deg apart; each sign change
#: is then refined by bisection to 1/8 deg and interpolated). Between two samples in air
#: whose values leave room for an arc, the edge is sampled every 1 deg, so that no arc of
#: :data:`MIN_ARC_DEG` is missed (a narrower one is none by definition).
N_PHI = 46


@dataclass(frozen=True, eq=False)
class Engagement:
    """Engagement of every move of a path (one entry per waypoint: the move ending there).

    Parameters
    ----------
    phi_entry, phi_exit : ndarray, shape (n,)
        Entry and exit angles [rad] (feed frame, clockwise from +y), NaN
        where the move does not cut.
    n_arcs : ndarray of int, shape (n,)
        Number of separate engaged arcs of the edge (0: no cut; > 1: the
        angles are the outermost).
    depth_m : ndarray, shape (n,)
        Axial depth of cut [m]: material height under the engaged edge above
        the tool tip (0 where the move does not cut): the largest over the
        engaged edge points of the material top one cell inside the point
        where that stands above the tip (at the edge itself the top jumps
        where the edge runs along an earlier, deeper wall), else the top at
        the point itself (a crescent or wall thinner than a cell: the outer
        side of a turn, a finishing pass at a step-down's wall). Within a
        cell's resolution: a wall thinner than a cell between two cuts that no
        cell centre falls in is measured at its cells' highest top.
    cutting : ndarray of bool, shape (n,)
        Feed moves of the program (rapid moves never cut here).
    plunge : ndarray of bool, shape (n,)
        Moves along the tool axis (no x-y travel): a plunge into material is
        reported as a full slot (0..pi) at the plunged depth.
    stock : Stock
        The stock the material removal started from.
    resolution_m : float
        Z-map cell [m].
    tool_diameter_m : float
        Cutter diameter [m].
    notes : tuple of str
        Sentences for the plan summary (default stock, air moves).
    """

    phi_entry: FloatArray
    phi_exit: FloatArray
    n_arcs: NDArray[np.int64]
    depth_m: FloatArray
    cutting: BoolArray
    plunge: BoolArray
    stock: Stock
    resolution_m: float
    tool_diameter_m: float
    notes: tuple[str, ...] = field(default=())

    @property
    def engaged(self) -> BoolArray:
        """Moves that meet material."""
        return self.n_arcs > 0

    @property
    def air(self) -> BoolArray:
        """Feed moves that meet no material: no stability limit applies to them."""
        return self.cutting & (self.n_arcs == 0)

    @property
    def immersion(self) -> FloatArray:
        """Radial immersion ``a_e / D = (cos phi_entry - cos phi_exit) / 2`` [-] (NaN: no cut)."""
        return 0.5 * (np.cos(self.phi_entry) - np.cos(self.phi_exit))

    @property
    def radial_width_m(self) -> FloatArray:
        """Radial width of cut ``a_e`` [m] spanned by the entry and exit angles."""
        return self.immersion * self.tool_diameter_m

    def milling(self) -> NDArray[np.str_]:
        """Per move: ``"slot"``, ``"down"``, ``"up"``, ``"inner"`` (neither side) or ``""``."""
        tol = math.radians(0.5)
        entry0 = self.phi_entry <= tol
        exitpi = self.phi_exit >= math.pi - tol
        out = np.full(len(self.n_arcs), "", dtype="<U5")
        e = self.engaged
        out[e & entry0 & exitpi] = "slot"
        out[e & ~entry0 & exitpi] = "down"
        out[e & entry0 & ~exitpi] = "up"
        out[e & ~entry0 & ~exitpi] = "inner"
        return out


def zmap_resolution(
    diameter_m: float,
    stock: Stock,
    resolution_m: float | None = None,
    *,
    key: str = "stock.resolution_mm",
) -> float:
    """The Z-map cell [m]: the job's, or the tool diameter / 40 (coarser for a huge stock).

    Raises
    ------
    InputError
        When the cell is coarser than the tool diameter / 10, or the Z-map
        would exceed :data:`MAX_CELLS` cells (naming ``key`` and the value
        that would do).
    """
    coarsest = diameter_m / MIN_CELLS_PER_DIAMETER
    x0, y0, x1, y1 = stock.bounds()
    area = (x1 - x0 + 8 * coarsest) * (y1 - y0 + 8 * coarsest)
    finest_fit = math.sqrt(area / MAX_CELLS)
    if resolution_m is None:
        res = max(diameter_m / DEFAULT_CELLS_PER_DIAMETER, finest_fit)
        if res > coarsest:
            raise InputError(
                f"{key}: the stock ({stock.describe()}) needs a cell of at least "
                f"{finest_fit * 1e3:.3g} mm to fit {MAX_CELLS:,} cells, coarser than the "
                f"tool diameter / {MIN_CELLS_PER_DIAMETER} = {coarsest * 1e3:.3g} mm; give a "
                "smaller stock"
            )
        return res
    if resolution_m > coarsest * (1 + 1e-9):
        raise InputError(
            f"{key}: expected at most the tool diameter / {MIN_CELLS_PER_DIAMETER} = "
            f"{coarsest * 1e3:.4g} mm for the {diameter_m * 1e3:g} mm cutter (default "
            f"diameter / {DEFAULT_CELLS_PER_DIAMETER} = "
            f"{diameter_m / DEFAULT_CELLS_PER_DIAMETER * 1e3:.4g} mm), found "
            f"{resolution_m * 1e3:g}"
        )
    if resolution_m < finest_fit:
        raise InputError(
            f"{key}: expected at least {finest_fit * 1e3:.3g} mm for this stock "
            f"({stock.describe()}: at most {MAX_CELLS:,} cells), found {resolution_m * 1e3:g}"
        )
    return resolution_m


def compute_engagement(
    xyz: FloatArray,
    cutting: BoolArray,
    tool_diameter_m: float,
    stock: Stock,
    *,
    resolution_m: float | None = None,
    axis: FloatArray | None = None,
    lines: NDArray[np.int64] | None = None,
    source: str = "path",
) -> Engagement:
    """Engagement of a flat end mill on every move of a 3-axis path.

    Parameters
    ----------
    xyz : ndarray, shape (n, 3)
        Tool-tip positions [m] in the workpiece frame (the end of each move).
    cutting : ndarray of bool, shape (n,)
        Feed moves (True) and rapid moves (False).
    tool_diameter_m : float
        Cutter diameter [m] (a flat end mill).
    stock : Stock
        The raw workpiece.
    resolution_m : float, optional
        Z-map cell [m]; default :func:`zmap_resolution`.
    axis : ndarray, shape (n, 3), optional
        Tool axis per waypoint (tip towards spindle); cutting moves must have
        it along +z within :data:`MAX_TILT_DEG`.
    lines, source : optional
        Program line per waypoint and file name, for messages.

    Returns
    -------
    Engagement

    Raises
    ------
    InputError
        A tilted tool on a cutting move, or a resolution out of range.
    """
    if not isinstance(stock, Stock):
        raise InputTypeError("stock", "a Stock", stock)
    if isinstance(tool_diameter_m, bool) or not isinstance(tool_diameter_m, numbers.Real):
        raise InputTypeError("tool_diameter_m", "a diameter in m (a number)", tool_diameter_m)
    try:
        p = np.ascontiguousarray(xyz, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputTypeError("xyz", "an (n, 3) array of positions [m]", xyz) from None
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"xyz: expected shape (n, 3), found {p.shape}")
    cut = np.ascontiguousarray(cutting, dtype=np.bool_)
    if cut.shape != (len(p),):
        raise InputError(f"cutting: expected shape ({len(p)},), found {cut.shape}")
    n = len(p)
    radius = 0.5 * tool_diameter_m
    if axis is not None and n:
        kz = np.asarray(axis, dtype=np.float64)[:, 2]
        bad = cut & (kz < math.cos(math.radians(MAX_TILT_DEG)))
        if bad.any():
            k = int(np.argmax(bad))
            where = f"{source}:{int(lines[k])}" if lines is not None else f"{source}: waypoint {k}"
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(kz[k])))))
            raise InputError(
                f"stock engagement: expected the tool axis along +z (3-axis, within "
                f"{MAX_TILT_DEG:g} deg) on cutting moves, found it tilted by {tilt:.1f} deg",
                source=where,
            )
    res = zmap_resolution(tool_diameter_m, stock, resolution_m)
    band = 1.5 * res  # the four cells around an edge point at the material's edge
    x0, y0, x1, y1 = stock.bounds()
    margin = 4.0 * res
    gx0, gy0 = x0 - margin, y0 - margin
    nx = math.ceil((x1 - x0 + 2 * margin) / res)
    ny = math.ceil((y1 - y0 + 2 * margin) / res)
    xc = gx0 + (np.arange(nx, dtype=np.float64) + 0.5) * res
    yc = gy0 + (np.arange(ny, dtype=np.float64) + 0.5) * res
    # one cell: top h, clearance s, its level zs, signed distance to the outline sd
    # ids: the sweeps that set s and zs, and h (move index, 0: none), for the exact test
    # where the cells disagree
    w = np.empty((ny, nx, 4), dtype=np.float32)
    ids = np.zeros((ny, nx, 2), dtype=np.int32)
    for j in range(ny):  # row by row: memory of a row per edge, not of the grid
        w[j, :, 3] = np.clip(
            signed_distance(stock.outline, xc, np.full(nx, yc[j])), -4 * res, 4 * res
        )
    w[..., 0] = stock.z_top  # the outline is sd's: h, s, zs say what the sweeps cleared
    w[..., 1] = -np.inf
    w[..., 2] = np.inf

    step = np.linalg.norm(np.diff(p, axis=0), axis=1) if n > 1 else np.zeros(0)
    cum = np.concatenate([[0.0], np.cumsum(step)])
    phi_entry = np.full(n, np.nan)
    phi_exit = np.full(n, np.nan)
    n_arcs = np.zeros(n, dtype=np.int64)
    depth = np.zeros(n)
    plunge = np.zeros(n, dtype=np.bool_)
    run, _ = kernels(work(p, cut, radius, res))
    run(
        w, ids, gx0, gy0, res, radius, band, p, cut, cum, 2.0 * res, 0.5 * radius,
        math.cos(math.radians(5.0)), stock.z_bottom, stock.z_top, LEVEL_TOL_M, N_PHI,
        phi_entry, phi_exit, n_arcs, depth, plunge, chain_neighbours(p, cut, res),
        sweep_index(p, cut, radius, res, gx0, gy0, nx, ny, LEVEL_TOL_M),
    )  # fmt: skip
    notes = [stock.note] if stock.note else []
    n_air = int((cut & (n_arcs == 0))[1:].sum())
    if n_air:
        notes.append(
            f"{n_air} of {int(cut[1:].sum())} feed moves cut no material (air): no stability "
            "limit applies to them"
        )
    return Engagement(
        phi_entry=phi_entry,
        phi_exit=phi_exit,
        n_arcs=n_arcs,
        depth_m=depth,
        cutting=cut,
        plunge=plunge,
        stock=stock,
        resolution_m=res,
        tool_diameter_m=tool_diameter_m,
        notes=tuple(notes),
    )
