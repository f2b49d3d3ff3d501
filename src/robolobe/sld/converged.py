"""Zero-order lobes of modal dynamics, converged in frequency (the one lobe computation).

The zero-order solution (:mod:`robolobe.sld.zoa`) turns frequency samples of
the tool-point receptance into lobe polylines ``(n_k(w), a(w))`` and
intersects them with the speed grid. How well the envelope is resolved then
rests on the samples alone: a fixed grid (so many points per mode) leaves a
lobe's end unresolved where its speed runs off fast, above all the k = 0 tail
of a low-frequency (robot) mode at high spindle speed, which lives at phases
``eps -> 0`` within a sliver of the resonance.

:func:`converged_lobes` starts from the modal grid of each batch entry
(the rule of :func:`robolobe.sld.frf.frequency_grid` for that entry's own
modes, its range widened to the tooth-passing frequencies) and halves every
interval of a branch whose lobes reach the speed range below the
envelope until

- the sample in the middle of the interval lies within :data:`CHORD_TOL`
  (relative depth, at its own speed) of the straight piece between its ends,
  for the lowest, the highest and a middle lobe number that reach the speed
  range; where the middle sample's speed falls outside the piece (a lobe
  folding back in speed), until it lies within :data:`SPEED_TOL` (relative
  speed) of it;
- at an end of a branch (``Re mu`` crossing zero: the depth rises to infinity,
  and for ``eps -> 0`` lobe 0's speed too), until the last sample is deeper
  than the envelope's relevance bound or lobe 0's speed there is above the range;

considering only pieces whose smallest depth lies below :data:`RELEVANT`
times the highest envelope value of that entry (the envelope on the initial
samples; formed again on the refined ones, and the refinement repeated where
it came out higher), and only intervals whose ends lie below
:data:`PREFILTER` times that. The compiled kernel
(:func:`robolobe.sld._kernels.refine`, depth first per entry) and the numpy
path (breadth first over the batch) apply the same rule. The stated result
(:data:`LOBE_TOL`): the envelope at every speed of the grid, and at any
speed queried later, lies within 0.5 % of the envelope of the exact lobes of
the model (tests: an independent textbook ZOA solved per speed,
``tests/sld/zoa_reference.py``, in ``tests/sld/test_converged.py``: property
tests over random modal models; ``tests/plan/test_converged_plans.py``: every
waypoint of the bundled plans).

Modes that cannot be resolved this way in reasonable time (damping below
:data:`ZETA_MIN`, frequency above :data:`F_MAX_HZ`) are refused with an
:class:`~robolobe.errors.InputError` naming the mode; a refinement that does
not settle within :data:`MAX_PASSES` halvings is refused the same way, never
returned unconverged.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe.errors import InputError
from robolobe.sld import zoa as _zoa
from robolobe.sld.frf import ModalModel, _mode_window
from robolobe.sld.lobes import LobeDiagram
from robolobe.sld.zoa import (
    _kernels,
    lobes_from_depth,
    zoa_depth,
    zoa_eigenvalues,
    zoa_lobes,
)

__all__ = [
    "CHORD_TOL",
    "F_MAX_HZ",
    "LOBE_TOL",
    "SPEED_TOL",
    "ZETA_MIN",
    "check_resolvable",
    "converged_lobes",
]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]
IntArray = NDArray[np.int64]

_TWO_PI = 2.0 * math.pi

#: The stated convergence tolerance: relative error of ``a_lim`` at any speed.
LOBE_TOL = 0.005
#: Largest relative depth error of a lobe piece at its middle sample (refinement target).
CHORD_TOL = 1e-3
#: Largest relative speed by which a lobe folding back may overshoot its pieces.
SPEED_TOL = 1e-5
#: Pieces deeper than this multiple of the highest envelope value are left alone.
RELEVANT = 1.5
#: Intervals whose two ends lie deeper than this multiple of the bound get no middle
#: sample (between two phase-resolved samples a lobe is not twice as deep).
PREFILTER = 2.0
#: Without a finite envelope value, pieces deeper than this multiple of the smallest
#: depth are left alone.
DEPTH_SPAN = 1e4
#: Halving passes before the refinement is declared unconverged.
MAX_PASSES = 64
#: Smallest damping ratio accepted (below, a resonance needs ~1/zeta samples).
ZETA_MIN = 1e-5
#: Highest natural frequency accepted [Hz].
F_MAX_HZ = 1e6
#: Most frequency samples one batch entry may need.
MAX_SAMPLES = 200_000
#: Points per decade of the base grid and per mode window (see ``frequency_grid``).
_PER_DECADE = 40
_PER_MODE = 33
_HALF_WIDTH = 25.0
#: Entries refined per call of the compiled kernel (bounds its working arrays).
_REFINE_CHUNK = 1024
#: Frequency samples whose FRFs are formed at once (bounds the temporaries).
_EVAL_CHUNK = 1 << 15


def check_resolvable(model: ModalModel) -> None:
    """Refuse modes whose lobes cannot be resolved to :data:`LOBE_TOL` in reasonable time.

    Raises
    ------
    InputError
        Naming the first such mode (batch entry, mode index, f, zeta) and the limit.
    """
    present = np.any(model.residues != 0.0, axis=(-1, -2))
    f = model.f_hz
    bad_z = present & (model.zeta < ZETA_MIN)
    bad_f = present & (f > F_MAX_HZ)
    for bad, what in (
        (bad_z, f"damping ratio >= {ZETA_MIN:g}"),
        (bad_f, f"natural frequency <= {F_MAX_HZ:g} Hz"),
    ):
        if np.any(bad):
            idx = np.argwhere(bad)[0]
            at = f" (batch entry {tuple(int(i) for i in idx[:-1])})" if idx.size > 1 else ""
            r = int(idx[-1])
            raise InputError(
                f"mode {r + 1}{at}: f = {float(f[tuple(idx)]):.6g} Hz, zeta = "
                f"{float(model.zeta[tuple(idx)]):.3g}: its lobes cannot be resolved to "
                f"{LOBE_TOL:.1%}; expected a {what}"
            )


def _initial_grid(
    om: FloatArray, ze: FloatArray, present: NDArray[np.bool_], w_speed: tuple[float, float]
) -> tuple[FloatArray, IntArray]:
    """Per entry: a log base grid over its own modes' range plus a window per mode.

    The rule of :func:`robolobe.sld.frf.frequency_grid` applied to each entry's
    own present modes, so that an entry's samples do not depend on the rest of
    the batch; the range widened to ``w_speed`` (from a quarter of the lowest
    to twice the highest tooth-passing frequency [rad/s]): above the modes,
    lobe 0 of the mass line (``eps`` near pi) sits at ``n = 60 w / (N pi)``,
    which a stiff tool or a fast spindle can put in the speed range.

    Returns
    -------
    grid : ndarray, shape (nb, n)
        Each row sorted, its ``count`` samples first, then NaN.
    count : ndarray of int, shape (nb,)
    """
    any_p = np.any(present, axis=1)
    wp = np.where(present, om, np.nan)
    safe = np.where(any_p[:, None], wp, 1.0)
    lo = np.minimum(0.5 * np.nanmin(safe, axis=1), w_speed[0])
    hi = np.maximum(2.0 * np.nanmax(safe, axis=1), w_speed[1])
    n_base = np.maximum(np.ceil(_PER_DECADE * np.log10(hi / lo)).astype(np.int64) + 1, 2)
    nbm = int(n_base.max())
    j = np.arange(nbm)[None, :]
    t = j / (n_base[:, None] - 1.0)
    base = np.where(j < n_base[:, None], lo[:, None] * (hi / lo)[:, None] ** t, np.nan)
    s = _mode_window(_PER_MODE, _HALF_WIDTH)
    width = np.minimum(ze * _HALF_WIDTH, np.log(2.0)) / _HALF_WIDTH
    win = om[..., None] * np.exp(width[..., None] * s)  # (nb, m, P)
    win = np.clip(win, lo[:, None, None], hi[:, None, None])
    win = np.where(present[..., None], win, np.nan).reshape(om.shape[0], -1)
    grid = np.sort(np.concatenate([base, win], axis=1), axis=1)  # NaN last
    count = n_base + _PER_MODE * present.sum(axis=1)
    return grid, count.astype(np.int64)


def _eig_at(
    om: FloatArray,
    ze: FloatArray,
    res: FloatArray,
    al: FloatArray,
    rows: IntArray,
    w: FloatArray,
) -> ComplexArray:
    """Eigenvalues of ``alpha G(w)`` at the samples ``(rows, w)``, shape (P, 2), untracked.

    The same closed form as :func:`robolobe.sld.zoa.zoa_eigenvalues`.
    """
    out = np.empty((w.size, 2), np.complex128)
    for s in range(0, w.size, _EVAL_CHUNK):
        r = rows[s : s + _EVAL_CHUNK]
        ww = w[s : s + _EVAL_CHUNK, None]
        wr = om[r]
        re = wr * wr - ww * ww
        im = 2.0 * (ze[r] * wr) * ww
        q = 1.0 / (re * re + im * im)
        inv = re * q - 1j * (im * q)
        g = np.einsum("pm,pmij->pij", inv, res[r])
        a = al[r]
        tr = (
            a[:, 0, 0] * g[:, 0, 0]
            + a[:, 0, 1] * g[:, 1, 0]
            + a[:, 1, 0] * g[:, 0, 1]
            + a[:, 1, 1] * g[:, 1, 1]
        )
        det = (a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]) * (
            g[:, 0, 0] * g[:, 1, 1] - g[:, 0, 1] * g[:, 1, 0]
        )
        h = 0.5 * tr
        root = np.sqrt(h * h - det)
        out[s : s + _EVAL_CHUNK, 0] = h + root
        out[s : s + _EVAL_CHUNK, 1] = h - root
    return out


def _follow(ref: ComplexArray, mu: ComplexArray) -> ComplexArray:
    """``mu`` (P, 2) with its two values ordered to continue the branches of ``ref``.

    The pairing rule of :func:`robolobe.sld.zoa.zoa_eigenvalues` (smaller sum of distances).
    """
    same = np.abs(mu[:, 0] - ref[:, 0]) + np.abs(mu[:, 1] - ref[:, 1])
    cross = np.abs(mu[:, 0] - ref[:, 1]) + np.abs(mu[:, 1] - ref[:, 0])
    swap = cross < same
    return np.where(swap[:, None], mu[:, ::-1], mu)


def _depth_eps(mu: ComplexArray, nkt: float) -> tuple[FloatArray, FloatArray]:
    re = mu.real
    pos = re > 0.0
    safe = np.where(pos, re, 1.0)
    return (
        np.where(pos, _TWO_PI / (nkt * safe), np.inf),
        np.where(pos, np.pi + 2.0 * np.arctan(mu.imag / safe), np.nan),
    )


def _split_mask(
    w: FloatArray,
    rows: IntArray,
    mu: ComplexArray,
    i: IntArray,
    mu_mid: ComplexArray,
    bound: FloatArray,
    *,
    teeth: int,
    nkt: float,
    smin: float,
    smax: float,
    kmax: int,
) -> NDArray[np.bool_]:
    """Which intervals ``[w[i], w[i + 1]]`` (of one row each) need their middle sample."""
    c = 60.0 / teeth
    mu_l = mu[i]
    mu_r = _follow(mu_l, mu[i + 1])
    mu_m = _follow(mu_l, mu_mid)
    a_l, e_l = _depth_eps(mu_l, nkt)  # (P, 2)
    a_r, e_r = _depth_eps(mu_r, nkt)
    a_m, e_m = _depth_eps(mu_m, nkt)
    w_l = w[i][:, None]
    w_r = w[i + 1][:, None]
    w_m = 0.5 * (w_l + w_r)
    fin_l, fin_r, fin_m = np.isfinite(a_l), np.isfinite(a_r), np.isfinite(a_m)
    b = bound[rows[i]][:, None]
    big = np.inf

    def reach(e_lo: FloatArray, e_hi: FloatArray) -> tuple[FloatArray, FloatArray]:
        klo = np.ceil((c * w_l / smax - e_hi) / _TWO_PI)
        khi = np.floor((c * w_r / smin - e_lo) / _TWO_PI)
        return np.clip(klo, 0, kmax + 1), np.clip(khi, -1, kmax)

    split = np.zeros(a_l.shape, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        # both ends on the branch: the middle sample against the straight piece
        both = fin_l & fin_r
        em_ok = np.where(fin_m, e_m, np.nan)
        e_lo = np.fmin(np.fmin(e_l, e_r), em_ok)
        e_hi = np.fmax(np.fmax(e_l, e_r), em_ok)
        klo, khi = reach(e_lo, e_hi)
        amin = np.fmin(np.minimum(a_l, a_r), np.where(fin_m, a_m, big))
        rel = both & (khi >= klo) & (amin < b)
        hole = rel & ~fin_m  # the branch leaves and comes back inside: resolve it
        check = rel & fin_m
        bad = np.zeros(a_l.shape, bool)
        for k in (klo, khi, np.floor(0.5 * (klo + khi))):
            tk = _TWO_PI * k
            n_l = c * w_l / (e_l + tk)
            n_r = c * w_r / (e_r + tk)
            n_m = c * w_m / (e_m + tk)
            lo_n = np.minimum(n_l, n_r)
            hi_n = np.maximum(n_l, n_r)
            meets = (np.maximum(hi_n, n_m) >= smin * (1 - 1e-3)) & (
                np.minimum(lo_n, n_m) <= smax * (1 + 1e-3)
            )
            inside = (n_m >= lo_n) & (n_m <= hi_n) & (hi_n > lo_n)
            chord = a_l + (a_r - a_l) * (n_m - n_l) / (n_r - n_l)
            err_a = np.abs(a_m - chord) / np.minimum(a_m, chord)
            err_n = np.maximum(lo_n - n_m, n_m - hi_n) / n_m
            bad |= meets & np.where(inside, ~(err_a <= CHORD_TOL), ~(err_n <= SPEED_TOL))
        split |= hole | (check & bad)
        # one end on the branch: its depth rises to infinity towards the other end
        # (and for eps -> 0 lobe 0's speed too): close in while it can matter
        edge = fin_l ^ fin_r
        a_f = np.where(fin_l, a_l, a_r)
        e_f = np.where(fin_l, e_l, e_r)
        e_x = np.where(e_f < np.pi, 0.0, _TWO_PI)
        klo, khi = reach(np.minimum(e_f, e_x), np.maximum(e_f, e_x))
        split |= edge & (khi >= klo) & (a_f < b)
    return np.asarray(split.any(axis=1))


def _candidates(
    w: FloatArray,
    rows: IntArray,
    mu: ComplexArray,
    i: IntArray,
    bound: FloatArray,
    *,
    teeth: int,
    nkt: float,
    smin: float,
    smax: float,
    kmax: int,
) -> NDArray[np.bool_]:
    """Intervals worth a middle sample, from their ends: an end of a branch, or a
    branch piece whose lobes reach the speeds and whose ends lie less than
    :data:`PREFILTER` times the bound deep."""
    c = 60.0 / teeth
    mu_l = mu[i]
    mu_r = _follow(mu_l, mu[i + 1])
    a_l, e_l = _depth_eps(mu_l, nkt)
    a_r, e_r = _depth_eps(mu_r, nkt)
    fin_l, fin_r = np.isfinite(a_l), np.isfinite(a_r)
    w_l = w[i][:, None]
    w_r = w[i + 1][:, None]
    with np.errstate(invalid="ignore"):
        klo = np.clip(np.ceil((c * w_l / smax - np.fmax(e_l, e_r)) / _TWO_PI), 0, kmax + 1)
        khi = np.clip(np.floor((c * w_r / smin - np.fmin(e_l, e_r)) / _TWO_PI), -1, kmax)
        piece = (
            fin_l
            & fin_r
            & (khi >= klo)
            & (np.minimum(a_l, a_r) < PREFILTER * bound[rows[i]][:, None])
        )
    return np.asarray((piece | (fin_l ^ fin_r)).any(axis=1))


def _refine(
    om: FloatArray,
    ze: FloatArray,
    res: FloatArray,
    al: FloatArray,
    w: FloatArray,
    rows: IntArray,
    bound: FloatArray,
    *,
    teeth: int,
    nkt: float,
    smin: float,
    smax: float,
    kmax: int,
) -> tuple[FloatArray, IntArray]:
    """Halve intervals until no interval needs its middle sample (flat, sorted by row, w)."""
    mu = _eig_at(om, ze, res, al, rows, w)
    active = np.r_[rows[1:] == rows[:-1], False]
    for _ in range(MAX_PASSES):
        i = np.flatnonzero(active)
        kw = dict(teeth=teeth, nkt=nkt, smin=smin, smax=smax, kmax=kmax)
        cand = _candidates(w, rows, mu, i, bound, **kw)  # type: ignore[arg-type]
        active[i[~cand]] = False
        i = i[cand]
        if i.size == 0:
            return w, rows
        w_mid = 0.5 * (w[i] + w[i + 1])
        mu_mid = _eig_at(om, ze, res, al, rows[i], w_mid)
        split = _split_mask(
            w, rows, mu, i, mu_mid, bound,
            teeth=teeth, nkt=nkt, smin=smin, smax=smax, kmax=kmax,
        )  # fmt: skip
        # an interval at the resolution of doubles cannot be halved any more
        tiny = (w[i + 1] - w[i]) <= 1e-12 * w[i]
        if np.any(split & tiny):
            r = int(rows[i[np.flatnonzero(split & tiny)[0]]])
            _unconverged(om, ze, r, "the frequency samples reached the resolution of doubles")
        active[i] = split
        if not np.any(split):
            return w, rows
        j = np.flatnonzero(split)
        w = np.concatenate([w, w_mid[j]])
        rows = np.concatenate([rows, rows[i[j]]])
        mu = np.concatenate([mu, mu_mid[j]])
        active = np.concatenate([active, np.ones(j.size, bool)])
        order = np.lexsort((w, rows))
        w, rows, mu, active = w[order], rows[order], mu[order], active[order]
        counts = np.bincount(rows, minlength=om.shape[0])
        if counts.max() > MAX_SAMPLES:
            _unconverged(
                om, ze, int(np.argmax(counts)), f"more than {MAX_SAMPLES} frequency samples"
            )
    r = int(rows[np.flatnonzero(active)[0]])
    _unconverged(om, ze, r, f"{MAX_PASSES} halvings")
    raise AssertionError  # pragma: no cover


def _unconverged(om: FloatArray, ze: FloatArray, row: int, why: str) -> None:
    m = int(np.argmin(ze[row]))
    raise InputError(
        f"lobes of batch entry {row} not resolved to {LOBE_TOL:.1%} ({why}); its least "
        f"damped mode {m + 1}: f = {om[row, m] / _TWO_PI:.6g} Hz, zeta = {ze[row, m]:.3g}"
    )


def _room(count: IntArray) -> int:
    """Samples per entry the results are made with (more where an entry needs more):
    the initial samples and a quarter again (at least 128 more)."""
    return int(count.max()) + max(128, int(count.max()) // 4)


def _padded(w: FloatArray, rows: IntArray, nb: int, width: int = 0) -> FloatArray:
    """Flat sorted samples as (nb, max(n_max, width)), each row padded with copies of its
    last value."""
    counts = np.bincount(rows, minlength=nb)
    n = max(int(counts.max()), width)
    start = np.r_[0, np.cumsum(counts)[:-1]]
    pos = np.arange(w.size) - start[rows]
    out = np.empty((nb, n))
    out[rows, pos] = w
    last = w[start + counts - 1]
    col = np.arange(n)[None, :]
    return np.where(col < counts[:, None], out, last[:, None])


def _pad(w2: FloatArray, dep: FloatArray, eps: FloatArray, rows: IntArray | slice, k: int) -> None:
    """Pad ``rows`` from column ``k`` on: copies of column ``k - 1``'s frequency, depth
    ``inf`` and phase NaN (off every branch: no lobe piece)."""
    if k >= w2.shape[1]:
        return
    w2[rows, k:] = w2[rows, k - 1 : k]
    dep[rows, :, k:] = np.inf
    eps[rows, :, k:] = np.nan


def _widened(
    w2: FloatArray, dep: FloatArray, eps: FloatArray, n: int, rows: int | None = None
) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The padded result arrays (nb, k), (nb, 2, k) made ``n`` wide, the new columns
    padded; only the first ``rows`` rows copied and padded (the others not written yet)."""
    nb, k = w2.shape
    m = nb if rows is None else rows
    dt = w2.dtype  # single precision stays so (converged_lobes' ``single_from``)
    out = (np.empty((nb, n), dt), np.empty((nb, 2, n), dt), np.empty((nb, 2, n), dt))
    out[0][:m, :k] = w2[:m]
    out[1][:m, :, :k] = dep[:m]
    out[2][:m, :, :k] = eps[:m]
    _pad(*out, slice(0, m), k)
    return out


def converged_lobes(
    model: ModalModel,
    alpha: ArrayLike,
    *,
    teeth: int,
    kt: float,
    rpm: ArrayLike,
    max_lobe: int | None = None,
    immersion: float = 1.0,
    max_lobe_cap: int = 400,
    jit: bool | None = None,
    single_from: int | None = None,
) -> LobeDiagram:
    """Zero-order lobes of modal dynamics whose envelope is converged to :data:`LOBE_TOL`.

    Parameters
    ----------
    model : ModalModel
        2-D feed-frame dynamics, any batch shape.
    alpha : array_like, shape (2, 2) or (..., 2, 2)
        Directional factors.
    teeth : int
        Number of teeth N.
    kt : float
        Tangential cutting coefficient [N/m^2].
    rpm : array_like, shape (n_speed,)
        Speed grid [rpm]; the lobes are resolved over its range.
    max_lobe : int or None, default None
        Highest lobe number; None: every lobe that reaches the lowest speed
        (at most ``max_lobe_cap``), as in :func:`robolobe.sld.zoa.zoa_lobes`.
    immersion : float
        ``a_e / D`` (the validity flag).
    max_lobe_cap : int
        Upper bound of the automatic lobe number.
    jit : bool or None
        As in :func:`robolobe.sld.zoa.zoa_lobes` (same envelopes either way).
    single_from : int or None
        Store the polylines (``omega``, ``depth``, ``eps``) in single
        precision when the result holds at least this many samples per array
        (entries x samples; compiled path only): each sample is computed in
        double precision and rounded when stored (relative 6e-8), and the
        envelope ``a_lim`` is formed from the stored samples, so the grid and
        any later query of the polylines agree. Halves the result's memory
        (a 1e6-waypoint plan: ~260 MB less at the lobe stage's peak).

    Returns
    -------
    LobeDiagram
        Batch shape of the model; ``omega`` holds each entry's own refined
        samples (rows padded with copies of their last value).

    Raises
    ------
    InputError
        A mode beyond :func:`check_resolvable`'s limits, or a refinement that
        does not settle.
    """
    if model.dim != 2:
        raise InputError(f"model: expected 2-D (feed-frame) dynamics, found dim {model.dim}")
    check_resolvable(model)
    r = np.asarray(rpm, dtype=np.float64)
    if r.ndim != 1 or r.size < 1 or not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError("rpm: expected a 1-D grid of positive speeds")
    if isinstance(teeth, bool) or int(teeth) != teeth or teeth < 1:
        raise InputError(f"teeth: expected an integer >= 1, found {teeth!r}")
    if not (np.isfinite(kt) and kt > 0):
        raise InputError(f"kt: expected a positive coefficient in N/m^2, found {kt!r}")
    a = np.asarray(alpha, dtype=np.float64)
    if a.shape[-2:] != (2, 2):
        raise InputError(f"alpha: expected shape (..., 2, 2), found {a.shape}")
    batch = np.broadcast_shapes(model.batch_shape, a.shape[:-2])
    nb = math.prod(batch)
    m = model.n_modes
    om = np.broadcast_to(model.omega, (*batch, m)).reshape(nb, m)
    ze = np.broadcast_to(model.zeta, (*batch, m)).reshape(nb, m)
    res = np.broadcast_to(model.residues, (*batch, m, 2, 2)).reshape(nb, m, 2, 2)
    al = np.ascontiguousarray(np.broadcast_to(a, (*batch, 2, 2)).reshape(nb, 2, 2))
    present = np.any(res != 0.0, axis=(-1, -2))
    smin, smax = float(r.min()), float(r.max())
    nkt = float(teeth) * float(kt)
    w_tooth = _TWO_PI * float(teeth) / 60.0  # tooth-passing frequency per rpm [rad/s]
    grid, count = _initial_grid(om, ze, present, (0.25 * w_tooth * smin, 2.0 * w_tooth * smax))
    w_top = float(np.nanmax(grid)) if grid.size else 1.0
    kmax = (
        int(max_lobe)
        if max_lobe is not None
        else int(min(max_lobe_cap, np.ceil(w_top * 60.0 / (teeth * smin * _TWO_PI))))
    )
    flat = ModalModel(om, ze, res)
    # the threshold of zoa_lobes (read at call time: one switch for both)
    use_jit = _zoa._use_kernels(nb * grid.shape[1]) if jit is None else bool(jit)
    kern = _kernels() if use_jit else None

    def lobes(w2: FloatArray, k: int | None) -> LobeDiagram:
        def synth(start: int, stop: int) -> ComplexArray:
            return flat.take(slice(start, stop)).frf(w2[start:stop])

        return zoa_lobes(
            w2, synth, alpha=al, teeth=int(teeth), kt=float(kt), rpm=r,
            max_lobe=k, immersion=immersion, max_lobe_cap=max_lobe_cap, jit=use_jit,
        )  # fmt: skip

    def bound_of(d: LobeDiagram) -> FloatArray:
        env = np.where(np.isfinite(d.a_lim), d.a_lim, -np.inf).max(axis=-1)
        assert d.depth is not None
        # depths are positive or inf; NaN left out (one pass, no temporaries of its size)
        dmin = np.fmin.reduce(d.depth.reshape(*d.depth.shape[:-2], -1), axis=-1)
        dmin = np.where(np.isnan(dmin), np.inf, dmin)
        cap = DEPTH_SPAN * dmin
        full = np.all(np.isfinite(d.a_lim), axis=-1)
        return np.asarray(np.where(full, np.minimum(RELEVANT * env, cap), cap))

    def refined(bound: FloatArray) -> tuple[LobeDiagram, FloatArray]:
        """The lobes on the samples refined for ``bound`` and the bound (NaN entries:
        formed from the lobes on the initial samples)."""
        kw = dict(teeth=int(teeth), nkt=nkt, smin=smin, smax=smax, kmax=kmax)
        if kern is None:
            if np.any(np.isnan(bound)):
                first = np.where(np.isfinite(grid), grid, np.nanmax(grid, axis=1, keepdims=True))
                bound = bound_of(lobes(first, kmax))
            ok = np.isfinite(grid)
            rows = np.broadcast_to(np.arange(nb, dtype=np.int64)[:, None], grid.shape)[ok]
            w, rows = _refine(om, ze, res, al, grid[ok], rows, bound, **kw)  # type: ignore[arg-type]
            w2 = _padded(w, rows, nb, _room(count))
            mu = zoa_eigenvalues(flat.frf(w2), al)
            depth, eps = zoa_depth(mu, teeth=int(teeth), kt=float(kt))
            fill = np.arange(w2.shape[1])[None, :] >= np.bincount(rows, minlength=nb)[:, None]
            return finish(w2, depth, eps, fill, False), bound
        start = np.arange(nb, dtype=np.int64) * grid.shape[1]
        w0 = np.where(np.isfinite(grid), grid, 0.0).ravel()
        bound = bound.copy()
        n_all = np.zeros(nb, np.int64)
        # written straight into the result, one room for every entry (a guess from the
        # initial samples, corrected after the first chunk); the few entries that need
        # more are refined again wider. The kernel pads each row up to its room.
        width = _room(count)
        single = single_from is not None and nb * width >= single_from
        dt = np.float32 if single else np.float64
        w2 = np.empty((nb, width), dt)
        dep = np.empty((nb, 2, width), dt)
        eps = np.empty((nb, 2, width), dt)
        wide: list[tuple[IntArray, FloatArray, FloatArray, FloatArray]] = []
        for c0 in range(0, nb, _REFINE_CHUNK):
            c1 = min(nb, c0 + _REFINE_CHUNK)
            todo = np.arange(c0, c1)
            room = width
            while todo.size:
                into = None
                if room == width:
                    # single precision: the kernel writes a chunk in double, stored rounded
                    into = (
                        (w2[c0:c1], dep[c0:c1], eps[c0:c1])
                        if not single
                        else (np.empty((c1 - c0, width)), np.empty((c1 - c0, 2, width)),
                              np.empty((c1 - c0, 2, width)))
                    )  # fmt: skip
                o_w, o_d, o_e, n_out, status, bound[todo] = kern.refine(
                    om[todo], ze[todo], res[todo], al[todo], w0, start[todo], count[todo],
                    bound[todo], chord_tol=CHORD_TOL, speed_tol=SPEED_TOL,
                    max_depth=MAX_PASSES, cap=room, rpm=r, relevant=RELEVANT,
                    depth_span=DEPTH_SPAN, out=into, **kw,
                )  # fmt: skip
                if single and room == width:
                    w2[c0:c1], dep[c0:c1], eps[c0:c1] = o_w, o_d, o_e
                if np.any(status == 2):
                    bad = int(todo[np.flatnonzero(status == 2)[0]])
                    _unconverged(om, ze, bad, f"{MAX_PASSES} halvings")
                ok = status == 0
                n_all[todo[ok]] = n_out[ok]
                if room != width:
                    k = int(n_out[ok].max(initial=1))
                    wide.append((todo[ok], o_w[ok, :k], o_d[ok, :, :k], o_e[ok, :, :k]))
                del o_w, o_d, o_e
                todo = todo[~ok]
                if todo.size and room >= MAX_SAMPLES:
                    _unconverged(om, ze, int(todo[0]), f"more than {MAX_SAMPLES} samples")
                room = min(4 * room, MAX_SAMPLES)
            if c0 == 0 and c1 < nb and wide:
                # the first chunk outgrew the guess: the rest of the batch (the same path,
                # most likely) gets its widest row and a sixteenth more, so that the whole
                # result is not copied into wider arrays at the end (10k-waypoint plan:
                # guess 584, first chunk 623, the others at most 621)
                n_first = int(n_all[:c1].max())
                grown = min(n_first + n_first // 16, MAX_SAMPLES)
                w2, dep, eps = _widened(w2, dep, eps, grown, rows=c1)
                width = grown
        n = int(n_all.max())
        if n > width:  # some entries needed more room still: widen (rare)
            w2, dep, eps = _widened(w2, dep, eps, n)
        for rows, wb, db, eb in wide:
            k = wb.shape[1]
            w2[rows, :k], dep[rows, :, :k], eps[rows, :, :k] = wb, db, eb
            _pad(w2, dep, eps, rows, k)
        del wide
        return finish(w2, dep, eps, None, True), bound

    def finish(
        w2: FloatArray,
        depth: FloatArray,
        eps: FloatArray,
        fill: NDArray[np.bool_] | None,
        jit: bool,
    ) -> LobeDiagram:
        # the padding (copies of a row's last sample) is off every branch: no lobe piece
        # (``fill`` None: padded so already)
        if fill is not None:
            f2 = np.broadcast_to(fill[:, None, :], depth.shape)
            np.copyto(depth, np.inf, where=f2)
            np.copyto(eps, np.nan, where=f2)
        return lobes_from_depth(
            w2, depth, eps, teeth=int(teeth), rpm=r, max_lobe=max_lobe, immersion=immersion,
            max_lobe_cap=max_lobe_cap, jit=jit,
        )  # fmt: skip

    bound = np.full(nb, np.nan)
    diag: LobeDiagram | None = None
    for _ in range(4):
        diag = None  # the previous refinement's arrays go before the next one's are made
        diag, bound = refined(bound)
        new = bound_of(diag)
        # the envelope came out higher than the bound assumed: pieces left alone
        # might matter; refine again with the new bound
        if np.all(new <= bound * (1.0 + 1e-9)):
            break
        bound = np.maximum(bound, new)
    else:
        _unconverged(om, ze, int(np.argmax(new / bound)), "the relevance bound did not settle")
    assert diag is not None
    nf = diag.depth.shape[-1] if diag.depth is not None else 0
    return dataclasses.replace(
        diag,
        a_lim=diag.a_lim.reshape(*batch, r.size),
        omega=np.asarray(diag.omega).reshape(*batch, nf),
        depth=None if diag.depth is None else diag.depth.reshape(*batch, 2, nf),
        eps=None if diag.eps is None else diag.eps.reshape(*batch, 2, nf),
        complete_above_rpm=None
        if diag.complete_above_rpm is None
        else np.asarray(diag.complete_above_rpm).reshape(batch),
    )
