"""Automatic selection of physical poles by clustering the stabilization diagram.

Following Reynders, Houbrechts and De Roeck (2012), "Fully automated
(operational) modal analysis", Mech. Syst. Signal Process. 29:

1. Poles that are certainly mathematical are removed: outside the hard
   limits, or not stable in frequency *and* in damping or shape with the
   previous order.
2. The remaining poles are grouped by hierarchical clustering (average
   linkage) with the distance
   ``d_ij = |lambda_i - lambda_j| / max(|lambda_i|, |lambda_j|) + 1 - MAC_ij``,
   cut at ``d_max``. A cluster holding two poles of the same order in more
   than a quarter of its orders is split again with half the threshold
   (close modes, as on the seed's Comau robot).
3. Clusters that gather poles from at least ``min_orders_fraction`` of the
   orders are physical; each is represented by the median frequency and the
   median damping of its members (and the member vector nearest to them).

No nearest-pole picking: with close modes that picks wrong poles
(docs/references.md: modal identification).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.cluster.hierarchy import fcluster, linkage
from scipy.spatial.distance import squareform

from robolobe.campaign.metrics import mac_matrix
from robolobe.errors import InputError
from robolobe.modal.stabilization import StabilizationDiagram
from robolobe.modal.synthesis import modal_to_poles

__all__ = ["SelectedPoles", "SelectionSettings", "select_poles"]


@dataclass(frozen=True, kw_only=True)
class SelectionSettings:
    """Parameters of the clustering selection.

    Parameters
    ----------
    d_max : float
        Cut-off of the pole distance (relative pole distance + 1 - MAC).
    min_orders_fraction : float
        A cluster is physical when it holds poles from at least this fraction
        of the model orders of the diagram.
    min_orders : int
        ... and from at least this many orders.
    require : {"f+any", "all", "f"}
        Stability flags a pole needs to enter the clustering: frequency and
        (damping or shape), all three, or frequency only.
    """

    d_max: float = 0.04
    min_orders_fraction: float = 0.3
    min_orders: int = 3
    require: str = "f+any"

    def __post_init__(self) -> None:
        if not 0 < self.d_max < 2:
            raise InputError(f"expected 0 < d_max < 2, found {self.d_max!r}", "SelectionSettings")
        if not 0 <= self.min_orders_fraction <= 1:
            raise InputError(
                f"expected 0 <= min_orders_fraction <= 1, found {self.min_orders_fraction!r}",
                "SelectionSettings",
            )
        if self.require not in ("f+any", "all", "f"):
            raise InputError(
                f"require: expected 'f+any', 'all' or 'f', found {self.require!r}",
                "SelectionSettings",
            )


@dataclass(frozen=True)
class SelectedPoles:
    """Poles chosen from a stabilization diagram, sorted by frequency.

    Attributes
    ----------
    f_hz, zeta : ndarray, shape (n_modes,)
        Median natural frequency (Hz) and damping ratio of each cluster.
    poles : ndarray of complex, shape (n_modes,)
        ``-zeta w + i w sqrt(1 - zeta^2)``, rad/s.
    vectors : ndarray of complex, shape (n_modes, n_v)
        Vector of the member nearest to the median.
    f_std_hz, zeta_std : ndarray, shape (n_modes,)
        Spread (standard deviation) of the members.
    n_members : ndarray of int, shape (n_modes,)
        Number of orders represented in the cluster.
    members : tuple of ndarray of int
        Indices into the diagram's pole arrays, per mode.
    """

    f_hz: NDArray[np.float64]
    zeta: NDArray[np.float64]
    poles: NDArray[np.complex128]
    vectors: NDArray[np.complex128]
    f_std_hz: NDArray[np.float64]
    zeta_std: NDArray[np.float64]
    n_members: NDArray[np.int64]
    members: tuple[NDArray[np.intp], ...]

    @property
    def n_modes(self) -> int:
        """Number of selected poles."""
        return int(self.f_hz.size)


def _distance_matrix(poles: NDArray[np.complex128], vecs: NDArray[np.complex128]) -> NDArray:
    """Pole distance ``|l_i - l_j| / max(|l_i|, |l_j|) + 1 - MAC_ij``, shape (n, n)."""
    dl = np.abs(poles[:, None] - poles[None, :])
    scale = np.maximum(np.abs(poles)[:, None], np.abs(poles)[None, :])
    d = dl / scale + 1.0 - mac_matrix(vecs, vecs)
    d = np.nan_to_num(d, nan=2.0)
    np.fill_diagonal(d, 0.0)
    return np.clip(0.5 * (d + d.T), 0.0, None)


def _cluster(d: NDArray, idx: NDArray[np.intp], order: NDArray, d_max: float) -> list[NDArray]:
    """Average-linkage clusters of the poles ``idx``; split clusters with repeated orders."""
    if idx.size == 1:
        return [idx]
    sub = d[np.ix_(idx, idx)]
    labels = fcluster(linkage(squareform(sub, checks=False), "average"), d_max, "distance")
    out: list[NDArray] = []
    for lab in np.unique(labels):
        members = idx[labels == lab]
        ords, counts = np.unique(order[members], return_counts=True)
        repeated = np.count_nonzero(counts > 1)
        if repeated > 0.25 * ords.size and d_max > 1e-3 and members.size > 1:
            out.extend(_cluster(d, members, order, d_max / 2))
        else:
            out.append(members)
    return out


def select_poles(
    diagram: StabilizationDiagram, settings: SelectionSettings | None = None
) -> SelectedPoles:
    """Choose the physical poles of a stabilization diagram by clustering.

    Parameters
    ----------
    diagram : StabilizationDiagram
    settings : SelectionSettings, optional

    Returns
    -------
    SelectedPoles
        Possibly empty (no stable structure found).
    """
    s = settings if settings is not None else SelectionSettings()
    if s.require == "all":
        cand = diagram.stable
    elif s.require == "f":
        cand = diagram.physical & diagram.stable_f
    else:
        cand = diagram.physical & diagram.stable_f & (diagram.stable_zeta | diagram.stable_shape)
    idx = np.flatnonzero(cand)
    n_orders = diagram.orders.size
    need = max(s.min_orders, int(np.ceil(s.min_orders_fraction * n_orders)))
    n_v = diagram.vectors.shape[1]
    clusters: list[NDArray] = []
    if idx.size:
        # distances among the candidates only (the others never enter a cluster)
        d = _distance_matrix(diagram.poles[idx], diagram.vectors[idx])
        local = _cluster(d, np.arange(idx.size), diagram.order[idx], s.d_max)
        clusters = [idx[c] for c in local if c.size]
    f_all, z_all = diagram.f_hz, diagram.zeta
    rows = []
    for c in clusters:
        n_ord = np.unique(diagram.order[c]).size
        if n_ord < need:
            continue
        f_med = float(np.median(f_all[c]))
        z_med = float(np.median(z_all[c]))
        dist = np.abs(f_all[c] - f_med) / f_med + np.abs(z_all[c] - z_med) / max(z_med, 1e-12)
        rep = c[np.argmin(dist)]
        rows.append(
            (
                f_med,
                z_med,
                diagram.vectors[rep],
                float(np.std(f_all[c])),
                float(np.std(z_all[c])),
                n_ord,
                np.sort(c),
            )
        )
    rows.sort(key=lambda r: r[0])
    f = np.array([r[0] for r in rows], dtype=float)
    z = np.array([r[1] for r in rows], dtype=float)
    return SelectedPoles(
        f_hz=f,
        zeta=z,
        poles=modal_to_poles(f, z),
        vectors=np.array([r[2] for r in rows], dtype=complex).reshape(len(rows), n_v),
        f_std_hz=np.array([r[3] for r in rows], dtype=float),
        zeta_std=np.array([r[4] for r in rows], dtype=float),
        n_members=np.array([r[5] for r in rows], dtype=np.int64),
        members=tuple(r[6] for r in rows),
    )
