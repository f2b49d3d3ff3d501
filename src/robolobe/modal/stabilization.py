"""Stabilization diagram: which poles repeat from one model order to the next.

A pole of order ``n`` is compared with the poles of the previous order in
the diagram (the closest in frequency among those within the hard limits):

- stable in frequency: ``|f_n - f_{n-1}| / f_{n-1} <= f_tol`` (default 1 %),
- stable in damping: ``|zeta_n - zeta_{n-1}| / zeta_{n-1} <= zeta_tol`` (5 %),
- stable in shape: ``MAC(v_n, v_{n-1}) >= mac_min`` (0.98),

(docs/references.md: modal identification), and it is *physical* when ``0 < zeta < zeta_max``
and its frequency lies in the band. Shapes are the participation vectors of
pLSCF (or, with one reference, the numerator values across the outputs).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from robolobe.campaign.metrics import mac
from robolobe.errors import InputError
from robolobe.modal.plscf import PoleSet

__all__ = ["StabilizationCriteria", "StabilizationDiagram", "stabilization_diagram"]


@dataclass(frozen=True, kw_only=True)
class StabilizationCriteria:
    """Tolerances of the stabilization diagram.

    Parameters
    ----------
    f_tol : float
        Relative frequency change between orders (default 0.01).
    zeta_tol : float
        Relative damping change between orders (default 0.05).
    mac_min : float
        Minimum MAC of the pole vectors between orders (default 0.98).
    zeta_max : float
        Hard upper limit on the damping ratio (default 0.2); ``zeta > 0`` always.
    """

    f_tol: float = 0.01
    zeta_tol: float = 0.05
    mac_min: float = 0.98
    zeta_max: float = 0.2

    def __post_init__(self) -> None:
        for name in ("f_tol", "zeta_tol", "mac_min", "zeta_max"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and 0.0 < v <= 1.0):
                raise InputError(
                    f"expected a number in (0, 1], found {v!r}",
                    source=f"StabilizationCriteria.{name}",
                )


@dataclass(frozen=True)
class StabilizationDiagram:
    """All poles of all orders with their stability flags (flat arrays, one entry per pole).

    Attributes
    ----------
    order : ndarray of int, shape (n_p,)
    poles : ndarray of complex, shape (n_p,)
        rad/s, upper half plane.
    vectors : ndarray of complex, shape (n_p, n_v)
    physical, stable_f, stable_zeta, stable_shape : ndarray of bool, shape (n_p,)
    band_hz : (float, float)
        Frequency band of the physical poles, Hz.
    criteria : StabilizationCriteria
    """

    order: NDArray[np.int64]
    poles: NDArray[np.complex128]
    vectors: NDArray[np.complex128]
    physical: NDArray[np.bool_]
    stable_f: NDArray[np.bool_]
    stable_zeta: NDArray[np.bool_]
    stable_shape: NDArray[np.bool_]
    band_hz: tuple[float, float]
    criteria: StabilizationCriteria

    @property
    def f_hz(self) -> NDArray[np.float64]:
        """Natural frequencies, Hz, shape (n_p,)."""
        return np.abs(self.poles) / (2.0 * np.pi)

    @property
    def zeta(self) -> NDArray[np.float64]:
        """Damping ratios, shape (n_p,)."""
        return np.asarray(-self.poles.real / np.abs(self.poles))

    @property
    def stable(self) -> NDArray[np.bool_]:
        """Physical and stable in frequency, damping and shape, shape (n_p,)."""
        return np.asarray(self.physical & self.stable_f & self.stable_zeta & self.stable_shape)

    @property
    def orders(self) -> NDArray[np.int64]:
        """The distinct model orders, rising."""
        return np.unique(self.order)


def stabilization_diagram(
    pole_sets: Sequence[PoleSet],
    *,
    band_hz: tuple[float, float],
    criteria: StabilizationCriteria | None = None,
) -> StabilizationDiagram:
    """Flag every pole against the previous order.

    Parameters
    ----------
    pole_sets : sequence of PoleSet
        Poles per model order, in rising order (as from :func:`plscf`).
    band_hz : (float, float)
        Physical poles must have ``band_hz[0] <= f <= band_hz[1]``.
    criteria : StabilizationCriteria, optional

    Returns
    -------
    StabilizationDiagram
    """
    c = criteria if criteria is not None else StabilizationCriteria()
    lo, hi = band_hz
    sets = sorted(pole_sets, key=lambda p: p.order)
    if not sets:
        raise InputError("expected at least one model order, found none", source="pole_sets")
    orders, poles, vecs = [], [], []
    phys, sf, sz, sv = [], [], [], []
    prev: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.complex128]] | None = None
    n_v = max((p.vectors.shape[1] for p in sets), default=1)
    for ps in sets:
        f = ps.f_hz
        z = ps.zeta
        v = ps.vectors
        ok = (z > 0) & (z < c.zeta_max) & (f >= lo) & (f <= hi)
        n = f.size
        st_f = np.zeros(n, bool)
        st_z = np.zeros(n, bool)
        st_v = np.zeros(n, bool)
        if prev is not None and prev[0].size and n:
            pf, pz, pv = prev
            rel = np.abs(f[:, None] - pf[None, :]) / pf[None, :]
            j = np.argmin(rel, axis=1)
            st_f = rel[np.arange(n), j] <= c.f_tol
            st_z = np.abs(z - pz[j]) <= c.zeta_tol * np.abs(pz[j])
            st_v = mac(v, pv[j]) >= c.mac_min
        orders.append(np.full(n, ps.order))
        poles.append(ps.poles)
        vv = np.zeros((n, n_v), complex)
        vv[:, : v.shape[1]] = v
        vecs.append(vv)
        phys.append(ok)
        sf.append(st_f & ok)
        sz.append(st_z & ok)
        sv.append(st_v & ok)
        prev = (f[ok], z[ok], v[ok])
    return StabilizationDiagram(
        order=np.concatenate(orders).astype(np.int64),
        poles=np.concatenate(poles).astype(np.complex128),
        vectors=np.concatenate(vecs),
        physical=np.concatenate(phys),
        stable_f=np.concatenate(sf),
        stable_zeta=np.concatenate(sz),
        stable_shape=np.concatenate(sv),
        band_hz=(float(lo), float(hi)),
        criteria=c,
    )
