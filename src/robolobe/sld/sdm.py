"""Semi-discretization (SDM) stability of milling: the reference for the ZOA.

First-order semi-discretization (Insperger & Stepan 2002, IJNME 55:503; 2004,
IJNME 61:117; Insperger, Stepan & Turi 2008, JSV 313:334) of the delayed,
time-periodic equation of milling in modal coordinates ::

    eta'' + 2 Z W eta' + W^2 eta = B F,      q = C eta           (q: tool x, y)
    F(t) = a Kt / 2 * A(t) (q(t) - q(t - T)),  A(t) = sum_j g(phi_j) A(phi_j)

with ``A(phi)`` from :func:`robolobe.sld.directional.directional_matrix`
(the same force model as the ZOA, whose factors are ``alpha = int A``), the
tooth period ``T = 60 / (N n)`` as the delay and the period, split into
``m`` intervals. On each interval ``A(t)`` is replaced by its exact mean and
the delayed displacement by the straight line between its two neighbouring
samples; the interval is then integrated exactly (one matrix exponential of
an augmented system). The product over one period, the monodromy matrix,
acts on ``[x_i, q_{i-1}, ..., q_{i-m}]``; the cut is stable when its spectral
radius is below one. The limiting depth per speed is found by a geometric
scan in depth followed by bisection (vectorised over speeds).

The modal realization comes from the :class:`~robolobe.sld.frf.ModalModel`
residues: modes with the same pole are merged and each residue matrix is
split by SVD into ``c_i b_i^T`` (one single-DOF oscillator per singular
value), so the SDM sees exactly the FRF the ZOA sees.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._threads import one_blas_thread
from robolobe.errors import ConvergenceError, InputError
from robolobe.sld.conditions import CuttingConditions
from robolobe.sld.directional import directional_factors, interval_directional_average
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram
from robolobe.sld.zoa import critical_depth

__all__ = [
    "MAX_SDM_INTERVALS",
    "SdmSystem",
    "expm_batched",
    "sdm_lobes",
    "sdm_spectral_radius",
    "sdm_system",
]

FloatArray = NDArray[np.float64]

_TWO_PI = 2.0 * np.pi
# entries of the (points, D, D) monodromy matrices built at once
_CHUNK = 1 << 22
#: Cap on the intervals per tooth period: the state has ``2 (modes + m)``
#: entries and each speed multiplies ``m`` such matrices, so the cost grows
#: with ``m**4``; 40 resolves the lobes to a fraction of a percent.
MAX_SDM_INTERVALS = 400


@dataclass(frozen=True, eq=False)
class SdmSystem:
    """Milling dynamics prepared for semi-discretization.

    Parameters
    ----------
    omega, zeta : ndarray, shape (n_s,)
        Natural frequency [rad/s] and damping ratio of each oscillator.
    c : ndarray, shape (2, n_s)
        Output map ``q = c @ eta``.
    b : ndarray, shape (n_s, 2)
        Input map (force to modal force).
    a_mean : ndarray, shape (m, 2, 2)
        Mean directional matrix of all teeth on each of the ``m`` intervals.
    teeth : int
        Number of teeth N.
    kt : float
        Tangential coefficient [N/m^2].
    """

    omega: FloatArray
    zeta: FloatArray
    c: FloatArray
    b: FloatArray
    a_mean: FloatArray
    teeth: int
    kt: float

    @property
    def intervals(self) -> int:
        """Number of intervals per tooth period m."""
        return int(self.a_mean.shape[0])

    @property
    def n_states(self) -> int:
        """Dimension of the monodromy matrix ``2 n_s + 2 m``."""
        return 2 * self.omega.size + 2 * self.intervals


_PADE13 = (
    64764752532480000.0,
    32382376266240000.0,
    7771770303897600.0,
    1187353796428800.0,
    129060195264000.0,
    10559470521600.0,
    670442572800.0,
    33522128640.0,
    1323241920.0,
    40840800.0,
    960960.0,
    16380.0,
    182.0,
    1.0,
)
_THETA13 = 5.371920351148152


def expm_batched(a: FloatArray) -> FloatArray:
    """Matrix exponential of a stack of small matrices, vectorised.

    Scaling and squaring with the degree-13 Pade approximant (Higham 2005,
    SIAM J. Matrix Anal. Appl. 26:1179), the scaling chosen per matrix from
    its 1-norm. ``scipy.linalg.expm`` loops over a stack in Python; this
    does not.

    Parameters
    ----------
    a : ndarray, shape (..., n, n)

    Returns
    -------
    ndarray, shape (..., n, n)
    """
    a = np.asarray(a, dtype=np.float64)
    n = a.shape[-1]
    norm = np.abs(a).sum(axis=-2).max(axis=-1)
    with np.errstate(divide="ignore"):
        s = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / _THETA13))).astype(np.int64)
    a = a * np.ldexp(1.0, -s)[..., None, None]
    b = _PADE13
    eye = np.eye(n)
    a2 = a @ a
    a4 = a2 @ a2
    a6 = a4 @ a2
    u = a @ (
        a6 @ (b[13] * a6 + b[11] * a4 + b[9] * a2) + b[7] * a6 + b[5] * a4 + b[3] * a2 + b[1] * eye
    )
    v = a6 @ (b[12] * a6 + b[10] * a4 + b[8] * a2) + b[6] * a6 + b[4] * a4 + b[2] * a2 + b[0] * eye
    r = np.linalg.solve(v - u, v + u)
    for i in range(int(s.max()) if s.size else 0):  # squarings (a handful)
        r = np.where((s > i)[..., None, None], r @ r, r)
    return np.asarray(r, dtype=np.float64)


def _realize(model: ModalModel) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    if model.dim != 2 or model.batch_shape:
        raise InputError(
            "model: expected unbatched 2-D (feed frame) dynamics for SDM, found "
            f"batch shape {model.batch_shape} and dim {model.dim}"
        )
    keys = np.stack([model.omega, model.zeta], axis=-1)
    uniq, inv = np.unique(keys, axis=0, return_inverse=True)
    inv = np.asarray(inv).ravel()
    res = np.zeros((uniq.shape[0], 2, 2))
    np.add.at(res, inv, model.residues)
    u, s, vt = np.linalg.svd(res)  # (g, 2, 2), (g, 2), (g, 2, 2)
    keep = s > 1e-12 * max(float(s.max()), 1e-300)
    g_idx, k_idx = np.nonzero(keep)
    if g_idx.size == 0:
        raise InputError("model: all residues are zero; there is no flexibility to cut against")
    root = np.sqrt(s[g_idx, k_idx])
    c = (u[g_idx, :, k_idx] * root[:, None]).T  # (2, n_s)
    b = vt[g_idx, k_idx, :] * root[:, None]  # (n_s, 2)
    return uniq[g_idx, 0], uniq[g_idx, 1], c, b


def sdm_system(
    model: ModalModel,
    *,
    teeth: int,
    kt: float,
    kr: float,
    conditions: CuttingConditions,
    intervals: int = 40,
) -> SdmSystem:
    """Prepare the SDM for one tool-point model and one set of conditions.

    Parameters
    ----------
    model : ModalModel
        Unbatched 2-D dynamics in the feed frame.
    teeth : int
        Number of teeth N.
    kt : float
        Tangential coefficient [N/m^2].
    kr : float
        ``Kn / Kt``.
    conditions : CuttingConditions
        Entry and exit angles.
    intervals : int, default 40
        Intervals m per tooth period (2 to :data:`MAX_SDM_INTERVALS`);
        first-order SD converges as ``O(1/m^2)``.

    Returns
    -------
    SdmSystem
    """
    if int(intervals) != intervals or not 2 <= intervals <= MAX_SDM_INTERVALS:
        raise InputError(
            f"intervals: expected an integer 2 to {MAX_SDM_INTERVALS}, found {intervals!r}"
        )
    m = int(intervals)
    w, z, c, b = _realize(model)
    dphi = _TWO_PI / (teeth * m)
    a_mean = interval_directional_average(
        np.arange(m) * dphi, dphi, conditions.phi_entry, conditions.phi_exit, kr, teeth
    )
    return SdmSystem(omega=w, zeta=z, c=c, b=b, a_mean=a_mean, teeth=int(teeth), kt=float(kt))


def _radius(sys: SdmSystem, depth: FloatArray, rpm: FloatArray) -> FloatArray:
    """Spectral radius of the monodromy matrix for 1-D arrays of points."""
    p = depth.size
    n = sys.omega.size
    m = sys.intervals
    nx = 2 * n
    dim = nx + 2 * m
    dt = 60.0 / (sys.teeth * rpm) / m  # (P,)
    ca = 0.5 * depth * sys.kt  # (P,)
    bac = np.einsum("sk,ikl,lr->isr", sys.b, sys.a_mean, sys.c)  # (m, n, n)
    ba = np.einsum("sk,ikl->isl", sys.b, sys.a_mean)  # (m, n, 2)
    na = nx + 4
    aug = np.zeros((p, m, na, na))
    aug[:, :, :n, n:nx] = np.eye(n)
    aug[:, :, n:nx, :n] = -np.diag(sys.omega**2) + ca[:, None, None, None] * bac
    aug[:, :, n:nx, n:nx] = -np.diag(2.0 * sys.zeta * sys.omega)
    aug[:, :, n:nx, nx : nx + 2] = -ca[:, None, None, None] * ba
    aug[:, :, nx : nx + 2, nx + 2 : nx + 4] = np.eye(2)
    aug *= dt[:, None, None, None]
    ex = expm_batched(aug)
    phi = ex[:, :, :nx, :nx]  # (P, m, nx, nx)
    g1 = ex[:, :, :nx, nx : nx + 2]
    g2 = ex[:, :, :nx, nx + 2 : nx + 4] / dt[:, None, None, None]
    wa = g1 - g2  # weight of q_{i-m}
    wb = g2  # weight of q_{i-m+1}
    cq = np.zeros((2, nx))
    cq[:, :n] = sys.c
    y = np.broadcast_to(np.eye(dim), (p, dim, dim)).copy()
    for i in range(m):  # intervals of one period (not frequencies or waypoints)
        x = y[:, :nx]
        q_old = y[:, dim - 2 :]
        q_next = y[:, dim - 4 : dim - 2]
        xn = phi[:, i] @ x + wa[:, i] @ q_old + wb[:, i] @ q_next
        qi = cq @ x
        y = np.concatenate([xn, qi, y[:, nx : dim - 2]], axis=1)
    # Many small dense eigenproblems: BLAS threads only contend here (50-100x slower on a
    # loaded 2-core machine for 100x100 matrices), so run them single-threaded.
    with one_blas_thread():
        ev = np.linalg.eigvals(y)
    return np.asarray(np.abs(ev).max(axis=-1))


def sdm_spectral_radius(sys: SdmSystem, depth: ArrayLike, rpm: ArrayLike) -> FloatArray:
    """Spectral radius of the SDM monodromy matrix (< 1: stable).

    Parameters
    ----------
    sys : SdmSystem
        From :func:`sdm_system`.
    depth : array_like
        Axial depth [m] (>= 0).
    rpm : array_like
        Spindle speed [rpm] (> 0); broadcast against ``depth``.

    Returns
    -------
    ndarray
        Spectral radius, shape of the broadcast inputs.
    """
    d, r = np.broadcast_arrays(np.asarray(depth, float), np.asarray(rpm, float))
    if np.any(r <= 0) or np.any(d < 0) or not (np.all(np.isfinite(d)) and np.all(np.isfinite(r))):
        raise InputError("sdm: expected depth >= 0 m and rpm > 0")
    flat_d, flat_r = d.ravel(), r.ravel()
    out = np.empty(flat_d.size)
    per = sys.n_states**2 + sys.intervals * (2 * sys.omega.size + 4) ** 2
    step = max(1, _CHUNK // per)
    for s in range(0, flat_d.size, step):  # memory chunks of points, each vectorised
        out[s : s + step] = _radius(sys, flat_d[s : s + step], flat_r[s : s + step])
    return out.reshape(d.shape)


def sdm_lobes(
    model: ModalModel,
    *,
    teeth: int,
    kt: float,
    kr: float,
    conditions: CuttingConditions,
    rpm: ArrayLike,
    intervals: int = 40,
    rtol: float = 1e-4,
    depth_min: float | None = None,
    depth_max: float | None = None,
    scan_ratio: float = 1.3,
) -> LobeDiagram:
    """Limiting depth per speed by semi-discretization.

    For each speed the depth is scanned geometrically from ``depth_min``
    (ratio ``scan_ratio``) until the monodromy spectral radius reaches one,
    then bisected to ``rtol``. All speeds advance together.

    Parameters
    ----------
    model : ModalModel
        Unbatched 2-D dynamics in the feed frame.
    teeth, kt, kr, conditions
        Cutter teeth, Kt [N/m^2], Kn/Kt, engagement.
    rpm : array_like, shape (n_speed,)
        Speeds [rpm].
    intervals : int, default 40
        Intervals per tooth period.
    rtol : float, default 1e-4
        Relative width of the final depth bracket.
    depth_min : float, optional
        Start of the scan [m]; default 5 % of the ZOA critical depth (a scale
        only: the scan goes lower if that depth is already unstable).
    depth_max : float, optional
        End of the scan [m]; speeds still stable there get ``inf``. Default
        1000 times the ZOA critical depth.
    scan_ratio : float, default 1.3
        Ratio between scanned depths; unstable windows narrower than this in
        depth can be missed.

    Returns
    -------
    LobeDiagram
        ``method == "sdm"``, valid at any immersion.

    Raises
    ------
    ConvergenceError
        When even a vanishing depth is unstable (a model error).
    """
    r = np.asarray(rpm, dtype=np.float64)
    if r.ndim != 1 or r.size < 1 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError("rpm: expected a 1-D grid of positive speeds")
    if not (0 < rtol < 0.1) or not (scan_ratio > 1.0):
        raise InputError(
            f"rtol/scan_ratio: expected 0 < rtol < 0.1 and ratio > 1, found {rtol}, {scan_ratio}"
        )
    sys = sdm_system(model, teeth=teeth, kt=kt, kr=kr, conditions=conditions, intervals=intervals)
    if depth_min is None or depth_max is None:
        alpha = directional_factors(conditions.phi_entry, conditions.phi_exit, kr)
        scale = float(critical_depth(model, alpha, teeth=teeth, kt=kt).depth)
        if not np.isfinite(scale):
            # no ZOA lobe: use the static compliance as a scale
            comp = float(
                np.abs(model.residues.sum(axis=0) / model.omega[:, None, None].mean() ** 2).max()
            )
            scale = _TWO_PI / (teeth * kt * comp)
        depth_min = 0.05 * scale if depth_min is None else depth_min
        depth_max = 1000.0 * scale if depth_max is None else depth_max
    if not (0 < depth_min < depth_max):
        raise InputError(
            f"depth_min/depth_max: expected 0 < min < max, found {depth_min}, {depth_max}"
        )
    lo = np.full(r.size, float(depth_min))
    # make sure the start is stable; go lower where it is not
    for _ in range(40):
        bad = sdm_spectral_radius(sys, lo, r) >= 1.0
        if not np.any(bad):
            break
        lo[bad] *= 0.25
    else:
        raise ConvergenceError(
            "sdm: the cut is unstable even at vanishing depth; check the damping of the model"
        )
    hi = np.full(r.size, np.inf)
    active = np.arange(r.size)
    cur = lo.copy()
    while active.size:
        trial = cur[active] * scan_ratio
        unstable = sdm_spectral_radius(sys, trial, r[active]) >= 1.0
        hi[active[unstable]] = trial[unstable]
        lo[active[unstable]] = cur[active[unstable]]
        cur[active] = trial
        over = ~unstable & (trial > depth_max)
        active = active[~unstable & ~over]
    found = np.isfinite(hi)
    idx = np.flatnonzero(found)
    while idx.size:
        mid = np.sqrt(lo[idx] * hi[idx])
        unstable = sdm_spectral_radius(sys, mid, r[idx]) >= 1.0
        hi[idx[unstable]] = mid[unstable]
        lo[idx[~unstable]] = mid[~unstable]
        idx = idx[hi[idx] / lo[idx] > 1.0 + rtol]
    a_lim = np.where(found, np.sqrt(lo * hi), np.inf)
    return LobeDiagram(
        rpm=r,
        a_lim=a_lim,
        teeth=int(teeth),
        method="sdm",
        immersion=conditions.immersion,
        valid=True,
        message="",
        max_lobe=0,
    )
