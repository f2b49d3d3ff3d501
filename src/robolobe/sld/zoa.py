"""Zero-order approximation (ZOA) of milling stability, batched (Altintas & Budak 1995).

With the oriented transfer matrix ``G0(w) = alpha G(w)`` (``alpha`` from
:func:`robolobe.sld.directional.directional_factors`, ``G`` the 2x2 tool-point
receptance in the feed frame, cross terms included), the characteristic
equation ``det(I + Lambda G0) = 0`` gives ``Lambda = -1 / mu`` for each
eigenvalue ``mu`` of ``G0`` (closed-form quadratic
``mu^2 - tr(G0) mu + det(G0) = 0``). With Altintas' formulas
(docs/references.md: stability lobes), ``Lambda_R (1 + kappa^2) = |Lambda|^2 / Lambda_R``
and ``kappa = Lambda_I / Lambda_R``, this becomes ::

    a_lim = -2 pi Lambda_R (1 + kappa^2) / (N Kt) = 2 pi / (N Kt Re mu)
    eps   = pi - 2 atan(kappa)                  = pi + 2 atan(Im mu / Re mu)

physical (``a_lim > 0``) only where ``Re mu > 0``, and then ``eps`` lies in
``(0, 2 pi)``. Lobe ``k`` sits at ``T = (eps + 2 k pi) / w``,
``n = 60 / (N T)``. The two eigenvalue branches are tracked along the
frequency axis (nearest-neighbour pairing, vectorised) so that a lobe curve
never jumps from one branch to the other.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from types import ModuleType
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.sld.frf import ModalModel
from robolobe.sld.lobes import LobeDiagram, lobe_envelope, lobe_speeds

__all__ = [
    "LOW_IMMERSION",
    "CriticalDepth",
    "critical_depth",
    "low_immersion_message",
    "zoa_depth",
    "zoa_eigenvalues",
    "zoa_lobes",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TWO_PI = 2.0 * np.pi

#: Frequency samples (waypoints x frequencies) from which :func:`zoa_lobes`
#: uses the compiled kernel by default: below, numba's start-up in a fresh
#: process costs more than the kernel saves over the numpy path. Measured
#: (benchmarks/bench_jit.py --kernel zoa, CPU seconds of a fresh process, 2 cores at
#: load 13): 1e6 samples numpy 0.42 vs compiled 0.68, 3e6 1.79 vs 0.93; equal at ~1.5e6.
JIT_MIN_SAMPLES = 1_500_000
#: The same where numba has started already (:func:`robolobe._jit.started`): 3e5
#: samples numpy 0.105 vs compiled 0.098 (the kernels' cache load included), 1e6 0.42
#: vs 0.16.
JIT_MIN_SAMPLES_STARTED = 300_000

#: Radial immersion below which the ZOA is flagged as unreliable.
LOW_IMMERSION = 0.2


def low_immersion_message(immersion: float) -> str:
    """The validity message for a radial immersion (empty when ZOA is fine)."""
    if immersion >= LOW_IMMERSION:
        return ""
    return (
        f"radial immersion a/D = {immersion:.3g} < {LOW_IMMERSION}: the zero-order (ZOA) "
        "lobes are unreliable here (they miss the period-doubling lobes and can "
        "overestimate the stable depth by 20-70 %); use method='sdm' "
        "(semi-discretization) to check"
    )


def _use_kernels(samples: int) -> bool:
    """Whether ``samples`` waypoints x frequencies take the compiled kernels by default."""
    from robolobe import _jit

    return _jit.use_compiled(samples, cold=JIT_MIN_SAMPLES, warm=JIT_MIN_SAMPLES_STARTED)


def _kernels() -> ModuleType | None:
    """The compiled kernel module, or None (no numba, or ``ROBOLOBE_NO_JIT`` set)."""
    from robolobe import _jit

    if not _jit.available():
        return None
    from robolobe.sld import _kernels

    return _kernels


def _flat(x: NDArray[np.generic], batch: tuple[int, ...], tail: tuple[int, ...]) -> NDArray[Any]:
    """``x`` broadcast to ``batch + tail``, batch axes merged: C-contiguous and writable.

    (A read-only broadcast view would make numba compile a second specialisation.)
    """
    shape = (*batch, *tail)
    out = x if x.shape == shape else np.broadcast_to(x, shape)
    out = np.ascontiguousarray(out.reshape(-1, *tail))
    return out if out.flags.writeable else out.copy()


def _alpha(alpha: ArrayLike) -> FloatArray:
    a = np.asarray(alpha, dtype=np.float64)
    if a.shape[-2:] != (2, 2):
        raise InputError(f"alpha: expected shape (..., 2, 2), found {a.shape}")
    return a


def zoa_eigenvalues(frf: ArrayLike, alpha: ArrayLike, *, track: bool = True) -> ComplexArray:
    """Eigenvalues ``mu`` of ``alpha @ G(w)``, branch-tracked along frequency.

    Parameters
    ----------
    frf : array_like, shape (..., n_freq, 2, 2), complex
        Tool-point receptance [m/N] in the feed frame (x feed, y normal).
    alpha : array_like, shape (..., 2, 2)
        Directional factors (broadcast against the batch shape).
    track : bool, default True
        Pair the eigenvalues of neighbouring frequencies so that each
        branch is continuous (needs a sorted frequency axis).

    Returns
    -------
    ndarray, shape (..., 2, n_freq), complex
        ``mu`` per branch [m/N].
    """
    g = np.asarray(frf)
    if g.ndim < 3 or g.shape[-2:] != (2, 2):
        raise InputError(f"frf: expected shape (..., n_freq, 2, 2), found {g.shape}")
    a = _alpha(alpha)[..., None, :, :]
    a00, a01, a10, a11 = a[..., 0, 0], a[..., 0, 1], a[..., 1, 0], a[..., 1, 1]
    g00, g01, g10, g11 = g[..., 0, 0], g[..., 0, 1], g[..., 1, 0], g[..., 1, 1]
    tr = a00 * g00 + a01 * g10 + a10 * g01 + a11 * g11
    det = (a00 * a11 - a01 * a10) * (g00 * g11 - g01 * g10)
    h = 0.5 * tr
    root = np.sqrt(h * h - det)
    m1 = h + root
    m2 = h - root
    if track and m1.shape[-1] > 1:
        same = np.abs(m1[..., 1:] - m1[..., :-1]) + np.abs(m2[..., 1:] - m2[..., :-1])
        cross = np.abs(m1[..., 1:] - m2[..., :-1]) + np.abs(m2[..., 1:] - m1[..., :-1])
        flips = np.cumsum(cross < same, axis=-1) % 2
        parity = np.concatenate([np.zeros((*flips.shape[:-1], 1), flips.dtype), flips], axis=-1)
        swap = parity.astype(bool)
        m1, m2 = np.where(swap, m2, m1), np.where(swap, m1, m2)
    return np.stack([m1, m2], axis=-2)


def zoa_depth(mu: ArrayLike, *, teeth: int, kt: float) -> tuple[FloatArray, FloatArray]:
    """Limiting depth and phase from the eigenvalues.

    Parameters
    ----------
    mu : array_like, complex
        Eigenvalues of ``alpha G`` [m/N] (any shape).
    teeth : int
        Number of teeth N.
    kt : float
        Tangential cutting coefficient [N/m^2].

    Returns
    -------
    depth : ndarray
        ``2 pi / (N Kt Re mu)`` [m] where ``Re mu > 0``, ``inf`` elsewhere.
    eps : ndarray
        ``pi + 2 atan(Im mu / Re mu)`` [rad] in ``(0, 2 pi)`` where
        ``Re mu > 0``, NaN elsewhere.
    """
    m = np.asarray(mu)
    re, im = m.real, m.imag
    pos = re > 0.0
    safe = np.where(pos, re, 1.0)
    depth = np.where(pos, _TWO_PI / (teeth * kt * safe), np.inf)
    eps = np.where(pos, np.pi + 2.0 * np.arctan(im / safe), np.nan)
    return depth, eps


def _complete_above(
    omega: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    a_lim: FloatArray,
    teeth: int,
    max_lobe: int,
) -> FloatArray:
    """Speed above which lobes beyond ``max_lobe`` cannot lower the envelope."""
    amax = np.where(np.isfinite(a_lim), a_lim, -np.inf).max(axis=-1)  # (...)
    amax = np.where(np.isfinite(amax), amax, np.inf)
    w = np.asarray(omega)[..., None, :]
    n_next = lobe_speeds(w, np.where(np.isfinite(eps), eps, 1.0), max_lobe + 1, teeth)
    relevant = np.isfinite(depth) & (depth < amax[..., None, None])
    return np.asarray(np.where(relevant, n_next, 0.0).max(axis=(-1, -2)))


#: Batch entries whose FRFs a synthesis callable forms at once (see :func:`zoa_lobes`):
#: small enough that the synthesis' temporaries (~2 MB for 460 frequencies and 10
#: modes) stay in cache (256 cost 25 % more CPU at 10k waypoints).
FRF_CHUNK = 64


def zoa_lobes(
    omega: ArrayLike,
    frf: ArrayLike | Callable[[int, int], ComplexArray],
    *,
    alpha: ArrayLike,
    teeth: int,
    kt: float,
    rpm: ArrayLike,
    max_lobe: int | None = 30,
    immersion: float = 1.0,
    max_lobe_cap: int = 400,
    jit: bool | None = None,
) -> LobeDiagram:
    """Batched zero-order stability lobes and their envelope on a speed grid.

    Parameters
    ----------
    omega : array_like, shape (n_freq,) or (..., n_freq)
        Sorted chatter-frequency grid [rad/s] (shared or per batch entry).
    frf : array_like, shape (..., n_freq, 2, 2), complex, or callable
        Tool-point receptance [m/N] in the feed frame; or, with ``omega`` of
        shape (nb, n_freq), a synthesis ``frf(start, stop)`` returning the
        receptance of batch entries ``start:stop``, shape
        (stop - start, n_freq, 2, 2): the compiled kernel then takes it in
        chunks of :data:`FRF_CHUNK` entries (no array of all FRFs), the numpy
        path at once. Same results either way.
    alpha : array_like, shape (2, 2) or (..., 2, 2)
        Directional factors.
    teeth : int
        Number of teeth N.
    kt : float
        Tangential cutting coefficient [N/m^2].
    rpm : array_like, shape (n_speed,)
        Speed grid [rpm] (any spacing; uniform grids take a faster path).
    max_lobe : int or None, default 30
        Highest lobe number K. None: chosen so that the lobes are complete
        down to the lowest grid speed (see ``complete_above_rpm``), at most
        ``max_lobe_cap``.
    immersion : float, default 1
        Radial immersion ``a_e / D`` for the validity flag.
    max_lobe_cap : int, default 400
        Upper bound of the automatic K.
    jit : bool or None, default None
        True: the compiled kernel (:mod:`robolobe.sld._kernels`, fused per
        waypoint, parallel over waypoints) where numba is available and
        ``ROBOLOBE_NO_JIT`` is unset; False: the numpy reference path
        (:func:`zoa_eigenvalues`, :func:`zoa_depth`,
        :func:`robolobe.sld.lobes.lobe_envelope`); None: the kernel from
        :data:`JIT_MIN_SAMPLES` waypoints x frequencies on. Both give the
        same envelopes to rounding (1e-12).

    Returns
    -------
    LobeDiagram
        ``a_lim`` of shape ``(..., n_speed)`` with the lobe data for queries.
    """
    w = np.asarray(omega, dtype=np.float64)
    synth = frf if callable(frf) else None
    if synth is not None:
        if w.ndim != 2:
            raise InputError(
                f"omega: expected shape (nb, n_freq) with an FRF synthesis, found {w.shape}"
            )
        # a stand-in of the right shape for the checks (no memory)
        g = np.broadcast_to(np.zeros((), np.complex128), (*w.shape, 2, 2))
    else:
        g = np.asarray(frf)
    if w.ndim < 1 or g.shape[-3:-2] != w.shape[-1:]:
        raise InputError(f"omega {w.shape} and frf {g.shape}: expected n_freq to match")
    if w.shape[-1] > 1 and np.any(w[..., 1:] < w[..., :-1]):
        raise InputError("omega: expected a sorted (non-decreasing) frequency grid")
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"teeth: expected an integer >= 1, found {teeth!r}")
    if not (np.isfinite(kt) and kt > 0):
        raise InputError(f"kt: expected a positive coefficient in N/m^2, found {kt!r}")
    r = np.asarray(rpm, dtype=np.float64)
    if r.ndim != 1 or r.size < 1 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError("rpm: expected a 1-D grid of positive speeds")
    k = 30 if max_lobe is None else int(max_lobe)
    if k < 0:
        raise InputError(f"max_lobe: expected an integer >= 0, found {max_lobe!r}")
    a = _alpha(alpha)
    try:
        batch = np.broadcast_shapes(g.shape[:-3], a.shape[:-2], w.shape[:-1])
    except ValueError:
        raise InputError(
            f"frf {g.shape}, alpha {a.shape} and omega {w.shape}: batch shapes do not broadcast"
        ) from None
    nb = math.prod(batch)
    nf = w.shape[-1]
    if jit is None:  # numba's start-up (~0.5 s per process) pays only on large batches
        jit = _use_kernels(nb * nf)
    kern = _kernels() if jit else None
    if synth is not None and nb == 0:
        g, synth = np.zeros((0, nf, 2, 2), np.complex128), None
    if synth is not None and kern is None:
        g = np.asarray(synth(0, nb))
        if g.shape != (nb, nf, 2, 2):
            raise InputError(f"frf: the synthesis returned {g.shape}, expected {(nb, nf, 2, 2)}")
    if kern is not None and synth is not None:
        w_f, a_f = _flat(w, batch, (nf,)), _flat(a, batch, (2, 2))
        depth2, eps2 = np.empty((nb, 2, nf)), np.empty((nb, 2, nf))
        env2, comp2 = np.empty((nb, r.size)), np.empty(nb)
        r_sorted = bool(np.all(r[1:] > r[:-1]))  # else each chunk's envelope is unsorted
        for c0 in range(0, nb, FRF_CHUNK):
            c1 = min(nb, c0 + FRF_CHUNK)
            gc = np.ascontiguousarray(synth(c0, c1), dtype=np.complex128)
            if gc.shape != (c1 - c0, nf, 2, 2):
                raise InputError(
                    f"frf: the synthesis returned {gc.shape}, expected {(c1 - c0, nf, 2, 2)}"
                )
            into = (depth2[c0:c1], eps2[c0:c1], env2[c0:c1], comp2[c0:c1])
            res = kern.zoa_fused(
                w_f[c0:c1],
                gc,
                a_f[c0:c1],
                teeth=int(teeth),
                kt=float(kt),
                rpm=r,
                max_lobe=k,
                out=into if r_sorted else None,
            )
            if not r_sorted:
                for dst, src in zip(into, res, strict=True):
                    dst[...] = src
    elif kern is not None:
        depth2, eps2, env2, comp2 = kern.zoa_fused(
            _flat(w, batch, (nf,)),
            _flat(g, batch, (nf, 2, 2)),
            _flat(a, batch, (2, 2)),
            teeth=int(teeth),
            kt=float(kt),
            rpm=r,
            max_lobe=k,
        )
    if kern is not None:
        depth = depth2.reshape(*batch, 2, nf)
        eps = eps2.reshape(*batch, 2, nf)
        a_lim = env2.reshape(*batch, r.size)
        complete = comp2.reshape(batch)
    else:
        mu = zoa_eigenvalues(g, a)
        depth, eps = zoa_depth(mu, teeth=int(teeth), kt=float(kt))
        a_lim = lobe_envelope(w, depth, eps, teeth=int(teeth), rpm=r, max_lobe=k)
        complete = _complete_above(w, depth, eps, a_lim, int(teeth), k)
    return _finish(
        w, depth, eps, a_lim, complete, kern=kern, teeth=int(teeth), rpm=r, max_lobe=max_lobe,
        k=k, max_lobe_cap=max_lobe_cap, immersion=immersion,
    )  # fmt: skip


def _finish(
    w: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    a_lim: FloatArray,
    complete: FloatArray,
    *,
    kern: ModuleType | None,
    teeth: int,
    rpm: FloatArray,
    max_lobe: int | None,
    k: int,
    max_lobe_cap: int,
    immersion: float,
) -> LobeDiagram:
    """The diagram from the envelope with ``k`` lobes; with ``max_lobe=None`` the lobes
    that reach the lowest speed are added first where ``k`` left some out."""
    r = rpm
    batch = depth.shape[:-2]
    nb = math.prod(batch)
    nf = depth.shape[-1]
    if max_lobe is None and np.any(complete > r.min()):
        # lobes beyond k could still cut the envelope at the low speeds: add them
        need = lobes_needed(w, depth, teeth=teeth, rpm_min=float(r.min()))
        k = int(min(max(need, k), max_lobe_cap))
        if kern is not None:
            env2, comp2 = kern.envelope(
                _flat(w, batch, (nf,)),
                depth.reshape(nb, 2, nf),
                eps.reshape(nb, 2, nf),
                teeth=int(teeth),
                rpm=r,
                max_lobe=k,
            )
            a_lim = env2.reshape(*depth.shape[:-2], r.size)
            complete = comp2.reshape(depth.shape[:-2])
        else:
            a_lim = lobe_envelope(w, depth, eps, teeth=int(teeth), rpm=r, max_lobe=k)
            complete = _complete_above(w, depth, eps, a_lim, int(teeth), k)
    msg = low_immersion_message(immersion)
    return LobeDiagram(
        rpm=r,
        a_lim=a_lim,
        teeth=int(teeth),
        method="zoa",
        immersion=float(immersion),
        valid=not msg,
        message=msg,
        max_lobe=k,
        omega=w,
        depth=depth,
        eps=eps,
        complete_above_rpm=complete,
    )


def lobes_needed(omega: ArrayLike, depth: ArrayLike, *, teeth: int, rpm_min: float) -> float:
    """Lobe count that reaches ``rpm_min`` [rpm] from the highest frequency on a branch.

    Parameters
    ----------
    omega : array_like, shape (..., n_freq)
        Frequencies [rad/s].
    depth : array_like, shape (..., 2, n_freq)
        Depth per branch (``inf`` off the branch).
    teeth : int
    rpm_min : float

    Returns
    -------
    float
        ``ceil(w_max 60 / (N rpm_min 2 pi))`` (0 where no sample is on a branch).
    """
    # no (..., 2, n_freq) temporary of frequencies (a long plan's lobes: ~100 MB)
    on = np.isfinite(depth).any(axis=-2)
    w_max = float(np.max(np.asarray(omega), where=on, initial=0.0))
    return float(np.ceil(w_max * 60.0 / (teeth * rpm_min * _TWO_PI)))


def polyline_samples(x: ArrayLike) -> FloatArray:
    """Lobe polyline samples as the kernels read them: C-contiguous, single precision
    kept as it is (a long plan's lobes are stored so:
    :func:`robolobe.sld.converged.converged_lobes`' ``single_from``), any other as
    double; copied only where not so already."""
    a = np.asarray(x)
    if a.dtype == np.float32:
        return cast("FloatArray", np.ascontiguousarray(a))
    return np.ascontiguousarray(a, dtype=np.float64)


def lobes_from_depth(
    omega: ArrayLike,
    depth: ArrayLike,
    eps: ArrayLike,
    *,
    teeth: int,
    rpm: ArrayLike,
    max_lobe: int | None = 30,
    immersion: float = 1.0,
    max_lobe_cap: int = 400,
    jit: bool | None = None,
) -> LobeDiagram:
    """:func:`zoa_lobes` from limiting depth and phase already formed (branch-tracked).

    Parameters
    ----------
    omega : array_like, shape (nb, n_freq)
        Sorted frequencies [rad/s] per batch entry.
    depth, eps : array_like, shape (nb, 2, n_freq)
        Depth [m] (``inf`` off the branch) and phase [rad] per branch.
    teeth, rpm, max_lobe, immersion, max_lobe_cap, jit
        As in :func:`zoa_lobes`.
    """
    w, d, e = (polyline_samples(x) for x in (omega, depth, eps))
    r = np.asarray(rpm, dtype=np.float64)
    nb, nf = w.shape
    if d.shape != (nb, 2, nf) or e.shape != d.shape:
        raise InputError(f"depth/eps: expected shape {(nb, 2, nf)}, found {d.shape}, {e.shape}")
    k = 30 if max_lobe is None else int(max_lobe)
    if jit is None:
        jit = _use_kernels(nb * nf)
    kern = _kernels() if jit else None
    if kern is not None:
        a_lim, complete = kern.envelope(w, d, e, teeth=int(teeth), rpm=r, max_lobe=k)
    else:
        a_lim = lobe_envelope(w, d, e, teeth=int(teeth), rpm=r, max_lobe=k)
        complete = _complete_above(w, d, e, a_lim, int(teeth), k)
    return _finish(
        w, d, e, a_lim, complete, kern=kern, teeth=int(teeth), rpm=r, max_lobe=max_lobe, k=k,
        max_lobe_cap=max_lobe_cap, immersion=immersion,
    )  # fmt: skip


@dataclass(frozen=True)
class CriticalDepth:
    """The smallest ZOA depth over all chatter frequencies (the lobe minima).

    Parameters
    ----------
    depth : ndarray, shape (...)
        ``a_crit`` [m].
    omega : ndarray, shape (...)
        Chatter frequency at the minimum [rad/s].
    eps : ndarray, shape (...)
        Phase there [rad].
    teeth : int
        Number of teeth.
    """

    depth: FloatArray
    omega: FloatArray
    eps: FloatArray
    teeth: int

    def rpm(self, k: ArrayLike) -> FloatArray:
        """Speed [rpm] of the bottom of lobe ``k``."""
        return lobe_speeds(self.omega, self.eps, k, self.teeth)


def critical_depth(
    model: ModalModel,
    alpha: ArrayLike,
    *,
    teeth: int,
    kt: float,
    iterations: int = 8,
    points: int = 33,
) -> CriticalDepth:
    """Smallest ZOA limiting depth over all chatter frequencies, refined.

    Maximises ``max_j Re mu_j(w)`` (so minimises ``a = 2 pi / (N Kt Re mu)``):
    first on a dense modal grid, then by repeated zooming on the bracket
    around the best sample (``points`` per zoom, ``iterations`` zooms),
    vectorised over the batch. The result is exact to well below 1e-6
    relative for smooth FRFs.

    Parameters
    ----------
    model : ModalModel
        2-D tool-point dynamics (feed frame), any batch shape.
    alpha : array_like, shape (2, 2) or (..., 2, 2)
        Directional factors.
    teeth : int
        Number of teeth N.
    kt : float
        Tangential coefficient [N/m^2].
    iterations, points : int
        Zoom steps and samples per step.

    Returns
    -------
    CriticalDepth
        Per batch entry; ``depth`` is ``inf`` when no frequency gives a
        positive depth.
    """
    if model.dim != 2:
        raise InputError(f"model: expected 2-D (feed frame) dynamics, found dim {model.dim}")
    grid = model.frequency_grid(shared=False, points_per_mode=129)
    batch = model.batch_shape

    def score(w: FloatArray) -> tuple[FloatArray, ComplexArray]:
        mu = zoa_eigenvalues(model.frf(w), alpha, track=False)  # (..., 2, n)
        re = mu.real
        j = np.argmax(re, axis=-2)[..., None, :]
        best = np.take_along_axis(mu, j, axis=-2)[..., 0, :]
        return best.real, best

    re, _ = score(grid)
    i = np.argmax(re, axis=-1)
    n = grid.shape[-1]
    lo = np.take_along_axis(grid, np.maximum(i - 1, 0)[..., None], axis=-1)[..., 0]
    hi = np.take_along_axis(grid, np.minimum(i + 1, n - 1)[..., None], axis=-1)[..., 0]
    t = np.linspace(0.0, 1.0, points)
    for _ in range(iterations):
        w = lo[..., None] + (hi - lo)[..., None] * t
        re, _ = score(w)
        j = np.argmax(re, axis=-1)
        step = (hi - lo) / (points - 1)
        centre = np.take_along_axis(w, j[..., None], axis=-1)[..., 0]
        lo, hi = centre - step, centre + step
    w = np.linspace(0.0, 1.0, 3) * (hi - lo)[..., None] + lo[..., None]
    re, mu = score(w)
    best = mu[..., 1]
    depth, eps = zoa_depth(best, teeth=int(teeth), kt=float(kt))
    return CriticalDepth(
        depth=np.broadcast_to(depth, batch).copy(),
        omega=np.broadcast_to(0.5 * (lo + hi), batch).copy(),
        eps=np.broadcast_to(eps, batch).copy(),
        teeth=int(teeth),
    )
