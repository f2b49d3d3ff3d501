"""Inputs of the schedule optimization: constraints, the lobe table, the path geometry."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

logger = logging.getLogger(__name__)

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi
#: Relative step to which :meth:`LobeTable.per_depth` rounds each waypoint's depth share up.
DEPTH_SHARE_STEP = 0.005


# ---------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Constraints:
    """Process limits in SI units.

    Parameters
    ----------
    teeth : int
        Number of flutes N.
    feed_per_tooth_m : float
        f_z [m].
    width_m : float
        Radial width of cut b [m].
    kt_N_per_m2 : float
        Tangential cutting coefficient [N/m^2] (power and torque).
    power_W, torque_Nm : float
        Spindle power [W] and torque [N m] limits.
    rpm_min, rpm_max : float
        Speed range [rpm].
    depth_min_m, depth_max_m : float
        Bounds on the depth [m].
    safety_factor : float
        ``a <= a_lim / safety_factor``.
    max_feed_m_per_s : float or None
        Cap on the feed rate [m/s].
    max_rate_rpm_per_s, max_rate_rpm_per_m : float or None
        Rate limits of the speed [rpm/s] or [rpm/m] (at most one).
    constant_speed : bool
        One speed for the whole path.
    """

    teeth: int
    feed_per_tooth_m: float
    width_m: float
    kt_N_per_m2: float
    power_W: float
    torque_Nm: float
    rpm_min: float
    rpm_max: float
    depth_min_m: float
    depth_max_m: float
    safety_factor: float = 1.0
    max_feed_m_per_s: float | None = None
    max_rate_rpm_per_s: float | None = None
    max_rate_rpm_per_m: float | None = None
    constant_speed: bool = False

    def __post_init__(self) -> None:
        for name in ("feed_per_tooth_m", "width_m", "kt_N_per_m2", "power_W", "torque_Nm"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"{name}: expected a positive number, found {v!r}")
        if not 0 < self.rpm_min < self.rpm_max:
            raise InputError(
                f"expected 0 < rpm_min < rpm_max, found {self.rpm_min}, {self.rpm_max}"
            )
        if not 0 < self.depth_min_m <= self.depth_max_m:
            raise InputError(
                f"expected 0 < depth_min <= depth_max, found {self.depth_min_m}, {self.depth_max_m}"
            )
        if self.safety_factor < 1:
            raise InputError(f"safety_factor: expected >= 1, found {self.safety_factor}")
        if self.max_rate_rpm_per_s is not None and self.max_rate_rpm_per_m is not None:
            raise InputError("give max_rate_rpm_per_s or max_rate_rpm_per_m, not both")

    @property
    def feed_per_rev_m(self) -> float:
        """``f_z N`` [m/rev]: feed rate [m/s] = this x rpm / 60."""
        return self.feed_per_tooth_m * self.teeth

    @property
    def rpm_hi(self) -> float:
        """Highest usable speed [rpm]: spindle range and feed cap."""
        hi = self.rpm_max
        if self.max_feed_m_per_s is not None:
            hi = min(hi, self.max_feed_m_per_s * 60.0 / self.feed_per_rev_m)
        return hi

    @property
    def depth_cap_m(self) -> float:
        """Largest depth [m] allowed by ``depth_max`` and the torque limit."""
        return min(self.depth_max_m, self.torque_depth_m)

    @property
    def torque_depth_m(self) -> float:
        """Depth [m] at which the cutting torque reaches the limit."""
        return self.torque_Nm * _TWO_PI / (self.kt_N_per_m2 * self.width_m * self.feed_per_rev_m)

    @property
    def power_product(self) -> float:
        """``a * n`` [m rpm] at which the cutting power reaches the limit."""
        return self.power_W * 60.0 / (self.kt_N_per_m2 * self.width_m * self.feed_per_rev_m)

    def power_W_at(self, depth_m: float, rpm: ArrayLike) -> FloatArray:
        """Cutting power [W] at a depth [m] and speeds [rpm]."""
        n = np.asarray(rpm, dtype=np.float64)
        return np.asarray(
            self.kt_N_per_m2 * depth_m * self.width_m * self.feed_per_rev_m * n / 60.0
        )

    def torque_Nm_at(self, depth_m: float) -> float:
        """Cutting torque [N m] at a depth [m]."""
        return self.kt_N_per_m2 * depth_m * self.width_m * self.feed_per_rev_m / _TWO_PI


@dataclass(frozen=True, eq=False)
class LobeTable:
    """Stability limits of the cutting waypoints on a speed grid, plus the exact boundary.

    Waypoints with the same dynamics share a row (``group``).

    Parameters
    ----------
    rpm : ndarray, shape (n_rpm,)
        Increasing speed grid [rpm].
    a_lim : ndarray, shape (n_groups, n_rpm)
        Limiting depth [m] on the grid (``inf``: no lobe there).
    group : ndarray of int, shape (n_cut,)
        Row of each cutting waypoint.
    exact : callable, optional
        ``exact(rpm_rows, groups) -> a_lim``: the exact boundary [m] of the
        groups ``groups`` (g,) at the speeds ``rpm_rows`` (g, m) [rpm], shape
        (g, m) (e.g. the lobe polylines of :mod:`robolobe.sld.lobes`). Without
        it the grid is interpolated linearly (then "exact" means "on the grid").
    """

    rpm: FloatArray
    a_lim: FloatArray
    group: IntArray
    exact: Callable[[FloatArray, IntArray], FloatArray] | None = None
    #: Per-block minima of the grid kept between the optimizer's runs on this table
    #: (:func:`robolobe.plan.optimize._search._blocks`), keyed by the blocks' first rows.
    _block_mins: dict[bytes, FloatArray] = field(
        default_factory=dict, init=False, repr=False, compare=False
    )

    def __post_init__(self) -> None:
        r = np.asarray(self.rpm, dtype=np.float64)
        a = np.asarray(self.a_lim, dtype=np.float64)
        g = np.asarray(self.group, dtype=np.int64)
        if r.ndim != 1 or r.size < 4 or np.any(np.diff(r) <= 0):
            raise InputError("rpm: expected an increasing grid of at least 4 speeds")
        if a.ndim != 2 or a.shape[1] != r.size:
            raise InputError(f"a_lim: expected shape (n_groups, {r.size}), found {a.shape}")
        if g.ndim != 1 or (g.size and (g.min() < 0 or g.max() >= a.shape[0])):
            raise InputError("group: expected row indices into a_lim")
        if np.any(np.isnan(a)) or np.any(a <= 0):
            raise InputError("a_lim: expected positive limits (inf where unbounded), found NaN/<=0")
        object.__setattr__(self, "rpm", r)
        object.__setattr__(self, "a_lim", a)
        object.__setattr__(self, "group", g)

    @property
    def n_cut(self) -> int:
        """Number of cutting waypoints."""
        return int(self.group.size)

    def rows(self, rows: ArrayLike, groups: ArrayLike) -> FloatArray:
        """Exact limits [m] of ``groups`` (g,) at speeds ``rows`` (g, m) [rpm]."""
        r = np.asarray(rows, dtype=np.float64)
        g = np.asarray(groups, dtype=np.int64)
        if g.size == 0:
            return np.zeros(r.shape)
        if self.exact is not None:
            out = np.asarray(self.exact(r, g), dtype=np.float64)
            if out.shape != r.shape:
                raise InputError(f"exact: expected shape {r.shape}, found {out.shape}")
            return out
        out = np.empty_like(r)
        for k, gi in enumerate(g):  # fallback only (tests, tables without lobes)
            out[k] = np.interp(r[k], self.rpm, self.a_lim[gi])
        return out

    def query_groups(self, rpm: ArrayLike, groups: ArrayLike) -> FloatArray:
        """Exact limits of some groups at shared speeds.

        Parameters
        ----------
        rpm : array_like, shape (m,)
        groups : array_like of int, shape (g,)

        Returns
        -------
        ndarray, shape (g, m) [m]
        """
        r = np.atleast_1d(np.asarray(rpm, dtype=np.float64))
        g = np.asarray(groups, dtype=np.int64)
        return self.rows(np.broadcast_to(r, (g.size, r.size)).copy(), g)

    def query_shared(self, rpm: ArrayLike) -> FloatArray:
        """Exact limits of every cutting waypoint at shared speeds.

        Parameters
        ----------
        rpm : array_like, shape (m,)

        Returns
        -------
        ndarray, shape (n_cut, m) [m]
        """
        r = np.atleast_1d(np.asarray(rpm, dtype=np.float64))
        used = np.unique(self.group)
        vals = np.full((self.a_lim.shape[0], r.size), np.inf)
        vals[used] = self.query_groups(r, used)
        return vals[self.group]

    def query(self, rpm: ArrayLike) -> FloatArray:
        """Exact limit of each cutting waypoint at its own speed.

        Parameters
        ----------
        rpm : array_like, shape (n_cut,)

        Returns
        -------
        ndarray, shape (n_cut,) [m]
        """
        r = np.asarray(rpm, dtype=np.float64)
        if r.shape != self.group.shape:
            raise InputError(f"rpm: expected shape {self.group.shape}, found {r.shape}")
        if r.size == 0:
            return np.zeros(0)
        # unique (group, speed) pairs in (group, speed) order, one padded row per group
        # (a sort of both keys: numpy.unique(axis=0) of the pairs is ~20x slower)
        order = np.lexsort((r, self.group))
        gs, rs = self.group[order], r[order]
        new = np.r_[True, (gs[1:] != gs[:-1]) | (rs[1:] != rs[:-1])]
        inv = np.empty(r.size, np.int64)
        inv[order] = np.cumsum(new) - 1
        us = rs[new]
        g = gs[new].astype(np.int64)
        used, slot = np.unique(g, return_inverse=True)
        counts = np.bincount(slot)
        start = np.concatenate([[0], np.cumsum(counts)[:-1]])
        pos = np.arange(us.size) - start[slot]
        out = np.empty(us.size)
        # groups of similar counts together (counts up to each power of 2): the padded
        # rows hold at most twice the pairs, not every group at the busiest group's count
        width = 1 << np.ceil(np.log2(counts)).astype(np.int64)
        for m in np.unique(width):
            sel = np.flatnonzero(width == m)
            rows = np.empty((sel.size, int(m)))
            rows[:] = us[start[sel]][:, None]  # pad with the group's first speed
            here = np.isin(slot, sel)
            local = np.searchsorted(sel, slot[here])
            rows[local, pos[here]] = us[here]
            out[here] = self.rows(rows, used[sel])[local, pos[here]]
        return out[inv]

    def per_depth(self, share: ArrayLike, step: float = DEPTH_SHARE_STEP) -> LobeTable:
        """The table for a depth that differs per waypoint: ``share`` of one planned depth.

        A waypoint that cuts ``share`` (> 0) of the planned depth
        ``a`` is stable while ``share a <= a_lim``: its limit on the planned
        depth is ``a_lim / share``. Shares are rounded *up* to steps of
        ``step`` (relative), so that waypoints of one group and nearly one
        depth share a row and no limit is stated above its own.

        Parameters
        ----------
        share : array_like, shape (n_cut,)
            Depth of each cutting waypoint over the planned depth (1 at the
            deepest move cut in passes; above 1 for a move cut deeper than
            the planned depth; 0 or NaN: no cut there, the unbounded row).
        step : float
            Relative step of the rounding.

        Returns
        -------
        LobeTable
            One row per (group, share) pair plus an unbounded last row;
            ``exact`` divides the original's.
        """
        r = np.asarray(share, dtype=np.float64)
        if r.shape != self.group.shape:
            raise InputError(f"share: expected shape {self.group.shape}, found {r.shape}")
        if np.any(np.isinf(r)):
            raise InputError("share: expected finite values, found inf")
        none = ~(r > 0)
        unb = np.isinf(self.a_lim[:, 0]) & np.all(np.isinf(self.a_lim), axis=1)
        none |= unb[self.group]
        lr = math.log1p(step)
        level = np.where(none, 0, np.ceil(np.log(np.where(none, 1.0, r)) / lr - 1e-9))
        level = level.astype(np.int64)
        # one integer key per (group, level) (a long path: no (n, 2) rows to sort)
        lo = int(level.min())
        span = int(level.max()) - lo + 1
        key = (np.where(none, -1, self.group).astype(np.int64) + 1) * span + (level - lo)
        uniq, inv = np.unique(key, return_inverse=True)
        inv = np.asarray(inv).ravel()
        parent = uniq // span - 1
        factor = np.exp((uniq % span + lo) * lr)  # the rounded share of each new row
        bounded = parent >= 0
        n_new = int(bounded.sum())
        order = np.full(uniq.shape[0], n_new, np.int64)  # unbounded pairs: the last row
        order[bounded] = np.arange(n_new)
        p_b, f_b = parent[bounded], factor[bounded]
        a_new = np.full((n_new + 1, self.rpm.size), np.inf)
        a_new[:n_new] = self.a_lim[p_b] / f_b[:, None]
        base = self

        def exact(rows: FloatArray, groups: IntArray) -> FloatArray:
            out = np.full(rows.shape, np.inf)  # the last row: unbounded
            sel = groups < n_new
            if np.any(sel):
                g = groups[sel]
                out[sel] = base.rows(rows[sel], p_b[g]) / f_b[g][:, None]
            return out

        return LobeTable(rpm=self.rpm, a_lim=a_new, group=order[inv], exact=exact)


@dataclass(frozen=True, eq=False)
class PathGeometry:
    """Where the cutting waypoints are along the path.

    Parameters
    ----------
    seg_m : ndarray, shape (n_cut,)
        Length [m] of the cutting move that ends at each cutting waypoint.
    rapid_time_s : float
        Time [s] of all other moves (independent of the speed).
    """

    seg_m: FloatArray
    rapid_time_s: float = 0.0

    def __post_init__(self) -> None:
        s = np.asarray(self.seg_m, dtype=np.float64)
        if s.ndim != 1 or np.any(~np.isfinite(s)) or np.any(s < 0):
            raise InputError("seg_m: expected finite non-negative lengths")
        object.__setattr__(self, "seg_m", s)

    @property
    def s_m(self) -> FloatArray:
        """Cumulative cutting length [m] at each cutting waypoint, shape (n_cut,)."""
        return np.cumsum(self.seg_m)

    @property
    def length_m(self) -> float:
        """Total cutting length [m]."""
        return float(self.seg_m.sum())
