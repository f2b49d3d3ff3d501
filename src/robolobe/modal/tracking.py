"""Mode tracking across postures: consistent mode identities over a campaign.

One triaxial sensor gives 3-component shapes, so MAC alone is ambiguous
(docs/references.md: modal identification). Modes are paired on frequency, damping, shape and
residue (shape amplitude) together, with an assignment step:

1. Postures are linked by a minimum spanning tree of their distances: the
   distance of their sets of natural frequencies (:func:`spectral_distances`)
   plus a small multiple of the joint-space distance; the tree is walked
   breadth-first from the posture with the most modes, so each posture is
   compared with a posture of similar dynamics.
2. At each posture the modes are assigned to the tracks known at its parent
   (the track's latest state along the path to the root, plus tracks
   started elsewhere) by an order-preserving alignment with gaps (a mode
   hidden at one posture leaves a gap, modes do not swap; or, optionally,
   by the project's gated assignment :func:`robolobe._matching.match_modes`) on

       c = (ln(f_i / f_t) / f_scale)^2 + (ln(zeta_i / zeta_t) / zeta_scale)^2
           + ((1 - MAC(u_i, u_t)) / mac_scale)^2 + (ln(|u_i| / |u_t|) / amp_scale)^2

   with pairs above ``gate`` forbidden; unassigned modes start new tracks.

The MAC uses signed shapes when both postures have them (full 3x3 FRF
matrix) and shape magnitudes otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree
from scipy.spatial.distance import cdist

from robolobe._matching import match_modes
from robolobe.campaign.metrics import mac
from robolobe.errors import InputError

__all__ = [
    "ModeTracks",
    "TrackingSettings",
    "posture_distances",
    "spectral_distances",
    "track_modes",
]


@dataclass(frozen=True, kw_only=True)
class TrackingSettings:
    """Cost scales of the assignment (each term costs 1 at its scale).

    Parameters
    ----------
    f_scale : float
        Relative frequency change between neighbouring postures.
    zeta_scale : float
        Change of ``ln zeta``.
    mac_scale : float
        ``1 - MAC``.
    amp_scale : float
        Change of the log shape amplitude (the residue scale).
    gate : float
        Largest admissible cost of a pair.
    joint_weight : float
        Weight of the joint-space distance (rad) added to the spectral
        distance when linking postures.
    order_preserving : bool
        Pair modes by an order-preserving alignment (modes keep their
        frequency order between neighbouring postures, gaps allowed for
        hidden modes) instead of a free assignment.
    gap_cost : float
        Cost of leaving a mode or a track unpaired in the alignment.
    """

    f_scale: float = 0.15
    zeta_scale: float = 0.7
    mac_scale: float = 0.5
    amp_scale: float = 1.5
    gate: float = 16.0
    joint_weight: float = 0.01
    order_preserving: bool = True
    gap_cost: float = 4.0

    def __post_init__(self) -> None:
        for name in (
            "f_scale",
            "zeta_scale",
            "mac_scale",
            "amp_scale",
            "gate",
            "joint_weight",
            "gap_cost",
        ):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and v > 0):
                raise InputError(
                    f"expected a positive number, found {v!r}", source=f"TrackingSettings.{name}"
                )


@dataclass(frozen=True)
class ModeTracks:
    """Track label of every mode of every posture.

    Attributes
    ----------
    labels : tuple of ndarray of int
        ``labels[p][i]`` is the track of mode ``i`` of posture ``p``.
    n_tracks : int
    order : ndarray of int, shape (n_postures,)
        Breadth-first visiting order of the postures.
    parent : ndarray of int, shape (n_postures,)
        Parent of each posture in the spanning tree (-1 for the root).
    """

    labels: tuple[NDArray[np.int64], ...]
    n_tracks: int
    order: NDArray[np.int64]
    parent: NDArray[np.int64]

    def members(self, track: int) -> list[tuple[int, int]]:
        """(posture index, mode index) pairs of a track."""
        return [
            (p, int(i)) for p, lab in enumerate(self.labels) for i in np.flatnonzero(lab == track)
        ]

    def mode_of(self, posture: int, track: int) -> int | None:
        """Mode index of ``track`` at ``posture`` or None."""
        hit = np.flatnonzero(self.labels[posture] == track)
        return int(hit[0]) if hit.size else None


def posture_distances(q_rad: ArrayLike) -> NDArray[np.float64]:
    """Joint-space distances between postures (Euclidean, rad), shape (n, n)."""
    q = np.asarray(q_rad, dtype=float)
    return np.asarray(cdist(q, q), dtype=float)


def spectral_distances(f_hz: Sequence[ArrayLike]) -> NDArray[np.float64]:
    """Distances between postures' sets of natural frequencies, shape (n, n).

    Symmetric Chamfer distance of the log frequencies (mean distance of each
    mode to the nearest mode of the other posture, both ways) plus 0.05 per
    mode of difference in count. Postures with similar spectra are near,
    whatever their joint angles (hammer-test designs are sparse: neighbours
    are often more than 1 rad apart in joint space).
    """
    n = len(f_hz)
    m = max((np.asarray(x).size for x in f_hz), default=0)
    if n == 0 or m == 0:
        return np.zeros((n, n))
    L = np.full((n, m), np.nan)
    cnt = np.zeros(n)
    for i, x in enumerate(f_hz):
        a = np.log(np.asarray(x, dtype=float).reshape(-1))
        L[i, : a.size] = a
        cnt[i] = a.size
    diff = np.abs(L[:, None, :, None] - L[None, :, None, :])  # (n, n, m, m)
    diff = np.where(np.isnan(diff), np.inf, diff)
    a_to_b = np.min(diff, axis=3)  # (n, n, m): each mode of i to nearest of j
    b_to_a = np.min(diff, axis=2)
    valid_a = ~np.isnan(L)[:, None, :]
    valid_b = ~np.isnan(L)[None, :, :]
    with np.errstate(invalid="ignore"):
        ma = np.sum(np.where(valid_a & np.isfinite(a_to_b), a_to_b, 0.0), axis=2) / np.maximum(
            cnt[:, None], 1
        )
        mb = np.sum(np.where(valid_b & np.isfinite(b_to_a), b_to_a, 0.0), axis=2) / np.maximum(
            cnt[None, :], 1
        )
    d = ma + mb + 0.05 * np.abs(cnt[:, None] - cnt[None, :])
    empty = (cnt[:, None] == 0) | (cnt[None, :] == 0)
    d = np.where(empty, 1.0, d)
    np.fill_diagonal(d, 0.0)
    return np.asarray(d, dtype=float)


def _cost(
    f: NDArray,
    z: NDArray,
    u: NDArray,
    signed: bool,
    tf: NDArray,
    tz: NDArray,
    tu: NDArray,
    tsigned: NDArray,
    s: TrackingSettings,
) -> NDArray[np.float64]:
    cf = (np.log(f[:, None] / tf[None, :]) / s.f_scale) ** 2
    cz = (np.log(z[:, None] / tz[None, :]) / s.zeta_scale) ** 2
    both = signed & tsigned[None, :]
    a = u[:, None, :]
    b = tu[None, :, :]
    m_signed = mac(a, b)
    m_abs = mac(np.abs(a), np.abs(b))
    m = np.where(both, m_signed, m_abs)
    cm = ((1.0 - np.nan_to_num(m, nan=0.0)) / s.mac_scale) ** 2
    na = np.linalg.norm(u, axis=1)[:, None]
    nb = np.linalg.norm(tu, axis=1)[None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        ca = (np.log(na / nb) / s.amp_scale) ** 2
    ca = np.nan_to_num(ca, nan=s.gate, posinf=s.gate)
    return np.asarray(cf + cz + cm + ca, dtype=float)


def _align(cost: NDArray[np.float64], gap: float, big: float) -> list[tuple[int, int]]:
    """Order-preserving pairing of two sorted sequences (alignment with gaps).

    Minimizes the sum of the costs of the pairs plus ``gap`` for every
    element left unpaired (Needleman-Wunsch); pairs of cost ``>= big`` are
    not allowed. Not :func:`robolobe._matching.match_modes` on purpose: the
    pairs may not cross (modes keep their frequency order between
    neighbouring postures), and leaving a mode unpaired has a price, so a
    poor pair can lose to two gaps.
    """
    n, m = cost.shape
    D = np.zeros((n + 1, m + 1))
    D[:, 0] = gap * np.arange(n + 1)
    D[0, :] = gap * np.arange(m + 1)
    move = np.zeros((n + 1, m + 1), dtype=np.int8)  # 0 pair, 1 skip mode, 2 skip track
    move[1:, 0] = 1
    move[0, 1:] = 2
    for i in range(1, n + 1):
        for j in range(1, m + 1):
            c = cost[i - 1, j - 1]
            best = D[i - 1, j - 1] + c if c < big else np.inf
            mv = 0
            if D[i - 1, j] + gap < best:
                best, mv = D[i - 1, j] + gap, 1
            if D[i, j - 1] + gap < best:
                best, mv = D[i, j - 1] + gap, 2
            D[i, j] = best
            move[i, j] = mv
    pairs = []
    i, j = n, m
    while i > 0 and j > 0:
        if move[i, j] == 0:
            pairs.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        elif move[i, j] == 1:
            i -= 1
        else:
            j -= 1
    return pairs[::-1]


def track_modes(
    f_hz: Sequence[ArrayLike],
    zeta: Sequence[ArrayLike],
    shapes: Sequence[ArrayLike],
    signed: Sequence[bool],
    q_rad: ArrayLike,
    *,
    settings: TrackingSettings | None = None,
) -> ModeTracks:
    """Assign the modes of all postures to tracks.

    Parameters
    ----------
    f_hz, zeta : sequence (n_postures) of array_like, shape (n_modes_p,)
        Natural frequencies (Hz) and damping ratios per posture.
    shapes : sequence of array_like, shape (n_modes_p, 3)
        TCP shapes per posture.
    signed : sequence of bool
        Whether a posture's shapes carry signs.
    q_rad : array_like, shape (n_postures, 6)
        Joint angles, rad.
    settings : TrackingSettings, optional

    Returns
    -------
    ModeTracks
    """
    s = settings if settings is not None else TrackingSettings()
    n = len(f_hz)
    q = np.asarray(q_rad, dtype=float)
    if q.shape[0] != n or not (len(zeta) == len(shapes) == len(signed) == n):
        raise InputError(
            f"expected {n} postures in every argument, found q_rad {q.shape}",
            source="track_modes",
        )
    F = [np.asarray(x, dtype=float).reshape(-1) for x in f_hz]
    Z = [np.clip(np.asarray(x, dtype=float).reshape(-1), 1e-6, None) for x in zeta]
    U = [np.asarray(x, dtype=float).reshape(-1, 3) for x in shapes]
    labels = [np.full(x.size, -1, dtype=np.int64) for x in F]
    parent = np.full(n, -1, dtype=np.int64)
    if n == 0:
        return ModeTracks((), 0, np.zeros(0, np.int64), parent)
    # neighbours by spectrum, joint distance as a tie-breaker
    d = spectral_distances(F) + s.joint_weight * posture_distances(q)
    # tiny offset so that identical postures stay connected
    tree = minimum_spanning_tree(d + 1e-9 * (1 - np.eye(n)))
    sym = tree + tree.T
    root = int(np.argmax([x.size for x in F]))
    order_list: list[int] = []
    seen = np.zeros(n, bool)
    # walk every connected component (identical postures form one tree anyway)
    for start in [root, *range(n)]:
        if seen[start]:
            continue
        ords, preds = breadth_first_order(sym, start, directed=False, return_predecessors=True)
        for p in ords:
            if not seen[p]:
                seen[p] = True
                order_list.append(int(p))
                parent[p] = preds[p] if preds[p] >= 0 else -1
    order = np.asarray(order_list, dtype=np.int64)

    # track state: f, zeta, u, signed; per posture a dict track -> state source (posture, mode)
    state: dict[int, dict[int, tuple[int, int]]] = {}
    latest: dict[int, tuple[int, int]] = {}  # global most recent occurrence of each track
    n_tracks = 0
    for p in order:
        par = int(parent[p])
        known = dict(state[par]) if par >= 0 else {}
        for t, src in latest.items():
            known.setdefault(t, src)
        tracks = sorted(known)
        if F[p].size and tracks:
            tf = np.array([F[known[t][0]][known[t][1]] for t in tracks])
            tz = np.array([Z[known[t][0]][known[t][1]] for t in tracks])
            tu = np.array([U[known[t][0]][known[t][1]] for t in tracks]).reshape(-1, 3)
            ts = np.array([bool(signed[known[t][0]]) for t in tracks])
            # tracks seen on the path to the root are preferred over ones from elsewhere
            local = np.array([par >= 0 and t in state[par] for t in tracks])
            c = _cost(F[p], Z[p], U[p], bool(signed[p]), tf, tz, tu, ts, s)
            c = c + np.where(local, 0.0, 1.0)[None, :]
            big = 1e6
            cc = np.where(c <= s.gate, c, big)
            if s.order_preserving:
                oi = np.argsort(F[p], kind="stable")
                ot = np.argsort(tf, kind="stable")
                pairs = _align(cc[np.ix_(oi, ot)], s.gap_cost, big)
                pairs = [(int(oi[a]), int(ot[b])) for a, b in pairs]
            else:
                rows, cols = match_modes(c, gate=s.gate)
                pairs = [(int(r), int(col)) for r, col in zip(rows, cols, strict=True)]
            for r, col in pairs:
                labels[p][r] = tracks[col]
        for j in np.flatnonzero(labels[p] < 0).tolist():
            labels[p][j] = n_tracks
            n_tracks += 1
        st = dict(state[par]) if par >= 0 else {}
        for i, t in enumerate(labels[p].tolist()):
            st[int(t)] = (int(p), int(i))
            latest[int(t)] = (int(p), int(i))
        state[int(p)] = st
    return ModeTracks(tuple(labels), n_tracks, order, parent)
