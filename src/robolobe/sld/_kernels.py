"""Compiled (numba) zero-order lobe kernel: eigenvalues, depth, phase and envelope.

One waypoint at a time, fused: the eigenvalues of ``alpha G(w)`` are formed,
branch-tracked, turned into depth and phase, and the lobe polylines of that
waypoint are intersected with the speed grid while its ``(2, n_freq)`` rows
are still in cache; waypoints run in parallel (``prange``). The arithmetic is
that of the numpy reference (:func:`robolobe.sld.zoa.zoa_eigenvalues`,
:func:`robolobe.sld.zoa.zoa_depth`, :func:`robolobe.sld.lobes.lobe_envelope`)
operation for operation, so the envelopes agree to rounding (tested to 1e-12).

This module imports numba: import it only through
:func:`robolobe.sld.zoa.zoa_lobes` (which checks :func:`robolobe._jit.available`).
Compilation and the on-disk cache: :mod:`robolobe._jit`.
"""

from __future__ import annotations

import math
import threading
from typing import Any

import numba
import numpy as np
from llvmlite import ir
from numba.core import cgutils, types
from numba.core.extending import intrinsic
from numpy.typing import NDArray

from robolobe._jit import njit
from robolobe.errors import InputError
from robolobe.sld.zoa import polyline_samples

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TWO_PI = 2.0 * math.pi
# numba's default threading layer (workqueue) must not be entered from two
# Python threads at once; the kernels are called under this lock.
_LOCK = threading.Lock()


def _fma_intrinsic(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """``a * b + c`` rounded once (LLVM's ``llvm.fma.f64``)."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        fnty = ir.FunctionType(ir.DoubleType(), [ir.DoubleType()] * 3)
        return builder.call(
            cgutils.get_or_insert_function(builder.module, fnty, "llvm.fma.f64"), args
        )

    return sig, codegen


_fma: Any = intrinsic(_fma_intrinsic)


@njit()
def _cmul(a: complex, b: complex) -> complex:
    """Complex product as numpy's SIMD loops form it (fused multiply-add per part).

    Matching numpy's rounding keeps the eigenvalues bit-identical to the numpy
    path, which matters where ``Re mu`` cancels (branch edges, huge depths).
    """
    return complex(_fma(a.real, b.real, -(a.imag * b.imag)), _fma(a.real, b.imag, a.imag * b.real))


@njit()
def _crossed(m1: complex, m2: complex, p1: complex, p2: complex) -> bool:
    """Whether ``|m1 - p2| + |m2 - p1| < |m1 - p1| + |m2 - p2|`` (the branches swapped).

    Decided from the squared moduli where the bounds ``max(x, y) <= (sqrt x +
    sqrt y)^2 <= 2 (x + y)`` settle it (nearly always), else from the moduli.
    """
    a2 = _cabs2(m1 - p1)
    b2 = _cabs2(m2 - p2)
    c2 = _cabs2(m1 - p2)
    d2 = _cabs2(m2 - p1)
    if max(c2, d2) > 2.0 * (a2 + b2) * (1.0 + 1e-9):
        return False
    if max(a2, b2) > 2.0 * (c2 + d2) * (1.0 + 1e-9):
        return True
    return math.sqrt(c2) + math.sqrt(d2) < math.sqrt(a2) + math.sqrt(b2)


@njit()
def _cabs2(z: complex) -> float:
    return z.real * z.real + z.imag * z.imag


@njit()
def _csqrt(z: complex) -> complex:
    """Principal square root, the algorithm of numpy's ``sqrt`` (hypot-based, exact halving)."""
    x, y = z.real, z.imag
    if x == 0.0 and y == 0.0:
        return complex(0.0, y)
    t = math.sqrt((abs(x) + math.hypot(x, y)) * 0.5)
    if x >= 0.0:
        return complex(t, y / (2.0 * t))
    return complex(abs(y) / (2.0 * t), math.copysign(t, y))


@njit()
def _tracked(m1: complex, m2: complex, p1: complex, p2: complex, parity: bool, i: int) -> bool:
    """Branch tracking: whether sample ``i``'s eigenvalues ``(m1, m2)`` (``h + root``
    first) are stored swapped, given the previous sample's ``(p1, p2)`` and ``parity``."""
    if i > 0 and _crossed(m1, m2, p1, p2):
        return not parity
    return parity


@njit()
def _de(mu: complex, nkt: float) -> tuple[float, float]:
    """ZOA depth [m] and phase [rad] of one eigenvalue (``inf``, NaN off the branch)."""
    re = mu.real
    if re > 0.0:
        return _TWO_PI / (nkt * re), math.pi + 2.0 * math.atan(mu.imag / re)
    return np.inf, np.nan


@njit()
def _put(
    depth: FloatArray,
    eps: FloatArray,
    i: int,
    parity: bool,
    d1: float,
    e1: float,
    d2: float,
    e2: float,
) -> None:
    """Column ``i`` of the tracked rows: ``(d1, e1)`` of ``h + root`` on branch 0 unless swapped."""
    j1 = 1 if parity else 0
    depth[j1, i] = d1
    eps[j1, i] = e1
    depth[1 - j1, i] = d2
    eps[1 - j1, i] = e2


@njit()
def _eig_row(
    w: FloatArray,
    g: ComplexArray,
    al: FloatArray,
    teeth: int,
    kt: float,
    depth: FloatArray,
    eps: FloatArray,
) -> None:
    """Branch-tracked ZOA depth and phase of one waypoint (rows of ``depth``/``eps``)."""
    nf = w.shape[0]
    a00, a01, a10, a11 = al[0, 0], al[0, 1], al[1, 0], al[1, 1]
    da = a00 * a11 - a01 * a10
    p1 = 0j
    p2 = 0j
    parity = False
    nkt = teeth * kt
    for i in range(nf):
        g00, g01, g10, g11 = g[i, 0, 0], g[i, 0, 1], g[i, 1, 0], g[i, 1, 1]
        tr = a00 * g00 + a01 * g10 + a10 * g01 + a11 * g11
        det = da * (_cmul(g00, g11) - _cmul(g01, g10))
        h = 0.5 * tr
        root = _csqrt(_cmul(h, h) - det)
        m1 = h + root
        m2 = h - root
        parity = _tracked(m1, m2, p1, p2, parity, i)
        p1 = m1
        p2 = m2
        d1, e1 = _de(m1, nkt)
        d2, e2 = _de(m2, nkt)
        _put(depth, eps, i, parity, d1, e1, d2, e2)


@njit()
def _piece(
    w0: float,
    w1: float,
    e0: float,
    e1: float,
    a0: float,
    a1: float,
    c: float,
    s: FloatArray,
    uniform: bool,
    k1: int,
    env: FloatArray,
    q0: FloatArray,
    q1: FloatArray,
) -> None:
    """Intersect the lobes ``k < k1`` of one polyline segment with the speeds ``s``.

    ``q0``, ``q1`` (length >= ``k1``) are scratch: the lobes' end coordinates
    are formed in one loop over ``k`` first (divisions, vectorised by LLVM),
    then scattered. A value is never below the segment's lower end
    ``min(a0, a1)`` (the chord rounded there otherwise): skipping a segment
    whose lower end is at least the envelope then changes no value, so each
    speed's envelope is that of every segment, whatever the other speeds.
    """
    ns = s.shape[0]
    smin, smax = s[0], s[ns - 1]
    klo_f = np.ceil((c * min(w0, w1) / smax - max(e0, e1)) / _TWO_PI)
    khi_f = np.floor((c * max(w0, w1) / smin - min(e0, e1)) / _TWO_PI)
    klo = int(min(max(klo_f, 0.0), float(k1)))
    khi = int(min(max(khi_f, -1.0), float(k1 - 1)))
    nk = khi - klo + 1
    if nk <= 0:
        return
    cw0 = c * w0
    cw1 = c * w1
    if uniform:
        inv_ds = (ns - 1) / (smax - smin)
        for i in range(nk):
            twopik = _TWO_PI * (klo + i)
            q0[i] = (cw0 / (e0 + twopik) - smin) * inv_ds
            q1[i] = (cw1 / (e1 + twopik) - smin) * inv_ds
    else:
        for i in range(nk):
            twopik = _TWO_PI * (klo + i)
            q0[i] = cw0 / (e0 + twopik)
            q1[i] = cw1 / (e1 + twopik)
    top = float(ns)
    a_lo = min(a0, a1)
    for i in range(nk):
        p0 = q0[i]
        p1 = q1[i]
        if uniform:
            jlo = max(int(np.ceil(min(max(min(p0, p1), -1.0), top))), 0)
            jhi = min(int(np.floor(min(max(max(p0, p1), -1.0), top))), ns - 1)
        else:
            jlo = int(np.searchsorted(s, min(p0, p1), side="left"))
            jhi = int(np.searchsorted(s, max(p0, p1), side="right")) - 1
        if jhi < jlo:
            continue
        den = p1 - p0
        if den == 0.0:
            beta = 0.0
            alpha = a_lo
        else:
            beta = (a1 - a0) / den
            alpha = a0 - beta * p0
        if uniform:
            for jj in range(jlo, jhi + 1):
                env[jj] = min(env[jj], max(alpha + beta * jj, a_lo))
        else:
            for jj in range(jlo, jhi + 1):
                env[jj] = min(env[jj], max(alpha + beta * s[jj], a_lo))


@njit()
def _env_row(
    w: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    teeth: int,
    s: FloatArray,
    uniform: bool,
    k1: int,
    env: FloatArray,
    complete: bool = True,
) -> float:
    """Envelope of one waypoint's lobes on the sorted speeds ``s`` (into ``env``).

    Returns the speed above which lobes ``k >= k1`` cannot lower the
    envelope (as :func:`robolobe.sld.zoa._complete_above`); 0 without
    ``complete`` (exact queries need only the envelope).

    Pieces are visited in rising depth bands (the first below twice the
    smallest depth, each next one twice as high) until the band's lower edge
    reaches the highest envelope value so far: deeper pieces cannot lower the
    envelope anywhere, so the result is that of visiting every piece.
    """
    nf = w.shape[0]
    ns = s.shape[0]
    for jj in range(ns):
        env[jj] = np.inf
    if nf < 2 or ns == 0:
        return _complete(w, depth, eps, teeth, k1, env) if complete else 0.0
    c = 60.0 / teeth
    # the finite segments (branch j, interval i) and their lower depth, compacted
    seg = np.empty(2 * (nf - 1), dtype=np.int64)
    amin = np.empty(2 * (nf - 1))
    q0 = np.empty(k1)
    q1 = np.empty(k1)
    n_seg = 0
    rowmin = np.inf
    for j in range(2):
        for i in range(nf - 1):
            a0, a1 = depth[j, i], depth[j, i + 1]
            if np.isfinite(a0) and np.isfinite(a1):
                m = min(a0, a1)
                seg[n_seg] = j * nf + i
                amin[n_seg] = m
                n_seg += 1
                rowmin = min(rowmin, m)
    hi = 2.0 * rowmin
    top = np.inf
    while n_seg > 0:
        keep = 0
        for r in range(n_seg):
            m = amin[r]
            if m >= top:
                continue  # above the envelope everywhere: cannot lower it
            if m >= hi:
                seg[keep] = seg[r]  # a later band
                amin[keep] = m
                keep += 1
                continue
            j, i = divmod(seg[r], nf)
            _piece(
                w[i], w[i + 1], eps[j, i], eps[j, i + 1], depth[j, i], depth[j, i + 1], c, s,
                uniform, k1, env, q0, q1,
            )  # fmt: skip
        n_seg = keep
        top = -np.inf
        for jj in range(ns):
            top = max(top, env[jj])
        hi = 2.0 * hi
    return _complete(w, depth, eps, teeth, k1, env) if complete else 0.0


@njit()
def _complete(
    w: FloatArray, depth: FloatArray, eps: FloatArray, teeth: int, k1: int, env: FloatArray
) -> float:
    """Highest speed of lobe ``k1`` over the points below the envelope's top."""
    amax = -np.inf
    for jj in range(env.shape[0]):
        if np.isfinite(env[jj]):
            amax = max(amax, env[jj])
    if not np.isfinite(amax):
        amax = np.inf
    # the largest w / (eps + 2 pi k1), compared by cross-multiplication (one division)
    twopik = _TWO_PI * float(k1)
    wb = 0.0
    db = 1.0
    for j in range(2):
        for i in range(w.shape[0]):
            d = depth[j, i]
            if np.isfinite(d) and d < amax:
                den = eps[j, i] + twopik
                if w[i] * db > wb * den:
                    wb = w[i]
                    db = den
    out = 60.0 * wb / (teeth * db) if wb > 0.0 else 0.0
    return out


@njit(parallel=True)
def _zoa_batch(
    w: FloatArray,
    g: ComplexArray,
    al: FloatArray,
    teeth: int,
    kt: float,
    s: FloatArray,
    uniform: bool,
    k1: int,
    depth: FloatArray,
    eps: FloatArray,
    env: FloatArray,
    complete: FloatArray,
) -> None:
    """Fused ZOA per waypoint, parallel over waypoints (see the module docstring)."""
    for b in numba.prange(w.shape[0]):
        _eig_row(w[b], g[b], al[b], teeth, kt, depth[b], eps[b])
        complete[b] = _env_row(w[b], depth[b], eps[b], teeth, s, uniform, k1, env[b])


@njit(parallel=True)
def _env_batch(
    w: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    teeth: int,
    s: FloatArray,
    uniform: bool,
    k1: int,
    env: FloatArray,
    complete: FloatArray,
) -> None:
    """Envelope only (depth and phase given), parallel over waypoints."""
    for b in numba.prange(w.shape[0]):
        complete[b] = _env_row(w[b], depth[b], eps[b], teeth, s, uniform, k1, env[b])


def _sorted_speeds(rpm: FloatArray) -> tuple[FloatArray, NDArray[np.intp], bool]:
    order = np.argsort(rpm, kind="stable")
    s = np.ascontiguousarray(rpm[order])
    uniform = False
    if s.size >= 3:
        d = np.diff(s)
        uniform = bool(d[0] > 0 and np.all(np.abs(d - d[0]) <= 1e-9 * d[0]))
    return s, order, uniform


def _unsort(env: FloatArray, order: NDArray[np.intp]) -> FloatArray:
    if np.array_equal(order, np.arange(order.size)):
        return env
    out = np.empty_like(env)
    out[:, order] = env
    return out


def zoa_fused(
    omega: FloatArray,
    frf: ComplexArray,
    alpha: FloatArray,
    *,
    teeth: int,
    kt: float,
    rpm: FloatArray,
    max_lobe: int,
    out: tuple[FloatArray, FloatArray, FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Depth, phase and envelope of a flat batch with the compiled kernel.

    Parameters
    ----------
    omega : ndarray, shape (nb, n_freq)
        Sorted frequency grid per waypoint [rad/s].
    frf : ndarray, shape (nb, n_freq, 2, 2), complex
        Feed-frame receptance [m/N].
    alpha : ndarray, shape (nb, 2, 2)
        Directional factors.
    teeth, kt, max_lobe
        As in :func:`robolobe.sld.zoa.zoa_lobes`.
    rpm : ndarray, shape (n_speed,)
        Speeds [rpm], any order.
    out : tuple of ndarray, optional
        C-contiguous arrays of the four results' shapes to write into (with
        ``rpm`` sorted; e.g. slices of a larger batch's results).

    Returns
    -------
    depth, eps : ndarray, shape (nb, 2, n_freq)
        Limiting depth [m] (``inf`` off-branch) and phase [rad] (NaN there).
    a_lim : ndarray, shape (nb, n_speed)
        Envelope [m] at ``rpm``.
    complete : ndarray, shape (nb,)
        Speed [rpm] above which lobes beyond ``max_lobe`` cannot lower the
        envelope (0 where none can).
    """
    nb, nf = omega.shape
    s, order, uniform = _sorted_speeds(rpm)
    if out is not None:
        depth, eps, env, complete = out
        if not np.array_equal(order, np.arange(order.size)):
            raise InputError("zoa_fused: out= needs sorted speeds")
    else:
        depth = np.empty((nb, 2, nf))
        eps = np.empty((nb, 2, nf))
        env = np.empty((nb, s.size))
        complete = np.empty(nb)
    with _LOCK:
        _zoa_batch(
            np.ascontiguousarray(omega, dtype=np.float64),
            np.ascontiguousarray(frf, dtype=np.complex128),
            np.ascontiguousarray(alpha, dtype=np.float64),
            int(teeth),
            float(kt),
            s,
            uniform,
            int(max_lobe) + 1,
            depth,
            eps,
            env,
            complete,
        )
    return depth, eps, _unsort(env, order), complete


def envelope(
    omega: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    *,
    teeth: int,
    rpm: FloatArray,
    max_lobe: int,
) -> tuple[FloatArray, FloatArray]:
    """Envelope and ``complete`` of a flat batch from depth and phase (as :func:`zoa_fused`).

    Samples in single precision are read in blocks of :data:`_ENV_ROWS` entries,
    each made double for the kernel (no double copy of the whole batch).
    """
    nb = depth.shape[0]
    s, order, uniform = _sorted_speeds(rpm)
    env = np.empty((nb, s.size))
    complete = np.empty(nb)
    step = nb if omega.dtype == depth.dtype == eps.dtype == np.float64 else _ENV_ROWS
    with _LOCK:
        for b0 in range(0, nb, max(step, 1)):
            b1 = min(nb, b0 + step)
            _env_batch(
                np.ascontiguousarray(omega[b0:b1], dtype=np.float64),
                np.ascontiguousarray(depth[b0:b1], dtype=np.float64),
                np.ascontiguousarray(eps[b0:b1], dtype=np.float64),
                int(teeth),
                s,
                uniform,
                int(max_lobe) + 1,
                env[b0:b1],
                complete[b0:b1],
            )
    return _unsort(env, order), complete


#: Entries per block when :func:`envelope` reads single-precision samples.
_ENV_ROWS = 4096


@njit(parallel=True)
def _rows_batch(
    w: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    groups: NDArray[np.int64],
    order: NDArray[np.int64],
    run: NDArray[np.int64],
    teeth: int,
    speeds: FloatArray,
    k1: int,
    out: FloatArray,
) -> None:
    """Envelope of group ``groups[r]`` at the speeds ``speeds[r]`` (any order), per row.

    The rows ``order[run[u]:run[u + 1]]`` share one group: its lobes are
    visited once for all their speeds (each speed's value is that of its row
    alone, :func:`_piece`); the groups run in parallel.
    """
    m = speeds.shape[1]
    for u in numba.prange(run.shape[0] - 1):
        r0 = run[u]
        nr = run[u + 1] - r0
        g = groups[order[r0]]
        flat = np.empty(nr * m)
        for a in range(nr):
            r = order[r0 + a]
            for i in range(m):
                flat[a * m + i] = speeds[r, i]
        idx = np.argsort(flat, kind="mergesort")
        s = np.empty(nr * m)
        for t in range(nr * m):
            s[t] = flat[idx[t]]
        env = np.empty(nr * m)
        _env_row(w[g], depth[g], eps[g], teeth, s, False, k1, env, False)
        for t in range(nr * m):
            a, i = divmod(idx[t], m)
            out[order[r0 + a], i] = env[t]


def envelope_rows(
    omega: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    groups: NDArray[np.int64],
    *,
    teeth: int,
    rpm: FloatArray,
    max_lobe: int,
) -> FloatArray:
    """Envelope of some batch entries, each at its own speeds (exact queries).

    The compiled counterpart of ``lobe_envelope(omega[groups], depth[groups],
    eps[groups], rpm=rpm, ...)`` with one speed row per entry, without
    gathering the entries' lobe data. Rows of one entry are answered
    together (its lobes visited once); each row's values are those of the
    row asked alone.

    Parameters
    ----------
    omega : ndarray, shape (nb, n_freq)
        Frequency grid per batch entry [rad/s].
    depth, eps : ndarray, shape (nb, 2, n_freq)
        Depth [m] and phase [rad] per branch.
    groups : ndarray of int, shape (g,)
        Batch entry of each row.
    teeth, max_lobe : int
        As in :func:`robolobe.sld.lobes.lobe_envelope`.
    rpm : ndarray, shape (g, m)
        Speeds [rpm] per row, any order.

    Returns
    -------
    ndarray, shape (g, m)
        Limiting depth [m] (``inf`` where no lobe up to ``max_lobe`` crosses).
    """
    s = np.ascontiguousarray(rpm, dtype=np.float64)
    out = np.empty(s.shape)
    if s.size == 0:
        return out
    g = np.ascontiguousarray(groups, dtype=np.int64)
    order = np.argsort(g, kind="stable")
    gs = g[order]
    run = np.flatnonzero(np.r_[True, gs[1:] != gs[:-1], True]).astype(np.int64)
    with _LOCK:
        _rows_batch(
            polyline_samples(omega),
            polyline_samples(depth),
            polyline_samples(eps),
            g,
            order,
            run,
            int(teeth),
            s,
            int(max_lobe) + 1,
            out,
        )
    return out


# ----------------------------------------------------------------------------------
# Converged lobes: the refinement of each entry's frequency samples
# (robolobe.sld.converged: the numpy path and the rule; this is the same rule per entry)

#: As robolobe.sld.converged.PREFILTER (a piece whose ends lie deeper than this multiple
#: of the relevance bound is not examined).
_PREFILTER = 2.0


@njit()
def _eig_pt(
    w: float, om: FloatArray, ze: FloatArray, res: FloatArray, al: FloatArray
) -> tuple[complex, complex]:
    """The two eigenvalues of ``alpha G(w)`` (untracked, ``h + root`` first)."""
    g00 = 0j
    g01 = 0j
    g10 = 0j
    g11 = 0j
    for r in range(om.shape[0]):
        wr = om[r]
        # 1 / (re + i im) = (re - i im) / (re^2 + im^2), as converged._eig_at forms it
        re = wr * wr - w * w
        im = 2.0 * (ze[r] * wr) * w
        q = 1.0 / (re * re + im * im)
        inv = complex(re * q, -im * q)
        g00 += inv * res[r, 0, 0]
        g01 += inv * res[r, 0, 1]
        g10 += inv * res[r, 1, 0]
        g11 += inv * res[r, 1, 1]
    a00, a01, a10, a11 = al[0, 0], al[0, 1], al[1, 0], al[1, 1]
    tr = a00 * g00 + a01 * g10 + a10 * g01 + a11 * g11
    det = (a00 * a11 - a01 * a10) * (g00 * g11 - g01 * g10)
    h = 0.5 * tr
    root = _csqrt(h * h - det)
    return h + root, h - root


@njit()
def _eig_many(
    w: FloatArray,
    om: FloatArray,
    ze: FloatArray,
    res: FloatArray,
    al: FloatArray,
    m1: ComplexArray,
    m2: ComplexArray,
) -> None:
    """:func:`_eig_pt` at every sample of ``w`` (into ``m1``, ``m2``): the same operations
    in the same order per sample (the same values), the modes outer and the samples
    inner, so that the sums over the modes run vectorised over the samples."""
    n = w.shape[0]
    g = np.zeros((8, n))  # real and imaginary parts of g00, g01, g10, g11
    for r in range(om.shape[0]):
        wr = om[r]
        zw = ze[r] * wr
        r00, r01, r10, r11 = res[r, 0, 0], res[r, 0, 1], res[r, 1, 0], res[r, 1, 1]
        for i in range(n):
            re = wr * wr - w[i] * w[i]
            im = 2.0 * zw * w[i]
            q = 1.0 / (re * re + im * im)
            x = re * q
            y = -im * q
            g[0, i] += x * r00
            g[1, i] += y * r00
            g[2, i] += x * r01
            g[3, i] += y * r01
            g[4, i] += x * r10
            g[5, i] += y * r10
            g[6, i] += x * r11
            g[7, i] += y * r11
    a00, a01, a10, a11 = al[0, 0], al[0, 1], al[1, 0], al[1, 1]
    for i in range(n):
        g00 = complex(g[0, i], g[1, i])
        g01 = complex(g[2, i], g[3, i])
        g10 = complex(g[4, i], g[5, i])
        g11 = complex(g[6, i], g[7, i])
        tr = a00 * g00 + a01 * g10 + a10 * g01 + a11 * g11
        det = (a00 * a11 - a01 * a10) * (g00 * g11 - g01 * g10)
        h = 0.5 * tr
        root = _csqrt(h * h - det)
        m1[i] = h + root
        m2[i] = h - root


@njit()
def _reach(
    c: float, wl: float, wr: float, e_lo: float, e_hi: float, smin: float, smax: float, kmax: int
) -> tuple[float, float]:
    klo = math.ceil((c * wl / smax - e_hi) / _TWO_PI)
    khi = math.floor((c * wr / smin - e_lo) / _TWO_PI)
    return min(max(klo, 0.0), kmax + 1.0), min(max(khi, -1.0), float(kmax))


@njit()
def _chord_bad(
    wl: float,
    wr: float,
    a_l: float,
    e_l: float,
    a_r: float,
    e_r: float,
    a_m: float,
    e_m: float,
    bound: float,
    c: float,
    smin: float,
    smax: float,
    kmax: int,
    chord_tol: float,
    speed_tol: float,
) -> bool:
    """One branch of :func:`robolobe.sld.converged._split_mask` for one interval."""
    fl = a_l < np.inf
    fr = a_r < np.inf
    fm = a_m < np.inf
    if fl and fr:
        e_lo = min(e_l, e_r)
        e_hi = max(e_l, e_r)
        amin = min(a_l, a_r)
        if fm:
            e_lo = min(e_lo, e_m)
            e_hi = max(e_hi, e_m)
            amin = min(amin, a_m)
        klo, khi = _reach(c, wl, wr, e_lo, e_hi, smin, smax, kmax)
        if not (khi >= klo and amin < bound):
            return False
        if not fm:
            return True
        wm = 0.5 * (wl + wr)
        for q in range(3):
            k = klo if q == 0 else (khi if q == 1 else math.floor(0.5 * (klo + khi)))
            tk = _TWO_PI * k
            n_l = c * wl / (e_l + tk)
            n_r = c * wr / (e_r + tk)
            n_m = c * wm / (e_m + tk)
            lo_n = min(n_l, n_r)
            hi_n = max(n_l, n_r)
            if max(hi_n, n_m) < smin * (1 - 1e-3) or min(lo_n, n_m) > smax * (1 + 1e-3):
                continue
            if n_m >= lo_n and n_m <= hi_n and hi_n > lo_n:
                chord = a_l + (a_r - a_l) * (n_m - n_l) / (n_r - n_l)
                err = abs(a_m - chord) / min(a_m, chord)
                if not (err <= chord_tol):
                    return True
            else:
                err = max(lo_n - n_m, n_m - hi_n) / n_m
                if not (err <= speed_tol):
                    return True
        return False
    if fl or fr:
        a_f = a_l if fl else a_r
        e_f = e_l if fl else e_r
        e_x = 0.0 if e_f < math.pi else _TWO_PI
        klo, khi = _reach(c, wl, wr, min(e_f, e_x), max(e_f, e_x), smin, smax, kmax)
        return khi >= klo and a_f < bound
    return False


@njit()
def _piece_candidate(
    wl: float,
    wr: float,
    a_l: float,
    e_l: float,
    a_r: float,
    e_r: float,
    bound: float,
    c: float,
    smin: float,
    smax: float,
    kmax: int,
) -> bool:
    """One branch of :func:`robolobe.sld.converged._candidates` for one interval."""
    fl = a_l < np.inf
    fr = a_r < np.inf
    if fl and fr:
        klo, khi = _reach(c, wl, wr, min(e_l, e_r), max(e_l, e_r), smin, smax, kmax)
        return khi >= klo and min(a_l, a_r) < _PREFILTER * bound
    return fl or fr


@njit()
def _bound_row(
    w: FloatArray,
    m1: ComplexArray,
    m2: ComplexArray,
    nkt: float,
    teeth: int,
    s: FloatArray,
    uniform: bool,
    k1: int,
    relevant: float,
    depth_span: float,
) -> float:
    """The relevance bound of one entry from its (untracked) eigenvalues at ``w``.

    As :func:`robolobe.sld.converged.converged_lobes` forms it from the lobes on
    the initial samples: ``relevant`` x the highest envelope value, at most
    ``depth_span`` x the smallest depth (that alone where the envelope is not
    finite everywhere).
    """
    nf = w.shape[0]
    depth = np.empty((2, nf))
    eps = np.empty((2, nf))
    env = np.empty(s.shape[0])
    p1 = 0j
    p2 = 0j
    parity = False
    dmin = np.inf
    for i in range(nf):
        parity = _tracked(m1[i], m2[i], p1, p2, parity, i)
        p1 = m1[i]
        p2 = m2[i]
        d1, e1 = _de(p1, nkt)
        d2, e2 = _de(p2, nkt)
        _put(depth, eps, i, parity, d1, e1, d2, e2)
        dmin = min(dmin, d1, d2)
    _env_row(w, depth, eps, teeth, s, uniform, k1, env, False)
    amax = -np.inf
    full = True
    for jj in range(env.shape[0]):
        if env[jj] < np.inf:
            amax = max(amax, env[jj])
        else:
            full = False
    cap = depth_span * dmin
    if full:
        return min(relevant * amax, cap)
    return cap


@njit(parallel=True)
def _refine_batch(
    om: FloatArray,
    ze: FloatArray,
    res: FloatArray,
    al: FloatArray,
    w0: FloatArray,
    start: NDArray[np.int64],
    count: NDArray[np.int64],
    bound: FloatArray,
    c: float,
    nkt: float,
    smin: float,
    smax: float,
    kmax: int,
    chord_tol: float,
    speed_tol: float,
    max_depth: int,
    s: FloatArray,
    uniform: bool,
    relevant: float,
    depth_span: float,
    out: FloatArray,
    dep: FloatArray,
    eps: FloatArray,
    n_out: NDArray[np.int64],
    status: NDArray[np.int64],
) -> None:
    """Each entry's samples halved where :func:`_chord_bad` says so (after
    :func:`_piece_candidate`), depth first.

    A NaN ``bound[b]`` is formed first (:func:`_bound_row`, written back).
    ``status``: 0 done, 1 out of room (``out`` too short), 2 at ``max_depth``
    halvings or the resolution of doubles. A finished row ``b`` is padded up to
    the room: copies of its last frequency, depth ``inf`` and phase NaN.
    """
    cap = out.shape[1]
    teeth = round(60.0 / c)
    for b in numba.prange(om.shape[0]):
        o, z, rs, a = om[b], ze[b], res[b], al[b]
        s0 = start[b]
        nc = count[b]
        wi = w0[s0 : s0 + nc]
        mi1 = np.empty(nc, np.complex128)
        mi2 = np.empty(nc, np.complex128)
        _eig_many(wi, o, z, rs, a, mi1, mi2)
        wmid = np.empty(max(nc - 1, 0))
        for i in range(nc - 1):
            wmid[i] = 0.5 * (wi[i] + wi[i + 1])
        mm1 = np.empty(wmid.shape[0], np.complex128)
        mm2 = np.empty(wmid.shape[0], np.complex128)
        _eig_many(wmid, o, z, rs, a, mm1, mm2)
        if np.isnan(bound[b]):
            bound[b] = _bound_row(
                wi, mi1, mi2, nkt, teeth, s, uniform, kmax + 1, relevant, depth_span
            )
        bd = bound[b]
        # the right ends still to visit: frequency, eigenvalues, depth and phase, level
        nd = max_depth + 2
        sw = np.empty(nd)
        s1 = np.empty(nd, np.complex128)
        s2 = np.empty(nd, np.complex128)
        sa = np.empty((nd, 4))
        lev = np.empty(nd, np.int64)
        n = 0
        st = 0
        wl = wi[0]
        l1 = mi1[0]
        l2 = mi2[0]
        la1, le1 = _de(l1, nkt)
        la2, le2 = _de(l2, nkt)
        # branch tracking of the samples as they are written (the rule of _eig_row)
        p1 = 0j
        p2 = 0j
        parity = False
        for i in range(1, nc):
            if st != 0:
                break
            top = 0
            sw[0] = wi[i]
            s1[0] = mi1[i]
            s2[0] = mi2[i]
            sa[0, 0], sa[0, 1] = _de(mi1[i], nkt)
            sa[0, 2], sa[0, 3] = _de(mi2[i], nkt)
            lev[0] = 0
            fresh = True
            while top >= 0:
                wr = sw[top]
                # the right end's branches in the left end's order
                sw_r = _crossed(s1[top], s2[top], l1, l2)
                ra1, re1, ra2, re2 = sa[top, 0], sa[top, 1], sa[top, 2], sa[top, 3]
                if sw_r:
                    ra1, re1, ra2, re2 = ra2, re2, ra1, re1
                split = False
                if _piece_candidate(
                    wl, wr, la1, le1, ra1, re1, bd, c, smin, smax, kmax
                ) or _piece_candidate(wl, wr, la2, le2, ra2, re2, bd, c, smin, smax, kmax):
                    wm = 0.5 * (wl + wr)
                    if fresh:  # the initial interval (wi[i - 1], wi[i]) itself
                        m1, m2 = mm1[i - 1], mm2[i - 1]
                        fresh = False
                    else:
                        m1, m2 = _eig_pt(wm, o, z, rs, a)
                    ma1, me1 = _de(m1, nkt)
                    ma2, me2 = _de(m2, nkt)
                    if _crossed(m1, m2, l1, l2):
                        ma1, me1, ma2, me2 = ma2, me2, ma1, me1
                    split = _chord_bad(
                        wl, wr, la1, le1, ra1, re1, ma1, me1, bd, c, smin, smax, kmax,
                        chord_tol, speed_tol,
                    ) or _chord_bad(
                        wl, wr, la2, le2, ra2, re2, ma2, me2, bd, c, smin, smax, kmax,
                        chord_tol, speed_tol,
                    )  # fmt: skip
                    if split:
                        if lev[top] >= max_depth or wr - wl <= 1e-12 * wl:
                            st = 2
                            break
                        top += 1
                        sw[top] = wm
                        s1[top] = m1
                        s2[top] = m2
                        # (depth and phase in m's own order, as stored for every point)
                        sa[top, 0], sa[top, 1] = _de(m1, nkt)
                        sa[top, 2], sa[top, 3] = _de(m2, nkt)
                        lev[top] = lev[top - 1] + 1
                        continue
                if n >= cap - 1:
                    st = 1
                    break
                parity = _tracked(l1, l2, p1, p2, parity, n)
                p1 = l1
                p2 = l2
                out[b, n] = wl
                _put(dep[b], eps[b], n, parity, la1, le1, la2, le2)
                n += 1
                wl = wr
                l1 = s1[top]
                l2 = s2[top]
                la1, le1, la2, le2 = sa[top, 0], sa[top, 1], sa[top, 2], sa[top, 3]
                top -= 1
        if st == 0:
            parity = _tracked(l1, l2, p1, p2, parity, n)
            out[b, n] = wl
            _put(dep[b], eps[b], n, parity, la1, le1, la2, le2)
            n += 1
            # the padding, written here while the row is in cache: copies of the last
            # frequency, off every branch (no lobe piece)
            for j in range(n, cap):
                out[b, j] = wl
                dep[b, 0, j] = np.inf
                dep[b, 1, j] = np.inf
                eps[b, 0, j] = np.nan
                eps[b, 1, j] = np.nan
        n_out[b] = n
        status[b] = st


def refine(
    om: FloatArray,
    ze: FloatArray,
    res: FloatArray,
    al: FloatArray,
    w0: FloatArray,
    start: NDArray[np.int64],
    count: NDArray[np.int64],
    bound: FloatArray,
    *,
    teeth: int,
    nkt: float,
    smin: float,
    smax: float,
    kmax: int,
    chord_tol: float,
    speed_tol: float,
    max_depth: int,
    cap: int,
    rpm: FloatArray,
    relevant: float,
    depth_span: float,
    out: tuple[FloatArray, FloatArray, FloatArray] | None = None,
) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.int64], NDArray[np.int64], FloatArray]:
    """Refined samples per entry (see :func:`robolobe.sld.converged.converged_lobes`).

    Returns ``out`` (nb, cap) (row ``b`` valid up to ``n_out[b]``, then padded:
    copies of its last frequency, depth ``inf``, phase NaN, off every branch), the
    branch-tracked depth and phase there (nb, 2, cap), ``n_out``, ``status``
    (0 done, 1 needs more than ``cap`` samples, 2 unconverged) and the bounds
    used (NaN entries of ``bound``: formed from the initial samples and the
    speeds ``rpm``). ``out``: C-contiguous arrays of shapes (nb, cap), (nb, 2, cap)
    and (nb, 2, cap) to write the samples, depth and phase into.
    """
    nb = om.shape[0]
    if out is None:
        out = (np.empty((nb, cap)), np.empty((nb, 2, cap)), np.empty((nb, 2, cap)))
    w_o, dep, eps = out
    if w_o.shape != (nb, cap) or not (w_o.flags.c_contiguous and dep.flags.c_contiguous):
        raise InputError("refine: out= arrays of the wrong shape or not contiguous")
    n_out = np.zeros(nb, np.int64)
    status = np.zeros(nb, np.int64)
    bd = np.array(bound, dtype=np.float64)
    s, _, uniform = _sorted_speeds(np.asarray(rpm, dtype=np.float64))
    with _LOCK:
        _refine_batch(
            np.ascontiguousarray(om, dtype=np.float64),
            np.ascontiguousarray(ze, dtype=np.float64),
            np.ascontiguousarray(res, dtype=np.float64),
            np.ascontiguousarray(al, dtype=np.float64),
            np.ascontiguousarray(w0, dtype=np.float64),
            np.ascontiguousarray(start, dtype=np.int64),
            np.ascontiguousarray(count, dtype=np.int64),
            bd,
            60.0 / teeth,
            float(nkt),
            float(smin),
            float(smax),
            int(kmax),
            float(chord_tol),
            float(speed_tol),
            int(max_depth),
            s,
            uniform,
            float(relevant),
            float(depth_span),
            w_o,
            dep,
            eps,
            n_out,
            status,
        )
    return w_o, dep, eps, n_out, status, bd


# ----------------------------------------------------------------------------------
# Lobe pieces at a speed near the envelope (robolobe.plan.lobes._lobe_pieces_at: the
# numpy reference, the same arithmetic and the same pieces)


@njit()
def _crossing(
    w0: float, w1: float, e0: float, e1: float, a0: float, a1: float, k: float, c: float, n: float
) -> tuple[bool, float, float, float]:
    """Whether lobe ``k`` of a piece crosses speed ``n``; its depth, frequency, phase there."""
    n0 = c * w0 / (e0 + _TWO_PI * k)
    n1 = c * w1 / (e1 + _TWO_PI * k)
    if not (np.isfinite(n0) and np.isfinite(n1) and n0 > 0 and n1 > 0):
        return False, 0.0, 0.0, 0.0
    t = (n - n0) / (n1 - n0) if n1 != n0 else 0.0
    t = min(max(t, 0.0), 1.0)
    depth = max(a0 + t * (a1 - a0), min(a0, a1))
    return True, depth, w0 + t * (w1 - w0), e0 + t * (e1 - e0)


@njit()
def _pieces_pass(
    w: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    g: NDArray[np.int64],
    rpm: FloatArray,
    top: FloatArray,
    within: float,
    teeth: int,
    max_lobe: int,
    low: FloatArray,
    count: NDArray[np.int64],
    out: FloatArray,
    fill: bool,
) -> None:
    """One pass over the rows' pieces: their smallest crossing (``low``, when not
    ``fill``), or the crossings within ``within`` of it counted (``count``) and, with
    ``fill``, written into ``out`` (rows of row, omega, depth, eps, k, span) from
    ``count``'s offsets."""
    c = 60.0 / teeth
    nf = w.shape[1]
    pos = 0
    for r in range(g.shape[0]):
        e = g[r]
        n = rpm[r]
        lim = within * top[r]
        cut = within * low[r]
        for j in range(2):
            for i in range(nf - 1):
                a0 = depth[e, j, i]
                a1 = depth[e, j, i + 1]
                if not (np.isfinite(a0) and np.isfinite(a1)) or min(a0, a1) > lim:
                    continue
                w0 = w[e, i]
                w1 = w[e, i + 1]
                e0 = eps[e, j, i]
                e1 = eps[e, j, i + 1]
                k0 = (c * w0 / n - e0) / _TWO_PI
                k1 = (c * w1 / n - e1) / _TWO_PI
                if not (np.isfinite(k0) and np.isfinite(k1)):
                    continue
                klo = max(np.ceil(min(k0, k1)), 0.0)
                khi = min(np.floor(max(k0, k1)), float(max_lobe))
                k = klo
                while k <= khi:
                    ok, d, om, ph = _crossing(w0, w1, e0, e1, a0, a1, k, c, n)
                    if ok:
                        if count[r] < 0:
                            low[r] = min(low[r], d)
                        elif d <= cut:
                            if fill:
                                out[pos, 0] = r
                                out[pos, 1] = om
                                out[pos, 2] = d
                                out[pos, 3] = ph
                                out[pos, 4] = k
                                out[pos, 5] = w1 - w0
                                pos += 1
                            else:
                                count[r] += 1
                    k += 1.0


def near_pieces(
    omega: FloatArray,
    depth: FloatArray,
    eps: FloatArray,
    g: NDArray[np.int64],
    rpm: FloatArray,
    top: FloatArray,
    *,
    within: float,
    teeth: int,
    max_lobe: int,
) -> FloatArray:
    """The lobe pieces near the envelope of entries ``g`` at speeds ``rpm`` (one per row).

    The compiled counterpart of :func:`robolobe.plan.lobes._lobe_pieces_at` with
    ``top`` (r,) the bound of each row's entry (the highest over its rows).
    Returns (p, 6): row, omega, depth, eps, lobe k, span of each piece.
    """
    w = polyline_samples(omega)
    gg = np.ascontiguousarray(g, dtype=np.int64)
    s = np.ascontiguousarray(rpm, dtype=np.float64)
    tp = np.ascontiguousarray(top, dtype=np.float64)
    a = polyline_samples(depth)
    e = polyline_samples(eps)
    low = np.full(gg.size, np.inf)
    count = np.full(gg.size, -1, np.int64)
    dummy = np.zeros((0, 6))
    _pieces_pass(w, a, e, gg, s, tp, within, teeth, max_lobe, low, count, dummy, False)
    count[:] = 0
    _pieces_pass(w, a, e, gg, s, tp, within, teeth, max_lobe, low, count, dummy, False)
    out = np.empty((int(count.sum()), 6))
    _pieces_pass(w, a, e, gg, s, tp, within, teeth, max_lobe, low, count, out, True)
    return out
