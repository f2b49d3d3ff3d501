"""Per-waypoint stability lobes: group equal dynamics, batch the ZOA over the groups.

Waypoints close together on a path have nearly the same tool-point dynamics.
:func:`group_dynamics` puts waypoints whose feed-frame modal models agree
within a tolerance (natural frequencies, damping, residues) into one group;
:func:`waypoint_lobes` computes the zero-order lobes once per group (the
group's leader, which is one of its waypoints), batched through
:func:`robolobe.sld.converged.converged_lobes` (converged in frequency), and returns a
:class:`robolobe.plan.optimize.LobeTable` whose ``exact`` boundary is the
lobe polylines intersected at any speed (:meth:`LobeDiagram.query`). With a
tolerance of zero every distinct waypoint is its own group.

Robust planning passes a second model (stiffness and damping lowered by the
prediction spread, :meth:`robolobe.plan.modes.RobotModes.robust`) and a
relative speed window per waypoint (the frequency spread: modes all shifted
by a factor r have the lobes at speed n / r): the limit is the smallest over
the models and over the window, on the grid and in the exact queries.

Grouping features include, per mode, the angle of its residue relative to
the feed direction (to ~0.3 deg) and the size with which the cut sees it,
``tr(alpha A_r)``: a mode within a degree of the feed or normal direction can
change the limit by several % per degree. Where each waypoint cuts at its own
engagement, its directional factors are compared too, to :data:`CUT_TOL`
(a sixth of the lobes' 0.5 % tolerance): the limit goes as one over their
eigenvalues, so the residue tolerance (2.1 % in a plan) let a move entering
at 89.56 deg share lobes made at 90.06 deg, 0.9 % above its own limit.

A mode's size is still shared to the residue tolerance, and the limit a
dominant mode sets goes as one over it: after the schedule,
:func:`size_members` finds the members whose own depth of the leader's lobe
pieces near the envelope at their planned speed (Newton on the phase
condition with the member's own model) lies outside the promise, and the
planner gives them lobes of their own, as it does :func:`steep_members`.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import math
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from robolobe._threads import each_on_threads
from robolobe.errors import InputError
from robolobe.plan.optimize import LobeTable
from robolobe.sld.converged import LOBE_TOL, converged_lobes
from robolobe.sld.directional import directional_factors
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram, lobe_envelope
from robolobe.sld.zoa import _use_kernels, lobes_needed

__all__ = [
    "DynamicsTolerance",
    "GroupedLobes",
    "group_dynamics",
    "group_features",
    "size_members",
    "steep_members",
    "waypoint_lobes",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
ComplexArray = NDArray[np.complex128]

_RADIUS = 0.75  # leader radius in tolerance units (plus the 0.25 cells: at most 1)
#: Tolerance of the cut's directional factors ``alpha`` where each waypoint cuts at its own
#: engagement (:func:`_engagement_features`: the log of the spectral radius and the
#: entries over it). The limit goes exactly as ``1 / c`` where ``alpha`` is scaled by
#: ``c`` (the ZOA's eigenvalues are those of ``alpha Phi``), so a size tolerance is a
#: limit tolerance; a change of shape moves the eigenvalues of ``alpha`` by up to about
#: twice the entries' change (2 x 2, Bauer-Fike with well-conditioned eigenvectors):
#: members within this of their leader cut with factors whose eigenvalues agree to
#: ~3 x 0.08 % = 0.25 %, half of the lobe-sharing promise (:data:`LOBE_TOL`), the other
#: half left to the modes' own tolerances. (The residue tolerance, 2.1 % in a plan, let
#: an entry angle of 89.56 deg share the lobes of 90.06 deg: 0.4 % in the factors' norm,
#: 0.9 % in their eigenvalues and in the limit, issue 25.)
CUT_TOL = LOBE_TOL / 6.0
#: Bytes of exact-query answers kept per :class:`GroupedLobes` (later answers are not kept).
_MEMO_BYTES = 64 << 20
#: Rows per block of a query answered from two parts of lobes (after a split).
_QUERY_ROWS = 65_536


@dataclass(frozen=True)
class DynamicsTolerance:
    """When two waypoints share lobes (all relative, as fractions).

    Parameters
    ----------
    freq : float
        Natural frequencies (0.003 = 0.3 %: the lobes shift by as much in speed).
    damping : float
        Damping ratios.
    residue : float
        Residue size (trace, ~ 1/k) and direction (entries over the trace).
    freq_low : float
        Frequencies of modes below ``f_low_hz``: such modes (the robot's,
        well below the tooth-passing frequency) only reach the speed range
        through the tail of their k = 0 lobe, where the limit varies smoothly
        with the frequency (about 1 % for 1 %), not through pockets that
        shift sideways.
    f_low_hz : float
        Where ``freq_low`` applies (e.g. half the lowest tooth-passing
        frequency); 0: nowhere.
    cut : float, optional
        The cut's directional factors, where each waypoint has its own
        engagement (:func:`_engagement_features`); None: :data:`CUT_TOL`, or
        ``residue`` where that is smaller (0 with an exact tolerance).
    """

    freq: float = 0.003
    damping: float = 0.03
    residue: float = 0.02
    freq_low: float = 0.01
    f_low_hz: float = 0.0
    cut: float | None = None

    @property
    def cut_tol(self) -> float:
        """The tolerance of the cut's directional factors in use (see ``cut``)."""
        return min(self.residue, CUT_TOL) if self.cut is None else self.cut

    @property
    def exact(self) -> bool:
        """True when only identical dynamics share a group."""
        return (
            self.freq == 0
            and self.damping == 0
            and self.residue == 0
            and (self.freq_low == 0 or self.f_low_hz == 0)
            and self.cut_tol == 0
        )


def _features(
    model: ModalModel, tol: DynamicsTolerance, alpha: FloatArray | None = None
) -> FloatArray:
    """Scaled features (n, F): a max-norm distance <= 1 means 'within tolerance'.

    Per mode: log natural frequency, log damping, log of the residue trace
    (the mode's size at the tool) and the residue matrix over its trace (its
    direction). Each mode's features are weighted by the square root of its
    share of the peak compliance at that waypoint, so that modes that barely
    move the tool do not split groups.

    With the directional factors ``alpha`` (2, 2) the cut sees a mode through
    ``tr(alpha A_r)`` (for a mode shape ``u``: ``u^T alpha u``), which is small
    and varies fast with the angle between the feed and a mode shape close to
    the feed direction (where ``alpha`` weighs the normal direction): the log
    of its size relative to the mode's trace (and its sign) is a feature too,
    so that such a mode splits groups at the angle where it changes the
    limit, not at the angle where its residue entries do.
    """
    w = model.omega.reshape(-1, model.n_modes)
    z = model.zeta.reshape(-1, model.n_modes)
    a = model.residues.reshape(-1, model.n_modes, model.dim, model.dim)
    tr = np.abs(np.trace(a, axis1=-2, axis2=-1))
    peak = tr / (2.0 * z * w**2)  # compliance at resonance, per mode
    weight = np.sqrt(peak / np.maximum(peak.max(axis=1, keepdims=True), 1e-300))
    trs = np.maximum(tr, 1e-300)
    tol_f = np.where(w < 2 * np.pi * tol.f_low_hz, max(tol.freq_low, tol.freq), tol.freq)
    pairs = [(i, j) for i in range(model.dim) for j in range(i, model.dim)]
    pairs = pairs[:-1]  # the last diagonal share follows from the others
    with_alpha = alpha is not None and model.dim == 2
    m = model.n_modes
    # (h-long, issue 16/17 memory: each block written into one array as it is made,
    # not a list of blocks, their weighted copies and their concatenation; same values)
    per_wp = alpha is not None and np.asarray(alpha).ndim == 3  # each waypoint's own cut
    n_eng = 5 if with_alpha and per_wp else 0
    out = np.empty((w.shape[0], (3 + len(pairs) + 2 * with_alpha) * m + n_eng))
    out[:, 0:m] = np.log(w) / np.maximum(tol_f, 1e-15) * weight
    out[:, m : 2 * m] = np.log(z) / max(tol.damping, 1e-15) * weight
    out[:, 2 * m : 3 * m] = np.log(trs) / max(tol.residue, 1e-15) * weight
    for k, (i, j) in enumerate(pairs, start=3):
        # a mode's direction relative to the feed: sin/cos products of its angle, to
        # a quarter of the size tolerance (0.5 % -> 0.3 deg): near the feed or normal
        # direction the limit moves by several % per degree
        out[:, k * m : (k + 1) * m] = a[:, :, i, j] / trs / max(tol.residue / 4.0, 1e-15) * weight
    if with_alpha:
        # the cut sees mode r through tr(alpha A_r): its limit goes as 1 / that, so its
        # log (relative to the mode's size) is compared to the residue tolerance, with the
        # mode's own weight: near a sign change it varies without bound and splits groups
        # finely there, which is where the limit is most sensitive
        al = np.asarray(alpha, dtype=np.float64)
        if al.ndim == 2:
            ori = np.einsum("ij,nmji->nm", al, a) / trs
        else:  # each waypoint's own engagement
            ori = np.einsum("nij,nmji->nm", al.reshape(-1, 2, 2), a) / trs
        mag = np.log(np.maximum(np.abs(ori), 1e-12)) / max(tol.residue, 1e-15)
        k = 3 + len(pairs)
        out[:, k * m : (k + 1) * m] = mag * weight
        out[:, (k + 1) * m : (k + 2) * m] = np.sign(ori) * weight / max(tol.residue, 1e-15)
        if per_wp:
            out[:, (k + 2) * m :] = _engagement_features(al.reshape(-1, 2, 2), tol)
    return out


def _engagement_features(alpha: FloatArray, tol: DynamicsTolerance) -> FloatArray:
    """Features (n, 5) of per-waypoint directional factors: their size and shape.

    The log of the spectral radius ``rho`` (the larger eigenvalue's modulus:
    the limit goes as one over the factors' scale) and the entries over
    ``rho`` (the shape, in units of the eigenvalues it moves), both to the
    cut's tolerance (:data:`CUT_TOL`): waypoints of one group then cut with
    factors whose eigenvalues agree with the leader's to ~3 ``cut_tol``, on
    top of each mode's oriented size. (Over the matrix norm instead, which
    is about twice ``rho`` at half immersion, a shape change moved the
    eigenvalues twice as much as the features said.)
    """
    a, b, c, d = (alpha[:, i, j] for i in (0, 1) for j in (0, 1))
    half_tr = 0.5 * (a + d)
    disc = np.sqrt((half_tr * half_tr - (a * d - b * c)).astype(np.complex128))
    rho = np.maximum(np.abs(half_tr + disc), np.abs(half_tr - disc))
    norm = np.sqrt(np.einsum("nij,nij->n", alpha, alpha))
    rho = np.maximum(rho, np.maximum(1e-6 * norm, 1e-300))  # a nilpotent cut: by its norm
    t = max(tol.cut_tol, 1e-15)
    out = np.empty((alpha.shape[0], 5))
    out[:, 0] = np.log(rho) / t
    out[:, 1:] = alpha.reshape(-1, 4) / rho[:, None] / t
    return out


def _distinct_rows(q: FloatArray | _Cells) -> tuple[IntArray, IntArray]:
    """First occurrence of each distinct row of ``q`` (n, F) and each row's distinct row.

    By hashing the rows (integer cells: the rounded features) and factorising
    the hashes in path order, verified row by row against each class's first
    row; on a hash collision (or cells that are not small integers) by
    sorting the rows (:func:`numpy.unique`). Either way the same partition.

    Returns
    -------
    first : ndarray of int, shape (n_distinct,)
        Row where each distinct row first occurs.
    inverse : ndarray of int, shape (n,)
        Index into ``first`` of each row.
    """
    import pandas as pd

    col = q.column if isinstance(q, _Cells) else (lambda c: q[:, c])
    h = np.zeros(q.shape[0], np.uint64)
    small = q.shape[0] > 0
    for c in range(q.shape[1] if small else 0):  # polynomial hash, wrapping in 64 bits
        qc = col(c)  # (a column at a time: memory)
        if not np.all(np.abs(qc) < 2.0**52):  # not small integers: sort instead
            small = False
            break
        qi = qc.astype(np.int64).view(np.uint64)
        h = h * np.uint64(0x100000001B3) + (qi ^ np.uint64(0x9E3779B97F4A7C15))
    if small:
        codes, _ = pd.factorize(h, sort=False)
        codes = np.asarray(codes, np.int64)
        first = np.full(int(codes.max()) + 1, q.shape[0], np.int64)
        np.minimum.at(first, codes, np.arange(q.shape[0]))
        step = 65_536  # verified in blocks (no copy of all rows)
        if all(
            np.array_equal(q[s : s + step], q[first[codes[s : s + step]]])
            for s in range(0, q.shape[0], step)
        ):
            return first, codes
    qa = q.all() if isinstance(q, _Cells) else q
    _, first, inv = np.unique(qa, axis=0, return_index=True, return_inverse=True)
    return np.asarray(first, np.int64), np.asarray(inv, np.int64).ravel()


def group_dynamics(
    model: ModalModel,
    tol: DynamicsTolerance | None = None,
    alpha: FloatArray | None = None,
    *,
    compiled: bool | None = None,
) -> tuple[IntArray, IntArray]:
    """Group a batch of modal models whose parameters agree within ``tol``.

    Leader clustering in the scaled feature space (max norm): the group of
    the first ungrouped model (in path order) is led by the last of the
    ungrouped models that follow it within tolerance of it (:func:`_centred`:
    along a path the leader stands in the middle of its group, not at its
    start) and takes every ungrouped model within tolerance of that leader.

    Parameters
    ----------
    model : ModalModel
        Batch shape (n,).
    tol : DynamicsTolerance, optional
    alpha : ndarray, shape (2, 2), optional
        Directional factors of the cut (feed-frame models): adds the oriented
        size of each mode to the features (see :func:`_features`).
    compiled : bool, optional
        Cluster with the compiled kernel (True), the cKDTree loop (False), or
        the kernel from :data:`JIT_MIN_ROWS` distinct rows on (None). Same groups.

    Returns
    -------
    group : ndarray of int, shape (n,)
        Group of each model.
    leader : ndarray of int, shape (n_groups,)
        Index of each group's leader (a member whose dynamics stand for it).
    """
    tol = tol or DynamicsTolerance()
    return group_features(_features(model, tol, alpha), tol, compiled=compiled)


def group_features(
    f: FloatArray, tol: DynamicsTolerance, *, compiled: bool | None = None
) -> tuple[IntArray, IntArray]:
    """:func:`group_dynamics` from the scaled features (:func:`_features`) of the batch.

    ``f`` (n, F) is consumed: it is overwritten (its useful columns and
    distinct rows compacted into it in place, so that grouping a long path
    holds no second copy of its features). Same groups as
    :func:`group_dynamics`.
    """
    n = f.shape[0]
    if tol.exact:
        _, first, inv = np.unique(f, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first)
        remap = np.empty_like(order)
        remap[order] = np.arange(order.size)
        return remap[np.asarray(inv).ravel()].astype(np.int64), first[order].astype(np.int64)
    # a feature whose range over the batch is within the radius can never split a group
    # (max norm): leave it out
    if n:
        f = _compact(f, cols=np.flatnonzero(np.ptp(f, axis=0) > _RADIUS))
    if f.shape[1] == 0:
        return np.zeros(n, np.int64), np.zeros(min(n, 1), np.int64)
    # near-duplicates first: cells 0.25 wide; leaders then take cells within 0.75 of
    # them, so every member lies within 0.25 + 0.75 = 1 of its leader
    first, inv = _distinct_rows(_Cells(f))
    order = np.argsort(first)  # unique rows in path order
    keep = first[order]  # increasing
    fu = _compact(f, rows=keep)
    label_u, lead_u = _leaders(fu, compiled)
    pos = np.empty_like(order)
    pos[order] = np.arange(order.size)
    group = label_u[pos[inv]]
    return group.astype(np.int64), keep[lead_u].astype(np.int64)


#: Rows per block of the in-place compaction and the chunked cells.
_BLOCK = 65_536


def _compact(
    f: FloatArray, *, cols: IntArray | None = None, rows: IntArray | None = None
) -> FloatArray:
    """``f[:, cols]`` or ``f[rows]`` (``rows`` increasing) written into ``f``'s own memory.

    Block by block in row order: the rows written never reach rows not yet read
    (each block is copied out first), so the result equals the fancy-indexed
    copy, without a second array of the size of ``f``. ``f`` is overwritten.
    """
    if not f.flags.c_contiguous:
        return f[:, cols] if cols is not None else f[rows]
    n, k = f.shape
    flat = f.reshape(-1)
    if cols is not None:
        k2 = int(cols.size)
        for s in range(0, n, _BLOCK):
            blk = f[s : s + _BLOCK][:, cols]  # a copy
            flat[s * k2 : s * k2 + blk.size] = blk.reshape(-1)
        return flat[: n * k2].reshape(n, k2)
    assert rows is not None
    m = int(rows.size)
    for s in range(0, m, _BLOCK):
        blk = f[rows[s : s + _BLOCK]]  # a copy; rows[i] >= i: never a row already written
        flat[s * k : s * k + blk.size] = blk.reshape(-1)
    return flat[: m * k].reshape(m, k)


class _Cells:
    """The rounded cells ``round(4 f)`` of features ``f`` (n, F), made block by block.

    Indexing gives the same values as indexing the full array of cells.
    """

    def __init__(self, f: FloatArray) -> None:
        self.f = f
        self.shape = f.shape

    def __getitem__(self, idx: Any) -> FloatArray:
        c = self.f[idx] * 4.0
        return np.round(c, out=c)

    def column(self, c: int) -> FloatArray:
        """Column ``c`` of the cells."""
        col = self.f[:, c] * 4.0
        return np.round(col, out=col)

    def all(self) -> FloatArray:
        """All cells (the fallback on a hash collision)."""
        return self[:]


#: Distinct rows from which :func:`group_dynamics` clusters with the compiled kernel
#: by default (below, the numpy loop is quick and numba's start-up would cost more).
#: Measured (benchmarks/bench_jit.py --kernel group, CPU seconds of a fresh process,
#: 2 cores at load 9): 4,000 rows numpy 0.40 vs compiled 0.67, 8,000 0.87 vs 0.75;
#: equal at ~6,000.
JIT_MIN_ROWS = 6_000
#: The same where numba has started already (:func:`robolobe._jit.started`): 1,000
#: rows numpy 0.25 vs compiled 0.21 (500: 0.22 vs 0.21).
JIT_MIN_ROWS_STARTED = 1_000


def _leaders(fu: FloatArray, compiled: bool | None) -> tuple[IntArray, IntArray]:
    """Leader clustering of ``fu`` (m, F) in row order: (label per row, leader rows).

    Compiled (:mod:`robolobe.plan._group_kernels`) where numba is available and
    ``compiled`` allows (None: from :data:`JIT_MIN_ROWS` rows on), else
    :func:`_leaders_numpy`; :func:`_leaders_tree` where a feature is not
    finite. The same groups on every path.
    """
    from robolobe import _jit

    if compiled is None:
        compiled = _jit.use_compiled(fu.shape[0], cold=JIT_MIN_ROWS, warm=JIT_MIN_ROWS_STARTED)
    # non-finite features (degenerate modes) keep the tree loop's handling of NaN
    if not bool(np.all(np.isfinite(fu))):
        return _leaders_tree(fu)
    if compiled and _jit.available():
        from robolobe.plan import _group_kernels

        return _group_kernels.leaders(fu, _RADIUS)
    return _leaders_numpy(fu)


def _leaders_numpy(fu: FloatArray) -> tuple[IntArray, IntArray]:
    """The leader clustering of :func:`_leaders_tree` in numpy, for finite features.

    The same comparison as the compiled kernel, ``max |f_j - f_lead| <= radius``,
    over the rows not yet grouped: O(rows x groups), quick below
    :data:`JIT_MIN_ROWS` rows, and without scipy.spatial's ~0.15 s import.
    """
    m = fu.shape[0]
    label_u = np.full(m, -1, np.int64)
    leaders: list[int] = []
    free = np.arange(m)
    while free.size:
        lead = _centred(fu, int(free[0]), label_u)
        d = np.abs(fu[free] - fu[lead]).max(axis=1, initial=0.0)
        near = d <= _RADIUS
        label_u[free[near]] = len(leaders)
        leaders.append(lead)
        free = free[~near]
    return label_u, np.asarray(leaders, dtype=np.int64)


def _centred(fu: FloatArray, first: int, label_u: IntArray) -> int:
    """The leader of the group that takes ``first`` (the first row not yet grouped).

    The last of the rows ``first, first + 1, ...`` that follow one another not
    yet grouped and within :data:`_RADIUS` of ``first`` (max norm): along a
    path, whose features change a little from row to row, it stands in the
    middle of the rows it takes (those up to the radius behind it, ``first``
    among them, and ahead of it) instead of at their start, so that a group
    takes about twice as many rows. Every member still lies within the radius
    of its leader. The rule of the compiled kernel
    (:mod:`robolobe.plan._group_kernels`).
    """
    m = fu.shape[0]
    lead = first
    x = fu[first]
    while lead + 1 < m and label_u[lead + 1] < 0:
        if not bool(np.all(np.abs(fu[lead + 1] - x) <= _RADIUS)):
            break
        lead += 1
    return lead


def _leaders_tree(fu: FloatArray) -> tuple[IntArray, IntArray]:
    """Leader clustering with a cKDTree: each leader (:func:`_centred`, in row order)
    takes every row not yet grouped within :data:`_RADIUS` (max norm). The reference of
    the compiled kernel."""
    from scipy.spatial import cKDTree  # the reference path only: scipy.spatial costs ~0.15 s

    label_u = np.full(fu.shape[0], -1, np.int64)
    leaders: list[int] = []
    tree = cKDTree(fu)
    for first in range(fu.shape[0]):  # in path order; most rows are taken by earlier leaders
        if label_u[first] >= 0:
            continue
        lead = _centred(fu, first, label_u)
        near = np.asarray(tree.query_ball_point(fu[lead], _RADIUS, p=np.inf), dtype=np.int64)
        near = near[label_u[near] < 0]
        label_u[near] = len(leaders)
        leaders.append(lead)
    return label_u, np.asarray(leaders, dtype=np.int64)


@dataclass(frozen=True, eq=False)
class GroupedLobes:
    """Lobes of the groups and the map from waypoints to groups.

    Attributes
    ----------
    table : LobeTable
        For the optimizer (one row per group, plus an unbounded row for
        waypoints without lateral chatter, e.g. plunges).
    parts : tuple of tuple of LobeDiagram
        The lobes as computed: per part (consecutive groups: those of a
        result that was reused, then the groups added to it) one diagram per
        scenario. :attr:`diagrams` joins them.
    leader : ndarray of int, shape (n_groups,)
        Waypoint (index into the models given) that stands for each group.
    valid : bool
        False when the ZOA is flagged unreliable (low immersion).
    message : str
        Why, when not valid.
    timings : dict
        Seconds spent grouping and computing lobes.
    window : ndarray, shape (n_groups,)
        Relative speed window of each group (0 without robust planning).
    n_base : int
        Groups formed by the tolerance; the ones after them are waypoints
        given lobes of their own (``own``).
    query : callable, optional
        ``query(rows, groups)``: the exact limit of groups ``groups`` (g,), all
        below ``n_groups``, at speeds ``rows`` (g, m) [rpm], without the
        robust window; answers are kept (up to :data:`_MEMO_BYTES`).
    query_compiled : bool
        Whether ``query`` runs the compiled kernel.
    forget : callable, optional
        ``forget()`` drops the answers ``query`` keeps (and those of the lobes
        these reuse): later questions are computed again, to the same values.
    """

    table: LobeTable
    parts: tuple[tuple[LobeDiagram, ...], ...]
    leader: IntArray
    valid: bool
    message: str
    timings: dict[str, float] = field(default_factory=dict)
    window: FloatArray = field(default_factory=lambda: np.zeros(0))
    n_base: int = -1
    query: Callable[[FloatArray, IntArray], FloatArray] | None = field(default=None, repr=False)
    query_compiled: bool = False
    forget: Callable[[], None] | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        if self.n_base < 0:
            object.__setattr__(self, "n_base", self.n_groups)

    @property
    def n_groups(self) -> int:
        """Number of distinct dynamics (lobe computations per scenario)."""
        return int(self.leader.size)

    @functools.cached_property
    def diagrams(self) -> tuple[LobeDiagram, ...]:
        """One diagram per scenario (nominal first), batch shape (n_groups,)."""
        return tuple(_joined(list(p)) for p in zip(*self.parts, strict=True))


def waypoint_lobes(
    models: Sequence[ModalModel],
    *,
    teeth: int,
    kt: float,
    kr: float,
    phi_entry: float | FloatArray,
    phi_exit: float | FloatArray,
    rpm: FloatArray,
    immersion: float,
    unbounded: NDArray[np.bool_] | None = None,
    tol: DynamicsTolerance | None = None,
    max_lobe_cap: int = 400,
    window: FloatArray | Sequence[FloatArray | None] | None = None,
    own: NDArray[np.bool_] | None = None,
    reuse: GroupedLobes | None = None,
    features: FloatArray | None = None,
) -> GroupedLobes:
    """Lobes of every waypoint, computed once per group of equal dynamics.

    Parameters
    ----------
    models : sequence of ModalModel
        Feed-frame (2-D) tool-point models, batch shape (n,), nominal first,
        then robust scenarios (same batch).
    teeth, kt, kr : int, float, float
        Flutes, Kt [N/m^2], Kn/Kt.
    phi_entry, phi_exit : float or ndarray, shape (n,)
        Engagement angles [rad]: of the whole cut, or of each waypoint (its
        own engagement; NaN allowed only where ``unbounded``). Per-waypoint
        angles enter the grouping (:func:`_engagement_features`): a group's
        members cut with directional factors within the tolerance of its
        leader's, whose own angles give the group's lobes.
    rpm : ndarray, shape (n_rpm,)
        Increasing speed grid [rpm].
    immersion : float
        a_e / D (validity flag of the ZOA).
    unbounded : ndarray of bool, shape (n,), optional
        Waypoints without a lateral stability limit (plunges): they get an
        unbounded row.
    tol : DynamicsTolerance, optional
        Grouping tolerance (default 0.3 % in frequency).
    max_lobe_cap : int
        Upper bound of the automatic lobe count.
    window : ndarray, shape (n,), optional
        Relative speed window per waypoint (robust planning: the frequency
        uncertainty): the limit at speed ``n`` is the smallest over
        ``n (1 + t w)``, ``|t| <= 1`` (sampled at most one grid step apart,
        kept inside the grid) in the exact queries, over the grid points inside
        the window on the grid. A group takes the widest window of its members.
        A list (one per model, None for none): each scenario in its own window
        (a robust bound's joint region, :func:`robolobe.plan.modes.region_corners`).
    own : ndarray of bool, shape (n,), optional
        Waypoints that get lobes of their own whatever the tolerance (e.g. those
        :func:`steep_members` finds next to a steep lobe wall).
    reuse : GroupedLobes, optional
        A result of this function for the same models and arguments without
        ``own``: its grouping and lobes are kept and only the waypoints that
        ``own`` adds are computed (the result is the same as without
        ``reuse``).
    features : ndarray, shape (n_bounded, F), optional
        The grouping features (:func:`_features` with ``tol`` and the cut's
        directional factors) of the waypoints that are not ``unbounded``, made
        beforehand (e.g. chunk by chunk along a long path, whose models are
        then only made for the leaders: ``models`` need only ``dim``,
        ``batch_shape`` and ``take``); one scenario only. Consumed
        (:func:`group_features`). Same groups as from the models.

    Returns
    -------
    GroupedLobes
    """
    if not models:
        raise InputError("waypoint_lobes: expected at least one model")
    nominal = models[0]
    if nominal.dim != 2 or len(nominal.batch_shape) != 1:
        raise InputError(
            f"models: expected feed-frame (2-D) models with one batch axis, found dim "
            f"{nominal.dim}, batch {nominal.batch_shape}"
        )
    n = nominal.batch_shape[0]
    unb = np.zeros(n, bool) if unbounded is None else np.asarray(unbounded, bool)
    idx_b = np.flatnonzero(~unb)
    t0 = time.perf_counter()
    alpha = _cut_alpha(phi_entry, phi_exit, kr, n, idx_b)
    rpm = np.asarray(rpm, dtype=np.float64)
    if idx_b.size:
        if reuse is not None:
            if reuse.n_base != reuse.n_groups or reuse.table.group.size != n:
                raise InputError("reuse: expected a result without own lobes for the same path")
            g_b = reuse.table.group[idx_b]
            pos_b = np.full(n, -1, np.int64)
            pos_b[idx_b] = np.arange(idx_b.size)
            lead_b = pos_b[reuse.leader]
        elif features is not None:
            if len(models) != 1 or features.shape[0] != idx_b.size:
                raise InputError(
                    f"features: expected one scenario and {idx_b.size} rows, found "
                    f"{len(models)} scenarios and {features.shape[0]} rows"
                )
            g_b, lead_b = group_features(features, tol or DynamicsTolerance())
            features = None  # consumed: not held through the lobes
        else:
            # group on all scenarios together so that a group is uniform in each
            # (h-long: built only here, and no copy of a lone nominal without plunges)
            joined = nominal if idx_b.size == n else nominal.take(idx_b)
            for m in models[1:]:
                joined = ModalModel(
                    np.concatenate([joined.omega, m.omega[idx_b]], axis=-1),
                    np.concatenate([joined.zeta, m.zeta[idx_b]], axis=-1),
                    np.concatenate([joined.residues, m.residues[idx_b]], axis=-3),
                )
            g_b, lead_b = group_dynamics(joined, tol, alpha if alpha.ndim == 2 else alpha[idx_b])
            del joined
        n_base = int(lead_b.size)
        if own is not None:
            force = np.asarray(own, bool)[idx_b]
            force[lead_b] = False  # leaders have their own lobes already
            extra = np.flatnonzero(force)
            g_b = g_b.copy()
            g_b[extra] = lead_b.size + np.arange(extra.size)
            lead_b = np.r_[lead_b, extra].astype(np.int64)
        leader = idx_b[lead_b]
    else:
        g_b = np.zeros(0, np.int64)
        leader = np.zeros(0, np.int64)
        n_base = 0
    n_groups = leader.size
    t1 = time.perf_counter()
    zoa_args: dict[str, Any] = {
        "alpha": alpha,
        "teeth": teeth,
        "kt": kt,
        "rpm": rpm,
        "immersion": immersion,
        "max_lobe_cap": max_lobe_cap,
    }
    parts: list[list[LobeDiagram]] = []  # per part, one diagram per scenario
    if n_groups and reuse is not None:
        parts = _extend_diagrams(models, reuse, leader, zoa_args)
    elif n_groups:
        parts = [
            [
                _leader_lobes(
                    m.take(leader),
                    zoa_args,
                    max_lobe=None,
                    idx=leader,
                    single_from=COMPACT_MIN_SAMPLES,
                )
                for m in models
            ]
        ]
        for diagrams in parts:
            for j in range(len(diagrams)):
                _compact_polylines(diagrams, j)
    # per scenario windows (n_scen, n_groups + 1): one row when all scenarios share one
    w_scen = _scenario_windows(window, len(models), n, group_of=(idx_b, g_b), n_groups=n_groups)
    per_scen = w_scen.shape[0] > 1
    a_grid = np.full((n_groups + 1, rpm.size), np.inf)
    a_scen = np.full((len(models) if per_scen else 0, n_groups + 1, rpm.size), np.inf)
    start = 0
    for part in parts:
        stop = start + part[0].a_lim.shape[0]
        if per_scen:
            for j, d in enumerate(part):
                a_scen[j, start:stop] = d.a_lim
        else:
            a_grid[start:stop] = np.min(np.stack([d.a_lim for d in part]), axis=0)
        start = stop
    group = np.full(n, n_groups, np.int64)  # last row: unbounded
    group[idx_b] = g_b
    first_part = parts[0] if parts else []
    merged: list[list[LobeDiagram]] = []  # the parts joined, formed when needed

    def whole() -> list[LobeDiagram]:
        if not merged:
            merged.append([_joined(list(p)) for p in zip(*parts, strict=True)])
        return merged[0]

    kern = _query_kernels(
        n_groups * (np.asarray(first_part[0].depth).shape[-1] if first_part else 0)
    )

    def lobes_at(rows: FloatArray, g: IntArray, diagrams: list[LobeDiagram]) -> FloatArray:
        vals = []
        for d in diagrams:
            assert d.depth is not None
            assert d.eps is not None
            assert d.omega is not None
            if kern is not None and np.ndim(d.omega) > 1:
                vals.append(
                    kern.envelope_rows(
                        d.omega, d.depth, d.eps, g, teeth=d.teeth, rpm=rows, max_lobe=d.max_lobe
                    )
                )
                continue
            om = d.omega[g] if np.ndim(d.omega) > 1 else d.omega
            vals.append(
                lobe_envelope(
                    om, d.depth[g], d.eps[g], teeth=d.teeth, rpm=rows, max_lobe=d.max_lobe
                )
            )
        return np.asarray(np.min(np.stack(vals), axis=0))

    # The optimizer asks the same questions more than once (the constant and the
    # searched schedule verified at the same speeds; the schedule made again after
    # the steep-wall split): the answers are kept. After the split, the groups of
    # ``reuse`` are answered from its lobes and the added ones from theirs (the kernel
    # computes each row on its own: the same values as from the parts joined).
    # keyed by a digest of the question (a copy of its bytes as the key held as much
    # again as the answers, uncounted: ~150 MB per lobes on the 1e6 path, two lobes alive
    # after a split); 128-bit BLAKE2b, so two questions never share a key in practice
    memo: dict[tuple[tuple[int, ...], bytes], FloatArray] = {}
    memo_bytes = [0]
    n_prev = reuse.n_groups if reuse is not None else 0
    # the added groups' lobes beside ``reuse``'s, each part on its own (not joined: a copy
    # of every polyline), where both run the same kernel (the same values as joined); a
    # question about ``reuse``'s groups alone goes to it (its kept answers)
    by_part = kern is not None and reuse is not None and reuse.query_compiled
    prev = reuse.query if by_part and reuse is not None else None

    def query(rows: FloatArray, g: IntArray) -> FloatArray:
        rows = np.ascontiguousarray(rows, dtype=np.float64)
        g = np.ascontiguousarray(g, dtype=np.int64)
        # large questions (robust windows: many shifted speeds) are neither kept nor
        # looked up: the key would copy them
        small = rows.nbytes <= _MEMO_BYTES // 8
        key = None
        if small:
            h = hashlib.blake2b(rows.data.cast("B"), digest_size=16)
            h.update(g.data.cast("B"))
            key = (rows.shape, h.digest())
        val = memo.get(key) if key is not None else None
        if val is not None:
            return val
        if prev is not None and len(parts) == 2 and not np.any(g >= n_prev):
            val = prev(rows, g)
        elif by_part and len(parts) == 2:
            # in blocks of rows: the masked copies of a whole table's question (1e6 rows x
            # its speeds) stay small
            val = np.empty(rows.shape)
            for s0 in range(0, g.size, _QUERY_ROWS):
                rb, gb = rows[s0 : s0 + _QUERY_ROWS], g[s0 : s0 + _QUERY_ROWS]
                vb = val[s0 : s0 + _QUERY_ROWS]
                old = gb < n_prev
                if np.all(old):
                    vb[...] = lobes_at(rb, gb, parts[0])
                elif not np.any(old):
                    vb[...] = lobes_at(rb, gb - n_prev, parts[1])
                else:
                    vb[old] = lobes_at(rb[old], gb[old], parts[0])
                    vb[~old] = lobes_at(rb[~old], gb[~old] - n_prev, parts[1])
        elif len(parts) == 1:
            val = lobes_at(rows, g, parts[0])
        else:
            val = lobes_at(rows, g, whole())
        if key is not None and memo_bytes[0] + val.nbytes <= _MEMO_BYTES:
            memo[key] = val
            memo_bytes[0] += val.nbytes
        return val

    def forget() -> None:
        memo.clear()
        memo_bytes[0] = 0
        if reuse is not None and reuse.forget is not None:
            reuse.forget()

    def exact0(rows: FloatArray, groups: IntArray) -> FloatArray:
        out = np.full(rows.shape, np.inf)
        sel = groups < n_groups  # the last row is the unbounded one
        if np.any(sel):
            out[sel] = query(rows[sel], groups[sel])
        return out

    w_group = w_scen.max(axis=0)
    w_max = float(w_group.max())
    if per_scen:

        def scen_query(rows: FloatArray, g: IntArray, j: int) -> FloatArray:
            diagrams = parts[0] if len(parts) == 1 else whole()
            return lobes_at(
                np.ascontiguousarray(rows, dtype=np.float64),
                np.ascontiguousarray(g, dtype=np.int64),
                [diagrams[j]],
            )

        def exact(rows: FloatArray, groups: IntArray) -> FloatArray:
            out = np.full(rows.shape, np.inf)
            sel = groups < n_groups  # the last row is the unbounded one
            if not np.any(sel):
                return out
            r, g = rows[sel], groups[sel]
            best = np.full(r.shape, np.inf)
            for j in range(len(models)):
                wj = w_scen[j][g]
                t_j = _window_samples(float(wj.max()), rpm)
                shifted = np.clip(
                    r[:, None, :] * (1.0 + t_j[:, None] * wj[:, None, None]), rpm[0], rpm[-1]
                )
                vals = scen_query(shifted.reshape(r.shape[0], -1), g, j)
                np.minimum(best, vals.reshape(shifted.shape).min(axis=1), out=best)
            out[sel] = best
            return out

        for j in range(len(models)):
            a_scen[j, :n_groups] = _window_grid(a_scen[j, :n_groups], w_scen[j][:n_groups], rpm)
        a_grid = a_scen.min(axis=0)
        del a_scen
    elif w_max > 0:
        t_samples = _window_samples(w_max, rpm)

        def exact(rows: FloatArray, groups: IntArray) -> FloatArray:
            # all shifts in one envelope query (one pass over the lobe pieces)
            wg = w_group[groups][:, None, None]
            shifted = np.clip(rows[:, None, :] * (1.0 + t_samples[:, None] * wg), rpm[0], rpm[-1])
            vals = exact0(shifted.reshape(rows.shape[0], -1), groups)
            return np.asarray(vals.reshape(shifted.shape).min(axis=1))

        a_grid[:n_groups] = _window_grid(a_grid[:n_groups], w_group[:n_groups], rpm)
    else:
        exact = exact0
        if len(models) == 1:
            # the grid is each part's own limits here: the diagrams read theirs from it
            # (not a second copy: 19,501 groups x 300 speeds on a 1e6-waypoint path)
            a_grid.flags.writeable = False
            start = 0
            for part in parts:
                stop = start + part[0].a_lim.shape[0]
                part[0] = dataclasses.replace(part[0], a_lim=a_grid[start:stop])
                start = stop

    t2 = time.perf_counter()
    return GroupedLobes(
        table=LobeTable(rpm=rpm, a_lim=a_grid, group=group, exact=exact),
        parts=tuple(tuple(p) for p in parts),
        leader=leader,
        valid=first_part[0].valid if first_part else True,
        message=first_part[0].message if first_part else "",
        timings={"grouping": t1 - t0, "zoa": t2 - t1},
        window=w_group[:n_groups],
        n_base=n_base,
        query=query if n_groups else None,
        query_compiled=kern is not None,
        forget=forget,
    )


def _scenario_windows(
    window: FloatArray | Sequence[FloatArray | None] | None,
    n_models: int,
    n: int,
    *,
    group_of: tuple[IntArray, IntArray],
    n_groups: int,
) -> FloatArray:
    """Each group's speed window per scenario, shape (n_scen, n_groups + 1).

    One row (every scenario in the same window) unless ``window`` is a list of
    per-scenario windows that differ; a group takes the widest of its members;
    the last (unbounded) row has none.
    """
    if window is None or isinstance(window, np.ndarray):
        rows: list[FloatArray | None] = [window]
    else:
        rows = list(window)
        if len(rows) != n_models:
            raise InputError(
                f"window: expected one window per model ({n_models}), found {len(rows)}"
            )
    idx_b, g_b = group_of
    out = np.zeros((len(rows), n_groups + 1))
    for j, w_in in enumerate(rows):
        if w_in is None or not n_groups:
            continue
        w = np.clip(np.nan_to_num(np.asarray(w_in, dtype=np.float64)), 0.0, 0.5)
        if w.shape != (n,):
            raise InputError(f"window: expected shape ({n},), found {w.shape}")
        np.maximum.at(out[j], g_b, w[idx_b])
    if out.shape[0] > 1 and np.all(out == out[:1]):
        out = out[:1]
    return out


def _window_samples(w_max: float, rpm: FloatArray) -> FloatArray:
    """Relative shifts ``t`` in [-1, 1] at which a window of half-width ``w_max`` is
    sampled in the exact queries: at most one grid step apart (3 to 41)."""
    step = float(rpm[-1] - rpm[0]) / max(rpm.size - 1, 1)
    n_t = int(min(41, max(3, 2 * math.ceil(w_max * rpm[-1] / max(step, 1e-9)) + 1)))
    return np.linspace(-1.0, 1.0, n_t)


def _window_grid(base: FloatArray, w: FloatArray, rpm: FloatArray) -> FloatArray:
    """The grid's running minimum over each row's speed window ``rpm (1 +- w)``
    (exact at the grid speeds, sampled at the grid's own spacing in between)."""
    lo_idx = np.searchsorted(rpm, rpm[None, :] * (1.0 - w[:, None]), "left")
    hi_idx = np.searchsorted(rpm, rpm[None, :] * (1.0 + w[:, None]), "right")
    win = base.copy()
    cols = np.arange(rpm.size)
    reach = np.maximum(cols - lo_idx, hi_idx - 1 - cols)
    for off in range(1, int(np.max(reach, initial=0)) + 1):
        left = np.where(cols - off >= lo_idx, np.roll(base, off, axis=1), np.inf)
        right = np.where(cols + off <= hi_idx - 1, np.roll(base, -off, axis=1), np.inf)
        win = np.minimum(win, np.minimum(left, right))
    return win


def _cut_alpha(
    phi_entry: float | FloatArray, phi_exit: float | FloatArray, kr: float, n: int, idx_b: IntArray
) -> FloatArray:
    """Directional factors of the cut (2, 2), or of each of ``n`` waypoints (n, 2, 2).

    Per-waypoint angles are checked on the bounded waypoints ``idx_b``; the
    others (plunges, air) get zeros.
    """
    if np.ndim(phi_entry) == 0 and np.ndim(phi_exit) == 0:
        return directional_factors(phi_entry, phi_exit, kr)
    pe = np.broadcast_to(np.asarray(phi_entry, dtype=np.float64), (n,))
    px = np.broadcast_to(np.asarray(phi_exit, dtype=np.float64), (n,))
    e, x = pe[idx_b], px[idx_b]
    bad = ~(np.isfinite(e) & np.isfinite(x) & (e >= -1e-12) & (x <= math.pi + 1e-12) & (e < x))
    if np.any(bad):
        k = int(idx_b[int(np.argmax(bad))])
        raise InputError(
            f"phi_entry/phi_exit: expected 0 <= entry < exit <= pi at every bounded waypoint, "
            f"found {pe[k]!r}, {px[k]!r} at waypoint {k}"
        )
    alpha = np.zeros((n, 2, 2))
    alpha[idx_b] = directional_factors(e, x, kr)
    return alpha


def _leader_lobes(
    reps: ModalModel,
    zoa_args: dict[str, Any],
    *,
    max_lobe: int | None,
    jit: bool | None = None,
    idx: IntArray | None = None,
    single_from: int | None = None,
) -> LobeDiagram:
    """Converged ZOA lobes of a batch of leaders (:func:`robolobe.sld.converged.converged_lobes`).

    Each leader's frequency samples are its own (they depend on its dynamics,
    the cut and the speed range only, not on the other leaders). ``idx``: the
    leaders' waypoints, where the cut's factors are per waypoint;
    ``single_from``: as in ``converged_lobes``.
    """
    args = dict(zoa_args)
    alpha = args.pop("alpha")
    if np.ndim(alpha) == 3:
        assert idx is not None
        alpha = alpha[idx]
    return converged_lobes(reps, alpha, max_lobe=max_lobe, jit=jit, single_from=single_from, **args)


#: Polyline samples (groups x frequencies) from which a plan keeps its lobes' polylines
#: (frequencies, depths, phases) in single precision, stored so as they are made
#: (``converged_lobes``' ``single_from``), and without the trailing samples no group
#: uses (:func:`_compact_polylines`): 19,501 groups of a 1e6-waypoint path took 565 MB
#: in double precision, 664 samples wide.
COMPACT_MIN_SAMPLES = 4_000_000


def _compact_polylines(diagrams: list[LobeDiagram], j: int) -> None:
    """``diagrams[j]``'s polylines in single precision from :data:`COMPACT_MIN_SAMPLES` on.

    Polylines made in single precision (``converged_lobes``' ``single_from``:
    the grid limits ``a_lim`` are formed from the stored samples) only lose
    their trailing samples; others are converted, the grid limits kept. The
    exact queries read single-precision samples: frequencies, depths and
    phases to a relative 6e-8, so a limit moves by ~1e-7 of itself (against the
    lobes' stated 0.5 %). The trailing samples that no group uses (infinite depth
    on both branches in every row: no lobe piece) are dropped. One array at a
    time, each array freed before the next is made (the diagram is replaced in
    ``diagrams``), so this adds one array's single-precision copy to the peak.
    """
    d = diagrams[j]
    if d.omega is None or d.depth is None or d.eps is None or np.ndim(d.omega) != 2:
        return
    if d.omega.size < COMPACT_MIN_SAMPLES:
        return
    used = np.flatnonzero(np.isfinite(d.depth).any(axis=(0, 1)))
    k = max(int(used[-1]) + 1 if used.size else 2, 2)
    if d.depth.dtype == np.float32 and k == d.omega.shape[-1]:
        return
    for name in ("omega", "depth", "eps"):
        # single precision where LobeDiagram states double: its readers take either
        arr: Any = np.ascontiguousarray(getattr(diagrams[j], name)[..., :k], dtype=np.float32)
        diagrams[j] = dataclasses.replace(diagrams[j], **{name: arr})
        del arr


def _lobe_need(d: LobeDiagram, rpm_min: float) -> float:
    """Lobe count that reaches ``rpm_min`` from the diagram's highest live frequency."""
    assert d.depth is not None
    assert d.omega is not None
    return lobes_needed(d.omega, d.depth, teeth=d.teeth, rpm_min=rpm_min)


def _extend_diagrams(
    models: Sequence[ModalModel],
    reuse: GroupedLobes,
    leader: IntArray,
    zoa_args: dict[str, Any],
) -> list[list[LobeDiagram]]:
    """``reuse``'s lobes and those of the leaders after its groups, as parts.

    Returns ``[reuse's diagrams, the added leaders' diagrams]`` (one per
    scenario each; :func:`_joined` joins them), or one part when nothing was
    added or everything was computed afresh. Each leader's frequency samples
    are its own; the automatic lobe count is decided as
    :func:`robolobe.sld.zoa.zoa_lobes` decides it over the whole batch; where
    it differs from what ``reuse`` was computed with, everything is computed
    afresh.
    """
    new = leader[reuse.n_groups :]
    prev_all = list(reuse.diagrams)
    if new.size == 0:
        return [prev_all]
    rpm = np.asarray(zoa_args["rpm"], dtype=np.float64)
    r_min = float(rpm.min())
    cap = int(zoa_args["max_lobe_cap"])

    def afresh() -> list[list[LobeDiagram]]:
        return [
            [_leader_lobes(mm.take(leader), zoa_args, max_lobe=None, idx=leader) for mm in models]
        ]

    out = []
    for m, prev in zip(models, prev_all, strict=True):
        # the kernel or the numpy path as for the whole batch (they agree to rounding only)
        assert prev.omega is not None
        assert prev.complete_above_rpm is not None
        jit = _use_kernels(leader.size * prev.omega.shape[-1])
        extra = _leader_lobes(m.take(new), zoa_args, max_lobe=30, jit=jit, idx=new)
        assert extra.omega is not None
        assert extra.complete_above_rpm is not None
        trig = prev.max_lobe > 30 or bool(np.any(prev.complete_above_rpm > r_min))
        trig = trig or bool(np.any(extra.complete_above_rpm > r_min))
        k = 30
        if trig:
            need = max(_lobe_need(prev, r_min), _lobe_need(extra, r_min))
            k = int(min(max(need, 30), cap))
        if k != prev.max_lobe:
            return afresh()
        if k != 30:
            extra = _leader_lobes(m.take(new), zoa_args, max_lobe=k, jit=jit, idx=new)
        out.append(extra)
    return [prev_all, out]


def _joined(parts: list[LobeDiagram]) -> LobeDiagram:
    """Diagrams of consecutive batches (same speeds, lobe count, scenario) as one.

    Frequency rows of different lengths are padded as
    :func:`robolobe.sld.converged.converged_lobes` pads them: copies of the
    last sample, off every branch (no lobe piece: the same lobes).
    """
    if len(parts) == 1:
        return parts[0]
    nf = max(np.asarray(d.omega).shape[-1] for d in parts)

    def pad(x: FloatArray, fill: float | None) -> FloatArray:
        x = np.asarray(x)
        if x.shape[-1] == nf:
            return x
        more = np.repeat(x[..., -1:], nf - x.shape[-1], axis=-1)
        if fill is not None:
            more = np.full_like(more, fill)
        return np.concatenate([x, more], axis=-1)

    def cat(name: str) -> FloatArray:
        return np.concatenate([np.asarray(getattr(d, name)) for d in parts], axis=0)

    def cat_padded(name: str, fill: float | None) -> FloatArray:
        return np.concatenate([pad(getattr(d, name), fill) for d in parts], axis=0)

    return dataclasses.replace(
        parts[0],
        a_lim=cat("a_lim"),
        omega=cat_padded("omega", None),
        depth=cat_padded("depth", np.inf),
        eps=cat_padded("eps", np.nan),
        complete_above_rpm=cat("complete_above_rpm"),
    )


def _query_kernels(samples: int) -> ModuleType | None:
    """The compiled kernels for exact queries where :func:`zoa_lobes` takes them for the lobes.

    (The same threshold, so that numba's start-up is paid only where it pays.)
    """
    if not _use_kernels(samples):
        return None
    from robolobe.sld import _kernels

    return _kernels


def steep_members(
    grouped: GroupedLobes, rpm: FloatArray, *, shift: float = 0.005, ratio: float = 1.01
) -> NDArray[np.bool_]:
    """Waypoints that share lobes and run next to a steep wall of them.

    A member's own lobes are its leader's shifted a little in speed (its
    frequencies differ within the tolerance) and reshaped a little (its mode
    directions): where the leader's limit changes by more than ``ratio``
    within ``rpm (1 +- shift)``, a steep wall or cusp is near and the shared
    limit may be far from the member's own. Such members should get their
    own lobes (``waypoint_lobes(..., own=...)``).

    Parameters
    ----------
    grouped : GroupedLobes
    rpm : ndarray, shape (n_cut,)
        Planned speed of each cutting waypoint [rpm].
    shift : float
        Relative speed range examined.
    ratio : float
        Largest allowed max/min of the limit over that range.

    Returns
    -------
    ndarray of bool, shape (n_cut,)
    """
    tab = grouped.table
    g = tab.group
    n = g.size
    out = np.zeros(n, bool)
    lead = np.zeros(n, bool)
    lead[grouped.leader] = True
    cand = np.flatnonzero((g < grouped.n_groups) & ~lead)
    if cand.size == 0:
        return out
    t = np.linspace(-1.0, 1.0, 9)
    rpm = np.asarray(rpm, dtype=np.float64)
    # in blocks: the (n, 9) speeds and limits of a long path at once would add to its peak
    # memory (each row's limits are its own: the same values)
    for s in range(0, cand.size, _BLOCK):
        c = cand[s : s + _BLOCK]
        r = np.clip(rpm[c, None] * (1.0 + shift * t), tab.rpm[0], tab.rpm[-1])
        a = tab.rows(r, g[c])
        with np.errstate(invalid="ignore", divide="ignore"):
            var = np.max(a, axis=1) / np.min(a, axis=1)
        out[c] = ~(var <= ratio) & np.isfinite(np.min(a, axis=1))  # NaN (inf/inf): steep
    return out


#: Share of the lobe-sharing promise (:data:`LOBE_TOL`) a member's first-order estimate
#: of its own limit may lie below the shared one before it gets lobes of its own
#: (:func:`size_members`): half of it, the other half left to the estimate's own error
#: (second order in the size difference, ~2 % squared) and to the frequencies' tolerance.
SIZE_SHARE = LOBE_TOL / 2.0
#: The lowest stated limit over a waypoint's own that sharing may give (issue 25: not
#: needlessly conservative); :func:`size_members` flags estimates below it plus ``share``.
_LOW = 1.0 - 2.0 * LOBE_TOL
#: Lobe pieces within this factor of the envelope at a speed are compared
#: (:func:`size_members`): a member's own minimum may be another piece of the leader's
#: than the lowest when their depths are close and its sizes differ (2.1 % in a plan).
#: (5 %: three times the CPU time on the 10k zig-zag, whose robot modes' flat lobe
#: bottoms put ~190 pieces of a group within it.)
_NEAR_ENVELOPE = 1.025

#: A scenario's shared limit this far over the smallest of a member's scenarios cannot set
#: the member's own (its models within the grouping tolerance of its leader's: a few %):
#: where that scenario has no estimate of the member's (Newton not converged), the
#: member keeps the shared lobes (:func:`size_members`).
_NO_ESTIMATE_ABOVE = 1.1

#: Waypoints per block of :func:`size_members` (its temporaries: ~7 kB a member) and
#: the threads that take the blocks.
_CHECK_BLOCK = 8_192
_CHECK_THREADS = min(2, os.cpu_count() or 1)
#: Elements (rows x branches x frequencies) per block of :func:`_lobe_pieces_at`.
_PIECE_BLOCK = 1 << 22


def _lobe_pieces_at(
    d: LobeDiagram,
    g: IntArray,
    rpm: FloatArray,
    bound: FloatArray,
    within: float,
    *,
    compiled: bool = False,
) -> tuple[IntArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """The lobe pieces of entries ``g`` that cross speeds ``rpm`` near the envelope there.

    The argmin side of :func:`robolobe.sld.lobes.lobe_envelope` (the same
    pieces, straight in speed between two frequency samples, lobes ``0..K``):
    lobe ``k`` of the piece between samples ``i`` and ``i + 1`` of a branch
    crosses speed ``n`` where ``kappa = (60 w / (N n) - eps) / (2 pi)`` passes
    ``k`` between the two samples. Of each row's crossings, those whose depth
    is within ``within`` times the row's smallest. Only pieces whose lower end
    lies within ``within`` times the highest ``bound`` of the entry's rows are
    examined: where a row's smallest crossing is at most its ``bound``, the
    others cannot be near it.

    Parameters
    ----------
    d : LobeDiagram
        ZOA lobes with their polylines, batch (nb,).
    g : ndarray of int, shape (r,)
        Entry of each row.
    rpm : ndarray, shape (r,)
        One speed per row [rpm].
    bound : ndarray, shape (r,)
        Pieces above ``within`` times the highest of an entry's rows are not
        examined [m] (``inf``: all; NaN: the row is not examined).
    within : float
        Factor (>= 1) over the row's smallest crossing depth.
    compiled : bool
        With the compiled kernel (:func:`robolobe.sld._kernels.near_pieces`:
        the same pieces) where numba is available.

    Returns
    -------
    row : ndarray of int, shape (p,)
        Row of each piece kept.
    omega, depth, eps : ndarray, shape (p,)
        Its chatter frequency [rad/s], depth [m] and phase [rad] at the row's
        speed (linear along the piece).
    lobe : ndarray, shape (p,)
        Its lobe number ``k`` (float).
    span : ndarray, shape (p,)
        Its frequency span ``w[i + 1] - w[i]`` [rad/s].
    """
    assert d.omega is not None
    assert d.depth is not None
    assert d.eps is not None
    empty = np.zeros(0)
    fin = ~np.isnan(bound)
    if not np.any(fin):
        return np.zeros(0, np.int64), empty, empty, empty, empty, empty
    rows_all = np.flatnonzero(fin)
    gu, inv = np.unique(g[rows_all], return_inverse=True)
    inv = inv.ravel()
    top = np.zeros(gu.size)
    np.maximum.at(top, inv, bound[rows_all])
    w_all = np.asarray(d.omega)
    a_all = np.asarray(d.depth)
    e_all = np.asarray(d.eps)
    from robolobe import _jit

    if compiled and _jit.available():
        from robolobe.sld import _kernels

        w2 = w_all if w_all.ndim > 1 else np.tile(w_all, (a_all.shape[0], 1))
        p = _kernels.near_pieces(
            w2, a_all, e_all, g[rows_all], rpm[rows_all], top[inv],
            within=within, teeth=d.teeth, max_lobe=d.max_lobe,
        )  # fmt: skip
        return (rows_all[p[:, 0].astype(np.int64)], p[:, 1], p[:, 2], p[:, 3], p[:, 4], p[:, 5])
    a = a_all[gu]  # (G, 2, nf)
    with np.errstate(invalid="ignore"):
        amin = np.minimum(a[..., :-1], a[..., 1:])  # inf/NaN ends: never kept
        keep = amin <= within * top[:, None, None]
    pg, pj, pi = np.nonzero(keep)  # pieces, sorted by entry
    cnt_g = np.bincount(pg, minlength=gu.size)
    start_g = np.cumsum(cnt_g) - cnt_g
    # every row with each piece of its entry
    cnt_r = cnt_g[inv]
    rr = np.repeat(np.arange(rows_all.size), cnt_r)
    pp = np.arange(rr.size) - np.repeat(np.cumsum(cnt_r) - cnt_r, cnt_r) + start_g[inv[rr]]
    ge = gu[pg[pp]]
    j, i = pj[pp], pi[pp]
    w0 = w_all[ge, i] if w_all.ndim > 1 else w_all[i]
    w1 = w_all[ge, i + 1] if w_all.ndim > 1 else w_all[i + 1]
    e0, e1 = e_all[ge, j, i], e_all[ge, j, i + 1]
    a0, a1 = a_all[ge, j, i], a_all[ge, j, i + 1]
    c = 60.0 / d.teeth
    nb = rpm[rows_all[rr]]
    k0 = (c * w0 / nb - e0) / (2.0 * math.pi)
    k1 = (c * w1 / nb - e1) / (2.0 * math.pi)
    klo = np.maximum(np.ceil(np.minimum(k0, k1)), 0.0)
    khi = np.minimum(np.floor(np.maximum(k0, k1)), float(d.max_lobe))
    span = khi - klo + 1.0
    cnt = np.where(np.isfinite(span) & (span > 0), span, 0.0).astype(np.int64)
    live = np.flatnonzero(cnt)
    rep = np.repeat(live, cnt[live])
    kk = klo[rep] + (np.arange(rep.size) - np.repeat(np.cumsum(cnt[live]) - cnt[live], cnt[live]))
    w0, w1, e0, e1, a0, a1, nb = (x[rep] for x in (w0, w1, e0, e1, a0, a1, nb))
    row = rows_all[rr[rep]]
    with np.errstate(divide="ignore", invalid="ignore"):
        n0 = c * w0 / (e0 + 2.0 * math.pi * kk)
        n1 = c * w1 / (e1 + 2.0 * math.pi * kk)
        t = np.clip(np.where(n1 != n0, (nb - n0) / (n1 - n0), 0.0), 0.0, 1.0)
    good = np.isfinite(n0) & np.isfinite(n1) & (n0 > 0) & (n1 > 0)
    depth = np.maximum(a0 + t * (a1 - a0), np.minimum(a0, a1))
    low = np.full(rpm.size, np.inf)
    np.minimum.at(low, row[good], depth[good])
    near = good & (depth <= low[row] * within)
    om = w0 + t * (w1 - w0)
    ph = e0 + t * (e1 - e0)
    span = np.asarray(w1 - w0, dtype=np.float64)
    return (
        np.asarray(row[near], np.int64),
        om[near],
        np.asarray(depth[near], np.float64),
        ph[near],
        np.asarray(kk[near], np.float64),
        span[near],
    )


def _zoa_mu(model: ModalModel, alpha: FloatArray, omega: FloatArray) -> ComplexArray:
    """Both eigenvalues of ``alpha G(w)`` of each batch entry at its own frequency.

    ``model`` batch (p,), ``alpha`` (p, 2, 2), ``omega`` (p,): returns (p, 2) [m/N].
    """
    from robolobe.sld.zoa import zoa_eigenvalues

    frf = model.frf(omega[:, None])  # (p, 1, 2, 2)
    return zoa_eigenvalues(frf, alpha, track=False)[:, :, 0]


def _lobe_depth(
    model: ModalModel,
    alpha: FloatArray,
    omega: FloatArray,
    mu0: ComplexArray,
    lobe: tuple[FloatArray, FloatArray, FloatArray],
    teeth: int,
    kt: float,
    steps: int = 4,
    more: int = 4,
) -> FloatArray:
    """Depth of one lobe of each entry at one speed, from its own model (Newton in frequency).

    The lobe ``k`` crosses the speed ``n`` where ``c w / n = eps(w) + 2 pi k``
    (``c = 60 / N``); from ``omega`` (p,) [rad/s], the eigenvalue followed
    from ``mu0`` (p,) (the nearest at each step), ``steps`` Newton steps
    (the phase's slope by a difference), each at most the piece's ``span``;
    the entries that have not met the phase condition then go on for up to
    ``more`` steps. ``lobe``: (k, c / n [rad^-1 s], span [rad/s]), each (p,).
    Returns the depth ``2 pi / (N Kt Re mu)`` there [m] (``inf`` where
    ``Re mu <= 0``: no such lobe; 0 where the phase condition is not met to
    1e-6 rad after the steps. On the 10k zig-zag 3 steps meet it everywhere,
    to 1e-12 in the depth; 2 steps leave up to 18 %. In a robust plan's
    lowered scenarios the k = 0 tails of its 7-11 Hz modes near 24,000 rpm,
    whose pieces span 0.001-0.013 Hz, need 5-6 steps: 4 left 40 members of
    the 10k zig-zag without an estimate, on lobes of their own).
    """
    kk, c_n, span = lobe
    w = np.asarray(omega, dtype=np.float64).copy()
    mu = np.asarray(mu0)
    ar = np.arange(w.size)
    h = 1e-7

    def pick(ww: FloatArray, prev: ComplexArray) -> ComplexArray:
        both = _zoa_mu(model, alpha, ww)
        return both[ar, np.argmin(np.abs(both - prev[:, None]), axis=1)]

    def phase(m: ComplexArray) -> FloatArray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.pi + 2.0 * np.arctan(m.imag / m.real)

    for _ in range(steps):
        mu = pick(w, mu)
        mu_h = pick(w * (1.0 + h), mu)
        f = c_n * w - 2.0 * math.pi * kk - phase(mu)
        fp = c_n - (phase(mu_h) - phase(mu)) / (w * h)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.clip(np.nan_to_num(-f / fp), -span, span)
        w = np.maximum(w + step, 1e-3 * np.abs(w))
    mu = pick(w, mu)
    # not converged (the phase condition missed by more than 1e-6 rad): no estimate, 0 (the
    # caller then gives the member lobes of its own: never a silent overstatement)
    miss = ~(np.abs(c_n * w - 2.0 * math.pi * kk - phase(mu)) <= 1e-6)
    with np.errstate(divide="ignore"):
        a = np.where(mu.real > 0, 2.0 * math.pi / (teeth * kt * mu.real), np.inf)
    a = np.where(miss & (mu.real > 0), 0.0, a)
    if more > 0 and np.any(miss):
        # the missed entries go on from where they are (a few: not every entry's steps)
        m = np.flatnonzero(miss)
        a[m] = _lobe_depth(
            model.take(m), alpha[m], w[m], mu[m], (kk[m], c_n[m], span[m]), teeth, kt, more, 0
        )
    return a


def size_members(
    grouped: GroupedLobes,
    model: ModalModel | Sequence[ModalModel],
    rpm: FloatArray,
    *,
    teeth: int,
    kt: float,
    kr: float,
    phi_entry: float | FloatArray,
    phi_exit: float | FloatArray,
    share: float = SIZE_SHARE,
) -> NDArray[np.bool_]:
    """Members whose own limit at their planned speed lies outside the promise of the shared one.

    A member shares its leader's lobes where their modal models agree to the
    grouping tolerance; a dominant mode's size (2.1 % in a plan) moves the
    limit it sets by as much, which the promise (:data:`LOBE_TOL`) does not
    allow. At each member's planned speed the leader's lobe pieces near the
    envelope there (:func:`_lobe_pieces_at`: the chatter frequencies ``w``
    that set it, within :data:`_NEAR_ENVELOPE`) are re-evaluated with the
    member's own model and cut: the depth of a piece goes as one over
    ``Re mu(w)`` (the ZOA, :func:`robolobe.sld.zoa.zoa_depth`), so the member's
    estimate is ``min over pieces of depth * a_member / a_leader``, where ``a``
    is each one's own depth of that lobe at the planned speed (:func:`_lobe_depth`:
    Newton in frequency on the phase condition from the piece's frequency and
    eigenvalue; the leader's once per piece of its group and speed). An estimate
    not converged to 1e-6 rad counts as 0 (its own lobes). Members whose
    estimate lies below the shared limit by more than ``share`` (or above it by
    more than ``1 / (0.99 + share)``: the limit stated must not be needlessly
    low either, :data:`_LOW`) should get lobes of their own
    (``waypoint_lobes(..., own=...)``, as :func:`steep_members`). Members are
    taken in blocks of waypoints on up to :data:`_CHECK_THREADS` threads.
    With one model per scenario (a robust plan's), each scenario's lobes are
    re-evaluated with each member's own model of that scenario, and the shared
    limit and the estimate are each the smallest over the scenarios (the
    limit the plan states, and the member's own): the scenarios lower each
    waypoint by the spread at its own posture, so a member's ratio to its
    leader in a scenario is not the nominal's (the speed windows are not
    searched: each scenario at the planned speed).

    Parameters
    ----------
    grouped : GroupedLobes
    model : ModalModel or sequence of ModalModel
        Feed-frame tool-point models of the cutting waypoints, batch (n_cut,):
        the nominal's (or an object with ``take``: the leaders' are taken; with
        ``block_models(lo, hi)`` and ``block_rows`` too, the members' come from
        it in blocks of ``block_rows`` waypoints starting at its multiples), or
        one per scenario of ``grouped`` in its order (nominal first, as given
        to :func:`waypoint_lobes`).
    rpm : ndarray, shape (n_cut,)
        Planned speed of each cutting waypoint [rpm].
    teeth, kt, kr : int, float, float
        Flutes, Kt [N/m^2], Kn/Kt.
    phi_entry, phi_exit : float or ndarray, shape (n_cut,)
        Engagement angles [rad] (as given to :func:`waypoint_lobes`).
    share : float
        Allowed relative shortfall of the estimate (default :data:`SIZE_SHARE`).

    Returns
    -------
    ndarray of bool, shape (n_cut,)
    """
    shared, own_est = _size_estimates(
        grouped, model, rpm, teeth=teeth, kt=kt, kr=kr, phi_entry=phi_entry, phi_exit=phi_exit
    )
    # too high (the promise) or needlessly low (below 1 - 2 LOBE_TOL = 0.99 of its own)
    return (own_est * (1.0 + share) < shared) | (shared < own_est * (_LOW + share))


def _size_estimates(
    grouped: GroupedLobes,
    model: ModalModel | Sequence[ModalModel],
    rpm: FloatArray,
    *,
    teeth: int,
    kt: float,
    kr: float,
    phi_entry: float | FloatArray,
    phi_exit: float | FloatArray,
) -> tuple[FloatArray, FloatArray]:
    """The shared limit and the estimate of each member's own (:func:`size_members`).

    With one model per scenario (a sequence), both are the smallest over the
    scenarios. Returns two arrays (n_cut,) [m]; ``inf`` in both where not
    estimated (leaders, unbounded waypoints, speeds no lobe crosses).
    """
    tab = grouped.table
    g = tab.group
    n = g.size
    shared_out = np.full(n, np.inf)
    est_out = np.full(n, np.inf)
    lead = np.zeros(n, bool)
    lead[grouped.leader] = True
    cand = np.flatnonzero((g < grouped.n_groups) & ~lead)
    if cand.size == 0 or not grouped.parts:
        return shared_out, est_out
    # one per scenario; or the nominal only (a ModalModel, or a streamed path's blocks)
    models: list[Any] = list(model) if isinstance(model, (list, tuple)) else [model]
    if len(models) > 1 and len(models) != len(grouped.parts[0]):
        raise InputError(
            f"model: expected one model per scenario of the lobes ({len(grouped.parts[0])}), "
            f"found {len(models)}"
        )
    diagrams = grouped.diagrams[: len(models)]
    if any(d.omega is None or d.depth is None or d.eps is None for d in diagrams):
        return shared_out, est_out
    rpm = np.asarray(rpm, dtype=np.float64)
    compiled = grouped.query_compiled  # where the plan's lobes run compiled (numba started)
    # the leaders' models once (a streamed path makes them again from their exact modes,
    # as its lobes did); the members' a block of waypoints at a time: where the model
    # offers ``block_models(lo, hi)`` (a streamed path's: its blocks of ``block_rows``
    # waypoints made again from their modes as the streamed pass made them, bit for
    # bit), from it; else taken
    leaders = [m.take(grouped.leader) for m in models]
    block_models = getattr(models[0], "block_models", None) if len(models) == 1 else None
    rows_per_block = int(getattr(models[0], "block_rows", _CHECK_BLOCK))
    if np.ndim(phi_entry) == 0 and np.ndim(phi_exit) == 0:
        alpha_one: FloatArray | None = directional_factors(phi_entry, phi_exit, kr)
        pe = px = np.zeros(0)
    else:  # each waypoint's own engagement (finite where bounded: members and leaders)
        alpha_one = None
        pe = np.broadcast_to(np.asarray(phi_entry, dtype=np.float64), (n,))
        px = np.broadcast_to(np.asarray(phi_exit, dtype=np.float64), (n,))

    def block(r0: int) -> None:
        r1 = min(n, r0 + rows_per_block)
        c = cand[np.searchsorted(cand, r0) : np.searchsorted(cand, r1)]
        if c.size == 0:
            return
        # members of one group at one speed: the same pieces (most of a path's members)
        key = np.stack([g[c].astype(np.float64), rpm[c]], axis=1)
        _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
        inv = inv.ravel()
        gu, nu = g[c][first], rpm[c][first]

        def from_block(rows: IntArray) -> ModalModel:
            assert block_models is not None
            return block_models(r0, r1).take(rows - r0)

        # each scenario's shared limit and own estimate; the smallest over them (a robust
        # plan's scenarios lower each waypoint by its own spread: a member's ratio to its
        # leader is not the nominal's there)
        per = [
            _scenario_estimates(
                d,
                leaders[j],
                models[j].take if block_models is None else from_block,
                grouped.leader,
                c,
                inv,
                gu,
                nu,
                teeth=teeth,
                kt=kt,
                kr=kr,
                alpha_one=alpha_one,
                pe=pe,
                px=px,
                compiled=compiled,
            )
            for j, d in enumerate(diagrams)
        ]
        shared = np.min([np.where(np.isfinite(e), s, np.inf) for s, e in per], axis=0)
        # a scenario without an estimate (0) far above the smallest shared limit cannot
        # set the member's own: not a reason for lobes of its own
        far = [(e == 0.0) & (s > _NO_ESTIMATE_ABOVE * shared) for s, e in per]
        est = np.min([np.where(f, np.inf, e) for (_, e), f in zip(per, far, strict=True)], axis=0)
        shared_out[c] = np.where(np.isfinite(est), shared, np.inf)
        est_out[c] = est

    each_on_threads(block, range(0, n, rows_per_block), _CHECK_THREADS)  # disjoint rows
    return shared_out, est_out


def _scenario_estimates(
    d: LobeDiagram,
    leaders: ModalModel,
    members: Callable[[IntArray], ModalModel],
    leader: IntArray,
    c: IntArray,
    inv: IntArray,
    gu: IntArray,
    nu: FloatArray,
    *,
    teeth: int,
    kt: float,
    kr: float,
    alpha_one: FloatArray | None,
    pe: FloatArray,
    px: FloatArray,
    compiled: bool,
) -> tuple[FloatArray, FloatArray]:
    """One scenario's shared limit and member estimates of a block (:func:`_size_estimates`).

    ``d``: the scenario's lobes (batch n_groups); ``leaders``: its models of the
    group leaders (batch n_groups); ``members(rows)``: its models of cutting
    waypoints ``rows``; ``leader``: each group's leader; ``c`` (b,): the
    block's members, ``inv`` (b,): each one's (group, speed) pair among ``gu``,
    ``nu`` (u,). Returns the shared limit (the leader's pieces near the envelope
    there) and the estimate of each member's own, each (b,) [m] (``inf`` where
    no piece crosses the speed).
    """
    env = np.full(c.size, np.inf)
    own_est = np.full(c.size, np.inf)
    # an upper bound of the envelope to examine fewer pieces: the scenario grid's at the
    # neighbouring grid speeds (the rows it does not bound are done again without it)
    j = np.clip(np.searchsorted(d.rpm, nu) - 1, 0, d.rpm.size - 2)
    top = np.maximum(d.a_lim[gu, j], d.a_lim[gu, j + 1]) * (1.0 + 1e-3)
    pieces: tuple[Any, ...] = _lobe_pieces_at(d, gu, nu, top, _NEAR_ENVELOPE, compiled=compiled)
    low = np.full(gu.size, np.inf)
    np.minimum.at(low, pieces[0], pieces[2])
    redo = np.flatnonzero(~(low <= top))
    if redo.size:
        more = _lobe_pieces_at(d, gu[redo], nu[redo], np.full(redo.size, np.inf), _NEAR_ENVELOPE)
        keep = ~np.isin(pieces[0], redo)
        pieces = tuple(
            np.concatenate([p[keep], m if i else redo[m]])
            for i, (p, m) in enumerate(zip(pieces, more, strict=True))
        )
    # each member with the pieces of its group and speed
    order = np.argsort(pieces[0], kind="stable")
    pieces = tuple(p[order] for p in pieces)
    n_p = np.bincount(pieces[0], minlength=gu.size)
    at = np.cumsum(n_p) - n_p
    cnt = n_p[inv]
    row = np.repeat(np.arange(c.size), cnt)
    sel = np.arange(row.size) - np.repeat(np.cumsum(cnt) - cnt, cnt) + at[inv[row]]
    np.minimum.at(env, row, pieces[2][sel])
    if row.size == 0:
        return env, own_est
    # the leader's own depth of each piece: once per piece (its group's and speed's
    # members share it), from the leader's eigenvalue of the piece: the one nearest
    # the piece's own (its depth and phase, zoa_depth inverted: both branches can
    # have about one depth)
    pk, om, depth, eps, kk, span = pieces
    mem = c[row]
    g_p = gu[pk]
    lead_p = leader[g_p]
    re_p = 2.0 * math.pi / (teeth * kt * depth)
    mu_p = re_p + 1j * re_p * np.tan(0.5 * (eps - math.pi))
    if alpha_one is not None:
        alpha_p = np.broadcast_to(alpha_one, (pk.size, 2, 2))
        alpha_m = np.broadcast_to(alpha_one, (row.size, 2, 2))
    else:
        alpha_p = directional_factors(pe[lead_p], px[lead_p], kr)
        alpha_m = directional_factors(pe[mem], px[mem], kr)
    lobe_p = (kk, 60.0 / (teeth * nu[pk]), span)
    a_l = _lobe_depth(leaders.take(g_p), alpha_p, om, mu_p, lobe_p, teeth, kt)[sel]
    lobe = (kk[sel], lobe_p[1][sel], span[sel])
    a_m = _lobe_depth(members(mem), alpha_m, om[sel], mu_p[sel], lobe, teeth, kt)
    # where Newton left the leader's own piece for no lobe (Re mu <= 0: the k = 0 tails of
    # 7-10 Hz modes near 24,000 rpm in a robust plan's mode-shift scenarios, a few pieces
    # of the 10k zig-zag), the piece's own depth stands for it: the member's estimate is
    # then its own depth of the lobe (a_m, converged)
    a_l = np.where(np.isinf(a_l), depth[sel], a_l)
    with np.errstate(divide="ignore", invalid="ignore"):
        # where the leader's own depth of the piece is not found: no estimate (0: its own)
        est = np.where(np.isfinite(a_l) & (a_l > 0), depth[sel] * a_m / a_l, 0.0)
    np.minimum.at(own_est, row, est)
    return env, own_est
