"""Tool-point dynamics from modal parameters, and frequency grids that resolve them.

A :class:`ModalModel` is a set of real (proportionally damped) modes seen at
``d`` coordinates (2 for the feed frame x/y, 3 for the TCP frame x/y/z)::

    H(w) = sum_r A_r / (w_r^2 - w^2 + 2 i zeta_r w_r w)          [m/N]

with a residue matrix ``A_r`` (``d x d``, [1/kg]) per mode. A mode with
mass-normalised shape ``u`` has ``A_r = u u^T``; a driving-point modal
stiffness ``k_r`` in one direction (docs/guide/modal.md) is
``A_r[d, d] = w_r^2 / k_r``. Everything is batched: arrays carry a leading
batch shape ``(...)`` (waypoints, postures) before the mode axis.

:func:`frequency_grid` builds frequency grids that resolve lightly damped
modes anywhere from a few Hz (robot) to kHz (spindle/tool) without a
uniformly fine grid: a coarse logarithmic base grid plus a window of points
around every mode, dense at the peak (``sinh`` spacing).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from robolobe._directions import AXES
from robolobe._modal_parameters import ModalParameters
from robolobe.errors import InputError

__all__ = ["ModalModel", "frequency_grid"]

FloatArray = NDArray[np.float64]
ComplexArray = NDArray[np.complex128]

_TWO_PI = 2.0 * np.pi


@dataclass(frozen=True, eq=False)
class ModalModel:
    """Modal tool-point dynamics, batched.

    Parameters
    ----------
    omega : array_like, shape (..., n_modes)
        Natural frequencies [rad/s], > 0.
    zeta : array_like, shape (..., n_modes)
        Damping ratios, ``> 0``; ``>= 1`` is an overdamped mode (no resonance;
        its term ``A_r / (w_r^2 - w^2 + 2 i zeta_r w_r w)`` holds all the same).
    residues : array_like, shape (..., n_modes, d, d)
        Residue matrices ``A_r`` [1/kg]; an absent mode has ``A_r = 0``.

    Notes
    -----
    The three arrays broadcast to one batch shape (:attr:`batch_shape`).
    Use :meth:`from_parameters`, :meth:`from_directional`, :meth:`isotropic` or
    :meth:`from_shapes`
    rather than building residues by hand.
    """

    omega: FloatArray
    zeta: FloatArray
    residues: FloatArray

    def __post_init__(self) -> None:
        w = np.asarray(self.omega, dtype=np.float64)
        z = np.asarray(self.zeta, dtype=np.float64)
        a = np.asarray(self.residues, dtype=np.float64)
        if w.ndim < 1 or a.ndim < 3 or a.shape[-1] != a.shape[-2]:
            raise InputError(
                "ModalModel: expected omega (..., n_modes) and residues (..., n_modes, d, d), "
                f"found {w.shape} and {a.shape}"
            )
        try:
            batch = np.broadcast_shapes(w.shape[:-1], z.shape[:-1], a.shape[:-3])
            n = np.broadcast_shapes(w.shape[-1:], z.shape[-1:], a.shape[-3:-2])[0]
        except ValueError as exc:
            raise InputError(
                f"ModalModel: omega {w.shape}, zeta {z.shape} and residues {a.shape} "
                "do not broadcast"
            ) from exc
        d = a.shape[-1]
        w = np.broadcast_to(w, (*batch, n))
        z = np.broadcast_to(z, (*batch, n))
        a = np.broadcast_to(a, (*batch, n, d, d))
        if not (np.all(np.isfinite(w)) and np.all(w > 0.0)):
            raise InputError("ModalModel: omega: expected finite natural frequencies > 0 rad/s")
        if not (np.all(np.isfinite(z)) and np.all(z > 0.0)):
            raise InputError("ModalModel: zeta: expected finite damping ratios > 0")
        if not np.all(np.isfinite(a)):
            raise InputError("ModalModel: residues: expected finite values")
        for name, arr in (("omega", w), ("zeta", z), ("residues", a)):
            arr = np.array(arr)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # ------------------------------------------------------------ constructors
    @classmethod
    def from_directional(
        cls,
        f_hz: ArrayLike,
        zeta: ArrayLike,
        k_N_per_m: ArrayLike,
        directions: Sequence[str],
        *,
        dim: int = 2,
    ) -> ModalModel:
        """Modes given per direction with a modal stiffness (docs/guide/modal.md).

        Each mode ``r`` adds ``w_r^2 / k_r`` to the entry named by
        ``directions[r]`` (``"xx"``, ``"yy"``, ``"zz"``; a cross entry such as
        ``"xy"`` is added to both ``xy`` and ``yx``). A direction's modes are
        independent of the other direction's unless cross entries couple them.

        Parameters
        ----------
        f_hz, zeta, k_N_per_m : array_like, shape (..., n_modes)
            Natural frequency [Hz], damping ratio [-], modal stiffness [N/m]
            (signed for cross entries). NaN in any of them marks an absent
            mode (it contributes nothing).
        directions : sequence of str, length n_modes
            Entry of each mode.
        dim : int, default 2
            Number of coordinates (2: x, y; 3: x, y, z).

        Returns
        -------
        ModalModel
        """
        f = np.asarray(f_hz, dtype=np.float64)
        z = np.asarray(zeta, dtype=np.float64)
        k = np.asarray(k_N_per_m, dtype=np.float64)
        try:
            f, z, k = np.broadcast_arrays(f, z, k)
        except ValueError as exc:
            raise InputError(
                f"f_hz {f.shape}, zeta {z.shape} and k_N_per_m {k.shape} do not broadcast"
            ) from exc
        if f.ndim < 1 or f.shape[-1] != len(directions):
            raise InputError(
                f"directions: expected one per mode ({f.shape[-1] if f.ndim else 0}), "
                f"found {len(directions)}"
            )
        if dim not in (1, 2, 3):
            raise InputError(f"dim: expected 1, 2 or 3, found {dim!r}")
        idx = []
        for d in directions:
            if len(d) != 2 or d[0] not in AXES[:dim] or d[1] not in AXES[:dim]:
                raise InputError(
                    f"direction: expected two letters of {AXES[:dim]!r} (e.g. 'xx'), found {d!r}"
                )
            idx.append((AXES.index(d[0]), AXES.index(d[1])))
        absent = ~(np.isfinite(f) & np.isfinite(z) & np.isfinite(k))
        if np.any(~absent & ((f <= 0) | (z <= 0) | (z >= 1) | (k == 0))):
            raise InputError("modal parameters: expected f_hz > 0, 0 < zeta < 1 and k_N_per_m != 0")
        w = _TWO_PI * np.where(absent, 1.0, f)
        zz = np.where(absent, 0.05, z)
        res_val = np.where(absent, 0.0, w**2 / np.where(absent, 1.0, k))
        res = np.zeros((*f.shape, dim, dim))
        for r, (i, j) in enumerate(idx):
            res[..., r, i, j] += res_val[..., r]
            if i != j:
                res[..., r, j, i] += res_val[..., r]
        if np.any(absent):
            # park absent modes on a present one so that grids stay sensible
            wp = np.where(absent, np.nan, w)
            fill = np.nanmedian(wp, axis=-1, keepdims=True) if np.any(~absent) else w
            w = np.where(absent, np.where(np.isfinite(fill), fill, _TWO_PI), w)
        return cls(w, zz, res)

    @classmethod
    def from_parameters(cls, parameters: ModalParameters, *, dim: int = 3) -> ModalModel:
        """The model of modal parameters per posture and direction (batch: the postures).

        Every (direction, mode) of ``parameters`` becomes one mode of the
        model (:meth:`from_directional`, direction-major: all modes of the
        first direction, then the next), so a direction's modes are
        independent of another direction's. A mode that is absent (any
        parameter NaN), does not move that way (``inf`` stiffness) or has a
        driving-point stiffness <= 0 (a reversed polarity is no driving-point
        compliance) contributes nothing.

        Parameters
        ----------
        parameters : ModalParameters
            Shape (n_postures, n_directions, n_modes).
        dim : int, default 3
            Number of coordinates (3: x, y, z of the TCP frame; 2: x, y).

        Returns
        -------
        ModalModel
            Batch (n_postures,), ``n_directions * n_modes`` modes.
        """
        if not isinstance(parameters, ModalParameters):
            raise InputError(
                f"parameters: expected ModalParameters, found {type(parameters).__name__}"
            )
        f, z, k = parameters.f_hz, parameters.zeta, parameters.k_N_per_m
        n, nd, m = parameters.shape
        driving = np.array([d[0] == d[1] for d in parameters.directions])[None, :, None]
        ok = np.isfinite(f) & np.isfinite(z) & np.isfinite(k) & ((k > 0) | ~driving)
        ff = np.where(ok, f, np.nan).reshape(n, nd * m)
        zz = np.where(ok, z, np.nan).reshape(n, nd * m)
        kk = np.where(ok, k, np.nan).reshape(n, nd * m)
        dirs = [d for d in parameters.directions for _ in range(m)]
        return cls.from_directional(ff, zz, kk, dirs, dim=dim)

    @classmethod
    def isotropic(cls, f_hz: ArrayLike, zeta: ArrayLike, k_N_per_m: ArrayLike) -> ModalModel:
        """The same modes in x and y, uncoupled (2-D).

        Parameters
        ----------
        f_hz, zeta, k_N_per_m : array_like, shape (..., n_modes)
            Natural frequency [Hz], damping ratio [-], modal stiffness [N/m].
        """
        f = np.atleast_1d(np.asarray(f_hz, dtype=np.float64))
        z = np.atleast_1d(np.asarray(zeta, dtype=np.float64))
        k = np.atleast_1d(np.asarray(k_N_per_m, dtype=np.float64))
        f, z, k = np.broadcast_arrays(f, z, k)
        w = _TWO_PI * f
        res = (w**2 / k)[..., None, None] * np.eye(2)
        return cls(w, z, res)

    @classmethod
    def from_shapes(cls, omega: ArrayLike, zeta: ArrayLike, shapes: ArrayLike) -> ModalModel:
        """Modes from mass-normalised shapes ``u`` [1/sqrt(kg)], ``A_r = u u^T``.

        Parameters
        ----------
        omega, zeta : array_like, shape (..., n_modes)
            Natural frequency [rad/s] and damping ratio [-].
        shapes : array_like, shape (..., n_modes, d)
            Mass-normalised mode shapes at the ``d`` coordinates.
        """
        u = np.asarray(shapes, dtype=np.float64)
        if u.ndim < 2:
            raise InputError(f"shapes: expected shape (..., n_modes, d), found {u.shape}")
        return cls(
            np.asarray(omega, float), np.asarray(zeta, float), u[..., :, None] * u[..., None, :]
        )

    # ------------------------------------------------------------ properties
    @property
    def batch_shape(self) -> tuple[int, ...]:
        """Leading batch shape ``(...)``."""
        return tuple(self.omega.shape[:-1])

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.omega.shape[-1])

    @property
    def dim(self) -> int:
        """Number of coordinates ``d``."""
        return int(self.residues.shape[-1])

    @property
    def f_hz(self) -> FloatArray:
        """Natural frequencies [Hz], shape (..., n_modes)."""
        return self.omega / _TWO_PI

    # ------------------------------------------------------------ operations
    def frf(self, omega: ArrayLike) -> ComplexArray:
        """Receptance matrix at the given circular frequencies.

        Parameters
        ----------
        omega : array_like, shape (n_freq,) or (..., n_freq)
            Circular frequencies [rad/s]; a batched grid broadcasts against
            :attr:`batch_shape`.

        Returns
        -------
        ndarray, shape (..., n_freq, d, d), complex
            ``H(w)`` [m/N].
        """
        w = np.asarray(omega, dtype=np.float64)
        wr = self.omega[..., None, :]
        ww = w[..., :, None]
        re = wr**2 - ww**2  # (..., n_freq, n_modes)
        im = 2.0 * (self.zeta * self.omega)[..., None, :] * ww
        mag = re * re + im * im
        d = self.dim
        res = self.residues.reshape(*self.residues.shape[:-2], d * d)  # (..., n_modes, d*d)
        # two real matrix products instead of a complex einsum
        out = np.empty(
            np.broadcast_shapes((*re.shape[:-1], d * d), (*res.shape[:-2], 1, d * d)),
            dtype=np.complex128,
        )
        out.real = (re / mag) @ res
        out.imag = (-im / mag) @ res
        return out.reshape(*out.shape[:-1], d, d)

    def rotated(self, rotation: ArrayLike) -> ModalModel:
        """The model seen in other coordinates: ``A_r -> R^T A_r R``.

        Parameters
        ----------
        rotation : array_like, shape (..., d, d_out)
            Columns are the new axes expressed in the current coordinates
            (``q_new = R^T q``). ``d_out < d`` keeps only those axes.

        Returns
        -------
        ModalModel
            With ``dim == d_out``; batch shapes broadcast.
        """
        r = np.asarray(rotation, dtype=np.float64)
        if r.ndim < 2 or r.shape[-2] != self.dim:
            raise InputError(f"rotation: expected shape (..., {self.dim}, d_out), found {r.shape}")
        # sum_ij (R_ia A_mij) R_jb term by term, i outer, j inner: the products and the
        # order of np.einsum("...ia,...mij,...jb->...mab", R, A, R) (the same values,
        # tested), ~3x faster than its generic three-operand loop
        a = self.residues
        ra = r[..., None, :, :]  # (..., 1, d, d_out): a mode axis
        res: FloatArray | None = None
        for i in range(self.dim):
            for j in range(self.dim):
                # (R_ia A_mij) R_jb, shape (..., m, d_out, d_out)
                term = (ra[..., i, :, None] * a[..., :, i, j, None, None]) * ra[..., j, None, :]
                res = term if res is None else res + term
        assert res is not None
        return ModalModel(self.omega, self.zeta, res)

    def block(self, axes: Sequence[int]) -> ModalModel:
        """The sub-model on some coordinates (e.g. ``(0, 1)`` for x and y)."""
        ax = list(axes)
        return ModalModel(self.omega, self.zeta, self.residues[..., ax, :][..., :, ax])

    def concat(self, *others: ModalModel) -> ModalModel:
        """All modes of ``self`` and ``others`` (same ``d``; batch shapes broadcast)."""
        models = (self, *others)
        if len({m.dim for m in models}) != 1:
            raise InputError(
                f"concat: expected models of one dimension, found {[m.dim for m in models]}"
            )
        batch = np.broadcast_shapes(*(m.batch_shape for m in models))
        w = np.concatenate([np.broadcast_to(m.omega, (*batch, m.n_modes)) for m in models], axis=-1)
        z = np.concatenate([np.broadcast_to(m.zeta, (*batch, m.n_modes)) for m in models], axis=-1)
        a = np.concatenate(
            [np.broadcast_to(m.residues, (*batch, m.n_modes, m.dim, m.dim)) for m in models],
            axis=-3,
        )
        return ModalModel(w, z, a)

    def take(self, index: int | slice | ArrayLike) -> ModalModel:
        """Select along the (flattened first) batch axis."""
        if not self.batch_shape:
            raise InputError("take: the model has no batch axis")
        idx = np.asarray(index) if not isinstance(index, slice | int) else index
        return ModalModel(self.omega[idx], self.zeta[idx], self.residues[idx])

    def frequency_grid(self, **kwargs: object) -> FloatArray:
        """:func:`frequency_grid` for this model's modes (absent modes ignored)."""
        present = np.any(self.residues != 0.0, axis=(-1, -2))
        return frequency_grid(self.omega, self.zeta, present=present, **kwargs)  # type: ignore[arg-type]


def _mode_window(points: int, half_width: float) -> FloatArray:
    """Offsets ``s`` in units of ``zeta w_r`` in ``[-hw, hw]``, uniform in ``atan(s)``.

    The phase of a mode goes as ``atan(s)``, so this samples the phase (which
    sets the lobe speeds) uniformly: ``pi / (points - 1)`` rad apart.
    """
    u = np.linspace(-np.arctan(half_width), np.arctan(half_width), points)
    return np.tan(u)


def frequency_grid(
    omega_modes: ArrayLike,
    zeta_modes: ArrayLike,
    *,
    omega_min: float | None = None,
    omega_max: float | None = None,
    points_per_decade: int = 40,
    points_per_mode: int = 33,
    half_width: float = 25.0,
    shared: bool = True,
    present: ArrayLike | None = None,
) -> FloatArray:
    """A frequency grid that resolves every mode.

    A logarithmic base grid over ``[omega_min, omega_max]`` plus, for each
    mode ``(w_r, zeta_r)``, ``points_per_mode`` points
    ``w_r exp(zeta_r s)`` with ``s`` in ``[-half_width, half_width]`` spaced
    uniformly in ``atan(s)``, i.e. in the mode's phase (``pi / points``
    rad apart; at the peak about ``points / pi`` points per ``zeta_r w_r``,
    the half-power bandwidth being ``2 zeta_r w_r``). The window is capped
    at a factor of 2 each way for heavily damped modes.

    Parameters
    ----------
    omega_modes, zeta_modes : array_like, shape (..., n_modes)
        Natural frequencies [rad/s] and damping ratios of the modes.
    omega_min, omega_max : float, optional
        Range [rad/s]; default half the lowest and twice the highest mode.
    points_per_decade : int, default 40
        Density of the base grid.
    points_per_mode : int, default 33
        Points in each mode's window.
    half_width : float, default 25
        Window half width in units of ``zeta_r w_r``.
    shared : bool, default True
        True: one sorted grid for all batch entries (the union, duplicates
        removed), shape ``(n_freq,)``. False: one grid per batch entry, all of
        the same length, shape ``(..., n_freq)`` (may hold repeated values).
    present : array_like of bool, shape (..., n_modes), optional
        Modes to resolve (absent modes get no window; with ``shared=False``
        their points are spread over the base range instead).

    Returns
    -------
    ndarray
        Sorted circular frequencies [rad/s].
    """
    w = np.asarray(omega_modes, dtype=np.float64)
    z = np.broadcast_to(np.asarray(zeta_modes, dtype=np.float64), w.shape)
    pres = (
        np.ones(w.shape, bool)
        if present is None
        else np.broadcast_to(np.asarray(present, bool), w.shape)
    )
    if w.ndim == 0:
        w, z, pres = w[None], z[None], pres[None]
    if not np.any(pres):
        raise InputError("frequency_grid: no mode to resolve")
    wp = w[pres]
    lo = 0.5 * float(wp.min()) if omega_min is None else float(omega_min)
    hi = 2.0 * float(wp.max()) if omega_max is None else float(omega_max)
    if not (0.0 < lo < hi and np.isfinite(hi)):
        raise InputError(f"frequency_grid: expected 0 < omega_min < omega_max, found {lo}, {hi}")
    n_base = max(int(np.ceil(points_per_decade * np.log10(hi / lo))) + 1, 2)
    base = np.geomspace(lo, hi, n_base)
    s = _mode_window(points_per_mode, half_width)
    width = np.minimum(z * half_width, np.log(2.0)) / half_width  # per-mode scale of s
    win = w[..., None] * np.exp(width[..., None] * s)  # (..., n_modes, P)
    if shared:
        pts = np.concatenate([base, win[pres].ravel()])
        pts = pts[(pts >= lo) & (pts <= hi)]
        pts = np.unique(pts)
        keep = np.concatenate([[True], np.diff(pts) > 1e-12 * pts[1:]])
        return np.asarray(pts[keep])
    filler = np.geomspace(lo, hi, points_per_mode + 2)[1:-1]
    win = np.where(pres[..., None], win, filler)
    win = np.clip(win, lo, hi)
    batch = w.shape[:-1]
    flat = win.reshape(*batch, -1)
    grid = np.concatenate([np.broadcast_to(base, (*batch, n_base)), flat], axis=-1)
    return np.sort(grid, axis=-1)
