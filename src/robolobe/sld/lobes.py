"""Lobe diagrams: the envelope of the stability lobes on a speed grid, and queries.

The zero-order solution gives, per eigenvalue branch ``j`` and chatter
frequency ``w``, a limiting depth ``a_j(w)`` and a phase ``eps_j(w)``; lobe
``k`` is the curve ``(n_k(w), a_j(w))`` with ``n_k = 60 w / (N (eps + 2 k pi))``
[rpm]. Each lobe is taken as the polyline through its samples on the
frequency grid (no smoothing). The envelope at a speed ``n`` is the smallest
depth at which any lobe polyline crosses ``n``: every polyline segment is
intersected with the speeds it spans, exactly, whether or not the lobe is
monotonic in ``w``. Branches, lobes and frequencies are processed as
arrays; the batch in chunks of a few entries (to stay in cache), each chunk
vectorised. Two exact shortcuts keep it fast: for each polyline piece only
the lobes whose speeds can reach the speed range are formed, and pieces are
visited in rising depth bands, stopping once every entry's envelope lies
below the band (deeper pieces cannot change it).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError

__all__ = ["LobeDiagram", "lobe_envelope", "lobe_speeds"]

FloatArray = NDArray[np.float64]

_TWO_PI = 2.0 * np.pi
# (segment x lobe) entries handled per chunk of batch entries
_CHUNK = 1 << 16


def lobe_speeds(omega: ArrayLike, eps: ArrayLike, k: ArrayLike, teeth: int) -> FloatArray:
    """Spindle speed of lobe ``k`` at chatter frequency ``omega``.

    ``T = (eps + 2 k pi) / omega`` (tooth period, s) and ``n = 60 / (N T)``.

    Parameters
    ----------
    omega : array_like
        Chatter frequency [rad/s].
    eps : array_like
        Phase between inner and outer modulation [rad], in ``(0, 2 pi)``.
    k : array_like of int
        Lobe number (0, 1, ...).
    teeth : int
        Number of teeth N.

    Returns
    -------
    ndarray
        Spindle speed [rpm] (broadcast of the inputs).
    """
    w = np.asarray(omega, dtype=np.float64)
    e = np.asarray(eps, dtype=np.float64)
    kk = np.asarray(k, dtype=np.float64)
    return np.asarray(60.0 * w / (teeth * (e + _TWO_PI * kk)))


def _ragged(counts: NDArray[np.int64]) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """Owner and offset of every element of a ragged expansion of ``counts``."""
    total = int(counts.sum())
    owner = np.repeat(np.arange(counts.size), counts)
    offset = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts)
    return owner, offset


def _is_uniform(s: FloatArray) -> bool:
    if s.ndim != 1 or s.size < 3:
        return False
    d = np.diff(s)
    return bool(d[0] > 0 and np.all(np.abs(d - d[0]) <= 1e-9 * d[0]))


def lobe_envelope(
    omega: ArrayLike,
    depth: ArrayLike,
    eps: ArrayLike,
    *,
    teeth: int,
    rpm: ArrayLike,
    max_lobe: int,
) -> FloatArray:
    """Envelope (minimum over lobes and branches) of the lobe polylines at given speeds.

    Parameters
    ----------
    omega : array_like, shape (n_freq,) or (..., n_freq)
        Sorted chatter-frequency grid [rad/s] (per batch entry or shared).
    depth : array_like, shape (..., n_branch, n_freq)
        Limiting depth ``a(w)`` [m] per branch; ``inf`` (or NaN) where the
        branch has no positive solution.
    eps : array_like, shape (..., n_branch, n_freq)
        Phase ``eps(w)`` [rad] per branch.
    teeth : int
        Number of teeth N.
    rpm : array_like, shape (n_speed,) or (..., n_speed)
        Speeds [rpm] at which to evaluate: one grid for all batch entries or
        one row per entry. Any order.
    max_lobe : int
        Highest lobe number K (lobes ``k = 0..K``).

    Returns
    -------
    ndarray, shape (..., n_speed)
        Smallest limiting depth [m] at each speed; ``inf`` where no lobe
        (up to K) crosses that speed.
    """
    a = np.asarray(depth, dtype=np.float64)
    e = np.asarray(eps, dtype=np.float64)
    if a.ndim < 2 or a.shape != e.shape:
        raise InputError(
            f"depth/eps: expected equal shapes (..., n_branch, n_freq), found {a.shape}, {e.shape}"
        )
    batch = a.shape[:-2]
    nj, nf = a.shape[-2:]
    w = np.asarray(omega, dtype=np.float64)
    if w.shape[-1] != nf:
        raise InputError(f"omega: expected {nf} frequencies, found shape {w.shape}")
    s = np.asarray(rpm, dtype=np.float64)
    if s.ndim == 0:
        s = s[None]
    shared = s.ndim == 1
    n_speed = s.shape[-1]
    nb = int(np.prod(batch)) if batch else 1
    a2 = a.reshape(nb, nj, nf)
    e2 = e.reshape(nb, nj, nf)
    w2 = np.broadcast_to(w, (*batch, nf)).reshape(nb, nf)
    if shared:
        order = np.argsort(s, kind="stable")
        s_sorted = s[order]
        s2 = None
    else:
        try:
            s_b = np.broadcast_to(s, (*batch, n_speed)).reshape(nb, n_speed)
        except ValueError as exc:
            raise InputError(
                f"rpm: expected shape (n_speed,) or {(*batch, n_speed)}, found {s.shape}"
            ) from exc
        order = np.argsort(s_b, axis=-1, kind="stable")
        s2 = np.take_along_axis(s_b, order, axis=-1)
        s_sorted = s2
    out_sorted = np.full((nb, n_speed), np.inf)
    if n_speed == 0 or nf < 2:
        return out_sorted.reshape(*batch, n_speed)
    k1 = max_lobe + 1
    per_entry = max(nj * (nf - 1) * min(k1, 8), 1)
    cb = max(1, _CHUNK // per_entry)
    c = 60.0 / teeth
    uniform = shared and _is_uniform(s_sorted)
    flat_out = out_sorted.ravel()
    for b0 in range(0, nb, cb):  # chunks bound memory; each chunk is fully vectorised
        b1 = min(nb, b0 + cb)
        ac, ec, wc = a2[b0:b1], e2[b0:b1], w2[b0:b1]
        fin = np.isfinite(ac)
        ok = fin[..., :-1] & fin[..., 1:]
        bb, jj, ii = np.nonzero(ok)
        if bb.size == 0:
            continue
        w0 = wc[bb, ii]
        w1 = wc[bb, ii + 1]
        e0 = ec[bb, jj, ii]
        e1 = ec[bb, jj, ii + 1]
        a0 = ac[bb, jj, ii]
        a1 = ac[bb, jj, ii + 1]
        # lobes whose speeds on this segment can reach the speed range (exact bound)
        if shared:
            smin: float | FloatArray = float(s_sorted[0])
            smax: float | FloatArray = float(s_sorted[-1])
        else:
            assert s2 is not None
            smin, smax = s2[b0 + bb, 0], s2[b0 + bb, -1]
        klo = np.ceil((c * np.minimum(w0, w1) / smax - np.maximum(e0, e1)) / _TWO_PI)
        khi = np.floor((c * np.maximum(w0, w1) / smin - np.minimum(e0, e1)) / _TWO_PI)
        klo = np.clip(klo, 0, k1).astype(np.int64)
        khi = np.clip(khi, -1, k1 - 1).astype(np.int64)
        v, off = _ragged(np.maximum(khi - klo + 1, 0))
        if v.size == 0:
            continue
        twopik = _TWO_PI * (klo[v] + off)
        with np.errstate(divide="ignore", invalid="ignore"):
            n0 = c * w0[v] / (e0[v] + twopik)
            n1 = c * w1[v] / (e1[v] + twopik)
        # eps + 2 k pi = 0 (lobe 0 at zero phase) puts an end of the piece at infinite
        # speed: outside any grid, and a straight piece through it would be NaN
        fin_piece = np.isfinite(n0) & np.isfinite(n1) & (n0 > 0) & (n1 > 0)
        if not np.all(fin_piece):
            v, twopik, n0, n1 = v[fin_piece], twopik[fin_piece], n0[fin_piece], n1[fin_piece]
            if v.size == 0:
                continue
        if uniform:
            s0 = float(s_sorted[0])
            ds = (float(s_sorted[-1]) - s0) / (n_speed - 1)
            x0 = (n0 - s0) / ds
            x1 = (n1 - s0) / ds
            jlo = np.ceil(np.clip(np.minimum(x0, x1), -1.0, n_speed)).astype(np.int64)
            jhi = np.floor(np.clip(np.maximum(x0, x1), -1.0, n_speed)).astype(np.int64)
            np.maximum(jlo, 0, out=jlo)
            np.minimum(jhi, n_speed - 1, out=jhi)
        elif shared:
            jlo = np.searchsorted(s_sorted, np.minimum(n0, n1), side="left")
            jhi = np.searchsorted(s_sorted, np.maximum(n0, n1), side="right") - 1
        else:
            assert s2 is not None
            sm = float(np.max(np.abs(s2[b0:b1]))) + 1.0
            gap = 4.0 * sm
            flat_s = (s2[b0:b1] + (np.arange(b1 - b0) * gap)[:, None]).ravel()
            row = bb[v]
            base = row * gap
            jlo = np.searchsorted(flat_s, np.clip(np.minimum(n0, n1), -2 * sm, 2 * sm) + base)
            jhi = (
                np.searchsorted(
                    flat_s, np.clip(np.maximum(n0, n1), -2 * sm, 2 * sm) + base, side="right"
                )
                - 1
            )
            jlo -= row * n_speed
            jhi -= row * n_speed
        # each entry is a straight piece a = alpha + beta * coordinate (x or rpm)
        p0, p1 = (x0, x1) if uniform else (n0, n1)
        av0, av1 = a0[v], a1[v]
        den = p1 - p0
        flat_piece = den == 0.0
        beta = np.divide(av1 - av0, den, out=np.zeros_like(den), where=~flat_piece)
        alpha = np.where(flat_piece, np.minimum(av0, av1), av0 - beta * p0)
        cnt = np.maximum(jhi - jlo + 1, 0)
        live = np.flatnonzero(cnt > 0)
        if live.size == 0:
            continue
        row = bb[v[live]]  # row within the chunk
        amin = np.minimum(av0, av1)[live]
        alpha, beta, jlo, cnt = alpha[live], beta[live], jlo[live], cnt[live]
        rowbase = (b0 + row) * n_speed
        # Pieces whose smallest depth is above the envelope everywhere cannot
        # change it. Process pieces in rising depth bands until every row's
        # envelope so far lies below the band edge: the rest is then provably
        # irrelevant (the result is the same as processing all pieces).
        nrow = b1 - b0
        rowmin = np.full(nrow, np.inf)
        np.minimum.at(rowmin, row, amin)
        tau = 8.0 * rowmin
        todo = np.ones(live.size, dtype=bool)
        while True:
            sel = np.flatnonzero(todo & (amin < tau[row]))
            if sel.size:
                todo[sel] = False
                c_sel = cnt[sel]
                q = np.repeat(sel, c_sel)
                js = np.arange(q.size) + np.repeat(jlo[sel] - (np.cumsum(c_sel) - c_sel), c_sel)
                if uniform:
                    coord = js.astype(np.float64)
                elif shared:
                    coord = s_sorted[js]
                else:
                    coord = s_sorted.ravel()[rowbase[q] + js]
                # never below the piece's lower end (rounding): skipping a piece
                # above the envelope then changes no value
                val = np.maximum(alpha[q] + beta[q] * coord, amin[q])
                np.minimum.at(flat_out, rowbase[q] + js, val)
            rowmax = out_sorted[b0:b1].max(axis=1)
            open_row = rowmax > tau
            rest = todo & open_row[row] & (amin < rowmax[row])
            if not np.any(rest):
                break
            todo &= rest
            tau = np.where(open_row, np.minimum(4.0 * tau, rowmax), tau)
    out = np.empty_like(out_sorted)
    if shared:
        out[:, order] = out_sorted
    else:
        np.put_along_axis(out, order, out_sorted, axis=-1)
    return out.reshape(*batch, n_speed)


@dataclass(frozen=True, eq=False)
class LobeDiagram:
    """Stability lobes of one or many tool-point FRFs (batch shape ``(...)``).

    Parameters
    ----------
    rpm : ndarray, shape (n_speed,)
        Spindle-speed grid [rpm].
    a_lim : ndarray, shape (..., n_speed)
        Limiting axial depth [m] on the grid (``inf``: no lobe crosses).
    teeth : int
        Number of teeth N.
    method : {"zoa", "sdm"}
        Solver that produced it.
    immersion : float
        Radial immersion ``a_e / D``.
    valid : bool
        False where the method is known to be unreliable (ZOA below
        ``a_e / D = 0.2``); ``message`` says why.
    message : str
        Empty when valid.
    max_lobe : int
        Highest lobe number included (ZOA).
    omega : ndarray, shape (n_freq,) or (..., n_freq), optional
        Chatter-frequency grid [rad/s] (ZOA).
    depth, eps : ndarray, shape (..., 2, n_freq), optional
        Limiting depth [m] and phase [rad] per eigenvalue branch (ZOA).
    complete_above_rpm : ndarray, shape (...), optional
        Above this speed lobes beyond ``max_lobe`` cannot lower the envelope
        (ZOA); below it the envelope may be too high.
    """

    rpm: FloatArray
    a_lim: FloatArray
    teeth: int
    method: str = "zoa"
    immersion: float = 1.0
    valid: bool = True
    message: str = ""
    max_lobe: int = 30
    omega: FloatArray | None = None
    depth: FloatArray | None = None
    eps: FloatArray | None = None
    complete_above_rpm: FloatArray | None = field(default=None)

    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Batch shape ``(...)``."""
        return tuple(self.a_lim.shape[:-1])

    @property
    def a_crit(self) -> FloatArray:
        """Smallest depth on the frequency grid over all branches [m], shape (...).

        For ZOA this is the sampled minimum of ``a(w)`` (use
        :func:`robolobe.sld.zoa.critical_depth` for the refined value); for
        SDM the minimum over the speed grid.
        """
        if self.depth is not None:
            d = np.where(np.isfinite(self.depth), self.depth, np.inf)
            return np.asarray(d.min(axis=(-1, -2)))
        return np.asarray(self.a_lim.min(axis=-1))

    def minimum(self) -> tuple[FloatArray, FloatArray]:
        """Smallest envelope depth on the speed grid and its speed.

        Returns
        -------
        (ndarray, ndarray), shapes (...) and (...)
            ``a_min`` [m] and ``rpm`` at which it occurs.
        """
        i = np.argmin(self.a_lim, axis=-1)
        return (
            np.take_along_axis(self.a_lim, i[..., None], axis=-1)[..., 0],
            np.asarray(self.rpm[i]),
        )

    def query(self, rpm: ArrayLike) -> FloatArray:
        """Limiting depth [m] at arbitrary speeds.

        For ZOA the lobe polylines are intersected with the given speeds
        exactly as on the grid (no interpolation of the grid envelope). For
        SDM, which has no lobe curves, the grid envelope is interpolated
        linearly (outside the grid: ``nan``).

        Parameters
        ----------
        rpm : array_like, shape (m,) or (..., m)
            Speeds [rpm]: shared by all batch entries or one row per entry.

        Returns
        -------
        ndarray, shape (..., m)
        """
        r = np.asarray(rpm, dtype=np.float64)
        scalar = r.ndim == 0
        if scalar:
            r = r[None]
        if self.depth is not None and self.eps is not None and self.omega is not None:
            out = lobe_envelope(
                self.omega, self.depth, self.eps, teeth=self.teeth, rpm=r, max_lobe=self.max_lobe
            )
        else:
            a = self.a_lim.reshape(-1, self.rpm.size)
            rr = np.broadcast_to(r, (*self.batch_shape, r.shape[-1])).reshape(a.shape[0], -1)
            out = np.stack(
                [
                    np.interp(rr[i], self.rpm, a[i], left=np.nan, right=np.nan)
                    for i in range(a.shape[0])
                ]
            ).reshape(*self.batch_shape, r.shape[-1])
        return out[..., 0] if scalar else out

    def lobe(self, k: int) -> tuple[FloatArray, FloatArray]:
        """Curve of lobe ``k`` per branch (ZOA only).

        Returns
        -------
        (ndarray, ndarray), shapes (..., 2, n_freq)
            Speed [rpm] and depth [m] (``inf`` where the branch has no
            positive solution).
        """
        if self.depth is None or self.eps is None or self.omega is None:
            raise InputError(
                f"lobe: only ZOA results carry lobe curves, this one is {self.method!r}"
            )
        w = np.asarray(self.omega)[..., None, :]
        return lobe_speeds(w, self.eps, k, self.teeth), self.depth

    def take(self, index: int) -> LobeDiagram:
        """One batch entry (first batch axis)."""
        import dataclasses

        def pick(x: FloatArray | None, nd: int) -> FloatArray | None:
            if x is None or np.ndim(x) <= nd:
                return x
            return np.asarray(x[index])

        return dataclasses.replace(
            self,
            a_lim=np.asarray(self.a_lim[index]),
            omega=pick(self.omega, 1),
            depth=pick(self.depth, 2),
            eps=pick(self.eps, 2),
            complete_above_rpm=pick(self.complete_above_rpm, 0),
        )
